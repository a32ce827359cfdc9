//! Bad input renders with a warning, never a NaN pixel: normals that are all NaN, infinite or
//! zero are replaced by computed ones, and a model made only of slivers renders.

use std::path::Path;

use glam::Vec3;
use phongrt::embree::Device;
use phongrt::scene::{load_obj_text, LoadOptions, Model};
use phongrt_render::{render, Camera, ObjectMode, ObjectSettings, RenderSettings, World};

/// An octahedron whose every corner uses the `vn` line given (written once, as line 7).
fn octahedron_with_normal(vn: &str) -> String {
    let mut t = String::from("v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n");
    t += &format!("vn {vn}\n");
    for [a, b, c] in [[1, 3, 5], [3, 2, 5], [2, 4, 5], [4, 1, 5], [3, 1, 6], [2, 3, 6], [4, 2, 6], [1, 4, 6]]
    {
        t += &format!("f {a}//1 {b}//1 {c}//1\n");
    }
    t
}

/// A shallow cone of `n` slivers fanned from its apex (each 360/n degrees wide and 200 times
/// longer than wide for n = 1256), closed by a fan of slivers underneath, no normals.
fn sliver_cone(n: u32) -> String {
    let mut t = String::from("v 0 0.05 0\nv 0 0 0\n");
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        t += &format!("v {:.7} 0 {:.7}\n", a.cos(), -a.sin());
    }
    let rim = |i: u32| 3 + i % n;
    for i in 0..n {
        t += &format!("f 1 {} {}\nf 2 {} {}\n", rim(i), rim(i + 1), rim(i + 1), rim(i));
    }
    t
}

fn load(text: &str) -> Model {
    load_obj_text(text, Path::new("bad.obj"), &LoadOptions::default()).unwrap()
}

/// Render at 96×72, 1 spp, in Phong mode: (clamped samples, pixels not finite, pixels covered).
fn render_counts(scene: &Model) -> (u64, usize, usize) {
    let device = Device::new().unwrap();
    let world = World::from_scene(&device, scene, |_, _| ObjectSettings {
        mode: ObjectMode::Phong { alpha: 0.75 },
        straight_creases: true,
    })
    .unwrap();
    let (lo, hi) = world.bounds();
    let cam = Camera {
        eye: (lo + hi) * 0.5 + Vec3::new(1.5, 2.0, 3.0),
        ..Camera::frame_bounds(lo, hi, 96.0 / 72.0)
    };
    let s = RenderSettings { width: 96, height: 72, spp: 1, seed: 0, packets: true };
    let out = render(&world, &cam, &s).unwrap();
    let img = &out.image;
    let (mut bad, mut covered) = (0, 0);
    for y in 0..img.height {
        for x in 0..img.width {
            let c = img.get(x, y);
            bad += !c.is_finite() as usize;
            covered += (c != world.background()) as usize;
        }
    }
    (out.clamped_samples, bad, covered)
}

#[test]
fn non_finite_normals_load_with_a_warning_naming_the_line() {
    for vn in ["nan nan nan", "inf 0 0", "0 -inf 1", "1e39 0 0", "NaN 0 1"] {
        let s = load(&octahedron_with_normal(vn));
        let w = s
            .warnings
            .iter()
            .find(|w| w.contains("`vn`"))
            .unwrap_or_else(|| panic!("{vn}: {:?}", s.warnings));
        assert!(w.starts_with("bad.obj:7: 1 `vn` lines") && w.contains("not a finite number"), "{w}");
        let m = &s.meshes[0];
        assert!(m.normals.iter().all(|n| n.is_finite() && (n.length() - 1.0).abs() < 1e-5), "{vn}");
        assert_eq!(s.stats.normals_from_file, 0, "{vn}");
    }
}

#[test]
fn a_huge_finite_normal_is_normalised_not_replaced() {
    let s = load(&octahedron_with_normal("3e38 3e38 0"));
    assert_eq!(s.stats.zero_normals_replaced, 0, "{:?}", s.warnings);
    let n = Vec3::new(1.0, 1.0, 0.0).normalize();
    assert!(s.meshes[0].normals.iter().all(|m| m.distance(n) < 1e-6));
}

#[test]
fn models_with_all_nan_or_zero_normals_or_only_slivers_render_without_nan() {
    for (name, text) in [
        ("NaN normals", octahedron_with_normal("nan nan nan")),
        ("infinite normals", octahedron_with_normal("inf -inf inf")),
        ("zero normals", octahedron_with_normal("0 0 0")),
        ("only slivers", sliver_cone(1256)),
    ] {
        let scene = load(&text);
        assert!(!scene.warnings.is_empty() || name == "only slivers", "{name}: no warning");
        let (clamped, bad, covered) = render_counts(&scene);
        println!("{name}: {clamped} clamped samples, {bad} non-finite pixels, {covered} pixels covered");
        assert_eq!((clamped, bad), (0, 0), "{name}");
        assert!(covered > 300, "{name}: only {covered} pixels show the model");
    }
}
