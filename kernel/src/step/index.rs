//! The batched step's pair index ([`PairIndex`]): the listed pairs of the
//! neighbour slots in the order and layout the vector lanes read, rebuilt
//! with the slots.
//!
//! Pairs are listed by first grain and padded so that each batch's first
//! grains lie in one window of lanes' worth of grains: their values are a
//! vector load and a permutation. In f32 the padding also keeps a batch's
//! second grains within 16 grains of that window's start (two loads, two
//! permutations and a blend) unless a pair crosses the periodic boundary;
//! other second grains are gathered; the radii come the same way as the
//! positions (not copied per pair: 16 bytes a pair less to stream each
//! step). Only chunks of pairs near the periodic seam take the periodic
//! image of their separation.
//!
//! While the index is ready it holds the spring history, in pair order
//! (vector loads and stores); the slots get it back before the scalar step
//! or a rebuild reads them ([`PairIndex::history_to_slots`]).
//!
//! Lanes need capacities that are powers of two (every host capacity), so
//! that masked indices need no bounds checks ([`lanes_fit`]).

use crate::contact::Spring;
use crate::grains::{Grains, Pad, PAD};
use crate::neighbours::Neighbours;
use crate::real::Real;

/// Bytes of one vector (AVX2: 256 bits).
const VECTOR_BYTES: usize = 32;

/// Lanes per vector in precision `R`: 4 for f64, 8 for f32.
pub(super) const fn lanes<R: Real>() -> usize {
    VECTOR_BYTES / R::BYTES
}

// The lane modules hold as many.
const _: () = assert!(crate::lanes::f64x4::L == lanes::<f64>());
const _: () = assert!(crate::lanes::f32x8::L == lanes::<f32>());

/// Listed pairs the storage holds per grain on average (a settled bed has
/// about 2.3; more: the scalar step runs).
pub(crate) const PAIRS: usize = 4;

/// Batches of pairs whose geometry is found before their laws (the pair
/// pass's chunks).
pub(crate) const CHUNK: usize = 8;

/// `pair_k` of a padding pair (w, w), which has no slot.
pub(crate) const SELF_PAIR: u8 = u8::MAX;

/// [`PairIndex::second_lanes`] of a batch whose second grains are gathered.
pub(super) const FAR: u8 = u8::MAX;

/// Grains in the window of a batch's second grains, from its window start
/// (0: none, all gathered): 16 for 8 lanes (f32). Grains are numbered
/// column by column, so a grain's contacts lie a few grains ahead, and
/// 8 pairs' second grains nearly always lie within 16 grains of their
/// first grains' window; two vector loads and permutations then replace
/// eight loads and seven inserts. For 4 lanes (f64) a window would need
/// as many permutations as the gather needs inserts.
pub(super) const fn second_window(lanes: usize) -> usize {
    if lanes >= 8 {
        2 * lanes
    } else {
        0
    }
}

/// The batched step's pair index, rebuilt with the neighbour slots; a
/// [`Pad`] after each array, as in [`crate::grains::Grains`] (arrays of a
/// power-of-two size would otherwise share cache sets).
#[derive(Debug, Clone)]
#[repr(C)]
pub(crate) struct PairIndex<R: Real, const N: usize, const K: usize> {
    /// The pair list the pair pass reads ([`List`]).
    pub(super) list: List<N>,
    /// Per pair, its slot k ([`SELF_PAIR`]: a padding pair).
    pair_k: [[u8; PAIRS]; N],
    _pad3: Pad,
    /// Pairs up to the last listed one (padding pairs between included),
    /// and pairs in whole batches (a multiple of the lanes).
    listed: usize,
    pub(super) pairs: usize,
    /// Per pair, its spring history (e_n, e_s) while the storage is ready:
    /// the slots' copy is stale until [`PairIndex::history_to_slots`].
    pub(super) e_n: [[R; PAIRS]; N],
    _pad4: Pad,
    pub(super) e_s: [[R; PAIRS]; N],
    _pad5: Pad,
    /// Per grain, its first pair: pairs (i, slot k) are listed at
    /// `start[i] + k`.
    start: [u32; N],
    /// Per grain, its sums during a step: force (x, y), torque, and a
    /// fourth value that is never read. Zero between steps.
    pub(super) sums: [[R; 4]; N],
    _pad6: Pad,
    /// Per grain, all-ones bits if it moves (is not fixed), else zero: the
    /// lane mask of the grain pass.
    pub(super) mobile: [R; N],
    _pad10: Pad,
    /// The index matches the current slots (false when they do not fit:
    /// then the scalar step runs). Every change of the slots marks them
    /// stale, so a step rebuilds and re-indexes before it reads this.
    pub(crate) ready: bool,
}

/// The pair list of the [`PairIndex`], as every range of the pair pass
/// reads it (shared): one struct, so that a pass holds one address for
/// all its arrays (as seven, they were reloaded from the stack in the
/// pair phase's loop).
#[derive(Debug, Clone)]
#[repr(C)]
pub(crate) struct List<const N: usize> {
    /// Listed pairs, padded with pairs (w, w) ([`SELF_PAIR`]) so that each
    /// batch's first grains lie in one window and the last batch is whole:
    /// first and second grain.
    pub(crate) pair_i: [[u32; PAIRS]; N],
    _pad1: Pad,
    pub(crate) pair_j: [[u32; PAIRS]; N],
    _pad2: Pad,
    /// Per batch of pairs, the 32-bit lanes (one byte each) that pick each
    /// pair's first grain from the batch's window (a permutation control):
    /// the window is the lanes' worth of grains from the batch's first
    /// grain ([`window_start`]; pairs are listed by first grain, and padded
    /// so that each batch's lie in one window), and their values are one
    /// load and one permutation instead of a gather.
    pub(crate) window_lanes: [[u8; 8]; N],
    _pad11: Pad,
    /// Per batch of pairs, the 32-bit lanes that pick each pair's second
    /// grain from the [`second_window`] grains from the batch's window
    /// start (values 0 to 15: the low three bits pick a lane of a vector,
    /// the fourth which of two), or [`FAR`] first if they do not lie there
    /// (then they are gathered).
    pub(crate) second_lanes: [[u8; 8]; N],
    _pad12: Pad,
    /// Per chunk of [`CHUNK`] batches, whether a pair of it may need the
    /// periodic image of its separation ([`PairIndex::index`]); the
    /// others' separations are within half the width and skip it.
    pub(crate) seam: [bool; N],
    _pad15: Pad,
    /// Which indexing wrote these pairs: a number no other
    /// [`PairIndex::index`] in the process draws ([`STAMPS`]), copied only
    /// with the pairs (`Clone`); 0 before the first. What the phased step
    /// in lanes builds from the pairs is keyed by it
    /// ([`crate::step::buffers::Phases`]), so that it is never read
    /// against other pairs.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    pub(crate) stamp: u64,
}

/// The stamps of [`List::stamp`]: one draw per [`PairIndex::index`].
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
static STAMPS: core::sync::atomic::AtomicU64 = core::sync::atomic::AtomicU64::new(0);

impl<const N: usize> List<N> {
    /// Empty (all-zero bits).
    const fn new() -> Self {
        List {
            pair_i: [[0; PAIRS]; N],
            _pad1: PAD,
            pair_j: [[0; PAIRS]; N],
            _pad2: PAD,
            window_lanes: [[0; 8]; N],
            _pad11: PAD,
            second_lanes: [[0; 8]; N],
            _pad12: PAD,
            seam: [false; N],
            _pad15: PAD,
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            stamp: 0,
        }
    }
}

impl<R: Real, const N: usize, const K: usize> PairIndex<R, N, K> {
    /// Empty (all-zero bits).
    pub(crate) const fn new() -> Self {
        PairIndex {
            list: List::new(),
            pair_k: [[0; PAIRS]; N],
            _pad3: PAD,
            listed: 0,
            pairs: 0,
            e_n: [[R::ZERO; PAIRS]; N],
            _pad4: PAD,
            e_s: [[R::ZERO; PAIRS]; N],
            _pad5: PAD,
            start: [0; N],
            sums: [[R::ZERO; 4]; N],
            _pad6: PAD,
            mobile: [R::ZERO; N],
            _pad10: PAD,
            ready: false,
        }
    }

    /// Forgets the pairs: not ready until the next [`PairIndex::index`].
    pub(crate) fn clear(&mut self) {
        self.ready = false;
    }

    /// Indexes the listed pairs of the grains `g` (the slots of `nbrs`,
    /// just rebuilt): pair list with its history and windows, lane
    /// masks, and the chunks near the periodic seam of a bed `width` wide:
    /// those with a pair whose first grain lies within `margin` of it (x
    /// below it, or above `width` less it; or x not a number). With
    /// `margin` at least the neighbour cut-off plus the skin, every pair
    /// whose separation can exceed half the width before the next rebuild
    /// is in a marked chunk: a listed pair across the seam has both grains,
    /// so its first, within the cut-off of it, and a grain moves less than
    /// half a skin between rebuilds. Not ready (the scalar step
    /// runs) if the capacities do not suit the lanes ([`lanes_fit`]), or
    /// the pairs with padding (`PAIRS` per grain) do not fit.
    pub(crate) fn index(
        &mut self,
        g: &Grains<R, N>,
        nbrs: &Neighbours<R, N, K>,
        width: R,
        margin: R,
    ) {
        let (count, other, spring) = (&nbrs.count, &nbrs.other, &nbrs.spring);
        let n = g.len.min(N);
        self.ready = false;
        // A new stamp before any pair changes (an RMW of one atomic: no
        // two draws alike; 2^64 of them would wrap).
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        {
            use core::sync::atomic::Ordering;
            self.list.stamp = STAMPS.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
        }
        let lanes = lanes::<R>();
        if !lanes_fit(N, K, lanes) {
            return;
        }
        for (mask, &fixed) in self.mobile.iter_mut().zip(&g.fixed).take(n) {
            *mask = R::from_raw(if fixed { 0 } else { u64::MAX });
        }
        self.mobile[n..].fill(R::ZERO);
        let mut list = PairList::<R, N> {
            i: self.list.pair_i.as_flattened_mut(),
            j: self.list.pair_j.as_flattened_mut(),
            k: self.pair_k.as_flattened_mut(),
            e_n: self.e_n.as_flattened_mut(),
            e_s: self.e_s.as_flattened_mut(),
            len: 0,
        };
        let per_chunk = (CHUNK * lanes).max(1);
        self.list.seam.fill(false);
        let grains = count.iter().zip(other).zip(spring).zip(&g.x).take(n);
        for (m, (((&c, js), springs), &x)) in grains.enumerate() {
            let own = usize::from(c).min(K);
            // A grain's pairs are consecutive: a new batch starts before them.
            if own > 0 && list.leaves_windows(m, &js[..own]) && !list.pad() {
                return;
            }
            let first = list.len;
            self.start[m] = first as u32;
            if !list.extend(m, &js[..own], &springs[..own], n) {
                return;
            }
            // The chunks of its pairs, if near the seam (or not a number).
            if own > 0 && !(x >= margin && x <= width - margin) {
                let chunks = first / per_chunk..=(list.len - 1) / per_chunk;
                if let Some(marks) = self.list.seam.get_mut(chunks) {
                    marks.fill(true);
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
        (self.listed, self.pairs) = (listed, pairs);
        self.ready = true;
    }

    /// Finds each batch's window controls ([`PairIndex::window_lanes`]) for the
    /// first `pairs` pairs, `lanes` per batch: false if a batch's first
    /// grains do not lie in its window.
    fn find_windows(&mut self, pairs: usize, lanes: usize) -> bool {
        let (pair_i, pair_j) = (
            self.list.pair_i.as_flattened(),
            self.list.pair_j.as_flattened(),
        );
        let pairs = pairs.min(pair_i.len()).min(pair_j.len());
        let per_lane = (8 / lanes.max(1)).max(1);
        let batches = pair_i[..pairs]
            .chunks_exact(lanes.max(1))
            .zip(pair_j[..pairs].chunks_exact(lanes.max(1)));
        let controls = self
            .list
            .window_lanes
            .iter_mut()
            .zip(&mut self.list.second_lanes);
        for ((batch, seconds), (control, second_control)) in batches.zip(controls) {
            let first = window_start::<N>(batch[0], lanes) as u32;
            if batch.iter().any(|&i| i.wrapping_sub(first) >= lanes as u32) {
                return false;
            }
            // Each pair's lane of the window, as `per_lane` 32-bit lanes.
            *control = [0; 8];
            for (entries, &i) in control.chunks_exact_mut(per_lane).zip(batch) {
                for (e, entry) in entries.iter_mut().enumerate() {
                    *entry = ((i - first) as usize * per_lane + e) as u8;
                }
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

    /// Chunks of pairs marked as near the seam, and chunks.
    #[cfg(test)]
    pub(crate) fn chunks_near_the_seam(&self) -> (usize, usize) {
        let chunks = self.pairs.div_ceil(CHUNK * lanes::<R>());
        let marked = self.list.seam.iter().take(chunks).filter(|&&s| s).count();
        (marked, chunks)
    }

    /// The index split into what the passes read and write ([`Parts`]).
    pub(crate) fn parts(&mut self) -> Parts<'_, R, N> {
        Parts {
            listed: Listed {
                list: &self.list,
                pairs: self.pairs,
            },
            e_n: self.e_n.as_flattened_mut(),
            e_s: self.e_s.as_flattened_mut(),
            sums: &mut self.sums,
            mobile: &self.mobile,
            start: &self.start,
            pair_k: &self.pair_k,
        }
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
    /// scalar step and the rebuild work on the slots.
    pub(crate) fn history_to_slots(&mut self, spring: &mut [[Spring<R>; K]; N]) {
        if !self.ready {
            return;
        }
        self.ready = false;
        let (e_n, e_s) = (self.e_n.as_flattened(), self.e_s.as_flattened());
        let (pair_i, pair_k) = (self.list.pair_i.as_flattened(), self.pair_k.as_flattened());
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

/// The pair list of the pair index as every range of the pair pass reads
/// it (shared), and the pairs in whole batches.
#[derive(Clone, Copy)]
pub(crate) struct Listed<'a, const N: usize> {
    pub(crate) list: &'a List<N>,
    pub(crate) pairs: usize,
}

/// The pair index split for the passes ([`PairIndex::parts`]): the pair
/// list (shared), the spring history, the grains' sums and lane masks, and
/// each grain's first pair.
pub(crate) struct Parts<'a, R: Real, const N: usize> {
    pub(crate) listed: Listed<'a, N>,
    pub(crate) e_n: &'a mut [R],
    pub(crate) e_s: &'a mut [R],
    pub(crate) sums: &'a mut [[R; 4]; N],
    pub(crate) mobile: &'a [R; N],
    pub(crate) start: &'a [u32; N],
    /// Whether each pair is a padding pair (w, w), which has no slot.
    pub(crate) pair_k: &'a [[u8; PAIRS]; N],
}

/// The pair list being built by [`PairIndex::index`]: first and second grain,
/// slot and history per pair, `len` pairs so far, [`lanes`] per batch.
struct PairList<'a, R, const N: usize> {
    i: &'a mut [u32],
    j: &'a mut [u32],
    k: &'a mut [u8],
    e_n: &'a mut [R],
    e_s: &'a mut [R],
    len: usize,
}

impl<R: Real, const N: usize> PairList<'_, R, N> {
    /// The places `q..end` of every array of the list (None: past its
    /// end).
    fn places(&mut self, q: usize, end: usize) -> Option<Places<'_, R>> {
        Some(Places {
            i: self.i.get_mut(q..end)?,
            j: self.j.get_mut(q..end)?,
            k: self.k.get_mut(q..end)?,
            e_n: self.e_n.get_mut(q..end)?,
            e_s: self.e_s.get_mut(q..end)?,
        })
    }

    /// Appends grain i's pairs (i, j) of slots 0, 1, … with second grains
    /// `js` and histories `springs` (as many): false if full, or a j not
    /// after i or not below `n`.
    fn extend(&mut self, i: usize, js: &[u32], springs: &[Spring<R>], n: usize) -> bool {
        let (q, own) = (self.len, js.len().min(springs.len()));
        let end = q + own;
        let Some(p) = self.places(q, end) else {
            return false;
        };
        for k in 0..own {
            let j = js[k] as usize;
            if j <= i || j >= n {
                return false;
            }
            (p.i[k], p.j[k], p.k[k]) = (i as u32, j as u32, k as u8);
            (p.e_n[k], p.e_s[k]) = (springs[k].e_n, springs[k].e_s);
        }
        self.len = end;
        true
    }

    /// The first grain of the batch being filled (None: none is).
    fn window_of_batch(&self) -> Option<usize> {
        let filled = self.len % lanes::<R>();
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
            let lanes = lanes::<R>();
            in_second_window::<N>(window_start::<N>(first as u32, lanes), j, lanes)
        };
        m - w >= lanes::<R>() || js.iter().any(|&j| !holds(w, j) && holds(m, j))
    }

    /// Fills the batch being filled with pairs (w, w) of its first grain w:
    /// coincident, so they keep a zero history and exert no force. False
    /// if full.
    fn pad(&mut self) -> bool {
        let Some(w) = self.window_of_batch() else {
            return true;
        };
        let (q, end) = (self.len, self.len.next_multiple_of(lanes::<R>()));
        let Some(p) = self.places(q, end) else {
            return false;
        };
        p.i.fill(w as u32);
        p.j.fill(w as u32);
        p.k.fill(SELF_PAIR);
        p.e_n.fill(R::ZERO);
        p.e_s.fill(R::ZERO);
        self.len = end;
        true
    }
}

/// Places of every array of a [`PairList`] (its first grain, second grain,
/// slot and history).
struct Places<'a, R> {
    i: &'a mut [u32],
    j: &'a mut [u32],
    k: &'a mut [u8],
    e_n: &'a mut [R],
    e_s: &'a mut [R],
}

/// The first grain of the window of a batch of pairs whose first pair's
/// first grain is `i`: i itself, or the last window that ends within the
/// grains' arrays.
#[inline]
pub(super) fn window_start<const N: usize>(i: u32, lanes: usize) -> usize {
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
/// is), N a whole number of groups and the pair places (N · [`PAIRS`]) a
/// whole number of chunks (the pair pass reads each chunk's history as one
/// array).
pub(crate) const fn lanes_fit(n: usize, k: usize, lanes: usize) -> bool {
    lanes > 0
        && n.is_power_of_two()
        && k.is_power_of_two()
        && n >= lanes
        && n * PAIRS >= CHUNK * lanes
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
    /// Lanes need powers of two, whole groups and whole chunks of pair
    /// places: f32's 8 lanes take N = 16 but not 8 (32 places, half a
    /// chunk of 64); f64's 4 lanes take N = 8 but not 4.
    #[test]
    fn lanes_fit_whole_groups_and_chunks() {
        assert!(lanes_fit(16, 4, 8) && !lanes_fit(8, 4, 8));
        assert!(lanes_fit(8, 4, 4) && !lanes_fit(4, 4, 4));
        assert!(!lanes_fit(1000, 8, 4) && !lanes_fit(1024, 6, 4) && !lanes_fit(1024, 8, 0));
    }

    #[test]
    fn second_grains_lie_in_windows_but_across_the_boundary() {
        const N: usize = 64;
        const K: usize = 4;
        let n = 40;
        let mut batch = std::boxed::Box::new(PairIndex::<f32, N, K>::new());
        let mut nbrs = std::boxed::Box::new(Neighbours::<f32, N, K>::new());
        for m in 0..n {
            let js = [m + 1, m + 13].into_iter().filter(|&j| j < n);
            let js = js.chain((m == 3).then_some(39));
            for j in js {
                nbrs.push_history(m, j, Spring::ZERO);
            }
        }
        let (count, other) = (nbrs.count, nbrs.other);
        let mut grains = std::boxed::Box::new(Grains::<f32, N>::new());
        grains.len = n;
        batch.index(&grains, &nbrs, 1.0, 1.0);
        assert!(batch.ready);
        let (pair_i, pair_j) = (
            batch.list.pair_i.as_flattened(),
            batch.list.pair_j.as_flattened(),
        );
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
                let first = usize::from(batch.list.window_lanes[t][l]);
                assert_eq!(pair_i[q] as usize, start + first);
            }
            if batch.list.second_lanes[t][0] == FAR {
                far += 1;
                assert!(pairs.clone().any(|q| (pair_i[q], pair_j[q]) == (3, 39)));
                continue;
            }
            for (l, q) in pairs.enumerate() {
                let second = usize::from(batch.list.second_lanes[t][l]);
                assert!(second < second_window(8));
                assert_eq!(pair_j[q] as usize, start + second);
            }
        }
        assert_eq!(far, 1);
    }
}
