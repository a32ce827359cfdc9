//! phongrt beside the `embree4-sys` crate: the program owns its device and scene through
//! `embree4-sys` (as an `embree4-rs` or `embree4-sys` user's code does), and adds Phong patches
//! with `phongrt::embree::attach_phong_raw`, passing the scene handle across with a pointer cast.
//!
//! **The ABI trap.** `embree4-sys` 0.0.12 bundles Embree 4.2's headers. In 4.3 `RTCHit` grew
//! (`instPrimID`), so its `RTCRayHit` is 80 bytes against the 96 bytes of the 4.3+ runtime that is
//! linked: a 4.3+ `rtcIntersect1` given embree4-sys's `RTCRayHit` writes 16 bytes past it. So this
//! program shares only *handles* between the two crates (`RTCDevice`, `RTCScene`: opaque
//! pointers, the same under every Embree 4 header) and traces with `phongrt::sys`'s functions and
//! structs, which are generated from (or checked against) the installed headers.
//! tests/embree4_sys_route.rs runs this program's `run` and checks the sizes it relies on.
//!
//! Run: `cargo run --release --example embree4_sys_route`.
use std::ptr;

use phongrt::embree::{attach_phong_raw, GeometryOptions, PhongMesh};
use phongrt::glam::Vec3;
use phongrt::sys;

/// The nearest hit of one ray (geomID, primID, t), traced with phongrt's bindings.
///
/// # Safety
/// `scene` must be live and committed.
unsafe fn trace(scene: sys::RTCScene, org: Vec3, dir: Vec3) -> Option<(u32, u32, f32)> {
    let mut rh = sys::RTCRayHit::default();
    (rh.ray.org_x, rh.ray.org_y, rh.ray.org_z) = (org.x, org.y, org.z);
    (rh.ray.dir_x, rh.ray.dir_y, rh.ray.dir_z) = (dir.x, dir.y, dir.z);
    rh.ray.tfar = f32::INFINITY;
    rh.ray.mask = u32::MAX;
    rh.hit.geomID = sys::RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = sys::RTC_INVALID_GEOMETRY_ID;
    // SAFETY: a live committed scene (this function's contract) and a ray-hit of the runtime's own
    // layout, initialised as rtcIntersect1 requires.
    unsafe { sys::rtcIntersect1(scene, &mut rh, ptr::null_mut()) };
    (rh.hit.geomID != sys::RTC_INVALID_GEOMETRY_ID).then_some((rh.hit.geomID, rh.hit.primID, rh.ray.tfar))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    for line in run()? {
        println!("{line}");
    }
    Ok(())
}

/// Builds the scene, traces three rays and returns one line per ray (and one on the struct sizes).
pub fn run() -> Result<Vec<String>, Box<dyn std::error::Error>> {
    let mut lines = Vec::new();
    // An octahedron with its vertices on the unit sphere and normals = positions.
    let p = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let idx = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    let octahedron = PhongMesh::builder(&p, &p, &idx).alpha(1.0).build()?;

    lines.push(format!(
        "RTCRayHit: embree4-sys {} bytes, phongrt::sys {} bytes",
        std::mem::size_of::<embree4_sys::RTCRayHit>(),
        std::mem::size_of::<sys::RTCRayHit>()
    ));
    // SAFETY: Embree's lifetime rules: the device outlives the scene; the Phong handle outlives
    // every trace of the scene (attach_phong_raw's contract) and is dropped after rtcReleaseScene.
    // RTCDevice and RTCScene are opaque pointers to the same objects whichever header declares
    // them, so the casts between the two crates' handle types are exact.
    unsafe {
        // Flush-to-zero and denormals-are-zero on this thread, which traces (Embree's advice;
        // set_flush_denormals' contract: nothing here depends for soundness on a float result).
        phongrt::embree::set_flush_denormals();
        let device = embree4_sys::rtcNewDevice(ptr::null());
        if device.is_null() {
            return Err("rtcNewDevice failed".into());
        }
        let scene = embree4_sys::rtcNewScene(device);
        let phong = attach_phong_raw(scene.cast(), octahedron, GeometryOptions::default())?;
        embree4_sys::rtcCommitScene(scene);
        if sys::rtcGetDeviceError(device.cast()) != sys::RTCError::RTC_ERROR_NONE {
            return Err("Embree reported an error".into());
        }
        let d = Vec3::ONE.normalize();
        let rays = [
            ("onto the top vertex", Vec3::new(0.0, 5.0, 0.0), -Vec3::Y),
            ("onto a face centre", d * 3.0 * 3f32.sqrt(), -d),
            ("beside it", Vec3::new(3.0, 5.0, 0.0), -Vec3::Y),
        ];
        for (i, (what, org, dir)) in rays.into_iter().enumerate() {
            lines.push(match trace(scene.cast(), org, dir) {
                Some((geom, prim, t)) if geom == phong.geom_id() => {
                    format!("ray {i} ({what}): hit phong prim {prim} t {t:.6}")
                }
                Some((geom, prim, t)) => format!("ray {i} ({what}): hit geom {geom} prim {prim} t {t:.6}"),
                None => format!("ray {i} ({what}): miss"),
            });
        }
        embree4_sys::rtcReleaseScene(scene);
        drop(phong);
        embree4_sys::rtcReleaseDevice(device);
    }
    Ok(lines)
}
