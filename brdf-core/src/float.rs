//! The float abstraction the model is generic over: `f64` on the host, `f32` on the MCU.

use core::fmt::{Debug, Display};
use num_traits::{Float, FloatConst};

/// A floating-point type the model can be evaluated in (`f32` or `f64`).
///
/// All math goes through [`num_traits::Float`] backed by `libm`, so the same code runs
/// on `no_std` targets and on the host.
pub trait Real: Float + FloatConst + Debug + Display + Default + Send + Sync + 'static {
    /// Largest `x` for which `exp(-x)` is still non-zero (subnormals included).
    /// Beyond it a Gaussian lobe `exp(-x)` is exactly zero, so it need not be computed.
    const EXP_UNDERFLOW: Self;
    /// Converts an `f64` constant (rounding to nearest for `f32`).
    fn lit(x: f64) -> Self;
    /// Widens to `f64` (exact for both implementations).
    fn widen(self) -> f64;
    /// The complementary error function erfc(x) = 1 - erf(x) (libm's, accurate where
    /// it is tiny), for Beckmann's Smith Lambda.
    fn erfc(self) -> Self;
}

impl Real for f64 {
    const EXP_UNDERFLOW: f64 = 745.13;
    #[inline(always)]
    fn lit(x: f64) -> f64 {
        x
    }
    #[inline(always)]
    fn widen(self) -> f64 {
        self
    }
    #[inline(always)]
    fn erfc(self) -> f64 {
        libm::erfc(self)
    }
}

impl Real for f32 {
    const EXP_UNDERFLOW: f32 = 103.97;
    #[inline(always)]
    fn lit(x: f64) -> f32 {
        x as f32
    }
    #[inline(always)]
    fn widen(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn erfc(self) -> f32 {
        libm::erfcf(self)
    }
}

/// Degrees to radians in `T`.
#[inline(always)]
pub fn deg_to_rad<T: Real>(deg: T) -> T {
    deg * (T::PI() / T::lit(180.0))
}

/// Cosine of an angle given in degrees, computed as `sin(90° - |deg|)` so that it is
/// exactly 0 at ±90° and keeps full relative precision near grazing.
#[inline(always)]
pub fn cos_deg<T: Real>(deg: T) -> T {
    deg_to_rad(T::lit(90.0) - deg.abs()).sin()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_underflow_threshold_is_where_exp_reaches_zero() {
        // Through num-traits, i.e. the same libm the model uses.
        assert!(Float::exp(-f64::EXP_UNDERFLOW) > 0.0);
        assert_eq!(Float::exp(-(f64::EXP_UNDERFLOW + 1.0)), 0.0);
        assert!(Float::exp(-f32::EXP_UNDERFLOW) > 0.0);
        assert_eq!(Float::exp(-(f32::EXP_UNDERFLOW + 1.0)), 0.0);
    }

    #[test]
    fn cos_deg_is_exact_at_grazing() {
        assert_eq!(cos_deg(90.0f64), 0.0);
        assert_eq!(cos_deg(-90.0f32), 0.0);
        assert_eq!(cos_deg(0.0f64), 1.0);
        let x = 90.0f64 - 1e-9;
        let near = cos_deg(x);
        // 90 - x is exact (Sterbenz), so this is cos(x) to full precision.
        let exact = (90.0 - x).to_radians();
        assert!((near - exact).abs() / exact < 1e-9);
    }
}
