//! Newton–Raphson in space: one step on `(u, v, t)` (the polish of the other methods) and the
//! plain Newton intersector started from the flat triangle.

use super::domain::{clamp_to_triangle, near_domain};
use super::PatchHit;
use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// One Newton step on `P(u,v) - o - t d = 0` (local frame). Returns `None` if singular, or if
/// the step or the new iterate is not finite.
#[inline(always)]
pub(super) fn newton_step<T: Real>(p: &Patch<T>, o: V3<T>, d: V3<T>, u: T, v: T, t: T) -> Option<(T, T, T)> {
    let (pu, pv) = p.partials_local(u, v);
    let r = p.eval_local(u, v) - o - d * t;
    // Solve [pu pv -d] [du dv dt]ᵀ = -r by Cramer's rule.
    let nd = -d;
    let det = pu.dot(pv.cross(nd));
    let inv = T::ONE / det;
    let du = -r.dot(pv.cross(nd)) * inv;
    let dv = -pu.dot(r.cross(nd)) * inv;
    let dt = -pu.dot(pv.cross(r)) * inv;
    let (nu, nv, nt) = (u + du, v + dv, t + dt);
    // One test for all: `x - x` is `+0` for a finite `x`, NaN otherwise. A zero `det` makes
    // `inv` infinite and so every step NaN or infinite (`0 · ∞` is NaN): it needs no test of its own.
    all_finite([det, nu, nv, nt]).then_some((nu, nv, nt))
}

/// Whether all four are finite: the sum of their `x - x` is `0` exactly then, NaN otherwise.
#[inline(always)]
#[allow(clippy::eq_op)] // `x - x` is the point: it is NaN for an infinite or NaN `x`
pub(super) fn all_finite<T: Real>(x: [T; 4]) -> bool {
    ((x[0] - x[0]) + (x[1] - x[1])) + ((x[2] - x[2]) + (x[3] - x[3])) == T::ZERO
}

/// Newton–Raphson on `(u, v, t)` from the hit of the ray with the flat triangle's plane; a root
/// within `margin` of the domain counts as a hit (clamped into it).
pub(super) fn newton_local<T: Real>(
    p: &Patch<T>,
    o: V3<T>,
    d: V3<T>,
    tmin: T,
    tmax: T,
    margin: T,
) -> Option<PatchHit<T>> {
    // Start: the flat triangle P0 + u (P1 - P0) + v (P2 - P0), unclamped.
    let p0 = p.f;
    let p1 = p.a + p.d + p.f; // P(1, 0)
    let p2 = p.b + p.e + p.f; // P(0, 1)
    let (e1, e2) = (p1 - p0, p2 - p0);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det == T::ZERO || !det.is_finite() {
        return None;
    }
    let inv = T::ONE / det;
    let s = o - p0;
    let mut u = s.dot(pv) * inv;
    let q = s.cross(e1);
    let mut v = d.dot(q) * inv;
    let mut t = e2.dot(q) * inv;
    let d_len = d.length();
    for _ in 0..12 {
        let (nu, nv, nt) = newton_step(p, o, d, u, v, t)?;
        let step = (nu - u).abs().max((nv - v).abs()).max((nt - t).abs() * d_len);
        u = nu;
        v = nv;
        t = nt;
        if step <= T::gamma(8) {
            break;
        }
    }
    let res = (p.eval_local(u, v) - o - d * t).length();
    if !(res <= T::gamma(256)) {
        return None; // not converged
    }
    (near_domain(u, v, margin) && t > tmin && t < tmax).then(|| {
        let (u, v) = clamp_to_triangle(u, v);
        PatchHit { t, u, v }
    })
}
