//! The Embree layer on its own: device, triangles, instances, packets, masks.
use glam::{Mat4, Vec3};
use phongrt::embree::{CommittedScene, Device, GeometryOptions, Ray, Scene};

fn unit_triangle_scene(device: &Device, mask: u32) -> CommittedScene {
    let mut scene = Scene::new(device).unwrap();
    let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
    scene.attach_triangles(&p, &[[0, 1, 2]], GeometryOptions { mask }).unwrap();
    scene.commit().unwrap()
}

#[test]
fn device_reports_embree_4_with_user_geometry() {
    let device = Device::new().unwrap();
    let (major, _, _) = device.version();
    assert_eq!(major, 4);
    assert!(device.supports_user_geometry());
    assert!([4, 8, 16].contains(&device.native_packet_width()));
}

#[test]
fn bad_config_is_an_error_not_a_panic() {
    assert!(Device::with_config("threads=1\0").is_err());
}

#[test]
fn triangle_hit_matches_embree_convention() {
    let device = Device::new().unwrap();
    let scene = unit_triangle_scene(&device, u32::MAX);
    let hit = scene.intersect1(Ray::new(Vec3::new(0.2, 0.3, 1.0), Vec3::new(0.0, 0.0, -2.0))).expect("hit");
    assert!((hit.t - 0.5).abs() < 1e-6);
    // (1-u-v) v0 + u v1 + v v2 = (u, v, 0)
    assert!((hit.u - 0.2).abs() < 1e-6 && (hit.v - 0.3).abs() < 1e-6);
    assert_eq!((hit.prim_id, hit.geom_id), (0, 0));
    assert!(hit.ng.normalize().dot(Vec3::Z).abs() > 0.999);
    // tnear/tfar honoured.
    let r = Ray::new(Vec3::new(0.2, 0.3, 1.0), Vec3::new(0.0, 0.0, -2.0));
    assert!(scene.intersect1(r.with_range(0.0, 0.49)).is_none());
    assert!(scene.intersect1(r.with_range(0.51, 10.0)).is_none());
    assert!(scene.occluded1(r));
    assert!(!scene.occluded1(r.with_range(0.0, 0.49)));
    assert!(scene.intersect1(Ray::new(Vec3::new(0.8, 0.8, 1.0), -Vec3::Z)).is_none());
}

#[test]
fn geometry_mask_is_honoured() {
    let device = Device::new().unwrap();
    let scene = unit_triangle_scene(&device, 0b10);
    let mut r = Ray::new(Vec3::new(0.2, 0.3, 1.0), -Vec3::Z);
    r.mask = 0b01;
    assert!(scene.intersect1(r).is_none());
    r.mask = 0b10;
    assert!(scene.intersect1(r).is_some());
}

#[test]
fn instance_reports_inst_id_and_transforms() {
    let device = Device::new().unwrap();
    let child = unit_triangle_scene(&device, u32::MAX);
    let mut top = Scene::new(&device).unwrap();
    let id =
        top.attach_instance(&child, Mat4::from_translation(Vec3::new(10.0, 0.0, 0.0)), u32::MAX).unwrap();
    let top = top.commit().unwrap();
    assert!(top.intersect1(Ray::new(Vec3::new(0.2, 0.3, 1.0), -Vec3::Z)).is_none());
    let hit = top.intersect1(Ray::new(Vec3::new(10.2, 0.3, 1.0), -Vec3::Z)).expect("hit");
    assert_eq!(hit.inst_id[0], id);
    assert!((hit.u - 0.2).abs() < 1e-5);
}

#[test]
fn out_of_range_index_is_refused() {
    let device = Device::new().unwrap();
    let mut scene = Scene::new(&device).unwrap();
    let err = scene.attach_triangles(&[Vec3::ZERO], &[[0, 1, 2]], GeometryOptions::default()).unwrap_err();
    assert!(err.to_string().contains("out of range"));
}

#[test]
fn subdivision_surface_of_an_octahedron_is_inside_it_and_hit() {
    let device = Device::new().unwrap();
    let p = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let i = vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    let mut scene = Scene::new(&device).unwrap();
    scene.attach_subdivision(&p, &i, 8.0).unwrap();
    let scene = scene.commit().unwrap();
    // Catmull–Clark shrinks towards the control hull's inside: the hit from +x is inside the vertex.
    let h = scene.intersect1(Ray::new(Vec3::new(3.0, 0.01, 0.02), -Vec3::X)).expect("hit");
    assert!(h.t > 2.0 && h.t < 2.9, "t = {}", h.t);
    assert!(Scene::new(&device).unwrap().attach_subdivision(&p, &[[0, 1, 9]], 4.0).is_err());
}

#[test]
fn robust_mode_is_set_and_cleared_and_traces_the_same() {
    let device = Device::new().unwrap();
    let scene = unit_triangle_scene(&device, 1);
    assert!(!scene.robust());
    let mut scene = scene.edit().expect("a scene nothing instances can be edited");
    scene.set_robust(true).unwrap();
    assert!(scene.robust());
    let scene = scene.commit().unwrap();
    assert!(scene.robust());
    let hit = scene
        .intersect1(Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::new(0.0, 0.0, -1.0)))
        .expect("hit in robust mode");
    assert!((hit.t - 1.0).abs() < 1e-6);
    let mut scene = scene.edit().unwrap();
    scene.set_robust(false).unwrap();
    assert!(!scene.commit().unwrap().robust());
}

#[test]
fn an_instanced_scene_cannot_be_edited_and_stays_committed_and_traced() {
    // The child is instanced (and may be traced through the parent): taking its builder back
    // is refused, and the refusal hands the committed scene back: its own rays still hit.
    let device = Device::new().unwrap();
    let child = unit_triangle_scene(&device, u32::MAX);
    let mut parent = Scene::new(&device).unwrap();
    parent.attach_instance(&child, Mat4::IDENTITY, u32::MAX).unwrap();
    let parent = parent.commit().unwrap();
    let r = Ray::new(Vec3::new(0.2, 0.3, 1.0), -Vec3::Z);
    let child = child.edit().expect_err("rebuilding a scene another may be tracing is refused");
    assert!(child.intersect1(r).is_some(), "the refused edit left the scene traced");
    assert!(child.occluded1(r));
    assert!(parent.intersect1(r).is_some());
    // Once the parent is gone, the child is its own again.
    drop(parent);
    let mut child = child.edit().expect("no other scene instances it");
    child.attach_triangles(&[Vec3::ZERO, Vec3::X, Vec3::Y], &[[0, 1, 2]], Default::default()).unwrap();
    let child = child.commit().unwrap();
    assert_eq!(child.intersect1(r).map(|h| h.geom_id), Some(0));
}

#[test]
fn scene_new_with_callers_pending_device_error_succeeds_and_leaves_it() {
    use phongrt::sys;
    let device = Device::new().unwrap();
    let other = Scene::new(&device).unwrap();
    // SAFETY (test): `other` is a live scene; the caller's own mistake through the raw API, a
    // build quality scenes do not take (refit is for geometries), leaves an error pending.
    unsafe { sys::rtcSetSceneBuildQuality(other.raw(), sys::RTCBuildQuality::RTC_BUILD_QUALITY_REFIT) };
    let scene = Scene::new(&device).expect("a new scene despite the caller's pending error");
    assert!(device.check().is_err(), "the caller's pending error is still theirs to read");
    drop(scene);
    let scene = unit_triangle_scene(&device, u32::MAX);
    let hit = scene.intersect1(Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z)).unwrap();
    assert_eq!((hit.geom_id, hit.t), (0, 1.0));
}

/// Half the smallest normal f32, computed at run time on the calling thread.
#[cfg(target_arch = "x86_64")]
fn half_min_positive_at_run_time() -> f32 {
    std::hint::black_box(f32::MIN_POSITIVE) * std::hint::black_box(0.5)
}

#[test]
#[cfg(target_arch = "x86_64")]
fn thread_pool_builder_threads_flush_denormals_and_others_do_not() {
    let pool = phongrt::embree::thread_pool_builder().num_threads(2).build().unwrap();
    let on_pool = pool.broadcast(|_| half_min_positive_at_run_time());
    assert_eq!(on_pool, vec![0.0, 0.0], "every pool thread flushes the subnormal result to zero");
    let plain = std::thread::spawn(half_min_positive_at_run_time).join().unwrap();
    assert!(plain > 0.0 && plain.is_subnormal(), "a thread of its own keeps IEEE subnormals: {plain}");
}

/// Leave an error pending on the calling thread through the raw API, as a caller's own
/// Embree code can: a build quality scenes do not take (refit is for geometries).
fn leave_a_raw_error_pending(device: &Device) -> Scene {
    let other = Scene::new(device).unwrap();
    // SAFETY (test): `other` is a live scene; the call only records an error on the device.
    unsafe {
        phongrt::sys::rtcSetSceneBuildQuality(
            other.raw(),
            phongrt::sys::RTCBuildQuality::RTC_BUILD_QUALITY_REFIT,
        )
    };
    other
}

#[test]
fn attach_and_commit_after_callers_pending_error_succeed_and_leave_it() {
    let device = Device::new().unwrap();
    let _other = leave_a_raw_error_pending(&device);
    let scene = unit_triangle_scene(&device, u32::MAX);
    let hit = scene.intersect1(Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z)).unwrap();
    assert_eq!((hit.geom_id, hit.t), (0, 1.0));
    let err = device.check().expect_err("the caller's pending error is still theirs to read");
    assert!(err.to_string().contains("invalid build quality"), "{err}");
    device.check().expect("read once");
}

#[test]
fn another_threads_pending_error_is_not_reported_on_this_one() {
    let device = Device::new().unwrap();
    let d = device.clone();
    std::thread::spawn(move || drop(leave_a_raw_error_pending(&d))).join().unwrap();
    let scene = unit_triangle_scene(&device, u32::MAX);
    assert!(scene.intersect1(Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z)).is_some());
    device.check().expect("no error of this thread's calls");
}

#[test]
fn scenes_built_on_many_threads_of_one_device_all_trace() {
    let device = Device::new().unwrap();
    let hits: Vec<bool> = std::thread::scope(|s| {
        let threads: Vec<_> = (0..8)
            .map(|_| {
                s.spawn(|| {
                    let scene = unit_triangle_scene(&device, u32::MAX);
                    scene.intersect1(Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z)).is_some()
                })
            })
            .collect();
        threads.into_iter().map(|t| t.join().unwrap()).collect()
    });
    assert_eq!(hits, vec![true; 8]);
    device.check().unwrap();
}
