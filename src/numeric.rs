//! Small numeric helpers shared by every layer (at the bottom with `output` and `error`).

/// IEEE floor without a libm call: on baseline x86-64 (no SSE4.1 `roundss`) `f32::floor`
/// and `f64::floor` call libm, which took 6% of a CPU render (the irregular walk's lateral
/// cells, the build's binning). Bit-exact: below 2^(mantissa bits) in magnitude truncation
/// through i64 is exact and one step down fixes a negative fraction; at or above it, and for
/// infinities and NaN, every value is its own floor; -0.0 stays -0.0.
pub trait Floor: Sized {
    /// `self.floor()`, bit for bit.
    fn floor_exact(self) -> Self;
}

macro_rules! impl_floor {
    ($t:ty) => {
        impl Floor for $t {
            #[inline(always)]
            fn floor_exact(self) -> Self {
                const INTEGRAL: $t = (1u64 << (<$t>::MANTISSA_DIGITS - 1)) as $t;
                // NaN and infinities fail `is_finite`; large values are integers already.
                if !self.is_finite() || self.abs() >= INTEGRAL {
                    return self;
                }
                let t = self as i64 as $t;
                let r = if t > self { t - 1.0 } else { t };
                if r == 0.0 {
                    self * 0.0
                } else {
                    r
                }
            }
        }
    };
}

impl_floor!(f32);
impl_floor!(f64);

/// `x.floor() as i64` (saturating; NaN gives 0) without calling `floor`, which x86-64's
/// baseline has no instruction for: the build takes six of these per triangle and level.
/// The truncation is exact, and one below it is the floor of a negative non-integer.
#[inline(always)]
pub fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x {
        t.saturating_sub(1)
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::{floor_i64, Floor};

    /// Equal to `floor` on edge values and on random bit patterns and fractions, bit for bit;
    /// `floor_i64` equal to `floor` then the saturating cast.
    #[test]
    fn floor_exact_matches_floor() {
        let mut xs: Vec<f64> = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            -2.5,
            1e-300,
            -1e-300,
            4503599627370495.5,
            -4503599627370495.5,
            4503599627370496.0,
            -9.0e15,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            // 2^63, the i64 range's end, and beyond: where `floor_i64` saturates.
            9.223_372_036_854_776e18,
            -9.223_372_036_854_776e18,
            -9.3e18,
        ];
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        for _ in 0..100_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            xs.push(f64::from_bits(state));
            xs.push((state % 2_000_001) as f64 / 1000.0 - 1000.0);
        }
        for &x in &xs {
            assert_eq!(floor_i64(x), x.floor() as i64, "{x:e}");
            let (a, b) = (x.floor_exact(), x.floor());
            assert!(
                a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                "{x:e}"
            );
            let y = x as f32;
            let (a, b) = (y.floor_exact(), y.floor());
            assert!(
                a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                "{y:e}"
            );
        }
        // Halfway below the f32 integral limit, where a fraction still exists.
        assert_eq!((-8388607.5f32).floor_exact(), -8388608.0);
    }
}
