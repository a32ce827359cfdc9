//! Polynomial solvers: quadratic and cubic, robust to degree drops and near-multiple roots.

use crate::phong::real::Real;

/// Real roots of `q2 x² + q1 x + q0`, without cancellation (citardauq form). Degree drops
/// are handled; an identically zero polynomial has no isolated roots.
pub fn solve_quadratic<T: Real>(q2: T, q1: T, q0: T) -> ([T; 2], usize) {
    let z = T::ZERO;
    let scale = q2.abs().max(q1.abs()).max(q0.abs());
    if scale == z || !scale.is_finite() {
        return ([z, z], 0);
    }
    let (q2, q1, q0) = (q2 / scale, q1 / scale, q0 / scale);
    // Leading coefficient lost in rounding relative to the others: linear.
    if q2.abs() <= T::gamma(4) * q1.abs().max(q0.abs()) * T::from_f64(1e-3) {
        if q1 == z {
            return ([z, z], 0);
        }
        return ([-q0 / q1, z], 1);
    }
    let disc = q1 * q1 - T::from_f64(4.0) * q2 * q0;
    if disc < z {
        // Tangency within rounding: keep the double root.
        if disc > -T::gamma(8) * (q1 * q1 + (T::from_f64(4.0) * q2 * q0).abs()) {
            return ([-q1 / (q2 + q2), z], 1);
        }
        return ([z, z], 0);
    }
    let s = disc.sqrt();
    let qq = -T::from_f64(0.5) * (q1 + s.copysign(q1));
    if qq == z {
        return ([z, z], 1);
    }
    let r0 = qq / q2;
    let r1 = q0 / qq;
    ([r0.min(r1), r0.max(r1)], 2)
}

/// Real roots of `c3 x³ + c2 x² + c1 x + c0` (up to 3), each polished by Newton steps.
pub fn solve_cubic<T: Real>(c3: T, c2: T, c1: T, c0: T) -> ([T; 3], usize) {
    let (r, n, _) = solve_cubic_flagged(c3, c2, c1, c0);
    (r, n)
}

/// As [`solve_cubic`], and whether two roots are within rounding of a double root (the
/// discriminant of the depressed cubic within `γ(256)` of its terms): there the count of
/// real roots, and each root's accuracy (only the square root of the precision), are uncertain.
pub(super) fn solve_cubic_flagged<T: Real>(c3: T, c2: T, c1: T, c0: T) -> ([T; 3], usize, bool) {
    let z = T::ZERO;
    let scale = c3.abs().max(c2.abs()).max(c1.abs()).max(c0.abs());
    if scale == z || !scale.is_finite() {
        return ([z; 3], 0, false);
    }
    let (c3, c2, c1, c0) = (c3 / scale, c2 / scale, c1 / scale, c0 / scale);
    if c3.abs() <= T::gamma(16) {
        let (r, n) = solve_quadratic(c2, c1, c0);
        return ([r[0], r[1], z], n, false);
    }
    let (a, b, c) = (c2 / c3, c1 / c3, c0 / c3);
    let third = T::from_f64(1.0 / 3.0);
    let q = (a * a - T::from_f64(3.0) * b) * T::from_f64(1.0 / 9.0);
    let r = (T::from_f64(2.0) * a * a * a - T::from_f64(9.0) * a * b + T::from_f64(27.0) * c)
        * T::from_f64(1.0 / 54.0);
    let mut roots = [z; 3];
    let n;
    let near_multiple = (r * r - q * q * q).abs() <= T::gamma(256) * (r * r).max((q * q * q).abs());
    if r * r < q * q * q {
        // Three real roots (trigonometric form).
        let sq = q.sqrt();
        let theta = (r / (sq * sq * sq)).max(-T::ONE).min(T::ONE).acos();
        let m = T::from_f64(-2.0) * sq;
        let tau = T::from_f64(2.0 * std::f64::consts::PI);
        for (k, root) in roots.iter_mut().enumerate() {
            let ang = (theta + tau * T::from_f64(k as f64)) * third;
            *root = m * ang.cos() - a * third;
        }
        n = 3;
    } else {
        let big_a = -(r.abs() + (r * r - q * q * q).max(z).sqrt()).cbrt().copysign(r);
        let big_b = if big_a == z { z } else { q / big_a };
        roots[0] = big_a + big_b - a * third;
        n = 1;
    }
    // Newton polish on the normalised cubic.
    for root in roots.iter_mut().take(n) {
        let mut x = *root;
        for _ in 0..2 {
            let f = ((x + a) * x + b) * x + c;
            let df = (T::from_f64(3.0) * x + a + a) * x + b;
            if df == z {
                break;
            }
            let nx = x - f / df;
            if !nx.is_finite() {
                break;
            }
            x = nx;
        }
        *root = x;
    }
    (roots, n, near_multiple)
}

/// An upper bound of `y^(1/3)` for `y >= 0`, without `cbrt`: a bit-level estimate, then one
/// Newton step, which by the AM–GM inequality (`(2e + y/e²)/3 >= y^(1/3)`) never lands below
/// the root, widened by a few roundings.
#[inline(always)]
pub(super) fn cbrt_upper(y: f64) -> f64 {
    // Dividing the exponent by 3: an estimate within a few percent for normal `y`.
    let e = f64::from_bits(y.to_bits() / 3 + 0x2A9F_7893_782D_A1CE);
    (e + e + y / (e * e)) * (1.0 / 3.0) * (1.0 + 1e-12)
}

/// The real roots of the monic cubic `x³ + a x² + b x + c`, without `acos`, `cos` or `cbrt`
/// (Kahan, "To solve a real cubic equation", 1986): Newton's method from a bound past the root
/// on the far side of the inflection point converges to it monotonically, and the quotient
/// quadratic gives the other two. The Newton root comes first. `None` if Newton did not settle
/// within its step cap (then the caller takes [`solve_cubic_flagged`]).
#[inline(always)]
pub(super) fn monic_cubic_roots<T: Real>(a: T, b: T, c: T) -> Option<([T; 3], usize)> {
    let z = T::ZERO;
    let three = T::from_f64(3.0);
    // Compute the start: the inflection point X, moved past the root by Kahan's bound.
    let x_inf = -a / three;
    let eval = |x: T| (((x + a) * x + b) * x + c, (three * x + a + a) * x + b);
    let (q, dq) = eval(x_inf);
    let s = if q < z { -T::ONE } else { T::ONE };
    let mut r = T::from_f64(cbrt_upper(q.abs().to_f64())) * (T::ONE + T::gamma(2));
    if dq < z {
        r = T::from_f64(1.324718) * r.max((-dq).sqrt());
    }
    let mut x = x_inf - s * r;
    // Compute the root: Newton steps move x towards X monotonically until rounding stops them.
    if q != z {
        let mut settled = false;
        for _ in 0..24 {
            let (f, df) = eval(x);
            if df == z {
                settled = true;
                break;
            }
            let nx = x - f / df;
            if !(s * nx > s * x) {
                settled = nx.is_finite();
                break;
            }
            x = nx;
        }
        if !settled || !x.is_finite() {
            return None;
        }
    } else {
        x = x_inf;
    }
    // Compute the quotient quadratic x² + b1 x + c2 (Horner), in Kahan's stabler form when the
    // constant term is better taken from c.
    let mut b1 = x + a;
    let mut c2 = x * b1 + b;
    if x != z && (x * x * x).abs() > (c / x).abs() {
        c2 = -c / x;
        b1 = (c2 - b) / x;
    }
    // Its real roots without cancellation; a complex pair is dropped (a pair within rounding
    // of a double root is flagged by the caller's discriminant test).
    let disc = b1 * b1 - T::from_f64(4.0) * c2;
    if !(disc >= z) {
        return Some(([x, z, z], 1));
    }
    let qq = T::from_f64(-0.5) * (b1 + disc.sqrt().copysign(b1));
    if qq == z {
        return Some(([x, z, z], 2)); // b1 = c2 = 0: a double root at 0
    }
    Some(([x, qq, c2 / qq], 3))
}
