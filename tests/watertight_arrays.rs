//! Watertight from the caller's own arrays: `PhongMesh::new` and the C API's
//! `phongrt_attach_mesh` weld by position and keep crease and border edges straight, so closed
//! meshes with split normals leak no ray from inside. The meshes are built here from raw arrays
//! (not the OBJ loader): scenes/cylinder_capped.obj as a triangle soup with split normals (flat
//! caps, radial sides), and a box whose faces have their own normals, tilted towards the corners.
use glam::Vec3;
use phongrt::embree::{CommittedScene, Device, GeometryOptions, PhongMesh, PhongMeshError, Ray, Scene};
use phongrt::phong::accuracy::SplitMix;
use std::process::Command;

mod common;

/// Raw arrays: positions, normals (one per vertex), triangles.
type Arrays = (Vec<Vec3>, Vec<Vec3>, Vec<[u32; 3]>);

/// scenes/cylinder_capped.obj as an exporter with hard rims would write it: every triangle its
/// own three vertices (a soup), cap corners with the cap's normal, side corners radial.
fn cylinder_soup() -> Arrays {
    let text = std::fs::read_to_string(common::root().join("scenes/cylinder_capped.obj")).unwrap();
    let mut v: Vec<Vec3> = Vec::new();
    let (mut p, mut n, mut idx) = (Vec::new(), Vec::new(), Vec::new());
    for line in text.lines() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => {
                let c: Vec<f32> = w.map(|x| x.parse().unwrap()).collect();
                v.push(Vec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let f: Vec<usize> =
                    w.map(|x| x.split('/').next().unwrap().parse::<usize>().unwrap() - 1).collect();
                let cap = f.iter().all(|&i| v[i].z == v[f[0]].z);
                for k in 1..f.len() - 1 {
                    for &i in &[f[0], f[k], f[k + 1]] {
                        p.push(v[i]);
                        n.push(if cap {
                            Vec3::new(0.0, 0.0, v[i].z.signum())
                        } else {
                            v[i] * Vec3::new(1.0, 1.0, 0.0)
                        });
                    }
                    let b = p.len() as u32 - 3;
                    idx.push([b, b + 1, b + 2]);
                }
            }
            _ => {}
        }
    }
    assert_eq!(idx.len(), 64, "16 side quads and 32 cap triangles");
    (p, n, idx)
}

/// A box of [-1, 1]^3, 4 vertices per face (24 in all), each face's normals tilted from the face
/// normal towards the corner: split at every edge, and curved (unlike face normals, which make
/// every patch flat).
fn split_normal_box() -> Arrays {
    let (mut p, mut n, mut idx) = (Vec::new(), Vec::new(), Vec::new());
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut face_n = Vec3::ZERO;
            face_n[axis] = sign;
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = p.len() as u32;
            for (s, t) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let mut q = face_n;
                q[a] = s;
                q[b] = t;
                p.push(q);
                n.push(face_n + 0.5 * q);
            }
            // Counter-clockwise seen from outside.
            let quad = if sign > 0.0 { [0, 1, 2, 3] } else { [0, 3, 2, 1] };
            idx.push([base + quad[0], base + quad[1], base + quad[2]]);
            idx.push([base + quad[0], base + quad[2], base + quad[3]]);
        }
    }
    (p, n, idx)
}

fn scene_of(device: &Device, mesh: PhongMesh) -> CommittedScene {
    let mut s = Scene::new(device).unwrap();
    s.attach_phong(mesh, GeometryOptions::default()).unwrap();
    s.commit().unwrap()
}

/// Rays escaping from four points inside, `per_origin` random directions each.
fn escapes(scene: &CommittedScene, per_origin: usize) -> usize {
    let origins =
        [Vec3::ZERO, Vec3::new(0.3, -0.4, 0.5), Vec3::new(-0.6, 0.2, -0.7), Vec3::new(0.5, 0.5, 0.9)];
    let mut r = SplitMix(7);
    origins
        .iter()
        .map(|&o| {
            (0..per_origin).filter(|_| scene.intersect1(Ray::new(o, r.unit().as_vec3())).is_none()).count()
        })
        .sum()
}

#[test]
fn phong_mesh_new_cylinder_soup_with_split_normals_leaks_no_ray_in_a_million() {
    let device = Device::new().unwrap();
    let (p, n, i) = cylinder_soup();
    let scene = scene_of(&device, PhongMesh::new(&p, &n, &i, 1.0).unwrap());
    let e = escapes(&scene, 250_000);
    assert_eq!(e, 0, "capped cylinder soup: {e} of 10^6 rays escaped");
}

#[test]
fn phong_mesh_new_split_normal_box_leaks_no_ray_in_a_million() {
    let device = Device::new().unwrap();
    let (p, n, i) = split_normal_box();
    let scene = scene_of(&device, PhongMesh::new(&p, &n, &i, 1.0).unwrap());
    let e = escapes(&scene, 250_000);
    assert_eq!(e, 0, "split-normal box: {e} of 10^6 rays escaped");
}

#[test]
fn plain_phong_of_the_same_arrays_leaks() {
    // The evidence for the default: without welding and straight edges both meshes part.
    let device = Device::new().unwrap();
    for (name, (p, n, i)) in [("cylinder", cylinder_soup()), ("box", split_normal_box())] {
        let mesh = PhongMesh::builder(&p, &n, &i).alpha(1.0).plain().build().unwrap();
        assert_eq!(mesh.straight_edge_count(), 0);
        let e = escapes(&scene_of(&device, mesh), 25_000);
        println!("{name}, plain Phong tessellation: {e} of 100000 rays escape");
        assert!(e > 100, "{name}: only {e} escapes: the arrays no longer show the crack the default fixes");
    }
}

#[test]
fn watertight_mesh_keeps_the_callers_prim_ids_and_corner_order() {
    // A hit's (primID, u, v) must name the caller's triangle and corners: the surface point there
    // is the hit point, and at alpha = 0 it is the caller's flat triangle.
    let device = Device::new().unwrap();
    let (p, n, idx) = cylinder_soup();
    let mesh = std::sync::Arc::new(PhongMesh::builder(&p, &n, &idx).alpha(0.0).build().unwrap());
    let mut s = Scene::new(&device).unwrap();
    s.attach_phong(mesh.clone(), GeometryOptions::default()).unwrap();
    let s = s.commit().unwrap();
    let mut r = SplitMix(3);
    for _ in 0..2000 {
        let ray = Ray::new(Vec3::new(0.1, 0.2, 0.3), r.unit().as_vec3());
        let h = s.intersect1(ray).expect("closed mesh");
        let t = idx[h.prim_id as usize].map(|k| p[k as usize]);
        let flat = t[0] * (1.0 - h.u - h.v) + t[1] * h.u + t[2] * h.v;
        let at = ray.org + ray.dir * h.t;
        assert!(
            flat.distance(at) < 1e-4,
            "prim {} (u, v) = ({}, {}): {flat} vs hit {at}",
            h.prim_id,
            h.u,
            h.v
        );
        let (sp, _) = mesh.surface_point(h.prim_id, h.u, h.v).unwrap();
        assert!(sp.distance(at) < 1e-4);
    }
    assert!(mesh.straight_edge_count() > 0);
}

#[test]
fn bad_arrays_are_refused_naming_what_is_wrong() {
    let (p, mut n, idx) = split_normal_box();
    let msg = |r: Result<PhongMesh, PhongMeshError>| r.unwrap_err().to_string();
    let e = msg(PhongMesh::new(&p, &n[..5], &idx, 1.0));
    assert!(e.contains("5 normals for 24 positions"), "{e}");
    let mut bad_idx = idx.clone();
    bad_idx[7][2] = 24;
    let e = msg(PhongMesh::new(&p, &n, &bad_idx, 1.0));
    assert!(e.contains("triangle 7 has vertex index 24") && e.contains("24 vertices"), "{e}");
    for alpha in [-0.1, 1.5, f32::NAN] {
        let e = msg(PhongMesh::new(&p, &n, &idx, alpha));
        assert!(e.contains("alpha") && e.contains("not in [0, 1]"), "{e}");
    }
    n[3] = Vec3::ZERO;
    let e = msg(PhongMesh::new(&p, &n, &idx, 1.0));
    assert_eq!(e, "vertex 3 has a zero normal (its triangles could never be hit)");
    // Zero in the plain builder too: an invisible triangle is never what the caller meant.
    assert!(msg(PhongMesh::builder(&p, &n, &idx).plain().build()).contains("vertex 3 has a zero normal"));
    n[3] = Vec3::new(f32::NAN, 0.0, 1.0);
    assert!(msg(PhongMesh::new(&p, &n, &idx, 1.0)).contains("vertex 3 has a non-finite"));
    n[3] = Vec3::Z;
    let mut q = p.clone();
    q[9].y = f32::INFINITY;
    assert!(msg(PhongMesh::new(&q, &n, &idx, 1.0)).contains("vertex 9 has a non-finite"));
    let e = msg(PhongMesh::builder(&p, &n, &idx).weld_tolerance(-1.0).build());
    assert!(e.contains("weld tolerance -1"), "{e}");
    let e = msg(PhongMesh::builder(&p, &n, &idx).straight_edges(&[[true; 3]; 3]).build());
    assert!(e.contains("3 per-triangle straight-edge flags for 12 triangles"), "{e}");
}

#[test]
fn c_program_attach_mesh_is_watertight_and_ex_plain_is_not() {
    let (_dir, exe) = common::compile_c(&common::root().join("tests/c/watertight.c"), "watertight");
    let run = Command::new(&exe).arg(common::root().join("scenes/cylinder_capped.obj")).output().unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    println!("{stdout}");
    assert!(run.status.success(), "C program failed:\n{stdout}\n{}", String::from_utf8_lossy(&run.stderr));
    // "cylinder escapes 0 of 1000000 (plain: N of 100000)", the same for the box.
    for name in ["cylinder", "box"] {
        let line = stdout.lines().find(|l| l.starts_with(name)).unwrap_or_else(|| panic!("no {name} line"));
        let w: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(&w[1..5], ["escapes", "0", "of", "1000000"], "{line}");
        let plain: usize = w[6].parse().unwrap();
        assert!(plain > 100, "{line}: plain tessellation no longer shows the crack");
    }
}
