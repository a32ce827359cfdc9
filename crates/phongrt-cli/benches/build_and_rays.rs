//! Flat against direct Phong on real models: BVH build time, memory, primary-ray Mrays/s.
//! `cargo bench --bench build_and_rays` prints a table (no criterion: each number is the median
//! of repeated runs, printed with what it measures). Models: the generated 12x6 sphere, and the
//! low-poly head and wuson from ../shared/corpus when present.
use std::path::Path;
use std::time::Instant;

use glam::Vec3;
use phongrt::embree::{CommittedScene, Device, GeometryOptions, PhongMesh, Ray, Scene};
use phongrt::scene::{load_obj, uv_sphere, LoadOptions, Mesh};
use phongrt_cli::bench::median;
use phongrt_render::Camera;

fn build(device: &Device, m: &Mesh, phong: bool) -> (CommittedScene, f64, i64, usize) {
    let before = device.memory_bytes().0;
    let t = Instant::now();
    let mut s = Scene::new(device).unwrap();
    let own = if phong {
        let pm = PhongMesh::new(&m.positions, &m.normals, &m.indices, 1.0).unwrap();
        let own = pm.memory_bytes();
        s.attach_phong(pm, GeometryOptions::default()).unwrap();
        own
    } else {
        s.attach_triangles(&m.positions, &m.indices, GeometryOptions::default()).unwrap();
        0
    };
    let s = s.commit().unwrap();
    let secs = t.elapsed().as_secs_f64();
    (s, secs, device.memory_bytes().0 - before, own)
}

/// On one thread in the float mode Embree recommends (FTZ/DAZ), as the renderer's threads run.
fn main() {
    let pool = phongrt::embree::thread_pool_builder().num_threads(1).build().expect("a thread pool");
    pool.install(bench_main);
}

fn bench_main() {
    let device = Device::with_config("threads=1").unwrap();
    let mut models: Vec<(String, Mesh)> = vec![("sphere 12x6".into(), uv_sphere(12, 6, 1.0))];
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/corpus");
    for (name, rel) in [("african_head", "african_head/african_head.obj"), ("wuson", "wuson/WusonOBJ.obj")] {
        let p = corpus.join(rel);
        if p.exists() {
            let s = load_obj(&p, &LoadOptions::default()).unwrap();
            models.push((name.into(), s.meshes.into_iter().next().unwrap()));
        } else {
            println!("skipped {name}: {} is absent", p.display());
        }
    }
    println!(
        "| model | triangles | mode | build ms | Embree bytes | own bytes | primary Mrays/s (1 thread) |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (name, m) in &models {
        let (lo, hi) = m
            .positions
            .iter()
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| (a.min(*p), b.max(*p)));
        let frame = Camera::frame_bounds(lo, hi, 1.0).frame(1.0).unwrap();
        let (w, h) = (256u32, 256u32);
        let rays: Vec<Ray> = (0..w * h)
            .map(|i| Ray::new(frame.eye, frame.direction((i % w) as f32 + 0.5, (i / w) as f32 + 0.5, w, h)))
            .collect();
        for phong in [false, true] {
            let mut builds = Vec::new();
            let mut last = None;
            for _ in 0..5 {
                let (s, secs, mem, own) = build(&device, m, phong);
                builds.push(secs);
                last = Some((s, mem, own));
            }
            let (scene, mem, own) = last.unwrap();
            let mut rates = Vec::new();
            for _ in 0..5 {
                let t = Instant::now();
                let hits = rays.iter().filter(|r| scene.intersect1(**r).is_some()).count();
                std::hint::black_box(hits);
                rates.push(rays.len() as f64 / t.elapsed().as_secs_f64() / 1e6);
            }
            println!(
                "| {name} | {} | {} | {:.2} | {mem} | {own} | {:.2} |",
                m.indices.len(),
                if phong { "phong" } else { "flat" },
                median(&mut builds) * 1e3,
                median(&mut rates)
            );
        }
    }
}
