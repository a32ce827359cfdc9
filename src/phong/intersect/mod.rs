//! Ray–patch intersection: the analytic method of Ogaki & Tokuyoshi (conic pencil), an optional
//! Newton polish, a certified Newton method, and a plain Newton–Raphson intersector for
//! comparison.
//!
//! The stages, each in its own module: `poly` (quadratic and cubic solvers), `conic` (the ray's
//! planes, the projected conics, splitting a degenerate conic, line–conic), `hull` (the bounds and
//! prism rejection), `analytic` (enumerate the pencil's degenerate members, split them into lines,
//! offer the roots), `certified` (the one-to-one certificates and Newton in the plane), `detsign`
//! (the certificate that `det J` keeps one sign), `net` (a miss proven from the control net seen
//! along the ray), `lanes` (the certified method on 8 rays at once), `newton` (Newton in space),
//! `domain` (the triangle's tolerances, the clamp and the on-the-ray test) and `retry` (the f64
//! retry). [`intersect`] below dispatches between them, compiled twice
//! by `dispatch`: for baseline x86-64 and for x86-64-v3 (AVX2 and FMA), the one the CPU runs
//! chosen at run time.

mod analytic;
mod certified;
mod conic;
mod detsign;
mod dispatch;
mod domain;
mod hull;
mod lanes;
mod net;
mod newton;
mod poly;
mod retry;

pub use lanes::{
    certified_lanes, certified_lanes_past, hull_of_lanes, LaneAnswers, LaneDecision, LaneHull, LaneRays,
    LANES,
};
pub(crate) use net::net_slack;
pub use poly::{solve_cubic, solve_quadratic};
pub(crate) use retry::sliver_reach;

use super::patch::Patch;
use super::real::{Real, V3};
use analytic::{analytic_from_member, analytic_local, analytic_projected, LeanMember};
use certified::{certified_newton, Proofs};
use conic::{project, Projected};
use domain::domain_tolerance;
#[cfg(test)]
use hull::hits_hull;
use net::misses_net;
use newton::newton_local;
use retry::{decide_in_f64, sliver_from_afar};

/// A hit: ray parameter and Embree-convention barycentrics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchHit<T> {
    /// The ray parameter: the hit point is `org + t dir`.
    pub t: T,
    /// The barycentric of the second vertex.
    pub u: T,
    /// The barycentric of the third vertex.
    pub v: T,
}

/// Which solver to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Method {
    /// The paper's conic-pencil method.
    Analytic,
    /// The analytic root followed by Newton steps on `(u, v, t)`.
    AnalyticPolished,
    /// Newton–Raphson on `(u, v, t)` from the flat triangle's hit (the comparison the paper left open).
    Newton,
    /// Newton–Raphson where a cheap certificate proves the ray meets the patch at most once near
    /// the triangle (so a converged root is *the* answer), the polished analytic method
    /// elsewhere: as exact as `AnalyticPolished`, faster on most rays (the render path). The
    /// certificate is the positive-definite one, and where it fails the det-sign one (`det J`
    /// keeps one sign on the region). Where both fail, a miss may still be proven from the
    /// patch's control net seen along the ray ([`TestOutcome::NetMiss`]) before the analytic
    /// method runs.
    Certified,
    /// [`Method::Certified`] with the positive-definite certificate alone, as before the det-sign
    /// certificate: the same answers, more of them from the analytic method (for comparison).
    CertifiedPositiveDefinite,
}

/// Which path a ray–patch test took: what [`intersect_traced`] reports, for profiling. New
/// paths of the solve add variants (as the control-net test added [`TestOutcome::NetMiss`]), so
/// a match outside this crate needs a wildcard arm; [`TestOutcome::ALL`] lists them all.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum TestOutcome {
    /// Turned away before any solve: a degenerate patch, a NaN interval, a non-finite or zero ray.
    BadInput,
    /// Rejected by the patch's local bounds or its prism (the cheap hull test).
    HullReject,
    /// A miss proven from the patch's control net seen along the ray, where both certificates
    /// refused the ray, before the analytic method (the certified methods).
    NetMiss,
    /// The certified Newton step proved a hit.
    CertifiedHit,
    /// The certified Newton step proved a miss.
    CertifiedMiss,
    /// The certificate failed (or the method is not certified): the analytic method decided,
    /// with a hit.
    AnalyticHit,
    /// As [`TestOutcome::AnalyticHit`], with a miss.
    AnalyticMiss,
    /// The f32 solve could not decide: decided again in f64.
    F64Retry,
    /// Newton–Raphson ([`Method::Newton`]) decided.
    Newton,
}

impl TestOutcome {
    /// Every outcome, in the order of the profile's columns.
    pub const ALL: [TestOutcome; 9] = [
        TestOutcome::BadInput,
        TestOutcome::HullReject,
        TestOutcome::NetMiss,
        TestOutcome::CertifiedHit,
        TestOutcome::CertifiedMiss,
        TestOutcome::AnalyticHit,
        TestOutcome::AnalyticMiss,
        TestOutcome::F64Retry,
        TestOutcome::Newton,
    ];

    /// A short name for tables.
    pub fn name(self) -> &'static str {
        match self {
            TestOutcome::BadInput => "bad input",
            TestOutcome::HullReject => "hull reject",
            TestOutcome::NetMiss => "net miss",
            TestOutcome::CertifiedHit => "certified hit",
            TestOutcome::CertifiedMiss => "certified miss",
            TestOutcome::AnalyticHit => "analytic hit",
            TestOutcome::AnalyticMiss => "analytic miss",
            TestOutcome::F64Retry => "f64 retry",
            TestOutcome::Newton => "newton",
        }
    }
}

/// The nearest hit of `org + t dir`, `t` in the open interval `(tmin, tmax)`, by `method`.
/// Never NaN: bad input (non-finite, zero direction, degenerate patch) gives `None`.
#[inline]
pub fn intersect<T: Real>(
    p: &Patch<T>,
    org: V3<T>,
    dir: V3<T>,
    tmin: T,
    tmax: T,
    method: Method,
) -> Option<PatchHit<T>> {
    intersect_traced(p, org, dir, tmin, tmax, method).0
}

/// [`intersect`], with the path the test took (for profiling: the hit is the same).
// Inlined into its callers, so that the run-time choice of version (`dispatch`) is made in the
// caller's frame: out of line, this wrapper saved and restored five registers and the ray
// around that choice on every patch test (about 30 instructions a test).
#[inline(always)]
pub fn intersect_traced<T: Real>(
    p: &Patch<T>,
    org: V3<T>,
    dir: V3<T>,
    tmin: T,
    tmax: T,
    method: Method,
) -> (Option<PatchHit<T>>, TestOutcome) {
    dispatch::intersect_dispatched(p, org, dir, tmin, tmax, method, true)
}

/// [`intersect_traced`] for a ray a caller has already tested against a conservative hull of
/// the patch (as [`crate::phong::cluster`]'s prism test does): the patch's own bounds and prism
/// test is skipped. The hit is the same as [`intersect`]'s: the hull test only rejects rays
/// that cannot hit.
#[inline]
pub fn intersect_in_hull_traced<T: Real>(
    p: &Patch<T>,
    org: V3<T>,
    dir: V3<T>,
    tmin: T,
    tmax: T,
    method: Method,
) -> (Option<PatchHit<T>>, TestOutcome) {
    dispatch::intersect_dispatched(p, org, dir, tmin, tmax, method, false)
}

/// The body of [`intersect_traced`], with the hull test where `cull`; `FMA` where the caller is
/// compiled with the `fma` target feature (the hull test then fuses its dot products).
#[cfg(test)]
#[inline(always)]
fn intersect_with<T: Real, const FMA: bool>(
    p: &Patch<T>,
    org: V3<T>,
    dir: V3<T>,
    tmin: T,
    tmax: T,
    method: Method,
    cull: bool,
) -> (Option<PatchHit<T>>, TestOutcome) {
    let (o, d) = to_local(p, org, dir);
    if cull && !hits_hull::<T, FMA>(p, o, d, tmin, tmax) {
        return (None, TestOutcome::HullReject);
    }
    solve_local(p, (org, dir), o, d, tmin, tmax, method)
}

/// The ray in the patch's local frame (t is unchanged). A non-finite ray stays non-finite there
/// (the frame's centre and scale are finite), so one test covers both.
#[inline(always)]
fn to_local<T: Real>(p: &Patch<T>, org: V3<T>, dir: V3<T>) -> (V3<T>, V3<T>) {
    ((org - p.center) * p.inv_scale, dir * p.inv_scale)
}

/// The patch test after the hull test (which comes first: it turns away half the tests Embree
/// hands over, and never a ray that hits; it passes NaN, which the bad-input test below then
/// turns away): the local ray `(o, d)` solved by `method`, the world-space ray `world` kept for
/// the f64 retry.
#[inline(always)]
fn solve_local<T: Real>(
    p: &Patch<T>,
    world: (V3<T>, V3<T>),
    o: V3<T>,
    d: V3<T>,
    tmin: T,
    tmax: T,
    method: Method,
) -> (Option<PatchHit<T>>, TestOutcome) {
    let (org, dir) = world;
    if p.degenerate || !finite_ray(tmin, tmax, o, d) {
        return (None, TestOutcome::BadInput);
    }
    match method {
        Method::Analytic => {
            let hit = analytic_local(p, o, d, tmin, tmax, false).0;
            (hit, if hit.is_some() { TestOutcome::AnalyticHit } else { TestOutcome::AnalyticMiss })
        }
        Method::AnalyticPolished => polished(p, (org, dir), o, d, tmin, tmax, None),
        Method::Certified => polished(p, (org, dir), o, d, tmin, tmax, Some(Proofs::WithDetSign)),
        Method::CertifiedPositiveDefinite => {
            polished(p, (org, dir), o, d, tmin, tmax, Some(Proofs::PositiveDefinite))
        }
        Method::Newton => (newton_local(p, o, d, tmin, tmax, domain_tolerance::<T>()), TestOutcome::Newton),
    }
}

/// Whether the interval is not NaN, the local ray `(o, d)` is finite and `d` is not zero. Each
/// `x - x` is `+0` for a finite `x` and NaN for an infinite or NaN one, so their sum is `0`
/// exactly when all six are finite (straight-line code: no test per component).
#[inline(always)]
#[allow(clippy::eq_op)] // `x - x` and `x == x` are the point: they tell NaN and infinity apart
fn finite_ray<T: Real>(tmin: T, tmax: T, o: V3<T>, d: V3<T>) -> bool {
    let z = ((o.x - o.x) + (o.y - o.y)) + ((o.z - o.z) + ((d.x - d.x) + (d.y - d.y) + (d.z - d.z)));
    let zero_dir = d.x == T::ZERO && d.y == T::ZERO && d.z == T::ZERO;
    tmin == tmin && tmax == tmax && z == T::ZERO && !zero_dir
}

/// [`Method::AnalyticPolished`], or a certified method when `certify` names its proofs, on the local ray
/// `(o, d)`, with the f64 retry from the world-space ray `world`. Inlined, so that the certified
/// path is compiled into each version of [`dispatch`].
#[inline(always)]
fn polished<T: Real>(
    p: &Patch<T>,
    world: (V3<T>, V3<T>),
    o: V3<T>,
    d: V3<T>,
    tmin: T,
    tmax: T,
    certify: Option<Proofs>,
) -> (Option<PatchHit<T>>, TestOutcome) {
    let (org, dir) = world;
    let Some(pr) = project(p, o, d) else { return (None, TestOutcome::BadInput) };
    if let Some(proofs) = certify {
        if let Some(answer) = certified_newton(p, o, d, &pr, tmin, tmax, proofs) {
            // A proven miss is proven only to the f32 parameter error, which a sliver seen from
            // afar makes wider than the domain's tolerance band.
            if answer.is_none() && sliver_from_afar(p, o) {
                return (decide_in_f64(p, org, dir, tmin, tmax), TestOutcome::F64Retry);
            }
            let outcome =
                if answer.is_some() { TestOutcome::CertifiedHit } else { TestOutcome::CertifiedMiss };
            return (answer, outcome);
        }
        return refused_tail(p, (org, dir), o, d, &pr, tmin, tmax, None);
    }
    analytic_tail(p, (org, dir), o, d, &pr, tmin, tmax, None)
}

/// The certified methods' answer where both certificates refused the ray (the tail of
/// [`polished`], and of the lanes the packet kernel leaves to the scalar path): the
/// control-net test first (it settles a third to a half of those misses), then
/// [`analytic_tail`]. Inlined, as [`polished`].
#[allow(clippy::too_many_arguments)] // as analytic_tail's
#[inline(always)]
fn refused_tail<T: Real>(
    p: &Patch<T>,
    world: (V3<T>, V3<T>),
    o: V3<T>,
    d: V3<T>,
    pr: &Projected<T>,
    tmin: T,
    tmax: T,
    member: Option<LeanMember<T>>,
) -> (Option<PatchHit<T>>, TestOutcome) {
    if misses_net(p, o, pr) {
        return (None, TestOutcome::NetMiss);
    }
    analytic_tail(p, world, o, d, pr, tmin, tmax, member)
}

/// The analytic method on the ray's conics `pr` where no certificate settled the ray (the tail
/// of [`polished`]), with the f64 retry from the world-space ray `world`; from the lean
/// solve's `member` where it is known already (the same answer). Inlined, as [`polished`].
#[allow(clippy::too_many_arguments)] // the ray in both frames, its interval, its conics, its member
#[inline(always)]
fn analytic_tail<T: Real>(
    p: &Patch<T>,
    world: (V3<T>, V3<T>),
    o: V3<T>,
    d: V3<T>,
    pr: &Projected<T>,
    tmin: T,
    tmax: T,
    member: Option<LeanMember<T>>,
) -> (Option<PatchHit<T>>, TestOutcome) {
    let (org, dir) = world;
    let (hit, ambiguous) = match member {
        Some(member) => analytic_from_member(p, o, d, pr, tmin, tmax, member),
        None => analytic_projected(p, o, d, pr, tmin, tmax, true),
    };
    // In f32, a miss that rested on a step within rounding (near tangency, a root at the
    // domain's edge, a sliver seen from afar), or a hit on an unconverged root at near
    // tangency, is decided again in f64 on the same f32 surface: the f32 solve stays the
    // common path, f64 only settles the rays it cannot.
    let unsure = (hit.is_none() && (ambiguous.miss || sliver_from_afar(p, o))) || ambiguous.hit;
    if unsure && T::UNIT_ROUNDOFF.to_f64() > 1e-10 {
        return (decide_in_f64(p, org, dir, tmin, tmax), TestOutcome::F64Retry);
    }
    (hit, if hit.is_some() { TestOutcome::AnalyticHit } else { TestOutcome::AnalyticMiss })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phong::accuracy::{generate, Category, SplitMix};

    /// Clear misses must be decided in f32: only a miss that rests on a step within rounding may
    /// be sent to f64 again (each costs a second, f64 solve). Rays come down the face normal,
    /// moved sideways by up to the patch size, so most of them miss and none grazes.
    #[test]
    fn clear_misses_are_not_ambiguous() {
        let mut rng = SplitMix(7);
        let (mut misses, mut ambiguous_misses) = (0usize, 0usize);
        for _ in 0..100_000 {
            let c = generate(&mut rng, Category::RandomCurved);
            let fnorm = (c.p[1] - c.p[0]).cross(c.p[2] - c.p[0]).normalize();
            let side = fnorm.any_orthonormal_vector() * rng.range(-1.0, 1.0) * c.size;
            let target = (c.p[0] + c.p[1] + c.p[2]) / 3.0 + side;
            let p: Patch<f32> = Patch::new(c.p, c.n, c.alpha);
            let o = (V3::from(target + fnorm * 3.0).cast::<f32>() - p.center) * p.inv_scale;
            let d = V3::from(-fnorm).cast::<f32>() * p.inv_scale;
            if !hits_hull::<f32, false>(&p, o, d, 0.0, f32::INFINITY) {
                continue;
            }
            let (hit, ambiguous) = analytic_local(&p, o, d, 0.0, f32::INFINITY, true);
            if hit.is_none() {
                misses += 1;
                ambiguous_misses += ambiguous.miss as usize;
            }
        }
        assert!(misses > 1000, "too few misses to judge: {misses}");
        // These rays pass near the domain's edges, where a root may lie within rounding of the
        // edge or two roots nearly coincide.
        assert!(ambiguous_misses * 20 <= misses, "{ambiguous_misses} of {misses} misses sent to f64");
    }
}
