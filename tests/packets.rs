//! 8-ray packets through the safe API (`Scene::intersect8_rays` / `occluded8_rays`): every
//! lane answers exactly as the single-ray query on its ray, for Embree's own triangles and for
//! Phong user geometry, coherent or not, whatever the mask; callback panics are resumed.
mod common;
use std::panic::{catch_unwind, AssertUnwindSafe};

use glam::Vec3;
use std::sync::Arc;

use phongrt::embree::{
    CommittedScene, Device, GeometryOptions, LaneOrigins, OriginPrim, PhongMesh, PrimHit, Ray, Scene,
    UserPrimitives, PACKET8,
};
use phongrt::phong::accuracy::SplitMix;
use phongrt::phong::intersect::{LaneRays, LANES};
use phongrt::scene::uv_sphere;

/// Partial and full masks, including single lanes at both ends and none at all.
const MASKS: [u8; 7] = [0xFF, 0x0F, 0xF0, 0xA5, 0x01, 0x80, 0x00];

/// Camera rays in 4x2 pixel blocks over a `w x h` image looking down -z at the origin (the
/// renderer's blocks), then random rays through the unit ball (incoherent packets).
fn packets(w: u32, h: u32, random: usize) -> Vec<[Ray; PACKET8]> {
    let eye = Vec3::new(0.1, 0.2, 3.0);
    let mut out = Vec::new();
    for by in (0..h).step_by(2) {
        for bx in (0..w).step_by(4) {
            out.push(std::array::from_fn(|k| {
                let (x, y) = (bx + k as u32 % 4, by + k as u32 / 4);
                let s = Vec3::new((x as f32 + 0.5) / w as f32 - 0.5, 0.5 - (y as f32 + 0.5) / h as f32, -1.0);
                Ray::new(eye, s * Vec3::new(2.6, 2.6, 1.0))
            }));
        }
    }
    let mut r = SplitMix(7);
    for _ in 0..random {
        out.push(std::array::from_fn(|_| {
            let o = r.unit().as_vec3() * 3.0;
            let target = r.unit().as_vec3() * 0.9;
            Ray::new(o, target - o).with_range(0.0, 0.5 + r.f() as f32)
        }));
    }
    out
}

/// Check every lane of every packet, under every mask, coherent and not, against the single
/// ray queries; returns how many active lanes hit.
fn check_lanes_match_single_rays(scene: &CommittedScene) -> usize {
    let mut hits = 0;
    for rays in packets(64, 48, 400) {
        let single: Vec<_> = rays.iter().map(|r| scene.intersect1(*r)).collect();
        let blocked: Vec<_> = rays.iter().map(|r| scene.occluded1(*r)).collect();
        for mask in MASKS {
            for coherent in [true, false] {
                let got = scene.intersect8_rays(&rays, mask, coherent);
                let occ = scene.occluded8_rays(&rays, mask, coherent);
                for k in 0..PACKET8 {
                    if mask & (1 << k) == 0 {
                        assert_eq!(got[k], None, "inactive lane {k} answered (mask {mask:#04x})");
                        assert_eq!(occ & (1 << k), 0, "inactive lane {k} occluded (mask {mask:#04x})");
                        continue;
                    }
                    assert_eq!(
                        got[k], single[k],
                        "lane {k}, mask {mask:#04x}, coherent {coherent}: {:?}",
                        rays[k]
                    );
                    assert_eq!(occ & (1 << k) != 0, blocked[k], "lane {k}, mask {mask:#04x}: {:?}", rays[k]);
                    hits += got[k].is_some() as usize;
                }
            }
        }
    }
    hits
}

#[test]
fn packet_lanes_equal_single_rays_on_flat_triangles() {
    let device = Device::new().unwrap();
    let m = uv_sphere(24, 12, 1.0);
    let mut scene = Scene::new(&device).unwrap();
    scene.attach_triangles(&m.positions, &m.indices, GeometryOptions::default()).unwrap();
    let scene = scene.commit().unwrap();
    assert!(check_lanes_match_single_rays(&scene) > 10_000);
}

#[test]
fn packet_lanes_equal_single_rays_on_a_phong_mesh() {
    let device = Device::new().unwrap();
    let m = uv_sphere(12, 6, 1.0);
    let pm = PhongMesh::new(&m.positions, &m.normals, &m.indices, 0.75).unwrap();
    let mut scene = Scene::new(&device).unwrap();
    scene.attach_phong(pm, GeometryOptions::default()).unwrap();
    // A flat floor beside it, so packets mix user geometry and Embree's triangles.
    let floor = [Vec3::new(-3.0, -1.0, -3.0), Vec3::new(3.0, -1.0, -3.0), Vec3::new(0.0, -1.0, 3.0)];
    scene.attach_triangles(&floor, &[[0, 2, 1]], GeometryOptions::default()).unwrap();
    let scene = scene.commit().unwrap();
    assert!(check_lanes_match_single_rays(&scene) > 10_000);
}

#[test]
fn packet_queries_answer_only_the_active_lanes() {
    // (An uncommitted scene has no queries at all: `Scene` only builds.)
    let device = Device::new().unwrap();
    let m = uv_sphere(12, 6, 1.0);
    let mut scene = Scene::new(&device).unwrap();
    scene.attach_triangles(&m.positions, &m.indices, GeometryOptions::default()).unwrap();
    let scene = scene.commit().unwrap();
    let rays = [Ray::new(Vec3::new(0.0, 0.0, 3.0), -Vec3::Z); PACKET8];
    assert_eq!(scene.intersect8_rays(&rays, 0, true), [None; PACKET8]);
    assert_eq!(scene.occluded8_rays(&rays, 0, true), 0);
    let some: Vec<bool> = scene.intersect8_rays(&rays, 0x0F, true).iter().map(Option::is_some).collect();
    assert_eq!(some, [true, true, true, true, false, false, false, false]);
    assert_eq!(scene.occluded8_rays(&rays, 0x0F, true), 0x0F);
    assert!(scene.intersect8_rays(&rays, 0xFF, true).iter().all(Option::is_some));
    assert_eq!(scene.occluded8_rays(&rays, 0xFF, true), 0xFF);
}

/// A Phong mesh with only the one-ray tests: its packets go through the trait's default
/// `intersect_packet8` and `intersect_packet`, lane by lane.
struct OneByOne(Arc<PhongMesh>);

impl UserPrimitives for OneByOne {
    fn count(&self) -> u32 {
        self.0.count()
    }
    fn bounds(&self, prim: u32) -> Option<(Vec3, Vec3)> {
        self.0.bounds(prim)
    }
    fn intersect(&self, prim: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit> {
        self.0.intersect(prim, org, dir, tnear, tfar)
    }
    fn intersect_from(
        &self,
        prim: u32,
        origin: Option<OriginPrim>,
        org: Vec3,
        dir: Vec3,
        tnear: f32,
        tfar: f32,
    ) -> Option<PrimHit> {
        self.0.intersect_from(prim, origin, org, dir, tnear, tfar)
    }
}

#[test]
fn packet_lanes_equal_single_rays_through_the_default_8_lane_test() {
    let device = Device::new().unwrap();
    let m = uv_sphere(12, 6, 1.0);
    let pm = PhongMesh::new(&m.positions, &m.normals, &m.indices, 0.75).unwrap();
    let mut scene = Scene::new(&device).unwrap();
    scene.attach_user(OneByOne(Arc::new(pm)), GeometryOptions::default()).unwrap();
    let scene = scene.commit().unwrap();
    assert!(check_lanes_match_single_rays(&scene) > 10_000);
}

#[test]
#[allow(clippy::needless_range_loop)] // lane loops index several arrays by the lane
fn the_default_8_lane_test_answers_as_the_phong_mesh_lanes() {
    let m = uv_sphere(12, 6, 1.0);
    let mesh = Arc::new(PhongMesh::new(&m.positions, &m.normals, &m.indices, 0.75).unwrap());
    let one = OneByOne(mesh.clone());
    let mut r = SplitMix(11);
    let (mut hits, mut settled) = (0, 0);
    for _ in 0..4000 {
        let prim = (r.f() * mesh.patches().len() as f64) as u32;
        // Rays from outside towards the patch's corner region, some starting on the patch itself.
        let mut rays = LaneRays {
            org: [[0.0; LANES]; 3],
            dir: [[0.0; LANES]; 3],
            tmin: [0.0; LANES],
            tmax: [0.0; LANES],
        };
        let mut origin = [None; LANES];
        let active: [bool; LANES] = std::array::from_fn(|_| r.f() < 0.8);
        let corner = m.positions[m.indices[prim as usize][0] as usize];
        for i in 0..LANES {
            let (u, v) = (r.f() as f32 * 0.5, r.f() as f32 * 0.5);
            let (o, d) = if r.f() < 0.4 {
                // Leaving the patch at (u, v), towards anywhere.
                origin[i] = Some(OriginPrim { prim, u, v });
                (mesh.surface_point(prim, u, v).unwrap().0, r.unit().as_vec3())
            } else {
                let o = r.unit().as_vec3() * 3.0;
                (o, corner + r.unit().as_vec3() * 0.2 - o)
            };
            for k in 0..3 {
                (rays.org[k][i], rays.dir[k][i]) = (o[k], d[k]);
            }
            (rays.tmin[i], rays.tmax[i]) = (1e-4, 10.0);
        }
        let origins = LaneOrigins::given(origin);
        let want = mesh.intersect_packet8(prim, &rays, active, &origins);
        let got = one.intersect_packet8(prim, &rays, active, &origins);
        assert_eq!(got, want, "patch {prim}");
        for i in 0..LANES {
            if !active[i] {
                assert_eq!(got[i], None, "inactive lane {i} answered");
            }
            hits += got[i].is_some() as usize;
            settled += (active[i] && origin[i].is_some() && got[i].is_none()) as usize;
        }
    }
    assert!(hits > 1000 && settled > 1000, "{hits} hits, {settled} lanes from the patch unhit");
}

/// The unit triangle in z = 0, whose intersect callback panics.
struct Exploding;

impl UserPrimitives for Exploding {
    fn count(&self) -> u32 {
        1
    }
    fn bounds(&self, _prim: u32) -> Option<(Vec3, Vec3)> {
        Some((Vec3::new(0.0, 0.0, -0.01), Vec3::new(1.0, 1.0, 0.01)))
    }
    fn intersect(&self, _prim: u32, _org: Vec3, _dir: Vec3, _tnear: f32, _tfar: f32) -> Option<PrimHit> {
        panic!("packet lane exploded");
    }
}

#[test]
fn a_panic_in_a_callback_during_a_packet_query_is_resumed_in_the_caller() {
    let device = Device::new().unwrap();
    let mut scene = Scene::new(&device).unwrap();
    scene.attach_user(Exploding, GeometryOptions::default()).unwrap();
    let scene = scene.commit().unwrap();
    let rays = [Ray::new(Vec3::new(0.2, 0.3, 1.0), -Vec3::Z); PACKET8];
    for coherent in [true, false] {
        let e = catch_unwind(AssertUnwindSafe(|| scene.intersect8_rays(&rays, 0x24, coherent)))
            .expect_err("intersect8_rays swallowed the panic");
        assert_eq!(common::panic_message(e), "packet lane exploded");
        let e = catch_unwind(AssertUnwindSafe(|| scene.occluded8_rays(&rays, 0x81, coherent)))
            .expect_err("occluded8_rays swallowed the panic");
        assert_eq!(common::panic_message(e), "packet lane exploded");
    }
    // Nothing is left pending on the thread, and nothing was recorded for commit to report.
    let mut good = Scene::new(&device).unwrap();
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    good.attach_triangles(&tri, &[[0, 1, 2]], GeometryOptions::default()).unwrap();
    let good = good.commit().unwrap();
    assert_eq!(good.occluded8_rays(&rays, 0xFF, true), 0xFF);
    scene.edit().expect("nothing instances it").commit().unwrap();
}
