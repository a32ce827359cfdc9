//! The paper's analytic method: the pencil of the ray's two conics, its degenerate members
//! split into lines, and the lines' intersections with a conic offered as roots.

use super::conic::{
    adj3, det3, line_conic, project, split_degenerate, trace_prod, Conic, NoLines, Projected,
};
use super::domain::{clamp_to_triangle, edge_band, inside, near_domain, on_ray};
use super::newton::newton_step;
use super::poly::solve_cubic_flagged;
use super::PatchHit;
use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// Which answers of [`analytic_local`] rest on a step within rounding, so that a higher
/// precision may decide differently.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Ambiguity {
    /// A miss would be uncertain.
    pub(super) miss: bool,
    /// The hit found is uncertain (an unconverged root at near tangency).
    pub(super) hit: bool,
}

/// The paper's analytic intersection in the local frame; `polish` adds Newton steps per root.
/// Also says whether the answer is *ambiguous*: it rested on a step whose sign or acceptance
/// is within rounding (a discriminant near zero, a root just outside the domain or off the ray,
/// no usable degenerate conic, a Newton step that diverged), so that a higher precision may
/// decide differently.
pub(super) fn analytic_local<T: Real>(
    p: &Patch<T>,
    o: V3<T>,
    d: V3<T>,
    tmin: T,
    tmax: T,
    polish: bool,
) -> (Option<PatchHit<T>>, Ambiguity) {
    match project(p, o, d) {
        Some(pr) => analytic_projected(p, o, d, &pr, tmin, tmax, polish),
        None => (None, Ambiguity::default()),
    }
}

/// The ray in the patch's local frame, its parameter interval, and whether roots are polished.
struct LocalRay<T> {
    o: V3<T>,
    d: V3<T>,
    tmin: T,
    tmax: T,
    polish: bool,
}

/// [`analytic_local`] on the ray's two conics `pr` (from [`project`]).
pub(super) fn analytic_projected<T: Real>(
    p: &Patch<T>,
    o: V3<T>,
    d: V3<T>,
    pr: &Projected<T>,
    tmin: T,
    tmax: T,
    polish: bool,
) -> (Option<PatchHit<T>>, Ambiguity) {
    let (cf, cg) = (pr.f, pr.g);
    if cf.norm() == T::ZERO || cg.norm() == T::ZERO {
        // The ray lies in the patch's plane (a flat patch seen edge-on): no isolated hit.
        return (None, Ambiguity::default());
    }
    // Compute the pencil's degenerate members, then offer the roots on their lines.
    let members = degenerate_members(&cf, &cg);
    let ray = LocalRay { o, d, tmin, tmax, polish };
    let mut s = Search::new(members.near_multiple);
    for &x in &members.x[..members.n] {
        if s.member(p, &ray, &cf, &cg, x) {
            break;
        }
    }
    s.ambiguous |= s.unsure_split && !s.clean_split;
    // Report barycentrics clamped into the triangle.
    let hit = s.best.map(|h| {
        let (u, v) = clamp_to_triangle(h.u, h.v);
        PatchHit { t: h.t, u, v }
    });
    (hit, Ambiguity { miss: s.ambiguous, hit: hit.is_some() && s.best_unsure })
}

/// The parameters `x` of the degenerate members `x M + N` of the pencil (`x = ∞` for `M`),
/// best-conditioned first, and whether two of them are within rounding of a double root.
struct Members<T> {
    x: [T; 4],
    n: usize,
    near_multiple: bool,
}

/// Compute the roots of `det(x M + N) = 0` for the conics `M = cf`, `N = cg`.
fn degenerate_members<T: Real>(cf: &Conic<T>, cg: &Conic<T>) -> Members<T> {
    let (m, n) = (cf.mat(), cg.mat());
    // det(x M + N) = x³ det M + x² tr(adj(M) N) + x tr(M adj(N)) + det N.
    let c3 = det3(&m);
    let c2 = trace_prod(&adj3(&m), &n);
    let c1 = trace_prod(&m, &adj3(&n));
    let c0 = det3(&n);
    // Compare with the size of the terms: a pencil of conics that are all degenerate (a flat
    // patch: both conics are lines times the line at infinity) gives a zero cubic.
    let term = cf.norm().max(cg.norm());
    let cubic_scale = term * term * term;
    let mut out = Members { x: [T::ZERO; 4], n: 1, near_multiple: false };
    let cn = c3.abs().max(c2.abs()).max(c1.abs()).max(c0.abs());
    if cn <= T::gamma(64) * cubic_scale {
        return out; // every member is degenerate: take G itself (x = 0)
    }
    let (r, k, near_multiple) = solve_cubic_flagged(c3, c2, c1, c0);
    // Near a double root of the pencil (two intersection points about to merge: a grazing
    // ray) the root count and the line factors are uncertain: a miss is not decided here.
    out.near_multiple = near_multiple;
    out.x[..3].copy_from_slice(&r);
    out.n = k;
    // det M ≈ 0: M itself (x = ∞) is a degenerate member too.
    if c3.abs() <= T::gamma(64) * cubic_scale && out.n < 4 {
        out.x[out.n] = T::from_f64(f64::INFINITY);
        out.n += 1;
    }
    // Best-conditioned first: roots of small |x| keep N dominant (we intersect with M).
    out.x[..out.n].sort_by(|a, b| a.abs().partial_cmp(&b.abs()).unwrap_or(std::cmp::Ordering::Equal));
    out
}

/// The degenerate member at `x`, scaled so its entries stay O(1), and the conic that dominates
/// the other side of the pencil (the one its lines are intersected with).
fn member_at<'a, T: Real>(cf: &'a Conic<T>, cg: &'a Conic<T>, x: T) -> ([[T; 3]; 3], &'a Conic<T>) {
    let (m, n) = (cf.mat(), cg.mat());
    if !x.is_finite() {
        (m, cg)
    } else if x.abs() <= T::ONE {
        (std::array::from_fn(|i| std::array::from_fn(|j| x * m[i][j] + n[i][j])), cf)
    } else {
        let ix = T::ONE / x;
        (std::array::from_fn(|i| std::array::from_fn(|j| m[i][j] + ix * n[i][j])), cg)
    }
}

/// The state of the search over the pencil's members: the nearest hit so far and what the
/// answer rests on.
struct Search<T> {
    best: Option<PatchHit<T>>,
    /// Whether the nearest hit is an unpolished root whose Newton step diverged (a ray within
    /// rounding of tangency): it may be a near miss.
    best_unsure: bool,
    ambiguous: bool,
    /// A member was within rounding of a real line pair but gave no lines.
    unsure_split: bool,
    /// A member split into lines whose intersections were decided without a near tangency.
    clean_split: bool,
    /// The residual gate before polish (relative to the unit patch).
    size_tol: T,
    /// The distance from the domain beyond which a root is decided: the residual gate's own
    /// tolerance, relative to the unit patch, is the largest parameter error a root can carry.
    far: T,
}

impl<T: Real> Search<T> {
    fn new(near_multiple: bool) -> Self {
        let size_tol = T::gamma(64).sqrt();
        let far = size_tol * T::from_f64(16.0) + edge_band::<T>();
        Search {
            best: None,
            best_unsure: false,
            ambiguous: near_multiple,
            unsure_split: false,
            clean_split: false,
            size_tol,
            far,
        }
    }

    /// Split the member at `x` into lines and offer their intersections with the other conic:
    /// whether any root was found (then the later members are not needed).
    fn member(&mut self, p: &Patch<T>, ray: &LocalRay<T>, cf: &Conic<T>, cg: &Conic<T>, x: T) -> bool {
        let (h, other) = member_at(cf, cg, x);
        let lines = match split_degenerate(&h) {
            Ok(lines) => lines,
            Err(why) => {
                self.unsure_split |= why == NoLines::Unsure;
                return false;
            }
        };
        let (mut found_any, mut tangent_any) = (false, false);
        for l in lines {
            let (pts, k, near_tangent) = line_conic(l, other);
            self.ambiguous |= near_tangent;
            tangent_any |= near_tangent;
            for &(u, v) in &pts[..k] {
                found_any |= self.offer(p, ray, u, v, near_tangent);
            }
        }
        // Every intersection point of the two conics lies on every member of the pencil, so
        // one member split into real lines whose intersections were decided without a tangency
        // within rounding gives them all: members that were unsure of being point-like no
        // longer matter.
        self.clean_split |= !tangent_any;
        found_any
    }

    /// Offer the point `(u, v)` of a line and a conic as a root: whether it is one (on the ray,
    /// near the domain), kept as the nearest hit if it is inside the domain and the interval.
    fn offer(&mut self, p: &Patch<T>, ray: &LocalRay<T>, u: T, v: T, near_tangent: bool) -> bool {
        // Far outside the domain (beyond what rounding or a Newton step can move): not a hit in
        // any precision. Also keeps points near infinity (a line almost parallel to a
        // parabola's axis) out of the residual gate below.
        if !near_domain(u, v, self.far) {
            return false;
        }
        let (o, d) = (ray.o, ray.d);
        let q = p.eval_local(u, v) - o;
        let t = q.dot(d) / d.dot(d);
        // Reject spurious roots (from rounding in the pencil) by the distance to the ray.
        if !((q - d * t).length() <= self.size_tol) {
            self.ambiguous = true;
            return false;
        }
        // A vertex offered at near tangency is a root only to rounding: a hit on it is as
        // uncertain as a miss would be.
        let (u, v, t, diverged) =
            if ray.polish { self.polish(p, ray, (u, v, t), near_tangent) } else { (u, v, t, near_tangent) };
        // Within 64 domain tolerances of the domain: the f32 answer may flip in f64.
        if !inside(u, v) && near_domain(u, v, edge_band::<T>()) {
            self.ambiguous = true;
        }
        if inside(u, v) && t > ray.tmin && t < ray.tmax && self.best.is_none_or(|b| t < b.t) {
            self.best = Some(PatchHit { t, u, v });
            self.best_unsure = diverged;
        }
        true
    }

    /// One Newton step on a root that passed the residual gate, kept only if it stays on the
    /// ray and in the domain: the root and whether it is uncertain (`diverged`).
    fn polish(
        &mut self,
        p: &Patch<T>,
        ray: &LocalRay<T>,
        root: (T, T, T),
        diverged: bool,
    ) -> (T, T, T, bool) {
        let (o, d) = (ray.o, ray.d);
        let mut diverged = diverged;
        let (mut u, mut v, mut t) = root;
        if let Some(step) = newton_step(p, o, d, u, v, t) {
            (u, v, t) = step;
        }
        // A polished point must lie on the ray to rounding (relative to the terms).
        if !on_ray(p, o, d, u, v, t) {
            // Newton diverged (a near-singular Jacobian at tangency): keep the unpolished
            // root, which passed the residual gate.
            self.ambiguous = true;
            diverged = true;
            (u, v, t) = root;
        }
        // Two close roots (grazing): if the step jumped out of the domain, keep the unpolished
        // root when that one is inside.
        if !inside(u, v) && inside(root.0, root.1) {
            diverged = true;
            (u, v, t) = root;
        }
        (u, v, t, diverged)
    }
}
