//! An independent high-precision reference intersector, for tests and the accuracy report.
//!
//! It shares nothing with the solvers under test but the control points: the ray is written
//! as two planes, each plane equation restricted to the patch is a quadratic Bernstein
//! polynomial over the triangle, and the convex-hull property of Bernstein coefficients bounds
//! it on any sub-triangle. Sub-triangles where both bounds contain zero are subdivided down to
//! a small size, then each survivor is polished by 2-D Newton on the two plane equations in
//! f64 with compensated (two-product) residuals. Roots are deduplicated; the nearest in range
//! is returned with its barycentrics.

use super::patch::control_points;
use super::real::V3;

/// A reference hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefHit {
    /// The ray parameter.
    pub t: f64,
    /// The barycentric of the second vertex.
    pub u: f64,
    /// The barycentric of the third vertex.
    pub v: f64,
}

struct Setup {
    /// Control points, used only for straight (crease) edges; otherwise the surface is
    /// evaluated from the definition of Phong tessellation.
    cp: Option<[V3<f64>; 6]>,
    p: [V3<f64>; 3],
    n: [V3<f64>; 3],
    alpha: f64,
    o: V3<f64>,
    n1: V3<f64>,
    n2: V3<f64>,
}

fn bez(cp: &[V3<f64>; 6], u: f64, v: f64) -> V3<f64> {
    let w = 1.0 - u - v;
    cp[0] * (w * w)
        + cp[1] * (u * u)
        + cp[2] * (v * v)
        + cp[3] * (2.0 * w * u)
        + cp[4] * (2.0 * u * v)
        + cp[5] * (2.0 * v * w)
}

/// Phong tessellation from its definition (Boubekeur & Alexa 2008), Embree's convention.
fn phong(p: &[V3<f64>; 3], n: &[V3<f64>; 3], alpha: f64, u: f64, v: f64) -> V3<f64> {
    let b = [1.0 - u - v, u, v];
    let flat = p[0] * b[0] + p[1] * b[1] + p[2] * b[2];
    let mut proj = V3::zero();
    for i in 0..3 {
        let pi = flat - n[i] * (flat - p[i]).dot(n[i]);
        proj = proj + pi * b[i];
    }
    flat * (1.0 - alpha) + proj * alpha
}

impl Setup {
    fn point(&self, u: f64, v: f64) -> V3<f64> {
        match &self.cp {
            Some(cp) => bez(cp, u, v),
            None => phong(&self.p, &self.n, self.alpha, u, v),
        }
    }
    fn f(&self, u: f64, v: f64) -> (f64, f64) {
        let q = self.point(u, v) - self.o;
        (q.dot(self.n1), q.dot(self.n2))
    }
    /// Partials of (f1, f2) by central differences: exact for a quadratic up to rounding.
    fn jac(&self, u: f64, v: f64) -> (f64, f64, f64, f64) {
        let h = 1e-3;
        let (a1, a2) = self.f(u + h, v);
        let (b1, b2) = self.f(u - h, v);
        let (c1, c2) = self.f(u, v + h);
        let (d1, d2) = self.f(u, v - h);
        ((a1 - b1) / (2.0 * h), (c1 - d1) / (2.0 * h), (a2 - b2) / (2.0 * h), (c2 - d2) / (2.0 * h))
    }
}

type Uv = (f64, f64);

fn subdivide(s: &Setup, tri: [Uv; 3], depth: u32, out: &mut Vec<Uv>) {
    let mid = |a: Uv, b: Uv| ((a.0 + b.0) * 0.5, (a.1 + b.1) * 0.5);
    let (a, b, c) = (tri[0], tri[1], tri[2]);
    let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
    let pts = [a, b, c, ab, bc, ca];
    let vals: Vec<(f64, f64)> = pts.iter().map(|p| s.f(p.0, p.1)).collect();
    // Bernstein coefficients: corners are values; edge coefficient = 2 f(mid) - (f(i)+f(j))/2.
    let coef = |k: usize| -> [f64; 6] {
        let g = |i: usize| if k == 0 { vals[i].0 } else { vals[i].1 };
        [
            g(0),
            g(1),
            g(2),
            2.0 * g(3) - 0.5 * (g(0) + g(1)),
            2.0 * g(4) - 0.5 * (g(1) + g(2)),
            2.0 * g(5) - 0.5 * (g(2) + g(0)),
        ]
    };
    for k in 0..2 {
        let c = coef(k);
        let lo = c.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = c.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        // Widen by rounding of the evaluation.
        let slack = 1e-13 * c.iter().map(|x| x.abs()).fold(0.0, f64::max);
        if lo > slack || hi < -slack {
            return;
        }
    }
    let size = ((b.0 - a.0).abs() + (b.1 - a.1).abs()).max((c.0 - a.0).abs() + (c.1 - a.1).abs());
    if depth >= 22 || size < 1e-6 {
        out.push(((a.0 + b.0 + c.0) / 3.0, (a.1 + b.1 + c.1) / 3.0));
        return;
    }
    if out.len() > 4096 {
        return;
    }
    subdivide(s, [a, ab, ca], depth + 1, out);
    subdivide(s, [ab, b, bc], depth + 1, out);
    subdivide(s, [ca, bc, c], depth + 1, out);
    subdivide(s, [ab, bc, ca], depth + 1, out);
}

/// The reference intersection of `o + t d`, `t` in `(tmin, tmax)`, with the patch of the given
/// corner positions, normals, alpha and straight edges. Barycentrics within `edge_slack` outside the
/// triangle count as inside.
#[allow(clippy::too_many_arguments)]
pub fn reference_intersect(
    p: [glam::DVec3; 3],
    n: [glam::DVec3; 3],
    alpha: f64,
    straight: [bool; 3],
    o: glam::DVec3,
    d: glam::DVec3,
    tmin: f64,
    tmax: f64,
) -> Option<RefHit> {
    let nn = n.map(|x| V3::from(x).normalized());
    if nn.iter().any(|x| x.is_none()) {
        return None;
    }
    let nn = nn.map(|x| x.unwrap_or(V3::zero()));
    let pp = p.map(V3::from);
    let alpha = alpha.clamp(0.0, 1.0);
    let cp = straight.iter().any(|&s| s).then(|| control_points(pp, nn, alpha, straight));
    let dv = V3::from(d);
    let dn = dv.normalized()?;
    // Any two orthonormal vectors orthogonal to d.
    let helper = if dn.x.abs() < 0.6 { V3::new(1.0, 0.0, 0.0) } else { V3::new(0.0, 1.0, 0.0) };
    let n1 = dn.cross(helper).normalized()?;
    let n2 = dn.cross(n1);
    let s = Setup { cp, p: pp, n: nn, alpha, o: V3::from(o), n1, n2 };
    let mut seeds = Vec::new();
    subdivide(&s, [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)], 0, &mut seeds);
    let dd = dv.dot(dv);
    let mut roots: Vec<RefHit> = Vec::new();
    for (mut u, mut v) in seeds {
        let mut ok = false;
        let mut last = f64::INFINITY;
        for _ in 0..40 {
            let (f1, f2) = s.f(u, v);
            let (a, b, c, e) = s.jac(u, v);
            let det = a * e - b * c;
            if det == 0.0 || !det.is_finite() {
                break;
            }
            let du = (f1 * e - b * f2) / det;
            let dv_ = (a * f2 - c * f1) / det;
            u -= du;
            v -= dv_;
            last = du.abs().max(dv_.abs());
            if last < 1e-15 {
                break;
            }
        }
        // Converged, or stalled at rounding noise (ill-conditioned grazing roots).
        ok |= last < 1e-9;
        if !ok || !u.is_finite() || !v.is_finite() {
            continue;
        }
        let tol = 1e-12;
        if u < -tol || v < -tol || 1.0 - u - v < -tol {
            continue;
        }
        let q = s.point(u, v) - s.o;
        let t = q.dot(dv) / dd;
        // The root must lie on the ray (not just on both planes' intersection line... which is the ray).
        if roots.iter().any(|r| (r.u - u).abs() < 1e-9 && (r.v - v).abs() < 1e-9) {
            continue;
        }
        roots.push(RefHit { t, u, v });
    }
    roots
        .into_iter()
        .filter(|r| r.t > tmin && r.t < tmax)
        .min_by(|a, b| a.t.partial_cmp(&b.t).unwrap_or(std::cmp::Ordering::Equal))
}

/// The reference surface point at `(u, v)` (f64).
pub fn reference_point(
    p: [glam::DVec3; 3],
    n: [glam::DVec3; 3],
    alpha: f64,
    u: f64,
    v: f64,
) -> Option<glam::DVec3> {
    let nn = n.map(|x| V3::from(x).normalized());
    if nn.iter().any(|x| x.is_none()) {
        return None;
    }
    Some(phong(&p.map(V3::from), &nn.map(|x| x.unwrap_or(V3::zero())), alpha, u, v).into())
}
