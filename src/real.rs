//! The floating-point type every field and kernel is generic over.
//!
//! [`Real`] is implemented for `f32` and `f64`. It gathers the `num-traits` bounds the kernels use
//! and the bound `rustfft::FftNum` needed by the spectral Poisson/Helmholtz solvers, plus two
//! conversions used for literal constants and for reporting.

use num_traits::{Float, FloatConst, FromPrimitive, NumAssign, ToPrimitive};
use std::fmt::{Debug, Display, LowerExp};
use std::iter::Sum;

/// Floating-point scalar of the library: `f32` or `f64`.
pub trait Real:
    Float
    + FloatConst
    + FromPrimitive
    + ToPrimitive
    + NumAssign
    + rustfft::FftNum
    + Default
    + Send
    + Sync
    + Debug
    + Display
    + LowerExp
    + Sum
    + 'static
{
    /// Converts an `f64` literal (rounded to nearest for `f32`).
    fn lit(x: f64) -> Self;
    /// Converts to `f64` (exact for both implementations).
    fn f64(self) -> f64;
    /// Machine epsilon of the type.
    fn eps() -> Self {
        Self::epsilon()
    }
}

impl Real for f64 {
    #[inline(always)]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn f64(self) -> f64 {
        self
    }
}

impl Real for f32 {
    #[inline(always)]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn f64(self) -> f64 {
        self as f64
    }
}
