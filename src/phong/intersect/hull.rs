//! The hull test: a cheap rejection of rays that miss the patch's bounds or prism.

use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// `a * b + c`: fused where `FMA` (the caller is compiled with the `fma` target feature, see
/// [`super::dispatch`]), two roundings elsewhere. Only for sums whose rounding a slack absorbs:
/// the fused result is never less accurate, so a bound for the unfused one holds for both.
#[inline(always)]
fn mad<T: Real, const FMA: bool>(a: T, b: T, c: T) -> T {
    if FMA {
        a.fused_mul_add(b, c)
    } else {
        a * b + c
    }
}

/// `n · x` by [`mad`].
#[inline(always)]
fn dot<T: Real, const FMA: bool>(n: V3<T>, x: V3<T>) -> T {
    mad::<T, FMA>(n.z, x.z, mad::<T, FMA>(n.y, x.y, n.x * x.x))
}

/// Clip the ray's `(tmin, tmax)` against the patch's local bounds (slab test) and its prism of
/// half-spaces: whether any of it stays.
///
/// Branch-free: every plane is clipped and the interval compared once at the end, so the
/// divisions overlap instead of each waiting on a data-dependent exit (half the patch tests
/// that Embree hands over are rejected here, unpredictably). A zero direction component gives
/// an infinite distance of the right sign (`±x / ±0`), which is no constraint when the origin is
/// inside that slab or half-space and an empty interval when it is outside; `0 / 0` is NaN, which
/// the comparisons below ignore (no constraint: the conservative answer). So are a NaN or
/// infinite ray and a NaN interval: this test may pass them, never turns away a ray that hits.
///
/// The prism offsets carry the ray-independent part of the rounding slack (built in with the
/// patch, [`Patch::prism`]); only `γ(8) |o|∞` is added here.
#[inline(always)]
pub(super) fn hits_hull<T: Real, const FMA: bool>(
    p: &Patch<T>,
    o: V3<T>,
    d: V3<T>,
    tmin: T,
    tmax: T,
) -> bool {
    let (mut t0, mut t1) = (tmin, tmax);
    // Widen the slab exits by the rounding of the divisions (pbrt-v4 Bounds3::IntersectP uses 1 + 2γ(3)).
    let widen = T::ONE + T::gamma(3) + T::gamma(3);
    for (oo, dd, lo, hi) in
        [(o.x, d.x, p.lo.x, p.hi.x), (o.y, d.y, p.lo.y, p.hi.y), (o.z, d.z, p.lo.z, p.hi.z)]
    {
        let inv = T::ONE / dd;
        let (a, b) = ((lo - oo) * inv, (hi - oo) * inv);
        // `if a > b { (b, a) } else { (a, b) }`, NaN included, as one min and one max.
        let (near, far) = (b.min(a), a.max(b));
        // `x.max(t0)` keeps t0 when x is NaN (Real::max compares `x > t0`), likewise `min`.
        t0 = near.max(t0);
        t1 = (far * widen).min(t1);
    }
    // The prism: leave through a plane the ray heads out of (n·d > 0, or +0), enter through the
    // others. `s = ±inf` with the sign bit of n·d picks the side without a branch: `max(-s, t)`
    // is t for an exit and +inf (no constraint) for an entry, `min(-s, t)` the other way round.
    // A NaN t (0/0: the ray in the plane) stays NaN through them, and a NaN is never a
    // constraint: `min(t1)` and `max(t0)` keep t1 and t0 then.
    // The rounding of the two dot products (local frame, |o| and |d| terms) is absorbed by
    // widening each plane outwards, entering earlier and leaving later.
    let inf = T::from_f64(f64::INFINITY);
    let slack = T::gamma(8) * o.max_abs();
    for k in 0..5 {
        let n = p.prism_n[k];
        let dn = dot::<T, FMA>(n, d);
        let t = ((p.prism_h[k] - dot::<T, FMA>(n, o)) + slack) / dn; // dist >= 0 inside
        let away = -inf.copysign_bits(dn);
        t1 = away.max(t).min(t1);
        t0 = away.min(t).max(t0);
    }
    t0 <= t1
}
