//! phongrt dropped into an Embree program that owns its scene, as a user outside this repository
//! writes it (tests/dropin.rs builds and runs this file as such a crate, with only
//! `phongrt = { path = ... }` in its Cargo.toml).
//!
//! The program makes its own `RTCDevice` and `RTCScene` through `phongrt::sys` (the raw Embree 4
//! bindings), adds a native triangle mesh (a floor at y = -2) and a Phong mesh (an octahedron
//! whose vertex normals point away from its centre, so it bulges towards the unit sphere), traces
//! a few rays with `rtcIntersect1` and prints each hit with its shading normal: the Phong mesh's
//! from phongrt, the floor's its face normal.
//!
//! Run: `cargo run --release --example embree_dropin`.
use std::ptr;

use phongrt::embree::{attach_phong_raw, GeometryOptions, PhongMesh};
use phongrt::glam::Vec3;
use phongrt::sys;

/// Add a native Embree triangle mesh to `scene`; returns its geomID.
///
/// # Safety
/// `device` and `scene` must be live.
unsafe fn add_triangles(
    device: sys::RTCDevice,
    scene: sys::RTCScene,
    p: &[[f32; 3]],
    idx: &[[u32; 3]],
) -> u32 {
    // SAFETY: Embree's buffer API: rtcSetNewGeometryBuffer returns a buffer of `count` items of
    // the given stride, owned by the geometry, which the scene retains once attached.
    unsafe {
        let geom = sys::rtcNewGeometry(device, sys::RTCGeometryType::RTC_GEOMETRY_TYPE_TRIANGLE);
        let vb = sys::rtcSetNewGeometryBuffer(
            geom,
            sys::RTCBufferType::RTC_BUFFER_TYPE_VERTEX,
            0,
            sys::RTCFormat::RTC_FORMAT_FLOAT3,
            12,
            p.len(),
        ) as *mut [f32; 3];
        ptr::copy_nonoverlapping(p.as_ptr(), vb, p.len());
        let ib = sys::rtcSetNewGeometryBuffer(
            geom,
            sys::RTCBufferType::RTC_BUFFER_TYPE_INDEX,
            0,
            sys::RTCFormat::RTC_FORMAT_UINT3,
            12,
            idx.len(),
        ) as *mut [u32; 3];
        ptr::copy_nonoverlapping(idx.as_ptr(), ib, idx.len());
        sys::rtcCommitGeometry(geom);
        let id = sys::rtcAttachGeometry(scene, geom);
        sys::rtcReleaseGeometry(geom);
        id
    }
}

/// Trace one ray; returns (geomID, primID, t, u, v, Ng) of the nearest hit.
///
/// # Safety
/// `scene` must be live and committed.
unsafe fn trace(scene: sys::RTCScene, org: Vec3, dir: Vec3) -> Option<(u32, u32, f32, f32, f32, Vec3)> {
    let mut rh = sys::RTCRayHit::default();
    (rh.ray.org_x, rh.ray.org_y, rh.ray.org_z) = (org.x, org.y, org.z);
    (rh.ray.dir_x, rh.ray.dir_y, rh.ray.dir_z) = (dir.x, dir.y, dir.z);
    rh.ray.tfar = f32::INFINITY;
    rh.ray.mask = u32::MAX;
    rh.hit.geomID = sys::RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = sys::RTC_INVALID_GEOMETRY_ID;
    // SAFETY: a live committed scene and a ray-hit initialised as rtcIntersect1 requires.
    unsafe { sys::rtcIntersect1(scene, &mut rh, ptr::null_mut()) };
    (rh.hit.geomID != sys::RTC_INVALID_GEOMETRY_ID).then(|| {
        let ng = Vec3::new(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
        (rh.hit.geomID, rh.hit.primID, rh.ray.tfar, rh.hit.u, rh.hit.v, ng)
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The Phong mesh: an octahedron with its vertices on the unit sphere, normals = positions.
    let p = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let idx = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    let octahedron = PhongMesh::new(&p, &p, &idx, 1.0)?;

    // SAFETY: the usual Embree lifetime rules: the device outlives the scene, the Phong handle
    // outlives every trace of the scene (attach_phong_raw's contract): it is dropped after
    // rtcReleaseScene.
    unsafe {
        // Flush-to-zero and denormals-are-zero on this thread, which traces (Embree's advice;
        // set_flush_denormals' contract: nothing here depends for soundness on a float result).
        phongrt::embree::set_flush_denormals();
        let device = sys::rtcNewDevice(ptr::null());
        if device.is_null() {
            return Err("rtcNewDevice failed".into());
        }
        let scene = sys::rtcNewScene(device);
        let floor = [[-10.0, -2.0, -10.0], [10.0, -2.0, -10.0], [10.0, -2.0, 10.0], [-10.0, -2.0, 10.0]];
        let floor_id = add_triangles(device, scene, &floor, &[[0, 2, 1], [0, 3, 2]]);
        let phong = attach_phong_raw(scene, octahedron, GeometryOptions::default())?;
        sys::rtcCommitScene(scene);
        if sys::rtcGetDeviceError(device) != sys::RTCError::RTC_ERROR_NONE {
            return Err("Embree reported an error".into());
        }
        println!("geometries: floor {floor_id} (triangles), octahedron {} (phong)", phong.geom_id());

        let d = Vec3::ONE.normalize();
        let rays = [
            ("onto the top vertex", Vec3::new(0.0, 5.0, 0.0), -Vec3::Y),
            ("beside the octahedron", Vec3::new(3.0, 5.0, 0.0), -Vec3::Y),
            ("onto a face centre", d * 3.0 * 3f32.sqrt(), -d),
            ("into the sky", Vec3::new(0.0, 5.0, 0.0), Vec3::Y),
        ];
        for (i, (what, org, dir)) in rays.into_iter().enumerate() {
            match trace(scene, org, dir) {
                None => println!("ray {i} ({what}): miss"),
                Some((geom, prim, t, u, v, ng)) => {
                    let (kind, n) = if geom == phong.geom_id() {
                        ("phong", phong.mesh().shading_normal(prim, u, v, dir).unwrap_or(Vec3::ZERO))
                    } else {
                        ("triangles", ng.normalize_or_zero())
                    };
                    println!(
                        "ray {i} ({what}): hit {kind} geom {geom} prim {prim} t {t:.6} u {u:.6} v {v:.6} \
                         normal {:.6} {:.6} {:.6}",
                        n.x, n.y, n.z
                    );
                }
            }
        }
        // For comparison: the flat face the third ray would hit without Phong tessellation.
        println!("flat face centre at t {:.6}", (3.0 * 3f32.sqrt() - 1.0 / 3f32.sqrt()));
        sys::rtcReleaseScene(scene);
        drop(phong);
        sys::rtcReleaseDevice(device);
    }
    Ok(())
}
