//! The det-sign certificate: the projected patch is one-to-one on a convex region where the
//! determinant of its Jacobian has no zero, which the signs of that determinant's Bernstein
//! coefficients prove.
//!
//! `π(u, v) = (F, G)` is quadratic, so for any two points `x`, `y`
//!
//! ```text
//! π(y) - π(x) = J((x + y) / 2) (y - x)
//! ```
//!
//! exactly (`J` is affine, and `π(x + h) = π(x) + J(x) h + B(h, h)` with `J(x + h/2) h =
//! J(x) h + B(h, h)`, `B` the constant second derivative). If `π(x) = π(y)` with `x ≠ y`, `J` is
//! singular at their midpoint. So where `det J` has no zero on a convex region `R`, `π` is
//! one-to-one on `R`: the ray meets that part of the surface at most once. Unlike a local
//! argument (a nonzero `det J` alone only makes `π` locally one-to-one), no boundary winding test
//! is needed, because the midpoint of two points of a convex region stays in it.
//!
//! `det J` is a quadratic in `(u, v)`. On a triangle with corners `p0, p1, p2` (barycentrics
//! `λ`), `J = Σ λi Ji` with `Ji = J(pi)`, and by polarisation
//!
//! ```text
//! det J = Σ λi² det Ji + Σ_{i<j} 2 λi λj m(Ji, Jj) / 2,
//! m(A, B) = a00 b11 + b00 a11 - a01 b10 - b01 a10,
//! ```
//!
//! so its Bernstein coefficients are `det Ji` at the corners and `m(Ji, Jj) / 2` on the edges.
//! The Bernstein polynomials are nonnegative and sum to 1: if all six coefficients have one sign,
//! so has `det J` on the whole triangle.
//!
//! Rounding, all in one place. Let `K` bound every coefficient of the Jacobian's entries (`2a`,
//! `c`, `d`, `2b`, `e` of both conics; `2 max(|F|, |G|)` over their coefficients does) and let
//! `w = 1 + |u| + |v|` at a point. An entry `α u + β v + δ`, computed with three roundings,
//! is within `γ(3) K w` of the exact one (pbrt-v4 §6.8), and both are at most `(1 + γ(3)) K w`.
//! A product of two entries at points `p`, `q` then carries `(2 γ(3) + γ(3)²) K² wp wq` from its
//! factors and `u (1 + γ(3))² K² wp wq` from its own rounding, together at most
//! `γ(7) K² wp wq`; summing four such products (three more roundings) gives at most
//! `4 γ(10) K² wp wq`, which also bounds the two-product `det Ji` (`2 γ(8) K² wi²`). So a
//! coefficient computed at the points of largest `w = W` is within
//!
//! ```text
//! 4 γ(10) K² W²
//! ```
//!
//! of the exact one, and one that exceeds that margin in size has the exact one's sign. The
//! margin is computed as `4 γ(16) K² W²`: `γ(16)` covers the rounding of the margin's own three
//! products. The certificate is exact for the conics as computed: their own rounding (of the
//! ray's planes and of `P - o`) is a backward error of the ray, which every stage of the solve
//! shares.
//!
//! Most rays need none of this: the patch's own cone of unfolded directions decides them first
//! ([`unfolded_along`]). With `n1`, `n2` the ray's planes, `J = [[n1·Pu, n1·Pv], [n2·Pu,
//! n2·Pv]]`, so `det J = (n1 × n2)·(Pu × Pv)`, and `n1 × n2` is the ray's unit direction to
//! rounding. Where that direction lies in the cone of [`unfolded_axis`], `d̂·N` exceeds `τ = 1e-4
//! S²` in size with one sign on the whole domain (`N = Pu × Pv`, `S` bounding `|Pu|` and `|Pv|`
//! there), so the exact `det J` of the conics as computed keeps that sign: their coefficients
//! are dot products of unit planes with `A, ..., E` and `F - o`, so each entry of `J` is within
//! `5 γ(3) S` of `n·Pu` or `n·Pv` (`2 |A| + |C| + |D| <= 5 S`, as `D`, `2A + D`, `C + D` are
//! the corners' `Pu`), `det J` within `20 γ(3) S²` of `(n1 × n2)·N`, and `n1 × n2` within a few
//! roundings of `d̂`: under `4e-6 S²` in f32 together, against `τ`. That is the det-sign
//! certificate's conclusion, for about a tenth of its instructions.
//!
//! [`unfolded_axis`]: crate::phong::patch::unfolded_axis

use super::conic::Projected;
use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// The det-sign certificate on the domain: `det J` has one sign on all of it.
pub(super) struct DetSign<T> {
    /// The Jacobian at `R`'s corners.
    corners: [[T; 4]; 3],
    /// The sign of `det J` on `R`: `1` or `-1`.
    sign: T,
    /// `K²`: the square of the bound on the Jacobian's coefficients.
    k2: T,
    /// The region's largest `w = 1 + |u| + |v|` at a corner.
    w: T,
}

/// `det A` for a 2×2 matrix, row-major.
#[inline(always)]
fn det2<T: Real>(a: &[T; 4]) -> T {
    a[0] * a[3] - a[1] * a[2]
}

/// `m(A, B) = a00 b11 + b00 a11 - a01 b10 - b01 a10`: twice the Bernstein coefficient of `det J`
/// on the edge between two points where `J` is `A` and `B`.
#[inline(always)]
fn mixed<T: Real>(a: &[T; 4], b: &[T; 4]) -> T {
    (a[0] * b[3] + b[0] * a[3]) - (a[1] * b[2] + b[1] * a[2])
}

/// The rounding margin of a Bernstein coefficient of `det J` computed at points whose
/// `w = 1 + |u| + |v|` is at most `w`: `4 γ(16) K² w²` (see the module's comment).
#[inline(always)]
fn margin<T: Real>(k2: T, w: T) -> T {
    T::gamma(16) * T::from_f64(4.0) * k2 * (w * w)
}

/// `K²`, the square of the bound on the Jacobian's coefficients: `2 max(|F|, |G|)` over the
/// conics' coefficients (see the module's comment).
#[inline(always)]
fn bound_squared<T: Real>(pr: &Projected<T>) -> T {
    let k = pr.f.norm().max(pr.g.norm()) * T::from_f64(2.0);
    k * k
}

/// [`DetSign`] when `det J`'s six Bernstein coefficients on the domain (`j`: `J` at its corners
/// `(0, 0)`, `(1, 0)`, `(0, 1)`, whose largest `w` is 2) all have one sign, clear of their
/// rounding margin; `None` when they do not (the patch may fold as seen along the ray), or when
/// a coefficient is NaN.
#[inline(always)]
pub(super) fn det_sign_on_domain<T: Real>(pr: &Projected<T>, j: [[T; 4]; 3]) -> Option<DetSign<T>> {
    // Compute the corners' coefficients first: one of the other sign refuses before the margin
    // and the edges' coefficients are computed (the same answer: each must clear a positive
    // margin with the first corner's sign).
    let corners = [det2(&j[0]), det2(&j[1]), det2(&j[2])];
    let sign = if corners[0] > T::ZERO { T::ONE } else { -T::ONE };
    if !(corners[1] * sign > T::ZERO && corners[2] * sign > T::ZERO) {
        return None;
    }
    // Compute the margin from the conics' largest coefficient, then the edges' coefficients
    // (doubled): all six must clear it with the first corner's sign.
    let (k2, w) = (bound_squared(pr), T::from_f64(2.0));
    let m = margin(k2, w);
    let c =
        [corners[0], corners[1], corners[2], mixed(&j[0], &j[1]), mixed(&j[1], &j[2]), mixed(&j[2], &j[0])];
    c.iter().all(|&x| x * sign > m).then_some(DetSign { corners: j, sign, k2, w })
}

/// [`DetSign`] on the domain where [`unfolded_along`] holds: the cone already proves what
/// [`det_sign_on_domain`] checks, so only what [`DetSign::holds_to`] needs is computed. The sign
/// is the corner `(0, 0)`'s, which the cone keeps far from rounding.
#[inline(always)]
pub(super) fn det_sign_unfolded<T: Real>(pr: &Projected<T>, j: [[T; 4]; 3]) -> DetSign<T> {
    let sign = if det2(&j[0]) > T::ZERO { T::ONE } else { -T::ONE };
    DetSign { corners: j, sign, k2: bound_squared(pr), w: T::from_f64(2.0) }
}

/// Whether the local ray direction `d` lies in the patch's cone of unfolded directions (see
/// the module's comment): then `det J` keeps one sign on the domain, as
/// [`det_sign_on_domain`] would prove, without computing it.
#[inline(always)]
pub(super) fn unfolded_along<T: Real>(p: &Patch<T>, d: V3<T>) -> bool {
    let s = d.dot(p.unfolded);
    s * s > d.dot(d)
}

/// Whether `a` and `b`, `det J` computed at two points of the domain (each entry of `J` with at
/// most four roundings, as [`det_sign_on_domain`]'s coefficients and the Jacobian at the
/// centroid are), clearly have opposite signs: each exceeds the rounding margin of a coefficient
/// (the module's comment; `w <= 2` in the domain), so the exact `det J` has a zero between the
/// two points. Then no certificate that proves `det J` one-signed on a region holding the
/// domain can hold: neither the det-sign one (on the domain) nor the positive-definite one (on
/// a larger region, where it makes `det J` the sign of `det J0`).
#[inline(always)]
pub(super) fn folds_between<T: Real>(pr: &Projected<T>, a: T, b: T) -> bool {
    if !(a * b < T::ZERO) {
        return false;
    }
    let m = margin(bound_squared(pr), T::from_f64(2.0));
    a.abs() > m && b.abs() > m
}

impl<T: Real> DetSign<T> {
    /// Whether `det J` also keeps its sign on the hull of the region and the Newton root
    /// `(u, v)`, where `J` is `jr`: then `π` is one-to-one on that hull too, and the root is the
    /// only one there.
    ///
    /// The three triangles joining `(u, v)` to the region's edges cover that hull whatever
    /// `(u, v)` is (a point of the region lies between `(u, v)` and the edge where the line from
    /// `(u, v)` through it leaves the region), so their coefficients are checked: `det jr` and
    /// `m(jr, Ji)` for the three corners (the region's own are known). Besides their rounding,
    /// the margin covers the root's own error: the exact root lies within `ρ = 2 γ(64)` of the
    /// iterate in each coordinate (Newton's last step was at most `γ(64)`, and it converges
    /// quadratically), which moves an entry of `jr` by at most `2 K ρ` and a coefficient by at
    /// most `10 ρ K² W²` (`W` the larger of the root's `w` and the region's). So the margin is
    /// `4 γ(16) K² W² + 20 γ(64) K² W²`, taken as `24 γ(64) K² W²`.
    #[inline(always)]
    pub(super) fn holds_to(&self, jr: [T; 4], u: T, v: T) -> bool {
        let w = self.w.max(T::ONE + u.abs() + v.abs());
        let m = T::gamma(64) * T::from_f64(24.0) * self.k2 * (w * w);
        let c = [
            det2(&jr),
            mixed(&jr, &self.corners[0]),
            mixed(&jr, &self.corners[1]),
            mixed(&jr, &self.corners[2]),
        ];
        c.iter().all(|&x| x * self.sign > m)
    }
}
