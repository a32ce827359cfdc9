//! The `embree4-sys` route (examples/embree4_sys_route.rs, compiled into this test): a scene made
//! through `embree4-sys`, Phong patches attached with `attach_phong_raw` and traced with
//! `phongrt::sys`, gives the Phong surface's hits.
#[allow(dead_code)] // its `main`
#[path = "../examples/embree4_sys_route.rs"]
mod example;

/// The handles the example passes between the two crates are pointers in both, and the ray-hit
/// struct it must NOT share really differs (the 4.2-header trap the README warns about): if a
/// later embree4-sys matches the 4.3+ layout, this fails and the warning can go.
#[test]
fn embree4_sys_shares_handles_with_phongrt_sys_but_not_rayhit() {
    use std::mem::{align_of, size_of};
    assert_eq!(size_of::<embree4_sys::RTCScene>(), size_of::<phongrt::sys::RTCScene>());
    assert_eq!(size_of::<embree4_sys::RTCDevice>(), size_of::<phongrt::sys::RTCDevice>());
    assert_eq!(align_of::<embree4_sys::RTCScene>(), align_of::<phongrt::sys::RTCScene>());
    assert_eq!(size_of::<phongrt::sys::RTCRayHit>(), 96, "phongrt::sys is not the 4.3+ layout");
    assert_eq!(size_of::<embree4_sys::RTCRayHit>(), 80, "embree4-sys's RTCRayHit changed size");
}

#[test]
fn embree4_sys_scene_with_phong_patches_traces_the_phong_surface() {
    let lines = example::run().expect("the example failed");
    let stdout = lines.join("\n");
    let t_of = |i: usize| -> f32 {
        let line = lines.iter().find(|l| l.starts_with(&format!("ray {i} "))).unwrap();
        assert!(line.contains("hit phong"), "{line}");
        line.rsplit(' ').next().unwrap().parse().unwrap()
    };
    // The top vertex at distance 4; the face centre bulges out of the flat face (at
    // 3√3 − 1/√3) but not beyond the unit sphere (at 3√3 − 1).
    assert!((t_of(0) - 4.0).abs() < 1e-4);
    let (flat, sphere) = (3.0 * 3f32.sqrt() - 1.0 / 3f32.sqrt(), 3.0 * 3f32.sqrt() - 1.0);
    assert!(t_of(1) < flat - 0.1 && t_of(1) > sphere - 1e-4, "t {}", t_of(1));
    assert!(stdout.contains("ray 2 (beside it): miss"), "{stdout}");
}
