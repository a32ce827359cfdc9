//! The lean analytic solve's second half on the refused lanes, from their members
//! ([`super::member`]): each member's two lines met with the other conic, the roots gated by
//! their distance to the ray, and the nearest polished (`lean_roots` and the tail of the
//! analytic method after it), all lanes together.
//!
//! Each lane computes what the scalar functions compute, in their order, and the lanes decide
//! only the clear cases: a hit, or a miss that rests on no step within rounding. A lane where
//! the scalar path would take another way (a line's quadratic that drops degree, a near
//! tangency, a root that fails the gate, a polish that diverged, two roots at the same `t`, a
//! miss it would decide again in f64, a ray in the patch's cone of unfolded directions) is left
//! to the scalar path, which decides it as before.

use super::{
    clamp_lanes, gamma, near, newton_step_lanes, on_ray_lanes, select, sliver_lanes, PatchLanes, F, M, V,
};
use crate::phong::intersect::analytic::RootGates;
use crate::phong::intersect::domain::{domain_tolerance, edge_band};
use crate::phong::patch::Patch;
use crate::phong::real::Real;

/// The lanes' answers: `decided` lanes hit where `hit`, at `(t, u, v)`, and miss elsewhere.
pub(super) struct RootLanes {
    pub(super) decided: M,
    pub(super) hit: M,
    pub(super) t: F,
    pub(super) u: F,
    pub(super) v: F,
}

/// The analytic method's answer from the members' `lines`, meeting the conic `other`, for the
/// local rays `(o, d)` on `(tmin, tmax)` of the lanes `lanes`.
#[allow(clippy::too_many_arguments)] // the patch, the rays, their members
#[inline(always)]
pub(super) fn roots_lanes(
    p: &Patch<f32>,
    o: V,
    d: V,
    (tmin, tmax): (F, F),
    lines: &[[F; 3]; 2],
    other: &[F; 6],
    near_multiple: M,
    lanes: M,
) -> RootLanes {
    let zero = F::splat(0.0);
    let pl = PatchLanes::new(p);
    let mut ok = lanes;
    // Compute the lines' meetings with the other conic, gated by the distance to the ray
    // (`lean_roots`): four slots, two a line.
    let RootGates { size_tol, far, polish_band } = RootGates::<f32>::new();
    let tol2 = F::splat(size_tol * size_tol);
    let inv_dd = F::splat(1.0) / d.dot(d);
    let mut slot = [(zero, zero, zero); 4];
    let mut valid = [M::none(); 4];
    for (l, line) in lines.iter().enumerate() {
        let (pts, exists) = line_conic(*line, other, &mut ok);
        for k in 0..2 {
            let (u, v) = pts[k];
            let near_far = exists[k] & near(u, v, far);
            let q = pl.eval(u, v) - o;
            let t = q.dot(d) * inv_dd;
            let r = q - d.scale(t);
            ok = ok & !(near_far & !r.dot(r).le(tol2));
            slot[2 * l + k] = (u, v, t);
            valid[2 * l + k] = near_far & near(u, v, polish_band);
        }
    }
    // Two roots at one `t`: the scalar path's order among them is its own.
    for a in 0..4 {
        for b in a + 1..4 {
            ok = ok & !(valid[a] & valid[b] & slot[a].2.eq(slot[b].2));
        }
    }
    // Compute the nearest root's polish, then the next, until one lies inside and on the
    // interval (`nearest_polished`).
    let (mut hit, mut ambiguous, mut searching) = (M::none(), near_multiple, ok);
    let (mut ht, mut hu, mut hv) = (zero, zero, zero);
    let mut taken = [M::none(); 4];
    for _ in 0..4 {
        // The nearest slot not taken, per lane (the roots' `t` are distinct).
        let mut best = F::splat(f32::INFINITY);
        let mut any = M::none();
        for k in 0..4 {
            let open = valid[k] & !taken[k];
            best = select(open & (slot[k].2.lt(best) | !any), slot[k].2, best);
            any = any | open;
        }
        searching = searching & any;
        if !searching.any() {
            break;
        }
        let (mut u, mut v, mut t) = (zero, zero, zero);
        for k in 0..4 {
            let this = valid[k] & !taken[k] & slot[k].2.eq(best);
            taken[k] = taken[k] | this;
            (u, v, t) = (select(this, slot[k].0, u), select(this, slot[k].1, v), select(this, slot[k].2, t));
        }
        // `step_from_residual` (the residual it is given is `newton_step`'s own: the same
        // bits), and the root itself where it gives no step.
        let (nu, nv, nt, stepped) = newton_step_lanes(&pl, o, d, u, v, t);
        let (pu, pv, pt) = (select(stepped, nu, u), select(stepped, nv, v), select(stepped, nt, t));
        // A polish that diverged or jumped out of the domain: a grazing ray, the scalar path's.
        let inside_after = near(pu, pv, domain_tolerance::<f32>());
        let inside_before = near(u, v, domain_tolerance::<f32>());
        let diverged = !on_ray_lanes(&pl, o, d, pu, pv, pt) | (!inside_after & inside_before);
        ok = ok & !(searching & diverged);
        searching = searching & !diverged;
        ambiguous = ambiguous | (searching & !inside_after & near(pu, pv, edge_band::<f32>()));
        let found = searching & inside_after & pt.gt(tmin) & pt.lt(tmax);
        let (cu, cv) = clamp_lanes(pu, pv);
        (ht, hu, hv) = (select(found, pt, ht), select(found, cu, hu), select(found, cv, hv));
        hit = hit | found;
        searching = searching & !found;
    }
    // Compute what the lanes decide: hits, and misses that rest on no step within rounding and
    // that f64 would not decide again (a sliver seen from afar), off the cone of unfolded
    // directions (where the scalar path certifies instead).
    let sliver = sliver_lanes(p, o);
    let s = d.dot(V::splat(p.unfolded));
    let unfolded = (s * s).gt(d.dot(d));
    let decided = ok & !unfolded & (hit | (!ambiguous & !sliver));
    RootLanes { decided, hit: hit & decided, t: ht, u: hu, v: hv }
}

/// `line_conic` on every lane, but for what the lanes leave to the scalar path (`ok` loses
/// them): a quadratic that drops degree, a discriminant in the near-tangency band. The points
/// `(u, v)`, and where each exists.
#[inline(always)]
fn line_conic(l: [F; 3], k: &[F; 6], ok: &mut M) -> ([(F, F); 2], [M; 2]) {
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    // Compute the line as a point and a unit direction (`along_line`); the line at infinity
    // has no points.
    let ll = l[0] * l[0] + l[1] * l[1];
    let line = ll.gt(zero) & ll.finite();
    let inv = one / ll.sqrt();
    let (n0, n1, n2) = (l[0] * inv, l[1] * inv, l[2] * inv);
    let (qx, qy) = (-n2 * n0, -n2 * n1);
    let (rx, ry) = (-n1, n0);
    let [a, b, c, d, e, f] = *k;
    let two = one + one;
    let s2 = a * rx * rx + b * ry * ry + c * rx * ry;
    let s1 = two * a * qx * rx + two * b * qy * ry + c * (qx * ry + qy * rx) + d * rx + e * ry;
    let s0 = a * qx * qx + b * qy * qy + c * qx * qy + d * qx + e * qy + f;
    // Compute its roots (`line_quadratic`), leaving a degree drop to the scalar path.
    let lin = s1.abs().max(s0.abs());
    let drops = !s2.abs().gt(gamma(4) * lin * F::splat(1e-3f64 as f32)) | !(lin + s2.abs()).finite();
    let four_s2_s0 = F::splat(4.0) * s2 * s0;
    let disc = s1 * s1 - four_s2_s0;
    let negative = disc.lt(zero);
    let double = negative & disc.gt(-gamma(8) * (s1 * s1 + four_s2_s0.abs()));
    // No root, yet within the near-tangency band: the scalar path's (`tangency_band`).
    let band = F::splat(<f32 as Real>::gamma(8).sqrt().sqrt()) * (s1 * s1 + four_s2_s0.abs());
    let tangent = negative & !double & !s2.eq(zero) & disc.gt(-band);
    *ok = *ok & !(line & (drops | tangent));
    let root = disc.sqrt();
    let qq = F::splat(-0.5) * (s1 + select(s1.lt(zero), -root, root));
    let qq_zero = qq.eq(zero);
    let (r0, r1) = (qq / s2, s0 / qq);
    let lo = select(double, -s1 / (s2 + s2), select(qq_zero, zero, r0.min(r1)));
    let hi = r0.max(r1);
    let pts = [(qx + lo * rx, qy + lo * ry), (qx + hi * rx, qy + hi * ry)];
    let exists = [line & (double | !negative), line & !negative & !qq_zero];
    (pts, exists)
}
