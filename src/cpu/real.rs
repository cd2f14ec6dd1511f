//! Scalar abstraction so one renderer runs in f64 (the ground truth) and in f32 (the GPU's
//! arithmetic). glam has no type generic over precision, so this is a minimal `V3<T>` with
//! just the operations the renderer needs.

use std::fmt::Debug;
use std::ops::{Add, Div, Index, Mul, Neg, Sub};

/// A floating-point scalar the renderer can run in.
pub trait Real:
    Copy
    + Debug
    + PartialOrd
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Unit roundoff u (half the machine epsilon).
    const UNIT_ROUNDOFF: Self;
    /// A finite stand-in for infinity: GLSL 1.20 has no literal infinity, so every backend
    /// uses this large value for "no boundary on this axis" and "no hit yet".
    const BIG: Self;
    /// Name for stats ("f32"/"f64").
    const NAME: &'static str;
    /// Conversion from f32 (exact for both types).
    fn from_f32(v: f32) -> Self;
    /// Conversion from f64 (rounds for f32).
    fn from_f64(v: f64) -> Self;
    /// Conversion to f64 (exact).
    fn to_f64(self) -> f64;
    /// Absolute value.
    fn abs(self) -> Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// Floor.
    fn floor(self) -> Self;
    /// x^y.
    fn powf(self, y: Self) -> Self;
    /// Base-2 logarithm.
    fn log2(self) -> Self;
    /// Finite test.
    fn is_finite(self) -> bool;
    /// The larger value (NaN-free inputs assumed).
    fn max(self, o: Self) -> Self {
        if self > o {
            self
        } else {
            o
        }
    }
    /// The smaller value.
    fn min(self, o: Self) -> Self {
        if self < o {
            self
        } else {
            o
        }
    }
    /// pbrt's gamma(n) = n u / (1 - n u): bound on the relative error of n operations.
    fn gamma(n: u32) -> Self {
        let nu = Self::from_f32(n as f32) * Self::UNIT_ROUNDOFF;
        nu / (Self::ONE - nu)
    }
}

macro_rules! impl_real {
    ($t:ty, $name:literal, $big:expr) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const UNIT_ROUNDOFF: Self = <$t>::EPSILON * 0.5;
            const BIG: Self = $big;
            const NAME: &'static str = $name;
            #[inline(always)]
            fn from_f32(v: f32) -> Self {
                v as $t
            }
            #[inline(always)]
            fn from_f64(v: f64) -> Self {
                v as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn floor(self) -> Self {
                crate::numeric::Floor::floor_exact(self)
            }
            #[inline(always)]
            fn powf(self, y: Self) -> Self {
                <$t>::powf(self, y)
            }
            #[inline(always)]
            fn log2(self) -> Self {
                <$t>::log2(self)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
        }
    };
}
impl_real!(f32, "f32", 1.0e30);
impl_real!(f64, "f64", 1.0e30);

/// A 3-vector of [`Real`]s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3<T> {
    /// x.
    pub x: T,
    /// y.
    pub y: T,
    /// z.
    pub z: T,
}

impl<T: Real> V3<T> {
    /// Constructor.
    #[inline(always)]
    pub fn new(x: T, y: T, z: T) -> Self {
        V3 { x, y, z }
    }
    /// All components equal.
    #[inline(always)]
    pub fn splat(v: T) -> Self {
        V3 { x: v, y: v, z: v }
    }
    /// From a glam f32 vector (exact).
    #[inline(always)]
    pub fn from_vec3(v: glam::Vec3) -> Self {
        V3::new(T::from_f32(v.x), T::from_f32(v.y), T::from_f32(v.z))
    }
    /// From a glam f64 vector (rounds for f32).
    #[inline(always)]
    pub fn from_dvec3(v: glam::DVec3) -> Self {
        V3::new(T::from_f64(v.x), T::from_f64(v.y), T::from_f64(v.z))
    }
    /// To glam f64.
    pub fn to_dvec3(self) -> glam::DVec3 {
        glam::DVec3::new(self.x.to_f64(), self.y.to_f64(), self.z.to_f64())
    }
    /// Dot product.
    #[inline(always)]
    pub fn dot(self, o: Self) -> T {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    /// Cross product.
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        V3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }
    /// Euclidean length.
    #[inline(always)]
    pub fn length(self) -> T {
        self.dot(self).sqrt()
    }
    /// Unit vector (NaN for the zero vector; callers check).
    #[inline(always)]
    pub fn normalize(self) -> Self {
        self * (T::ONE / self.length())
    }
    /// Component-wise absolute value.
    #[inline(always)]
    pub fn abs(self) -> Self {
        V3::new(self.x.abs(), self.y.abs(), self.z.abs())
    }
    /// Component-wise product.
    #[inline(always)]
    pub fn mul_elem(self, o: Self) -> Self {
        V3::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
    /// Largest component.
    #[inline(always)]
    pub fn max_elem(self) -> T {
        self.x.max(self.y).max(self.z)
    }
    /// True when all components are finite.
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
    /// Component by axis index 0..3.
    #[inline(always)]
    pub fn get(self, i: usize) -> T {
        match i {
            0 => self.x,
            1 => self.y,
            _ => self.z,
        }
    }
}

impl<T: Real> Index<usize> for V3<T> {
    type Output = T;
    #[inline(always)]
    fn index(&self, i: usize) -> &T {
        match i {
            0 => &self.x,
            1 => &self.y,
            _ => &self.z,
        }
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
impl<T: Real> Neg for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        V3::new(-self.x, -self.y, -self.z)
    }
}
impl<T: Real> Mul<T> for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: T) -> Self {
        V3::new(self.x * s, self.y * s, self.z * s)
    }
}
