//! The search's distance tests in vector lanes (x86-64 with AVX2): the
//! sort copies the grains' positions and radii in search order
//! ([`Sorted`]), so that a run of candidates is a run of memory, and a
//! mobile grain tests a run `L` candidates at a time (four f64, eight f32)
//! with the scalar test's operations in its order, so the lists are the
//! same ([`super::search`]'s brute-force tests compare them). Most runs
//! hold fewer than eight candidates: one vector test instead of a loop of
//! scalar tests whose exit is hard to predict. The sort also notes each
//! grain's bin, which it and the search would otherwise find three times
//! (8 bytes per grain: not on the boards, whose largest bed fills the RAM).

use super::bins::{bucket, Bins};
use super::found::{At, Found, FOUND_MAX};
use crate::real::Real;
use core::any::Any;

/// What the sort copies for the search in lanes: each grain's bin, and the
/// grains' positions and radii in the order of the sort's `order`.
#[derive(Debug, Clone)]
pub(crate) struct Sorted<R: Real, const N: usize> {
    /// Each grain's bin (bx, by), by grain (what the sort and the search
    /// would otherwise find three times).
    bin: [[u32; 2]; N],
    pub(super) x: [R; N],
    pub(super) y: [R; N],
    pub(super) r: [R; N],
}

impl<R: Real, const N: usize> Sorted<R, N> {
    /// All zero.
    pub(super) const fn new() -> Self {
        Sorted {
            bin: [[0; 2]; N],
            x: [R::ZERO; N],
            y: [R::ZERO; N],
            r: [R::ZERO; N],
        }
    }

    /// Notes grain i's bin (bx, by).
    #[inline]
    pub(super) fn note_bin(&mut self, i: usize, bx: u32, by: u32) {
        if let Some(bin) = self.bin.get_mut(i) {
            *bin = [bx, by];
        }
    }

    /// Grain i's bin (bx, by) as noted, and its bucket.
    #[inline]
    pub(super) fn bin_of(&self, bins: &Bins<R>, i: usize) -> (u32, u32, usize) {
        let [bx, by] = self.bin.get(i).copied().unwrap_or_default();
        (bx, by, bucket(bx, by, bins.nx, bins.buckets))
    }

    /// Grain i (position, radius) at place k of `order`.
    #[inline]
    pub(super) fn place(&mut self, k: usize, x: R, y: R, r: R) {
        if let (Some(sx), Some(sy), Some(sr)) =
            (self.x.get_mut(k), self.y.get_mut(k), self.r.get_mut(k))
        {
            (*sx, *sy, *sr) = (x, y, r);
        }
    }
}

/// Adds to `found` the grains j of `order` in `runs` within reach of
/// mobile grain `at` ([`At::test`]'s test, in lanes), `seam`: through the
/// periodic image. False (nothing done) if `R` has no lanes.
#[inline]
pub(super) fn test_in_lanes<R: Real, const N: usize>(
    at: &At<R>,
    seam: bool,
    sorted: &Sorted<R, N>,
    order: &[u32],
    runs: &[(u32, u32)],
    found: &mut Found,
) -> bool {
    let (at, sorted): (&dyn Any, &dyn Any) = (at, sorted);
    macro_rules! in_lanes {
        ($t:ty, $module:ident) => {
            if let (Some(at), Some(sorted)) = (
                at.downcast_ref::<At<$t>>(),
                sorted.downcast_ref::<Sorted<$t, N>>(),
            ) {
                #[allow(unsafe_code)]
                // SAFETY: `test` needs AVX2, which the whole build enables
                // (this module is compiled only then).
                unsafe {
                    if seam {
                        $module::test::<N, true>(at, sorted, order, runs, found)
                    } else {
                        $module::test::<N, false>(at, sorted, order, runs, found)
                    }
                }
                return true;
            }
        };
    }
    in_lanes!(f64, in_f64x4);
    in_lanes!(f32, in_f32x8);
    false
}

/// The 32-bit lanes of `ids` that `keep` marks, in lane order, first
/// (the rest: copies of lane 0), by a permutation from [`PACK`].
#[inline]
#[target_feature(enable = "avx2")]
fn pack(ids: core::arch::x86_64::__m256i, keep: u32) -> [u32; 8] {
    use core::arch::x86_64::*;
    let c = PACK[keep as usize & 0xff];
    let control = _mm256_setr_epi32(
        c[0] as i32,
        c[1] as i32,
        c[2] as i32,
        c[3] as i32,
        c[4] as i32,
        c[5] as i32,
        c[6] as i32,
        c[7] as i32,
    );
    let packed = _mm256_castsi256_ps(_mm256_permutevar8x32_epi32(ids, control));
    let mut lanes = [0f32; 8];
    crate::lanes::f32x8::put(&mut lanes, packed);
    lanes.map(f32::to_bits)
}

/// Per mask of eight lanes, the permutation that moves the marked lanes
/// to the front in lane order.
static PACK: [[u32; 8]; 256] = {
    let mut table = [[0u32; 8]; 256];
    let mut mask = 0;
    while mask < 256 {
        let (mut lane, mut at) = (0, 0);
        while lane < 8 {
            if mask >> lane & 1 == 1 {
                table[mask][at] = lane as u32;
                at += 1;
            }
            lane += 1;
        }
        mask += 1;
    }
    table
};

/// Writes the tests in one precision's lanes (`$lanes`, a module of
/// [`crate::lanes`]) as the module `$module`.
macro_rules! tests_in {
    ($module:ident, $lanes:ident) => {
        mod $module {
            use super::pack;
            use super::{At, Found, Sorted, FOUND_MAX};
            use crate::lanes::$lanes::*;
            use core::arch::x86_64::{
                _mm256_castsi256_ps, _mm256_cmpgt_epi32, _mm256_movemask_ps, _mm256_set1_epi32,
                _mm256_setr_epi32,
            };

            /// The tests of [`super::test_in_lanes`].
            #[target_feature(enable = "avx2")]
            pub(super) fn test<const N: usize, const SEAM: bool>(
                at: &At<R>,
                s: &Sorted<R, N>,
                order: &[u32],
                runs: &[(u32, u32)],
                found: &mut Found,
            ) {
                let (x, y, r, skin) = (splat(at.x), splat(at.y), splat(at.r), splat(at.skin));
                let (width, half) = (splat(at.width), splat(at.half_width));
                let below = splat(-at.half_width);
                let i = _mm256_set1_epi32(at.i as i32);
                for &(from, to) in runs {
                    let (mut k, to) = (from as usize, to as usize);
                    while k < to {
                        let (Some(xs), Some(ys), Some(rs), Some(js)) = (
                            s.x.get(k..).and_then(|a| a.first_chunk::<L>()),
                            s.y.get(k..).and_then(|a| a.first_chunk::<L>()),
                            s.r.get(k..).and_then(|a| a.first_chunk::<L>()),
                            order.get(k..).and_then(|a| a.first_chunk::<L>()),
                        ) else {
                            // The last places of `order`: one at a time.
                            for k in k..to {
                                let (Some(&xj), Some(&yj), Some(&rj), Some(&j)) =
                                    (s.x.get(k), s.y.get(k), s.r.get(k), order.get(k))
                                else {
                                    continue;
                                };
                                let near = at.near::<SEAM>(xj, yj, rj);
                                found.push(j, (j as usize > at.i) & near);
                            }
                            break;
                        };
                        // `periodic` and the test as in `At::near`, lane by lane.
                        let dx = sub(load(xs), x);
                        let ddx = if SEAM {
                            let wrapped = select(dx, add(dx, width), lt(dx, below));
                            select(wrapped, sub(dx, width), gt(dx, half))
                        } else {
                            dx
                        };
                        let ddy = sub(load(ys), y);
                        let reach = add(add(r, load(rs)), skin);
                        let near = lt(add(mul(ddx, ddx), mul(ddy, ddy)), mul(reach, reach));
                        // The lanes within the run, near and after grain i,
                        // packed to the front and written from `found.len`.
                        let mut ids = [0u32; 8];
                        if let Some(first) = ids.first_chunk_mut::<L>() {
                            *first = *js;
                        }
                        let ids = _mm256_setr_epi32(
                            ids[0] as i32,
                            ids[1] as i32,
                            ids[2] as i32,
                            ids[3] as i32,
                            ids[4] as i32,
                            ids[5] as i32,
                            ids[6] as i32,
                            ids[7] as i32,
                        );
                        let after =
                            _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(ids, i)));
                        let within = (1u32 << (to - k).min(L)) - 1;
                        let keep = movemask(near) as u32 & after as u32 & within;
                        let packed = pack(ids, keep);
                        let at_place = found.len.min(FOUND_MAX);
                        if let Some(room) = found
                            .js
                            .get_mut(at_place..)
                            .and_then(|a| a.first_chunk_mut::<8>())
                        {
                            *room = packed;
                        }
                        found.len = at_place + keep.count_ones() as usize;
                        k += L;
                    }
                }
            }
        }
    };
}

tests_in!(in_f64x4, f64x4);
tests_in!(in_f32x8, f32x8);
