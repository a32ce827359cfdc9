//! Where a Phong mesh's build time goes: the per-patch precomputation, Embree's commit of the user
//! geometry, and, for comparison, Embree's build of the same triangles.
//! `cargo run --release --example build_split -- MODEL.obj` (best of 5 runs each).
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use phongrt::embree::{Device, GeometryOptions, PhongMesh, Scene};
use phongrt::scene::{load_obj, LoadOptions};

fn main() -> anyhow::Result<()> {
    let path = PathBuf::from(std::env::args().nth(1).context("usage: build_split MODEL.obj")?);
    let scene = load_obj(&path, &LoadOptions::default())?;
    let m = scene.meshes.first().with_context(|| format!("{}: no mesh", path.display()))?;
    let device = Device::new()?;
    let straight = m.straight_edges();
    let (mut patches, mut commit, mut flat) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
    for _ in 0..5 {
        let t0 = Instant::now();
        let mesh =
            PhongMesh::with_straight_edges(&m.positions, &m.normals, &m.indices, 1.0, Some(&straight))?;
        let t1 = Instant::now();
        let mut s = Scene::new(&device)?;
        s.attach_phong(mesh, GeometryOptions::default())?;
        let t2 = Instant::now();
        let _s = s.commit()?;
        let t3 = Instant::now();
        let mut f = Scene::new(&device)?;
        f.attach_triangles(&m.positions, &m.indices, GeometryOptions::default())?;
        let _f = f.commit()?;
        let t4 = Instant::now();
        patches = patches.min((t1 - t0).as_secs_f64() * 1e3);
        commit = commit.min((t3 - t2).as_secs_f64() * 1e3);
        flat = flat.min((t4 - t3).as_secs_f64() * 1e3);
    }
    println!(
        "{}: {} triangles: patches {patches:.3} ms, Embree user-geometry commit {commit:.3} ms; flat triangles {flat:.3} ms (best of 5)",
        path.display(),
        m.indices.len()
    );
    Ok(())
}
