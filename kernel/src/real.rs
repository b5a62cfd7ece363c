//! The floating-point type the kernel is generic over: `f64` (host default) or
//! `f32` (small boards).
//!
//! Every transcendental call goes through [`libm`], a pure-software library, so
//! the same inputs give the same bits on x86_64 and on a Cortex-M4F; `sqrt` is
//! IEEE correctly rounded on every target. With the `micromath` feature the
//! `f32` `exp` and `ln` (flow log law only, never contact geometry) use
//! micromath instead: deterministic, but coarse (worst relative error about
//! 2.4e-3 for exp and 5.8e-4 for ln; docs/board.md).
//!
//! Functions are associated functions (`R::sqrt(x)`), never method calls, so a
//! `std` build of the tests cannot silently pick an inherent float method.

use core::fmt::Debug;
use core::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

mod sealed {
    /// Only `f32` and `f64` implement [`super::Real`]; both are valid as all-zero bits.
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// A floating-point scalar usable by the kernel: `f32` or `f64` (sealed, so
/// an all-zero [`crate::Sim`] is always a valid value).
///
/// ```
/// use mbs_kernel::Real;
///
/// // Generic code calls the associated functions (libm inside).
/// fn hypot<R: Real>(x: R, y: R) -> R {
///     R::sqrt(x * x + y * y)
/// }
/// assert_eq!(hypot(3.0f64, 4.0), 5.0);
/// assert_eq!(hypot(3.0f32, 4.0), 5.0);
/// // The digest hashes −0.0 as +0.0.
/// assert_eq!(f64::canonical_bits(-0.0), f64::canonical_bits(0.0));
/// ```
pub trait Real:
    sealed::Sealed
    + Copy
    + Debug
    + Default
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + Send
    + Sync
    + 'static
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// ½.
    const HALF: Self;
    /// Name of the type ("f32" or "f64"), for reports.
    const NAME: &'static str;
    /// Nearest representable value (IEEE round-to-nearest).
    fn from_f64(x: f64) -> Self;
    /// Exact widening to `f64`.
    fn to_f64(self) -> f64;
    /// IEEE correctly rounded square root.
    fn sqrt(x: Self) -> Self;
    /// e^x.
    fn exp(x: Self) -> Self;
    /// Natural logarithm.
    fn ln(x: Self) -> Self;
    /// |x|.
    fn abs(x: Self) -> Self;
    /// Neither infinite nor NaN.
    fn is_finite(x: Self) -> bool;
    /// Bits for hashing with −0.0 mapped to +0.0 and every NaN to one pattern.
    fn canonical_bits(x: Self) -> u64;
    /// Bytes of the IEEE representation (4 or 8).
    const BYTES: usize;
    /// The raw IEEE bits, zero-extended.
    fn to_raw(self) -> u64;
    /// The value of raw IEEE bits (the low `BYTES` bytes).
    fn from_raw(bits: u64) -> Self;
    /// The value's place in the order of all values of this type: adjacent
    /// values differ by 1 (one unit in the last place, ULP), −0.0 and +0.0
    /// are both 0, negative values are negative. The distance between two
    /// values in ULPs is the difference of their ordinals.
    ///
    /// ```
    /// use mbs_kernel::Real;
    ///
    /// assert_eq!(1.0f64.ordinal() + 1, f64::from_ordinal(1.0f64.ordinal() + 1).ordinal());
    /// assert_eq!(f64::from_ordinal(1.0f64.ordinal() + 1), 1.0 + f64::EPSILON);
    /// assert_eq!((-0.0f32).ordinal(), 0.0f32.ordinal());
    /// assert_eq!(f32::from_ordinal(-1), -f32::from_bits(1));
    /// ```
    fn ordinal(self) -> i64;
    /// The value whose [`Real::ordinal`] is `o` (saturating beyond the
    /// type's range, where only NaNs are).
    fn from_ordinal(o: i64) -> Self;
    /// The larger of two values (the first if they compare equal or unordered).
    #[inline]
    fn max(a: Self, b: Self) -> Self {
        if b > a {
            b
        } else {
            a
        }
    }
    /// The smaller of two values (the first if they compare equal or unordered).
    #[inline]
    fn min(a: Self, b: Self) -> Self {
        if b < a {
            b
        } else {
            a
        }
    }
}

/// e^x in `f32`: micromath's with the `micromath` feature, else libm's.
#[inline]
fn expf(x: f32) -> f32 {
    #[cfg(feature = "micromath")]
    {
        micromath::F32Ext::exp(x)
    }
    #[cfg(not(feature = "micromath"))]
    {
        libm::expf(x)
    }
}

/// ln x in `f32`: micromath's with the `micromath` feature, else libm's.
#[inline]
fn logf(x: f32) -> f32 {
    #[cfg(feature = "micromath")]
    {
        micromath::F32Ext::ln(x)
    }
    #[cfg(not(feature = "micromath"))]
    {
        libm::logf(x)
    }
}

/// [`Real`] for one IEEE type `$R`: its raw-bits type `$Bits`, the one
/// NaN pattern it hashes every NaN as, and the functions behind `sqrt`,
/// `exp`, `ln` and `abs`.
macro_rules! real {
    ($R:ident, $Bits:ident, $Signed:ident, $nan:literal, $sqrt:path, $exp:path, $ln:path, $abs:path) => {
        impl Real for $R {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const HALF: Self = 0.5;
            const NAME: &'static str = stringify!($R);
            const BYTES: usize = core::mem::size_of::<$R>();
            #[inline]
            fn to_raw(self) -> u64 {
                u64::from(self.to_bits())
            }
            #[inline]
            fn from_raw(bits: u64) -> Self {
                // The low BYTES bytes: a no-op for f64.
                $R::from_bits(bits as $Bits)
            }
            fn ordinal(self) -> i64 {
                // Sign-magnitude bits to a two's-complement order.
                let b = self.to_bits() as $Signed;
                i64::from(if b < 0 {
                    $Signed::MIN.wrapping_sub(b)
                } else {
                    b
                })
            }
            fn from_ordinal(o: i64) -> Self {
                let o = o.clamp(i64::from($Signed::MIN), i64::from($Signed::MAX)) as $Signed;
                let b = if o < 0 {
                    $Signed::MIN.wrapping_sub(o)
                } else {
                    o
                };
                $R::from_bits(b as $Bits)
            }
            #[inline]
            fn from_f64(x: f64) -> Self {
                // Round to nearest: a no-op for f64.
                x as $R
            }
            #[inline]
            fn to_f64(self) -> f64 {
                f64::from(self)
            }
            #[inline]
            fn sqrt(x: Self) -> Self {
                $sqrt(x)
            }
            #[inline]
            fn exp(x: Self) -> Self {
                $exp(x)
            }
            #[inline]
            fn ln(x: Self) -> Self {
                $ln(x)
            }
            #[inline]
            fn abs(x: Self) -> Self {
                $abs(x)
            }
            #[inline]
            fn is_finite(x: Self) -> bool {
                x.is_finite()
            }
            #[inline]
            fn canonical_bits(x: Self) -> u64 {
                if x == 0.0 {
                    0
                } else if x.is_nan() {
                    $nan
                } else {
                    x.to_raw()
                }
            }
        }
    };
}

real!(
    f64,
    u64,
    i64,
    0x7ff8_0000_0000_0000,
    libm::sqrt,
    libm::exp,
    libm::log,
    libm::fabs
);
real!(
    f32,
    u32,
    i32,
    0x7fc0_0000,
    libm::sqrtf,
    expf,
    logf,
    libm::fabsf
);

#[cfg(test)]
mod tests {
    use super::Real;

    #[test]
    fn negative_zero_and_nan_hash_alike() {
        assert_eq!(f64::canonical_bits(-0.0), f64::canonical_bits(0.0));
        assert_eq!(f32::canonical_bits(-0.0), f32::canonical_bits(0.0));
        let nan_a = f64::from_bits(0x7ff8_0000_0000_0001);
        let nan_b = f64::from_bits(0xfff8_0000_0000_0000);
        assert_eq!(f64::canonical_bits(nan_a), f64::canonical_bits(nan_b));
        assert_ne!(f64::canonical_bits(1.0), f64::canonical_bits(-1.0));
    }

    #[test]
    fn libm_backend_matches_reference_values() {
        // `<T as Real>::` so that std's inherent methods cannot stand in.
        assert_eq!(<f64 as Real>::sqrt(2.0), core::f64::consts::SQRT_2);
        assert!((<f64 as Real>::ln(30.1) - 3.404_525_171_754_83).abs() < 1e-15);
        assert!((<f64 as Real>::exp(-1.0) - 0.367_879_441_171_442_3).abs() < 1e-16);
        assert_eq!(<f32 as Real>::sqrt(4.0), 2.0);
    }

    /// Measures the micromath backend against libm over the flow's argument range.
    #[cfg(feature = "micromath")]
    #[test]
    fn micromath_backend_accuracy() {
        let mut worst_exp = 0.0f64;
        let mut worst_ln = 0.0f64;
        for k in 1..2000 {
            let x = -(k as f32) * 0.002; // exp(-y/h), exp(-(..)^2): arguments in [-4, 0]
            let e =
                (<f32 as Real>::exp(x) as f64 - libm::exp(x as f64)).abs() / libm::exp(x as f64);
            worst_exp = worst_exp.max(e);
            let z = 1.0 + k as f32 * 0.05; // ln of 30.1(y+d/4)/k_sr: arguments in [1, 100]
            let l = (<f32 as Real>::ln(z) as f64 - libm::log(z as f64)).abs()
                / libm::log(z as f64).max(0.1);
            worst_ln = worst_ln.max(l);
        }
        std::println!("micromath: worst relative error exp {worst_exp:.2e}, ln {worst_ln:.2e}");
        assert!(worst_exp < 0.01 && worst_ln < 0.01);
    }
}
