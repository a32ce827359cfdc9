//! Primary-ray throughput through Embree: native triangles, flat triangles as user geometry
//! (the floor of the callback route), and direct Phong patches, on a low-poly sphere.
//! `cargo bench --bench primary_rays` prints ns per ray; Mrays/s = 1000 / ns.
use criterion::{criterion_group, Criterion, Throughput};
use glam::Vec3;
use phongrt::embree::{Device, GeometryOptions, PhongMesh, Ray, Scene, UserTriangles};

fn camera_rays(w: u32, h: u32) -> Vec<Ray> {
    let eye = Vec3::new(0.0, 0.0, 3.0);
    let mut v = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let sx = (x as f32 + 0.5) / w as f32 * 2.0 - 1.0;
            let sy = 1.0 - (y as f32 + 0.5) / h as f32 * 2.0;
            v.push(Ray::new(eye, Vec3::new(sx * 0.45, sy * 0.45, -1.0)));
        }
    }
    v
}

fn bench(c: &mut Criterion) {
    let device = Device::with_config("threads=1").unwrap();
    let m = phongrt::scene::uv_sphere(12, 6, 1.0);
    let (p, n, idx) = (m.positions, m.normals, m.indices);
    let rays = camera_rays(128, 128);
    let mut native = Scene::new(&device).unwrap();
    native.attach_triangles(&p, &idx, GeometryOptions::default()).unwrap();
    let native = native.commit().unwrap();
    let mut user = Scene::new(&device).unwrap();
    user.attach_user(
        UserTriangles { positions: p.clone(), indices: idx.clone() },
        GeometryOptions::default(),
    )
    .unwrap();
    let user = user.commit().unwrap();

    let mut phong = Scene::new(&device).unwrap();
    phong.attach_phong(PhongMesh::new(&p, &n, &idx, 1.0).unwrap(), GeometryOptions::default()).unwrap();
    let phong = phong.commit().unwrap();

    let mut g = c.benchmark_group("primary_rays_sphere_12x6");
    g.throughput(Throughput::Elements(rays.len() as u64));
    for (name, scene) in [("native_triangles", &native), ("user_triangles", &user), ("phong_direct", &phong)]
    {
        g.bench_function(name, |b| {
            b.iter(|| rays.iter().filter(|r| scene.intersect1(**r).is_some()).count())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);

/// `criterion_main!`'s body, on one thread in the float mode Embree recommends (FTZ/DAZ), as
/// the renderer's threads run.
fn main() {
    let pool = phongrt::embree::thread_pool_builder().num_threads(1).build().expect("a thread pool");
    pool.install(|| {
        benches();
        Criterion::default().configure_from_args().final_summary();
    });
}
