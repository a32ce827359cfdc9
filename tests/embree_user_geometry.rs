//! The user-geometry plumbing (callbacks, packets, filters, masks, instances), checked with
//! flat triangles as user geometry against Embree's native triangles on the same rays.
mod common;
use glam::{Mat4, Vec3};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;

use phongrt::embree::{
    new_rayhit, Blocker, CommittedScene, Device, EmbreeError, GeometryOptions, IntersectArgs, OccludedArgs,
    OriginPrim, PrimHit, QueryContext, Ray, RayOrigin, Scene, UserPrimitives, UserTriangles, PACKET8,
};
use phongrt::sys;

/// A small closed mesh: an octahedron around the origin.
fn octahedron() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let p = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let i = vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    (p, i)
}

/// A deterministic stream of rays aimed near the origin.
fn rays(n: usize) -> Vec<Ray> {
    let mut s = 0x1234_5678_9abc_def0u64;
    let mut r = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    };
    (0..n)
        .map(|_| {
            let o = Vec3::new(r(), r(), r()).normalize_or(Vec3::X) * 3.0;
            let target = Vec3::new(r(), r(), r()) * 0.8;
            Ray::new(o, target - o)
        })
        .collect()
}

fn scenes(device: &Device) -> (CommittedScene, CommittedScene) {
    let (p, i) = octahedron();
    let mut native = Scene::new(device).unwrap();
    native.attach_triangles(&p, &i, GeometryOptions::default()).unwrap();
    let native = native.commit().unwrap();
    let mut user = Scene::new(device).unwrap();
    user.attach_user(UserTriangles { positions: p, indices: i }, GeometryOptions::default()).unwrap();
    let user = user.commit().unwrap();
    (native, user)
}

#[test]
fn user_triangles_match_native_triangles() {
    let device = Device::new().unwrap();
    let (native, user) = scenes(&device);
    let mut hits = 0;
    for r in rays(20_000) {
        let a = native.intersect1(r);
        let b = user.intersect1(r);
        assert_eq!(a.is_some(), b.is_some(), "{r:?}");
        if let (Some(a), Some(b)) = (a, b) {
            hits += 1;
            assert_eq!(a.prim_id, b.prim_id);
            assert!((a.t - b.t).abs() <= 1e-5 * a.t, "{} vs {}", a.t, b.t);
            assert!((a.u - b.u).abs() < 1e-4 && (a.v - b.v).abs() < 1e-4);
            assert!(a.ng.normalize().dot(b.ng.normalize()) > 0.9999);
        }
        assert_eq!(native.occluded1(r), user.occluded1(r));
    }
    assert!(hits > 10_000, "too few hits: {hits}");
}

fn packet_check<const N: usize>(native: &CommittedScene, user: &CommittedScene) {
    for chunk in rays(64 * N).chunks(N) {
        // Leave the last lane invalid to check the valid mask is honoured.
        let mut valid = [-1i32; N];
        valid[N - 1] = 0;
        macro_rules! fill {
            ($rh:expr) => {
                for (k, r) in chunk.iter().enumerate() {
                    $rh.ray.org_x[k] = r.org.x;
                    $rh.ray.org_y[k] = r.org.y;
                    $rh.ray.org_z[k] = r.org.z;
                    $rh.ray.dir_x[k] = r.dir.x;
                    $rh.ray.dir_y[k] = r.dir.y;
                    $rh.ray.dir_z[k] = r.dir.z;
                    $rh.ray.tnear[k] = 0.0;
                    $rh.ray.tfar[k] = f32::INFINITY;
                    $rh.ray.mask[k] = u32::MAX;
                    $rh.hit.geomID[k] = u32::MAX;
                }
            };
        }
        match N {
            4 => {
                let mut rh = sys::RTCRayHit4::default();
                fill!(rh);
                let v: &[i32; 4] = valid[..].try_into().unwrap();
                user.intersect4(v, &mut rh, None);
                for (k, r) in chunk.iter().enumerate() {
                    let single = native.intersect1(*r);
                    if k == N - 1 {
                        assert_eq!(rh.hit.geomID[k], u32::MAX, "invalid lane traced");
                    } else {
                        assert_eq!(
                            single.map(|h| h.prim_id),
                            (rh.hit.geomID[k] != u32::MAX).then_some(rh.hit.primID[k])
                        );
                    }
                }
                let mut ray = rh.ray;
                for k in 0..N {
                    ray.tfar[k] = f32::INFINITY;
                }
                user.occluded4(v, &mut ray, None);
                for (k, r) in chunk.iter().enumerate().take(N - 1) {
                    assert_eq!(native.occluded1(*r), ray.tfar[k] == f32::NEG_INFINITY);
                }
            }
            8 => {
                let mut rh = sys::RTCRayHit8::default();
                fill!(rh);
                let v: &[i32; 8] = valid[..].try_into().unwrap();
                user.intersect8(v, &mut rh, None);
                for (k, r) in chunk.iter().enumerate().take(N - 1) {
                    let single = native.intersect1(*r);
                    assert_eq!(
                        single.map(|h| h.prim_id),
                        (rh.hit.geomID[k] != u32::MAX).then_some(rh.hit.primID[k])
                    );
                }
                let mut ray = rh.ray;
                for k in 0..N {
                    ray.tfar[k] = f32::INFINITY;
                }
                user.occluded8(v, &mut ray, None);
                for (k, r) in chunk.iter().enumerate().take(N - 1) {
                    assert_eq!(native.occluded1(*r), ray.tfar[k] == f32::NEG_INFINITY);
                }
            }
            16 => {
                let mut rh = sys::RTCRayHit16::default();
                fill!(rh);
                let v: &[i32; 16] = valid[..].try_into().unwrap();
                user.intersect16(v, &mut rh, None);
                for (k, r) in chunk.iter().enumerate().take(N - 1) {
                    let single = native.intersect1(*r);
                    assert_eq!(
                        single.map(|h| h.prim_id),
                        (rh.hit.geomID[k] != u32::MAX).then_some(rh.hit.primID[k])
                    );
                    if let Some(s) = single {
                        assert!((s.t - rh.ray.tfar[k]).abs() <= 1e-5 * s.t);
                    }
                }
                let mut ray = rh.ray;
                for k in 0..N {
                    ray.tfar[k] = f32::INFINITY;
                }
                user.occluded16(v, &mut ray, None);
                for (k, r) in chunk.iter().enumerate().take(N - 1) {
                    assert_eq!(native.occluded1(*r), ray.tfar[k] == f32::NEG_INFINITY);
                }
            }
            _ => unreachable!(),
        }
    }
}

#[test]
fn packets_4_8_16_match_single_rays() {
    let device = Device::new().unwrap();
    let (native, user) = scenes(&device);
    packet_check::<4>(&native, &user);
    packet_check::<8>(&native, &user);
    packet_check::<16>(&native, &user);
}

/// A filter that rejects every hit on primitives with an even primID.
unsafe extern "C" fn reject_even(args: *const sys::RTCFilterFunctionNArguments) {
    let a = &*args;
    let n = a.N as usize;
    let hit = a.hit as *const u32;
    for lane in 0..n {
        let valid = a.valid.add(lane);
        if *valid != -1 {
            continue;
        }
        let prim = *hit.add(5 * n + lane);
        if prim.is_multiple_of(2) {
            *valid = 0;
        }
    }
}

/// Give geometry `id` of the uncommitted `scene` the filter `reject_even`, for both queries.
fn filter_out_even(scene: &Scene, id: u32) {
    // SAFETY (test): the geometry is live in an uncommitted scene; setting filters before commit
    // is allowed, and `reject_even` touches only the lanes Embree passes it.
    unsafe {
        let g = sys::rtcGetGeometry(scene.raw(), id);
        sys::rtcSetGeometryIntersectFilterFunction(g, Some(reject_even));
        sys::rtcSetGeometryOccludedFilterFunction(g, Some(reject_even));
        sys::rtcCommitGeometry(g);
    }
}

#[test]
fn filters_see_and_reject_candidates_as_on_triangles() {
    let device = Device::new().unwrap();
    let (p, i) = octahedron();
    // Same geometry twice, each with the filter: native triangles and user triangles.
    let mut results = Vec::new();
    for user in [false, true] {
        let mut scene = Scene::new(&device).unwrap();
        let id = if user {
            scene
                .attach_user(
                    UserTriangles { positions: p.clone(), indices: i.clone() },
                    GeometryOptions::default(),
                )
                .unwrap()
        } else {
            scene.attach_triangles(&p, &i, GeometryOptions::default()).unwrap()
        };
        filter_out_even(&scene, id);
        let scene = scene.commit().unwrap();
        let r: Vec<_> = rays(5000)
            .into_iter()
            .map(|r| {
                (scene.intersect1(r).map(|h| (h.prim_id, (h.t * 1e4).round() as i64)), scene.occluded1(r))
            })
            .collect();
        results.push(r);
    }
    let odd_hits = results[1].iter().filter(|(h, _)| h.is_some()).count();
    assert!(odd_hits > 1000);
    assert!(results[1].iter().all(|(h, _)| h.is_none_or(|(p, _)| p % 2 == 1)));
    // Rays through a rejected front face reach the back face: same as with native triangles.
    let same = results[0].iter().zip(&results[1]).filter(|(a, b)| a == b).count();
    assert!(same as f64 >= 0.999 * results[0].len() as f64, "{same} of {}", results[0].len());
}

#[test]
fn masks_and_instances_work_for_user_geometry() {
    let device = Device::new().unwrap();
    let (p, i) = octahedron();
    let mut child = Scene::new(&device).unwrap();
    child.attach_user(UserTriangles { positions: p, indices: i }, GeometryOptions { mask: 0b10 }).unwrap();
    let child = child.commit().unwrap();
    let mut top = Scene::new(&device).unwrap();
    let inst =
        top.attach_instance(&child, Mat4::from_translation(Vec3::new(5.0, 0.0, 0.0)), u32::MAX).unwrap();
    let top = top.commit().unwrap();
    let mut r = Ray::new(Vec3::new(5.2, 0.1, 5.0), -Vec3::Z);
    let h = top.intersect1(r).expect("hit through instance");
    assert_eq!(h.inst_id[0], inst);
    assert!((h.t - (5.0 - (1.0 - 0.3))).abs() < 1e-5, "t = {}", h.t);
    r.mask = 0b01;
    assert!(top.intersect1(r).is_none(), "geometry mask ignored");
    assert!(!top.occluded1(r));
}

/// Whether each ray hits (primID) and is occluded, with `reject_even` passed in the query
/// arguments (with or without the flag that invokes it).
fn with_argument_filter(scene: &CommittedScene, invoke: bool) -> Vec<(Option<u32>, bool)> {
    let flags = if invoke {
        sys::RTCRayQueryFlags::RTC_RAY_QUERY_FLAG_INVOKE_ARGUMENT_FILTER
    } else {
        sys::RTCRayQueryFlags::RTC_RAY_QUERY_FLAG_INCOHERENT
    };
    rays(5000)
        .into_iter()
        .map(|r| {
            let mut context = QueryContext::new();
            // SAFETY (test): `reject_even` reads the valid flags and primIDs of the lanes it is
            // given and clears valid flags only; it cannot unwind.
            let mut args =
                unsafe { IntersectArgs::new().flags(flags).context(&mut context).filter(reject_even) };
            let mut rh = phongrt::embree::scene::new_rayhit(r);
            scene.intersect1_raw(&mut rh, Some(&mut args));
            // SAFETY (test): as above.
            let mut oargs = unsafe { OccludedArgs::new().flags(flags).filter(reject_even) };
            let mut ray = phongrt::embree::scene::new_rayhit(r).ray;
            scene.occluded1_raw(&mut ray, Some(&mut oargs));
            ((rh.hit.geomID != u32::MAX).then_some(rh.hit.primID), ray.tfar == f32::NEG_INFINITY)
        })
        .collect()
}

#[test]
fn a_filter_in_the_query_arguments_reaches_embree() {
    // Native triangles: Embree runs the argument filter itself. (Embree 4 gives a user geometry's
    // callback no way to run the argument filter: rtcInvokeIntersectFilterFromGeometry runs the
    // geometry's filter only, as its docs say.)
    let device = Device::new().unwrap();
    let (native, _) = scenes(&device);
    let plain: Vec<_> = rays(5000)
        .into_iter()
        .map(|r| (native.intersect1(r).map(|h| h.prim_id), native.occluded1(r)))
        .collect();
    let even = |v: &[(Option<u32>, bool)]| v.iter().filter(|(h, _)| h.is_some_and(|p| p % 2 == 0)).count();
    let filtered = with_argument_filter(&native, true);
    assert!(even(&plain) > 1000, "{}", even(&plain));
    assert_eq!(even(&filtered), 0, "the argument filter was not invoked");
    assert!(filtered.iter().filter(|(h, _)| h.is_some()).count() > 1000);
    // Occlusion: a ray blocked only by even primitives is not occluded under the filter.
    let blocked = |v: &[(Option<u32>, bool)]| v.iter().filter(|(_, o)| *o).count();
    assert!(blocked(&filtered) < blocked(&plain), "{} vs {}", blocked(&filtered), blocked(&plain));
    // Without the flag the argument filter is not invoked.
    assert_eq!(with_argument_filter(&native, false), plain);
    // The flag without a filter (all safe code) is harmless: Embree checks for NULL.
    let flags = sys::RTCRayQueryFlags::RTC_RAY_QUERY_FLAG_INVOKE_ARGUMENT_FILTER;
    for (r, expected) in rays(5000).into_iter().zip(&plain) {
        let mut rh = phongrt::embree::scene::new_rayhit(r);
        native.intersect1_raw(&mut rh, Some(&mut IntersectArgs::new().flags(flags)));
        let mut ray = phongrt::embree::scene::new_rayhit(r).ray;
        native.occluded1_raw(&mut ray, Some(&mut OccludedArgs::new().flags(flags)));
        let got = ((rh.hit.geomID != u32::MAX).then_some(rh.hit.primID), ray.tfar == f32::NEG_INFINITY);
        assert_eq!(&got, expected);
    }
}

#[test]
fn raw_packet_queries_trace_only_the_valid_lanes() {
    // (An uncommitted scene has no query methods at all: `Scene` only builds, see its
    // compile_fail example.)
    let device = Device::new().unwrap();
    let (p, i) = octahedron();
    let mut scene = Scene::new(&device).unwrap();
    scene.attach_user(UserTriangles { positions: p, indices: i }, GeometryOptions::default()).unwrap();
    let scene = scene.commit().unwrap();
    let r = Ray::new(Vec3::new(0.1, 0.1, 3.0), -Vec3::Z);
    let mut rh = phongrt::embree::scene::new_rayhit(r);
    scene.intersect1_raw(&mut rh, None);
    assert_eq!(rh.hit.geomID, 0);
    let mut rh4 = sys::RTCRayHit4::default();
    for k in 0..4 {
        (rh4.ray.org_x[k], rh4.ray.org_y[k], rh4.ray.org_z[k]) = (0.1, 0.1, 3.0);
        (rh4.ray.dir_z[k], rh4.ray.tfar[k], rh4.ray.mask[k]) = (-1.0, 7.0, u32::MAX);
    }
    scene.intersect4(&[-1, 0, -1, 0], &mut rh4, None);
    assert!(rh4.ray.tfar[0] < 7.0 && rh4.ray.tfar[2] < 7.0, "{:?}", rh4.ray.tfar);
    assert_eq!((rh4.ray.tfar[1], rh4.ray.tfar[3]), (7.0, 7.0), "invalid lanes are left alone");
}

/// One triangle (the unit triangle in z = 0) whose callbacks panic on request.
struct Panicky {
    in_bounds: bool,
    in_intersect: bool,
}

impl UserPrimitives for Panicky {
    fn count(&self) -> u32 {
        1
    }
    fn bounds(&self, _prim: u32) -> Option<(Vec3, Vec3)> {
        if self.in_bounds {
            panic!("bounds exploded");
        }
        Some((Vec3::new(0.0, 0.0, -0.01), Vec3::new(1.0, 1.0, 0.01)))
    }
    fn intersect(&self, prim: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit> {
        if self.in_intersect {
            panic!("intersect exploded");
        }
        let t = -org.z / dir.z;
        let p = org + t * dir;
        (t > tnear && t < tfar && p.x >= 0.0 && p.y >= 0.0 && p.x + p.y <= 1.0).then_some(PrimHit {
            t,
            u: p.x,
            v: p.y,
            ng: Vec3::Z,
            prim,
        })
    }
}

fn panicky_scene(device: &Device, in_bounds: bool, in_intersect: bool) -> Scene {
    let mut scene = Scene::new(device).unwrap();
    scene.attach_user(Panicky { in_bounds, in_intersect }, GeometryOptions::default()).unwrap();
    scene
}

#[test]
fn a_panic_in_intersect_is_resumed_in_the_caller() {
    let device = Device::new().unwrap();
    let scene = panicky_scene(&device, false, true).commit().unwrap();
    let r = Ray::new(Vec3::new(0.2, 0.3, 1.0), -Vec3::Z);
    let e =
        catch_unwind(AssertUnwindSafe(|| scene.intersect1(r))).expect_err("intersect1 swallowed the panic");
    assert_eq!(common::panic_message(e), "intersect exploded");
    let e = catch_unwind(AssertUnwindSafe(|| scene.occluded1(r))).expect_err("occluded1 swallowed the panic");
    assert_eq!(common::panic_message(e), "intersect exploded");
    let mut rh = sys::RTCRayHit8::default();
    for k in 0..8 {
        (rh.ray.org_x[k], rh.ray.org_y[k], rh.ray.org_z[k]) = (0.2, 0.3, 1.0);
        (rh.ray.dir_z[k], rh.ray.tfar[k], rh.ray.mask[k]) = (-1.0, f32::INFINITY, u32::MAX);
    }
    let e = catch_unwind(AssertUnwindSafe(|| scene.intersect8(&[-1; 8], &mut rh, None)))
        .expect_err("intersect8 swallowed the panic");
    assert_eq!(common::panic_message(e), "intersect exploded");
    // Nothing is left pending on the thread: the next query on a sound scene hits.
    let good = panicky_scene(&device, false, false).commit().unwrap();
    assert!(good.intersect1(r).is_some() && good.occluded1(r));
}

#[test]
fn a_panic_in_intersect_under_the_callers_own_embree_call_is_reported_by_commit() {
    let device = Device::new().unwrap();
    let scene = panicky_scene(&device, false, true).commit().unwrap();
    let mut rh = phongrt::embree::scene::new_rayhit(Ray::new(Vec3::new(0.2, 0.3, 1.0), -Vec3::Z));
    // SAFETY (test): the scene is live and committed; `rh` is a valid RTCRayHit; NULL arguments
    // select Embree's defaults.
    unsafe { sys::rtcIntersect1(scene.raw(), &mut rh, std::ptr::null_mut()) };
    // No Rust caller was waiting: the ray missed, and the panic is recorded for the geometry.
    assert_eq!(rh.hit.geomID, u32::MAX);
    let good = panicky_scene(&device, false, false).commit().unwrap();
    assert!(good.intersect1(Ray::new(Vec3::new(0.2, 0.3, 1.0), -Vec3::Z)).is_some());
    let err = scene.edit().expect("nothing instances it").commit().unwrap_err();
    assert!(
        matches!(&err, EmbreeError::CallbackPanicked { geom_id: 0, callback: "intersect", message }
        if message == "intersect exploded"),
        "{err}"
    );
}

#[test]
fn a_panic_in_bounds_makes_commit_fail() {
    let device = Device::new().unwrap();
    let scene = panicky_scene(&device, true, false);
    let err = scene.commit().unwrap_err();
    assert!(
        matches!(&err, EmbreeError::CallbackPanicked { geom_id: 0, callback: "bounds", message }
        if message == "bounds exploded"),
        "{err}"
    );
}

/// A Phong sphere with `k` patches per Embree primitive, with `reject_even` as its geometry
/// filter where `filtered`.
fn phong_sphere(device: &Device, k: usize, filtered: bool) -> CommittedScene {
    let m = phongrt::scene::uv_sphere(12, 6, 1.0);
    let mesh = phongrt::embree::PhongMesh::builder(&m.positions, &m.normals, &m.indices)
        .straight_edges(&m.straight_edges())
        .cluster_size(k)
        .build()
        .unwrap();
    let mut scene = Scene::new(device).unwrap();
    let id = scene.attach_phong(mesh, GeometryOptions::default()).unwrap();
    if filtered {
        filter_out_even(&scene, id);
    }
    scene.commit().unwrap()
}

#[test]
fn clustered_phong_mesh_gives_the_same_hits_as_one_patch_per_primitive() {
    let device = Device::new().unwrap();
    for filtered in [false, true] {
        let single = phong_sphere(&device, 1, filtered);
        let clustered = phong_sphere(&device, 8, filtered);
        let (mut hits, mut ties) = (0, 0);
        for r in rays(20_000) {
            let (a, b) = (single.intersect1(r), clustered.intersect1(r));
            assert_eq!(a.is_some(), b.is_some(), "{r:?}");
            if let (Some(a), Some(b)) = (a, b) {
                hits += 1;
                assert_eq!(a.t, b.t, "{r:?}");
                assert!(!filtered || b.prim_id % 2 == 1, "a rejected patch reported");
                if a.prim_id == b.prim_id {
                    assert_eq!((a.u, a.v, a.ng), (b.u, b.v, b.ng));
                } else {
                    ties += 1; // the same t on two patches: a shared edge
                }
            }
            assert_eq!(single.occluded1(r), clustered.occluded1(r), "{r:?}");
        }
        assert!(hits > 10_000, "too few hits: {hits}");
        assert!(ties * 1000 <= hits, "{ties} ties in {hits} hits");
    }
}

#[test]
fn clustered_phong_mesh_answers_packets_as_single_rays() {
    let device = Device::new().unwrap();
    let (single, clustered) = (phong_sphere(&device, 1, false), phong_sphere(&device, 8, false));
    packet_check::<4>(&single, &clustered);
    packet_check::<8>(&single, &clustered);
    packet_check::<16>(&single, &clustered);
}

#[test]
fn clusters_hold_every_patch_that_can_be_hit_once() {
    let m = phongrt::scene::uv_sphere(24, 12, 1.0);
    let mesh = phongrt::embree::PhongMesh::builder(&m.positions, &m.normals, &m.indices)
        .cluster_size(8)
        .build()
        .unwrap();
    let mut seen = vec![0u32; m.indices.len()];
    for c in mesh.clusters() {
        assert!(!c.members().is_empty() && c.members().len() <= 8);
        let (lo, hi) = c.bounds();
        for &t in c.members() {
            seen[t as usize] += 1;
            let (plo, phi) = mesh.patch_bounds(t).unwrap();
            assert!(lo.cmple(plo).all() && phi.cmple(hi).all(), "patch {t} outside its cluster's bounds");
        }
    }
    for (t, &n) in seen.iter().enumerate() {
        let expected = u32::from(!mesh.patches()[t].degenerate());
        assert_eq!(n, expected, "patch {t} in {n} clusters");
    }
    // Neighbours: most clusters are full.
    let full = mesh.clusters().iter().filter(|c| c.members().len() == 8).count();
    assert!(full * 10 >= mesh.clusters().len() * 9, "{full} of {} clusters full", mesh.clusters().len());
}

#[test]
fn a_cluster_size_outside_1_to_8_is_refused() {
    let (p, i) = octahedron();
    let n: Vec<Vec3> = p.iter().map(|v| v.normalize()).collect();
    for k in [0, 9] {
        let e = phongrt::embree::PhongMesh::builder(&p, &n, &i).cluster_size(k).build().unwrap_err();
        assert_eq!(e.to_string(), format!("cluster size {k} is not in 1..=8"));
    }
}

/// A unit triangle in z = 0 (as user geometry) whose test answers a fixed `t`, wherever the
/// ray really meets it: a broken implementation.
struct FixedT(f32);

impl UserPrimitives for FixedT {
    fn count(&self) -> u32 {
        1
    }

    fn bounds(&self, _prim: u32) -> Option<(Vec3, Vec3)> {
        Some((Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)))
    }

    fn intersect(&self, prim: u32, _org: Vec3, _dir: Vec3, _tnear: f32, _tfar: f32) -> Option<PrimHit> {
        Some(PrimHit { t: self.0, u: 0.25, v: 0.25, ng: Vec3::Z, prim })
    }
}

#[test]
fn a_user_hit_outside_the_ray_interval_is_refused_and_counted() {
    let device = Device::new().unwrap();
    let ray = Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z).with_range(0.5, 2.0);
    for (t, hit) in [(1.0, true), (0.25, false), (0.5, false), (2.0, false), (-1.0, false), (f32::NAN, false)]
    {
        let mut scene = Scene::new(&device).unwrap();
        scene.attach_user(FixedT(t), GeometryOptions::default()).unwrap();
        let scene = scene.commit().unwrap();
        let before = phongrt::embree::user_hits_out_of_range();
        assert_eq!(scene.intersect1(ray).map(|h| h.t), hit.then_some(t), "t = {t}");
        assert_eq!(scene.occluded1(ray), hit, "t = {t}");
        // One refusal per query that saw the bad t (no other test here makes bad hits).
        let refused = phongrt::embree::user_hits_out_of_range() - before;
        assert_eq!(refused, if hit { 0 } else { 2 }, "t = {t}");
    }
}

/// A filter that rejects every candidate it is shown.
unsafe extern "C" fn reject_all(args: *const sys::RTCFilterFunctionNArguments) {
    let a = &*args;
    for lane in 0..a.N as usize {
        *a.valid.add(lane) = 0;
    }
}

#[test]
fn a_filter_rejecting_every_candidate_leaves_the_hit_of_another_geometry_whole() {
    // Geometry 0: an octahedron; geometry 1: the same, a little nearer to the rays' origins,
    // with a filter that rejects all its candidates. Whichever Embree visits first, every answer
    // (single rays and 8-ray packets, hit fields and occlusion) must be geometry 0's alone.
    let device = Device::new().unwrap();
    let (p, i) = octahedron();
    let mut both = Scene::new(&device).unwrap();
    let mut alone = Scene::new(&device).unwrap();
    let tris =
        |shift: Vec3| UserTriangles { positions: p.iter().map(|&q| q + shift).collect(), indices: i.clone() };
    assert_eq!(both.attach_user(tris(Vec3::ZERO), GeometryOptions::default()).unwrap(), 0);
    let id = both.attach_user(tris(Vec3::splat(0.3)), GeometryOptions::default()).unwrap();
    // SAFETY (test): as in `filter_out_even`.
    unsafe {
        let g = sys::rtcGetGeometry(both.raw(), id);
        sys::rtcSetGeometryIntersectFilterFunction(g, Some(reject_all));
        sys::rtcSetGeometryOccludedFilterFunction(g, Some(reject_all));
        sys::rtcCommitGeometry(g);
    }
    alone.attach_user(tris(Vec3::ZERO), GeometryOptions::default()).unwrap();
    let (both, alone) = (both.commit().unwrap(), alone.commit().unwrap());
    let rays = rays(4000);
    let mut hits = 0;
    for r in &rays {
        let want = alone.intersect1(*r);
        hits += want.is_some() as usize;
        assert_eq!(both.intersect1(*r), want, "{r:?}");
        assert_eq!(both.occluded1(*r), alone.occluded1(*r), "{r:?}");
    }
    assert!(hits > 1000, "{hits} hits");
    for chunk in rays.chunks_exact(8) {
        let rays: [Ray; 8] = chunk.try_into().unwrap();
        for coherent in [false, true] {
            assert_eq!(
                both.intersect8_rays(&rays, 0xff, coherent),
                alone.intersect8_rays(&rays, 0xff, coherent)
            );
            assert_eq!(
                both.occluded8_rays(&rays, 0xff, coherent),
                alone.occluded8_rays(&rays, 0xff, coherent)
            );
        }
    }
}

/// Octahedron triangles (moved by a shift) that record, for every call of the occlusion route,
/// the object-space origin of the ray and the origin Embree's callback handed them.
struct RecordingTriangles {
    tris: UserTriangles,
    seen: std::sync::Mutex<Vec<(Vec3, Option<OriginPrim>)>>,
}

/// A committed scene of the given recorders, each attached as a user geometry, in order.
fn recording_scene(device: &Device, recs: &[&Arc<RecordingTriangles>]) -> CommittedScene {
    let mut scene = Scene::new(device).unwrap();
    for rec in recs {
        scene.attach_user(Arc::clone(rec), GeometryOptions::default()).unwrap();
    }
    scene.commit().unwrap()
}

impl RecordingTriangles {
    fn new(shift: Vec3) -> Arc<Self> {
        let (p, indices) = octahedron();
        let tris = UserTriangles { positions: p.iter().map(|v| *v + shift).collect(), indices };
        Arc::new(RecordingTriangles { tris, seen: Default::default() })
    }

    /// The calls since the last `take`.
    fn take(&self) -> Vec<(Vec3, Option<OriginPrim>)> {
        std::mem::take(&mut *self.seen.lock().unwrap())
    }
}

impl UserPrimitives for RecordingTriangles {
    fn count(&self) -> u32 {
        self.tris.count()
    }
    fn bounds(&self, prim: u32) -> Option<(Vec3, Vec3)> {
        self.tris.bounds(prim)
    }
    fn intersect(&self, prim: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit> {
        self.tris.intersect(prim, org, dir, tnear, tfar)
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
        self.seen.lock().unwrap().push((org, origin));
        self.intersect(prim, org, dir, tnear, tfar)
    }
}

/// A shadow ray from where `eye -> -z` hits `scene`, towards `to`, with the hit as its origin.
fn shadow_from_hit(scene: &CommittedScene, eye: Vec3, to: Vec3) -> (Ray, RayOrigin) {
    let h = scene.intersect1(Ray::new(eye, -Vec3::Z)).expect("the eye ray hits");
    let p = eye - Vec3::Z * h.t;
    (Ray::new(p, to - p), RayOrigin::of_hit(&h))
}

/// A point in the box of the octahedron moved 3 units along x, outside the octahedron: a ray
/// from the first octahedron towards it meets the second's boxes, not its faces.
const PAST_B: Vec3 = Vec3::new(3.0, 0.9, 0.9);

/// The origin a callback should see for `o`.
fn prim_of(o: &RayOrigin) -> Option<OriginPrim> {
    Some(OriginPrim { prim: o.prim, u: o.u, v: o.v })
}

#[test]
fn an_occlusion_ray_sees_its_origin_on_the_geometry_it_starts_on_and_nowhere_else() {
    let device = Device::new().unwrap();
    // A at the origin, B 3 units along x: two geometries of one scene.
    let (a, b) = (RecordingTriangles::new(Vec3::ZERO), RecordingTriangles::new(Vec3::X * 3.0));
    let scene = recording_scene(&device, &[&a, &b]);
    let (ray, origin) = shadow_from_hit(&scene, Vec3::new(0.2, 0.1, 5.0), PAST_B);
    a.take();
    b.take();
    // Compute the occlusion with the origin: A's calls see it, B's do not. (Whether the ray
    // meets the face it starts on again is the triangle test's rounding: the answer is not
    // asked; a ray that stops early would leave out calls, so it passes B by.)
    scene.occluded1_from(ray, Some(origin));
    let (seen_a, seen_b) = (a.take(), b.take());
    assert!(!seen_a.is_empty() && !seen_b.is_empty(), "{} calls on A, {} on B", seen_a.len(), seen_b.len());
    assert!(seen_a.iter().all(|(_, o)| *o == prim_of(&origin)), "{seen_a:?}");
    assert!(seen_b.iter().all(|(_, o)| o.is_none()), "{seen_b:?}");
    // Without an origin, or with one on another geometry, no call sees one.
    scene.occluded1_from(ray, None);
    scene.occluded1_from(ray, Some(RayOrigin { geom_id: origin.geom_id + 7, ..origin }));
    scene.occluded1(ray);
    assert!(a.take().iter().chain(&b.take()).all(|(_, o)| o.is_none()));
}

#[test]
fn an_occlusion_ray_sees_its_origin_only_in_the_instance_it_starts_on() {
    let device = Device::new().unwrap();
    let rec = RecordingTriangles::new(Vec3::ZERO);
    let child = recording_scene(&device, &[&rec]);
    let mut top = Scene::new(&device).unwrap();
    let shift = Vec3::X * 3.0;
    top.attach_instance(&child, Mat4::IDENTITY, u32::MAX).unwrap();
    top.attach_instance(&child, Mat4::from_translation(shift), u32::MAX).unwrap();
    let top = top.commit().unwrap();
    let (ray, origin) = shadow_from_hit(&top, Vec3::new(0.2, 0.1, 5.0), PAST_B);
    rec.take();
    top.occluded1_from(ray, Some(origin));
    // The first instance is the identity: its calls see the ray's own origin; the second's see
    // it shifted, and no origin (the instance stack differs).
    let seen = rec.take();
    let (first, second): (Vec<_>, Vec<_>) = seen.iter().partition(|(org, _)| *org == ray.org);
    assert!(!first.is_empty() && !second.is_empty() && first.len() + second.len() == seen.len());
    assert!(first.iter().all(|(_, o)| *o == prim_of(&origin)), "{first:?}");
    assert!(second.iter().all(|(org, o)| o.is_none() && (*org - (ray.org - shift)).length() < 1e-5));
}

#[test]
fn packet_lanes_see_their_own_origins() {
    let device = Device::new().unwrap();
    let rec = RecordingTriangles::new(Vec3::ZERO);
    let scene = recording_scene(&device, &[&rec]);
    // Eight rays leaving the octahedron's upper faces upwards, every other one with its origin.
    let shadows: Vec<(Ray, RayOrigin)> = (0..8)
        .map(|k| {
            let eye = Vec3::new(0.1 * k as f32 - 0.35, 0.05 * k as f32 - 0.2, 5.0);
            shadow_from_hit(&scene, eye, eye + Vec3::new(0.0, 0.0, 1.0))
        })
        .collect();
    let rays: [Ray; PACKET8] = std::array::from_fn(|k| shadows[k].0);
    let origins: [Option<RayOrigin>; PACKET8] = std::array::from_fn(|k| (k % 2 == 0).then_some(shadows[k].1));
    for coherent in [false, true] {
        rec.take();
        // (Whether a lane meets the face it starts on again is the triangle test's rounding.)
        scene.occluded8_rays_from(&rays, &origins, 0xff, coherent);
        let seen = rec.take();
        for (k, r) in rays.iter().enumerate() {
            let lane: Vec<_> = seen.iter().filter(|(org, _)| *org == r.org).collect();
            assert!(!lane.is_empty(), "lane {k} tests the face it starts on");
            let want = origins[k].as_ref().and_then(prim_of);
            assert!(lane.iter().all(|(_, o)| *o == want), "lane {k}: {lane:?}");
        }
    }
}

#[test]
fn a_ray_id_under_the_callers_own_context_names_no_origin() {
    let device = Device::new().unwrap();
    let rec = RecordingTriangles::new(Vec3::ZERO);
    let scene = recording_scene(&device, &[&rec]);
    let (ray, _) = shadow_from_hit(&scene, Vec3::new(0.2, 0.1, 5.0), Vec3::new(0.2, 0.1, 9.0));
    rec.take();
    // A raw query whose ray carries an id, under a context of the caller's own: no origin is
    // read from past that context.
    let mut r = sys::RTCRay { id: 1, ..new_rayhit(ray).ray };
    let mut ctx = QueryContext::new();
    scene.occluded1_raw(&mut r, Some(&mut OccludedArgs::new().context(&mut ctx)));
    let seen = rec.take();
    assert!(!seen.is_empty() && seen.iter().all(|(_, o)| o.is_none()), "{seen:?}");
}

/// The hits of `ray` on `scene` in order (closest-hit queries, each just past the last).
fn hits_along(scene: &CommittedScene, ray: Ray) -> Vec<phongrt::embree::Hit> {
    let mut out = Vec::new();
    let mut tnear = ray.tnear;
    while let Some(h) = scene.intersect1(ray.with_range(tnear, ray.tfar)) {
        tnear = h.t.next_up();
        out.push(h);
    }
    out
}

#[test]
fn an_occlusion_ray_reports_one_of_its_hits_as_what_blocked_it() {
    let device = Device::new().unwrap();
    let (a, b) = (RecordingTriangles::new(Vec3::ZERO), RecordingTriangles::new(Vec3::X * 3.0));
    let scene = recording_scene(&device, &[&a, &b]);
    // From A's top towards B's centre and on: through B's faces. The ray starts a little past
    // A's face, so that only B's faces are hits.
    let (ray, origin) = shadow_from_hit(&scene, Vec3::new(0.2, 0.1, 5.0), Vec3::X * 3.0);
    let ray = Ray::new(ray.org, ray.dir * 2.0).with_range(1e-3, 1.0);
    let hits = hits_along(&scene, ray);
    assert!(hits.len() >= 2 && hits.iter().all(|h| h.geom_id != origin.geom_id), "{hits:?}");
    let is_hit = |b: &Blocker| hits.iter().any(|h| (h.geom_id, h.prim_id, h.t) == (b.geom_id, b.prim, b.t));
    // With an origin the blocking hit is reported; without, only that something blocks.
    let by = scene.occluded1_by(ray, Some(origin)).expect("B blocks the ray");
    assert!(by.is_some_and(|b| is_hit(&b)), "{by:?} is not one of {hits:?}");
    assert_eq!(scene.occluded1_by(ray, None), Some(None));
    // A ray that meets nothing is clear.
    assert_eq!(
        scene.occluded1_by(Ray::new(ray.org, Vec3::Z).with_range(1e-3, f32::INFINITY), Some(origin)),
        None
    );
    // The same rays as packet lanes, every other one with its origin and every third inactive.
    let rays: [Ray; PACKET8] = std::array::from_fn(|_| ray);
    let origins: [Option<RayOrigin>; PACKET8] = std::array::from_fn(|k| (k % 2 == 0).then_some(origin));
    let active = 0b1101_1011;
    for coherent in [false, true] {
        let (blocked, by) = scene.occluded8_rays_by(&rays, &origins, active, coherent);
        assert_eq!(blocked, active);
        for k in 0..PACKET8 {
            match (active & (1 << k) != 0, origins[k]) {
                (true, Some(_)) => assert!(by[k].is_some_and(|b| is_hit(&b)), "lane {k}: {:?}", by[k]),
                _ => assert_eq!(by[k], None, "lane {k}"),
            }
        }
    }
}
