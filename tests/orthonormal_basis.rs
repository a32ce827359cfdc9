//! `phong::orthonormal_basis`, the one basis the intersector and the renderer share: orthonormal
//! and right-handed for any unit vector, the poles included, and the same at z = -0.0 as at +0.0.
use glam::{DVec3, Vec3};
use phongrt::phong::{orthonormal_basis, V3};
use proptest::prelude::*;

/// The largest deviation of `(t, b, n)` from a right-handed orthonormal basis.
fn basis_error(n: DVec3) -> f64 {
    let (t, b) = orthonormal_basis(V3::from(n));
    let (t, b) = (DVec3::from(t), DVec3::from(b));
    [t.dot(n), b.dot(n), t.dot(b), t.length() - 1.0, b.length() - 1.0, (t.cross(b) - n).length()]
        .into_iter()
        .fold(0.0, |m, e| m.max(e.abs()))
}

#[test]
fn orthonormal_basis_is_right_handed_at_the_poles_and_the_axes() {
    for n in [DVec3::X, DVec3::Y, DVec3::Z, -DVec3::X, -DVec3::Y, -DVec3::Z] {
        assert!(basis_error(n) < 1e-15, "{n}: error {}", basis_error(n));
    }
}

#[test]
fn orthonormal_basis_at_negative_zero_z_is_the_one_at_positive_zero() {
    for (x, y) in [(1.0f32, 0.0f32), (0.0, 1.0), (0.6, 0.8), (-0.8, 0.6)] {
        let plus = orthonormal_basis(V3::from(Vec3::new(x, y, 0.0)));
        let minus = orthonormal_basis(V3::from(Vec3::new(x, y, -0.0)));
        // Compare values, not bits: a component may be +0.0 in one and -0.0 in the other.
        let same = |a: V3<f32>, b: V3<f32>| a.x == b.x && a.y == b.y && a.z == b.z;
        assert!(same(plus.0, minus.0) && same(plus.1, minus.1), "({x}, {y}, -0): {minus:?} vs {plus:?}");
    }
}

proptest! {
    #[test]
    fn orthonormal_basis_is_right_handed_for_any_unit_vector(
        x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0,
    ) {
        let n = DVec3::new(x, y, z);
        prop_assume!(n.length() > 1e-3);
        let n = n.normalize();
        prop_assert!(basis_error(n) < 1e-12, "{}: error {}", n, basis_error(n));
    }

    #[test]
    fn orthonormal_basis_in_f32_is_orthonormal_to_f32_precision(
        x in -1.0f32..1.0, y in -1.0f32..1.0, z in -1.0f32..1.0,
    ) {
        let n = Vec3::new(x, y, z);
        prop_assume!(n.length() > 1e-3);
        let n = n.normalize();
        let (t, b) = orthonormal_basis(V3::from(n));
        let (t, b) = (Vec3::from(t), Vec3::from(b));
        for e in [t.dot(n), b.dot(n), t.dot(b), t.length() - 1.0, b.length() - 1.0, (t.cross(b) - n).length()] {
            prop_assert!(e.abs() < 1e-5, "{}: t {} b {} error {}", n, t, b, e);
        }
    }
}
