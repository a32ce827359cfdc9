//! OBJ loading: every bad-input class gives a one-line error naming the file (and line), or a
//! warning with counts; triangulation, smoothing groups, crease angles, welding, edge classes;
//! and every model of ../shared/corpus loads or is refused with a clear reason.
mod common;

use std::path::{Path, PathBuf};

use glam::Vec3;
use phongrt::scene::{load_obj, uv_sphere, EdgeKind, LoadOptions, SceneError};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn load_text(text: &str) -> Result<phongrt::scene::Model, SceneError> {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "t.obj", text);
    load_obj(&p, &LoadOptions::default())
}

fn one_line_naming(e: &SceneError, file: &str) -> String {
    let s = e.to_string();
    assert!(!s.contains('\n'), "multi-line error: {s}");
    assert!(s.contains(file), "error does not name {file}: {s}");
    s
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

#[test]
fn missing_file() {
    let e = load_obj(Path::new("/nonexistent/dir/model.obj"), &LoadOptions::default()).unwrap_err();
    let s = one_line_naming(&e, "model.obj");
    assert!(s.contains("cannot read"), "{s}");
}

#[test]
fn malformed_line_names_the_line() {
    let e = load_text(&format!("{TRI}v 1 2 banana\nf 1 2 3\n")).unwrap_err();
    let s = one_line_naming(&e, "t.obj");
    assert!(s.contains(":4:") && s.contains("banana"), "{s}");
    let e = load_text(&format!("{TRI}f 1/2/3/4 2 3\n")).unwrap_err();
    assert!(e.to_string().contains(":4:"), "{e}");
}

#[test]
fn index_out_of_range() {
    let e = load_text(&format!("{TRI}f 1 2 4\n")).unwrap_err();
    let s = one_line_naming(&e, "t.obj");
    assert!(s.contains(":4:") && s.contains("out of range"), "{s}");
    let e = load_text(&format!("{TRI}f -4 2 3\n")).unwrap_err();
    assert!(e.to_string().contains("out of range"), "{e}");
    let e = load_text(&format!("{TRI}vn 0 0 1\nf 1//2 2//1 3//1\n")).unwrap_err();
    assert!(e.to_string().contains("normal index"), "{e}");
    let e = load_text(&format!("{TRI}f 0 1 2\n")).unwrap_err();
    assert!(e.to_string().contains("out of range"), "{e}");
}

#[test]
fn non_finite_coordinates() {
    for bad in ["nan", "inf", "-inf", "1e39"] {
        let e = load_text(&format!("v 0 0 0\nv 1 0 {bad}\nv 0 1 0\nf 1 2 3\n")).unwrap_err();
        let s = one_line_naming(&e, "t.obj");
        assert!(s.contains(":2:") && s.contains("finite"), "{bad}: {s}");
    }
}

#[test]
fn zero_length_normal_is_replaced_with_a_warning() {
    let s = load_text(&format!("{TRI}vn 0 0 0\nvn 0 0 1\nf 1//1 2//2 3//2\n")).unwrap();
    assert!(s.warnings.iter().any(|w| w.contains("1 zero-length")), "{:?}", s.warnings);
    let m = &s.meshes[0];
    assert!(m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-5 && n.z > 0.99));
}

#[test]
fn degenerate_triangles_are_skipped_and_counted() {
    let s = load_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 3\n").unwrap();
    assert_eq!(s.stats.degenerate_skipped, 2);
    assert!(s.warnings.iter().any(|w| w.contains("skipped 2 degenerate")), "{:?}", s.warnings);
    assert_eq!(s.stats.triangles, 1);
}

#[test]
fn empty_mesh_is_an_error() {
    let e = load_text("# nothing\nv 0 0 0\n").unwrap_err();
    let s = one_line_naming(&e, "t.obj");
    assert!(s.contains("no triangles"), "{s}");
    let e = load_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").unwrap_err();
    assert!(e.to_string().contains("degenerate"), "{e}");
    let e = load_text("").unwrap_err();
    assert!(e.to_string().contains("no triangles"), "{e}");
}

#[test]
fn binary_file_is_refused() {
    let e = load_text("v 0 0 0\0\u{1}\u{2}").unwrap_err();
    one_line_naming(&e, "t.obj");
}

#[test]
fn missing_mtl_and_texture_are_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "m.obj", &format!("mtllib nothere.mtl\nusemtl red\n{TRI}f 1 2 3\n"));
    let s = load_obj(&p, &LoadOptions::default()).unwrap();
    assert!(s.warnings.iter().any(|w| w.contains("nothere.mtl")), "{:?}", s.warnings);
    write(dir.path(), "tex.mtl", "newmtl red\nKd 1 0 0\nmap_Kd .\\textures\\missing.png\n");
    let p = write(dir.path(), "t.obj", &format!("mtllib tex.mtl\nusemtl red\n{TRI}f 1 2 3\n"));
    let s = load_obj(&p, &LoadOptions::default()).unwrap();
    assert!(
        s.warnings.iter().any(|w| w.contains("missing.png") && w.contains("not found")),
        "{:?}",
        s.warnings
    );
    assert_eq!(s.materials[0].kd, Vec3::new(1.0, 0.0, 0.0));
    assert_eq!(s.meshes[0].material, Some(0));
    let s = load_text(&format!("usemtl x\n{TRI}f 1 2 3\n")).unwrap();
    assert!(s.warnings.iter().any(|w| w.contains("without `mtllib`")), "{:?}", s.warnings);
}

#[test]
fn concave_polygon_is_triangulated_inside() {
    // An L-shaped hexagon (area 3): a fan from corner 0 would leave it.
    let s = load_text("v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nf 1 2 3 4 5 6\n").unwrap();
    let m = &s.meshes[0];
    assert_eq!(m.indices.len(), 4);
    let mut area = 0.0;
    for t in &m.indices {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        let cross = (b - a).cross(c - a);
        assert!(cross.z > 0.0, "triangle flipped: {t:?}");
        area += 0.5 * cross.length();
        let centroid = (a + b + c) / 3.0;
        assert!(!(centroid.x > 1.0 && centroid.y > 1.0), "triangle outside the L: {t:?}");
    }
    assert!((area - 3.0).abs() < 1e-5, "area {area}");
}

#[test]
fn quads_negative_indices_and_continuations() {
    let s = load_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf -4 -3 \\\n -2 -1\n").unwrap();
    assert_eq!(s.stats.triangles, 2);
}

fn cube(split_normals: bool, smoothing: &str) -> String {
    let mut t =
        String::from("v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n");
    t += smoothing;
    // Outward-wound quads.
    let faces = [[1, 4, 3, 2], [5, 6, 7, 8], [1, 2, 6, 5], [2, 3, 7, 6], [3, 4, 8, 7], [4, 1, 5, 8]];
    let normals = ["0 0 -1", "0 0 1", "0 -1 0", "1 0 0", "0 1 0", "-1 0 0"];
    if split_normals {
        for n in normals {
            t += &format!("vn {n}\n");
        }
    }
    for (k, f) in faces.iter().enumerate() {
        if split_normals {
            t += &format!("f {}//{n} {}//{n} {}//{n} {}//{n}\n", f[0], f[1], f[2], f[3], n = k + 1);
        } else {
            t += &format!("f {} {} {} {}\n", f[0], f[1], f[2], f[3]);
        }
    }
    t
}

#[test]
fn cube_with_split_normals_has_only_crease_edges() {
    let s = load_text(&cube(true, "")).unwrap();
    assert_eq!(s.stats.vertices, 24);
    // 12 cube edges are creases, 6 face diagonals are smooth, none is a border.
    assert_eq!(s.stats.crease_edges, 12);
    assert_eq!(s.stats.smooth_edges, 6);
    assert_eq!(s.stats.border_edges, 0);
}

#[test]
fn crease_angle_controls_computed_normals() {
    let sharp = load_text(&cube(false, "")).unwrap();
    assert_eq!(sharp.stats.vertices, 24, "30 degrees: every cube edge is a crease");
    let o = LoadOptions { crease_angle_deg: 100.0, ..Default::default() };
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "c.obj", &cube(false, ""));
    let smooth = load_obj(&p, &o).unwrap();
    assert_eq!(smooth.stats.vertices, 8, "100 degrees: one normal per corner");
    for (p, n) in smooth.meshes[0].positions.iter().zip(&smooth.meshes[0].normals) {
        assert!(p.normalize().dot(*n) > 0.999, "corner normal not diagonal: {p} {n}");
    }
    assert_eq!(smooth.stats.crease_edges, 0);
}

#[test]
fn smoothing_groups_are_honoured() {
    let all_smooth = load_text(&cube(false, "s 1\n")).unwrap();
    assert_eq!(all_smooth.stats.vertices, 8);
    let off = load_text(&cube(false, "s off\n")).unwrap();
    assert_eq!(off.stats.vertices, 24);
}

#[test]
fn welding_joins_duplicated_positions() {
    // Two triangles with their own copies of the shared edge's positions (within tolerance).
    let s = load_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 0 0.0000000001\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 4 6 5\n")
        .unwrap();
    assert_eq!(s.stats.vertices, 4);
    assert_eq!(s.stats.smooth_edges, 1);
    assert_eq!(s.stats.border_edges, 4);
}

#[test]
fn sphere_generator_is_closed_and_smooth() {
    let m = uv_sphere(16, 8, 1.0);
    assert!(m.edge_kinds.iter().flatten().all(|e| *e == EdgeKind::Smooth));
    for (p, n) in m.positions.iter().zip(&m.normals) {
        assert!((p.length() - 1.0).abs() < 1e-6 && p.dot(*n) > 0.99999);
    }
    // Outward winding.
    for t in &m.indices {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
    }
}

#[test]
fn computed_normals_of_a_sphere_approximate_the_analytic_ones() {
    let dir = tempfile::tempdir().unwrap();
    let m = uv_sphere(24, 12, 1.0);
    let mut text = String::new();
    for p in &m.positions {
        text += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for t in &m.indices {
        text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    let p = write(dir.path(), "s.obj", &text);
    let s = load_obj(&p, &LoadOptions::default()).unwrap();
    assert_eq!(s.stats.normals_computed, m.positions.len());
    for (p, n) in s.meshes[0].positions.iter().zip(&s.meshes[0].normals) {
        assert!(p.normalize().dot(*n) > 0.995, "{p} {n}");
    }
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn every_corpus_model_loads_or_is_refused_clearly() {
    let c = common::corpus_required();
    let mut n = 0;
    for entry in std::fs::read_dir(&c).unwrap() {
        let dir = entry.unwrap().path();
        if !dir.is_dir() {
            continue;
        }
        for f in std::fs::read_dir(&dir).unwrap() {
            let f = f.unwrap().path();
            if f.extension().is_some_and(|e| e == "obj") {
                n += 1;
                match load_obj(&f, &LoadOptions::default()) {
                    Ok(s) => {
                        assert!(s.stats.triangles > 0);
                        for m in &s.meshes {
                            assert_eq!(m.positions.len(), m.normals.len());
                            assert!(
                                m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4),
                                "{}",
                                f.display()
                            );
                            assert!(m.indices.iter().flatten().all(|&i| (i as usize) < m.positions.len()));
                        }
                        println!(
                            "{}: {} triangles, {} warnings",
                            f.display(),
                            s.stats.triangles,
                            s.warnings.len()
                        );
                    }
                    Err(e) => {
                        let s = e.to_string();
                        assert!(
                            !s.contains('\n') && s.contains(&*f.file_name().unwrap().to_string_lossy()),
                            "{s}"
                        );
                        println!("{}: refused: {s}", f.display());
                    }
                }
            }
        }
    }
    assert!(n >= 10, "only {n} corpus models found");
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn corpus_concave_polygon_keeps_its_area() {
    let c = common::corpus_required();
    let s = load_obj(&c.join("concave_polygon/concave_polygon.obj"), &LoadOptions::default()).unwrap();
    // 66 indices over 64 vertices (some repeated): n-2 triangles, all facing one way.
    let m = &s.meshes[0];
    let n0 = {
        let [a, b, c] = m.indices[0].map(|i| m.positions[i as usize]);
        (b - a).cross(c - a).normalize()
    };
    for t in &m.indices {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        assert!((b - a).cross(c - a).dot(n0) > 0.0, "flipped triangle in the concave polygon");
    }
}
