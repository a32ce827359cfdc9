//! Phong meshes through Embree: watertightness, parity with triangles at alpha = 0,
//! agreement with the pure-Rust intersector, shading helpers.
mod common;

use glam::Vec3;
use phongrt::embree::{CommittedScene, Device, GeometryOptions, PhongMesh, Ray, Scene};
use phongrt::phong::accuracy::SplitMix;
use phongrt::scene::{uv_sphere, Mesh};

fn phong_scene(device: &Device, mesh: &Mesh, alpha: f32, straight_creases: bool) -> CommittedScene {
    let straight = mesh.straight_edges();
    let pm = PhongMesh::with_straight_edges(
        &mesh.positions,
        &mesh.normals,
        &mesh.indices,
        alpha,
        straight_creases.then_some(&straight[..]),
    )
    .unwrap();
    let mut s = Scene::new(device).unwrap();
    s.attach_phong(pm, GeometryOptions::default()).unwrap();
    s.commit().unwrap()
}

fn random_dirs(n: usize, seed: u64) -> Vec<Vec3> {
    let mut r = SplitMix(seed);
    (0..n).map(|_| r.unit().as_vec3()).collect()
}

/// Rays from points inside a closed mesh must all hit it.
fn count_escapes(scene: &CommittedScene, origins: &[Vec3], n: usize, seed: u64) -> usize {
    let dirs = random_dirs(n, seed);
    dirs.iter()
        .enumerate()
        .filter(|(i, d)| scene.intersect1(Ray::new(origins[i % origins.len()], **d)).is_none())
        .count()
}

#[test]
fn phong_sphere_is_watertight_from_inside() {
    let device = Device::new().unwrap();
    for (seg, rings) in [(12, 6), (7, 4), (32, 16)] {
        let mesh = uv_sphere(seg, rings, 1.0);
        let scene = phong_scene(&device, &mesh, 1.0, true);
        let origins = [Vec3::ZERO, Vec3::new(0.3, -0.2, 0.1), Vec3::new(-0.5, 0.4, 0.2)];
        let escapes = count_escapes(&scene, &origins, 200_000, seg as u64);
        assert_eq!(escapes, 0, "{seg}x{rings} sphere: {escapes} of 200000 rays escaped");
    }
}

#[test]
fn alpha_zero_matches_embree_triangles() {
    let device = Device::new().unwrap();
    let mesh = uv_sphere(24, 12, 1.0);
    let phong = phong_scene(&device, &mesh, 0.0, false);
    let mut tri = Scene::new(&device).unwrap();
    tri.attach_triangles(&mesh.positions, &mesh.indices, GeometryOptions::default()).unwrap();
    let tri = tri.commit().unwrap();
    let mut rng = SplitMix(7);
    let (mut n, mut mismatch) = (0, 0);
    for _ in 0..200_000 {
        let o = (rng.unit() * 3.0).as_vec3();
        let target = (rng.unit() * 0.9).as_vec3();
        let r = Ray::new(o, target - o);
        let (a, b) = (tri.intersect1(r), phong.intersect1(r));
        match (a, b) {
            (Some(a), Some(b)) => {
                n += 1;
                assert!((a.t - b.t).abs() <= 1e-5 * a.t, "t {} vs {}", a.t, b.t);
                if a.prim_id != b.prim_id {
                    // Only on an edge: both barycentric sets must be on the boundary.
                    let edge = |u: f32, v: f32| u.min(v).min(1.0 - u - v) < 1e-4;
                    assert!(edge(a.u, a.v) && edge(b.u, b.v), "prim {} vs {}", a.prim_id, b.prim_id);
                }
            }
            (None, None) => {}
            _ => mismatch += 1,
        }
    }
    assert!(n > 100_000);
    assert_eq!(mismatch, 0, "{mismatch} hit/miss disagreements");
}

fn load_scene_mesh(rel: &str) -> Mesh {
    let p = common::root().join(rel);
    let s = phongrt::scene::load_obj(&p, &phongrt::scene::LoadOptions::default()).unwrap();
    s.meshes.into_iter().next().unwrap()
}

#[test]
fn alpha_zero_matches_embree_triangles_on_a_real_mesh_for_a_million_rays() {
    let device = Device::new().unwrap();
    let mesh = load_scene_mesh("scenes/wuson/WusonOBJ.obj");
    let phong = phong_scene(&device, &mesh, 0.0, false);
    let mut tri = Scene::new(&device).unwrap();
    tri.attach_triangles(&mesh.positions, &mesh.indices, GeometryOptions::default()).unwrap();
    let tri = tri.commit().unwrap();
    let (lo, hi) = mesh
        .positions
        .iter()
        .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| (a.min(*p), b.max(*p)));
    let (c, r) = ((lo + hi) * 0.5, (hi - lo).length());
    let mut rng = SplitMix(21);
    let (mut hits, mut disagree, mut near_edge) = (0, 0, 0);
    for _ in 0..1_000_000 {
        let o = c + (rng.unit() * r as f64).as_vec3();
        let target = c + (rng.unit() * 0.4 * r as f64).as_vec3();
        let ray = Ray::new(o, target - o);
        match (tri.intersect1(ray), phong.intersect1(ray)) {
            (Some(a), Some(b)) => {
                hits += 1;
                let cos = ray.dir.normalize().dot(a.ng.normalize()).abs();
                // t within 1e-5 relative; for grazing hits (cos < 0.1) the t error grows as 1/cos,
                // so there: the two hit points within 1e-6 of the model size along the normal.
                let ok = if cos >= 0.1 {
                    (a.t - b.t).abs() <= 1e-5 * a.t
                } else {
                    (a.t - b.t).abs() * ray.dir.length() * cos <= 1e-6 * r
                };
                assert!(
                    ok || a.prim_id != b.prim_id,
                    "t {} vs {} prims {} {} cos {cos}",
                    a.t,
                    b.t,
                    a.prim_id,
                    b.prim_id
                );
                if a.prim_id != b.prim_id {
                    let edge = |u: f32, v: f32| u.min(v).min(1.0 - u - v) < 1e-4;
                    assert!(
                        edge(a.u, a.v) && edge(b.u, b.v),
                        "prim {} vs {} away from an edge",
                        a.prim_id,
                        b.prim_id
                    );
                    near_edge += 1;
                }
            }
            (None, None) => {}
            (a, b) => {
                // Allowed only within an epsilon of an edge (the two tests round differently there).
                let h = a.or(b).unwrap();
                assert!(
                    h.u.min(h.v).min(1.0 - h.u - h.v) < 1e-4,
                    "hit/miss disagreement away from edges: {a:?} {b:?}"
                );
                disagree += 1;
            }
        }
    }
    println!("wuson alpha=0: {hits} hits, {near_edge} different prims on edges, {disagree} edge hit/miss disagreements");
    assert!(hits > 150_000, "{hits}");
    assert!(disagree < 100, "{disagree}");
}

#[test]
fn embree_path_matches_the_pure_rust_intersector() {
    use phongrt::phong::{intersect, V3};
    let device = Device::new().unwrap();
    let mesh = uv_sphere(12, 6, 1.0);
    let scene = phong_scene(&device, &mesh, 1.0, true);
    let pm =
        PhongMesh::with_straight_edges(&mesh.positions, &mesh.normals, &mesh.indices, 1.0, None).unwrap();
    let mut rng = SplitMix(33);
    let mut hits = 0;
    for _ in 0..20_000 {
        let o = (rng.unit() * 3.0).as_vec3();
        let d = ((rng.unit() * 0.8).as_vec3() - o).normalize();
        let brute = pm
            .patches()
            .iter()
            .enumerate()
            .filter_map(|(i, p)| {
                intersect(p, V3::from(o), V3::from(d), 0.0, f32::INFINITY, pm.method()).map(|h| (i as u32, h))
            })
            .min_by(|a, b| a.1.t.partial_cmp(&b.1.t).unwrap());
        let e = scene.intersect1(Ray::new(o, d));
        assert_eq!(brute.is_some(), e.is_some());
        if let (Some((prim, h)), Some(e)) = (brute, e) {
            hits += 1;
            assert_eq!(prim, e.prim_id);
            assert_eq!(h.t, e.t);
            assert_eq!((h.u, h.v), (e.u, e.v));
        }
    }
    assert!(hits > 10_000);
}

#[test]
fn phong_mesh_attaches_to_a_raw_scene_made_by_the_callers_own_embree_code() {
    use phongrt::embree::attach_phong_raw;
    use phongrt::sys;
    let device = Device::new().unwrap();
    let mesh = uv_sphere(12, 6, 1.0);
    let pm = PhongMesh::new(&mesh.positions, &mesh.normals, &mesh.indices, 1.0).unwrap();
    // The caller's own scene, created through the raw API on our device.
    let helper = Scene::new(&device).unwrap(); // only to reach the raw device handle
                                               // SAFETY (test): the device is live while `helper` is; the raw scene is released below,
                                               // before the handle returned by attach_phong_raw is dropped.
    unsafe {
        let raw_device = sys::rtcGetSceneDevice(helper.raw());
        let raw = sys::rtcNewScene(raw_device);
        let handle = attach_phong_raw(raw, pm, GeometryOptions::default()).unwrap();
        sys::rtcCommitScene(raw);
        let mut rh = phongrt::embree::scene::new_rayhit(Ray::new(Vec3::new(0.0, 3.0, 0.0), -Vec3::Y));
        sys::rtcIntersect1(raw, &mut rh, std::ptr::null_mut());
        assert_eq!(rh.hit.geomID, handle.geom_id());
        assert!((rh.ray.tfar - 2.0).abs() < 1e-5, "t = {}", rh.ray.tfar);
        let n = handle.mesh().shading_normal(rh.hit.primID, rh.hit.u, rh.hit.v, -Vec3::Y).unwrap();
        assert!(n.dot(Vec3::Y) > 0.999);
        sys::rtcReleaseScene(raw);
        sys::rtcReleaseDevice(raw_device);
        drop(handle);
    }
}

#[test]
fn attach_phong_shares_the_mesh_with_the_caller_without_a_copy() {
    use std::sync::Arc;
    let device = Device::new().unwrap();
    let m = uv_sphere(12, 6, 1.0);
    let mesh = Arc::new(PhongMesh::new(&m.positions, &m.normals, &m.indices, 1.0).unwrap());
    let mut s = Scene::new(&device).unwrap();
    s.attach_phong(mesh.clone(), GeometryOptions::default()).unwrap();
    let s = s.commit().unwrap();
    // The scene holds the caller's mesh itself: one more reference, no second copy.
    assert_eq!(Arc::strong_count(&mesh), 2);
    let h = s.intersect1(Ray::new(Vec3::new(0.0, 3.0, 0.0), -Vec3::Y)).unwrap();
    let n = mesh.shading_normal(h.prim_id, h.u, h.v, -Vec3::Y).unwrap();
    assert!(n.dot(Vec3::Y) > 0.999, "{n}");
    drop(s);
    assert_eq!(Arc::strong_count(&mesh), 1, "the scene released its reference");
}

#[test]
fn the_renderers_phong_objects_share_their_mesh_with_the_scene() {
    use phongrt_render::{ObjectMode, ObjectSettings, World};
    let device = Device::new().unwrap();
    let scene = phongrt::scene::Model::from_mesh(uv_sphere(12, 6, 1.0));
    let world = World::from_scene(&device, &scene, |_, _| ObjectSettings {
        mode: ObjectMode::Phong { alpha: 1.0 },
        straight_creases: true,
    })
    .unwrap();
    let pm = world.objects()[0].geometry.phong().expect("a Phong object keeps its mesh");
    assert_eq!(std::sync::Arc::strong_count(pm), 2, "object and Embree geometry share one mesh");
}
