//! The Phong tessellation patch as a quadratic Bézier triangle, in a local frame.
//!
//! Embree's triangle convention: barycentrics `(w, u, v) = (1-u-v, u, v)` weight `(p0, p1, p2)`.
//! Phong tessellation (Boubekeur & Alexa 2008) with shape factor `alpha`,
//! `p_a(u,v) = (1-a) p(u,v) + a Σ_i b_i π_i(p(u,v))`, `π_i(q) = q - ((q-p_i)·n_i) n_i`,
//! is the quadratic Bézier triangle with corner control points `p_i` and edge control points
//! `P_ij = (1-a) (p_i+p_j)/2 + a (π_i(p_j) + π_j(p_i))/2`.
//! A *straight* edge (for watertight creases) keeps `P_ij = (p_i+p_j)/2`: both patches beside a
//! crease then share the straight edge whatever their normals.

use super::intersect::{net_slack, sliver_reach};
use super::real::{Real, V3};

/// A patch, built in f64 and stored in the precision `T` of the solver that uses it.
///
/// Geometry lives in a local frame: `x_local = (x - center) * inv_scale`, with `center` the
/// centroid of the corners and `1/inv_scale` the largest corner distance from it rounded up to a
/// power of two, so the solve
/// does not lose accuracy with distance from the origin or with the patch size. Ray parameters
/// `t` are the same in both frames.
///
/// The fields are read through accessors: they are derived together (the bounds and the prism
/// from the coefficients, all of them from the frame), so they cannot be edited one at a time.
#[derive(Clone, Copy, Debug)]
pub struct Patch<T> {
    pub(crate) center: V3<T>,
    pub(crate) scale: T,
    pub(crate) inv_scale: T,
    /// Polynomial coefficients (local frame): `P(u,v) = A u² + B v² + C uv + D u + E v + F`.
    pub(crate) a: V3<T>,
    pub(crate) b: V3<T>,
    pub(crate) c: V3<T>,
    pub(crate) d: V3<T>,
    pub(crate) e: V3<T>,
    pub(crate) f: V3<T>,
    /// Unit vertex normals (for shading).
    pub(crate) n: [V3<T>; 3],
    /// Conservative local-frame bounds (the exact range of each coordinate over the domain, padded).
    pub(crate) lo: V3<T>,
    pub(crate) hi: V3<T>,
    /// A tighter conservative hull (local frame): the prism of 5 half-spaces `n_k · x <= h_k`:
    /// the face normal and its opposite (the patch's thickness) and the 3 outward edge normals in
    /// the face plane (each edge's side drop), every offset the exact maximum of the surface
    /// along its normal, padded, and widened by [`prism_slack`] (the part of the hull test's
    /// rounding slack that does not depend on the ray, added here once instead of per test).
    pub(crate) prism_n: [V3<T>; 5],
    pub(crate) prism_h: [T; 5],
    /// The axis of the cone of local ray directions `d` along which the patch cannot fold:
    /// where `(d · unfolded)² > d · d`, `det J` keeps one sign over the domain (the det-sign
    /// certificate holds without being computed; see [`unfolded_axis`]). Zero where no direction
    /// is certain.
    pub(crate) unfolded: V3<T>,
    /// How far from the frame's centre (max norm, local frame) a ray may start before an f32
    /// miss is decided again in f64, on a sliver ([`sliver_reach`]); infinite in f64.
    pub(crate) sliver_reach: T,
    /// The part of the control-net test's error bound that does not depend on the ray
    /// ([`crate::phong::intersect::net_slack`]).
    pub(crate) net_slack: T,
    /// Whether the patch has zero area or non-finite input: it is never hit.
    pub(crate) degenerate: bool,
}

/// The 6 control points of the quadratic Bézier triangle, world space, f64:
/// `[P0, P1, P2, P01, P12, P20]`.
pub fn control_points(p: [V3<f64>; 3], n: [V3<f64>; 3], alpha: f64, straight: [bool; 3]) -> [V3<f64>; 6] {
    let proj = |i: usize, q: V3<f64>| q - n[i] * (q - p[i]).dot(n[i]);
    let edge = |i: usize, j: usize, k: usize| {
        let mid = (p[i] + p[j]) * 0.5;
        if straight[k] {
            return mid;
        }
        let bent = (proj(i, p[j]) + proj(j, p[i])) * 0.5;
        mid * (1.0 - alpha) + bent * alpha
    };
    // Edge k runs from corner k to corner k+1: 0 = (p0,p1), 1 = (p1,p2), 2 = (p2,p0).
    [p[0], p[1], p[2], edge(0, 1, 0), edge(1, 2, 1), edge(2, 0, 2)]
}

/// The exact range `(min, max)` over the triangle `u, v >= 0, u + v <= 1` of the quadratic
/// `q(u,v) = k0 u² + k1 v² + k2 uv + k3 u + k4 v + k5`: the extremes lie at a corner, at the
/// stationary point of an edge, or at the interior stationary point (Ogaki & Tokuyoshi 2011
/// bound a patch's thickness the same way, at its `(û, v̂)`).
pub fn quadratic_range(k: [f64; 6]) -> (f64, f64) {
    let [a, b, c, d, e, f] = k;
    let q = |u: f64, v: f64| a * u * u + b * v * v + c * u * v + d * u + e * v + f;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut take = |u: f64, v: f64| {
        let x = q(u, v);
        lo = lo.min(x);
        hi = hi.max(x);
    };
    take(0.0, 0.0);
    take(1.0, 0.0);
    take(0.0, 1.0);
    let on = |s: f64| s > 0.0 && s < 1.0;
    // Edge v = 0: a u² + d u + f.
    if a != 0.0 && on(-d / (2.0 * a)) {
        take(-d / (2.0 * a), 0.0);
    }
    // Edge u = 0: b v² + e v + f.
    if b != 0.0 && on(-e / (2.0 * b)) {
        take(0.0, -e / (2.0 * b));
    }
    // Edge u + v = 1: (a + b - c) u² + (c + d - e - 2b) u + (b + e + f).
    let (a2, b2) = (a + b - c, c + d - e - 2.0 * b);
    if a2 != 0.0 && on(-b2 / (2.0 * a2)) {
        let u = -b2 / (2.0 * a2);
        take(u, 1.0 - u);
    }
    // Interior: [2a c; c 2b] (u, v) = -(d, e). Only a definite quadratic (det > 0) has an
    // extremum there; otherwise the stationary point is a saddle (or absent) and the extremes lie
    // on the boundary.
    let det = 4.0 * a * b - c * c;
    if det > 0.0 {
        let inv = 1.0 / det;
        let u = (-d * 2.0 * b + c * e) * inv;
        let v = (-2.0 * a * e + c * d) * inv;
        if u > 0.0 && v > 0.0 && u + v < 1.0 {
            take(u, v);
        }
    }
    (lo, hi)
}

/// The smallest power of two `>= x`, for finite `x > 0` (`2^ceil(log2 x)`, from the bits of a
/// normal number: no logarithm).
fn pow2_at_least(x: f64) -> f64 {
    const MANTISSA: u64 = (1 << 52) - 1;
    let bits = x.to_bits();
    if bits >> 52 == 0 || bits >> 52 >= 0x7fe {
        // Subnormal, or within a factor 2 of overflow: the general formula.
        return 2f64.powi(x.log2().ceil() as i32);
    }
    if bits & MANTISSA == 0 {
        x
    } else {
        f64::from_bits(((bits >> 52) + 1) << 52)
    }
}

/// How a Phong patch's shading normal is chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ShadingNormal {
    /// The interpolated normal, bent just enough that the view vector reflected about it stays
    /// above the true surface (Keller et al. 2017, "The Iray Light Transport Simulation and
    /// Rendering System", appendix A.3). Equal to the interpolated normal wherever the reflection
    /// is above the surface, and continuous at the switch: the default.
    #[default]
    Adapted,
    /// Ogaki & Tokuyoshi §4: the interpolated normal, switched to the true normal where the
    /// reflected view vector falls below the surface. Discontinuous at the switch.
    Paper,
    /// The plain interpolated vertex normal, `normalize(w n0 + u n1 + v n2)`.
    Interpolated,
}

impl ShadingNormal {
    /// Every rule, the default first.
    pub const ALL: [ShadingNormal; 3] =
        [ShadingNormal::Adapted, ShadingNormal::Paper, ShadingNormal::Interpolated];

    /// The rule's name as the command line and scene files spell it.
    pub fn name(self) -> &'static str {
        match self {
            ShadingNormal::Adapted => "adapted",
            ShadingNormal::Paper => "paper",
            ShadingNormal::Interpolated => "interpolated",
        }
    }

    /// The rule named `s` (see [`ShadingNormal::name`]).
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|r| r.name() == s)
    }
}

/// Bend the shading normal `ns` so that the view vector `wo` reflected about it does not fall
/// below the true surface (normal `ng`); `wo`, `ng` and `ns` are unit and on one side
/// (`wo·ng >= 0`, `ns·ng > 0`). Where the reflection `r` is below `r·ng = q` (a margin of
/// `q = min(0.01, wo·ng / 2)` above the tangent plane), it is pushed along `ns` up to it and the
/// normal becomes the half vector of `wo` and the pushed `r`: at the switch (`r·ng = q`) that half
/// vector is `ns` itself, so the result is continuous.
pub fn adapt_shading_normal<T: Real>(wo: V3<T>, ng: V3<T>, ns: V3<T>) -> V3<T> {
    let two = T::ONE + T::ONE;
    // Compute the reflection and how far below the surface it points.
    let r = ns * (two * wo.dot(ns)) - wo;
    let a = r.dot(ng);
    // Compute the margin kept above the tangent plane: a reflection exactly on it would graze
    // the surface it leaves and, after rounding, hit it again.
    let q = T::from_f64(0.01).min(wo.dot(ng) * T::from_f64(0.5));
    if !(a < q) {
        return ns;
    }
    let b = ns.dot(ng);
    // Compute the pushed reflection, just above the tangent plane: (r + s ns)·ng = q.
    let tangent = (r + ns * ((q - a) / b)).normalized();
    match tangent.and_then(|t| (wo + t).normalized()) {
        Some(n) if n.dot(ng) > T::ZERO => n,
        // A grazing view (wo on the tangent plane too) or a normal on it: the true normal.
        _ => ng,
    }
}

/// A prism offset `h` widened by the ray-independent part of the hull test's rounding slack in
/// precision `T`: `γ(8) (1 + |h|)` (the test adds `γ(8) |o|∞` for the ray's origin `o`).
fn prism_slack<T: Real>(h: f64) -> f64 {
    h + T::gamma(8).to_f64() * (1.0 + h.abs())
}

/// The padding of a patch's local-frame bounds and prism offsets for precision `T`: the
/// rounding of the control points and of their cast to `T`, relative to the local frame (whose
/// extent is about 1).
fn bounds_pad<T: Real>() -> f64 {
    T::gamma(8).to_f64() * 4.0 + f64::EPSILON * 16.0
}

/// The axis `k` of a cone of local ray directions along which the patch `[A, B, C, D, E]`
/// (its coefficients but the constant) cannot fold: for a direction `d` with `(d·k)² > d·d`,
/// the normal `N(u, v) = Pu × Pv` satisfies `|d̂·N| > τ = 1e-4 S²` with one sign on the whole
/// domain (`d̂ = d / |d|`, `S` the largest `|Pu|`, `|Pv|` at a corner, which bounds them on the
/// domain). Zero where no such cone exists (the normals spread over a half-space or more, or
/// one of them is within `τ` of zero). [`super::intersect`]'s det-sign certificate rests on it
/// (`det J = (n1 × n2)·N`, see there).
///
/// `N` is quadratic: on the triangle its Bernstein coefficients are `Pu_i × Pv_i` at the
/// corners and `(Pu_i × Pv_j + Pu_j × Pv_i) / 2` on the edges, and `d̂·N` is their convex
/// combination, so `d̂·N_i > τ` for all six is enough. With `a` the unit mean of their
/// directions and `θ_i` their angles from it, a direction within `φ_i = acos(τ / |N_i|) - θ_i`
/// of `a` has `d̂·N_i >= |N_i| cos(θ_i + angle) > τ`; the cone's half-angle is the least
/// `φ_i` less `3e-3` (which covers the rounding of `k` and of the test in f32: an angle error
/// of about the square root of its relative error, 1e-3 at most), and `k = a / cos φ`. Built in
/// f64 with square roots only (no `acos`): `cos φ_i = c cos θ_i + sin(acos c) sin θ_i`,
/// `c = τ / |N_i|`.
pub(crate) fn unfolded_axis(k: [V3<f64>; 5]) -> V3<f64> {
    // Compute the partials at the corners, their bound S, and the six Bernstein coefficients of N.
    let (pu, pv) = corner_partials(k);
    let s = pu.iter().chain(&pv).map(|x| x.length()).fold(0.0, f64::max);
    let n = normal_bernstein(&pu, &pv);
    let tau = 1e-4 * s * s;
    let len = n.map(|x| x.length());
    if !len.iter().all(|&l| l > tau && l.is_finite()) {
        return V3::zero();
    }
    // Compute the axis, then the cone's half-angle: the largest cos φ_i, less the margin.
    let sum = (0..6).fold(V3::zero(), |acc, i| acc + n[i] * (1.0 / len[i]));
    let Some(axis) = sum.normalized() else { return V3::zero() };
    let mut cos_phi = f64::NEG_INFINITY;
    for i in 0..6 {
        let (cos_t, c) = (axis.dot(n[i]) / len[i], tau / len[i]);
        if !(c < cos_t) {
            return V3::zero();
        }
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        cos_phi = cos_phi.max(c * cos_t + (1.0 - c * c).sqrt() * sin_t);
    }
    let (cos_m, sin_m) = (3e-3f64.cos(), 3e-3f64.sin());
    if !(cos_phi < cos_m) {
        return V3::zero();
    }
    let sin_phi = (1.0 - cos_phi * cos_phi).max(0.0).sqrt();
    axis * (1.0 / (cos_phi * cos_m + sin_phi * sin_m))
}

/// `Pu = 2A u + C v + D` and `Pv = C u + 2B v + E` of the patch with coefficients
/// `[A, B, C, D, E]` at the domain's corners `(0, 0)`, `(1, 0)`, `(0, 1)`.
#[inline(always)]
pub(crate) fn corner_partials(k: [V3<f64>; 5]) -> ([V3<f64>; 3], [V3<f64>; 3]) {
    let [a, b, c, d, e] = k;
    ([d, a * 2.0 + d, c + d], [e, c + e, b * 2.0 + e])
}

/// The degree-2 Bernstein coefficients of `N = Pu × Pv` over the triangle from the corner
/// partials ([`corner_partials`]), as [`bilinear_bernstein`] gives them.
#[inline(always)]
pub(crate) fn normal_bernstein(pu: &[V3<f64>; 3], pv: &[V3<f64>; 3]) -> [V3<f64>; 6] {
    bilinear_bernstein(|i, j| pu[i].cross(pv[j]))
}

/// The degree-2 Bernstein coefficients over the triangle of a product `f(Pu, Pv)` bilinear in
/// the linear partials, from `f` at pairs of corners (`f(i, j)`: corner `i`'s `Pu` with corner
/// `j`'s `Pv`, corners `(0, 0)`, `(1, 0)`, `(0, 1)`): the corner products and, on each edge, the
/// mean of the two mixed ones; in the order corners, then edges `(0, 0)-(1, 0)`,
/// `(1, 0)-(0, 1)`, `(0, 1)-(0, 0)`.
#[inline(always)]
pub(crate) fn bilinear_bernstein<X>(f: impl Fn(usize, usize) -> X) -> [X; 6]
where
    X: Copy + std::ops::Add<Output = X> + std::ops::Mul<f64, Output = X>,
{
    let mixed = |i: usize, j: usize| (f(i, j) + f(j, i)) * 0.5;
    [f(0, 0), f(1, 1), f(2, 2), mixed(0, 1), mixed(1, 2), mixed(2, 0)]
}

impl<T: Real> Patch<T> {
    /// A patch from 3 positions, 3 normals (normalised here) and `alpha` in [0, 1].
    pub fn new(p: [glam::DVec3; 3], n: [glam::DVec3; 3], alpha: f64) -> Self {
        Self::with_straight_edges(p, n, alpha, [false; 3])
    }

    /// As [`Patch::new`], with edges `k` (corner k to k+1) kept straight where `straight[k]`.
    pub fn with_straight_edges(
        p: [glam::DVec3; 3],
        n: [glam::DVec3; 3],
        alpha: f64,
        straight: [bool; 3],
    ) -> Self {
        let p: [V3<f64>; 3] = p.map(V3::from);
        let nn: [Option<V3<f64>>; 3] = n.map(|v| V3::from(v).normalized());
        let alpha = if alpha.is_finite() { alpha.clamp(0.0, 1.0) } else { 0.0 };
        let finite = p.iter().all(|q| q.is_finite());
        let area = (p[1] - p[0]).cross(p[2] - p[0]).length();
        let zero_normal = nn.iter().any(|x| x.is_none());
        // A zero normal cannot define a tangent plane: such a patch is degenerate.
        let degenerate = !finite || !(area > 0.0) || zero_normal;
        let n = nn.map(|x| x.unwrap_or(V3::zero()));
        // The centre is rounded to T first, so the local coordinates (computed exactly enough in
        // f64 relative to it) describe the same surface as the T-precision frame does.
        let center: V3<f64> = ((p[0] + p[1] + p[2]) * (1.0 / 3.0)).cast::<T>().to_f64();
        let center = if center.is_finite() { center } else { V3::zero() };
        let scale = p.iter().map(|q| (*q - center).length()).fold(0.0, f64::max);
        // A power of two, so the map to the local frame and back only shifts exponents: no
        // rounding from the scale in either precision, and the same frame in f32 and f64.
        let scale = if scale > 0.0 && scale.is_finite() { pow2_at_least(scale) } else { scale };
        let (scale, inv) =
            if degenerate || !(scale > 0.0 && scale.is_finite()) { (1.0, 1.0) } else { (scale, 1.0 / scale) };
        let q = control_points(p, n, alpha, straight).map(|c| (c - center) * inv);
        let [p0, p1, p2, p01, p12, p20] = q;
        // Bernstein to power basis (w = 1-u-v).
        let a = p0 + p1 - p01 * 2.0;
        let b = p0 + p2 - p20 * 2.0;
        let c = (p0 - p01 + p12 - p20) * 2.0;
        let d = (p01 - p0) * 2.0;
        let e = (p20 - p0) * 2.0;
        let f = p0;
        // The exact range of each linear functional `n · P(u, v)` over the domain (each is a
        // quadratic in (u, v)): tighter than the hull of the control points, which lies up to
        // twice as far from the base triangle as the surface does.
        let range =
            |n: V3<f64>| quadratic_range([n.dot(a), n.dot(b), n.dot(c), n.dot(d), n.dot(e), n.dot(f)]);
        let (x, y, z) =
            (range(V3::new(1.0, 0.0, 0.0)), range(V3::new(0.0, 1.0, 0.0)), range(V3::new(0.0, 0.0, 1.0)));
        let mut lo = V3::new(x.0, y.0, z.0);
        let mut hi = V3::new(x.1, y.1, z.1);
        // Pad by the rounding of the control points and their cast to T.
        let pad = bounds_pad::<T>();
        // The prism (Ogaki & Tokuyoshi 2011 bound the patch by its thickness and edge side drops):
        // the face normal both ways and the three outward edge normals, each offset the exact
        // maximum of the surface along it.
        let fnorm = (q[1] - q[0]).cross(q[2] - q[0]).normalized().unwrap_or(V3::new(0.0, 0.0, 1.0));
        let edge_out = |a: V3<f64>, b: V3<f64>| (b - a).cross(fnorm).normalized().unwrap_or(fnorm);
        let prism_n = [fnorm, -fnorm, edge_out(q[0], q[1]), edge_out(q[1], q[2]), edge_out(q[2], q[0])];
        // The face normal's range gives both of its planes (max along -n is -min along n).
        let thickness = range(fnorm);
        let prism_h = [
            thickness.1 + pad,
            -thickness.0 + pad,
            range(prism_n[2]).1 + pad,
            range(prism_n[3]).1 + pad,
            range(prism_n[4]).1 + pad,
        ];
        lo = lo - V3::new(pad, pad, pad);
        hi = hi + V3::new(pad, pad, pad);
        // The cone is the stored coefficients' (rounded to T), as the solve sees them.
        let stored = |x: V3<f64>| x.cast::<T>().to_f64();
        let unfolded = unfolded_axis([a, b, c, d, e].map(stored));
        Patch {
            center: center.cast(),
            scale: T::from_f64(scale),
            inv_scale: T::from_f64(inv),
            a: a.cast(),
            b: b.cast(),
            c: c.cast(),
            d: d.cast(),
            e: e.cast(),
            f: f.cast(),
            n: n.map(|x| x.cast()),
            lo: lo.cast(),
            hi: hi.cast(),
            prism_n: prism_n.map(|n| n.cast()),
            prism_h: prism_h.map(|h| T::from_f64(prism_slack::<T>(h))),
            unfolded: if degenerate { V3::zero() } else { unfolded.cast() },
            sliver_reach: T::from_f64(sliver_reach::<T>(stored(a), stored(b), stored(d), stored(e))),
            net_slack: T::from_f64(net_slack::<T>([a, b, c, d, e].map(stored), stored(f))),
            degenerate,
        }
    }

    /// The same patch in another precision `U`, as accurate as [`Patch::new`] in `U` would
    /// build it: from f32 to f64 every field converts exactly; from f64 to f32 the frame's
    /// centre is rounded to f32 first and the patch re-expressed in that frame (its constant
    /// coefficient, bounds and prism offsets shifted by the rounding, computed in f64), and the
    /// bounds padded for f32. Rounding only the fields would leave the coefficients relative to
    /// a centre the f32 patch no longer has: a t error of the centre's rounding over the patch
    /// size, large for small patches far from the origin.
    pub fn cast<U: Real>(&self) -> Patch<U> {
        let center = self.center.to_f64();
        let center_u: V3<U> = center.cast();
        // Compute the shift of the local frame (exact in f64: the centre and its rounding are
        // neighbours, Sterbenz) and the extra padding U needs over T.
        let shift = (center - center_u.to_f64()) * self.inv_scale.to_f64();
        let extra = (bounds_pad::<U>() - bounds_pad::<T>()).max(0.0);
        let widen = V3::new(extra, extra, extra);
        let prism_n = self.prism_n.map(|n| n.to_f64());
        // The offsets already carry T's slack; a coarser U needs its own on top.
        let coarser = U::UNIT_ROUNDOFF.to_f64() > T::UNIT_ROUNDOFF.to_f64();
        // The coefficients as `U` stores them, in f64.
        let stored = |x: V3<T>| x.cast::<U>().to_f64();
        let prism_h: [f64; 5] = std::array::from_fn(|k| {
            let h = self.prism_h[k].to_f64() + prism_n[k].dot(shift) + extra;
            if coarser {
                prism_slack::<U>(h)
            } else {
                h
            }
        });
        Patch {
            center: center_u,
            scale: U::from_f64(self.scale.to_f64()),
            inv_scale: U::from_f64(self.inv_scale.to_f64()),
            a: self.a.cast(),
            b: self.b.cast(),
            c: self.c.cast(),
            d: self.d.cast(),
            e: self.e.cast(),
            f: (self.f.to_f64() + shift).cast(),
            n: self.n.map(|x| x.cast()),
            prism_n: prism_n.map(|n| n.cast()),
            prism_h: prism_h.map(U::from_f64),
            lo: (self.lo.to_f64() + shift - widen).cast(),
            hi: (self.hi.to_f64() + shift + widen).cast(),
            // To a finer precision the coefficients convert exactly, and the cone's margin
            // covers its axis's rounding; to a coarser one it is the rounded coefficients'.
            unfolded: if !coarser {
                self.unfolded.to_f64()
            } else if self.degenerate {
                V3::zero()
            } else {
                unfolded_axis([self.a, self.b, self.c, self.d, self.e].map(stored))
            }
            .cast(),
            sliver_reach: U::from_f64(sliver_reach::<U>(
                stored(self.a),
                stored(self.b),
                stored(self.d),
                stored(self.e),
            )),
            net_slack: U::from_f64(net_slack::<U>(
                [self.a, self.b, self.c, self.d, self.e].map(stored),
                (self.f.to_f64() + shift).cast::<U>().to_f64(),
            )),
            degenerate: self.degenerate,
        }
    }

    /// The local frame's centre (world space).
    pub fn center(&self) -> V3<T> {
        self.center
    }

    /// The local frame's scale (a power of two): `x_world = x_local * scale + center`.
    pub fn scale(&self) -> T {
        self.scale
    }

    /// `1 / scale`.
    pub fn inv_scale(&self) -> T {
        self.inv_scale
    }

    /// The local-frame polynomial coefficients `[A, B, C, D, E, F]` of
    /// `P(u,v) = A u² + B v² + C uv + D u + E v + F`.
    pub fn coefficients(&self) -> [V3<T>; 6] {
        [self.a, self.b, self.c, self.d, self.e, self.f]
    }

    /// The unit vertex normals.
    pub fn normals(&self) -> [V3<T>; 3] {
        self.n
    }

    /// Conservative local-frame bounds `(lo, hi)`.
    pub fn local_bounds(&self) -> (V3<T>, V3<T>) {
        (self.lo, self.hi)
    }

    /// The conservative prism (local frame): the patch satisfies `normals[k] · x <= offsets[k]`
    /// for the 5 planes (face normal both ways, then the 3 outward edge normals). The offsets
    /// include the ray-independent part of the hull test's rounding slack.
    pub fn prism(&self) -> ([V3<T>; 5], [T; 5]) {
        (self.prism_n, self.prism_h)
    }

    /// Whether the patch has zero area or non-finite input (it is never hit).
    pub fn degenerate(&self) -> bool {
        self.degenerate
    }

    /// The local-frame point at `(u, v)`.
    #[inline(always)]
    pub fn eval_local(&self, u: T, v: T) -> V3<T> {
        self.a * (u * u) + self.b * (v * v) + self.c * (u * v) + self.d * u + self.e * v + self.f
    }

    /// Local-frame partial derivatives `(dP/du, dP/dv)`.
    #[inline(always)]
    pub fn partials_local(&self, u: T, v: T) -> (V3<T>, V3<T>) {
        let two = T::ONE + T::ONE;
        (self.a * (two * u) + self.c * v + self.d, self.b * (two * v) + self.c * u + self.e)
    }

    /// The world-space point at `(u, v)`.
    pub fn eval(&self, u: T, v: T) -> V3<T> {
        self.eval_local(u, v) * self.scale + self.center
    }

    /// World-space partial derivatives.
    pub fn partials(&self, u: T, v: T) -> (V3<T>, V3<T>) {
        let (pu, pv) = self.partials_local(u, v);
        (pu * self.scale, pv * self.scale)
    }

    /// The true surface normal `dP/du × dP/dv` (unit; oriented like Embree's triangle `Ng`).
    pub fn geometric_normal(&self, u: T, v: T) -> Option<V3<T>> {
        let (pu, pv) = self.partials_local(u, v);
        pu.cross(pv).normalized()
    }

    /// The Phong-interpolated normal `normalize(w n0 + u n1 + v n2)`.
    pub fn interpolated_normal(&self, u: T, v: T) -> Option<V3<T>> {
        let w = T::ONE - u - v;
        (self.n[0] * w + self.n[1] * u + self.n[2] * v).normalized()
    }

    /// The default shading normal ([`ShadingNormal::Adapted`]) for a ray arriving along `dir`,
    /// facing the side the ray came from.
    pub fn shading_normal(&self, u: T, v: T, dir: V3<T>) -> Option<V3<T>> {
        self.shading_normal_with(u, v, dir, ShadingNormal::default())
    }

    /// The shading normal at `(u, v)` for a ray arriving along `dir` under `rule`, facing the
    /// side the ray came from (unit). `None` where `dir` or the true normal is degenerate.
    pub fn shading_normal_with(&self, u: T, v: T, dir: V3<T>, rule: ShadingNormal) -> Option<V3<T>> {
        // Compute both normals towards the viewer.
        let ng = self.geometric_normal(u, v)?;
        let d = dir.normalized()?;
        let ng = if ng.dot(d) > T::ZERO { -ng } else { ng };
        let ns = match self.interpolated_normal(u, v) {
            Some(n) if n.dot(ng) > T::ZERO => n,
            Some(n) => -n,
            None => return Some(ng),
        };
        Some(match rule {
            ShadingNormal::Interpolated => ns,
            ShadingNormal::Paper => {
                let two = T::ONE + T::ONE;
                let r = d - ns * (two * d.dot(ns));
                if r.dot(ng) < T::ZERO {
                    ng
                } else {
                    ns
                }
            }
            ShadingNormal::Adapted => adapt_shading_normal(-d, ng, ns),
        })
    }

    /// The world-space corner positions `(p0, p1, p2)`.
    pub fn corners(&self) -> [V3<T>; 3] {
        [self.eval(T::ZERO, T::ZERO), self.eval(T::ONE, T::ZERO), self.eval(T::ZERO, T::ONE)]
    }

    /// How far to lift a shadow ray's origin off the surface point at `(u, v)`, as a world-space
    /// vector, on the side `side` (+1: the vertex normals' side, -1: the other).
    ///
    /// This is Hanika's shadow-terminator offset ("Hacking the Shadow Terminator", Ray Tracing Gems
    /// II, ch. 4, 2021) taken from the surface point itself: the point is moved up to each corner's
    /// tangent plane where it lies below it, `Σ b_i max(0, (p_i - P)·n_i) n_i`. A shadow ray from
    /// the lifted point clears the patch's own bulge, so hard shadows follow the shading normal
    /// instead of each patch's own true-normal terminator. The lift depends only on `(u, v)` and
    /// the corners shared across an edge, so it is continuous across smooth edges.
    pub fn shadow_lift(&self, u: T, v: T, side: T) -> V3<T> {
        // Compute the point and barycentrics in the local frame.
        let p = self.eval_local(u, v);
        let b = [T::ONE - u - v, u, v];
        let q = [self.f, self.eval_local(T::ONE, T::ZERO), self.eval_local(T::ZERO, T::ONE)];
        // Compute each corner's lift along its own normal, and blend.
        let mut lift = V3::zero();
        for i in 0..3 {
            let n = self.n[i] * side;
            let h = (q[i] - p).dot(n);
            if h > T::ZERO {
                lift = lift + n * (h * b[i].max(T::ZERO));
            }
        }
        lift * self.scale
    }

    /// How far the patch's own shape can rise into a shadow ray leaving it, world space:
    /// `(height, reach)`. `height` is the largest offset of the patch from its flat triangle along
    /// the triangle's normal `m` (see [`flat_offset_height`]), `reach` the diagonal of the patch's
    /// bounds. Zero height for a flat patch. The renderer lets a shadow ray pass the C0 bumps of
    /// its own mesh only within these (see its terminator rule).
    pub fn bump_bound(&self) -> (T, T) {
        // Compute the flat triangle's unit normal: (p1 - p0) x (p2 - p0).
        let m = (self.a + self.d).cross(self.b + self.e);
        let len = m.length();
        if !(len > T::ZERO) {
            return (T::ZERO, T::ZERO);
        }
        let m = m * (T::ONE / len);
        let height = flat_offset_height(self.a.dot(m), self.b.dot(m), self.c.dot(m));
        (height * self.scale, (self.hi - self.lo).length() * self.scale)
    }

    /// World-space bounds.
    pub fn bounds(&self) -> (V3<T>, V3<T>) {
        let lo = self.lo * self.scale + self.center;
        let hi = self.hi * self.scale + self.center;
        // The map to world space rounds: widen by its error.
        let err = (lo.abs().max_elem(hi.abs())) * T::gamma(3);
        (lo - err, hi + err)
    }

    /// [`Patch::bounds`] rounded outwards to f32 (what Embree's bounds callback takes; exact for
    /// `Patch<f32>`), or `None` for a degenerate patch (never hit: left out of the BVH).
    pub fn bounds_f32(&self) -> Option<(glam::Vec3, glam::Vec3)> {
        if self.degenerate {
            return None;
        }
        let (lo, hi) = self.bounds();
        let (lo, hi) = (lo.to_f64(), hi.to_f64());
        let down = |x: f64| {
            let f = x as f32;
            if f as f64 > x {
                f.next_down()
            } else {
                f
            }
        };
        let up = |x: f64| {
            let f = x as f32;
            if (f as f64) < x {
                f.next_up()
            } else {
                f
            }
        };
        Some((
            glam::Vec3::new(down(lo.x), down(lo.y), down(lo.z)),
            glam::Vec3::new(up(hi.x), up(hi.y), up(hi.z)),
        ))
    }

    /// World-space point with a conservative bound on its absolute rounding error.
    pub fn eval_with_error(&self, u: T, v: T) -> (V3<T>, V3<T>) {
        let p = self.eval(u, v);
        let (au, av) = (u.abs(), v.abs());
        let terms = self.a.abs() * (au * au)
            + self.b.abs() * (av * av)
            + self.c.abs() * (au * av)
            + self.d.abs() * au
            + self.e.abs() * av
            + self.f.abs();
        let err = terms * (self.scale * T::gamma(12)) + (p.abs() + self.center.abs()) * T::gamma(2);
        (p, err)
    }
}

/// The largest `|q(u, v)|` over the domain `u, v >= 0, u + v <= 1` of the offset of a patch
/// `A u² + B v² + C uv + D u + E v + F` from its flat triangle, along a unit direction `m`, given
/// `a = A·m`, `b = B·m`, `c = C·m`: `q = a(u² - u) + b(v² - v) + c uv`, zero at the corners.
/// Exact: the largest of the edges' extremes (`a/4`, `b/4`, `(a + b - c)/4` in size, at their
/// midpoints) and the interior critical point where it lies in the domain.
pub fn flat_offset_height<T: Real>(a: T, b: T, c: T) -> T {
    let quarter = T::from_f64(0.25);
    // Compute the edges' extremes.
    let mut h = (a.abs().max(b.abs())).max((a + b - c).abs()) * quarter;
    // Compute the interior critical point: [2a c; c 2b] (u, v) = (a, b).
    let two = T::ONE + T::ONE;
    let det = two * two * a * b - c * c;
    if det.abs() > T::ZERO {
        let u = (two * a * b - b * c) / det;
        let v = (two * a * b - a * c) / det;
        if u > T::ZERO && v > T::ZERO && u + v < T::ONE {
            h = h.max((a * (u * u - u) + b * (v * v - v) + c * u * v).abs());
        }
    }
    if h.is_finite() {
        h
    } else {
        T::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::pow2_at_least;

    #[test]
    fn pow2_at_least_matches_the_logarithm() {
        let mut x = 1e-300f64;
        while x < 1e300 {
            for y in [x, x.next_up(), x * 1.5, x.next_down()] {
                assert_eq!(pow2_at_least(y), 2f64.powi(y.log2().ceil() as i32), "{y:e}");
            }
            x *= 1.7;
        }
        for k in -1000..1000 {
            let p = 2f64.powi(k);
            assert_eq!(pow2_at_least(p), p);
            assert_eq!(pow2_at_least(p.next_up()), p * 2.0);
        }
    }
}
