//! The hull test: a cheap rejection of rays that miss the patch's bounds or prism.

use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// Clip the ray's `(tmin, tmax)` against the patch's local bounds (slab test) and its prism of
/// half-spaces: whether any of it stays.
///
/// Branch-free: every plane is clipped and the interval compared once at the end, so the
/// divisions overlap instead of each waiting on a data-dependent exit (half the patch tests
/// that Embree hands over are rejected here, unpredictably). A zero direction component gives
/// an infinite distance of the right sign (`±x / ±0`), which is no constraint when the origin is
/// inside that slab or half-space and an empty interval when it is outside; `0 / 0` is NaN, which
/// the comparisons below ignore (no constraint: the conservative answer).
#[inline(always)]
pub(super) fn hits_hull<T: Real>(p: &Patch<T>, o: V3<T>, d: V3<T>, tmin: T, tmax: T) -> bool {
    let (mut t0, mut t1) = (tmin, tmax);
    // Widen the slab exits by the rounding of the divisions (pbrt-v4 Bounds3::IntersectP uses 1 + 2γ(3)).
    let widen = T::ONE + T::gamma(3) + T::gamma(3);
    for (oo, dd, lo, hi) in
        [(o.x, d.x, p.lo.x, p.hi.x), (o.y, d.y, p.lo.y, p.hi.y), (o.z, d.z, p.lo.z, p.hi.z)]
    {
        let inv = T::ONE / dd;
        let (a, b) = ((lo - oo) * inv, (hi - oo) * inv);
        let (near, far) = if a > b { (b, a) } else { (a, b) };
        // `x.max(t0)` keeps t0 when x is NaN (Real::max compares `x > t0`), likewise `min`.
        t0 = near.max(t0);
        t1 = (far * widen).min(t1);
    }
    // The prism: leave through a plane the ray heads out of (n·d > 0), enter through the others.
    let inf = T::from_f64(f64::INFINITY);
    let om = o.max_abs();
    for k in 0..5 {
        let n = p.prism_n[k];
        let dist = p.prism_h[k] - n.dot(o); // >= 0 inside
        let dn = n.dot(d);
        // Rounding of the two dot products (local frame, |o| and |d| terms): widen the plane
        // outwards by `slack`, entering earlier and leaving later.
        let slack = T::gamma(8) * (T::ONE + om + p.prism_h[k].abs());
        let t = (dist + slack) / dn;
        let leaving = dn.is_sign_positive();
        t1 = (if leaving { t } else { inf }).min(t1);
        t0 = (if leaving { -inf } else { t }).max(t0);
    }
    t0 <= t1
}
