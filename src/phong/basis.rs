//! An orthonormal basis around a unit vector, shared by the intersector (the ray's two planes)
//! and the renderer (tangent frames for hemisphere sampling and the ground plane).

use super::real::{Real, V3};

/// Two unit vectors `(t, b)` that complete the unit vector `n` to a right-handed orthonormal
/// basis (`t × b = n`), without branches or square roots (Duff et al. 2017, "Building an
/// Orthonormal Basis, Revisited").
///
/// The basis is continuous in `n` except across the plane `n.z = 0`, where it flips with the sign
/// of `n.z`. That sign is taken by comparison ([`Real::copysign`]), so `n.z = -0.0` gives the
/// same basis as `n.z = +0.0`. `n` must be unit length (the result is not orthonormal otherwise).
#[inline(always)]
pub fn orthonormal_basis<T: Real>(n: V3<T>) -> (V3<T>, V3<T>) {
    let sign = T::ONE.copysign(n.z);
    let a = -T::ONE / (sign + n.z);
    let b = n.x * n.y * a;
    (V3::new(T::ONE + sign * n.x * n.x * a, sign * b, -sign * n.x), V3::new(b, sign + n.y * n.y * a, -n.y))
}
