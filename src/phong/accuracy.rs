//! The accuracy report: every method and precision against the reference, per category of
//! hard case. `phongrt accuracy` prints it; the tests assert its targets.

use glam::DVec3;

use super::intersect::{intersect, Method};
use super::patch::Patch;
use super::real::{Real, V3};
use super::reference::{reference_intersect, reference_point};
/// The case generator's RNG, from its neutral home [`crate::rng`] (kept here for existing users).
pub use crate::rng::SplitMix;

/// The categories of hard cases.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Category {
    /// Well-shaped triangles, normals tilted up to 0.7 rad, alpha in 0.5..1.
    RandomCurved,
    /// Normals within 1e-7..1e-2 rad of the face normal.
    NearFlat,
    /// Shape factor 0: the flat triangle.
    AlphaZero,
    /// All normals equal to the face normal, alpha > 0 (a flat patch).
    PlanarNormals,
    /// Normals tilted 60 to 80 degrees.
    StronglyCurved,
    /// Rays within 1e-5..1e-1 rad of the tangent plane.
    Grazing,
    /// Patches 10 to 1e5 units from the origin.
    FarFromOrigin,
    /// Patches of size 1e-4.
    Tiny,
    /// Patches of size 1e5.
    Huge,
    /// Ray directions of length 1e-4..1e4.
    DirectionScale,
}

impl Category {
    /// Every category, in the report's order.
    pub const ALL: [Category; 10] = [
        Category::RandomCurved,
        Category::NearFlat,
        Category::AlphaZero,
        Category::PlanarNormals,
        Category::StronglyCurved,
        Category::Grazing,
        Category::FarFromOrigin,
        Category::Tiny,
        Category::Huge,
        Category::DirectionScale,
    ];
    /// The category's label in the report.
    pub fn name(self) -> &'static str {
        match self {
            Category::RandomCurved => "random curved",
            Category::NearFlat => "near-flat (1e-7..1e-2 rad)",
            Category::AlphaZero => "alpha = 0",
            Category::PlanarNormals => "planar normals, alpha > 0",
            Category::StronglyCurved => "strongly curved (60-80 deg)",
            Category::Grazing => "grazing (1e-5..1e-1 rad)",
            Category::FarFromOrigin => "far from origin (10..1e5)",
            Category::Tiny => "tiny (1e-4)",
            Category::Huge => "huge (1e5)",
            Category::DirectionScale => "|dir| 1e-4..1e4",
        }
    }
}

/// One generated case: a patch, a ray, and how close to tangency the ray is.
#[derive(Clone, Debug)]
pub struct Case {
    /// The triangle's vertices.
    pub p: [DVec3; 3],
    /// The vertex normals.
    pub n: [DVec3; 3],
    /// The shape factor.
    pub alpha: f64,
    /// The ray's origin.
    pub org: DVec3,
    /// The ray's direction (not normalised).
    pub dir: DVec3,
    /// Angle between the ray and the tangent plane at the aimed point (radians).
    pub grazing_angle: f64,
    /// Patch size (largest corner distance from the centroid).
    pub size: f64,
}

fn tilt(rng: &mut SplitMix, n: DVec3, angle: f64) -> DVec3 {
    // Rotate n by `angle` towards a random perpendicular direction.
    let t = (rng.unit() - n * rng.unit().dot(n)).normalize_or(n.any_orthonormal_vector());
    let t = (t - n * t.dot(n)).normalize_or(n.any_orthonormal_vector());
    n * angle.cos() + t * angle.sin()
}

/// Generate a case of `cat`.
pub fn generate(rng: &mut SplitMix, cat: Category) -> Case {
    // A random well-shaped triangle around the origin, unit size.
    let mut p;
    loop {
        p = [
            rng.unit() * rng.range(0.5, 1.0),
            rng.unit() * rng.range(0.5, 1.0),
            rng.unit() * rng.range(0.5, 1.0),
        ];
        let area = (p[1] - p[0]).cross(p[2] - p[0]).length();
        let longest = [(p[1] - p[0]).length(), (p[2] - p[1]).length(), (p[0] - p[2]).length()]
            .into_iter()
            .fold(0.0, f64::max);
        if area > 0.15 * longest * longest {
            break;
        }
    }
    let fnorm = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
    let (angle_lo, angle_hi, alpha) = match cat {
        Category::NearFlat => (-1.0, -1.0, 1.0),
        Category::AlphaZero => (0.0, 0.7, 0.0),
        Category::PlanarNormals => (0.0, 0.0, rng.range(0.2, 1.0)),
        Category::StronglyCurved => (60f64.to_radians(), 80f64.to_radians(), 1.0),
        _ => (0.0, 0.7, rng.range(0.5, 1.0)),
    };
    let n = [0, 1, 2].map(|_| {
        let a = if angle_lo < 0.0 { rng.log_range(1e-7, 1e-2) } else { rng.range(angle_lo, angle_hi) };
        tilt(rng, fnorm, a)
    });
    // A target point strictly inside, and its true tangent plane (reference evaluation).
    let (u, v) = loop {
        let (u, v) = (rng.range(0.02, 0.96), rng.range(0.02, 0.96));
        if u + v < 0.98 {
            break (u, v);
        }
    };
    let pt = |u: f64, v: f64| reference_point(p, n, alpha, u, v).unwrap_or(DVec3::ZERO);
    let target = pt(u, v);
    let h = 1e-4;
    let tu = (pt(u + h, v) - pt(u - h, v)) / (2.0 * h);
    let tv = (pt(u, v + h) - pt(u, v - h)) / (2.0 * h);
    let ng = tu.cross(tv).normalize_or(fnorm);
    // The direction: from the front, at a random angle to the tangent plane.
    let (elev, grazing_angle) = match cat {
        Category::Grazing => {
            let g = rng.log_range(1e-5, 1e-1);
            (g, g)
        }
        _ => {
            let g = rng.range(0.15, std::f64::consts::FRAC_PI_2);
            (g, g)
        }
    };
    let tangent = {
        let t = rng.unit();
        (t - ng * t.dot(ng)).normalize_or(ng.any_orthonormal_vector())
    };
    let to_target = -(ng * elev.sin() + tangent * elev.cos());
    let dist = rng.range(1.0, 4.0);
    let mut case =
        Case { p, n, alpha, org: target - to_target * dist, dir: to_target, grazing_angle, size: 1.0 };
    // Placement, scale and direction magnitude.
    let (offset, scale, dscale) = match cat {
        Category::FarFromOrigin => (rng.unit() * rng.log_range(10.0, 1e5), 1.0, 1.0),
        Category::Tiny => (rng.unit(), 1e-4, 1.0),
        Category::Huge => (rng.unit(), 1e5, 1.0),
        Category::DirectionScale => (DVec3::ZERO, 1.0, rng.log_range(1e-4, 1e4)),
        _ => (DVec3::ZERO, 1.0, 1.0),
    };
    case.p = case.p.map(|q| q * scale + offset);
    case.org = case.org * scale + offset;
    case.dir *= dscale;
    let c = (case.p[0] + case.p[1] + case.p[2]) / 3.0;
    case.size = case.p.iter().map(|q| (*q - c).length()).fold(0.0, f64::max);
    case
}

/// Errors of one method on one case.
#[derive(Clone, Copy, Debug)]
pub enum Outcome {
    /// Both hit: the relative error of `t`, and the hit point's distance from the reference's
    /// relative to the patch size.
    Agree {
        /// `|t - t_ref| / t_ref`.
        rel_t: f64,
        /// `|hit - hit_ref| / size`.
        point_err: f64,
    },
    /// The reference hits, the method misses.
    FalseMiss,
    /// The method hits, the reference misses.
    FalseHit,
    /// Both miss.
    BothMiss,
}

/// Run `method` in precision `T` on `case` and compare with the reference.
pub fn evaluate<T: Real>(case: &Case, method: Method) -> Outcome {
    // Both solvers see the same input: the case rounded to T (in f32, coordinates of 1e5 carry
    // an input error of ~6e-3 that no solver can remove; it is not the solver's error).
    let r = |v: DVec3| -> DVec3 { V3::from(v).cast::<T>().to_f64().into() };
    let case =
        &Case { p: case.p.map(r), n: case.n.map(r), org: r(case.org), dir: r(case.dir), ..case.clone() };
    let reference =
        reference_intersect(case.p, case.n, case.alpha, [false; 3], case.org, case.dir, 0.0, f64::INFINITY);
    let patch: Patch<T> = Patch::new(case.p, case.n, case.alpha);
    let o: V3<T> = V3::from(case.org).cast();
    let d: V3<T> = V3::from(case.dir).cast();
    let hit = intersect(&patch, o, d, T::ZERO, T::from_f64(f64::INFINITY), method);
    match (reference, hit) {
        (Some(r), Some(h)) => {
            let t = h.t.to_f64();
            let rel_t = ((t - r.t) / r.t).abs();
            let hp = case.org + case.dir * t;
            let rp = case.org + case.dir * r.t;
            Outcome::Agree { rel_t, point_err: (hp - rp).length() / case.size }
        }
        (Some(_), None) => Outcome::FalseMiss,
        (None, Some(_)) => Outcome::FalseHit,
        (None, None) => Outcome::BothMiss,
    }
}

/// Summary for one (method, precision, category).
#[derive(Clone, Debug)]
pub struct Row {
    /// The method's label (`analytic`, `analytic+polish`, `newton`, `certified`).
    pub method: &'static str,
    /// `f32` or `f64`.
    pub precision: &'static str,
    /// The category of cases.
    pub category: Category,
    /// Cases where both hit (the error columns are over these).
    pub cases: usize,
    /// The relative `t` error: median, 99th percentile, maximum.
    pub rel_t: [f64; 3],
    /// The hit point's error relative to the patch size: median, 99th percentile, maximum.
    pub point: [f64; 3],
    /// False misses.
    pub false_miss: usize,
    /// False hits.
    pub false_hit: usize,
    /// False misses of rays within 1e-4 rad of tangency (allowed by the targets).
    pub false_miss_near_tangent: usize,
}

fn percentiles(mut v: Vec<f64>) -> [f64; 3] {
    if v.is_empty() {
        return [0.0; 3];
    }
    v.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    [q(0.5), q(0.99), q(1.0)]
}

/// The whole report.
#[derive(Clone, Debug)]
pub struct AccuracyReport {
    /// One row per (method, precision, category).
    pub rows: Vec<Row>,
    /// Cases generated per category.
    pub rays_per_category: usize,
    /// The generator's seed.
    pub seed: u64,
}

type Eval = fn(&Case, Method) -> Outcome;

/// Run every method and precision on `rays_per_category` cases of every category.
pub fn report(rays_per_category: usize, seed: u64) -> AccuracyReport {
    let methods: [(&'static str, Method); 4] = [
        ("analytic", Method::Analytic),
        ("analytic+polish", Method::AnalyticPolished),
        ("newton", Method::Newton),
        ("certified", Method::Certified),
    ];
    let precisions: [(&'static str, Eval); 2] = [("f32", evaluate::<f32>), ("f64", evaluate::<f64>)];
    let mut rows = Vec::new();
    for cat in Category::ALL {
        let mut rng = SplitMix(seed ^ (cat as u64).wrapping_mul(0x2545_F491_4F6C_DD1D));
        let cases: Vec<Case> = (0..rays_per_category).map(|_| generate(&mut rng, cat)).collect();
        for (pname, eval) in precisions {
            for (mname, m) in methods {
                let (mut ts, mut ps) = (Vec::new(), Vec::new());
                let (mut fm, mut fh, mut fm_tan) = (0, 0, 0);
                for c in &cases {
                    match eval(c, m) {
                        Outcome::Agree { rel_t, point_err } => {
                            ts.push(rel_t);
                            ps.push(point_err);
                        }
                        Outcome::FalseMiss => {
                            fm += 1;
                            if c.grazing_angle < 1e-4 {
                                fm_tan += 1;
                            }
                        }
                        Outcome::FalseHit => fh += 1,
                        Outcome::BothMiss => {}
                    }
                }
                rows.push(Row {
                    method: mname,
                    precision: pname,
                    category: cat,
                    cases: cases.len(),
                    rel_t: percentiles(ts),
                    point: percentiles(ps),
                    false_miss: fm,
                    false_hit: fh,
                    false_miss_near_tangent: fm_tan,
                });
            }
        }
    }
    AccuracyReport { rows, rays_per_category, seed }
}

impl std::fmt::Display for AccuracyReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "Accuracy against the subdivision reference: {} rays per category, seed {}.",
            self.rays_per_category, self.seed
        )?;
        writeln!(f, "rel t = |t - t_ref| / t_ref; point = |hit - hit_ref| / patch size; p50 / p99 / max.")?;
        writeln!(f)?;
        writeln!(f, "| method | prec | category | rel t p50 | rel t p99 | rel t max | point p99 | point max | false miss (near tangent) | false hit |")?;
        writeln!(f, "|---|---|---|---|---|---|---|---|---|---|")?;
        for r in &self.rows {
            writeln!(
                f,
                "| {} | {} | {} | {:.1e} | {:.1e} | {:.1e} | {:.1e} | {:.1e} | {} ({}) | {} |",
                r.method,
                r.precision,
                r.category.name(),
                r.rel_t[0],
                r.rel_t[1],
                r.rel_t[2],
                r.point[1],
                r.point[2],
                r.false_miss,
                r.false_miss_near_tangent,
                r.false_hit
            )?;
        }
        Ok(())
    }
}
