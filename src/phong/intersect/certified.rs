//! The certified method: Newton's iteration in the plane of `(u, v)`, trusted where a cheap
//! certificate proves the ray meets the patch at most once near the triangle.

use super::conic::Projected;
use super::detsign::{det_sign_on_domain, det_sign_unfolded, folds_between, unfolded_along, DetSign};
use super::domain::{clamp_to_triangle, edge_band, inside, near_domain, on_ray};
use super::newton::{all_finite, newton_step};
use super::PatchHit;
use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// The corners' coordinates of the region `R` (the domain enlarged by 1.25 about its centroid):
/// `(lo, lo)`, `(hi, lo)`, `(lo, hi)`.
fn region<T: Real>() -> (T, T) {
    (T::from_f64(-0.25 / 3.0), T::from_f64(3.5 / 3.0))
}

/// Which proofs that the projected patch is one-to-one the certified method accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Proofs {
    /// The positive-definite certificate alone ([`Method::CertifiedPositiveDefinite`](super::Method::CertifiedPositiveDefinite)).
    PositiveDefinite,
    /// The positive-definite certificate, and where it fails the det-sign certificate
    /// ([`Method::Certified`](super::Method::Certified)).
    WithDetSign,
}

/// The certified Newton step of [`Method::Certified`](super::Method::Certified): `Some(answer)` when it is proven,
/// `None` when the caller must run the analytic method.
///
/// Project the patch along the ray: `π(u, v) = (n1·P(u,v), n2·P(u,v))`, with `n1, n2` the ray's
/// two planes. The ray meets the surface at `(u, v)` exactly where `π(u, v) = π(o)`. Two
/// certificates prove `π` one-to-one on a convex region (so that the ray meets that part of the
/// surface at most once, and a converged Newton root in it is *the* answer):
///
/// - *Positive definite*, on `R`, the domain enlarged by 1.25 about its centroid: if the
///   symmetric part of `J0⁻¹ J(u, v)` is positive definite over `R` (`J` the Jacobian of `π`,
///   `J0` a fixed matrix), then `(x-y)ᵀ J0⁻¹ (π(x) - π(y)) > 0` for `x ≠ y` in `R` (Gale &
///   Nikaidô 1965). `J` is linear in `(u, v)`, so checking the three corners of a triangular `R`
///   checks all of it. `R` is larger than the domain (larger regions fail the test on strongly
///   curved patches more often than they save), so a Newton root in `R` but well outside the
///   domain also proves a miss.
/// - *Det-sign* ([`det_sign_on_domain`]), on the domain itself: if `det J` has no zero there.
///   `π` is quadratic, so `π(y) - π(x) = J((x+y)/2) (y - x)` exactly, and the midpoint of two
///   points of the domain is in it. It is weaker than the first (a positive definite symmetric
///   part makes `det J > 0`), so it settles more rays, and it is tried on the domain, not on
///   `R`: on the head and the sphere nearly every ray it still refuses there sees a true fold
///   (the exact range of `det J` over the domain straddles zero), and each enlargement of its
///   region refuses more.
///
/// The det-sign certificate is the cheaper, so it is computed first, and the positive-definite
/// one only where it fails or for a root outside the domain that it does not extend to. A
/// converged root inside the domain is the answer whichever certificate proves it; one outside
/// is a miss under either. The packet kernel ([`super::lanes`]) takes them in the same order
/// and decides a lane only as this path does.
///
/// `π(u, v) - π(o)` is the pair of conics `(F, G)` of [`Projected`], so the Jacobian, the
/// certificates and Newton's iteration all run in the plane on their 12 scalar coefficients
/// (the analytic fallback reuses them); `t` is the surface point's projection on the ray.
#[inline(always)]
pub(super) fn certified_newton<T: Real>(
    p: &Patch<T>,
    o: V3<T>,
    d: V3<T>,
    pr: &Projected<T>,
    tmin: T,
    tmax: T,
    proofs: Proofs,
) -> Option<Option<PatchHit<T>>> {
    // Compute the cheaper certificate first: the det-sign one on the domain. A root it proves
    // inside the domain is the answer whichever certificate proves it (the same Newton
    // iterates), so the positive-definite one is computed only for a root outside the domain
    // that the det-sign certificate does not extend to.
    let first = first_proof(p, d, pr, proofs)?;
    let (u, v, t, converged) = newton_root(p, o, d, pr)?;
    if !converged || !on_ray(p, o, d, u, v, t) {
        return None;
    }
    let anchor = match first {
        // Inside the domain: proven. Outside, where the det-sign certificate extends to the
        // root, as below (the cone stands for its coefficients on the domain).
        First::Unfolded if in_region(u, v, T::ZERO) => return decide(u, v, t, tmin, tmax),
        First::Unfolded => {
            if det_sign_unfolded(pr, domain_jacobians(pr)).holds_to(jacobian(pr, u, v), u, v) {
                return decide(u, v, t, tmin, tmax);
            }
            positive_definite(pr)?
        }
        First::DetSign(ds) => {
            // Inside the domain, or outside where the det-sign certificate extends to the
            // root: proven (outside, a miss: the root is the only one on the hull of the domain
            // and the root). Else the positive-definite certificate, where it holds.
            if in_region(u, v, T::ZERO) || ds.holds_to(jacobian(pr, u, v), u, v) {
                return decide(u, v, t, tmin, tmax);
            }
            positive_definite(pr)?
        }
        First::PositiveDefinite(anchor) => anchor,
    };
    // Inside `R` (with room for the root's error) the root is its only one. Outside it is still
    // the only one there when the certificate also holds on the hull of `R` and the root (the
    // matrices that pass form a convex cone and `J` is linear): a proven miss.
    if !(in_region(u, v, region::<T>().0) || certificate_holds(&anchor, jacobian(pr, u, v))) {
        return None;
    }
    decide(u, v, t, tmin, tmax)
}

/// Whether `(u, v)` lies inside the triangle with corners `(lo, lo)`, `(1 - 2 lo, lo)`,
/// `(lo, 1 - 2 lo)` (the domain for `lo = 0`, `R` for `region().0`) with room for the root's
/// error.
#[inline(always)]
fn in_region<T: Real>(u: T, v: T, lo: T) -> bool {
    let slack = T::from_f64(0.005);
    u >= lo + slack && v >= lo + slack && u + v <= T::ONE - lo - slack
}

/// The root in the plane from the flat triangle's hit, then its point in space: `(u, v, t)` and
/// whether Newton converged. A converged root inside the domain takes one Newton step on
/// `(u, v, t)` in space: its correction is computed from a residual that is already at
/// rounding level, so `t` ends within about an ulp of the f64 answer.
#[inline(always)]
fn newton_root<T: Real>(p: &Patch<T>, o: V3<T>, d: V3<T>, pr: &Projected<T>) -> Option<(T, T, T, bool)> {
    let (u, v) = flat_start(pr)?;
    let (u, v, converged) = newton_plane(pr, u, v)?;
    // The ray parameter of the surface point: its projection on the ray.
    let t = (p.eval_local(u, v) - o).dot(d) / d.dot(d);
    if converged && inside(u, v) {
        let (u, v, t) = newton_step(p, o, d, u, v, t)?;
        return Some((u, v, t, converged));
    }
    Some((u, v, t, converged))
}

/// The first proof that holds: the patch's cone of unfolded directions or the det-sign
/// certificate on the domain (where `proofs` allows them), else the positive-definite one on
/// `R`.
enum First<T> {
    /// The ray's direction is in the patch's cone of unfolded directions
    /// ([`unfolded_along`]): `det J` keeps one sign on the domain.
    Unfolded,
    DetSign(DetSign<T>),
    PositiveDefinite(Anchor<T>),
}

/// [`First`]: the cone or else the det-sign certificate where `proofs` allows them and one
/// holds, the positive-definite one where only it holds, `None` where none does. A fold is refused
/// before either: where `det J` clearly has opposite signs at the domain's corner `(0, 0)` and
/// at the centroid ([`folds_between`]), neither can hold, and the caller goes to the analytic
/// method for the price of one 2×2 determinant.
#[inline(always)]
fn first_proof<T: Real>(p: &Patch<T>, d: V3<T>, pr: &Projected<T>, proofs: Proofs) -> Option<First<T>> {
    if proofs == Proofs::WithDetSign && unfolded_along(p, d) {
        return Some(First::Unfolded);
    }
    let (_, det0) = centroid_jacobian(pr);
    // `det J(0, 0)`: J there is `[fd, fe, gd, ge]`, as in `domain_jacobians`.
    let corner = pr.f.k[3] * pr.g.k[4] - pr.f.k[4] * pr.g.k[3];
    if folds_between(pr, corner, det0) {
        return None;
    }
    if proofs == Proofs::WithDetSign {
        if let Some(ds) = det_sign_on_domain(pr, domain_jacobians(pr)) {
            return Some(First::DetSign(ds));
        }
    }
    positive_definite(pr).map(First::PositiveDefinite)
}

/// The positive-definite certificate on `R` ([`positive_definite_on_region`]).
#[inline(always)]
fn positive_definite<T: Real>(pr: &Projected<T>) -> Option<Anchor<T>> {
    let (j0, det0) = centroid_jacobian(pr);
    positive_definite_on_region(pr, j0, det0)
}

/// The answer for a proven root `(u, v, t)`, R's only one: a hit inside the domain and the interval,
/// a proven miss outside, `None` (not proven) within the band where the analytic method would
/// decide again in f64.
#[inline(always)]
fn decide<T: Real>(u: T, v: T, t: T, tmin: T, tmax: T) -> Option<Option<PatchHit<T>>> {
    if inside(u, v) {
        if !(t > tmin && t < tmax) {
            return Some(None);
        }
        let (u, v) = clamp_to_triangle(u, v);
        return Some(Some(PatchHit { t, u, v }));
    }
    if near_domain(u, v, edge_band::<T>()) {
        return None;
    }
    Some(None)
}

/// The Jacobian `J(u, v) = [[F_u, F_v], [G_u, G_v]]` of the projected patch, linear in `(u, v)`.
#[inline(always)]
fn jacobian<T: Real>(pr: &Projected<T>, u: T, v: T) -> [T; 4] {
    let ([fa, fb, fc, fd, fe, _], [ga, gb, gc, gd, ge, _]) = (pr.f.k, pr.g.k);
    let two = T::ONE + T::ONE;
    [
        two * fa * u + fc * v + fd,
        fc * u + two * fb * v + fe,
        two * ga * u + gc * v + gd,
        gc * u + two * gb * v + ge,
    ]
}

/// The Jacobian at the domain's corners `(0, 0)`, `(1, 0)`, `(0, 1)` (as [`jacobian`] would give
/// it there, with one rounding per entry at most).
#[inline(always)]
fn domain_jacobians<T: Real>(pr: &Projected<T>) -> [[T; 4]; 3] {
    let ([fa, fb, fc, fd, fe, _], [ga, gb, gc, gd, ge, _]) = (pr.f.k, pr.g.k);
    let two = T::ONE + T::ONE;
    [
        [fd, fe, gd, ge],
        [two * fa + fd, fc + fe, two * ga + gd, gc + ge],
        [fc + fd, two * fb + fe, gc + gd, two * gb + ge],
    ]
}

/// `J0⁻¹` up to a positive factor, computed once for every certificate check of a test: the
/// adjugate of `J0` (the Jacobian at the centroid) times the sign of `det J0`. The certificate
/// below is invariant under a positive scale of `J0⁻¹ J`, so no division is needed.
struct Anchor<T> {
    /// `sign(det J0) adj(J0)`, row-major.
    k: [T; 4],
}

/// The Jacobian `J0` at the centroid (`(1/3, 1/3)` in `T`) and its determinant.
#[inline(always)]
fn centroid_jacobian<T: Real>(pr: &Projected<T>) -> ([T; 4], T) {
    let third = T::from_f64(1.0 / 3.0);
    let j0 = jacobian(pr, third, third);
    (j0, j0[0] * j0[3] - j0[1] * j0[2])
}

/// [`Anchor`] when the symmetric part of `J0⁻¹ J` is clearly positive definite at the corners of
/// `R`: then the projection is one-to-one on `R`. `None` when it is not, or when `J0` is within
/// rounding of singular (the ray grazes the patch: it proves nothing).
#[cfg(test)]
fn one_to_one_on_region<T: Real>(pr: &Projected<T>) -> Option<Anchor<T>> {
    let (j0, det0) = centroid_jacobian(pr);
    positive_definite_on_region(pr, j0, det0)
}

/// [`one_to_one_on_region`] from `J0` and `det J0` ([`centroid_jacobian`]).
#[inline(always)]
fn positive_definite_on_region<T: Real>(pr: &Projected<T>, j0: [T; 4], det0: T) -> Option<Anchor<T>> {
    let j0n = j0[0].abs().max(j0[1].abs()).max(j0[2].abs()).max(j0[3].abs());
    if !(det0.abs() > T::gamma(64).sqrt() * j0n * j0n) {
        return None;
    }
    let s = if det0 > T::ZERO { T::ONE } else { -T::ONE };
    let anchor = Anchor { k: [j0[3] * s, -j0[1] * s, -j0[2] * s, j0[0] * s] };
    let (lo, hi) = region::<T>();
    let holds = certificate_holds(&anchor, jacobian(pr, lo, lo))
        && certificate_holds(&anchor, jacobian(pr, hi, lo))
        && certificate_holds(&anchor, jacobian(pr, lo, hi));
    holds.then_some(anchor)
}

/// Whether the symmetric part of `J0⁻¹ J` is clearly positive definite. The matrices that pass
/// form a convex cone, and `J` is linear in `(u, v)`: passing at the corners of a polygon is
/// passing on all of it.
#[inline(always)]
fn certificate_holds<T: Real>(anchor: &Anchor<T>, j: [T; 4]) -> bool {
    let k = &anchor.k;
    // M = J0⁻¹ J up to a positive factor; its symmetric part must be clearly positive definite
    // (a margin of 1% of its diagonal product keeps the answer out of the rounding of J0⁻¹ and
    // of J; the test is invariant under a positive scale of M).
    let m00 = k[0] * j[0] + k[1] * j[2];
    let m01 = k[0] * j[1] + k[1] * j[3];
    let m10 = k[2] * j[0] + k[3] * j[2];
    let m11 = k[2] * j[1] + k[3] * j[3];
    let h = (m01 + m10) * T::from_f64(0.5);
    m00 > T::ZERO && m11 > T::ZERO && m00 * m11 - h * h > T::from_f64(0.01) * m00 * m11
}

/// The start of Newton's iteration: the ray's hit with the flat triangle (`F` and `G` with their
/// quadratic terms dropped: `P(1,0) - P(0,0) = a + d`, `P(0,1) - P(0,0) = b + e`).
#[inline(always)]
fn flat_start<T: Real>(pr: &Projected<T>) -> Option<(T, T)> {
    let ([fa, fb, _, fd, fe, ff], [ga, gb, _, gd, ge, gf]) = (pr.f.k, pr.g.k);
    let (l00, l01, l10, l11) = (fa + fd, fb + fe, ga + gd, gb + ge);
    let det = l00 * l11 - l01 * l10;
    let idet = T::ONE / det;
    let (u, v) = ((l01 * gf - l11 * ff) * idet, (l10 * ff - l00 * gf) * idet);
    // A zero `det` makes `idet` infinite and the start NaN or infinite (`0 · ∞` is NaN): one
    // test covers it with the rest.
    all_finite([det, u, v, T::ZERO]).then_some((u, v))
}

/// Newton on `(F, G) = 0` in the plane of `(u, v)` from `(u, v)`: the last iterate and whether
/// it converged, that is, whether the next step would be within about `γ(64)`. `F` and `G` are
/// quadratic, so after a step `δ` the residual is `Q(δ)`, their second-order part, exactly but
/// for rounding: at most `q |δ|∞²`, `q` the larger sum of their second-order coefficients'
/// magnitudes. `J` moves by at most `2 q |δ|∞` over the step, so with `k = |J⁻¹|∞ q |δ|∞` (`J` of
/// the step's start) at most 1/4, `|J⁻¹|∞` at the new iterate is at most twice as large, and the
/// next step is at most `2 k |δ|∞`: the iteration stops where `k |δ|∞` is within `γ(64)` (and
/// the step within `√γ(64)`), a step before the step itself is that small; the step in space that
/// follows polishes a root inside the domain as before. One link fewer in a chain of dependent
/// operations, which the clock sees more than the instruction count (a certified hit 898
/// instructions on the sphere's primary rays, 910 before; `scripts/instructions.sh`). The bound
/// leaves out the rounding of the residual: where `J` is ill-conditioned the iterates wander
/// within `|J⁻¹|∞` times it, and the iteration may stop there where stopping at a step within
/// `γ(64)` never did (about 1% of the accuracy suite's rays); the step in space and [`on_ray`]
/// then decide, as for every root. A singular Jacobian or an overflow makes the step NaN or
/// infinite: it may pass the test (`max` drops a NaN operand), but the iterate is then NaN and
/// reported as not converged.
#[inline(always)]
fn newton_plane<T: Real>(pr: &Projected<T>, mut u: T, mut v: T) -> Option<(T, T, bool)> {
    let ([fa, fb, fc, fd, fe, ff], [ga, gb, gc, gd, ge, gf]) = (pr.f.k, pr.g.k);
    let tol = T::gamma(64);
    let q = (fa.abs() + fb.abs() + fc.abs()).max(ga.abs() + gb.abs() + gc.abs());
    let (near, quarter) = (tol.sqrt(), T::from_f64(0.25));
    for _ in 0..8 {
        let r0 = ((fa * u + fc * v + fd) * u + (fb * v + fe) * v) + ff;
        let r1 = ((ga * u + gc * v + gd) * u + (gb * v + ge) * v) + gf;
        let j = jacobian(pr, u, v);
        let idet = T::ONE / (j[0] * j[3] - j[1] * j[2]);
        let du = (j[1] * r1 - j[3] * r0) * idet;
        let dv = (j[2] * r0 - j[0] * r1) * idet;
        u = u + du;
        v = v + dv;
        // Compute the bound on the next step from this one.
        let inv = (j[3].abs() + j[1].abs()).max(j[2].abs() + j[0].abs()) * idet.abs();
        let step = du.abs().max(dv.abs());
        let k = inv * q * step;
        if step <= near && k <= quarter && k * step <= tol {
            return Some((u, v, u.is_finite() && v.is_finite()));
        }
    }
    Some((u, v, false))
}

#[cfg(test)]
mod tests {
    use super::super::conic::{project, Conic, Projected};
    use super::super::{intersect, intersect_traced, Method, TestOutcome};
    use super::{
        centroid_jacobian, det_sign_on_domain, domain_jacobians, flat_start, folds_between, jacobian,
        newton_plane, one_to_one_on_region, unfolded_along,
    };
    use crate::phong::accuracy::{generate, Case, Category, SplitMix};
    use crate::phong::patch::Patch;
    use crate::phong::real::{Real, V3};
    use crate::phong::reference::reference_intersect;
    use glam::DVec3;
    use proptest::prelude::*;

    /// Whether an answer is certified (by either certificate).
    fn certified(o: TestOutcome) -> bool {
        matches!(o, TestOutcome::CertifiedHit | TestOutcome::CertifiedMiss)
    }

    /// Case `c`'s ray moved sideways by `side` (in patch sizes), in f32: the patch and the ray.
    fn f32_ray(c: &Case, side: f64) -> (Patch<f32>, V3<f32>, V3<f32>) {
        let off = c.dir.any_orthonormal_vector() * side * c.size;
        let p: Patch<f32> = Patch::new(c.p, c.n, c.alpha);
        (p, V3::from(c.org + off).cast::<f32>(), V3::from(c.dir).cast::<f32>())
    }

    /// The det-sign certificate settles rays that the positive-definite one leaves to the
    /// analytic method (patches that curve away from the ray without folding), hits and misses
    /// both, with the analytic method's answers; where the positive-definite certificate holds,
    /// the answer is the same bit for bit (whichever certificate is computed first, a root is
    /// decided as the positive-definite one decides it).
    #[test]
    fn det_sign_settles_what_the_positive_definite_certificate_leaves() {
        let mut rng = SplitMix(41);
        let (mut hits, mut misses, mut refused) = (0, 0, 0);
        for i in 0..20_000 {
            let cat = [Category::RandomCurved, Category::StronglyCurved][i % 2];
            let c = generate(&mut rng, cat);
            let (p, o, d) = f32_ray(&c, rng.range(-0.7, 0.7));
            let inf = f32::INFINITY;
            let (h, outcome) = intersect_traced(&p, o, d, 0.0, inf, Method::Certified);
            let (h_pd, outcome_pd) = intersect_traced(&p, o, d, 0.0, inf, Method::CertifiedPositiveDefinite);
            if certified(outcome_pd) {
                assert_eq!((h, outcome), (h_pd, outcome_pd), "case {i}: {c:?}");
                continue;
            }
            if !certified(outcome) {
                refused += matches!(outcome, TestOutcome::AnalyticHit | TestOutcome::AnalyticMiss) as usize;
                continue;
            }
            let analytic = intersect(&p, o, d, 0.0, inf, Method::AnalyticPolished);
            assert_eq!(h.is_some(), analytic.is_some(), "case {i}: det-sign {h:?}, analytic {analytic:?}");
            if let (Some(a), Some(b)) = (h, analytic) {
                assert!(((a.t - b.t) / b.t).abs() < 1e-5, "case {i}: t {} vs {}", a.t, b.t);
                hits += 1;
            } else {
                misses += 1;
            }
        }
        assert!(hits > 200 && misses > 200, "det-sign settled {hits} hits and {misses} misses");
        assert!(refused > 100, "only {refused} rays refused by both certificates");
    }

    /// A patch that bulges up between its first two corners (normals tilted 45° towards each
    /// other), seen along that edge through the bulge: the ray enters and leaves it, so the
    /// projection folds (two roots in the domain). Both certificates must refuse it, and the
    /// analytic method finds the nearer root, as the reference does, from either side.
    #[test]
    fn a_fold_is_refused_and_left_to_the_analytic_method() {
        let pos = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let nrm = [DVec3::new(-1.0, 0.0, 1.0), DVec3::new(1.0, 0.0, 1.0), DVec3::Z];
        let p: Patch<f32> = Patch::new(pos, nrm, 0.75);
        for (org, dir) in [(DVec3::new(-1.0, 0.05, 0.1), DVec3::X), (DVec3::new(2.0, 0.05, 0.1), -DVec3::X)] {
            let (o, d) = (V3::from(org).cast::<f32>(), V3::from(dir).cast::<f32>());
            let lo = (o - p.center) * p.inv_scale;
            let pr = project(&p, lo, d * p.inv_scale).unwrap();
            assert!(one_to_one_on_region(&pr).is_none());
            assert!(det_sign_on_domain(&pr, domain_jacobians(&pr)).is_none());
            let (hit, outcome) = intersect_traced(&p, o, d, 0.0, f32::INFINITY, Method::Certified);
            assert_eq!(outcome, TestOutcome::AnalyticHit);
            let hit = hit.unwrap();
            let r = reference_intersect(pos, nrm, 0.75, [false; 3], org, dir, 0.0, f64::INFINITY).unwrap();
            assert!(((hit.t as f64 - r.t) / r.t).abs() < 1e-5, "t {} vs reference {}", hit.t, r.t);
            // The far root is in the domain too: the reference finds it from beyond the near one.
            let far = reference_intersect(pos, nrm, 0.75, [false; 3], org, dir, r.t + 1e-3, f64::INFINITY);
            let far = far.expect("the ray leaves the bulge inside the domain");
            assert!((far.u - r.u).abs() > 0.3, "roots at u = {} and {}", r.u, far.u);
        }
    }

    /// Newton in the plane stops where its bound puts the next step within about `γ(64)`, one
    /// step before the step itself is that small (as it stopped before), on rays of every
    /// accuracy category:
    /// - wherever it reports convergence, the next Newton step (computed in f64 on the same
    ///   conics) is within `2 γ(64)`, and the rounding of the residual that the iterates of an
    ///   ill-conditioned Jacobian wander within (`|J⁻¹|∞` times `γ(8)` of its terms);
    /// - wherever the iteration to a step within `γ(64)` converges, it converges too, a step
    ///   shorter on most rays, and within the same of that iterate.
    #[test]
    fn newton_in_the_plane_stops_a_step_early_at_the_same_root() {
        let mut rng = SplitMix(83);
        let tol = <f32 as Real>::gamma(64) as f64;
        let [mut converged, mut both, mut shorter] = [0usize; 3];
        for i in 0..20_000 {
            let c = generate(&mut rng, Category::ALL[i % Category::ALL.len()]);
            let (p, o, d) = f32_ray(&c, 0.0);
            let Some(pr) = project(&p, (o - p.center) * p.inv_scale, d * p.inv_scale) else { continue };
            let Some((u0, v0)) = flat_start(&pr) else { continue };
            let (fk, gk) = (pr.f.k.map(f64::from), pr.g.k.map(f64::from));
            let pr64 = Projected { f: Conic { k: fk }, g: Conic { k: gk } };
            // Compute the size of a Newton step from `(u, v)` in f64 on the same conics, and
            // the rounding of the f32 residual there.
            let newton = |u: f64, v: f64| {
                let (r0, r1) = (pr64.f.at(u, v), pr64.g.at(u, v));
                let j = jacobian(&pr64, u, v);
                let det = j[0] * j[3] - j[1] * j[2];
                let (du, dv) = ((j[1] * r1 - j[3] * r0) / det, (j[2] * r0 - j[0] * r1) / det);
                let terms = |k: [f64; 6]| {
                    let [a, b, cc, dd, e, f] = k.map(f64::abs);
                    a * u * u + b * v * v + cc * (u * v).abs() + dd * u.abs() + e * v.abs() + f
                };
                let inv = (j[3].abs() + j[1].abs()).max(j[2].abs() + j[0].abs()) / det.abs();
                let floor = inv * <f32 as Real>::gamma(8) as f64 * terms(fk).max(terms(gk));
                (du.abs().max(dv.abs()), floor)
            };
            let early = newton_plane(&pr, u0, v0).unwrap();
            if early.2 {
                converged += 1;
                let (next, floor) = newton(early.0 as f64, early.1 as f64);
                assert!(next <= 2.0 * (tol + floor), "case {i}: next step {next}, rounding {floor}: {c:?}");
            }
            // Compute the iteration to a step within the tolerance, in f32.
            let ([fa, fb, fc, fd, fe, ff], [ga, gb, gc, gd, ge, gf]) = (pr.f.k, pr.g.k);
            let step = |u: f32, v: f32| {
                let r0 = ((fa * u + fc * v + fd) * u + (fb * v + fe) * v) + ff;
                let r1 = ((ga * u + gc * v + gd) * u + (gb * v + ge) * v) + gf;
                let j = jacobian(&pr, u, v);
                let idet = 1.0 / (j[0] * j[3] - j[1] * j[2]);
                ((j[1] * r1 - j[3] * r0) * idet, (j[2] * r0 - j[0] * r1) * idet)
            };
            let (mut u, mut v, mut before, mut steps, mut done) = (u0, v0, (u0, v0), 0, false);
            while steps < 8 && !done {
                let (du, dv) = step(u, v);
                (before, u, v, steps) = ((u, v), u + du, v + dv, steps + 1);
                done = du.abs() as f64 <= tol && dv.abs() as f64 <= tol && u.is_finite() && v.is_finite();
            }
            if !done {
                continue;
            }
            assert!(early.2, "case {i}: converged to ({u}, {v}) in {steps} steps, not early: {c:?}");
            let off = (early.0 - u).abs().max((early.1 - v).abs()) as f64;
            let (_, floor) = newton(u as f64, v as f64);
            assert!(off <= 2.0 * (tol + floor), "case {i}: {early:?} is {off} from ({u}, {v}): {c:?}");
            both += 1;
            shorter += ((early.0, early.1) == before) as usize;
        }
        assert!(both > 15_000, "only {both} of {converged} converged both ways");
        assert!(shorter * 2 > both, "a step shorter on only {shorter} of {both}");
    }

    /// The fold test refuses only rays that neither certificate would settle: wherever `det J`
    /// clearly changes sign between the corner `(0, 0)` and the centroid, both the
    /// positive-definite and the det-sign certificates fail as computed, so refusing first
    /// changes no answer. It refuses a good share of the rays both certificates refuse.
    #[test]
    fn the_fold_test_refuses_only_what_both_certificates_refuse() {
        let mut rng = SplitMix(43);
        let (mut refused_by_both, mut folds) = (0, 0);
        for i in 0..40_000 {
            let c = generate(&mut rng, [Category::RandomCurved, Category::StronglyCurved][i % 2]);
            let (p, o, d) = f32_ray(&c, rng.range(-0.7, 0.7));
            let Some(pr) = project(&p, (o - p.center) * p.inv_scale, d * p.inv_scale) else { continue };
            let both_fail = one_to_one_on_region(&pr).is_none()
                && det_sign_on_domain(&pr, domain_jacobians(&pr)).is_none();
            let (_, det0) = centroid_jacobian(&pr);
            let corner = pr.f.k[3] * pr.g.k[4] - pr.f.k[4] * pr.g.k[3];
            if folds_between(&pr, corner, det0) {
                assert!(both_fail, "case {i}: a certificate holds on a refused fold: {c:?}");
                folds += 1;
            }
            refused_by_both += both_fail as usize;
        }
        assert!(folds * 4 > refused_by_both, "the fold test refused {folds} of {refused_by_both} rays");
    }

    /// Where a ray's direction lies in the patch's cone of unfolded directions, the det-sign
    /// certificate as computed on the ray's conics holds too, and `d̂·(Pu × Pv)`, in f64 on the
    /// f32 patch at 231 points of the domain, keeps one sign clear of the cone's margin
    /// `1e-4 S²`. The cone takes most rays on moderately curved patches.
    #[test]
    fn the_cone_of_unfolded_directions_proves_what_the_det_sign_certificate_checks() {
        let mut rng = SplitMix(71);
        let (mut in_cone, mut rays) = (0, 0);
        for i in 0..30_000 {
            let cat = [Category::RandomCurved, Category::StronglyCurved, Category::NearFlat][i % 3];
            let c = generate(&mut rng, cat);
            let (p, o, d) = f32_ray(&c, rng.range(-0.7, 0.7));
            let dl = d * p.inv_scale;
            let Some(pr) = project(&p, (o - p.center) * p.inv_scale, dl) else { continue };
            rays += 1;
            if !unfolded_along(&p, dl) {
                continue;
            }
            in_cone += 1;
            assert!(det_sign_on_domain(&pr, domain_jacobians(&pr)).is_some(), "case {i}: {c:?}");
            let exact = p.cast::<f64>();
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)].map(|(u, v)| exact.partials_local(u, v));
            let s = corners.iter().map(|(pu, pv)| pu.length().max(pv.length())).fold(0.0, f64::max);
            let dh = dl.to_f64().normalized().unwrap();
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for a in 0..=20 {
                for b in 0..=20 - a {
                    let (pu, pv) = exact.partials_local(a as f64 / 20.0, b as f64 / 20.0);
                    let x = dh.dot(pu.cross(pv));
                    (lo, hi) = (lo.min(x), hi.max(x));
                }
            }
            let tau = 1e-4 * s * s;
            assert!(lo > tau || hi < -tau, "case {i}: d·N in [{lo}, {hi}], margin {tau}: {c:?}");
        }
        assert!(in_cone * 2 > rays, "the cone took {in_cone} of {rays} rays");
    }

    /// [`det_sign_answers_equal_the_reference`] on one ray: whether the det-sign certificate
    /// settled it, and if so whether its answer is the reference's.
    fn check_against_reference(c: &Case, side: f64) -> Result<bool, String> {
        let (p, o, d) = f32_ray(c, side);
        let inf = f32::INFINITY;
        let (h, outcome) = intersect_traced(&p, o, d, 0.0, inf, Method::Certified);
        let (_, outcome_pd) = intersect_traced(&p, o, d, 0.0, inf, Method::CertifiedPositiveDefinite);
        if !certified(outcome) || certified(outcome_pd) {
            return Ok(false);
        }
        let r = |x: DVec3| -> DVec3 { V3::from(x).cast::<f32>().to_f64().into() };
        let (org, dir) = (o.to_f64().into(), d.to_f64().into());
        let reference =
            reference_intersect(c.p.map(r), c.n.map(r), c.alpha, [false; 3], org, dir, 0.0, inf.into());
        let edge = |u: f64, v: f64| u.min(v).min(1.0 - u - v);
        match (h, reference) {
            (Some(h), Some(r)) if ((h.t as f64 - r.t) / r.t).abs() >= 1e-5 => {
                Err(format!("t {} vs {}", h.t, r.t))
            }
            (Some(h), None) if edge(h.u.into(), h.v.into()) >= 1e-3 => Err(format!("false hit {h:?}")),
            (None, Some(r)) if edge(r.u, r.v) >= 1e-3 => Err(format!("false miss, reference {r:?}")),
            _ => Ok(true),
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 200, .. ProptestConfig::default() })]

        /// Where the det-sign certificate settles a ray (the positive-definite one did not),
        /// the answer is the independent f64 reference's (on the same inputs rounded to f32):
        /// the same hit or miss, except within rounding of the domain's edge, and `t` within
        /// the f32 target. Each case draws 64 rays from its seed (the certificate settles about
        /// one in 30 of them).
        #[test]
        fn det_sign_answers_equal_the_reference(seed in 0u64..1_000_000) {
            let mut rng = SplitMix(seed);
            for k in 0..64 {
                let c = generate(&mut rng, [Category::RandomCurved, Category::StronglyCurved][k % 2]);
                let side = rng.range(-0.7, 0.7);
                let checked = check_against_reference(&c, side);
                prop_assert!(checked.is_ok(), "ray {k}: {:?}, case {c:?}, side {side}", checked);
            }
        }
    }

    /// The proptest above checks rays: enough of them are settled by the det-sign certificate.
    #[test]
    fn det_sign_settles_enough_rays_for_the_reference_check() {
        let mut rng = SplitMix(5);
        let mut settled = 0;
        for k in 0..64 * 200 {
            let c = generate(&mut rng, [Category::RandomCurved, Category::StronglyCurved][k % 2]);
            let side = rng.range(-0.7, 0.7);
            settled += check_against_reference(&c, side).unwrap() as usize;
        }
        assert!(settled > 200, "only {settled} of {} rays settled by the det-sign certificate", 64 * 200);
    }

    /// A ray aimed at the surface's continuation beyond `R` (at `(u, v) = (-0.1, 0.55)`, left of
    /// the edge `u = 0`) from above the middle of the patch: Newton's iteration converges to
    /// that root, outside `R`, and where the certificate also holds there the miss is proven
    /// without the analytic method. The answers stay the analytic method's.
    #[test]
    fn root_beyond_region_is_a_certified_miss() {
        let mut rng = SplitMix(14);
        let (mut tested, mut certified, mut analytic) = (0, 0, 0);
        for _ in 0..2000 {
            let c = generate(&mut rng, Category::RandomCurved);
            let exact: Patch<f64> = Patch::new(c.p, c.n, c.alpha);
            let target = exact.eval(-0.1, 0.55);
            // From above the middle of the patch, down and out across the edge.
            let fnorm = V3::from((c.p[1] - c.p[0]).cross(c.p[2] - c.p[0]).normalize());
            let up = if fnorm.dot(V3::from(c.n[0] + c.n[1] + c.n[2])) > 0.0 { fnorm } else { -fnorm };
            let org = exact.eval(1.0 / 3.0, 1.0 / 3.0) + up * (0.3 * c.size);
            let dir = target - org;
            let p: Patch<f32> = Patch::new(c.p, c.n, c.alpha);
            let (o, d) = (org.cast::<f32>(), dir.cast::<f32>());
            let (hit, outcome) = intersect_traced(&p, o, d, 0.0, f32::INFINITY, Method::Certified);
            let reference = intersect(&p, o, d, 0.0, f32::INFINITY, Method::AnalyticPolished);
            assert_eq!(
                hit.is_some(),
                reference.is_some(),
                "case {c:?}: certified {hit:?}, analytic {reference:?}"
            );
            match outcome {
                TestOutcome::HullReject => {}
                TestOutcome::CertifiedMiss => {
                    tested += 1;
                    certified += 1
                }
                TestOutcome::AnalyticMiss | TestOutcome::AnalyticHit => {
                    tested += 1;
                    analytic += 1
                }
                _ => tested += 1,
            }
        }
        assert!(tested > 500, "only {tested} rays passed the hull");
        assert!(
            certified * 2 > tested,
            "{certified} certified misses, {analytic} analytic answers of {tested} rays past the hull"
        );
    }
}
