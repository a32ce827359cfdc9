//! The hull test: a cheap rejection of rays that miss the patch's bounds or prism.

use crate::phong::patch::Patch;
use crate::phong::real::{Real, V3};

/// `a * b + c`: fused where `FMA` (the caller is compiled with the `fma` target feature, see
/// [`super::dispatch`]), two roundings elsewhere. Only for sums whose rounding a slack absorbs:
/// the fused result is never less accurate, so a bound for the unfused one holds for both.
#[inline(always)]
fn mad<T: Real, const FMA: bool>(a: T, b: T, c: T) -> T {
    if FMA {
        a.fused_mul_add(b, c)
    } else {
        a * b + c
    }
}

/// `n · x` by [`mad`].
#[inline(always)]
fn dot<T: Real, const FMA: bool>(n: V3<T>, x: V3<T>) -> T {
    mad::<T, FMA>(n.z, x.z, mad::<T, FMA>(n.y, x.y, n.x * x.x))
}

/// Clip the ray's `(tmin, tmax)` against the patch's local bounds (slab test) and its prism of
/// half-spaces: whether any of it stays.
///
/// Branch-free: every plane is clipped, each giving an entry and an exit distance (eight of
/// each: three slabs and five prism planes, as lanes the compiler vectorises), and the interval
/// compared once at the end, so the divisions overlap instead of each waiting on a
/// data-dependent exit (half the patch tests that Embree hands over are rejected here,
/// unpredictably). A zero direction component gives an infinite distance of the right sign
/// (`±x / ±0`), which is no constraint when the origin is inside that slab or half-space and an
/// empty interval when it is outside; `0 / 0` is NaN, which counts as no constraint (the
/// conservative answer). So are a NaN or infinite ray: this test may pass them, never turns
/// away a ray that hits. A NaN `tmin` or `tmax` is turned away (no hit lies in a NaN interval),
/// and so is an interval at infinity (entered at +inf or left at -inf).
///
/// The prism offsets carry the ray-independent part of the rounding slack (built in with the
/// patch, [`Patch::prism`]); only `γ(8) |o|∞` is added here.
#[inline(always)]
pub(super) fn hits_hull<T: Real, const FMA: bool>(
    p: &Patch<T>,
    o: V3<T>,
    d: V3<T>,
    tmin: T,
    tmax: T,
) -> bool {
    let (near, far) = clip_planes::<T, FMA>(p, o, d);
    // Compute the interval: a NaN distance is no constraint (`max(-big)` and `min(big)` map it
    // there: `Real::max` compares `x > -big`), then the nearest exit and farthest entry. `big`,
    // the largest finite value, also turns away an interval at infinity (an entry at +inf, an
    // exit at -inf), which holds no hit, whatever the planes the ray runs along (n·d = ±0,
    // whose sign says entry or exit) say.
    let big = max_finite::<T>();
    let near = near.map(|x| x.max(-big));
    let far = far.map(|x| x.min(big));
    // `x.max(tmin)` is tmin when tmin is NaN, likewise `min`: a NaN interval stays NaN.
    let t0 = max8(near).max(tmin);
    let t1 = min8(far).min(tmax);
    t0 <= t1
}

/// The largest finite value of `T`.
#[inline(always)]
fn max_finite<T: Real>() -> T {
    T::from_f64(if std::mem::size_of::<T>() == 4 { f32::MAX as f64 } else { f64::MAX })
}

/// The entry and exit distances of the ray `o + t d` for the patch's 3 slabs (lanes 0-2) and
/// its 5 prism planes (lanes 3-7), NaN where a plane gives `0 / 0`.
#[inline(always)]
fn clip_planes<T: Real, const FMA: bool>(p: &Patch<T>, o: V3<T>, d: V3<T>) -> ([T; 8], [T; 8]) {
    let (mut near, mut far) = ([T::ZERO; 8], [T::ZERO; 8]);
    // Widen the slab exits by the rounding of the divisions (pbrt-v4 Bounds3::IntersectP uses 1 + 2γ(3)).
    let widen = T::ONE + T::gamma(3) + T::gamma(3);
    let (oa, da) = ([o.x, o.y, o.z], [d.x, d.y, d.z]);
    let (lo, hi) = ([p.lo.x, p.lo.y, p.lo.z], [p.hi.x, p.hi.y, p.hi.z]);
    for i in 0..3 {
        let inv = T::ONE / da[i];
        let (a, b) = ((lo[i] - oa[i]) * inv, (hi[i] - oa[i]) * inv);
        // `if a > b { (b, a) } else { (a, b) }`, NaN included (no constraint then), as one
        // min and one max.
        near[i] = b.min(a);
        far[i] = a.max(b) * widen;
    }
    // The prism: leave through a plane the ray heads out of (n·d > 0, or +0), enter through the
    // others. `s = ±inf` with the sign bit of n·d picks the side without a branch: `max(-s, t)`
    // is t for an exit and +inf (no constraint) for an entry, `min(-s, t)` the other way round;
    // a NaN t (0/0: the ray in the plane) stays NaN through `min` (no constraint).
    // The rounding of the two dot products (local frame, |o| and |d| terms) is absorbed by
    // widening each plane outwards, entering earlier and leaving later.
    let inf = T::from_f64(f64::INFINITY);
    let slack = T::gamma(8) * o.max_abs();
    for k in 0..5 {
        let n = p.prism_n[k];
        let dn = dot::<T, FMA>(n, d);
        let t = ((p.prism_h[k] - dot::<T, FMA>(n, o)) + slack) / dn; // dist >= 0 inside
        let away = -inf.copysign_bits(dn);
        far[3 + k] = away.max(t);
        near[3 + k] = away.min(t);
    }
    (near, far)
}

/// The largest of 8 values, none NaN, as a tree (lane-wise halves, which vectorise).
#[inline(always)]
fn max8<T: Real>(x: [T; 8]) -> T {
    let h: [T; 4] = std::array::from_fn(|i| x[i].max(x[i + 4]));
    let q: [T; 2] = std::array::from_fn(|i| h[i].max(h[i + 2]));
    q[0].max(q[1])
}

/// The smallest of 8 values, none NaN, as [`max8`].
#[inline(always)]
fn min8<T: Real>(x: [T; 8]) -> T {
    let h: [T; 4] = std::array::from_fn(|i| x[i].min(x[i + 4]));
    let q: [T; 2] = std::array::from_fn(|i| h[i].min(h[i + 2]));
    q[0].min(q[1])
}

/// [`hits_hull`] with fused dot products for an f32 patch and the world-space ray `org + t dir`
/// (the local frame computed here, as [`super::to_local`] does), in 4-wide SSE registers with
/// the AVX and FMA encodings: the slabs in lanes 0-2 of one register, prism planes 1-4 in the 4
/// lanes of another, plane 0 from plane 1 (its negation, bit for bit: `Patch::new` builds them
/// as `n` and `-n`, so `n0 · x` is `-(n1 · x)` exactly, fused or not) in the slabs' lane 3.
/// Every distance is bit for bit the one `hits_hull::<f32, true>` computes (the same operations
/// in the same order, lane by lane; `minps`/`maxps` pick as [`Real::min`]/[`Real::max`] do, NaN
/// included), so it decides as that does. (Where `n1 · d` is a zero from cancellation, `+0`,
/// plane 0's is `+0` too, not `-0`: plane 0 is then an exit there and an entry here, at ±inf
/// or NaN, which `hits_hull` decides alike: no constraint, or an interval at infinity.)
///
/// `None` for another precision (which takes [`hits_hull`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) fn hits_hull_v3<T: Real>(p: &Patch<T>, org: V3<T>, dir: V3<T>, tmin: T, tmax: T) -> Option<bool> {
    use std::any::Any;
    let p = (p as &dyn Any).downcast_ref::<Patch<f32>>()?;
    let f32s = |x: &dyn Any| x.downcast_ref::<f32>().copied();
    let v3s = |x: &dyn Any| x.downcast_ref::<V3<f32>>().copied();
    Some(hull_f32_v3(p, v3s(&org)?, v3s(&dir)?, f32s(&tmin)?, f32s(&tmax)?))
}

/// The body of [`hits_hull_v3`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
fn hull_f32_v3(p: &Patch<f32>, org: V3<f32>, dir: V3<f32>, tmin: f32, tmax: f32) -> bool {
    use std::arch::x86_64::*;
    let (sign, inf, big) = (_mm_set1_ps(-0.0), _mm_set1_ps(f32::INFINITY), _mm_set1_ps(f32::MAX));
    // Compute the local ray, as `to_local`. Lane 3 is not used (of the ray, the centre and the
    // slabs), and holds what lets the compiler load 4 floats at once (the next field).
    let (c, s) = (_mm_setr_ps(p.center.x, p.center.y, p.center.z, p.scale), _mm_set1_ps(p.inv_scale));
    let o = _mm_mul_ps(_mm_sub_ps(_mm_setr_ps(org.x, org.y, org.z, 0.0), c), s);
    let d = _mm_mul_ps(_mm_setr_ps(dir.x, dir.y, dir.z, 0.0), s);
    // The slabs, lanes 0-2 (lane 3 is overwritten below).
    let widen = _mm_set1_ps(1.0 + <f32 as Real>::gamma(3) + <f32 as Real>::gamma(3));
    let inv = _mm_div_ps(_mm_set1_ps(1.0), d);
    let a = _mm_mul_ps(_mm_sub_ps(_mm_setr_ps(p.lo.x, p.lo.y, p.lo.z, p.hi.x), o), inv);
    let b = _mm_mul_ps(_mm_sub_ps(_mm_setr_ps(p.hi.x, p.hi.y, p.hi.z, p.prism_n[0].x), o), inv);
    let (near_s, far_s) = (_mm_min_ps(b, a), _mm_mul_ps(_mm_max_ps(a, b), widen));
    // Prism planes 1-4: the normals' x, y and z as lanes (lanes 0 and 3 of rows of 4 floats).
    let n = &p.prism_n;
    let rows = |a: V3<f32>, b: V3<f32>| {
        (_mm_setr_ps(a.x, a.y, a.z, b.x), _mm_setr_ps(a.y, a.z, b.x, b.y), _mm_setr_ps(a.z, b.x, b.y, b.z))
    };
    let ((p0, p1, p2), (q0, q1, q2)) = (rows(n[1], n[2]), rows(n[3], n[4]));
    const PICK: i32 = 0b11_00_11_00;
    let (nx, ny, nz) =
        (_mm_shuffle_ps::<PICK>(p0, q0), _mm_shuffle_ps::<PICK>(p1, q1), _mm_shuffle_ps::<PICK>(p2, q2));
    // `n · x` as `dot::<f32, true>`: fma(nz, z, fma(ny, y, nx x)).
    let dot4 = |x: __m128| {
        let xx = _mm_mul_ps(nx, _mm_permute_ps::<0x00>(x));
        _mm_fmadd_ps(nz, _mm_permute_ps::<0xaa>(x), _mm_fmadd_ps(ny, _mm_permute_ps::<0x55>(x), xx))
    };
    // `γ(8) |o|∞`, |o|∞ as `V3::max_abs` (`maxss` picks as `Real::max`).
    let abs = _mm_andnot_ps(sign, o);
    let m = _mm_max_ss(_mm_max_ss(abs, _mm_permute_ps::<0x55>(abs)), _mm_permute_ps::<0xaa>(abs));
    let slack = _mm_mul_ps(_mm_set1_ps(<f32 as Real>::gamma(8)), _mm_permute_ps::<0x00>(m));
    let (dn, no) = (dot4(d), dot4(o));
    let h = _mm_setr_ps(p.prism_h[1], p.prism_h[2], p.prism_h[3], p.prism_h[4]);
    let t = _mm_div_ps(_mm_add_ps(_mm_sub_ps(h, no), slack), dn);
    // `away = -inf.copysign(dn)`: infinity with the sign bit of dn flipped.
    let away = _mm_or_ps(_mm_andnot_ps(dn, sign), inf);
    let (near_p, far_p) = (_mm_min_ps(away, t), _mm_max_ps(away, t));
    // Plane 0 from plane 1 (lane 0): `(h0 - n0·o) + slack) / n0·d` with `n0·x = -(n1·x)`.
    let t0 = _mm_div_ps(_mm_add_ps(_mm_add_ps(_mm_set1_ps(p.prism_h[0]), no), slack), _mm_xor_ps(dn, sign));
    let away0 = _mm_xor_ps(away, sign);
    // Into lane 3 of the slabs' registers.
    const LANE_0_TO_3: i32 = 0x30; // source lane 0 (bits 7-6), destination lane 3 (bits 5-4)
    let near_s = _mm_insert_ps::<LANE_0_TO_3>(near_s, _mm_min_ps(away0, t0));
    let far_s = _mm_insert_ps::<LANE_0_TO_3>(far_s, _mm_max_ps(away0, t0));
    // Compute the interval as `hits_hull`: a NaN distance no constraint (`maxps(x, y)` is y
    // when x is NaN), an interval at infinity none.
    let near = _mm_max_ps(near_p, _mm_max_ps(near_s, _mm_xor_ps(big, sign)));
    let far = _mm_min_ps(far_p, _mm_min_ps(far_s, big));
    let near = _mm_max_ps(near, _mm_movehl_ps(near, near));
    let far = _mm_min_ps(far, _mm_movehl_ps(far, far));
    let near = _mm_cvtss_f32(_mm_max_ss(near, _mm_movehdup_ps(near)));
    let far = _mm_cvtss_f32(_mm_min_ss(far, _mm_movehdup_ps(far)));
    // `x.max(tmin)` is tmin when tmin is NaN, likewise `min`: a NaN interval stays NaN.
    Real::max(near, tmin) <= Real::min(far, tmax)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phong::accuracy::{generate, Category, SplitMix};

    /// The hull test as it was before its planes were combined as lanes: each plane clipped
    /// into `(t0, t1)` in turn.
    fn hits_hull_sequential<T: Real, const FMA: bool>(
        p: &Patch<T>,
        o: V3<T>,
        d: V3<T>,
        tmin: T,
        tmax: T,
    ) -> bool {
        let (mut t0, mut t1) = (tmin, tmax);
        let widen = T::ONE + T::gamma(3) + T::gamma(3);
        for (oo, dd, lo, hi) in
            [(o.x, d.x, p.lo.x, p.hi.x), (o.y, d.y, p.lo.y, p.hi.y), (o.z, d.z, p.lo.z, p.hi.z)]
        {
            let inv = T::ONE / dd;
            let (a, b) = ((lo - oo) * inv, (hi - oo) * inv);
            let (near, far) = (b.min(a), a.max(b));
            t0 = near.max(t0);
            t1 = (far * widen).min(t1);
        }
        let inf = T::from_f64(f64::INFINITY);
        let slack = T::gamma(8) * o.max_abs();
        for k in 0..5 {
            let n = p.prism_n[k];
            let dn = dot::<T, FMA>(n, d);
            let t = ((p.prism_h[k] - dot::<T, FMA>(n, o)) + slack) / dn;
            let away = -inf.copysign_bits(dn);
            t1 = away.max(t).min(t1);
            t0 = away.min(t).max(t0);
        }
        // Since the lanes: an interval at infinity is turned away too.
        t0 <= t1 && t0 < inf && t1 > -inf
    }

    /// The world-space ray `(org, dir)` with direction components zeroed, the origin moved onto a
    /// slab's plane or made NaN, or the interval made NaN now and then (the cases where a plane
    /// gives `0 / 0` or `±x / 0`).
    fn odd_ray(
        rng: &mut SplitMix,
        p: &Patch<f32>,
        org: V3<f32>,
        dir: V3<f32>,
    ) -> (V3<f32>, V3<f32>, f32, f32) {
        let (mut org, mut dir) = (org, dir);
        match rng.next_u64() % 10 {
            0 => dir.x = 0.0,
            1 => (dir.y, dir.z) = (0.0, -0.0),
            // An origin on the lower x slab plane (where the local frame maps it there exactly),
            // moving along it: 0 / 0 there.
            2 => (org.x, dir.x) = (p.lo.x * p.scale + p.center.x, 0.0),
            3 => dir = V3::new(0.0, 0.0, 0.0),
            4 => org.y = f32::NAN,
            _ => {}
        }
        let (tmin, tmax) = match rng.next_u64() % 16 {
            0 => (f32::NAN, f32::INFINITY),
            1 => (0.0, f32::NAN),
            2 => (0.5, 1.5),
            _ => (0.0, f32::INFINITY),
        };
        (org, dir, tmin, tmax)
    }

    /// The lane-wise hull test decides as the sequential one, with and without fused dot
    /// products, on rays of every accuracy category and on rays with zero direction components,
    /// origins on a slab plane and NaN intervals.
    #[test]
    fn lane_hull_decides_as_sequential_hull() {
        let mut rng = SplitMix(2718);
        let (mut passed, mut rejected, mut vector_tests, mut on_plane) = (0usize, 0usize, 0usize, 0usize);
        for i in 0..60_000 {
            let c = generate(&mut rng, Category::ALL[i % Category::ALL.len()]);
            let p: Patch<f32> = Patch::new(c.p, c.n, c.alpha);
            let (org, dir) = (V3::from(c.org).cast::<f32>(), V3::from(c.dir).cast::<f32>());
            // The case's ray, and one aimed off to the side (most of those miss).
            let side = V3::from(rng.unit()).cast::<f32>() * (rng.f() as f32 * 4.0);
            for (org, dir) in [(org, dir), (org, dir + side)] {
                let (org, dir, tmin, tmax) = odd_ray(&mut rng, &p, org, dir);
                let (o, d) = ((org - p.center) * p.inv_scale, dir * p.inv_scale);
                let lanes = hits_hull::<f32, false>(&p, o, d, tmin, tmax);
                assert_eq!(
                    lanes,
                    hits_hull_sequential::<f32, false>(&p, o, d, tmin, tmax),
                    "case {i}: {c:?}"
                );
                let fused = hits_hull::<f32, true>(&p, o, d, tmin, tmax);
                assert_eq!(fused, hits_hull_sequential::<f32, true>(&p, o, d, tmin, tmax), "case {i}: {c:?}");
                if let Some(v3) = hull_v3_where_available(&p, org, dir, tmin, tmax) {
                    assert_eq!(v3, fused, "case {i}, explicit vectors: {c:?} {org:?} {dir:?} {tmin} {tmax}");
                    vector_tests += 1;
                }
                passed += lanes as usize;
                rejected += !lanes as usize;
                on_plane += (o.x == p.lo.x && d.x == 0.0) as usize;
            }
        }
        assert!(passed > 10_000 && rejected > 10_000, "{passed} passed, {rejected} rejected");
        assert!(on_plane > 100, "only {on_plane} origins on a slab plane");
        #[cfg(target_arch = "x86_64")]
        if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            assert_eq!(vector_tests, 120_000, "the explicit vector hull test did not run");
        }
    }

    /// [`hits_hull_v3`] where this CPU has AVX2 and FMA, `None` elsewhere.
    #[multiversion::multiversion(targets("x86_64+avx2+fma"))]
    fn hull_v3_where_available(
        p: &Patch<f32>,
        org: V3<f32>,
        dir: V3<f32>,
        tmin: f32,
        tmax: f32,
    ) -> Option<bool> {
        multiversion::target::match_target! {
            "x86_64+avx2+fma" => hits_hull_v3(p, org, dir, tmin, tmax),
            _ => {
                let _ = (p, org, dir, tmin, tmax);
                None
            }
        }
    }
}
