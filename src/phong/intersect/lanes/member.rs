//! The lean analytic solve's first half on the lanes both certificates refused: the pencil's
//! line-pair member and its two lines ([`lean_member`]), all lanes together. The refused lanes
//! of a call usually come several at once (a patch that folds as seen by the whole packet), and
//! this half (the cubic, its Newton root, the member's choice, the split) is straight-line
//! arithmetic but for the root's Newton loop, which runs until every lane has stopped.
//!
//! Each lane computes what [`lean_member`] computes, in its order, so a lane it gives a member
//! has that function's member bit for bit. A lane it gives none (a flat or degenerate pencil, no
//! member clearly a line pair, a Newton root that did not settle) takes the scalar path whole,
//! which then decides it as it would have anyway.

use super::{gamma, select, F, LANES, M};
#[cfg(doc)]
use crate::phong::intersect::analytic::lean_member;
use crate::phong::intersect::analytic::{self, pencil_cubic, sym_adj, trace_adj_quadratic, LeanMember};
use crate::phong::intersect::poly::cbrt_upper;

/// A symmetric 3×3 matrix per lane, `[s00, s11, s22, s01, s02, s12]`.
type Sym = analytic::Sym<F>;

/// The refused lanes' members ([`member_lanes`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct MemberLanes {
    /// The two lines' coefficients, per lane.
    lines: [[[f32; LANES]; 3]; 2],
    /// Bit `i` set where lane `i` has a member.
    found: u32,
    /// Bit `i` set where lane `i`'s lines meet `G`.
    meets_g: u32,
    /// Bit `i` set where lane `i`'s cubic is near a double root.
    near_multiple: u32,
}

impl MemberLanes {
    /// Lane `i`'s member, as [`lean_member`] gives it, where the lanes found one.
    pub(super) fn get(&self, i: usize) -> Option<LeanMember<f32>> {
        let bit = |b: u32| b >> i & 1 != 0;
        let l = &self.lines;
        bit(self.found).then(|| LeanMember {
            lines: [[l[0][0][i], l[0][1][i], l[0][2][i]], [l[1][0][i], l[1][1][i], l[1][2][i]]],
            meets_g: bit(self.meets_g),
            near_multiple: bit(self.near_multiple),
        })
    }
}

/// The refused lanes' members as lanes ([`member_lanes`]).
pub(super) struct Members {
    /// The two lines' coefficients.
    pub(super) lines: [[F; 3]; 2],
    /// The lanes that have a member.
    pub(super) found: M,
    /// The lanes whose lines meet `G`.
    pub(super) meets_g: M,
    /// The lanes whose cubic is near a double root.
    pub(super) near_multiple: M,
}

impl Members {
    /// The members kept for the scalar path.
    pub(super) fn stored(&self) -> MemberLanes {
        let l = &self.lines;
        MemberLanes {
            lines: [[l[0][0].0, l[0][1].0, l[0][2].0], [l[1][0].0, l[1][1].0, l[1][2].0]],
            found: self.found.bits(),
            meets_g: self.meets_g.bits(),
            near_multiple: self.near_multiple.bits(),
        }
    }
}

/// [`lean_member`] for the lanes `lanes` of the conics `f`, `g` (6 coefficients each, per lane).
#[inline(always)]
pub(super) fn member_lanes(f: &[F; 6], g: &[F; 6], lanes: M) -> Members {
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    // Compute the conics' sizes (`Conic::norm`); a flat pencil is the scalar path's.
    let (nm, nn) = (norm(f), norm(g));
    let mut ok = lanes & !nm.eq(zero) & !nn.eq(zero);
    let (m, n) = (sym_of(f), sym_of(g));
    let (root, near_multiple) = line_pair_root(&m, &n, nm, nn, &mut ok);
    // Compute the member, scaled as `lean_member` does.
    let small = root.abs().le(one);
    let ix = one / root;
    let mut h: Sym = [zero; 6];
    for i in 0..6 {
        h[i] = select(small, root * m[i] + n[i], m[i] + ix * n[i]);
    }
    let lines = split_line_pair(&h, &mut ok);
    Members { lines, found: ok, meets_g: !small, near_multiple }
}

/// The f64 constant `x` in f32, on every lane (as `T::from_f64`).
#[inline(always)]
fn konst(x: f64) -> F {
    F::splat(x as f32)
}

/// `Conic::norm`: the largest coefficient's size.
#[inline(always)]
fn norm(k: &[F; 6]) -> F {
    let mut m = F::splat(0.0);
    for x in k {
        m = m.max(x.abs());
    }
    m
}

/// `x0` where `first`, else `x1` where `second`, else `x2`.
#[inline(always)]
fn pick3(first: M, second: M, x0: F, x1: F, x2: F) -> F {
    select(first, x0, select(second, x1, x2))
}

/// The monic cubic `x³ + a x² + b x + c` and its derivative at `x`, in `monic_cubic_roots`'s
/// order.
#[inline(always)]
fn cubic_at(x: F, a: F, b: F, c: F) -> (F, F) {
    let three = F::splat(3.0);
    (((x + a) * x + b) * x + c, (three * x + a + a) * x + b)
}

/// `line_pair_score`: `tr adj(x M + N) = x² t2 + x t1 + t0` relative to the member's size.
#[inline(always)]
fn line_pair_score(x: F, (t2, t1, t0): (F, F, F), nm: F, nn: F) -> F {
    let one = F::splat(1.0);
    let small = x.abs().le(one);
    let s = x.abs() * nm + nn;
    let near = ((x * t2 + t1) * x + t0) / (s * s);
    let ix = one / x;
    let s = nm + ix.abs() * nn;
    let far = ((t0 * ix + t1) * ix + t2) / (s * s);
    select(small, near, far)
}

/// `sym_of`: the conic's matrix.
#[inline(always)]
fn sym_of(k: &[F; 6]) -> Sym {
    let h = F::splat(0.5);
    let [a, b, c, d, e, f] = *k;
    [a, b, f, c * h, d * h, e * h]
}

/// `line_pair_root`: the root of `det(x M + N)` whose member is most clearly a real line pair,
/// and the lanes near a double root; `ok` loses the lanes where it gives none.
#[inline(always)]
fn line_pair_root(m: &Sym, n: &Sym, nm: F, nn: F, ok: &mut M) -> (F, M) {
    let c = konst;
    let (zero, three) = (c(0.0), c(3.0));
    // Compute the cubic's coefficients, and leave the lanes where it drops degree.
    let ([c3, c2, c1, c0], am, an) = pencil_cubic(m, n);
    let term = nm.max(nn);
    let cubic_scale = term * term * term;
    let cn = c3.abs().max(c2.abs()).max(c1.abs()).max(c0.abs());
    let drops = c3.abs().le(gamma(64) * cubic_scale) | c3.abs().le(gamma(16) * cn);
    *ok = *ok & !drops;
    let (a, b, cc) = (c2 / c3, c1 / c3, c0 / c3);
    let q = (a * a - three * b) * c(1.0 / 9.0);
    let r = (c(2.0) * a * a * a - c(9.0) * a * b + c(27.0) * cc) * c(1.0 / 54.0);
    let near_multiple = (r * r - q * q * q).abs().le(gamma(256) * (r * r).max((q * q * q).abs()));
    let (x, pair, qq, c2q) = monic_cubic_roots(a, b, cc, ok);
    // Compute the scores of the roots (`line_pair_score`) and take the least.
    let t = trace_adj_quadratic(m, n, &am, &an);
    let (mut best, mut best_score) = (x, line_pair_score(x, t, nm, nn));
    // The quotient's roots: `0` as the second where it is `x²` (`qq = 0`), none without a pair.
    let qq_zero = qq.eq(zero);
    let second = select(qq_zero, zero, qq);
    let third = c2q / qq;
    for (root, lanes) in [(second, pair), (third, pair & !qq_zero)] {
        let s = line_pair_score(root, t, nm, nn);
        let take = lanes & s.lt(best_score);
        (best, best_score) = (select(take, root, best), select(take, s, best_score));
    }
    *ok = *ok & best_score.lt(-gamma(64).sqrt());
    // Compute the chosen root to full precision where it is not Newton's.
    let refine = !best.eq(x);
    for _ in 0..2 {
        let fx = ((best + a) * best + b) * best + cc;
        let df = (three * best + a + a) * best + b;
        let nx = best - fx / df;
        best = select(refine & nx.finite(), nx, best);
    }
    (best, near_multiple)
}

/// `monic_cubic_roots`: Newton's root `x` of `x³ + a x² + b x + c` from Kahan's bound, the
/// lanes whose quotient quadratic has real roots, its `qq` and its constant term (the other
/// roots are `qq` and `c2 / qq`); `ok` loses the lanes where Newton did not settle.
#[inline(always)]
fn monic_cubic_roots(a: F, b: F, c: F, ok: &mut M) -> (F, M, F, F) {
    let (zero, one, three) = (F::splat(0.0), F::splat(1.0), F::splat(3.0));
    // Compute the start: the inflection point, moved past the root by Kahan's bound.
    let x_inf = -a / three;
    let (q, dq) = cubic_at(x_inf, a, b, c);
    let s = select(q.lt(zero), -one, one);
    let mut bound = [0.0; LANES];
    for i in 0..LANES {
        bound[i] = cbrt_upper(q.0[i].abs() as f64) as f32;
    }
    let mut r = F(bound) * (F::splat(1.0) + gamma(2));
    r = select(dq.lt(zero), F::splat(1.324718f64 as f32) * r.max((-dq).sqrt()), r);
    let mut x = x_inf - s * r;
    // Compute the root: each lane's Newton steps until they stop moving it towards the
    // inflection point (or its derivative vanishes), as the scalar loop's break.
    let moves = !q.eq(zero);
    let (mut running, mut settled) = (*ok & moves, M::none());
    for _ in 0..24 {
        if !running.any() {
            break;
        }
        let (fx, dfx) = cubic_at(x, a, b, c);
        let flat = dfx.eq(zero);
        let nx = x - fx / dfx;
        let stops = !(s * nx).gt(s * x);
        settled = settled | (running & flat) | (running & !flat & stops & nx.finite());
        running = running & !flat & !stops;
        x = select(running, nx, x);
    }
    x = select(moves, x, x_inf);
    *ok = *ok & (!moves | (settled & x.finite()));
    // Compute the quotient quadratic x² + b1 x + c2, in Kahan's stabler form where the
    // constant term is better taken from c.
    let b1 = x + a;
    let c2 = x * b1 + b;
    let kahan = !x.eq(zero) & (x * x * x).abs().gt((c / x).abs());
    let c2k = -c / x;
    let b1k = (c2k - b) / x;
    let (b1, c2) = (select(kahan, b1k, b1), select(kahan, c2k, c2));
    let disc = b1 * b1 - F::splat(4.0) * c2;
    let root = disc.sqrt();
    let qq = F::splat(-0.5) * (b1 + select(b1.lt(zero), -root, root));
    (x, disc.ge(zero), qq, c2)
}

/// `split_line_pair`: the member's two lines; `ok` loses the lanes where it gives none.
#[inline(always)]
fn split_line_pair(h: &Sym, ok: &mut M) -> [[F; 3]; 2] {
    let zero = F::splat(0.0);
    let b = sym_adj(h);
    // Compute the column of the least diagonal entry of adj(H) = -p pᵀ.
    let first = b[0].le(b[1]) & b[0].le(b[2]);
    let second = !first & b[1].le(b[2]);
    let col = [
        pick3(first, second, b[0], b[3], b[4]),
        pick3(first, second, b[3], b[1], b[5]),
        pick3(first, second, b[4], b[5], b[2]),
    ];
    let bii = pick3(first, second, b[0], b[1], b[2]);
    *ok = *ok & bii.lt(zero);
    let inv = F::splat(1.0) / (-bii).sqrt();
    let p = [col[0] * inv, col[1] * inv, col[2] * inv];
    let [h00, h11, h22, h01, h02, h12] = *h;
    // H + [p]× has rank 1: its largest entry's row and column are the two lines.
    let c = [[h00, h01 + p[2], h02 - p[1]], [h01 - p[2], h11, h12 + p[0]], [h02 + p[1], h12 - p[0], h22]];
    let (mut bm, mut bi, mut bj) = (zero, zero, zero);
    for (r, row) in c.iter().enumerate() {
        for (s, x) in row.iter().enumerate() {
            let a = x.abs();
            let larger = a.gt(bm);
            bm = select(larger, a, bm);
            bi = select(larger, F::splat(r as f32), bi);
            bj = select(larger, F::splat(s as f32), bj);
        }
    }
    *ok = *ok & bm.gt(zero);
    let (bi0, bi1) = (bi.eq(zero), bi.eq(F::splat(1.0)));
    let (bj0, bj1) = (bj.eq(zero), bj.eq(F::splat(1.0)));
    let mut lines = [[zero; 3]; 2];
    for k in 0..3 {
        lines[0][k] = pick3(bi0, bi1, c[0][k], c[1][k], c[2][k]);
        lines[1][k] = pick3(bj0, bj1, c[k][0], c[k][1], c[k][2]);
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phong::accuracy::{generate, Category, SplitMix};
    use crate::phong::intersect::analytic::lean_member;
    use crate::phong::intersect::conic::project;
    use crate::phong::patch::Patch;
    use crate::phong::real::V3;

    /// The lanes give [`lean_member`]'s member bit for bit wherever they give one, and give
    /// one wherever it does: conics of rays of every accuracy category, 8 different rays to a
    /// call.
    #[test]
    fn member_lanes_give_lean_members_bits() {
        let mut rng = SplitMix(43);
        let (mut found, mut calls) = (0usize, 0usize);
        while calls < 20_000 {
            let mut f = [F::splat(0.0); 6];
            let mut g = [F::splat(0.0); 6];
            let mut want = [None; LANES];
            for i in 0..LANES {
                let category = Category::ALL[(calls * LANES + i) % Category::ALL.len()];
                let c = generate(&mut rng, category);
                let p: Patch<f32> = Patch::new(c.p, c.n, c.alpha);
                let org = (V3::from(c.org).cast::<f32>() - p.center) * p.inv_scale;
                let dir = V3::from(c.dir).cast::<f32>() * p.inv_scale;
                let Some(pr) = project(&p, org, dir) else { continue };
                for j in 0..6 {
                    (f[j].0[i], g[j].0[i]) = (pr.f.k[j], pr.g.k[j]);
                }
                let (nf, ng) = (pr.f.norm(), pr.g.norm());
                if nf != 0.0 && ng != 0.0 {
                    want[i] = lean_member(&pr.f, nf, &pr.g, ng).map(|(m, _)| m);
                }
            }
            let lanes = member_lanes(&f, &g, !M::none()).stored();
            for (i, want) in want.iter().enumerate() {
                let got = lanes.get(i);
                let bits = |m: Option<LeanMember<f32>>| {
                    m.map(|m| (m.lines.map(|l| l.map(f32::to_bits)), m.meets_g, m.near_multiple))
                };
                assert_eq!(bits(got), bits(*want), "call {calls}, lane {i}");
                found += got.is_some() as usize;
            }
            calls += 1;
        }
        assert!(found > calls * LANES / 2, "only {found} members found");
    }
}
