//! Phong meshes through Embree: watertightness, parity with triangles at alpha = 0,
//! agreement with the pure-Rust intersector, shading helpers.
use glam::Vec3;
use phongrt::embree::{Device, GeometryOptions, PhongMesh, Ray, Scene, UserGeometryOptions};
use phongrt::phong::accuracy::SplitMix;
use phongrt::scene::{uv_sphere, EdgeKind, Mesh};

fn phong_scene(device: &Device, mesh: &Mesh, alpha: f32, straight_creases: bool) -> Scene {
    let straight: Vec<[bool; 3]> = mesh.edge_kinds.iter().map(|k| k.map(|e| e != EdgeKind::Smooth)).collect();
    let pm = PhongMesh::with_straight_edges(
        &mesh.positions,
        &mesh.normals,
        &mesh.indices,
        alpha,
        straight_creases.then_some(&straight[..]),
    )
    .unwrap();
    let mut s = Scene::new(device).unwrap();
    s.attach_phong(pm, UserGeometryOptions::default()).unwrap();
    s.commit().unwrap();
    s
}

fn random_dirs(n: usize, seed: u64) -> Vec<Vec3> {
    let mut r = SplitMix(seed);
    (0..n).map(|_| r.unit().as_vec3()).collect()
}

/// Rays from points inside a closed mesh must all hit it.
fn count_escapes(scene: &Scene, origins: &[Vec3], n: usize, seed: u64) -> usize {
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
    tri.commit().unwrap();
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
