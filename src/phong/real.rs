//! A minimal float abstraction so every solver runs in f32 (the render path) and f64.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// f32 or f64.
pub trait Real:
    Copy
    + PartialOrd
    + std::fmt::Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Send
    + Sync
    + 'static
{
    /// Zero.
    const ZERO: Self;
    /// One.
    const ONE: Self;
    /// Unit roundoff (half the machine epsilon).
    const UNIT_ROUNDOFF: Self;
    /// `x` rounded to this precision.
    fn from_f64(x: f64) -> Self;
    /// The value in f64 (exact).
    fn to_f64(self) -> f64;
    /// The square root.
    fn sqrt(self) -> Self;
    /// The absolute value.
    fn abs(self) -> Self;
    /// The cube root.
    fn cbrt(self) -> Self;
    /// The arccosine, in radians.
    fn acos(self) -> Self;
    /// The cosine of an angle in radians.
    fn cos(self) -> Self;
    /// Neither infinite nor NaN.
    fn is_finite(self) -> bool;
    /// Whether the sign bit is clear (true for +0.0, false for -0.0).
    fn is_sign_positive(self) -> bool;
    /// `self * a + b` (two roundings: not a fused multiply-add).
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// `self`'s magnitude with the sign bit of `sign` (so `-0.0` counts as negative).
    fn copysign_bits(self, sign: Self) -> Self;
    /// `self * a + b` with one rounding (a fused multiply-add): one instruction only where the
    /// calling function is compiled with the `fma` target feature, a library call elsewhere.
    fn fused_mul_add(self, a: Self, b: Self) -> Self;
    /// The larger of the two; `o` when either is NaN.
    fn max(self, o: Self) -> Self {
        if self > o {
            self
        } else {
            o
        }
    }
    /// The smaller of the two; `o` when either is NaN.
    fn min(self, o: Self) -> Self {
        if self < o {
            self
        } else {
            o
        }
    }
    /// `self` with the sign of `sign` (by comparison with zero: -0.0 counts as positive).
    fn copysign(self, sign: Self) -> Self {
        if (sign < Self::ZERO) == (self < Self::ZERO) {
            self
        } else {
            -self
        }
    }
    /// `gamma(n) = n u / (1 - n u)`: the relative error bound of `n` rounded operations
    /// (Higham; pbrt-v4 §6.8).
    fn gamma(n: u32) -> Self {
        let nu = Self::from_f64(n as f64) * Self::UNIT_ROUNDOFF;
        nu / (Self::ONE - nu)
    }
}

macro_rules! impl_real {
    ($t:ty) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const UNIT_ROUNDOFF: Self = <$t>::EPSILON * 0.5;
            #[inline(always)]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn cbrt(self) -> Self {
                <$t>::cbrt(self)
            }
            #[inline(always)]
            fn acos(self) -> Self {
                <$t>::acos(self)
            }
            #[inline(always)]
            fn cos(self) -> Self {
                <$t>::cos(self)
            }
            #[inline(always)]
            fn is_sign_positive(self) -> bool {
                <$t>::is_sign_positive(self)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline(always)]
            fn mul_add(self, a: Self, b: Self) -> Self {
                // Plain multiply-add: `fma` is a libm call without target-feature fma.
                self * a + b
            }
            #[inline(always)]
            fn copysign_bits(self, sign: Self) -> Self {
                <$t>::copysign(self, sign)
            }
            #[inline(always)]
            fn fused_mul_add(self, a: Self, b: Self) -> Self {
                <$t>::mul_add(self, a, b)
            }
        }
    };
}
impl_real!(f32);
impl_real!(f64);

/// A 3-vector over [`Real`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3<T> {
    /// The x component.
    pub x: T,
    /// The y component.
    pub y: T,
    /// The z component.
    pub z: T,
}

impl<T: Real> V3<T> {
    /// The vector `(x, y, z)`.
    #[inline(always)]
    pub fn new(x: T, y: T, z: T) -> Self {
        V3 { x, y, z }
    }
    /// The zero vector.
    pub fn zero() -> Self {
        V3::new(T::ZERO, T::ZERO, T::ZERO)
    }
    /// The dot product.
    #[inline(always)]
    pub fn dot(self, o: Self) -> T {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    /// The cross product.
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        V3::new(self.y * o.z - self.z * o.y, self.z * o.x - self.x * o.z, self.x * o.y - self.y * o.x)
    }
    /// The Euclidean length.
    pub fn length(self) -> T {
        self.dot(self).sqrt()
    }
    /// The componentwise absolute value.
    pub fn abs(self) -> Self {
        V3::new(self.x.abs(), self.y.abs(), self.z.abs())
    }
    /// The largest absolute component.
    pub fn max_abs(self) -> T {
        self.x.abs().max(self.y.abs()).max(self.z.abs())
    }
    /// The componentwise minimum.
    pub fn min_elem(self, o: Self) -> Self {
        V3::new(self.x.min(o.x), self.y.min(o.y), self.z.min(o.z))
    }
    /// The componentwise maximum.
    pub fn max_elem(self, o: Self) -> Self {
        V3::new(self.x.max(o.x), self.y.max(o.y), self.z.max(o.z))
    }
    /// Whether every component is finite.
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
    /// `self / |self|`, or `None` for a zero or non-finite vector.
    pub fn normalized(self) -> Option<Self> {
        let l = self.length();
        (l > T::ZERO && l.is_finite()).then(|| self * (T::ONE / l))
    }
    /// The vector in f64 (exact).
    pub fn to_f64(self) -> V3<f64> {
        V3::new(self.x.to_f64(), self.y.to_f64(), self.z.to_f64())
    }
    /// The vector rounded to precision `U`.
    pub fn cast<U: Real>(self) -> V3<U> {
        V3::new(U::from_f64(self.x.to_f64()), U::from_f64(self.y.to_f64()), U::from_f64(self.z.to_f64()))
    }
}

impl<T: Real> Add for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        V3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}
impl<T: Real> Sub for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        V3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}
impl<T: Real> Mul<T> for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: T) -> Self {
        V3::new(self.x * s, self.y * s, self.z * s)
    }
}
impl<T: Real> Neg for V3<T> {
    type Output = Self;
    fn neg(self) -> Self {
        V3::new(-self.x, -self.y, -self.z)
    }
}

impl From<glam::Vec3> for V3<f32> {
    fn from(v: glam::Vec3) -> Self {
        V3::new(v.x, v.y, v.z)
    }
}
impl From<V3<f32>> for glam::Vec3 {
    fn from(v: V3<f32>) -> Self {
        glam::Vec3::new(v.x, v.y, v.z)
    }
}
impl From<glam::DVec3> for V3<f64> {
    fn from(v: glam::DVec3) -> Self {
        V3::new(v.x, v.y, v.z)
    }
}
impl From<V3<f64>> for glam::DVec3 {
    fn from(v: V3<f64>) -> Self {
        glam::DVec3::new(v.x, v.y, v.z)
    }
}
