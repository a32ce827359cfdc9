//! The paper's analytic method: the pencil of the ray's two conics, its degenerate members
//! split into lines, and the lines' intersections with a conic offered as roots.

use std::ops::{Add, Mul, Sub};

use super::conic::{
    adj3, det3, line_conic, project, split_degenerate, trace_prod, Conic, NoLines, Projected,
};
use super::domain::{clamp_to_triangle, edge_band, inside, near_domain, on_ray};
use super::newton::newton_step;
use super::poly::{monic_cubic_roots, solve_cubic_flagged};
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
/// decide differently. With `polish` in f32, a ray the lean solve leaves at a near tangency is
/// not searched further: it is reported as an ambiguous miss, for the caller to decide in f64.
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

/// [`analytic_local`] on the ray's two conics `pr` (from [`project`]). Inlined, so that the
/// lean solve is compiled into each version of the caller's multiversioned patch test (with
/// AVX2's three-operand forms in the x86-64-v3 one); the full search is not.
#[inline(always)]
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
    let (nf, ng) = (cf.norm(), cg.norm());
    if nf == T::ZERO || ng == T::ZERO {
        // The ray lies in the patch's plane (a flat patch seen edge-on): no isolated hit.
        return (None, Ambiguity::default());
    }
    let ray = LocalRay { o, d, tmin, tmax, polish };
    // The lean solve decides the clear cases; what rests on rounding goes the full way below.
    // Except a near tangency in a coarser precision than f64: it is left undecided (an
    // ambiguous miss, which the caller decides again in f64, where the lean solve settles it;
    // cheaper than the full search in f32, which nearly always ends there too).
    if polish {
        let lean = match lean_member(&cf, nf, &cg, ng) {
            Some((member, other)) => lean_roots(p, &ray, other, member),
            None => Err(Undecided::Other),
        };
        match lean {
            Ok(answer) => return answer,
            Err(Undecided::NearTangent) if T::UNIT_ROUNDOFF.to_f64() > 1e-10 => {
                return (None, Ambiguity { miss: true, hit: false })
            }
            Err(_) => {}
        }
    }
    full_search(p, &ray, &cf, &cg)
}

/// [`analytic_projected`] with polish, for a ray whose lean member is already known: `member`
/// is what [`lean_member`] gives for the conics `pr` (the packet kernel computes it for its
/// refused lanes together), so the answer is the same, bit for bit.
#[inline(always)]
pub(super) fn analytic_from_member<T: Real>(
    p: &Patch<T>,
    o: V3<T>,
    d: V3<T>,
    pr: &Projected<T>,
    tmin: T,
    tmax: T,
    member: LeanMember<T>,
) -> (Option<PatchHit<T>>, Ambiguity) {
    let ray = LocalRay { o, d, tmin, tmax, polish: true };
    let other = if member.meets_g { &pr.g } else { &pr.f };
    lean_answer(lean_roots(p, &ray, other, member)).unwrap_or_else(|| full_search(p, &ray, &pr.f, &pr.g))
}

/// The lean solve's answer, or `None` where the full search must decide. A near tangency in a
/// coarser precision than f64 is left undecided: an ambiguous miss, which the caller decides
/// again in f64, where the lean solve settles it (cheaper than the full search in f32, which
/// nearly always ends there too). [`analytic_projected`] writes the same match out: through
/// this function its analytic hits cost 68 instructions more (1,813 against 1,745 on the
/// sphere's primary rays, `scripts/instructions.sh`).
#[inline(always)]
fn lean_answer<T: Real>(
    lean: Result<(Option<PatchHit<T>>, Ambiguity), Undecided>,
) -> Option<(Option<PatchHit<T>>, Ambiguity)> {
    match lean {
        Ok(answer) => Some(answer),
        Err(Undecided::NearTangent) if T::UNIT_ROUNDOFF.to_f64() > 1e-10 => {
            Some((None, Ambiguity { miss: true, hit: false }))
        }
        Err(_) => None,
    }
}

/// The full search of [`analytic_projected`], for what the lean solve cannot decide (but a near
/// tangency in f32), and for every ray of the unpolished method: every degenerate member of the
/// pencil, best-conditioned first, split into lines whose roots are offered until one member
/// gives roots. Not inlined: it is the rare path.
#[inline(never)]
#[cold]
fn full_search<T: Real>(
    p: &Patch<T>,
    ray: &LocalRay<T>,
    cf: &Conic<T>,
    cg: &Conic<T>,
) -> (Option<PatchHit<T>>, Ambiguity) {
    // Compute the pencil's degenerate members, then offer the roots on their lines.
    let members = degenerate_members(cf, cg);
    let mut s = Search::new(members.near_multiple);
    for &x in &members.x[..members.n] {
        if s.member(p, ray, cf, cg, x) {
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
    /// The gates its roots pass.
    gates: RootGates<T>,
}

/// The gates a root of the analytic solve passes, in one home for the full search, the lean
/// solve and the lanes' (`lanes::roots`): all relative to the unit patch.
#[derive(Clone, Copy, Debug)]
pub(super) struct RootGates<T> {
    /// The residual gate before polish: the distance from the root's point to the ray.
    pub(super) size_tol: T,
    /// The distance from the domain beyond which a root is decided: the residual gate's own
    /// tolerance is the largest parameter error a root can carry.
    pub(super) far: T,
    /// The band around the domain within which a root is polished (the lean solves).
    pub(super) polish_band: T,
}

impl<T: Real> RootGates<T> {
    /// The gates in precision `T`.
    #[inline(always)]
    pub(super) fn new() -> Self {
        let size_tol = T::gamma(64).sqrt();
        RootGates {
            size_tol,
            far: size_tol * T::from_f64(16.0) + edge_band::<T>(),
            polish_band: edge_band::<T>() * T::from_f64(4.0),
        }
    }
}

impl<T: Real> Search<T> {
    fn new(near_multiple: bool) -> Self {
        Search {
            best: None,
            best_unsure: false,
            ambiguous: near_multiple,
            unsure_split: false,
            clean_split: false,
            gates: RootGates::new(),
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
            let (pts, k, tangency) = line_conic(l, other);
            let near_tangent = tangency.is_some();
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
        if !near_domain(u, v, self.gates.far) {
            return false;
        }
        let (o, d) = (ray.o, ray.d);
        let q = p.eval_local(u, v) - o;
        let t = q.dot(d) / d.dot(d);
        // Reject spurious roots (from rounding in the pencil) by the distance to the ray.
        if !((q - d * t).length() <= self.gates.size_tol) {
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

/// The member of the pencil the lean solve takes (the root of the cubic whose member is most
/// clearly a real line pair), split into its two lines, with the conic those lines meet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct LeanMember<T> {
    /// The two lines `(l0, l1, l2)`: `l0 u + l1 v + l2 = 0`.
    pub(super) lines: [[T; 3]; 2],
    /// The lines meet `G` (the member's root `|x| > 1`), else `F`.
    pub(super) meets_g: bool,
    /// Two roots of the cubic are within rounding of a double root.
    pub(super) near_multiple: bool,
}

/// The lean analytic solve's first half: one degenerate member of the pencil of `F` and `G`
/// (with their sizes, [`Conic::norm`]), every intersection point of the two conics lying on
/// it, split into its lines ([`LeanMember`]). `None` for a degenerate or near-flat pencil or
/// no member clearly a line pair: the full search's cases.
#[inline(always)]
pub(super) fn lean_member<'a, T: Real>(
    cf: &'a Conic<T>,
    nf: T,
    cg: &'a Conic<T>,
    ng: T,
) -> Option<(LeanMember<T>, &'a Conic<T>)> {
    let (m, n) = (sym_of(cf), sym_of(cg));
    let (x, near_multiple) = line_pair_root(&m, &n, nf, ng)?;
    let (h, other, meets_g) = if x.abs() <= T::ONE {
        (std::array::from_fn(|i| x * m[i] + n[i]), cf, false)
    } else {
        let ix = T::ONE / x;
        (std::array::from_fn(|i| m[i] + ix * n[i]), cg, true)
    };
    let lines = split_line_pair(&h)?;
    Some((LeanMember { lines, meets_g, near_multiple }, other))
}

/// The lean analytic solve's second half: the lines of the member ([`lean_member`]) met with
/// the other conic, and Newton polish of the nearest root in the domain only. `Err` where the
/// answer would rest on a step within rounding (a near tangency, a spurious root, a polish that
/// diverged), with the reason ([`Undecided`]): then the full search of [`analytic_projected`]
/// decides, with its ambiguity flags, or f64 decides. A line within rounding of tangent to the
/// other conic whose points stay far from the domain is passed over.
#[inline(always)]
fn lean_roots<T: Real>(
    p: &Patch<T>,
    ray: &LocalRay<T>,
    other: &Conic<T>,
    member: LeanMember<T>,
) -> Result<(Option<PatchHit<T>>, Ambiguity), Undecided> {
    let LeanMember { lines, near_multiple, .. } = member;
    // Compute the roots on its lines near the domain, gated by the distance to the ray.
    let RootGates { size_tol, far, polish_band } = RootGates::<T>::new();
    let tol2 = size_tol * size_tol;
    let (o, d) = (ray.o, ray.d);
    let inv_dd = T::ONE / d.dot(d);
    let mut cand =
        [Candidate { u: T::ZERO, v: T::ZERO, t: T::ZERO, r: V3::new(T::ZERO, T::ZERO, T::ZERO) }; 4];
    let mut k = 0;
    for l in lines {
        let (pts, n, tangency) = line_conic(l, other);
        if let Some(reach) = tangency {
            // A tangency whose points, wherever rounding puts them, stay beyond the far band
            // of the domain decides nothing: such a line is passed over, as a root there is.
            // Near the domain it is a grazing ray, for f64 to decide.
            if pts[..n].iter().any(|&(u, v)| near_domain(u, v, far + reach)) {
                return Err(Undecided::NearTangent);
            }
            continue;
        }
        for &(u, v) in &pts[..n] {
            if !near_domain(u, v, far) {
                continue;
            }
            let q = p.eval_local(u, v) - o;
            let t = q.dot(d) * inv_dd;
            let r = q - d * t;
            if !(r.dot(r) <= tol2) {
                return Err(Undecided::Other);
            }
            // Clearly outside the domain: no polish can bring it in.
            if near_domain(u, v, polish_band) {
                cand[k] = Candidate { u, v, t, r };
                k += 1;
            }
        }
    }
    nearest_polished(p, ray, &mut cand[..k], near_multiple)
}

/// Why the lean solve left a ray undecided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Undecided {
    /// A line of the member within rounding of tangent to the other conic near the domain, or a
    /// polish that diverged or jumped out of the domain: a grazing ray, which a finer precision
    /// settles.
    NearTangent,
    /// A degenerate or near-flat pencil, no member clearly a line pair, or a spurious root: the
    /// full search's cases.
    Other,
}

/// A root offered by the lean solve: its parameters, its ray parameter and its residual
/// `P(u, v) - o - t d` (local frame).
#[derive(Clone, Copy)]
struct Candidate<T> {
    u: T,
    v: T,
    t: T,
    r: V3<T>,
}

/// Polish the roots `cand` nearest first, and answer with the first one inside the domain and
/// the interval; [`Undecided::NearTangent`] if a polish diverged.
#[inline(always)]
fn nearest_polished<T: Real>(
    p: &Patch<T>,
    ray: &LocalRay<T>,
    cand: &mut [Candidate<T>],
    near_multiple: bool,
) -> Result<(Option<PatchHit<T>>, Ambiguity), Undecided> {
    let (o, d) = (ray.o, ray.d);
    let mut ambiguous = near_multiple;
    for i in 0..cand.len() {
        // The nearest of those left (there are at most 4).
        let j = (i + 1..cand.len()).fold(i, |j, k| if cand[k].t < cand[j].t { k } else { j });
        cand.swap(i, j);
        let Candidate { u, v, t, r } = cand[i];
        let (pu, pv, pt) = step_from_residual(p, d, (u, v, t), r).unwrap_or((u, v, t));
        if !on_ray(p, o, d, pu, pv, pt) || (!inside(pu, pv) && inside(u, v)) {
            return Err(Undecided::NearTangent); // Newton diverged or jumped out
        }
        if !inside(pu, pv) {
            ambiguous |= near_domain(pu, pv, edge_band::<T>());
        } else if pt > ray.tmin && pt < ray.tmax {
            let (u, v) = clamp_to_triangle(pu, pv);
            return Ok((Some(PatchHit { t: pt, u, v }), Ambiguity { miss: ambiguous, hit: false }));
        }
    }
    Ok((None, Ambiguity { miss: ambiguous, hit: false }))
}

/// One Newton step on `P(u,v) - o - t d = 0` from `root`, whose residual `r` is known: as
/// [`newton_step`] computes it (the same operations in the same order, so the same bits),
/// without evaluating the patch again.
#[inline(always)]
fn step_from_residual<T: Real>(p: &Patch<T>, d: V3<T>, root: (T, T, T), r: V3<T>) -> Option<(T, T, T)> {
    let (u, v, t) = root;
    let (pu, pv) = p.partials_local(u, v);
    // Solve [pu pv -d] [du dv dt]ᵀ = -r by Cramer's rule.
    let nd = -d;
    let w = pv.cross(nd);
    let det = pu.dot(w);
    if det == T::ZERO || !det.is_finite() {
        return None;
    }
    let inv = T::ONE / det;
    let du = -r.dot(w) * inv;
    let dv = -pu.dot(r.cross(nd)) * inv;
    let dt = -pu.dot(pv.cross(r)) * inv;
    let (nu, nv, nt) = (u + du, v + dv, t + dt);
    (nu.is_finite() && nv.is_finite() && nt.is_finite()).then_some((nu, nv, nt))
}

/// A symmetric 3×3 matrix by its entries `[s00, s11, s22, s01, s02, s12]`.
pub(super) type Sym<T> = [T; 6];

/// The conic's matrix (see [`Conic`]).
#[inline(always)]
fn sym_of<T: Real>(k: &Conic<T>) -> Sym<T> {
    let h = T::from_f64(0.5);
    let [a, b, c, d, e, f] = k.k;
    [a, b, f, c * h, d * h, e * h]
}

/// What [`pencil_cubic`] and [`trace_adj_quadratic`] compute with: a scalar, or one per lane (the packet kernel's),
/// with the same operations in the same order either way.
pub(super) trait Arith: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> {}

impl<X: Copy + Add<Output = X> + Sub<Output = X> + Mul<Output = X>> Arith for X {}

/// The pencil's cubic, from `M` and `N`: `det(x M + N) = x³ det M + x² tr(adj(M) N) + x tr(M
/// adj(N)) + det N` as `[c3, c2, c1, c0]`, with `adj(M)` and `adj(N)` (for
/// [`trace_adj_quadratic`]). Generic over the arithmetic, so that the scalar solve and the packet
/// kernel's lanes compute it in one order (the same bits).
#[inline(always)]
pub(super) fn pencil_cubic<T: Arith>(m: &Sym<T>, n: &Sym<T>) -> ([T; 4], Sym<T>, Sym<T>) {
    let (am, an) = (sym_adj(m), sym_adj(n));
    let c3 = m[0] * am[0] + m[3] * am[3] + m[4] * am[4];
    let c2 = sym_trace_prod(&am, n);
    let c1 = sym_trace_prod(m, &an);
    let c0 = n[0] * an[0] + n[3] * an[3] + n[4] * an[4];
    ([c3, c2, c1, c0], am, an)
}

/// `tr adj(x M + N) = x² tr adj(M) + x t1 + tr adj(N)` as `(t2, t1, t0)`, from `M`, `N` and
/// their adjugates `am`, `an`; generic as [`pencil_cubic`] is.
#[inline(always)]
pub(super) fn trace_adj_quadratic<T: Arith>(m: &Sym<T>, n: &Sym<T>, am: &Sym<T>, an: &Sym<T>) -> (T, T, T) {
    let t2 = am[0] + am[1] + am[2];
    let t0 = an[0] + an[1] + an[2];
    let t1 = mixed(m, n, 0, 1, 3) + mixed(m, n, 0, 2, 4) + mixed(m, n, 1, 2, 5);
    (t2, t1, t0)
}

/// The term of `t1` (see [`trace_adj_quadratic`]) from the entries `i`, `j` and their
/// off-diagonal `ij`.
#[inline(always)]
fn mixed<T: Arith>(m: &Sym<T>, n: &Sym<T>, i: usize, j: usize, ij: usize) -> T {
    m[i] * n[j] + n[i] * m[j] - (m[ij] * n[ij] + m[ij] * n[ij])
}

/// The adjugate of a symmetric matrix (symmetric too).
#[inline(always)]
pub(super) fn sym_adj<T: Arith>(m: &Sym<T>) -> Sym<T> {
    let [m00, m11, m22, m01, m02, m12] = *m;
    [
        m11 * m22 - m12 * m12,
        m00 * m22 - m02 * m02,
        m00 * m11 - m01 * m01,
        m02 * m12 - m01 * m22,
        m01 * m12 - m02 * m11,
        m01 * m02 - m00 * m12,
    ]
}

/// `tr(A B)` of two symmetric matrices.
#[inline(always)]
fn sym_trace_prod<T: Arith>(a: &Sym<T>, b: &Sym<T>) -> T {
    let off = a[3] * b[3] + a[4] * b[4] + a[5] * b[5];
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + off + off
}

/// The root `x` of `det(x M + N)` whose member is most clearly a real line pair, and whether
/// two roots are within rounding of a double root (as [`solve_cubic_flagged`] tells them).
/// `None` for a pencil the full search handles: all members or `M` degenerate, a cubic that
/// drops degree, or no member clearly a line pair. `nm`, `nn`: the conics' sizes.
///
/// A degenerate member has rank 2, and `adj(H) = -p pᵀ` for a pair of real lines through `p`,
/// `+p pᵀ` for a point-like pair of complex lines: the sign of `tr adj(x M + N)`, a quadratic
/// in `x`, tells them apart. Two real conics meet in 4 real points (three real members, all
/// line pairs), 2 (one real member, a line pair) or none (three, one a line pair): there is
/// always a line pair to take, and any one carries every intersection point.
#[inline(always)]
fn line_pair_root<T: Real>(m: &Sym<T>, n: &Sym<T>, nm: T, nn: T) -> Option<(T, bool)> {
    let ([c3, c2, c1, c0], am, an) = pencil_cubic(m, n);
    let term = nm.max(nn);
    let cubic_scale = term * term * term;
    let cn = c3.abs().max(c2.abs()).max(c1.abs()).max(c0.abs());
    if c3.abs() <= T::gamma(64) * cubic_scale || c3.abs() <= T::gamma(16) * cn {
        return None;
    }
    let (a, b, c) = (c2 / c3, c1 / c3, c0 / c3);
    let q = (a * a - T::from_f64(3.0) * b) * T::from_f64(1.0 / 9.0);
    let r = (T::from_f64(2.0) * a * a * a - T::from_f64(9.0) * a * b + T::from_f64(27.0) * c)
        * T::from_f64(1.0 / 54.0);
    let near_multiple = (r * r - q * q * q).abs() <= T::gamma(256) * (r * r).max((q * q * q).abs());
    let (roots, k) = monic_cubic_roots(a, b, c)?;
    // Score the roots by tr adj(x M + N), relative to the member's size.
    let (t2, t1, t0) = trace_adj_quadratic(m, n, &am, &an);
    let score = |x: T| line_pair_score(x, (t2, t1, t0), nm, nn);
    let (mut best, mut best_score) = (roots[0], score(roots[0]));
    for &x in &roots[1..k] {
        let sx = score(x);
        if sx < best_score {
            (best, best_score) = (x, sx);
        }
    }
    if !(best_score < -T::gamma(64).sqrt()) {
        return None;
    }
    // Compute the chosen root to full precision (the quotient's roots carry the first's error).
    if best != roots[0] {
        for _ in 0..2 {
            let f = ((best + a) * best + b) * best + c;
            let df = (T::from_f64(3.0) * best + a + a) * best + b;
            let nx = best - f / df;
            if nx.is_finite() {
                best = nx;
            }
        }
    }
    Some((best, near_multiple))
}

/// `tr adj(x M + N) = x² t2 + x t1 + t0` relative to the member's size (`nm`, `nn`: the sizes
/// of `M` and `N`): clearly negative for a real line pair, positive for a point-like one.
#[inline(always)]
fn line_pair_score<T: Real>(x: T, (t2, t1, t0): (T, T, T), nm: T, nn: T) -> T {
    if x.abs() <= T::ONE {
        let s = x.abs() * nm + nn;
        ((x * t2 + t1) * x + t0) / (s * s)
    } else {
        let ix = T::ONE / x;
        let s = nm + ix.abs() * nn;
        ((t0 * ix + t1) * ix + t2) / (s * s)
    }
}

/// Split a degenerate conic `h` known to be a pair of real lines well apart (the member
/// [`line_pair_root`] chose) into its two lines `(l0, l1, l2)`: `l0 u + l1 v + l2 = 0`, as
/// [`split_degenerate`] does, without its rank and point-like tests.
#[inline(always)]
fn split_line_pair<T: Real>(h: &Sym<T>) -> Option<[[T; 3]; 2]> {
    // adj(H) = -p pᵀ for two real lines meeting at p (Richter-Gebert, §11.3).
    let b = sym_adj(h);
    let (col, bii) = if b[0] <= b[1] && b[0] <= b[2] {
        ([b[0], b[3], b[4]], b[0])
    } else if b[1] <= b[2] {
        ([b[3], b[1], b[5]], b[1])
    } else {
        ([b[4], b[5], b[2]], b[2])
    };
    if !(bii < T::ZERO) {
        return None;
    }
    let inv = T::ONE / (-bii).sqrt();
    let p = [col[0] * inv, col[1] * inv, col[2] * inv];
    let [h00, h11, h22, h01, h02, h12] = *h;
    // H + [p]× has rank 1: its largest entry's row and column are the two lines.
    let c = [[h00, h01 + p[2], h02 - p[1]], [h01 - p[2], h11, h12 + p[0]], [h02 + p[1], h12 - p[0], h22]];
    let (mut bi, mut bj, mut bm) = (0, 0, T::ZERO);
    for (r, row) in c.iter().enumerate() {
        for (s, x) in row.iter().enumerate() {
            let a = x.abs();
            if a > bm {
                (bm, bi, bj) = (a, r, s);
            }
        }
    }
    if !(bm > T::ZERO) {
        return None;
    }
    Some([c[bi], [c[0][bj], c[1][bj], c[2][bj]]])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phong::accuracy::{generate, Category, SplitMix};

    /// The lean solve's polish step, from the residual it already has, gives the bits of
    /// [`newton_step`] (points in and around the domain, on rays of every accuracy category).
    #[test]
    fn step_from_residual_gives_newton_steps_bits() {
        let mut rng = SplitMix(18);
        let bits = |(u, v, t): (f32, f32, f32)| (u.to_bits(), v.to_bits(), t.to_bits());
        let mut steps = 0;
        for i in 0..20_000 {
            let c = generate(&mut rng, Category::ALL[i % Category::ALL.len()]);
            let p: Patch<f32> = Patch::new(c.p, c.n, c.alpha);
            let o = (V3::from(c.org).cast::<f32>() - p.center) * p.inv_scale;
            let d = V3::from(c.dir).cast::<f32>() * p.inv_scale;
            let (u, v) = (rng.range(-0.2, 1.2) as f32, rng.range(-0.2, 1.2) as f32);
            let q = p.eval_local(u, v) - o;
            let t = q.dot(d) / d.dot(d);
            let lean = step_from_residual(&p, d, (u, v, t), q - d * t);
            assert_eq!(lean.map(bits), newton_step(&p, o, d, u, v, t).map(bits), "case {i}: {c:?}");
            steps += lean.is_some() as usize;
        }
        assert!(steps > 15_000, "only {steps} steps taken");
    }
}
