//! The vector lanes (x86-64 with AVX2) of the batched step and of the
//! neighbour search: one module per precision,
//! [`f64x4`] (four `f64` per AVX2 vector) and [`f32x8`] (eight `f32`),
//! each the **lane type** `V` with its scalar `R`, its lane count `L`, the
//! row type `Row` that holds one grain's four sums, and the same
//! operations under the same names (`add`, `mul`, `select`, `gt`,
//! `to_rows`, `load`, `gather`, …). The passes (`drag`, `pairs`, `grains`)
//! are written once against these names and compiled once per precision
//! (`step::batch`'s `lanes!`; the search's tests, `neighbours::lanes`); implements no equation itself: each operation
//! is the one IEEE operation of its scalar counterpart, so the lanes give
//! the scalar step's bits.
//!
//! Most operations are the AVX2 intrinsics themselves, renamed; the rest
//! are `#[inline]` functions of a few intrinsics, and the helpers that
//! move values between arrays and lanes are written once for both
//! precisions (`helpers!`). Every function is `#[target_feature(enable =
//! "avx2")]`, callable without `unsafe` from the passes, which are too.
//!
//! The module's two `unsafe` blocks are [`read`] and [`write`]: a vector
//! (or a row) from and to an array of exactly its size. Sound because the
//! sizes are equal (checked at compile time), any bits are a valid value of
//! either side (the vector types of the private [`Vector`]; `f32` and
//! `f64`, the sealed [`Real`]), and the unaligned read and write need no
//! alignment: what `_mm256_loadu_pd` and its kin do.

use crate::real::Real;
use core::arch::x86_64::{__m128, __m256, __m256d};

/// A vector or row type of the lanes: plain bits, any of which are a valid
/// value (`__m256d`, `__m256`, `__m128`; private, so no other).
trait Vector: Copy {}
impl Vector for __m128 {}
impl Vector for __m256 {}
impl Vector for __m256d {}

/// The vector (or row) holding `values`, an array of exactly its size.
#[inline(always)]
#[allow(unsafe_code)]
fn read<R: Real, const M: usize, T: Vector>(values: &[R; M]) -> T {
    const { assert!(size_of::<[R; M]>() == size_of::<T>()) };
    // SAFETY: `values` is `size_of::<T>()` readable bytes (the sizes are
    // equal, checked above), any bits are a valid `T` (`Vector`), and an
    // unaligned read needs no alignment.
    unsafe { core::ptr::read_unaligned(core::ptr::from_ref(values).cast::<T>()) }
}

/// Writes the vector (or row) `v` to `values`, an array of exactly its size.
#[inline(always)]
#[allow(unsafe_code)]
fn write<R: Real, const M: usize, T: Vector>(values: &mut [R; M], v: T) {
    const { assert!(size_of::<[R; M]>() == size_of::<T>()) };
    // SAFETY: `values` is `size_of::<T>()` writable bytes (the sizes are
    // equal, checked above), any bits are valid values of `R` (`f32` or
    // `f64`), and an unaligned write needs no alignment.
    unsafe { core::ptr::write_unaligned(core::ptr::from_mut(values).cast::<T>(), v) }
}

/// The helpers every pass shares, written into each precision's module:
/// vectors and rows from and to arrays ([`read`], [`write`]), groups of
/// `L` grains, lanes gathered from grains or picked from a window, and
/// scalar functions of selected lanes.
macro_rules! helpers {
    () => {
        /// A vector from L values.
        #[inline]
        #[target_feature(enable = "avx2")]
        pub(crate) fn load(values: &[R; L]) -> V {
            crate::lanes::read(values)
        }

        /// Group `group` of L grains of an array (zeros past its whole groups).
        #[inline]
        pub(crate) fn group(a: &[R], group: usize) -> &[R; L] {
            let (groups, _) = a.as_chunks::<L>();
            groups.get(group).unwrap_or(&[0.0; L])
        }

        /// A vector from `a[at..at + L]`, zero if out of bounds.
        #[inline]
        #[target_feature(enable = "avx2")]
        pub(crate) fn load_at(a: &[R], at: usize) -> V {
            match a.get(at..).and_then(|s| s.first_chunk::<L>()) {
                Some(values) => load(values),
                None => zero(),
            }
        }

        /// Stores a vector to L values.
        #[inline]
        #[target_feature(enable = "avx2")]
        pub(crate) fn put(values: &mut [R; L], v: V) {
            crate::lanes::write(values, v)
        }

        /// A grain's sums as a row.
        #[inline]
        #[target_feature(enable = "avx2")]
        pub(crate) fn load_row(values: &[R; 4]) -> Row {
            crate::lanes::read(values)
        }

        /// Adds a row to a grain's sums.
        #[inline]
        #[target_feature(enable = "avx2")]
        pub(crate) fn add_row(values: &mut [R; 4], row: Row) {
            put_row(values, row_add(load_row(values), row));
        }

        /// Stores a row.
        #[inline]
        #[target_feature(enable = "avx2")]
        pub(crate) fn put_row(values: &mut [R; 4], row: Row) {
            crate::lanes::write(values, row)
        }

        /// The lanes of a vector.
        #[inline]
        #[target_feature(enable = "avx2")]
        pub(crate) fn lanes(v: V) -> [R; L] {
            let mut a = [0.0; L];
            put(&mut a, v);
            a
        }

        /// The values of `a` at indices `i` (in bounds: else zero).
        #[inline]
        #[target_feature(enable = "avx2")]
        pub(crate) fn gather(a: &[R], i: &[usize; L]) -> V {
            let v: [R; L] = core::array::from_fn(|l| a.get(i[l]).copied().unwrap_or(0.0));
            set(v)
        }

        /// The values of `a` at grains `window + lane` (`lanes`: a permutation
        /// control of 32-bit lanes; zero if the window is out of bounds).
        #[inline]
        #[target_feature(enable = "avx2")]
        pub(crate) fn window(a: &[R], window: usize, lanes: core::arch::x86_64::__m256i) -> V {
            permute(load_at(a, window), lanes)
        }

        /// `f` of the lanes of `v` selected by `mask`, zero elsewhere (one
        /// call per lane: the lanes hold the values the scalar step has).
        #[inline]
        #[target_feature(enable = "avx2")]
        pub(crate) fn map_where(v: V, mask: V, f: fn(R) -> R) -> V {
            if movemask(mask) == 0 {
                return zero();
            }
            let (values, selected) = (lanes(v), lanes(mask));
            // Built in registers: a vector load of scalar stores would stall.
            set(core::array::from_fn(|l| {
                if selected[l].to_bits() != 0 {
                    f(values[l])
                } else {
                    0.0
                }
            }))
        }
    };
}

/// The `f64` lanes: four per `__m256d`; a grain's four sums are a row,
/// also a `__m256d`.
pub(crate) mod f64x4 {
    use core::arch::x86_64::*;
    // The lane-wise operations under the names both precisions share:
    // arithmetic (add, sub, mul, div, sqrt, max, min), bits (and, andnot,
    // xor), select(no, yes, mask) (yes where the mask lane is set),
    // movemask (the lanes' sign bits), zero, splat (one value in every
    // lane), to_mask (integer lanes as a mask), to_int (a mask as integer
    // lanes, all ones −1), int_sub (integer lanes' difference), row_add.
    pub(crate) use core::arch::x86_64::{
        _mm256_add_pd as add, _mm256_add_pd as row_add, _mm256_and_pd as and,
        _mm256_andnot_pd as andnot, _mm256_blendv_pd as select, _mm256_castpd_si256 as to_int,
        _mm256_castsi256_pd as to_mask, _mm256_div_pd as div, _mm256_max_pd as max,
        _mm256_min_pd as min, _mm256_movemask_pd as movemask, _mm256_mul_pd as mul,
        _mm256_set1_pd as splat, _mm256_setzero_pd as zero, _mm256_sqrt_pd as sqrt,
        _mm256_sub_epi64 as int_sub, _mm256_sub_pd as sub, _mm256_xor_pd as xor,
    };

    /// The precision.
    pub(crate) type R = f64;
    /// Its lane type: L lanes.
    pub(crate) type V = __m256d;
    /// A row: one grain's sums (f_x, f_y, torque, unused).
    pub(crate) type Row = __m256d;
    /// Lanes per vector.
    pub(crate) const L: usize = 4;
    /// Every bit set: a mask lane's "true".
    pub(crate) const TRUE: R = f64::from_bits(u64::MAX);
    /// Every bit but the sign: the mask of |x|.
    pub(crate) const ABS: R = f64::from_bits(u64::MAX >> 1);

    /// A vector from L values, built in registers.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn set(v: [R; L]) -> V {
        _mm256_setr_pd(v[0], v[1], v[2], v[3])
    }

    /// The 32-bit lanes of `v` that `lanes` picks (a permutation control).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn permute(v: V, lanes: __m256i) -> V {
        _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(v), lanes))
    }

    /// a > b lane by lane (false where either is a NaN, as every
    /// comparison here).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn gt(a: V, b: V) -> V {
        _mm256_cmp_pd::<_CMP_GT_OQ>(a, b)
    }

    /// a < b.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn lt(a: V, b: V) -> V {
        _mm256_cmp_pd::<_CMP_LT_OQ>(a, b)
    }

    /// a ≥ b.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn ge(a: V, b: V) -> V {
        _mm256_cmp_pd::<_CMP_GE_OQ>(a, b)
    }

    /// a ≤ b.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn le(a: V, b: V) -> V {
        _mm256_cmp_pd::<_CMP_LE_OQ>(a, b)
    }

    /// a = b.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn eq(a: V, b: V) -> V {
        _mm256_cmp_pd::<_CMP_EQ_OQ>(a, b)
    }

    /// The lanes rounded towards zero.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn trunc(v: V) -> V {
        _mm256_round_pd::<{ _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC }>(v)
    }

    /// The lanes truncated to `i32` indices.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn to_index(v: V) -> [i32; L] {
        let i = _mm256_cvttpd_epi32(v);
        [
            _mm_extract_epi32::<0>(i),
            _mm_extract_epi32::<1>(i),
            _mm_extract_epi32::<2>(i),
            _mm_extract_epi32::<3>(i),
        ]
    }

    /// A pair's row (f_x, f_y, t_i, t_j) as its second grain's: (−f_x,
    /// −f_y, t_j, t_j).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn second_row(row: Row) -> Row {
        _mm256_xor_pd(
            _mm256_permute4x64_pd::<0b11_11_01_00>(row),
            _mm256_setr_pd(-0.0, -0.0, 0.0, 0.0),
        )
    }

    /// Four vectors as L rows: row l holds value l of each vector.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn to_rows(columns: [V; 4]) -> [Row; L] {
        transpose(columns)
    }

    /// L rows as four vectors ([`to_rows`] undone).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn from_rows(rows: [Row; L]) -> [V; 4] {
        transpose(rows)
    }

    /// Four vectors of four lanes transposed: value l of vector c becomes
    /// value c of vector l.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn transpose([a, b, c, d]: [__m256d; 4]) -> [__m256d; 4] {
        let (ab_even, ab_odd) = (_mm256_unpacklo_pd(a, b), _mm256_unpackhi_pd(a, b));
        let (cd_even, cd_odd) = (_mm256_unpacklo_pd(c, d), _mm256_unpackhi_pd(c, d));
        [
            _mm256_permute2f128_pd::<0x20>(ab_even, cd_even),
            _mm256_permute2f128_pd::<0x20>(ab_odd, cd_odd),
            _mm256_permute2f128_pd::<0x31>(ab_even, cd_even),
            _mm256_permute2f128_pd::<0x31>(ab_odd, cd_odd),
        ]
    }

    helpers!();
}

/// The `f32` lanes: eight per `__m256`; a grain's four sums are a row, an
/// `__m128`.
pub(crate) mod f32x8 {
    use core::arch::x86_64::*;
    // The lane-wise operations under the names both precisions share (see
    // `f64x4`); `permute` is the intrinsic itself here.
    pub(crate) use core::arch::x86_64::{
        _mm256_add_ps as add, _mm256_and_ps as and, _mm256_andnot_ps as andnot,
        _mm256_blendv_ps as select, _mm256_castps_si256 as to_int, _mm256_castsi256_ps as to_mask,
        _mm256_div_ps as div, _mm256_max_ps as max, _mm256_min_ps as min,
        _mm256_movemask_ps as movemask, _mm256_mul_ps as mul, _mm256_permutevar8x32_ps as permute,
        _mm256_set1_ps as splat, _mm256_setzero_ps as zero, _mm256_sqrt_ps as sqrt,
        _mm256_sub_epi32 as int_sub, _mm256_sub_ps as sub, _mm256_xor_ps as xor,
        _mm_add_ps as row_add,
    };

    /// The precision.
    pub(crate) type R = f32;
    /// Its lane type: L lanes.
    pub(crate) type V = __m256;
    /// A row: one grain's sums (f_x, f_y, torque, unused).
    pub(crate) type Row = __m128;
    /// Lanes per vector.
    pub(crate) const L: usize = 8;
    /// Every bit set: a mask lane's "true".
    pub(crate) const TRUE: R = f32::from_bits(u32::MAX);
    /// Every bit but the sign: the mask of |x|.
    pub(crate) const ABS: R = f32::from_bits(u32::MAX >> 1);

    /// A vector from L values, built in registers.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn set(v: [R; L]) -> V {
        _mm256_setr_ps(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7])
    }

    /// a > b lane by lane (false where either is a NaN, as every
    /// comparison here).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn gt(a: V, b: V) -> V {
        _mm256_cmp_ps::<_CMP_GT_OQ>(a, b)
    }

    /// a < b.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn lt(a: V, b: V) -> V {
        _mm256_cmp_ps::<_CMP_LT_OQ>(a, b)
    }

    /// a ≥ b.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn ge(a: V, b: V) -> V {
        _mm256_cmp_ps::<_CMP_GE_OQ>(a, b)
    }

    /// a ≤ b.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn le(a: V, b: V) -> V {
        _mm256_cmp_ps::<_CMP_LE_OQ>(a, b)
    }

    /// a = b.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn eq(a: V, b: V) -> V {
        _mm256_cmp_ps::<_CMP_EQ_OQ>(a, b)
    }

    /// The lanes rounded towards zero.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn trunc(v: V) -> V {
        _mm256_round_ps::<{ _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC }>(v)
    }

    /// The lanes truncated to `i32` indices.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn to_index(v: V) -> [i32; L] {
        let i = _mm256_cvttps_epi32(v);
        [
            _mm256_extract_epi32::<0>(i),
            _mm256_extract_epi32::<1>(i),
            _mm256_extract_epi32::<2>(i),
            _mm256_extract_epi32::<3>(i),
            _mm256_extract_epi32::<4>(i),
            _mm256_extract_epi32::<5>(i),
            _mm256_extract_epi32::<6>(i),
            _mm256_extract_epi32::<7>(i),
        ]
    }

    /// A pair's row (f_x, f_y, t_i, t_j) as its second grain's: (−f_x,
    /// −f_y, t_j, t_j).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn second_row(row: Row) -> Row {
        _mm_xor_ps(
            _mm_permute_ps::<0b11_11_01_00>(row),
            _mm_setr_ps(-0.0, -0.0, 0.0, 0.0),
        )
    }

    /// Four vectors as L rows: row l holds value l of each vector.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn to_rows(columns: [V; 4]) -> [Row; L] {
        let t = transpose_halves(columns);
        let low = t.map(|v| _mm256_castps256_ps128(v));
        let high = t.map(|v| _mm256_extractf128_ps::<1>(v));
        [
            low[0], low[1], low[2], low[3], high[0], high[1], high[2], high[3],
        ]
    }

    /// L rows as four vectors ([`to_rows`] undone).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn from_rows(rows: [Row; L]) -> [V; 4] {
        let pairs: [V; 4] = core::array::from_fn(|l| _mm256_set_m128(rows[l + 4], rows[l]));
        transpose_halves(pairs)
    }

    /// Four vectors of eight lanes transposed within each half: value l
    /// of vector c becomes value c of vector l mod 4, half l / 4.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn transpose_halves([a, b, c, d]: [__m256; 4]) -> [__m256; 4] {
        let (ab_low, ab_high) = (_mm256_unpacklo_ps(a, b), _mm256_unpackhi_ps(a, b));
        let (cd_low, cd_high) = (_mm256_unpacklo_ps(c, d), _mm256_unpackhi_ps(c, d));
        [
            _mm256_shuffle_ps::<0x44>(ab_low, cd_low),
            _mm256_shuffle_ps::<0xee>(ab_low, cd_low),
            _mm256_shuffle_ps::<0x44>(ab_high, cd_high),
            _mm256_shuffle_ps::<0xee>(ab_high, cd_high),
        ]
    }

    helpers!();
}
