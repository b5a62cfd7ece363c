//! The batched step: the drag (SPEC (4)–(5), flow on) on every grain, every
//! listed pair's contact force (SPEC §2 geometry, law (6)–(9)), then every
//! grain's force sum and motion (SPEC (1)–(3)), all in vector lanes, with
//! the bits of the fused pass ([`crate::Sim::step`] on every other target).
//!
//! Pairs are independent until their forces are summed, and the sums fix
//! the bits. The pair pass finds a vector of pairs' forces, then adds each
//! pair's to its two grains' sums lane by lane, in pair order: one row
//! (f_x, f_y, torque) per grain, one vector add per side. Pairs are listed
//! by first grain, so grain i receives the pairs (m, i), m ascending, whose
//! second grain it is, then its own pairs (i, j) in slot order: exactly the
//! fused pass's order (the second grain's force negated: s + (−f) is s − f,
//! bit for bit; each torque adds its own −r f_s, the product the fused pass
//! forms). The grain pass then moves each grain. Every lane does the
//! operations of [`crate::pairs::State::contact`],
//! [`crate::contact::ContactLaw::apply`] and the integrator in their
//! order; branches become selects. A pair that exerts no force adds +0 or
//! −0: neither changes a sum's bits (a sum starts at +0, or at a drag
//! force added to +0, so it is never −0, and s + 0 = s for every other s).
//!
//! Pairs are listed by first grain and padded so that each batch's first
//! grains lie in one window of lanes' worth of grains: their values are a
//! vector load and a permutation. In f32 the padding also keeps a batch's
//! second grains within 16 grains of that window's start (two loads, two
//! permutations and a blend) unless a pair crosses the periodic boundary;
//! other second grains are gathered. Each pair's radii are copied in pair
//! order when the pairs are indexed, and only chunks of pairs near the
//! periodic seam take the periodic image of their separation.
//!
//! While the storage is ready it holds the spring history, in pair order
//! (vector loads and stores); the slots get it back before the fused pass
//! or a rebuild reads them ([`Batch::history_to_slots`]).
//!
//! Lanes exist on x86-64 with AVX2 (`target-cpu=x86-64-v3` or newer, the
//! host default), for f64 (four per vector) and f32 (eight), with
//! capacities that are powers of two (every host capacity), so that masked
//! indices need no bounds checks. Elsewhere the fused pass runs. One macro
//! (`lanes!`) writes the step once for both precisions.

use crate::contact::{ContactLaw, Spring};
use crate::error::Error;
use crate::flow::Profile;
use crate::grains::{Grains, Pad, PAD};
use crate::real::Real;
use crate::sim::Mover;
use core::arch::x86_64::{
    __m128, __m256, __m256d, _mm256_castps256_ps128, _mm256_extractf128_ps, _mm256_permute2f128_pd,
    _mm256_set_m128, _mm256_shuffle_ps, _mm256_unpackhi_pd, _mm256_unpackhi_ps, _mm256_unpacklo_pd,
    _mm256_unpacklo_ps,
};

/// Listed pairs the storage holds per grain on average (a settled bed has
/// about 2.3; more: the fused pass runs).
const PAIRS: usize = 4;

/// Batches of pairs whose geometry is found before their laws (the pair
/// pass's chunks).
const CHUNK: usize = 8;

/// `pair_k` of a padding pair (w, w), which has no slot.
const SELF_PAIR: u8 = u8::MAX;

/// [`Batch::second_lanes`] of a batch whose second grains are gathered.
const FAR: u8 = u8::MAX;

/// Grains in the window of a batch's second grains, from its window start
/// (0: none, all gathered): 16 for 8 lanes (f32). Grains are numbered
/// column by column, so a grain's contacts lie a few grains ahead, and
/// 8 pairs' second grains nearly always lie within 16 grains of their
/// first grains' window; two vector loads and permutations then replace
/// eight loads and seven inserts. For 4 lanes (f64) a window would need
/// as many permutations as the gather needs inserts.
const fn second_window(lanes: usize) -> usize {
    if lanes >= 8 {
        2 * lanes
    } else {
        0
    }
}

/// The batched step's storage, rebuilt with the neighbour slots; a
/// [`Pad`] after each array, as in [`crate::grains::Grains`] (arrays of a
/// power-of-two size would otherwise share cache sets).
#[derive(Debug, Clone)]
#[repr(C)]
pub(crate) struct Batch<R: Real, const N: usize, const K: usize> {
    /// Listed pairs, padded with pairs (w, w) ([`SELF_PAIR`]) so that each
    /// batch's first grains lie in one window and the last batch is whole,
    /// first and second grain, and slot k.
    pair_i: [[u32; PAIRS]; N],
    _pad1: Pad,
    pair_j: [[u32; PAIRS]; N],
    _pad2: Pad,
    pair_k: [[u8; PAIRS]; N],
    _pad3: Pad,
    /// Per pair, its grains' radii (r_i, r_j): copied when the pairs are
    /// indexed (a radius changes only with the grains, which marks the
    /// slots stale), so a batch loads them instead of gathering them.
    r_i: [[R; PAIRS]; N],
    _pad13: Pad,
    r_j: [[R; PAIRS]; N],
    _pad14: Pad,
    /// Pairs up to the last listed one (padding pairs between included),
    /// and pairs in whole batches (a multiple of the lanes).
    listed: usize,
    pairs: usize,
    /// Per pair, its spring history (e_n, e_s) while the storage is ready:
    /// the slots' copy is stale until [`Batch::history_to_slots`].
    e_n: [[R; PAIRS]; N],
    _pad4: Pad,
    e_s: [[R; PAIRS]; N],
    _pad5: Pad,
    /// Per grain, its first pair: pairs (i, slot k) are listed at
    /// `start[i] + k`.
    start: [u32; N],
    /// Per batch of pairs, the 32-bit lanes (one byte each) that pick each
    /// pair's first grain from the batch's window (a permutation control):
    /// the window is the lanes' worth of grains from the batch's first
    /// grain ([`window_start`]; pairs are listed by first grain, and padded
    /// so that each batch's lie in one window), and their values are one
    /// load and one permutation instead of a gather.
    window_lanes: [[u8; 8]; N],
    _pad11: Pad,
    /// Per batch of pairs, the 32-bit lanes that pick each pair's second
    /// grain from the [`second_window`] grains from the batch's window
    /// start (values 0 to 15: the low three bits pick a lane of a vector,
    /// the fourth which of two), or [`FAR`] first if they do not lie there
    /// (then they are gathered).
    second_lanes: [[u8; 8]; N],
    _pad12: Pad,
    /// Per chunk of [`CHUNK`] batches, whether a pair of it may need the
    /// periodic image of its separation ([`Batch::find_seams`]); the
    /// others' separations are within half the width and skip it.
    seam: [bool; N],
    /// Per grain, its sums during a step: force (x, y), torque, and a
    /// fourth value that is never read. Zero between steps.
    sums: [[R; 4]; N],
    _pad6: Pad,
    /// Per grain, all-ones bits if it moves (is not fixed), else zero: the
    /// lane mask of the grain pass.
    mobile: [R; N],
    _pad10: Pad,
    /// The storage matches the current slots (false when they do not fit:
    /// then the fused pass runs). Every change of the slots marks them
    /// stale, so a step rebuilds and re-indexes before it reads this.
    pub(crate) ready: bool,
}

impl<R: Real, const N: usize, const K: usize> Batch<R, N, K> {
    /// Empty (all-zero bits).
    pub(crate) const fn new() -> Self {
        Batch {
            pair_i: [[0; PAIRS]; N],
            _pad1: PAD,
            pair_j: [[0; PAIRS]; N],
            _pad2: PAD,
            pair_k: [[0; PAIRS]; N],
            _pad3: PAD,
            r_i: [[R::ZERO; PAIRS]; N],
            _pad13: PAD,
            r_j: [[R::ZERO; PAIRS]; N],
            _pad14: PAD,
            listed: 0,
            pairs: 0,
            e_n: [[R::ZERO; PAIRS]; N],
            _pad4: PAD,
            e_s: [[R::ZERO; PAIRS]; N],
            _pad5: PAD,
            start: [0; N],
            window_lanes: [[0; 8]; N],
            _pad11: PAD,
            second_lanes: [[0; 8]; N],
            _pad12: PAD,
            seam: [false; N],
            sums: [[R::ZERO; 4]; N],
            _pad6: PAD,
            mobile: [R::ZERO; N],
            _pad10: PAD,
            ready: false,
        }
    }

    /// Indexes the listed pairs of the grains `g` (`count`, `other`,
    /// `spring`: the neighbour slots): pair list with its radii, history
    /// and windows, lane masks, and the chunks near the periodic seam of a
    /// bed `width` wide (`margin`: see [`Batch::find_seams`]). Not ready
    /// (the fused pass runs) if the precision has no lanes or the
    /// capacities do not suit them ([`lanes_fit`]), or the pairs with
    /// padding (`PAIRS` per grain) do not fit.
    pub(crate) fn index(
        &mut self,
        g: &Grains<R, N>,
        count: &[u8; N],
        other: &[[u32; K]; N],
        spring: &[[Spring<R>; K]; N],
        width: R,
        margin: R,
    ) {
        let n = g.len.min(N);
        self.ready = false;
        let lanes = R::LANES;
        if !lanes_fit(N, K, lanes) {
            return;
        }
        for (mask, &fixed) in self.mobile.iter_mut().zip(&g.fixed).take(n) {
            *mask = R::from_raw(if fixed { 0 } else { u64::MAX });
        }
        self.mobile[n..].fill(R::ZERO);
        let mut list = PairList::<R, N> {
            i: self.pair_i.as_flattened_mut(),
            j: self.pair_j.as_flattened_mut(),
            k: self.pair_k.as_flattened_mut(),
            r_i: self.r_i.as_flattened_mut(),
            r_j: self.r_j.as_flattened_mut(),
            radius: &g.r,
            e_n: self.e_n.as_flattened_mut(),
            e_s: self.e_s.as_flattened_mut(),
            len: 0,
            lanes,
        };
        for (m, ((&c, js), springs)) in count.iter().zip(other).zip(spring).take(n).enumerate() {
            let own = usize::from(c).min(K);
            // A grain's pairs are consecutive: a new batch starts before them.
            if own > 0 && list.leaves_windows(m, &js[..own]) && !list.pad() {
                return;
            }
            self.start[m] = list.len as u32;
            for (k, (&j, h)) in js.iter().zip(springs).take(own).enumerate() {
                if j as usize >= n || j as usize <= m || !list.push(m as u32, j, k as u8, *h) {
                    return;
                }
            }
        }
        // A whole last batch.
        let listed = list.len;
        if !list.pad() {
            return;
        }
        let pairs = list.len;
        if !self.find_windows(pairs, lanes) {
            return;
        }
        self.find_seams(pairs, lanes, &g.x, width, margin);
        (self.listed, self.pairs) = (listed, pairs);
        self.ready = true;
    }

    /// Finds each batch's window controls ([`Batch::window_lanes`]) for the
    /// first `pairs` pairs, `lanes` per batch: false if a batch's first
    /// grains do not lie in its window.
    fn find_windows(&mut self, pairs: usize, lanes: usize) -> bool {
        let (pair_i, pair_j) = (self.pair_i.as_flattened(), self.pair_j.as_flattened());
        let pairs = pairs.min(pair_i.len()).min(pair_j.len());
        let per_lane = 8 / lanes.max(1);
        let batches = pair_i[..pairs]
            .chunks_exact(lanes.max(1))
            .zip(pair_j[..pairs].chunks_exact(lanes.max(1)));
        let controls = self.window_lanes.iter_mut().zip(&mut self.second_lanes);
        for ((batch, seconds), (control, second_control)) in batches.zip(controls) {
            let first = window_start::<N>(batch[0], lanes) as u32;
            if batch.iter().any(|&i| i.wrapping_sub(first) >= lanes as u32) {
                return false;
            }
            for (e, entry) in control.iter_mut().enumerate() {
                let lane = batch.get(e / per_lane).map_or(0, |&i| i - first);
                *entry = (lane as usize * per_lane + e % per_lane) as u8;
            }
            *second_control = [FAR; 8];
            if seconds
                .iter()
                .all(|&j| in_second_window::<N>(first as usize, j, lanes))
            {
                for (entry, &j) in second_control.iter_mut().zip(seconds) {
                    *entry = (j - first) as u8;
                }
            }
        }
        true
    }

    /// Marks each chunk of the first `pairs` pairs ([`CHUNK`] batches of
    /// `lanes`) that has a grain within `margin` of the periodic seam (x
    /// below it, or above `width` less it; any x that is not a number).
    /// With `margin` at least the neighbour cutoff plus the skin, every pair
    /// whose separation can exceed half the width before the next rebuild
    /// is in a marked chunk: a listed pair across the seam has both grains
    /// within the cutoff of it, and a grain moves less than half a skin
    /// between rebuilds, so only one that starts within that of the seam
    /// can wrap around it.
    fn find_seams(&mut self, pairs: usize, lanes: usize, x: &[R; N], width: R, margin: R) {
        let (pair_i, pair_j) = (self.pair_i.as_flattened(), self.pair_j.as_flattened());
        let pairs = pairs.min(pair_i.len()).min(pair_j.len());
        let near = |g: u32| {
            x.get(g as usize)
                .is_none_or(|&x| !(x >= margin && x <= width - margin))
        };
        let per_chunk = (CHUNK * lanes).max(1);
        let chunks = pair_i[..pairs]
            .chunks(per_chunk)
            .zip(pair_j[..pairs].chunks(per_chunk));
        self.seam.fill(false);
        for ((firsts, seconds), seam) in chunks.zip(&mut self.seam) {
            *seam = firsts.iter().chain(seconds).any(|&g| near(g));
        }
    }

    /// Chunks of pairs marked as near the seam, and chunks.
    #[cfg(test)]
    pub(crate) fn chunks_near_the_seam(&self) -> (usize, usize) {
        let chunks = self.pairs.div_ceil(CHUNK * R::LANES.max(1));
        let marked = self.seam.iter().take(chunks).filter(|&&s| s).count();
        (marked, chunks)
    }

    /// The history of grain i's used slot k while the storage is ready,
    /// else `None` (the slots hold it).
    pub(crate) fn spring_at(&self, i: usize, k: usize) -> Option<Spring<R>> {
        if !self.ready {
            return None;
        }
        let q = *self.start.get(i)? as usize + k;
        let (e_n, e_s) = (self.e_n.as_flattened(), self.e_s.as_flattened());
        Some(Spring {
            e_n: *e_n.get(q)?,
            e_s: *e_s.get(q)?,
        })
    }

    /// Moves the history back into the slots and stops being ready: the
    /// fused pass and the rebuild work on the slots.
    pub(crate) fn history_to_slots(&mut self, spring: &mut [[Spring<R>; K]; N]) {
        if !self.ready {
            return;
        }
        self.ready = false;
        let (e_n, e_s) = (self.e_n.as_flattened(), self.e_s.as_flattened());
        let (pair_i, pair_k) = (self.pair_i.as_flattened(), self.pair_k.as_flattened());
        let listed = self.listed.min(e_n.len());
        for q in 0..listed {
            if pair_k[q] == SELF_PAIR {
                continue;
            }
            let (i, k) = (pair_i[q] as usize, usize::from(pair_k[q]));
            if let Some(slot) = spring.get_mut(i).and_then(|s| s.get_mut(k)) {
                *slot = Spring {
                    e_n: e_n[q],
                    e_s: e_s[q],
                };
            }
        }
    }
}

/// The pair list being built by [`Batch::index`]: first and second grain,
/// slot, radii (from the grains' `radius`) and history per pair, `len`
/// pairs so far, `lanes` per batch.
struct PairList<'a, R, const N: usize> {
    i: &'a mut [u32],
    j: &'a mut [u32],
    k: &'a mut [u8],
    r_i: &'a mut [R],
    r_j: &'a mut [R],
    radius: &'a [R; N],
    e_n: &'a mut [R],
    e_s: &'a mut [R],
    len: usize,
    lanes: usize,
}

impl<R: Real, const N: usize> PairList<'_, R, N> {
    /// Appends pair (i, j) of slot k with history h: false if full (or a
    /// grain out of bounds).
    fn push(&mut self, i: u32, j: u32, k: u8, h: Spring<R>) -> bool {
        let q = self.len;
        let radii = (self.radius.get(i as usize), self.radius.get(j as usize));
        let (Some(&r_i), Some(&r_j)) = radii else {
            return false;
        };
        if q >= self.i.len().min(self.j.len()).min(self.k.len())
            || q >= self.r_i.len().min(self.r_j.len())
            || q >= self.e_n.len().min(self.e_s.len())
        {
            return false;
        }
        (self.i[q], self.j[q], self.k[q]) = (i, j, k);
        (self.r_i[q], self.r_j[q]) = (r_i, r_j);
        (self.e_n[q], self.e_s[q]) = (h.e_n, h.e_s);
        self.len += 1;
        true
    }

    /// The first grain of the batch being filled (None: none is).
    fn window_of_batch(&self) -> Option<usize> {
        let filled = self.len % self.lanes.max(1);
        let first = self.i.get(self.len.wrapping_sub(filled))?;
        (filled > 0).then_some(*first as usize)
    }

    /// Whether grain m's pairs, with second grains `js`, must start a new
    /// batch: m lies outside the first grains' window of the batch being
    /// filled, or one of `js` outside that batch's second window but inside
    /// the one a batch from m would have (a pair that no window holds,
    /// across the periodic boundary, joins the batch, whose second grains
    /// are then gathered).
    fn leaves_windows(&self, m: usize, js: &[u32]) -> bool {
        let Some(w) = self.window_of_batch() else {
            return false;
        };
        let holds = |first: usize, j: u32| {
            in_second_window::<N>(window_start::<N>(first as u32, self.lanes), j, self.lanes)
        };
        m - w >= self.lanes || js.iter().any(|&j| !holds(w, j) && holds(m, j))
    }

    /// Fills the batch being filled with pairs (w, w) of its first grain w:
    /// coincident, so they keep a zero history and exert no force. False
    /// if full.
    fn pad(&mut self) -> bool {
        let Some(w) = self.window_of_batch() else {
            return true;
        };
        while !self.len.is_multiple_of(self.lanes.max(1)) {
            if !self.push(w as u32, w as u32, SELF_PAIR, Spring::ZERO) {
                return false;
            }
        }
        true
    }
}

/// The first grain of the window of a batch of pairs whose first pair's
/// first grain is `i`: i itself, or the last window that ends within the
/// grains' arrays.
#[inline]
fn window_start<const N: usize>(i: u32, lanes: usize) -> usize {
    (i as usize).min(N.saturating_sub(lanes))
}

/// Whether second grain j lies in the [`second_window`] of a batch whose
/// window starts at grain `start` (never for f64, whose window is empty),
/// that window within the grains' arrays.
#[inline]
fn in_second_window<const N: usize>(start: usize, j: u32, lanes: usize) -> bool {
    let width = second_window(lanes);
    start + width <= N && (j as usize).wrapping_sub(start) < width
}

/// Whether capacities suit `lanes` lanes (none: 0): N and K powers of
/// two, so that masked indices need no bounds checks (every host capacity
/// is), N a whole number of groups.
pub(crate) const fn lanes_fit(n: usize, k: usize, lanes: usize) -> bool {
    lanes > 0 && n.is_power_of_two() && k.is_power_of_two() && n >= lanes
}

/// What the batched step reads and writes: the grains (first `n`), the
/// pair slots and the batch storage.
pub struct BatchStep<'a, R: Real, const N: usize, const K: usize> {
    pub(crate) n: usize,
    /// x, y, u, v, ω (moved; the radii are in the batch storage).
    pub(crate) x: &'a mut [R; N],
    pub(crate) y: &'a mut [R; N],
    pub(crate) u: &'a mut [R; N],
    pub(crate) v: &'a mut [R; N],
    pub(crate) w: &'a mut [R; N],
    pub(crate) inv_mass: &'a [R; N],
    pub(crate) inv_inertia: &'a [R; N],
    pub(crate) width: R,
    pub(crate) law: ContactLaw<R>,
    pub(crate) mover: Mover<R>,
    pub(crate) batch: &'a mut Batch<R, N, K>,
    /// The flow's drag, added to the forces first (flow on), or None.
    pub(crate) drag: Option<Drag<'a, R, N>>,
}

/// What the drag (4)–(5) of [`Profile::drag`] reads: the profile, the mean
/// bed level heights are measured from, and per grain ½ρC_D A2 d² and the
/// held fluctuation draws.
#[derive(Clone, Copy)]
pub struct Drag<'a, R: Real, const N: usize> {
    pub(crate) profile: Profile<R>,
    pub(crate) bed_level: R,
    pub(crate) coef: &'a [R; N],
    pub(crate) z_u: &'a [R; N],
    pub(crate) z_v: &'a [R; N],
}

/// Runs the batched step if this precision has lanes on this target and
/// the storage is ready: the largest squared speed, or the first grain's
/// error in grain order (as the fused pass). `None`: run the fused pass.
#[inline]
pub(crate) fn batched_step<R: Real, const N: usize, const K: usize>(
    step: &mut BatchStep<'_, R, N, K>,
) -> Option<Result<R, Error>> {
    if !step.batch.ready {
        return None;
    }
    R::batched_step(step)
}

pub(crate) use f32x8::batched_step as batched_step_f32;
pub(crate) use f64x4::batched_step as batched_step_f64;

/// The batched step in AVX2 lanes of one precision: module `$module`,
/// precision `$R` (raw bits `$bits`), vector `$V` of `$lanes` lanes, and
/// the precision's intrinsics; rows of a grain's four sums are `$Row`, and
/// `$to_rows` and `$from_rows` transpose four vectors to a row per lane and
/// back; `$to_mask` reads integer lanes as a lane mask. `unsafe` appears
/// five times in the macro: the call of a `#[target_feature]` function,
/// sound because the build enables AVX2 (`cfg(target_feature = "avx2")`),
/// and the loads and stores of a vector from and to a `[$R; $lanes]` and
/// of a row from and to a `[$R; 4]`, sound because the array is exactly
/// the vector's or row's size and the unaligned loads and stores need no
/// alignment.
macro_rules! lanes {
    (
        $module:ident, $R:ty, $bits:ty, $V:ty, $lanes:literal,
        $loadu:ident, $storeu:ident, $setzero:ident, $set1:ident, $gather:expr, $permute:expr,
        $Row:ty, $row_loadu:ident, $row_storeu:ident, $row_add:ident, $second_row:expr,
        $to_rows:expr, $from_rows:expr, $to_mask:ident,
        $add:ident, $sub:ident, $mul:ident, $div:ident, $sqrt:ident,
        $and:ident, $andnot:ident, $xor:ident, $blendv:ident, $cmp:ident,
        $max:ident, $movemask:ident
    ) => {
        #[allow(unsafe_code)]
        mod $module {
            use super::{BatchStep, CHUNK, PAIRS};
            use crate::error::Error;
            use crate::real::Real;
            use core::arch::x86_64::*;

            /// Lanes per vector.
            const L: usize = $lanes;
            /// Second grains from a window ([`super::second_window`]).
            const SECOND_WINDOW: bool = super::second_window(L) == 2 * L;
            const _: () = assert!(L == <$R as Real>::LANES);

            /// The batched step ([`super::batched_step`]).
            pub(crate) fn batched_step<const N: usize, const K: usize>(
                step: &mut BatchStep<'_, $R, N, K>,
            ) -> Result<$R, Error> {
                // SAFETY: this module is compiled only with AVX2 enabled for the
                // whole build, so the CPU running it has AVX2.
                unsafe {
                    if let Some(drag) = step.drag {
                        drag_pass(step, &drag);
                    }
                    pair_pass(step);
                    grain_pass(step)
                }
            }

            /// A vector from L values.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn load(values: &[$R; L]) -> $V {
                // SAFETY: `values` is L values (32 bytes); loadu needs no alignment.
                unsafe { $loadu(values.as_ptr()) }
            }

            /// Group `group` of L grains of an array (N is a whole number of groups).
            #[inline]
            fn group<const N: usize>(a: &[$R; N], group: usize) -> &[$R; L] {
                let (groups, _) = a.as_chunks::<L>();
                groups.get(group).unwrap_or(&[0.0; L])
            }

            /// Group `group` of L grains of an array, to write.
            #[inline]
            fn group_mut<const N: usize>(a: &mut [$R; N], group: usize) -> Option<&mut [$R; L]> {
                let (groups, _) = a.as_chunks_mut::<L>();
                groups.get_mut(group)
            }

            /// A vector from `a[at..at + L]`, zero if out of bounds.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn load_at(a: &[$R], at: usize) -> $V {
                match a.get(at..).and_then(|s| s.first_chunk::<L>()) {
                    Some(values) => load(values),
                    None => $setzero(),
                }
            }

            /// Stores a vector to `a[at..at + L]`, if in bounds.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn store(a: &mut [$R], at: usize, v: $V) {
                if let Some(values) = a.get_mut(at..).and_then(|s| s.first_chunk_mut::<L>()) {
                    put(values, v);
                }
            }

            /// Stores a vector to L values.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn put(values: &mut [$R; L], v: $V) {
                // SAFETY: `values` is L values (32 bytes); storeu needs no alignment.
                unsafe { $storeu(values.as_mut_ptr(), v) }
            }

            /// A grain's sums as a row.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn load_row(values: &[$R; 4]) -> $Row {
                // SAFETY: `values` is one row; loadu needs no alignment.
                unsafe { $row_loadu(values.as_ptr()) }
            }

            /// Adds a row to a grain's sums.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn add_row(values: &mut [$R; 4], row: $Row) {
                put_row(values, $row_add(load_row(values), row));
            }

            /// Stores a row.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn put_row(values: &mut [$R; 4], row: $Row) {
                // SAFETY: `values` is one row; storeu needs no alignment.
                unsafe { $row_storeu(values.as_mut_ptr(), row) }
            }

            /// The lanes of a vector.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn lanes(v: $V) -> [$R; L] {
                let mut a = [0.0; L];
                put(&mut a, v);
                a
            }

            /// The values of `a` at indices `i` (in bounds: else zero).
            #[inline]
            #[target_feature(enable = "avx2")]
            fn gather(a: &[$R], i: &[usize; L]) -> $V {
                let v: [$R; L] = core::array::from_fn(|l| a.get(i[l]).copied().unwrap_or(0.0));
                $gather(v)
            }

            /// The values of `a` at grains `window + lane` (`lanes`: a permutation
            /// control of 32-bit lanes; zero if the window is out of bounds).
            #[inline]
            #[target_feature(enable = "avx2")]
            fn window(a: &[$R], window: usize, lanes: __m256i) -> $V {
                $permute(load_at(a, window), lanes)
            }

            /// `f` of the lanes of `v` selected by `mask`, zero elsewhere (scalar
            /// calls: the vector holds the same values as the fused pass's).
            #[inline]
            #[target_feature(enable = "avx2")]
            fn map_where(v: $V, mask: $V, f: fn($R) -> $R) -> $V {
                if $movemask(mask) == 0 {
                    return $setzero();
                }
                let (values, selected) = (lanes(v), lanes(mask));
                // Built in registers: a vector load of scalar stores would stall.
                $gather(core::array::from_fn(|l| {
                    if selected[l].to_bits() != 0 {
                        f(values[l])
                    } else {
                        0.0
                    }
                }))
            }

            /// Adds the drag (4)–(5) to every mobile grain's force, L grains at a
            /// time, lane by lane as [`Profile::drag`](crate::flow::Profile::drag)
            /// (its scalar `ln` and `exp` only in the lanes that need them).
            #[target_feature(enable = "avx2")]
            fn drag_pass<const N: usize, const K: usize>(
                s: &mut BatchStep<'_, $R, N, K>,
                d: &super::Drag<'_, $R, N>,
            ) {
                let splat = $set1;
                let zero = $setzero();
                let (add, sub, mul) = ($add, $sub, $mul);
                let select = |no: $V, yes: $V, mask: $V| $blendv(no, yes, mask);
                let p = &d.profile;
                let one = splat(1.0);
                let (bed, shift, inv_ks) = (
                    splat(d.bed_level),
                    splat(p.zero_shift),
                    splat(p.inv_roughness),
                );
                let log_law = splat(<$R as Real>::from_f64(30.1));
                let (eps0, open) = (splat(p.eps0), splat(1.0 - p.eps0));
                let turbulence = splat(if p.turbulence {
                    <$R>::from_bits(<$bits>::MAX)
                } else {
                    0.0
                });
                let b = &mut *s.batch;
                let groups = s.n.min(N).div_ceil(L).min(N / L);
                for grp in 0..groups {
                    let mobile = load(group(&b.mobile, grp));
                    if $movemask(mobile) == 0 {
                        continue;
                    }
                    let at = |a: &[$R; N]| load(group(a, grp));
                    let y = sub(at(s.y), bed);
                    // (14) mean velocity.
                    let above = add(y, shift);
                    let arg = mul(mul(log_law, above), inv_ks);
                    let flows = $and($cmp(arg, one, _CMP_GT_OQ), mobile);
                    let mean = $and(
                        mul(
                            splat(p.u_star_over_kappa),
                            map_where(arg, flows, <$R as Real>::ln),
                        ),
                        flows,
                    );
                    // (15) fluctuations where U > 0.
                    let fluctuates = $and($cmp(mean, zero, _CMP_GT_OQ), turbulence);
                    let decay = map_where(
                        mul(y, splat(p.minus_inv_depth)),
                        fluctuates,
                        <$R as Real>::exp,
                    );
                    let fluct_u = $and(mul(at(d.z_u), mul(splat(p.rms_u0), decay)), fluctuates);
                    let fluct_v = $and(mul(at(d.z_v), mul(splat(p.rms_v0), decay)), fluctuates);
                    let wx = sub(add(mean, fluct_u), at(s.u));
                    let wy = sub(fluct_v, at(s.v));
                    // (16) sheltering.
                    let z = mul(above, inv_ks);
                    let exposed = $and($cmp(z, zero, _CMP_GT_OQ), mobile);
                    let hidden =
                        map_where($xor(mul(z, z), splat(-0.0)), exposed, <$R as Real>::exp);
                    let eps = select(eps0, add(eps0, mul(open, sub(one, hidden))), exposed);
                    // (4)–(5).
                    let xi = mul(mul(at(d.coef), eps), $sqrt(add(mul(wx, wx), mul(wy, wy))));
                    // The sums (+0) add the drag (+0 for fixed grains).
                    let [fx, fy] = [mul(xi, wx), mul(xi, wy)].map(|f| $and(f, mobile));
                    let rows = $to_rows([fx, fy, zero, zero]);
                    if let Some(sums) = b.sums.as_chunks_mut::<L>().0.get_mut(grp) {
                        for (sum, row) in sums.iter_mut().zip(rows) {
                            add_row(sum, row);
                        }
                    }
                }
            }

            /// A batch's geometry and relative speeds: what its laws need of it
            /// (`State::contact`).
            #[derive(Clone, Copy)]
            struct Geometry {
                /// Unit normal, r_i + r_j − distance, radii.
                nx: $V,
                ny: $V,
                overlap: $V,
                ri: $V,
                rj: $V,
                /// Lane masks: in contact (not apart, not coincident); coincident
                /// (keeps its history).
                touching: $V,
                keeps: $V,
                /// Normal and tangential relative speeds.
                v_n: $V,
                v_s: $V,
            }

            /// Every listed pair's geometry and law, L pairs at a time, lane by
            /// lane as `State::contact` and `ContactLaw::apply`; each pair's force
            /// and torques added to its grains' sums in pair order.
            #[target_feature(enable = "avx2")]
            fn pair_pass<const N: usize, const K: usize>(s: &mut BatchStep<'_, $R, N, K>) {
                let splat = $set1;
                let zero = $setzero();
                let sign = splat(-0.0);
                let all = splat(<$R>::from_bits(<$bits>::MAX));
                let neg = |a: $V| $xor(a, sign);
                let (add, sub, mul) = ($add, $sub, $mul);
                let select = |no: $V, yes: $V, mask: $V| $blendv(no, yes, mask);
                let (width, half_width) = (splat(s.width), splat(s.width * 0.5));
                let law = &s.law;
                let (dt, k_n, k_s) = (splat(law.dt), splat(law.k_n), splat(law.k_s));
                let (eta_n, eta_s, mu) = (splat(law.eta_n), splat(law.eta_s), splat(law.mu));
                let b = &mut *s.batch;
                let (x, y, u, v, w) = (&*s.x, &*s.y, &*s.u, &*s.v, &*s.w);
                let cap = N * PAIRS;
                // Pair q's grain in `a` (< N by construction; masked so that the
                // compiler sees it in bounds), and those of the batch from pair q.
                let index = |a: &[[u32; PAIRS]; N], q: usize| {
                    a.as_flattened()[q & (cap - 1)] as usize & (N - 1)
                };
                let at = |a: &[[u32; PAIRS]; N], q: usize| -> [usize; L] {
                    core::array::from_fn(|l| index(a, q + l))
                };
                let control =
                    |c: [u8; 8]| _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(i64::from_le_bytes(c)));
                // Batch t's first grains: its window and their lanes in it.
                let first_window = |t: usize| {
                    let lanes = control(b.window_lanes[t & (N - 1)]);
                    let first = b.pair_i.as_flattened()[(t * L) & (cap - 1)];
                    (super::window_start::<N>(first, L), lanes)
                };
                // Batch t's second grains' x, y, u, v, ω: from its second
                // window (from `start`), or gathered.
                let second_grains = |t: usize, start: usize| {
                    let grains = [x, y, u, v, w];
                    let c = b.second_lanes[t & (N - 1)];
                    if SECOND_WINDOW && c[0] != super::FAR {
                        let lanes = control(c);
                        let high = $to_mask(_mm256_slli_epi32::<28>(lanes));
                        grains.map(|a| {
                            let low = window(a, start, lanes);
                            select(low, window(a, start + L, lanes), high)
                        })
                    } else {
                        let j = at(&b.pair_j, t * L);
                        grains.map(|a| gather(a, &j))
                    }
                };

                // Chunks of batches: first their geometry (square root, division)
                // and relative speeds (the gathers), then their laws and sums, so
                // that the core overlaps many batches' square roots, divisions and
                // gathers instead of waiting for each.
                let batches = b.pairs.min(cap) / L;
                // The last first grain and its sums.
                let mut last = (usize::MAX, load_row(&[0.0; 4]));
                // One buffer for every chunk (zeroing it per chunk cost ~8
                // instructions per grain-step).
                let mut geometry = [Geometry {
                    nx: zero,
                    ny: zero,
                    overlap: zero,
                    ri: zero,
                    rj: zero,
                    touching: zero,
                    keeps: zero,
                    v_n: zero,
                    v_s: zero,
                }; CHUNK];
                for chunk in (0..batches).step_by(CHUNK) {
                    let seam = b.seam[(chunk / CHUNK) & (N - 1)];
                    let chunk = chunk..batches.min(chunk + CHUNK);
                    // Geometry (State::contact).
                    for (t, g) in chunk.clone().zip(&mut geometry) {
                        let (start, lanes) = first_window(t);
                        let own = |a: &[$R; N]| window(a, start, lanes);
                        let [x_j, y_j, u_j, v_j, w_j] = second_grains(t, start);
                        // The periodic image: d itself (within half the width)
                        // away from the seam.
                        let d = sub(x_j, own(x));
                        let dx = if seam {
                            select(
                                select(d, add(d, width), $cmp(d, neg(half_width), _CMP_LT_OQ)),
                                sub(d, width),
                                $cmp(d, half_width, _CMP_GT_OQ),
                            )
                        } else {
                            d
                        };
                        let dy = sub(y_j, own(y));
                        let ri = load_at(b.r_i.as_flattened(), t * L);
                        let rj = load_at(b.r_j.as_flattened(), t * L);
                        let reach = add(ri, rj);
                        let dist2 = add(mul(dx, dx), mul(dy, dy));
                        let apart = $cmp(dist2, mul(reach, reach), _CMP_GE_OQ);
                        let dist = $sqrt(dist2);
                        let coincident = $cmp(dist, zero, _CMP_EQ_OQ);
                        let inv = $div(splat(1.0), dist);
                        let (nx, ny) = (mul(dx, inv), mul(dy, inv));
                        let (tx, ty) = (ny, neg(nx));
                        let du = sub(own(u), u_j);
                        let dv = sub(own(v), v_j);
                        let v_n = add(mul(du, nx), mul(dv, ny));
                        let spin = mul(ri, own(w));
                        let v_s = add(add(neg(add(mul(du, tx), mul(dv, ty))), spin), mul(rj, w_j));
                        *g = Geometry {
                            nx,
                            ny,
                            overlap: sub(reach, dist),
                            ri,
                            rj,
                            touching: $andnot(apart, $andnot(coincident, all)),
                            keeps: $andnot(apart, coincident),
                            v_n,
                            v_s,
                        };
                    }
                    for (t, g) in chunk.zip(&geometry) {
                        let q = t * L;
                        let Geometry {
                            nx,
                            ny,
                            overlap,
                            ri,
                            rj,
                            touching,
                            keeps,
                            v_n,
                            v_s,
                        } = *g;
                        let (tx, ty) = (ny, neg(nx));
                        let e_n0 = load_at(b.e_n.as_flattened(), q);
                        let e_s0 = load_at(b.e_s.as_flattened(), q);

                        // Law (ContactLaw::apply).
                        let first = $cmp(e_n0, zero, _CMP_EQ_OQ);
                        let e_n = add(e_n0, mul(k_n, select(mul(v_n, dt), overlap, first)));
                        let broken = $cmp(e_n, zero, _CMP_LT_OQ);
                        let f_n = add(e_n, mul(eta_n, v_n));
                        let e_s = add(e_s0, mul(mul(k_s, v_s), dt));
                        let limit = mul(mu, e_n);
                        let slides = $cmp($andnot(sign, e_s), limit, _CMP_GT_OQ);
                        let e_s_slid = select(neg(limit), limit, $cmp(e_s, zero, _CMP_GT_OQ));
                        let e_s_new = select(e_s, e_s_slid, slides);
                        let f_s = select(add(e_s, mul(eta_s, v_s)), e_s_new, slides);

                        // Outcomes: apart or broken drop the history; coincident keeps
                        // it; otherwise the new history and a force.
                        let acts = $andnot(broken, touching);
                        // Padding pairs (w, w) are coincident: their history stays zero.
                        // The lanes that act and those that keep are disjoint, so
                        // one of each pair of terms is +0: a bitwise merge, which
                        // the optimiser does not turn into a masked store
                        // (`vmaskmovpd`, slow on AMD cores) as it did a select.
                        let e_n_out = $xor($and(e_n, acts), $and(e_n0, keeps));
                        let e_s_out = $xor($and(e_s_new, acts), $and(e_s0, keeps));
                        store(b.e_n.as_flattened_mut(), q, e_n_out);
                        store(b.e_s.as_flattened_mut(), q, e_s_out);
                        let fx = $and(add(mul(neg(f_n), nx), mul(f_s, tx)), acts);
                        let fy = $and(add(mul(neg(f_n), ny), mul(f_s, ty)), acts);
                        let f_s = $and(f_s, acts);
                        // Rows (f_x, f_y, −r_i f_s, −r_j f_s), added in pair order:
                        // the first three to the first grain, the force negated and
                        // the fourth to the second. A first grain's pairs are
                        // consecutive, and no other pair adds to its sums between
                        // them (its second-grain pairs all come earlier; a padding
                        // pair (w, w) adds zeros, to the stale copy in memory that
                        // the store overwrites), so its sums stay in a register
                        // from one to the next and are stored once, when the next
                        // first grain comes or the pass ends.
                        let rows = $to_rows([fx, fy, neg(mul(ri, f_s)), neg(mul(rj, f_s))]);
                        for (l, row) in rows.into_iter().enumerate() {
                            let (i, j) = (index(&b.pair_i, q + l), index(&b.pair_j, q + l));
                            let base = if i == last.0 {
                                last.1
                            } else {
                                if let Some(sums) = b.sums.get_mut(last.0) {
                                    put_row(sums, last.1);
                                }
                                load_row(&b.sums[i])
                            };
                            last = (i, $row_add(base, row));
                            add_row(&mut b.sums[j], $second_row(row));
                        }
                    }
                }
                if let Some(sums) = b.sums.get_mut(last.0) {
                    put_row(sums, last.1);
                }
            }

            /// Every grain's motion (`Mover::advance`) from its sums, which it
            /// zeroes, L grains at a time: the largest squared speed, or the
            /// first failing grain's error (the sums then all zeroed).
            #[target_feature(enable = "avx2")]
            fn grain_pass<const N: usize, const K: usize>(
                s: &mut BatchStep<'_, $R, N, K>,
            ) -> Result<$R, Error> {
                let splat = $set1;
                let zero = $setzero();
                let (add, sub, mul) = ($add, $sub, $mul);
                let select = |no: $V, yes: $V, mask: $V| $blendv(no, yes, mask);
                let m = &s.mover;
                let (dt, width) = (splat(m.dt), splat(m.width));
                let (gx, gy) = (splat(m.gravity[0]), splat(m.gravity[1]));
                let (y_min, y_max) = (splat(m.y_min), splat(m.y_max));
                let largest = splat(<$R>::MAX);
                let abs = splat(<$R>::from_bits(<$bits>::MAX >> 1));
                let b = &mut *s.batch;
                let mut max_v2 = zero;
                let groups = s.n.min(N).div_ceil(L).min(N / L);
                for grp in 0..groups {
                    let g = grp * L;
                    let mobile = load(group(&b.mobile, grp));
                    let at = |a: &[$R; N]| load(group(a, grp));
                    let Some(sums) = b.sums.as_chunks_mut::<L>().0.get_mut(grp) else {
                        break;
                    };
                    let [fx, fy, torque, _] = $from_rows(sums.each_ref().map(|row| load_row(row)));
                    *sums = [[0.0; 4]; L];
                    if $movemask(mobile) == 0 {
                        continue;
                    }
                    // Mover::advance.
                    let im = at(s.inv_mass);
                    let (x0, y0, u0, v0, w0) = (at(s.x), at(s.y), at(s.u), at(s.v), at(s.w));
                    let u = add(u0, mul(add(mul(fx, im), gx), dt));
                    let v = add(v0, mul(add(mul(fy, im), gy), dt));
                    let w = add(w0, mul(mul(torque, at(s.inv_inertia)), dt));
                    let x = add(x0, mul(u, dt));
                    let y = add(y0, mul(v, dt));
                    let inside =
                        |x: $V| $and($cmp(x, zero, _CMP_GE_OQ), $cmp(x, width, _CMP_LT_OQ));
                    let mut in_x = inside(x);
                    // The periodic wrap, where a grain left [0, L) (x is
                    // its own wrap inside).
                    let x = if $movemask(in_x) == (1 << L) - 1 {
                        x
                    } else {
                        let over = $cmp(x, width, _CMP_GE_OQ);
                        let under = $cmp(x, zero, _CMP_LT_OQ);
                        let wrapped = add(x, width);
                        let wrapped = $andnot($cmp(wrapped, width, _CMP_GE_OQ), wrapped);
                        let x = select(select(x, wrapped, under), sub(x, width), over);
                        in_x = inside(x);
                        x
                    };
                    let ok = $and(
                        $and($cmp($and(w, abs), largest, _CMP_LE_OQ), in_x),
                        $and($cmp(y, y_min, _CMP_GE_OQ), $cmp(y, y_max, _CMP_LE_OQ)),
                    );
                    if $movemask($andnot(ok, mobile)) != 0 {
                        // A grain fails: redo the group grain by grain, as the
                        // fused pass, up to the first failure.
                        let sums = [lanes(fx), lanes(fy), lanes(torque)];
                        let mobile = lanes(mobile);
                        for l in 0..L {
                            let i = (g + l) & (N - 1);
                            if mobile[l].to_bits() == 0 {
                                continue;
                            }
                            let moved = m.advance(
                                i,
                                [s.x[i], s.y[i], s.u[i], s.v[i], s.w[i]],
                                [
                                    sums[0][l] * s.inv_mass[i],
                                    sums[1][l] * s.inv_mass[i],
                                    sums[2][l] * s.inv_inertia[i],
                                ],
                            );
                            let moved = moved.inspect_err(|_| b.sums.fill([0.0; 4]))?;
                            [s.x[i], s.y[i], s.u[i], s.v[i], s.w[i]] = moved;
                            let v2 = moved[2] * moved[2] + moved[3] * moved[3];
                            max_v2 = $max(splat(v2), max_v2);
                        }
                        continue;
                    }
                    // Fixed grains keep their state (a whole group of mobile
                    // grains, the usual case, needs no blend).
                    let all_mobile = $movemask(mobile) == (1 << L) - 1;
                    for (a, old, new) in [
                        (&mut *s.x, x0, x),
                        (&mut *s.y, y0, y),
                        (&mut *s.u, u0, u),
                        (&mut *s.v, v0, v),
                        (&mut *s.w, w0, w),
                    ] {
                        if let Some(values) = group_mut(a, grp) {
                            put(
                                values,
                                if all_mobile {
                                    new
                                } else {
                                    select(old, new, mobile)
                                },
                            );
                        }
                    }
                    let v2 = $and(add(mul(u, u), mul(v, v)), mobile);
                    max_v2 = $max(v2, max_v2);
                }
                Ok(lanes(max_v2).into_iter().fold(0.0, <$R as Real>::max))
            }
        }
    };
}

lanes!(
    f64x4,
    f64,
    u64,
    __m256d,
    4,
    _mm256_loadu_pd,
    _mm256_storeu_pd,
    _mm256_setzero_pd,
    _mm256_set1_pd,
    |v: [f64; 4]| _mm256_setr_pd(v[0], v[1], v[2], v[3]),
    |v: __m256d, lanes: __m256i| _mm256_castps_pd(_mm256_permutevar8x32_ps(
        _mm256_castpd_ps(v),
        lanes
    )),
    __m256d,
    _mm256_loadu_pd,
    _mm256_storeu_pd,
    _mm256_add_pd,
    // (f_x, f_y, t_i, t_j) → (−f_x, −f_y, t_j, t_j)
    |row: __m256d| _mm256_xor_pd(
        _mm256_permute4x64_pd::<0b11_11_01_00>(row),
        _mm256_setr_pd(-0.0, -0.0, 0.0, 0.0)
    ),
    super::transpose_f64,
    super::transpose_f64,
    _mm256_castsi256_pd,
    _mm256_add_pd,
    _mm256_sub_pd,
    _mm256_mul_pd,
    _mm256_div_pd,
    _mm256_sqrt_pd,
    _mm256_and_pd,
    _mm256_andnot_pd,
    _mm256_xor_pd,
    _mm256_blendv_pd,
    _mm256_cmp_pd,
    _mm256_max_pd,
    _mm256_movemask_pd
);

lanes!(
    f32x8,
    f32,
    u32,
    __m256,
    8,
    _mm256_loadu_ps,
    _mm256_storeu_ps,
    _mm256_setzero_ps,
    _mm256_set1_ps,
    |v: [f32; 8]| _mm256_setr_ps(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]),
    _mm256_permutevar8x32_ps,
    __m128,
    _mm_loadu_ps,
    _mm_storeu_ps,
    _mm_add_ps,
    // (f_x, f_y, t_i, t_j) → (−f_x, −f_y, t_j, t_j)
    |row: __m128| _mm_xor_ps(
        _mm_permute_ps::<0b11_11_01_00>(row),
        _mm_setr_ps(-0.0, -0.0, 0.0, 0.0)
    ),
    super::rows_f32,
    super::columns_f32,
    _mm256_castsi256_ps,
    _mm256_add_ps,
    _mm256_sub_ps,
    _mm256_mul_ps,
    _mm256_div_ps,
    _mm256_sqrt_ps,
    _mm256_and_ps,
    _mm256_andnot_ps,
    _mm256_xor_ps,
    _mm256_blendv_ps,
    _mm256_cmp_ps,
    _mm256_max_ps,
    _mm256_movemask_ps
);

/// Four vectors of four f64 lanes transposed: value l of vector c becomes
/// value c of vector l (per-lane values to rows, and back).
#[inline]
#[target_feature(enable = "avx2")]
fn transpose_f64([a, b, c, d]: [__m256d; 4]) -> [__m256d; 4] {
    let (ab_even, ab_odd) = (_mm256_unpacklo_pd(a, b), _mm256_unpackhi_pd(a, b));
    let (cd_even, cd_odd) = (_mm256_unpacklo_pd(c, d), _mm256_unpackhi_pd(c, d));
    [
        _mm256_permute2f128_pd::<0x20>(ab_even, cd_even),
        _mm256_permute2f128_pd::<0x20>(ab_odd, cd_odd),
        _mm256_permute2f128_pd::<0x31>(ab_even, cd_even),
        _mm256_permute2f128_pd::<0x31>(ab_odd, cd_odd),
    ]
}

/// Four vectors of eight f32 lanes transposed within each half: value l of
/// vector c becomes value c of vector l mod 4, half l / 4.
#[inline]
#[target_feature(enable = "avx2")]
fn transpose_halves_f32([a, b, c, d]: [__m256; 4]) -> [__m256; 4] {
    let (ab_low, ab_high) = (_mm256_unpacklo_ps(a, b), _mm256_unpackhi_ps(a, b));
    let (cd_low, cd_high) = (_mm256_unpacklo_ps(c, d), _mm256_unpackhi_ps(c, d));
    [
        _mm256_shuffle_ps::<0x44>(ab_low, cd_low),
        _mm256_shuffle_ps::<0xee>(ab_low, cd_low),
        _mm256_shuffle_ps::<0x44>(ab_high, cd_high),
        _mm256_shuffle_ps::<0xee>(ab_high, cd_high),
    ]
}

/// Four vectors of eight f32 lanes as eight rows of four: row l holds
/// value l of each vector.
#[inline]
#[target_feature(enable = "avx2")]
fn rows_f32(columns: [__m256; 4]) -> [__m128; 8] {
    let t = transpose_halves_f32(columns);
    let low = t.map(|v| _mm256_castps256_ps128(v));
    let high = t.map(|v| _mm256_extractf128_ps::<1>(v));
    [
        low[0], low[1], low[2], low[3], high[0], high[1], high[2], high[3],
    ]
}

/// Eight rows of four f32 as four vectors of eight lanes ([`rows_f32`]
/// undone).
#[inline]
#[target_feature(enable = "avx2")]
fn columns_f32(rows: [__m128; 8]) -> [__m256; 4] {
    let pairs: [__m256; 4] = core::array::from_fn(|l| _mm256_set_m128(rows[l + 4], rows[l]));
    transpose_halves_f32(pairs)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 40 grains numbered as a bed's, column by column, 13 to a column:
    /// grain m's pairs are the grain above it (m + 1) and its neighbour in
    /// the next column (m + 13), and grain 3 touches grain 39 across the
    /// periodic boundary. In f32 lanes: every listed pair is found at its
    /// grain's start and slot, each batch's first and second grains are
    /// picked by its controls (a batch of four grains' pairs would reach
    /// 16 grains ahead: it ends early), and only the batch across the
    /// boundary gathers its second grains.
    #[test]
    fn second_grains_lie_in_windows_but_across_the_boundary() {
        const N: usize = 64;
        const K: usize = 4;
        let n = 40;
        let mut batch = std::boxed::Box::new(Batch::<f32, N, K>::new());
        let (mut count, mut other) = ([0u8; N], [[0u32; K]; N]);
        for m in 0..n {
            let js = [m + 1, m + 13].into_iter().filter(|&j| j < n);
            let js = js.chain((m == 3).then_some(39));
            for j in js {
                other[m][usize::from(count[m])] = j as u32;
                count[m] += 1;
            }
        }
        let spring = [[Spring::<f32>::ZERO; K]; N];
        let mut grains = std::boxed::Box::new(Grains::<f32, N>::new());
        grains.len = n;
        batch.index(&grains, &count, &other, &spring, 1.0, 1.0);
        assert!(batch.ready);
        let (pair_i, pair_j) = (batch.pair_i.as_flattened(), batch.pair_j.as_flattened());
        for m in 0..n {
            for (k, &j) in other[m][..usize::from(count[m])].iter().enumerate() {
                let q = batch.start[m] as usize + k;
                assert_eq!((pair_i[q], pair_j[q]), (m as u32, j));
            }
        }
        let mut far = 0;
        for t in 0..batch.pairs / 8 {
            let pairs = t * 8..t * 8 + 8;
            let start = window_start::<N>(pair_i[t * 8], 8);
            for (l, q) in pairs.clone().enumerate() {
                let first = usize::from(batch.window_lanes[t][l]);
                assert_eq!(pair_i[q] as usize, start + first);
            }
            if batch.second_lanes[t][0] == FAR {
                far += 1;
                assert!(pairs.clone().any(|q| (pair_i[q], pair_j[q]) == (3, 39)));
                continue;
            }
            for (l, q) in pairs.enumerate() {
                let second = usize::from(batch.second_lanes[t][l]);
                assert!(second < second_window(8));
                assert_eq!(pair_j[q] as usize, start + second);
            }
        }
        assert_eq!(far, 1);
    }
}
