//! Conics: the ray's two planes, the patch projected into a pair of conics, the pencil's
//! degenerate members split into lines, and line–conic intersection.

use super::poly::solve_quadratic;
use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// A symmetric 3×3 conic matrix `[[a, c/2, d/2], [c/2, b, e/2], [d/2, e/2, f]]` for
/// `a u² + b v² + c uv + d u + e v + f`, stored as the 6 polynomial coefficients.
#[derive(Clone, Copy, Debug)]
pub(super) struct Conic<T> {
    pub(super) k: [T; 6], // a, b, c, d, e, f
}

impl<T: Real> Conic<T> {
    #[inline(always)]
    pub(super) fn mat(&self) -> [[T; 3]; 3] {
        let h = T::from_f64(0.5);
        let [a, b, c, d, e, f] = self.k;
        [[a, c * h, d * h], [c * h, b, e * h], [d * h, e * h, f]]
    }
    #[inline(always)]
    pub(super) fn norm(&self) -> T {
        self.k.iter().fold(T::ZERO, |m, x| m.max(x.abs()))
    }
    #[inline(always)]
    pub(super) fn at(&self, u: T, v: T) -> T {
        let [a, b, c, d, e, f] = self.k;
        a * u * u + b * v * v + c * u * v + d * u + e * v + f
    }
}

pub(super) fn det3<T: Real>(m: &[[T; 3]; 3]) -> T {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

pub(super) fn adj3<T: Real>(m: &[[T; 3]; 3]) -> [[T; 3]; 3] {
    let c = |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    // adj = transpose of the cofactor matrix.
    [
        [c(1, 2, 1, 2), -c(0, 2, 1, 2), c(0, 1, 1, 2)],
        [-c(1, 2, 0, 2), c(0, 2, 0, 2), -c(0, 1, 0, 2)],
        [c(1, 2, 0, 1), -c(0, 2, 0, 1), c(0, 1, 0, 1)],
    ]
}

pub(super) fn trace_prod<T: Real>(a: &[[T; 3]; 3], b: &[[T; 3]; 3]) -> T {
    let mut s = T::ZERO;
    for i in 0..3 {
        for j in 0..3 {
            s = s + a[i][j] * b[j][i];
        }
    }
    s
}

/// Why a degenerate member gave no real lines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum NoLines {
    /// Clearly a pair of complex lines (a real point): in exact arithmetic too.
    PointLike,
    /// Within rounding of a real line pair, or unusable (zero): another precision may differ.
    Unsure,
}

/// Split a degenerate conic into its two lines `(l0, l1, l2)`: `l0 u + l1 v + l2 = 0`.
/// A point-like conic (a pair of complex lines) has none.
pub(super) fn split_degenerate<T: Real>(h: &[[T; 3]; 3]) -> Result<[[T; 3]; 2], NoLines> {
    let hn = h.iter().flatten().fold(T::ZERO, |m, x| m.max(x.abs()));
    if hn == T::ZERO {
        return Err(NoLines::Unsure);
    }
    let b = adj3(h);
    let bn = b.iter().flatten().fold(T::ZERO, |m, x| m.max(x.abs()));
    // Rank 1 (a double line): the adjugate vanishes up to rounding.
    if bn <= T::gamma(32) * hn * hn {
        let i = (0..3)
            .max_by(|&i, &j| {
                let ni = h[i][0].abs() + h[i][1].abs() + h[i][2].abs();
                let nj = h[j][0].abs() + h[j][1].abs() + h[j][2].abs();
                ni.partial_cmp(&nj).unwrap_or(std::cmp::Ordering::Equal)
            })
            .unwrap_or(0);
        return Ok([h[i], h[i]]);
    }
    // Rank 2: adj(H) = -p pᵀ for two real lines meeting at p (Richter-Gebert, §11.3).
    let i = (0..3)
        .min_by(|&i, &j| b[i][i].partial_cmp(&b[j][j]).unwrap_or(std::cmp::Ordering::Equal))
        .unwrap_or(0);
    if b[i][i] > T::ZERO {
        // Point-like. The entries of H carry the error of the pencil root (up to the square
        // root of the precision at a double root) times |H|, so a 2×2 minor of H is uncertain
        // by about sqrt(γ(64)) |H|²; above that it is point-like in any precision.
        let unsure = T::gamma(64).sqrt() * hn * hn;
        return Err(if b[i][i] > unsure { NoLines::PointLike } else { NoLines::Unsure });
    }
    let beta = (-b[i][i]).max(T::ZERO).sqrt();
    if beta == T::ZERO || !beta.is_finite() {
        return Err(NoLines::Unsure);
    }
    let p = [b[0][i] / beta, b[1][i] / beta, b[2][i] / beta];
    let c = [
        [h[0][0], h[0][1] + p[2], h[0][2] - p[1]],
        [h[1][0] - p[2], h[1][1], h[1][2] + p[0]],
        [h[2][0] + p[1], h[2][1] - p[0], h[2][2]],
    ];
    let (mut bi, mut bj, mut bm) = (0, 0, T::ZERO);
    for (r, row) in c.iter().enumerate() {
        for (s, x) in row.iter().enumerate() {
            if x.abs() > bm {
                bm = x.abs();
                bi = r;
                bj = s;
            }
        }
    }
    if bm == T::ZERO {
        return Err(NoLines::Unsure);
    }
    Ok([c[bi], [c[0][bj], c[1][bj], c[2][bj]]])
}

/// Intersect the line `l` with the conic `k`: up to 2 points `(u, v)`, and, where the answer
/// rests on a discriminant within rounding of zero (near tangency), how far from the vertex
/// offered the true points lie if they are real: the discriminant is within [`tangency_band`]
/// `B` of zero and at most `B` below it, so the roots lie within `sqrt(2 B) / 2|s2|` of the
/// vertex (along a unit direction).
#[inline(always)]
pub(super) fn line_conic<T: Real>(l: [T; 3], k: &Conic<T>) -> ([(T, T); 2], usize, Option<T>) {
    let z = T::ZERO;
    let Some(AlongLine { q: (qx, qy), r: (rx, ry), s: [s2, s1, s0] }) = along_line(l, k) else {
        return ([(z, z); 2], 0, None); // the line at infinity
    };
    let (mut r, mut n) = line_quadratic(s2, s1, s0);
    let mut tangency = None;
    if n == 0 && s2 != z {
        // Near tangency the discriminant's sign is lost in the rounding of everything upstream
        // (pencil root, line factors, each carrying up to the square root of the precision near
        // a double root, squared again in the discriminant): offer the parabola's vertex when
        // the discriminant is within γ(8)^¼ of the terms' size, and mark the answer ambiguous so
        // that a miss is decided again in f64. The caller's residual gate and Newton polish keep
        // the vertex only if it is a real (double) root.
        let disc = s1 * s1 - T::from_f64(4.0) * s2 * s0;
        let band = tangency_band(s2, s1, s0);
        if disc > -band {
            r[0] = -s1 / (s2 + s2);
            n = 1;
            tangency = Some((band * T::from_f64(2.0)).sqrt() / (s2 + s2).abs());
        }
    }
    let mut out = [(z, z); 2];
    for i in 0..n {
        out[i] = (qx + r[i] * rx, qy + r[i] * ry);
    }
    (out, n, tangency)
}

/// A line as a point `q` and a unit direction `r`, and a conic along it: `k(q + x r) = s2 x² +
/// s1 x + s0`, as `s = [s2, s1, s0]`.
struct AlongLine<T> {
    q: (T, T),
    r: (T, T),
    s: [T; 3],
}

/// The line `l` and the conic `k` along it ([`AlongLine`]). `None` for the line at infinity.
#[inline(always)]
fn along_line<T: Real>(l: [T; 3], k: &Conic<T>) -> Option<AlongLine<T>> {
    let ll = l[0] * l[0] + l[1] * l[1];
    if !(ll > T::ZERO) || !ll.is_finite() {
        return None;
    }
    let inv = T::ONE / ll.sqrt();
    let (n0, n1, n2) = (l[0] * inv, l[1] * inv, l[2] * inv);
    let (qx, qy) = (-n2 * n0, -n2 * n1);
    let (rx, ry) = (-n1, n0);
    let [a, b, c, d, e, _] = k.k;
    let two = T::ONE + T::ONE;
    let s2 = a * rx * rx + b * ry * ry + c * rx * ry;
    let s1 = two * a * qx * rx + two * b * qy * ry + c * (qx * ry + qy * rx) + d * rx + e * ry;
    let s0 = k.at(qx, qy);
    Some(AlongLine { q: (qx, qy), r: (rx, ry), s: [s2, s1, s0] })
}

/// How far from zero the discriminant of `s2 x² + s1 x + s0` may be and still be a tangency to
/// rounding ([`line_conic`]): `γ(8)^¼` of the terms' size.
#[inline(always)]
fn tangency_band<T: Real>(s2: T, s1: T, s0: T) -> T {
    T::gamma(8).sqrt().sqrt() * (s1 * s1 + (T::from_f64(4.0) * s2 * s0).abs())
}

/// The real roots of `s2 x² + s1 x + s0` along a unit line, as [`solve_quadratic`] finds them
/// (the same relative tests), without its normalisation: the coefficients are a conic's
/// values along a unit line, of the conic's size.
#[inline(always)]
fn line_quadratic<T: Real>(s2: T, s1: T, s0: T) -> ([T; 2], usize) {
    let z = T::ZERO;
    let lin = s1.abs().max(s0.abs());
    if !(s2.abs() > T::gamma(4) * lin * T::from_f64(1e-3)) || !(lin + s2.abs()).is_finite() {
        return solve_quadratic(s2, s1, s0); // a degree drop (or bad input): the careful way
    }
    let disc = s1 * s1 - T::from_f64(4.0) * s2 * s0;
    if disc < z {
        // Tangency within rounding: keep the double root.
        if disc > -T::gamma(8) * (s1 * s1 + (T::from_f64(4.0) * s2 * s0).abs()) {
            return ([-s1 / (s2 + s2), z], 1);
        }
        return ([z, z], 0);
    }
    let qq = T::from_f64(-0.5) * (s1 + disc.sqrt().copysign(s1));
    if qq == z {
        return ([z, z], 1);
    }
    let (r0, r1) = (qq / s2, s0 / qq);
    ([r0.min(r1), r0.max(r1)], 2)
}

/// A unit vector pair `(n1, n2)` orthogonal to `d` and to each other: the ray's two planes.
#[inline(always)]
pub(super) fn planes_for<T: Real>(d: V3<T>) -> Option<(V3<T>, V3<T>)> {
    Some(crate::phong::orthonormal_basis(d.normalized()?))
}

/// The patch seen along the ray: `F(u,v) = n1 · (P(u,v) - o)`, `G(u,v) = n2 · (P(u,v) - o)`,
/// with `n1, n2` the ray's two planes. The ray meets the surface exactly where `F = G = 0`.
/// Both solvers start from these 12 coefficients, computed once per ray and patch.
#[derive(Clone, Copy, Debug)]
pub(super) struct Projected<T> {
    pub(super) f: Conic<T>,
    pub(super) g: Conic<T>,
}

#[inline(always)]
pub(super) fn project<T: Real>(p: &Patch<T>, o: V3<T>, d: V3<T>) -> Option<Projected<T>> {
    let (n1, n2) = planes_for(d)?;
    let f0 = p.f - o;
    Some(Projected {
        f: Conic { k: [n1.dot(p.a), n1.dot(p.b), n1.dot(p.c), n1.dot(p.d), n1.dot(p.e), n1.dot(f0)] },
        g: Conic { k: [n2.dot(p.a), n2.dot(p.b), n2.dot(p.c), n2.dot(p.d), n2.dot(p.e), n2.dot(f0)] },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phong::accuracy::SplitMix;

    /// Where [`line_conic`] reports a near tangency in f32, the true intersection points of the
    /// same (f32) line and conic, computed in f64, lie within the reach it reports of the vertex
    /// it offers: lines tangent to random conics at random points, moved off tangency by 1e-9 to
    /// 1e-3 of the gradient's size, either way.
    #[test]
    fn a_near_tangency_has_its_points_within_reach_of_the_vertex() {
        let mut rng = SplitMix(61);
        let (mut tangencies, mut real_pairs) = (0, 0);
        for i in 0..200_000 {
            let k: [f64; 6] = std::array::from_fn(|_| rng.range(-1.0, 1.0));
            // Compute a point on the conic: v from the quadratic in v at a random u.
            let u0 = rng.range(-1.5, 1.5);
            let [a, b, c, d, e, f] = k;
            let (qa, qb, qc) = (b, c * u0 + e, a * u0 * u0 + d * u0 + f);
            let disc = qb * qb - 4.0 * qa * qc;
            if !(disc >= 0.0) || qa.abs() < 1e-3 {
                continue;
            }
            let v0 = (-qb + disc.sqrt()) / (2.0 * qa);
            // The tangent there, moved off by a tiny offset.
            let (gu, gv) = (2.0 * a * u0 + c * v0 + d, c * u0 + 2.0 * b * v0 + e);
            let g = (gu * gu + gv * gv).sqrt();
            let off = 10f64.powf(rng.range(-9.0, -3.0))
                * g
                * if rng.next_u64().is_multiple_of(2) { 1.0 } else { -1.0 };
            let l = [gu, gv, -gu * u0 - gv * v0 + off];
            let (l32, k32) = (l.map(|x| x as f32), Conic { k: k.map(|x| x as f32) });
            let (pts, n, tangency) = line_conic(l32, &k32);
            let Some(reach) = tangency else { continue };
            let reach = reach as f64;
            tangencies += 1;
            // The same f32 line and conic in f64: their exact points, where real.
            let along = along_line(l32.map(|x| x as f64), &Conic { k: k32.k.map(|x| x as f64) }).unwrap();
            let [s2, s1, s0] = along.s;
            let disc = s1 * s1 - 4.0 * s2 * s0;
            if disc < 0.0 {
                continue;
            }
            real_pairs += 1;
            let (vu, vv) = (pts[0].0 as f64, pts[0].1 as f64);
            for x in [(-s1 + disc.sqrt()) / (2.0 * s2), (-s1 - disc.sqrt()) / (2.0 * s2)] {
                let (pu, pv) = (along.q.0 + x * along.r.0, along.q.1 + x * along.r.1);
                let dist = ((pu - vu).powi(2) + (pv - vv).powi(2)).sqrt();
                assert!(
                    dist <= reach,
                    "case {i}: a point {dist} from the vertex, reach {reach} ({n} offered)"
                );
            }
        }
        assert!(
            tangencies > 10_000 && real_pairs > 1_000,
            "{tangencies} near tangencies, {real_pairs} real pairs"
        );
    }
}
