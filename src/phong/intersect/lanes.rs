//! Eight lanes at once: the certified method of [`Method::Certified`](super::Method::Certified)
//! for up to [`LANES`] rays against one f32 patch, with every step (the local frame, the hull and
//! prism test, the projection, the det-sign certificate and where it fails the positive-definite
//! one, Newton in the plane and the Newton step in space) run on all lanes together, as plain
//! loops over fixed-size arrays that the compiler vectorises: AVX2 (one register of 8 lanes) or
//! SSE 4.1 (two of 4), chosen at run time, or the baseline target's own vectors. Where both
//! certificates refuse lanes, the lean analytic solve runs on them together too: the pencil's
//! line-pair member and its lines ([`member`]), then the roots on them ([`roots`]).
//!
//! Each lane computes exactly what the scalar path computes, in the same order: no fused
//! operations (Rust never contracts `a * b + c`), the same `min`/`max` (by comparison, as
//! [`Real::max`]), the same constants, so a lane it decides has bit for bit the scalar path's
//! answer. What it does not decide (Newton does not converge, the root lies in the band where the
//! scalar path asks f64, a certified miss on a sliver seen from afar; of the refused lanes, those
//! the analytic solve would not settle in the lanes' clear cases) it leaves
//! [`LaneDecision::Unsure`], for the scalar path through [`LaneAnswers::unsure_answer`]: the
//! analytic method at once, from the lane's projected conics and its member, where both
//! certificates refused it, [`intersect_in_hull_traced`](super::intersect_in_hull_traced) (the
//! hull passed) otherwise.

// The lane loops index every array by the lane: the form the vectoriser turns into one
// instruction per operation.
#![allow(clippy::needless_range_loop)]

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

use multiversion::multiversion;

mod member;
mod roots;
use member::{member_lanes, MemberLanes};
use roots::roots_lanes;

use super::conic::{Conic, Projected};
use super::detsign::unfolded_along;
use super::domain::{domain_tolerance, edge_band};
use super::net::misses_net;
use super::{dispatch, intersect_in_hull_traced, Method, PatchHit, TestOutcome};
use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// The lanes of one block: a packet of 8 rays, or half of one of 16.
pub const LANES: usize = 8;

/// Up to [`LANES`] rays, structure of arrays, world space. Lanes the caller does not need may
/// hold anything (their answers are computed and ignored).
#[derive(Clone, Copy, Debug)]
pub struct LaneRays {
    /// The origins' x, y and z.
    pub org: [[f32; LANES]; 3],
    /// The directions' x, y and z.
    pub dir: [[f32; LANES]; 3],
    /// The open interval's lower ends.
    pub tmin: [f32; LANES],
    /// The open interval's upper ends.
    pub tmax: [f32; LANES],
}

impl LaneRays {
    /// Lane `i`'s ray: its origin and direction.
    ///
    /// # Panics
    /// If `i >= LANES`.
    #[inline(always)]
    pub fn ray(&self, i: usize) -> (V3<f32>, V3<f32>) {
        let (o, d) = (&self.org, &self.dir);
        (V3::new(o[0][i], o[1][i], o[2][i]), V3::new(d[0][i], d[1][i], d[2][i]))
    }
}

/// What the lane kernel decided for one lane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LaneDecision {
    /// No hit: turned away as bad input, rejected by the hull, a certified miss, or a clear miss
    /// of the analytic solve.
    Miss,
    /// A certified hit, or one of the analytic solve, in [`LaneAnswers::hit`].
    Hit,
    /// Past the hull, not settled: the scalar path decides.
    Unsure,
}

/// The answers of [`certified_lanes`].
#[derive(Clone, Copy, Debug)]
pub struct LaneAnswers {
    /// Per lane, what was decided.
    pub decision: [LaneDecision; LANES],
    /// The hits' `t`.
    pub t: [f32; LANES],
    /// The hits' `u`.
    pub u: [f32; LANES],
    /// The hits' `v`.
    pub v: [f32; LANES],
    /// Bit `i` set where lane `i` is unsure because both certificates refused it.
    refused: u32,
    /// What the scalar path takes on from the refused lanes, where `refused` has a lane. An
    /// `Option`, so that a call that refuses none (nearly all) writes none of it: its answers are
    /// made with `None`, a tag, where the arrays themselves cost a `memset` per call.
    refused_lanes: Option<RefusedLanes>,
}

/// The refused lanes' projected conics and lean members, for the scalar path's analytic method.
#[derive(Clone, Copy, Debug)]
struct RefusedLanes {
    /// The projected conics' 12 coefficients (`F`'s, then `G`'s), per lane.
    conics: [[f32; LANES]; 12],
    /// The lean analytic solve's members of their pencils, computed together.
    members: MemberLanes,
}

/// Lane `i`'s projected conics from their 12 coefficients per lane (`F`'s, then `G`'s).
#[inline(always)]
fn lane_conics(conics: &[[f32; LANES]; 12], i: usize) -> Projected<f32> {
    let k = |j: usize| conics[j][i];
    Projected {
        f: Conic { k: [k(0), k(1), k(2), k(3), k(4), k(5)] },
        g: Conic { k: [k(6), k(7), k(8), k(9), k(10), k(11)] },
    }
}

impl LaneAnswers {
    /// Lane `i`'s hit, where [`LaneAnswers::decision`] says [`LaneDecision::Hit`].
    pub fn hit(&self, i: usize) -> Option<PatchHit<f32>> {
        (self.decision[i] == LaneDecision::Hit).then(|| PatchHit { t: self.t[i], u: self.u[i], v: self.v[i] })
    }

    /// Lane `i`'s answer where [`LaneAnswers::decision`] says [`LaneDecision::Unsure`], with its
    /// outcome: the scalar certified path's on `p` (as
    /// [`intersect_in_hull_traced`](super::intersect_in_hull_traced) with
    /// [`Method::Certified`]), for the lane's world-space ray `(org, dir)` and interval
    /// `(tmin, tmax)` as given to [`certified_lanes`]. Where the kernel found both certificates
    /// refused, the scalar path starts where it stopped: the analytic method on the lane's
    /// projected conics (the scalar projection's bits), with no second projection and no second
    /// certificate; unless the ray lies in the patch's cone of unfolded directions, which the
    /// kernel does not test and the scalar path certifies by.
    ///
    /// # Panics
    /// If `i >= LANES`, as [`LaneAnswers::hit`].
    pub fn unsure_answer(
        &self,
        p: &Patch<f32>,
        i: usize,
        org: V3<f32>,
        dir: V3<f32>,
        tmin: f32,
        tmax: f32,
    ) -> (Option<PatchHit<f32>>, TestOutcome) {
        // A ray in the patch's cone of unfolded directions (which the kernel does not test)
        // takes the scalar path whole, which certifies it by the cone.
        let refused = self.refused_lanes.as_ref().filter(|_| self.refused >> i & 1 != 0);
        let Some(refused) = refused.filter(|_| !unfolded_along(p, dir * p.inv_scale)) else {
            return intersect_in_hull_traced(p, org, dir, tmin, tmax, Method::Certified);
        };
        let pr = lane_conics(&refused.conics, i);
        dispatch::refused_dispatched(p, org, dir, tmin, tmax, &pr, refused.members.get(i))
    }
}

/// [`Method::Certified`](super::Method::Certified) on every lane of `rays` against `p`, 8 lanes
/// at once where the CPU allows: each decided lane's answer is the scalar path's, bit for bit.
/// The kernel in one call: [`hull_of_lanes`], then [`certified_lanes_past`].
#[inline]
pub fn certified_lanes(p: &Patch<f32>, rays: &LaneRays) -> LaneAnswers {
    certified_lanes_past(p, &hull_of_lanes(p, rays), rays)
}

/// The first half of [`certified_lanes`]: the local rays and the hull test on every lane of
/// `rays` against `p` (bad input turned away). Where no lane passes it
/// ([`LaneHull::is_empty`]), every lane is a miss, as for most of the packets that enter a
/// patch's box. A caller may leave lanes out ([`LaneHull::leave_out`]) before
/// [`certified_lanes_past`] decides the rest.
#[inline]
pub fn hull_of_lanes(p: &Patch<f32>, rays: &LaneRays) -> LaneHull {
    if p.degenerate {
        let zero = V::splat(V3::new(0.0, 0.0, 0.0));
        return LaneHull(HullLanes { o: zero, d: zero, passed: M::none() });
    }
    // Returned as it is made (wrapped in an `Option`, it was copied by `memcpy`).
    LaneHull(hull_for_cpu(p, rays))
}

/// The second half of [`certified_lanes`]: the lanes of `hull` (from [`hull_of_lanes`] on the
/// same `p` and `rays`) decided, the others misses.
#[inline]
pub fn certified_lanes_past(p: &Patch<f32>, hull: &LaneHull, rays: &LaneRays) -> LaneAnswers {
    let mut out = LaneAnswers::all(LaneDecision::Miss);
    // One lane past the hull costs the scalar path less than all lanes through the stages below.
    match hull.0.passed.count() {
        0 => out,
        1 => {
            for i in (0..LANES).filter(|&i| hull.0.passed.lane(i)) {
                out.decision[i] = LaneDecision::Unsure;
            }
            out
        }
        _ => solve_for_cpu(p, &hull.0, rays),
    }
}

/// The lanes past a patch's hull, from [`hull_of_lanes`].
pub struct LaneHull(HullLanes);

impl std::fmt::Debug for LaneHull {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LaneHull")
            .field("passed", &std::array::from_fn::<bool, LANES, _>(|i| self.passed(i)))
            .finish()
    }
}

impl LaneHull {
    /// Whether no lane passed (or every lane that did is left out).
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        !self.0.passed.any()
    }

    /// Whether lane `i` passed the hull test and is not left out.
    ///
    /// # Panics
    /// If `i >= LANES`.
    #[inline(always)]
    pub fn passed(&self, i: usize) -> bool {
        self.0.passed.lane(i)
    }

    /// Leave lane `i` out of [`certified_lanes_past`]: its answer a miss.
    ///
    /// # Panics
    /// If `i >= LANES`.
    #[inline(always)]
    pub fn leave_out(&mut self, i: usize) {
        self.0.passed.0[i] = 0;
    }
}

/// [`hull_lanes`] compiled for the widest vectors the CPU has, chosen at run time by the
/// `multiversion` crate: AVX2 (one 256-bit register per 8 lanes), SSE 4.1 (two 128-bit
/// registers, with `blendv` selects), or the baseline target's SSE2. A function of its own:
/// inlined into the stages after it, its loops were vectorised 4 lanes at a time and not
/// unrolled (about 800 instructions for 8 lanes instead of 250, counted by callgrind).
#[multiversion(targets("x86_64+avx2", "x86_64+sse4.1"))]
fn hull_for_cpu(p: &Patch<f32>, rays: &LaneRays) -> HullLanes {
    hull_lanes(p, rays)
}

/// [`solve_lanes`] compiled for the widest vectors the CPU has (as [`hull_for_cpu`]).
#[multiversion(targets("x86_64+avx2", "x86_64+sse4.1"))]
fn solve_for_cpu(p: &Patch<f32>, hull: &HullLanes, rays: &LaneRays) -> LaneAnswers {
    solve_lanes(p, hull, rays)
}

impl LaneAnswers {
    fn all(d: LaneDecision) -> Self {
        LaneAnswers {
            decision: [d; LANES],
            t: [0.0; LANES],
            u: [0.0; LANES],
            v: [0.0; LANES],
            refused: 0,
            refused_lanes: None,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Lanes of f32 and of bool, with the scalar path's operations.

/// One f32 per lane.
#[derive(Clone, Copy)]
#[repr(align(32))]
struct F([f32; LANES]);

/// One mask per lane: all bits set (true) or none, as the vector compares give them, so that
/// the masks, their logic and the selects stay in the same registers as the floats.
#[derive(Clone, Copy)]
#[repr(align(32))]
struct M([u32; LANES]);

/// `f(a[i])` for every lane.
#[inline(always)]
fn map(a: F, f: impl Fn(f32) -> f32) -> F {
    let mut r = [0.0; LANES];
    for i in 0..LANES {
        r[i] = f(a.0[i]);
    }
    F(r)
}

/// `f(a[i], b[i])` for every lane.
#[inline(always)]
fn zip(a: F, b: F, f: impl Fn(f32, f32) -> f32) -> F {
    let mut r = [0.0; LANES];
    for i in 0..LANES {
        r[i] = f(a.0[i], b.0[i]);
    }
    F(r)
}

/// The mask of `f(a[i], b[i])`.
#[inline(always)]
fn test(a: F, b: F, f: impl Fn(f32, f32) -> bool) -> M {
    let mut r = [0; LANES];
    for i in 0..LANES {
        r[i] = if f(a.0[i], b.0[i]) { u32::MAX } else { 0 };
    }
    M(r)
}

/// `f(a[i], b[i])` on the masks' bits.
#[inline(always)]
fn bits(a: M, b: M, f: impl Fn(u32, u32) -> u32) -> M {
    let mut r = [0; LANES];
    for i in 0..LANES {
        r[i] = f(a.0[i], b.0[i]);
    }
    M(r)
}

impl F {
    #[inline(always)]
    fn splat(x: f32) -> F {
        F([x; LANES])
    }
    #[inline(always)]
    fn abs(self) -> F {
        map(self, f32::abs)
    }
    #[inline(always)]
    fn sqrt(self) -> F {
        map(self, f32::sqrt)
    }
    /// [`Real::max`]: `o` when either is NaN.
    #[inline(always)]
    fn max(self, o: F) -> F {
        select(self.gt(o), self, o)
    }
    /// [`Real::min`]: `o` when either is NaN.
    #[inline(always)]
    fn min(self, o: F) -> F {
        select(self.lt(o), self, o)
    }
    #[inline(always)]
    fn gt(self, o: F) -> M {
        test(self, o, |a, b| a > b)
    }
    #[inline(always)]
    fn ge(self, o: F) -> M {
        test(self, o, |a, b| a >= b)
    }
    #[inline(always)]
    fn le(self, o: F) -> M {
        test(self, o, |a, b| a <= b)
    }
    #[inline(always)]
    fn lt(self, o: F) -> M {
        test(self, o, |a, b| a < b)
    }
    #[inline(always)]
    fn eq(self, o: F) -> M {
        test(self, o, |a, b| a == b)
    }
    /// Neither infinite nor NaN: `x - x` is `+0` exactly then (NaN otherwise). The same
    /// answer as `|x| < inf`, which LLVM turns into a class test it does lane by lane.
    #[inline(always)]
    #[allow(clippy::eq_op)] // `x - x` is the point: it is NaN for an infinite or NaN `x`
    fn finite(self) -> M {
        (self - self).eq(F::splat(0.0))
    }
    /// The sign bit is clear.
    #[inline(always)]
    fn sign_positive(self) -> M {
        let mut r = [0; LANES];
        for i in 0..LANES {
            r[i] = ((self.0[i].to_bits() as i32) >> 31) as u32;
        }
        !M(r)
    }
}

/// `a` where `m`, else `b` (on the bits, as a blend).
#[inline(always)]
fn select(m: M, a: F, b: F) -> F {
    let mut r = [0.0; LANES];
    for i in 0..LANES {
        r[i] = f32::from_bits((a.0[i].to_bits() & m.0[i]) | (b.0[i].to_bits() & !m.0[i]));
    }
    F(r)
}

macro_rules! lane_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for F {
            type Output = F;
            #[inline(always)]
            fn $f(self, o: F) -> F {
                zip(self, o, |a, b| a $op b)
            }
        }
    };
}
lane_op!(Add, add, +);
lane_op!(Sub, sub, -);
lane_op!(Mul, mul, *);
lane_op!(Div, div, /);

impl Neg for F {
    type Output = F;
    #[inline(always)]
    fn neg(self) -> F {
        map(self, |a| -a)
    }
}

impl M {
    #[inline(always)]
    fn none() -> M {
        M([0; LANES])
    }
    #[inline(always)]
    fn any(self) -> bool {
        self.0.iter().fold(0, |a, &b| a | b) != 0
    }
    #[inline(always)]
    fn count(self) -> u32 {
        self.0.iter().fold(0, |n, &b| n + (b & 1))
    }
    #[inline(always)]
    fn lane(self, i: usize) -> bool {
        self.0[i] != 0
    }
    /// Bit `i` set where lane `i` is.
    #[inline(always)]
    fn bits(self) -> u32 {
        (0..LANES).fold(0, |b, i| b | (self.0[i] & 1) << i)
    }
}

impl BitAnd for M {
    type Output = M;
    #[inline(always)]
    fn bitand(self, o: M) -> M {
        bits(self, o, |a, b| a & b)
    }
}

impl BitOr for M {
    type Output = M;
    #[inline(always)]
    fn bitor(self, o: M) -> M {
        bits(self, o, |a, b| a | b)
    }
}

impl Not for M {
    type Output = M;
    #[inline(always)]
    fn not(self) -> M {
        bits(self, self, |a, _| !a)
    }
}

/// A 3-vector per lane, with [`V3`]'s operations in its order.
#[derive(Clone, Copy)]
struct V {
    x: F,
    y: F,
    z: F,
}

impl V {
    #[inline(always)]
    fn splat(a: V3<f32>) -> V {
        V { x: F::splat(a.x), y: F::splat(a.y), z: F::splat(a.z) }
    }
    #[inline(always)]
    fn dot(self, o: V) -> F {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    fn cross(self, o: V) -> V {
        V { x: self.y * o.z - self.z * o.y, y: self.z * o.x - self.x * o.z, z: self.x * o.y - self.y * o.x }
    }
    #[inline(always)]
    fn scale(self, s: F) -> V {
        V { x: self.x * s, y: self.y * s, z: self.z * s }
    }
    #[inline(always)]
    fn max_abs(self) -> F {
        self.x.abs().max(self.y.abs()).max(self.z.abs())
    }
    #[inline(always)]
    fn finite(self) -> M {
        self.x.finite() & self.y.finite() & self.z.finite()
    }
}

impl Add for V {
    type Output = V;
    #[inline(always)]
    fn add(self, o: V) -> V {
        V { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

impl Sub for V {
    type Output = V;
    #[inline(always)]
    fn sub(self, o: V) -> V {
        V { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

// ---------------------------------------------------------------------------------------------
// The kernel, stage by stage (each the lane form of the scalar function it names).

/// The patch's coefficients, one copy per lane.
struct PatchLanes {
    a: V,
    b: V,
    c: V,
    d: V,
    e: V,
    f: V,
}

impl PatchLanes {
    #[inline(always)]
    fn new(p: &Patch<f32>) -> Self {
        PatchLanes {
            a: V::splat(p.a),
            b: V::splat(p.b),
            c: V::splat(p.c),
            d: V::splat(p.d),
            e: V::splat(p.e),
            f: V::splat(p.f),
        }
    }

    /// [`Patch::eval_local`].
    #[inline(always)]
    fn eval(&self, u: F, v: F) -> V {
        self.a.scale(u * u)
            + self.b.scale(v * v)
            + self.c.scale(u * v)
            + self.d.scale(u)
            + self.e.scale(v)
            + self.f
    }

    /// [`Patch::partials_local`].
    #[inline(always)]
    fn partials(&self, u: F, v: F) -> (V, V) {
        let two = F::splat(2.0);
        (self.a.scale(two * u) + self.c.scale(v) + self.d, self.b.scale(two * v) + self.c.scale(u) + self.e)
    }
}

/// The lanes' state through the stages: which are still to be settled by the kernel and which
/// are left to the scalar path.
struct Lanes {
    /// Still on the kernel's certified path.
    live: M,
    /// Left to the scalar path.
    unsure: M,
    /// Left to the scalar path because both certificates refused them.
    refused: M,
}

impl Lanes {
    /// Hand the live lanes where `m` to the scalar path.
    #[inline(always)]
    fn give_up(&mut self, m: M) {
        self.unsure = self.unsure | (self.live & m);
        self.live = self.live & !m;
    }
}

/// The local rays and the lanes past the hull.
struct HullLanes {
    /// The local ray's origin.
    o: V,
    /// The local ray's direction.
    d: V,
    /// The lanes that passed the hull (bad input turned away).
    passed: M,
}

/// The kernel's first stage: the local rays, bad input turned away (as `intersect_with`), and
/// the hull test on every lane.
#[inline(always)]
fn hull_lanes(p: &Patch<f32>, rays: &LaneRays) -> HullLanes {
    // Compute the local ray (t is unchanged) and turn bad input away.
    let (c, s) = (V::splat(p.center), F::splat(p.inv_scale));
    let org = V { x: F(rays.org[0]), y: F(rays.org[1]), z: F(rays.org[2]) };
    let dir = V { x: F(rays.dir[0]), y: F(rays.dir[1]), z: F(rays.dir[2]) };
    let (o, d) = ((org - c).scale(s), dir.scale(s));
    let (tmin, tmax) = (F(rays.tmin), F(rays.tmax));
    let zero = F::splat(0.0);
    let bad = !(tmin.eq(tmin) & tmax.eq(tmax) & o.finite() & d.finite()) | d.max_abs().eq(zero);
    // A packet hands over every active lane, those that miss the patch's box included: when
    // none meets the box, the prism is not clipped (the prism only narrows the interval).
    let (t0, t1) = box_lanes(p, o, d, tmin, tmax);
    let mut passed = !bad & t0.le(t1);
    if passed.any() {
        passed = passed & prism_lanes(p, o, d, t0, t1);
    }
    HullLanes { o, d, passed }
}

/// The kernel's second stage, for the lanes past the hull: the scalar path's certified stages.
#[inline(always)]
fn solve_lanes(p: &Patch<f32>, hull: &HullLanes, rays: &LaneRays) -> LaneAnswers {
    let (o, d, passed) = (hull.o, hull.d, hull.passed);
    let (tmin, tmax) = (F(rays.tmin), F(rays.tmax));
    let mut out = LaneAnswers::all(LaneDecision::Miss);
    // Compute the projection; a direction whose length over- or underflows is bad input too.
    let Some((pr, ok)) = project_lanes(p, o, d) else { return out };
    let mut lanes = Lanes { live: passed & ok, unsure: M::none(), refused: M::none() };
    let (u, v, t) = certified_root(p, o, d, &pr, &mut lanes);
    // Compute the decision, as `decide`, and leave a miss on a sliver seen from afar to the
    // scalar path (it asks f64).
    let inside = near(u, v, domain_tolerance::<f32>());
    let hit = lanes.live & inside & t.gt(tmin) & t.lt(tmax);
    lanes.give_up(!inside & near(u, v, edge_band::<f32>()));
    let miss = lanes.live & !hit;
    if miss.any() {
        lanes.give_up(miss & sliver_lanes(p, o));
    }
    let (cu, cv) = clamp_lanes(u, v);
    // The decisions from the masks' bits (a loop over the masks themselves would pull every
    // stage above out of the vector registers, lane by lane).
    let (unsure, hit) = (lanes.unsure.bits(), hit.bits());
    for i in 0..LANES {
        out.decision[i] = if unsure >> i & 1 != 0 {
            LaneDecision::Unsure
        } else if hit >> i & 1 != 0 {
            LaneDecision::Hit
        } else {
            LaneDecision::Miss
        };
    }
    (out.t, out.u, out.v) = (t.0, cu.0, cv.0);
    // The refused lanes' conics and lean members, for the scalar path's analytic method.
    out.refused = lanes.refused.bits();
    if out.refused != 0 {
        let mut conics = [[0.0; LANES]; 12];
        for j in 0..6 {
            (conics[j], conics[j + 6]) = (pr.f[j].0, pr.g[j].0);
        }
        let members = member_lanes(&pr.f, &pr.g, lanes.refused);
        // Compute the lanes' roots from their members; the lanes they decide are no longer
        // the scalar path's.
        let mut other = pr.f;
        for j in 0..6 {
            other[j] = select(members.meets_g, pr.g[j], pr.f[j]);
        }
        let roots =
            roots_lanes(p, o, d, (tmin, tmax), &members.lines, &other, members.near_multiple, members.found);
        let (decided, hit) = (roots.decided.bits(), roots.hit.bits());
        for i in 0..LANES {
            if decided >> i & 1 != 0 {
                // The scalar path asks the control-net test before the analytic method: a hit
                // it turns away (a false hit of the f32 solve) is its miss here too.
                let net = || misses_net(p, V3::new(o.x.0[i], o.y.0[i], o.z.0[i]), &lane_conics(&conics, i));
                out.decision[i] =
                    if hit >> i & 1 != 0 && !net() { LaneDecision::Hit } else { LaneDecision::Miss };
                (out.t[i], out.u[i], out.v[i]) = (roots.t.0[i], roots.u.0[i], roots.v.0[i]);
            }
        }
        out.refused &= !decided;
        if out.refused != 0 {
            out.refused_lanes = Some(RefusedLanes { conics, members: members.stored() });
        }
    }
    out
}

/// `retry`'s `sliver_from_afar` on every lane (local origins `o`), against the patch's reach.
#[inline(always)]
fn sliver_lanes(p: &Patch<f32>, o: V) -> M {
    !o.max_abs().le(F::splat(p.sliver_reach))
}

/// `hits_hull`'s first stage on every lane: `(tmin, tmax)` clipped against the bounds.
#[inline(always)]
fn box_lanes(p: &Patch<f32>, o: V, d: V, tmin: F, tmax: F) -> (F, F) {
    let (mut t0, mut t1) = (tmin, tmax);
    let g3 = <f32 as Real>::gamma(3);
    let widen = F::splat(1.0 + g3 + g3);
    let one = F::splat(1.0);
    for (oo, dd, lo, hi) in
        [(o.x, d.x, p.lo.x, p.hi.x), (o.y, d.y, p.lo.y, p.hi.y), (o.z, d.z, p.lo.z, p.hi.z)]
    {
        let inv = one / dd;
        let (a, b) = ((F::splat(lo) - oo) * inv, (F::splat(hi) - oo) * inv);
        let swap = a.gt(b);
        let (near, far) = (select(swap, b, a), select(swap, a, b));
        t0 = near.max(t0);
        t1 = (far * widen).min(t1);
    }
    (t0, t1)
}

/// `hits_hull`'s second stage on every lane: the interval `(t0, t1)` [`box_lanes`] left,
/// clipped against the prism, and where it is not empty.
#[inline(always)]
fn prism_lanes(p: &Patch<f32>, o: V, d: V, mut t0: F, mut t1: F) -> M {
    let one = F::splat(1.0);
    let (inf, ninf) = (F::splat(f32::INFINITY), F::splat(f32::NEG_INFINITY));
    let om = o.max_abs();
    let g8 = F::splat(<f32 as Real>::gamma(8));
    for k in 0..5 {
        let n = V::splat(p.prism_n[k]);
        let h = F::splat(p.prism_h[k]);
        let dist = h - n.dot(o);
        let dn = n.dot(d);
        let slack = g8 * (one + om + h.abs());
        let t = (dist + slack) / dn;
        let leaving = dn.sign_positive();
        t1 = select(leaving, t, inf).min(t1);
        t0 = select(leaving, ninf, t).max(t0);
    }
    t0.le(t1)
}

/// The projected conics `(F, G)`, 6 coefficients each, per lane.
struct ProjLanes {
    f: [F; 6],
    g: [F; 6],
}

/// `project` on every lane, with the lanes where the direction normalises (`None` when none does).
#[inline(always)]
fn project_lanes(p: &Patch<f32>, o: V, d: V) -> Option<(ProjLanes, M)> {
    // Compute `d.normalized()`.
    let zero = F::splat(0.0);
    let one = F::splat(1.0);
    let l = d.dot(d).sqrt();
    let ok = l.gt(zero) & l.finite();
    if !ok.any() {
        return None;
    }
    let n = d.scale(one / l);
    // Compute the orthonormal basis (Duff et al., as `orthonormal_basis`).
    let sign = select(n.z.lt(zero), -one, one);
    let a = -one / (sign + n.z);
    let b = n.x * n.y * a;
    let n1 = V { x: one + sign * n.x * n.x * a, y: sign * b, z: -sign * n.x };
    let n2 = V { x: b, y: sign + n.y * n.y * a, z: -n.y };
    let pl = PatchLanes::new(p);
    let f0 = pl.f - o;
    Some((ProjLanes { f: conic_lanes(&pl, f0, n1), g: conic_lanes(&pl, f0, n2) }, ok))
}

/// The conic of the plane with normal `m`: the patch's coefficients along `m`, its constant
/// `f0` (the patch's less the ray's origin). A function, not a closure: a closure here was
/// compiled outside the vector version, in baseline SSE, and called per use.
#[inline(always)]
fn conic_lanes(pl: &PatchLanes, f0: V, m: V) -> [F; 6] {
    [m.dot(pl.a), m.dot(pl.b), m.dot(pl.c), m.dot(pl.d), m.dot(pl.e), m.dot(f0)]
}

/// `jacobian`: `[F_u, F_v, G_u, G_v]` at `(u, v)`.
#[inline(always)]
fn jacobian_lanes(pr: &ProjLanes, u: F, v: F) -> [F; 4] {
    let ([fa, fb, fc, fd, fe, _], [ga, gb, gc, gd, ge, _]) = (pr.f, pr.g);
    let two = F::splat(2.0);
    [
        two * fa * u + fc * v + fd,
        fc * u + two * fb * v + fe,
        two * ga * u + gc * v + gd,
        gc * u + two * gb * v + ge,
    ]
}

/// `Anchor`: `sign(det J0) adj(J0)`, row-major, per lane (the scalar path's `J0⁻¹` up to a
/// positive factor, computed once per test).
#[inline(always)]
fn anchor_lanes(j0: &[F; 4], det0: F) -> [F; 4] {
    let one = F::splat(1.0);
    let s = select(det0.gt(F::splat(0.0)), one, -one);
    [j0[3] * s, -j0[1] * s, -j0[2] * s, j0[0] * s]
}

/// `certificate_holds` at the Jacobian `j`, for the anchor `k` ([`anchor_lanes`]).
#[inline(always)]
fn certificate_lanes(k: &[F; 4], j: [F; 4]) -> M {
    let m00 = k[0] * j[0] + k[1] * j[2];
    let m01 = k[0] * j[1] + k[1] * j[3];
    let m10 = k[2] * j[0] + k[3] * j[2];
    let m11 = k[2] * j[1] + k[3] * j[3];
    let h = (m01 + m10) * F::splat(0.5);
    let zero = F::splat(0.0);
    let margin = F::splat(0.01f64 as f32) * m00 * m11;
    m00.gt(zero) & m11.gt(zero) & (m00 * m11 - h * h).gt(margin)
}

/// The corners' coordinates of the certificate's region (as `region`).
fn region() -> (f32, f32) {
    ((-0.25f64 / 3.0) as f32, (3.5f64 / 3.0) as f32)
}

/// `det2`: `det A` for a 2×2 matrix, row-major.
#[inline(always)]
fn det2_lanes(a: &[F; 4]) -> F {
    a[0] * a[3] - a[1] * a[2]
}

/// `mixed`: `m(A, B) = a00 b11 + b00 a11 - a01 b10 - b01 a10`.
#[inline(always)]
fn mixed_lanes(a: &[F; 4], b: &[F; 4]) -> F {
    (a[0] * b[3] + b[0] * a[3]) - (a[1] * b[2] + b[1] * a[2])
}

/// `DetSign`, the det-sign certificate on the domain, per lane: the Jacobian at the domain's
/// corners, the sign of `det J` there and `K²`.
struct DetSignLanes {
    corners: [[F; 4]; 3],
    sign: F,
    k2: F,
}

/// `det_sign_on_domain` at `domain_jacobians` on every lane: the certificate, and the lanes
/// where it holds (`det J`'s six Bernstein coefficients of one sign, clear of their margin).
#[inline(always)]
fn det_sign_lanes(pr: &ProjLanes) -> (DetSignLanes, M) {
    let ([fa, fb, fc, fd, fe, _], [ga, gb, gc, gd, ge, _]) = (pr.f, pr.g);
    let (zero, one, two) = (F::splat(0.0), F::splat(1.0), F::splat(2.0));
    // Compute the margin from the conics' largest coefficient (`Conic::norm`), at w = 2.
    let norm = |c: &[F; 6]| c.iter().fold(zero, |m, x| m.max(x.abs()));
    let k = norm(&pr.f).max(norm(&pr.g)) * two;
    let k2 = k * k;
    let m = F::splat(<f32 as Real>::gamma(16) * 4.0) * k2 * (two * two);
    // Compute the Jacobian at the domain's corners (`domain_jacobians`) and the six coefficients.
    let j = [
        [fd, fe, gd, ge],
        [two * fa + fd, fc + fe, two * ga + gd, gc + ge],
        [fc + fd, two * fb + fe, gc + gd, two * gb + ge],
    ];
    let c = [
        det2_lanes(&j[0]),
        det2_lanes(&j[1]),
        det2_lanes(&j[2]),
        mixed_lanes(&j[0], &j[1]),
        mixed_lanes(&j[1], &j[2]),
        mixed_lanes(&j[2], &j[0]),
    ];
    let sign = select(c[0].gt(zero), one, -one);
    let holds = c.iter().fold(!M::none(), |h, &x| h & (x * sign).gt(m));
    (DetSignLanes { corners: j, sign, k2 }, holds)
}

impl DetSignLanes {
    /// `DetSign::holds_to`: the certificate extends to the hull of the domain and the root
    /// `(u, v)`, where the Jacobian is `jr`.
    #[inline(always)]
    fn holds_to(&self, jr: [F; 4], u: F, v: F) -> M {
        let w = F::splat(2.0).max(F::splat(1.0) + u.abs() + v.abs());
        let m = F::splat(<f32 as Real>::gamma(64) * 24.0) * self.k2 * (w * w);
        let c = [
            det2_lanes(&jr),
            mixed_lanes(&jr, &self.corners[0]),
            mixed_lanes(&jr, &self.corners[1]),
            mixed_lanes(&jr, &self.corners[2]),
        ];
        c.iter().fold(!M::none(), |h, &x| h & (x * self.sign).gt(m))
    }
}

/// The positive-definite certificate on `R` (`positive_definite_on_region` at the centroid's
/// Jacobian) on every lane: the lanes where it holds, and its anchor.
#[inline(always)]
fn positive_definite_lanes(pr: &ProjLanes) -> (M, [F; 4]) {
    let third = F::splat((1.0f64 / 3.0) as f32);
    let j0 = jacobian_lanes(pr, third, third);
    let det0 = j0[0] * j0[3] - j0[1] * j0[2];
    let j0n = j0.iter().fold(F::splat(0.0), |m, x| m.max(x.abs()));
    let g64 = <f32 as Real>::gamma(64);
    let mut pd = det0.abs().gt(F::splat(g64.sqrt()) * j0n * j0n);
    let anchor = anchor_lanes(&j0, det0);
    let (lo, hi) = region();
    let (lo, hi) = (F::splat(lo), F::splat(hi));
    for (cu, cv) in [(lo, lo), (hi, lo), (lo, hi)] {
        pd = pd & certificate_lanes(&anchor, jacobian_lanes(pr, cu, cv));
    }
    (pd, anchor)
}

/// The proofs that the projection is one-to-one, per lane, in `certified_newton`'s order: the
/// det-sign certificate on the domain, and the positive-definite one on `R` where it fails (on
/// every lane when computed: it may be needed later for a root outside the domain).
struct ProofLanes {
    /// The det-sign certificate, and the live lanes it proves.
    ds: DetSignLanes,
    by_ds: M,
    /// The positive-definite certificate, where computed: the lanes it proves, its anchor.
    pd: Option<(M, [F; 4])>,
}

/// `first_proof` with `Proofs::WithDetSign` on the live lanes; lanes that neither certificate
/// proves are handed to the scalar path (as refused).
#[inline(always)]
fn proof_lanes(pr: &ProjLanes, lanes: &mut Lanes) -> ProofLanes {
    let (ds, holds) = det_sign_lanes(pr);
    let rest = lanes.live & !holds;
    let pd = rest.any().then(|| positive_definite_lanes(pr));
    let refused = rest & !pd.map_or(M::none(), |(m, _)| m);
    lanes.refused = refused;
    lanes.give_up(refused);
    ProofLanes { ds, by_ds: lanes.live & holds, pd }
}

/// `in_region`: inside the triangle with corners `(lo, lo)`, `(1 - 2 lo, lo)`, `(lo, 1 - 2 lo)`
/// with room for the root's error.
#[inline(always)]
fn in_region_lanes(u: F, v: F, lo: f32) -> M {
    let (lo, slack, one) = (F::splat(lo), F::splat(0.005), F::splat(1.0));
    u.ge(lo + slack) & v.ge(lo + slack) & (u + v).le(one - lo - slack)
}

/// `certified_newton` up to `decide`: the certificates, the flat start, Newton in
/// the plane, the point's `t`, the Newton step in space and the checks of the root. Lanes that
/// fail a check are handed to the scalar path.
#[inline(always)]
fn certified_root(p: &Patch<f32>, o: V, d: V, pr: &ProjLanes, lanes: &mut Lanes) -> (F, F, F) {
    let zero = F::splat(0.0);
    let proof = proof_lanes(pr, lanes);
    if !lanes.live.any() {
        return (zero, zero, zero);
    }
    let (u, v) = flat_start_lanes(pr, lanes);
    let (u, v, converged) = newton_plane_lanes(pr, u, v, lanes);
    lanes.give_up(!converged);
    // Compute the point's ray parameter, and one Newton step in space inside the domain.
    let pl = PatchLanes::new(p);
    let t = (pl.eval(u, v) - o).dot(d) / d.dot(d);
    let step = lanes.live & near(u, v, domain_tolerance::<f32>());
    let (su, sv, st, ok) = newton_step_lanes(&pl, o, d, u, v, t);
    lanes.give_up(step & !ok);
    let (u, v, t) = (select(step, su, u), select(step, sv, v), select(step, st, t));
    // The root must be on the ray, and the only root of a region the domain is in: the
    // det-sign lanes' inside the domain or where that certificate extends to it, the others'
    // (and the det-sign lanes' it does not extend to) inside `R` or where the
    // positive-definite certificate extends to it.
    let in_domain = in_region_lanes(u, v, 0.0);
    let jr = jacobian_lanes(pr, u, v);
    let ds_out = lanes.live & proof.by_ds & !in_domain;
    let ds_ok =
        proof.by_ds & (in_domain | if ds_out.any() { proof.ds.holds_to(jr, u, v) } else { M::none() });
    let need = lanes.live & !ds_ok;
    let pd_ok = if need.any() {
        let (pd, anchor) = proof.pd.unwrap_or_else(|| positive_definite_lanes(pr));
        need & pd & (in_region_lanes(u, v, region().0) | certificate_lanes(&anchor, jr))
    } else {
        M::none()
    };
    lanes.give_up(!on_ray_lanes(&pl, o, d, u, v, t) | !(ds_ok | pd_ok));
    (u, v, t)
}

/// `flat_start`: the ray's hit with the flat triangle in the plane.
#[inline(always)]
fn flat_start_lanes(pr: &ProjLanes, lanes: &mut Lanes) -> (F, F) {
    let ([fa, fb, _, fd, fe, ff], [ga, gb, _, gd, ge, gf]) = (pr.f, pr.g);
    let (l00, l01, l10, l11) = (fa + fd, fb + fe, ga + gd, gb + ge);
    let det = l00 * l11 - l01 * l10;
    lanes.give_up(det.eq(F::splat(0.0)) | !det.finite());
    let idet = F::splat(1.0) / det;
    ((l01 * gf - l11 * ff) * idet, (l10 * ff - l00 * gf) * idet)
}

/// `newton_plane` on the live lanes: the last iterates and where they converged (its bound on
/// the next step, in the same operations in the same order, so the same bits). A singular
/// Jacobian or a non-finite step hands the lane to the scalar path.
#[inline(always)]
fn newton_plane_lanes(pr: &ProjLanes, mut u: F, mut v: F, lanes: &mut Lanes) -> (F, F, M) {
    let ([fa, fb, fc, fd, fe, ff], [ga, gb, gc, gd, ge, gf]) = (pr.f, pr.g);
    let mut run = lanes.live;
    let mut converged = M::none();
    let tol = F::splat(<f32 as Real>::gamma(64));
    let near = F::splat(<f32 as Real>::gamma(64).sqrt());
    let q = (fa.abs() + fb.abs() + fc.abs()).max(ga.abs() + gb.abs() + gc.abs());
    for _ in 0..8 {
        let r0 = ((fa * u + fc * v + fd) * u + (fb * v + fe) * v) + ff;
        let r1 = ((ga * u + gc * v + gd) * u + (gb * v + ge) * v) + gf;
        let j = jacobian_lanes(pr, u, v);
        let det = j[0] * j[3] - j[1] * j[2];
        let idet = F::splat(1.0) / det;
        let du = (j[1] * r1 - j[3] * r0) * idet;
        let dv = (j[2] * r0 - j[0] * r1) * idet;
        let fail = det.eq(F::splat(0.0)) | !det.finite() | !(du.finite() & dv.finite());
        lanes.give_up(run & fail);
        run = run & !fail;
        u = select(run, u + du, u);
        v = select(run, v + dv, v);
        let inv = (j[3].abs() + j[1].abs()).max(j[2].abs() + j[0].abs()) * idet.abs();
        let step = du.abs().max(dv.abs());
        let k = inv * q * step;
        let done = run & step.le(near) & k.le(F::splat(0.25)) & (k * step).le(tol);
        converged = converged | done;
        run = run & !done;
        if !run.any() {
            break;
        }
    }
    (u, v, converged)
}

/// `newton_step`: one Newton step on `(u, v, t)` in space, and where it is finite and regular.
#[inline(always)]
fn newton_step_lanes(pl: &PatchLanes, o: V, d: V, u: F, v: F, t: F) -> (F, F, F, M) {
    let (pu, pv) = pl.partials(u, v);
    let r = pl.eval(u, v) - o - d.scale(t);
    let nd = V { x: -d.x, y: -d.y, z: -d.z };
    let det = pu.dot(pv.cross(nd));
    let inv = F::splat(1.0) / det;
    let du = -r.dot(pv.cross(nd)) * inv;
    let dv = -pu.dot(r.cross(nd)) * inv;
    let dt = -pu.dot(pv.cross(r)) * inv;
    let (nu, nv, nt) = (u + du, v + dv, t + dt);
    let ok = !(det.eq(F::splat(0.0)) | !det.finite()) & nu.finite() & nv.finite() & nt.finite();
    (nu, nv, nt, ok)
}

/// `on_ray`: the surface point lies on the ray at `t` to rounding.
#[inline(always)]
fn on_ray_lanes(pl: &PatchLanes, o: V, d: V, u: F, v: F, t: F) -> M {
    let dt = d.scale(t);
    let scale = F::splat(1.0) + o.max_abs() + dt.max_abs();
    let res = (pl.eval(u, v) - o - dt).max_abs();
    res.le(F::splat(<f32 as Real>::gamma(1024)) * scale)
}

/// `T::gamma(n)` of f32 on every lane.
#[inline(always)]
fn gamma(n: u32) -> F {
    F::splat(<f32 as Real>::gamma(n))
}

/// `near_domain`: `(u, v)` within `margin` of the triangle.
#[inline(always)]
fn near(u: F, v: F, margin: f32) -> M {
    let m = F::splat(-margin);
    u.ge(m) & v.ge(m) & (F::splat(1.0) - u - v).ge(m)
}

/// `clamp_to_triangle`.
#[inline(always)]
fn clamp_lanes(u: F, v: F) -> (F, F) {
    let zero = F::splat(0.0);
    let (u, v) = (u.max(zero), v.max(zero));
    let s = u + v;
    let over = s.gt(F::splat(1.0));
    (select(over, u / s, u), select(over, v / s, v))
}
