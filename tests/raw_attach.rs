//! `attach_phong_raw` on a raw scene of the caller's own Embree code: an Embree error the caller
//! left pending on the device is theirs, and must not turn a successful attach into a failure
//! that frees the mesh under the attached geometry. The case runs in-process, then again under
//! valgrind (memcheck) when valgrind is installed, so a mesh freed under its geometry shows as
//! an invalid read in the commit's bounds callback or the trace.
//!
//! The Rust counterpart of tests/c/pending_error.c.
use glam::Vec3;
use phongrt::embree::scene::new_rayhit;
use phongrt::embree::{attach_phong_raw, GeometryOptions, PhongMesh, Ray};
use phongrt::sys;

mod common;

/// Set in the child run under valgrind, so it runs the case without re-running itself.
const UNDER_VALGRIND: &str = "PHONGRT_TEST_UNDER_VALGRIND";

/// An octahedron with unit-sphere normals at its 6 vertices (which lie on the unit sphere).
fn octahedron() -> PhongMesh {
    let p: Vec<Vec3> = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ]
    .map(Vec3::from)
    .to_vec();
    let idx = vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    PhongMesh::new(&p, &p, &idx, 1.0).unwrap()
}

/// The case: attach with an error pending, then commit and trace whatever the attach answered
/// (so the old use-after-free is exercised, not only reported), then check the answers.
fn attach_with_pending_error() {
    // SAFETY (test): the device and scene are made here and released at the end, the scene
    // before the handle attach_phong_raw returns is dropped (its contract).
    unsafe {
        let device = sys::rtcNewDevice(std::ptr::null());
        assert!(!device.is_null(), "no Embree device");
        let scene = sys::rtcNewScene(device);
        // The caller's own mistake: a build quality scenes do not take (refit is for geometries).
        sys::rtcSetSceneBuildQuality(scene, sys::RTCBuildQuality::RTC_BUILD_QUALITY_REFIT);
        let attached = attach_phong_raw(scene, octahedron(), GeometryOptions::default());
        let pending = sys::rtcGetDeviceError(device);
        sys::rtcCommitScene(scene);
        let commit_error = sys::rtcGetDeviceError(device);
        // A ray at the +z vertex from z = 4 hits the patch at distance 3.
        let mut rh = new_rayhit(Ray::new(Vec3::new(0.0, 0.0, 4.0), -Vec3::Z));
        sys::rtcIntersect1(scene, &mut rh, std::ptr::null_mut());
        sys::rtcReleaseScene(scene);
        sys::rtcReleaseDevice(device);
        let handle = attached.expect("the attach succeeds despite the caller's pending error");
        assert_ne!(
            pending,
            sys::RTCError::RTC_ERROR_NONE,
            "the caller's pending error is still theirs to read"
        );
        assert_eq!(commit_error, sys::RTCError::RTC_ERROR_NONE, "the commit succeeds");
        assert_eq!(rh.hit.geomID, handle.geom_id(), "the ray hits the Phong mesh");
        assert!((rh.ray.tfar - 3.0).abs() < 1e-4, "at the vertex, distance 3: t = {}", rh.ray.tfar);
        drop(handle);
    }
}

#[test]
fn raw_attach_with_callers_pending_device_error_succeeds() {
    attach_with_pending_error();
    if std::env::var_os(UNDER_VALGRIND).is_some() {
        return;
    }
    let exe = std::env::current_exe().unwrap();
    let Some(mut vg) = common::valgrind(&exe) else { return };
    let out = vg
        .args(["--exact", "raw_attach_with_callers_pending_device_error_succeeds", "--test-threads=1"])
        .env(UNDER_VALGRIND, "1")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "under valgrind:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 passed"), "the case ran under valgrind");
}
