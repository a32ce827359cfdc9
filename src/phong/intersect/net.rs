//! The control-net test: a miss proven from the patch's six Bézier control points seen along
//! the ray, before any solve.
//!
//! Seen along the ray, the patch is the map `(F, G)` of its domain (the ray's two planes,
//! [`Projected`]), and the ray meets the patch where the map reaches `(0, 0)`. Both are quadratic,
//! so on the triangle each is a convex combination of its six Bernstein coefficients: the map's
//! image lies in the convex hull of the six points `(F_i, G_i)`. Where the origin lies clearly
//! outside that hull, the ray misses the patch. Run where both certificates refuse a ray, it
//! settles a third to a half of the misses there (rays passing beside a curved patch, seen along
//! a fold), which otherwise cost the analytic method.

use super::conic::{Conic, Projected};
use super::domain::domain_tolerance;
use super::retry::sliver_from_afar;
use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// Whether the ray `(o, d)` (local frame) clearly misses the patch `p`, from its conics `pr`
/// ([`super::conic::project`]): the origin lies outside the convex hull of the six points
/// `(F_i, G_i)` by more than their error. `false` decides nothing (and is the answer for NaN).
///
/// A hit has the origin inside the hull; most of them are told apart first, and cheaply, by the
/// origin lying inside the triangle of the three corner points (which are on the surface).
///
/// Then a supporting line: the origin is outside the hull when, for some `i`, every other point
/// lies strictly to the left of the line from the origin through `P_i` (`cross(P_i, P_j) > 0`);
/// the hull then touches that line only at `P_i`, which is not the origin. The candidate `P_i`
/// is the most clockwise point (one pass, each point against the best so far: where the points
/// fit in a half-plane, that is the one), then every cross product is checked. Each must exceed
/// its rounding (`γ(3)` of its terms) and the effect of moving each point by up to `e` in either
/// coordinate, where `e` bounds the points' own error and widens the domain by four domain
/// tolerances ([`domain_tolerance`]): `e` is the patch's [`net_slack`] and `γ(32) 3 |o|∞` for
/// the ray's origin. The solve accepts a root up to one tolerance outside the domain; so an
/// answer this test changes can only be a hit at a root more than three tolerances outside, a
/// false hit of the f32 solve (a grazing ray), and no ray whose line meets the patch is turned
/// away. The rounding of `e`, of the slack's own terms and of the threshold's sum is covered by
/// the spare margin in both (`γ(3)` where the cross product needs `γ(2)`, and `e`'s own).
///
/// A sliver seen from afar is left out (`false`): there a miss of the f32 solve is decided again
/// in f64, which accepts a root further outside the domain than four tolerances, by the
/// patch's narrowness ([`super::retry::sliver_from_afar`]); the test leaves those rays to it.
#[inline(always)]
pub(super) fn misses_net<T: Real>(p: &Patch<T>, o: V3<T>, pr: &Projected<T>) -> bool {
    if sliver_from_afar(p, o) {
        return false;
    }
    // Compute the control points seen along the ray (corners first), and the corners' triangle:
    // the origin strictly inside it (as computed) is inside the hull, and no supporting line
    // can prove otherwise. Only a shortcut: it proves nothing.
    let (f, g) = (control_values(&pr.f), control_values(&pr.g));
    let cross = |i: usize, j: usize| f[i] * g[j] - g[i] * f[j];
    let (c01, c12, c20) = (cross(0, 1), cross(1, 2), cross(2, 0));
    let z = T::ZERO;
    if (c01 > z && c12 > z && c20 > z) || (c01 < z && c12 < z && c20 < z) {
        return false;
    }
    // Compute the most clockwise point.
    let (mut fi, mut gi) = (f[0], g[0]);
    for j in 1..6 {
        if fi * g[j] - gi * f[j] < z {
            (fi, gi) = (f[j], g[j]);
        }
    }
    // Compute every point's side of the line through it, each with its slack:
    // `|f_i g_j| + |g_i f_j| <= s_i s_j` with `s = |f| + |g|`, so the rounding and the points'
    // error `e` give `s_j (γ(3) s_i + e) + e s_i + 2 e²`.
    let e = p.net_slack + T::gamma(32) * T::from_f64(3.0) * o.max_abs();
    let s_i = fi.abs() + gi.abs();
    let (a, b) = (T::gamma(3) * s_i + e, e * s_i + T::from_f64(2.0) * e * e);
    let mut left = 0u32;
    for j in 0..6 {
        left += (fi * g[j] - gi * f[j] > (f[j].abs() + g[j].abs()) * a + b) as u32;
    }
    // Every point but the line's own.
    left == 5
}

/// The six Bernstein coefficients of the conic `k` on the triangle `u, v, 1 - u - v >= 0`, at
/// the corners `(0, 0)`, `(1, 0)`, `(0, 1)`, then the edges' middle coefficients, of the edges
/// `(0, 0)–(1, 0)`, `(0, 0)–(0, 1)` and `(1, 0)–(0, 1)`.
#[inline(always)]
fn control_values<T: Real>(k: &Conic<T>) -> [T; 6] {
    let [a, b, c, d, e, f] = k.k;
    let h = T::from_f64(0.5);
    [f, a + d + f, b + e + f, f + d * h, f + e * h, f + (c + d + e) * h]
}

/// The part of [`misses_net`]'s bound `e` on each control value's error that does not depend
/// on the ray, for a patch with coefficients `coef` (`A` to `E`) and `f` (`F`) as stored in
/// precision `T`: the distance of the computed value from the exact control value of the exact
/// ray on the domain widened by four domain tolerances ([`domain_tolerance`]; see
/// [`misses_net`]), in either coordinate.
/// - The domain widened by `δ` (`u, v >= -δ`, `u + v <= 1 + δ`, as [`super::domain::near_domain`]):
///   each of its points is within `2δ` of the domain in `u` and in `v`, so the map moves by at
///   most `2δ (|F_u| + |F_v|)`, and there `|F_u| + |F_v| <= 8 (1 + 2δ) max |k|` over the conic's
///   quadratic and linear coefficients, each `n · x` with `n` a unit vector: at most `√3 |x|∞`.
/// - Rounding: each coefficient `n · x` of [`super::conic::project`] is within `γ(3) |x|₁` of
///   exact, and a control value sums up to four of them, with up to three more roundings (the
///   local origin's and the coefficients' own rounding to `T` fit in the same budget); the planes' normals
///   are unit and orthogonal to the ray's direction to a few roundings, which moves the line they
///   meet in by as much over the distance from the ray's origin to a point of the (widened)
///   patch, at most `(1 + 2δ)² s + |o|∞`. All of it is within `γ(32)` of `3 s`, `s` the sum of the
///   coefficient vectors' largest components and `|o|∞` (`|x|₁ <= 3 |x|∞`, and every point of
///   the patch is within `s` of the frame's centre); the ray's part, `|o|∞`, is added per ray.
pub(crate) fn net_slack<T: Real>(coef: [V3<f64>; 5], f: V3<f64>) -> f64 {
    let largest = coef.iter().fold(0.0f64, |m, x| m.max(x.max_abs()));
    let delta = 4.0 * domain_tolerance::<T>().to_f64();
    let widened = 16.0 * delta * (1.0 + 2.0 * delta) * 3f64.sqrt() * largest;
    let s = coef.iter().map(|x| x.max_abs()).sum::<f64>() + f.max_abs();
    // Rounded up: the sum above and its conversion to `T` may round down.
    (widened + T::gamma(32).to_f64() * 3.0 * s) * (1.0 + 1e-6)
}

#[cfg(test)]
mod tests {
    use super::super::conic::project;
    use super::super::domain::domain_tolerance;
    use super::*;
    use crate::phong::accuracy::{generate, Category, SplitMix};
    use crate::phong::reference::reference_intersect;

    /// The control values are the conic's Bernstein coefficients: their combination by the
    /// quadratic Bernstein basis gives the conic's value, at points in and around the domain.
    #[test]
    fn control_values_combine_to_the_conic() {
        let mut rng = SplitMix(91);
        for _ in 0..10_000 {
            let k = Conic { k: std::array::from_fn(|_| rng.range(-2.0, 2.0)) };
            let c = control_values(&k);
            let (u, v) = (rng.range(-0.5, 1.5), rng.range(-0.5, 1.5));
            let w = 1.0 - u - v;
            let bernstein = [w * w, u * u, v * v, 2.0 * w * u, 2.0 * w * v, 2.0 * u * v];
            let sum: f64 = (0..6).map(|i| bernstein[i] * c[i]).sum();
            assert!((sum - k.at(u, v)).abs() <= 1e-12, "{k:?} at ({u}, {v}): {sum}");
        }
    }

    /// No ray whose line the f64 reference finds on the patch is turned away by the net test,
    /// in f32 or in f64, on rays of every accuracy category (grazing ones, slivers, far
    /// origins; every other one moved sideways by up to 1.5 times the patch's size, so that
    /// many miss; the patch and the ray rounded to f32 for all three); and the test settles a
    /// good share of the rays whose line misses.
    #[test]
    fn the_net_test_never_turns_away_a_ray_that_hits() {
        let mut rng = SplitMix(92);
        let (mut misses, mut settled) = (0usize, 0usize);
        let r = |x: glam::DVec3| -> glam::DVec3 { V3::from(x).cast::<f32>().to_f64().into() };
        for i in 0..20_000 {
            let mut c = generate(&mut rng, Category::ALL[i / 2 % Category::ALL.len()]);
            if i % 2 == 1 {
                let side = c.dir.normalize().any_orthonormal_pair();
                let (x, y) = (rng.range(-1.5, 1.5), rng.range(-1.5, 1.5));
                c.org += (side.0 * x + side.1 * y) * c.size;
            }
            let (cp, cn, org, dir) = (c.p.map(r), c.n.map(r), r(c.org), r(c.dir));
            let p64: Patch<f64> = Patch::new(cp, cn, c.alpha);
            let p32: Patch<f32> = Patch::new(cp, cn, c.alpha);
            let inf = f64::INFINITY;
            let hit = reference_intersect(cp, cn, c.alpha, [false; 3], org, dir, -inf, inf).is_some();
            let (o, d) = (V3::from(org), V3::from(dir));
            let (o64, d64) = ((o - p64.center) * p64.inv_scale, d * p64.inv_scale);
            let (o32, d32) =
                ((o.cast::<f32>() - p32.center) * p32.inv_scale, d.cast::<f32>() * p32.inv_scale);
            let n64 = project(&p64, o64, d64).is_some_and(|pr| misses_net(&p64, o64, &pr));
            let n32 = project(&p32, o32, d32).is_some_and(|pr| misses_net(&p32, o32, &pr));
            if hit {
                assert!(!n64 && !n32, "case {i}: a ray that hits turned away (f64 {n64}, f32 {n32}): {c:?}");
            } else {
                misses += 1;
                settled += n32 as usize;
            }
        }
        assert!(misses > 5_000 && settled * 4 > misses, "{settled} of {misses} misses settled");
        println!("{settled} of {misses} misses settled");
    }

    /// Lines through points of the stored f32 patch up to four domain tolerances outside the
    /// domain (past an edge, the widening the test promises) are never turned away:
    /// the point computed in f64 from the f32 coefficients, the ray's origin rounded to f32 a
    /// random distance back along a random direction.
    #[test]
    fn lines_through_the_widened_domain_are_not_turned_away() {
        let mut rng = SplitMix(93);
        let tol = domain_tolerance::<f32>() as f64;
        let mut tried = 0;
        for i in 0..50_000 {
            // Flat patches half the time: there the hull is the triangle, and the widening is
            // what keeps these lines (it is nearly all of the slack).
            let category =
                if i % 2 == 0 { Category::AlphaZero } else { Category::ALL[i / 2 % Category::ALL.len()] };
            let c = generate(&mut rng, category);
            let p: Patch<f32> = Patch::new(c.p, c.n, c.alpha);
            if p.degenerate {
                continue;
            }
            // Compute a point of the widened domain near its boundary.
            let out = rng.range(0.0, 4.0) * tol;
            let t = rng.range(0.0, 1.0);
            let (u, v) = match i % 3 {
                0 => (t, -out),
                1 => (-out, t),
                _ => (t + 0.5 * out, 1.0 - t + 0.5 * out),
            };
            let k = |x: V3<f32>| x.to_f64();
            let x = k(p.a) * (u * u) + k(p.b) * (v * v) + k(p.c) * (u * v) + k(p.d) * u + k(p.e) * v + k(p.f);
            let d = V3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
            let o = (x - d * rng.range(0.5, 20.0)).cast::<f32>();
            let d = d.cast::<f32>();
            let Some(pr) = project(&p, o, d) else { continue };
            tried += 1;
            assert!(!misses_net(&p, o, &pr), "case {i}: ({u}, {v}) turned away: {c:?}");
        }
        assert!(tried > 45_000, "{tried} rays");
    }
}
