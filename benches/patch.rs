//! ns per patch test: analytic (plain and polished) and Newton, f32 and f64, hit and miss rays;
//! and the bounds computation. `cargo bench --bench patch`.
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use phongrt::phong::accuracy::{generate, Category, SplitMix};
use phongrt::phong::{intersect, Method, Patch, Real, V3};

fn cases<T: Real>(hit: bool) -> Vec<(Patch<T>, V3<T>, V3<T>)> {
    let mut rng = SplitMix(42);
    (0..256)
        .map(|_| {
            let c = generate(&mut rng, Category::RandomCurved);
            let p: Patch<T> = Patch::new(c.p, c.n, c.alpha);
            let mut d = c.dir;
            if !hit {
                // Aim past the patch: rotate the ray away from it.
                d = (d + (c.org - c.p[0]).normalize() * 3.0).normalize();
            }
            (p, V3::from(c.org).cast(), V3::from(d).cast())
        })
        .collect()
}

fn bench_t<T: Real>(c: &mut Criterion, name: &str) {
    for hit in [true, false] {
        let cs = cases::<T>(hit);
        for (mname, m) in [
            ("analytic", Method::Analytic),
            ("analytic_polished", Method::AnalyticPolished),
            ("newton", Method::Newton),
            ("certified", Method::Certified),
        ] {
            c.bench_function(&format!("{name}/{mname}/{}", if hit { "hit" } else { "miss" }), |b| {
                b.iter(|| {
                    let mut n = 0;
                    for (p, o, d) in &cs {
                        n += intersect(p, *o, *d, T::ZERO, T::from_f64(f64::INFINITY), m).is_some() as u32;
                    }
                    black_box(n)
                })
            });
        }
    }
}

fn benches(c: &mut Criterion) {
    bench_t::<f32>(c, "f32x256");
    bench_t::<f64>(c, "f64x256");
    let mut rng = SplitMix(1);
    let raw: Vec<_> = (0..256).map(|_| generate(&mut rng, Category::RandomCurved)).collect();
    c.bench_function("build_and_bounds_x256", |b| {
        b.iter(|| {
            for cs in &raw {
                let p: Patch<f32> = Patch::new(cs.p, cs.n, cs.alpha);
                black_box(p.bounds());
            }
        })
    });
}

criterion_group!(g, benches);
criterion_main!(g);
