//! The f64 retry: the rays whose f32 answer rests on rounding (grazing rays, roots at the
//! domain's edge, slivers seen from afar) are decided again in f64 on the same f32 surface.

use super::analytic::analytic_local;
use super::domain::{domain_tolerance, edge_band};
use super::newton::newton_local;
use super::PatchHit;
use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// The reciprocal of the flat triangle's smallest height, `longest edge / |e1 × e2|` (local
/// frame): how much a distance across the patch is magnified in the barycentrics. About 1 for a
/// well-shaped patch, about 500 for the Stanford bunny's near-collinear triangles.
#[inline]
fn inverse_height<T: Real>(p: &Patch<T>) -> T {
    flat_inverse_height(p.a, p.b, p.d, p.e)
}

/// [`inverse_height`] from the coefficients `A`, `B`, `D`, `E` (the flat triangle's edges are
/// `A + D` and `B + E`).
#[inline]
fn flat_inverse_height<T: Real>(a: V3<T>, b: V3<T>, d: V3<T>, e: V3<T>) -> T {
    let (e1, e2) = (a + d, b + e);
    let e3 = e2 - e1;
    let longest = e1.dot(e1).max(e2.dot(e2)).max(e3.dot(e3)).sqrt();
    longest / e1.cross(e2).length()
}

/// Whether an f32 miss on patch `p` (local ray origin `o`) cannot be trusted because the
/// patch is a sliver seen from afar: the ray's rounding in the local frame, about
/// `u (1 + |o|)`, moves the barycentrics across the thin direction by that times
/// [`inverse_height`]. Beyond a quarter of the band in which a root outside the domain is
/// decided again in f64 (64 domain tolerances), a true root inside the domain may land outside
/// the band: the miss is decided in f64 instead. A well-shaped patch (the accuracy cases have
/// areas above 0.15 longest²) needs a ray origin over a thousand patch sizes away for this; the
/// Stanford bunny's slivers only a few. Always false in f64 (there is no higher precision to ask).
/// The patch holds how far that is ([`sliver_reach`]), so a miss pays one comparison.
#[inline(always)]
pub(super) fn sliver_from_afar<T: Real>(p: &Patch<T>, o: V3<T>) -> bool {
    !(o.max_abs() <= p.sliver_reach)
}

/// [`sliver_from_afar`]'s reach for a patch stored in precision `T` with local coefficients
/// `A`, `B`, `D`, `E` (as [`flat_inverse_height`] takes them): the largest `|o|`
/// (max norm, local frame) with `4 u (1 + |o|) inverse_height <= band`. Infinite in f64; NaN
/// (every miss decided in f64) for a triangle without area.
pub(crate) fn sliver_reach<T: Real>(a: V3<f64>, b: V3<f64>, d: V3<f64>, e: V3<f64>) -> f64 {
    let u = T::UNIT_ROUNDOFF.to_f64();
    if u < 1e-10 {
        return f64::INFINITY;
    }
    edge_band::<T>().to_f64() / (4.0 * u * flat_inverse_height(a, b, d, e)) - 1.0
}

/// The ray decided again in f64 on the same (f32) surface, from the world-space input: the f32
/// rounding of the local ray alone moves a grazing ray across the surface, or a ray across a
/// sliver.
///
/// On a sliver, the f32 rounding of the patch itself (a few units in the last place of its
/// local coefficients, differently in each neighbour's frame) opens a gap between neighbours
/// that is wider, in barycentrics, than the f32 domain tolerance: a ray through it would miss
/// both in f64 too. There a miss of the analytic solve is decided by the f64 Newton root, which
/// counts as a hit within `γ(16)` (in f32 terms) times [`inverse_height`] of the domain.
#[cold]
pub(super) fn decide_in_f64<T: Real>(
    p: &Patch<T>,
    org: V3<T>,
    dir: V3<T>,
    tmin: T,
    tmax: T,
) -> Option<PatchHit<T>> {
    let p64 = p.cast::<f64>();
    let o64 = (org.cast::<f64>() - p64.center) * p64.inv_scale;
    let d64 = dir.cast::<f64>() * p64.inv_scale;
    let (tmin, tmax) = (tmin.to_f64(), tmax.to_f64());
    let (h, _) = analytic_local(&p64, o64, d64, tmin, tmax, true);
    let h = h.or_else(|| {
        let margin = T::gamma(16).to_f64() * inverse_height(&p64);
        if margin > domain_tolerance::<T>().to_f64() {
            newton_local(&p64, o64, d64, tmin, tmax, margin)
        } else {
            None
        }
    });
    h.map(|h| PatchHit { t: T::from_f64(h.t), u: T::from_f64(h.u), v: T::from_f64(h.v) })
}
