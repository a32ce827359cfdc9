//! Mesh preparation that keeps smooth models smooth: normals equal up to rounding are one normal
//! (no crease between them), and duplicated faces are dropped (no non-manifold edges).

use std::path::Path;

use phongrt::scene::{load_obj_text, LoadOptions, Model};

fn load(text: &str, opts: &LoadOptions) -> Model {
    load_obj_text(text, Path::new("gen.obj"), opts).unwrap()
}

/// A closed UV sphere written as exporters write one: every (ring, segment) its own `v` and
/// `vn` from sin/cos, the poles once per segment and the seam column twice, so positions and
/// normals there agree only up to rounding (and in the sign of zero).
fn sincos_sphere_obj(segments: u32, rings: u32) -> String {
    let mut t = String::new();
    for r in 0..=rings {
        let th = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let ph = std::f32::consts::TAU * s as f32 / segments as f32;
            let n = [th.sin() * ph.cos(), th.cos(), -th.sin() * ph.sin()];
            t += &format!("v {:e} {:e} {:e}\nvn {:e} {:e} {:e}\n", n[0], n[1], n[2], n[0], n[1], n[2]);
        }
    }
    let at = |r: u32, s: u32| r * (segments + 1) + s + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (at(r, s), at(r + 1, s), at(r + 1, s + 1), at(r, s + 1));
            if r > 0 {
                t += &format!("f {a}//{a} {b}//{b} {d}//{d}\n");
            }
            if r + 1 < rings {
                t += &format!("f {b}//{b} {c}//{c} {d}//{d}\n");
            }
        }
    }
    t
}

#[test]
fn a_sincos_uv_sphere_has_no_straight_edges() {
    let s = load(&sincos_sphere_obj(24, 12), &LoadOptions::default());
    assert_eq!(s.meshes.len(), 1);
    let straight = s.meshes[0].straight_edges().iter().flatten().filter(|&&b| b).count();
    assert_eq!(straight, 0, "{:?}", s.stats);
    assert_eq!(s.stats.crease_edges, 0);
    assert_eq!(s.stats.border_edges, 0);
    assert_eq!(s.stats.smooth_edges, 3 * s.stats.triangles / 2);
}

#[test]
fn a_zero_normal_tolerance_keeps_the_sincos_sphere_poles_and_seam_creased() {
    let opts = LoadOptions { normal_tolerance_rad: 0.0, ..LoadOptions::default() };
    let s = load(&sincos_sphere_obj(24, 12), &opts);
    assert!(s.stats.crease_edges > 0, "{:?}", s.stats);
}

#[test]
fn normals_farther_apart_than_the_tolerance_stay_a_crease() {
    // Two triangles of a square, the diagonal's normals 1e-3 rad apart at one end.
    let (c, sn) = (1e-3f32.cos(), 1e-3f32.sin());
    let text = format!(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nvn {sn} 0 {c}\n\
         f 1//1 2//1 3//1\nf 1//2 3//1 4//1\n"
    );
    let s = load(&text, &LoadOptions::default());
    assert_eq!(s.stats.crease_edges, 1);
    let close = text.replace(&format!("vn {sn} 0 {c}"), "vn 1e-5 -0 1");
    let s = load(&close, &LoadOptions::default());
    assert_eq!(s.stats.crease_edges, 0);
    assert_eq!(s.stats.smooth_edges, 1);
}

/// An octahedron, closed, with every face written twice (the second time in the other winding
/// for odd faces).
fn doubled_octahedron_obj() -> String {
    let mut t = String::from("v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n");
    let faces = [[1, 3, 5], [3, 2, 5], [2, 4, 5], [4, 1, 5], [3, 1, 6], [2, 3, 6], [4, 2, 6], [1, 4, 6]];
    for f in faces {
        t += &format!("f {} {} {}\n", f[0], f[1], f[2]);
    }
    for (i, f) in faces.iter().enumerate() {
        if i % 2 == 0 {
            t += &format!("f {} {} {}\n", f[1], f[2], f[0]);
        } else {
            t += &format!("f {} {} {}\n", f[0], f[2], f[1]);
        }
    }
    t
}

#[test]
fn duplicate_faces_are_dropped_with_one_warning() {
    let s =
        load(&doubled_octahedron_obj(), &LoadOptions { crease_angle_deg: 100.0, ..LoadOptions::default() });
    assert_eq!(s.stats.triangles, 8);
    assert_eq!(s.stats.duplicates_dropped, 8);
    assert_eq!(s.stats.nonmanifold_edges, 0);
    assert_eq!(s.stats.smooth_edges, 12);
    let w: Vec<_> = s.warnings.iter().filter(|w| w.contains("duplicate")).collect();
    assert_eq!(w.len(), 1, "{:?}", s.warnings);
    assert!(w[0].starts_with("gen.obj: dropped 8 duplicate triangles"), "{}", w[0]);
}

#[test]
fn keeping_duplicate_faces_makes_their_edges_non_manifold() {
    let opts = LoadOptions { crease_angle_deg: 100.0, drop_duplicate_faces: false, ..LoadOptions::default() };
    let s = load(&doubled_octahedron_obj(), &opts);
    assert_eq!(s.stats.triangles, 16);
    assert_eq!(s.stats.duplicates_dropped, 0);
    assert!(s.stats.nonmanifold_edges > 0);
}

#[test]
fn a_model_without_normals_with_many_soft_creases_gets_a_crease_angle_warning() {
    // A 16-sided cylinder without caps: its sides meet at 22.5°, creases at a 20° crease angle.
    let mut t = String::new();
    for z in [0, 1] {
        for s in 0..16 {
            let a = std::f32::consts::TAU * s as f32 / 16.0;
            t += &format!("v {} {} {z}\n", a.cos(), a.sin());
        }
    }
    for s in 0..16 {
        let (a, b) = (s + 1, (s + 1) % 16 + 1);
        t += &format!("f {a} {b} {} {}\n", b + 16, a + 16);
    }
    let warned = |angle: f32| {
        let s = load(&t, &LoadOptions { crease_angle_deg: angle, ..LoadOptions::default() });
        s.warnings.iter().any(|w| w.contains("16 of the 32 edges") && w.contains("--crease-angle"))
    };
    assert!(warned(20.0));
    assert!(!warned(30.0));
}

#[test]
fn a_box_without_normals_gets_no_crease_angle_warning() {
    let mut t = String::from("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n");
    for f in [[1, 4, 3, 2], [5, 6, 7, 8], [1, 2, 6, 5], [2, 3, 7, 6], [3, 4, 8, 7], [4, 1, 5, 8]] {
        t += &format!("f {} {} {} {}\n", f[0], f[1], f[2], f[3]);
    }
    let s = load(&t, &LoadOptions::default());
    assert_eq!(s.stats.crease_edges, 12);
    assert!(!s.warnings.iter().any(|w| w.contains("--crease-angle")), "{:?}", s.warnings);
}
