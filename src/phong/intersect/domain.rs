//! The patch's parameter domain (the triangle `u, v, 1-u-v >= 0`) and its tolerances, and the
//! test that a root lies on the ray.

use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// How far outside `[0, 1]` a barycentric may be and still count as inside: the parameter
/// error of the f32/f64 solve after its Newton step, so that a ray through a shared edge is
/// reported by at least one of the two patches (no cracks).
pub(super) fn domain_tolerance<T: Real>() -> T {
    T::gamma(64)
}

/// The band outside the domain (64 domain tolerances) in which a root's side of the edge may
/// differ between f32 and f64: a miss decided there is decided again in f64.
pub(super) fn edge_band<T: Real>() -> T {
    domain_tolerance::<T>() * T::from_f64(64.0)
}

/// Whether `(u, v)` is within `margin` of the triangle `u, v, 1-u-v >= 0`.
#[inline(always)]
pub(super) fn near_domain<T: Real>(u: T, v: T, margin: T) -> bool {
    u >= -margin && v >= -margin && T::ONE - u - v >= -margin
}

/// Whether `(u, v)` is inside the domain, up to [`domain_tolerance`].
#[inline(always)]
pub(super) fn inside<T: Real>(u: T, v: T) -> bool {
    near_domain(u, v, domain_tolerance::<T>())
}

/// Barycentrics clamped into the triangle: negative ones to zero, then `(u, v)` scaled back
/// onto the edge `u + v = 1` if beyond it.
#[inline(always)]
pub(super) fn clamp_to_triangle<T: Real>(u: T, v: T) -> (T, T) {
    let (u, v) = (u.max(T::ZERO), v.max(T::ZERO));
    let s = u + v;
    if s > T::ONE {
        (u / s, v / s)
    } else {
        (u, v)
    }
}

/// Whether the surface point `P(u, v)` lies on the ray at `t` to rounding, relative to the size
/// of the terms (local frame).
#[inline(always)]
pub(super) fn on_ray<T: Real>(p: &Patch<T>, o: V3<T>, d: V3<T>, u: T, v: T, t: T) -> bool {
    let scale = T::ONE + o.max_abs() + (d * t).max_abs();
    let res = (p.eval_local(u, v) - o - d * t).max_abs();
    res <= T::gamma(1024) * scale
}
