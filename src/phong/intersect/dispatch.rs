//! Run-time multiversioning of the patch test: [`intersect_with`] compiled for baseline x86-64
//! and again for x86-64-v3's AVX2 and FMA (three-operand VEX encodings, fused dot products in
//! the hull test), the one the CPU runs chosen at run time by the `multiversion` crate (the
//! features detected once, then read from its cache). The release binary stays portable, and
//! this module holds no `unsafe` of its own: the call of the version compiled for features the
//! baseline target does not promise is the crate's, right after it has detected them.
//!
//! Both versions give the same hits bit for bit: Rust never contracts `a * b + c` into a fused
//! operation, so the only fused arithmetic is the hull test's, whose rounding its slack absorbs
//! either way (it only turns away rays that cannot hit).

use multiversion::target::match_target;
use multiversion::{inherit_target, multiversion};

use super::analytic::LeanMember;
use super::conic::Projected;
use super::hull::hits_hull;
#[cfg(target_arch = "x86_64")]
use super::hull::hits_hull_v3;
#[cfg(test)]
use super::intersect_with;
use super::{refused_tail, solve_local, to_local, Method, PatchHit, TestOutcome};
use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// [`intersect_with`] in the version this CPU runs best: with AVX2 and FMA (and the hull test
/// fused) where the CPU has both, the baseline otherwise.
///
/// The hull test is inlined here and the solve is not (compiled for the same features, see
/// [`multiversion::inherit_target`]): the half of the tests the hull turns away then pay
/// neither the solve's register saves nor its stack frame.
#[multiversion(targets("x86_64+avx2+fma"))]
#[inline(always)]
pub(super) fn intersect_dispatched<T: Real>(
    p: &Patch<T>,
    org: V3<T>,
    dir: V3<T>,
    tmin: T,
    tmax: T,
    method: Method,
    cull: bool,
) -> (Option<PatchHit<T>>, TestOutcome) {
    /// [`solve_local`], not inlined, in this version's target features. It computes the local
    /// ray again (the same arithmetic, so the same values) rather than take it from the hull
    /// test: a rejected ray then does not pay for keeping it.
    #[inherit_target]
    #[inline(never)]
    fn solve<T: Real>(
        p: &Patch<T>,
        org: V3<T>,
        dir: V3<T>,
        tmin: T,
        tmax: T,
        method: Method,
    ) -> (Option<PatchHit<T>>, TestOutcome) {
        let (o, d) = to_local(p, org, dir);
        solve_local(p, (org, dir), o, d, tmin, tmax, method)
    }
    const FMA: bool = multiversion::target::target_cfg_f!(target_feature = "fma");
    // Compute the local ray, then the hull test.
    if cull {
        // An f32 patch in this version takes the hull test in explicit vector code, the local
        // ray included: the same decisions as `hits_hull::<T, FMA>`, in fewer instructions.
        let fast = match_target! {
            "x86_64+avx2+fma" => hits_hull_v3(p, org, dir, tmin, tmax),
            _ => None,
        };
        let pass = fast.unwrap_or_else(|| {
            let (o, d) = to_local(p, org, dir);
            hits_hull::<T, FMA>(p, o, d, tmin, tmax)
        });
        if !pass {
            return (None, TestOutcome::HullReject);
        }
    }
    solve(p, org, dir, tmin, tmax, method)
}

/// The certified method's answer for a ray both its certificates refused, from the ray's
/// projected conics `pr` (as [`super::conic::project`] gives them for the local ray) and, where
/// known, the lean solve's `member` of their pencil (as [`lean_member`](super::analytic::lean_member)
/// gives it): the control-net test, then the analytic method and its f64 retry, in the version
/// this CPU runs best (as [`intersect_dispatched`]). The same answer as [`intersect_dispatched`] with
/// [`Method::Certified`] gives such a ray, bit for bit.
#[multiversion(targets("x86_64+avx2+fma"))]
pub(super) fn refused_dispatched<T: Real>(
    p: &Patch<T>,
    org: V3<T>,
    dir: V3<T>,
    tmin: T,
    tmax: T,
    pr: &Projected<T>,
    member: Option<LeanMember<T>>,
) -> (Option<PatchHit<T>>, TestOutcome) {
    let (o, d) = to_local(p, org, dir);
    refused_tail(p, (org, dir), o, d, pr, tmin, tmax, member)
}

/// [`intersect_with`] in its baseline version, whatever the CPU: for comparing the two.
#[cfg(test)]
pub(super) fn intersect_baseline<T: Real>(
    p: &Patch<T>,
    org: V3<T>,
    dir: V3<T>,
    tmin: T,
    tmax: T,
    method: Method,
    cull: bool,
) -> (Option<PatchHit<T>>, TestOutcome) {
    intersect_with::<T, false>(p, org, dir, tmin, tmax, method, cull)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phong::accuracy::{generate, Category, SplitMix};

    /// The x86-64-v3 version answers as the baseline one, bit for bit, on rays of every
    /// accuracy category (when this CPU has AVX2 and FMA; otherwise both are the baseline).
    #[test]
    fn v3_and_baseline_versions_give_identical_hits() {
        let mut rng = SplitMix(27);
        let (mut hits, mut outcome_differs) = (0usize, 0usize);
        let n = 40_000;
        for i in 0..n {
            let category = Category::ALL[i % Category::ALL.len()];
            let c = generate(&mut rng, category);
            let p: Patch<f32> = Patch::new(c.p, c.n, c.alpha);
            let (o, d) = (V3::from(c.org).cast::<f32>(), V3::from(c.dir).cast::<f32>());
            for method in [Method::Certified, Method::AnalyticPolished, Method::Newton] {
                let fast = intersect_dispatched(&p, o, d, 0.0, f32::INFINITY, method, true);
                let base = intersect_baseline(&p, o, d, 0.0, f32::INFINITY, method, true);
                assert_eq!(fast.0, base.0, "case {i} ({category:?}, {method:?}): {c:?}");
                hits += fast.0.is_some() as usize;
                outcome_differs += (fast.1 != base.1) as usize;
            }
        }
        assert!(hits > n / 4, "only {hits} hits");
        // The fused hull test may pass a ray within rounding of a plane that the other turns
        // away (then decided as a miss by the solve): rarely.
        assert!(outcome_differs * 1000 <= n, "{outcome_differs} outcomes differ");
    }
}
