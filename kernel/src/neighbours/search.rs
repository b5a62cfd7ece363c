//! The search of a build (module docs): each grain's list over a range of
//! grains ([`Search`]), a phase of the phased step.

use super::bins::{bucket, Bins};
use super::found::{At, Found};
use super::merge_into_slots;
use crate::contact::Spring;
use crate::error::{Capacity, Error};
use crate::executor::Phase;
use crate::grains::Grains;
use crate::real::Real;

/// The search of a range of grains' lists ([`Neighbours::search`]): each
/// grain i of the range, in ascending order, tests the grains of the nine
/// bins around it that follow it in its buckets (the buckets' `cursors`
/// drop each grain once searched, so only grains j > i are kept) and
/// replaces its slots by those within the cut-off, keeping their history.
/// Each grain's list depends on nothing else, so the range can be cut at
/// any grain, each part searching on its own ([`Search::split_at`]; the
/// phased step runs it as a phase); the lists are the same.
pub(crate) struct Search<'a, R: Real, const N: usize, const K: usize> {
    pub(super) g: &'a Grains<R, N>,
    pub(super) bins: Bins<R>,
    pub(super) order: &'a [u32],
    /// The grains' positions and radii in `order`'s order (lanes only).
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    pub(super) sorted: &'a super::lanes::Sorted<R, N>,
    pub(super) end: &'a [u32],
    /// The range's first grain.
    pub(super) lo: usize,
    pub(super) count: &'a mut [u8],
    pub(super) other: &'a mut [[u32; K]],
    pub(super) spring: &'a mut [[Spring<R>; K]],
    /// Per bucket, where its grains after the last one searched start in
    /// `order` (`ready`), or room for them, set when the range runs.
    pub(super) cursors: &'a mut [u32],
    pub(super) ready: bool,
    /// Room for the cursors of further ranges, `bins.buckets` each.
    pub(super) spare: &'a mut [u32],
}

/// The search as a phase of the phased step: each grain's list depends on
/// nothing else, so any cut gives the same lists; the first range's error
/// in grain order.
impl<R: Real, const N: usize, const K: usize> Phase for Search<'_, R, N, K> {
    type Output = Result<(), Error>;

    /// Grains in the range.
    fn grains(&self) -> usize {
        self.count.len()
    }

    /// The first `mid` grains and the rest, the rest with cursors of its
    /// own from `spare` and `spare`'s other room shared by grains; not cut
    /// (the whole and an empty range) without room for them.
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (len, buckets) = (self.count.len(), self.bins.buckets);
        let mid = mid.min(len);
        if self.spare.len() < buckets || mid == 0 || mid == len {
            let empty = Search {
                lo: self.lo + len,
                count: &mut [],
                other: &mut [],
                spring: &mut [],
                cursors: &mut [],
                ready: true,
                spare: &mut [],
                ..self
            };
            return (self, empty);
        }
        let (cursors, spare) = self.spare.split_at_mut(buckets);
        let first_share = spare.len() / buckets * mid / len * buckets;
        let (spare_first, spare_second) = spare.split_at_mut(first_share);
        let (count, other, spring) = (
            self.count.split_at_mut(mid),
            self.other.split_at_mut(mid),
            self.spring.split_at_mut(mid),
        );
        let second = Search {
            lo: self.lo + mid,
            count: count.1,
            other: other.1,
            spring: spring.1,
            cursors,
            ready: false,
            spare: spare_second,
            ..self
        };
        let first = Search {
            count: count.0,
            other: other.0,
            spring: spring.0,
            spare: spare_first,
            ..self
        };
        (first, second)
    }

    /// Searches the range's grains: their lists, or the capacity error of
    /// a grain with more than `K` neighbours (or [`FOUND_MAX`] − 1).
    fn run(self) -> Result<(), Error> {
        let (g, bins, order, end) = (self.g, self.bins, self.order, self.end);
        let (nx, buckets) = (bins.nx, bins.buckets);
        // Both `buckets` long: a bucket's cursor and end checked once.
        // The sort sizes `end` to the buckets; the cursors are empty only
        // for an empty range.
        debug_assert!(end.len() >= buckets);
        let (Some(cursors), Some(end)) = (self.cursors.get_mut(..buckets), end.get(..buckets))
        else {
            return Ok(());
        };
        if !self.ready {
            // Each bucket's start (the end of the one before), past the
            // grains before the range.
            let mut start = 0;
            for (cursor, &end) in cursors.iter_mut().zip(end) {
                *cursor = start;
                start = end;
            }
            for i in 0..self.lo {
                #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
                let (.., b) = self.sorted.bin_of(&bins, i);
                #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
                let (.., b) = bins.bucket_of(g, i);
                if let Some(cursor) = cursors.get_mut(b) {
                    *cursor += 1;
                }
            }
        }
        let half_width = bins.width * R::HALF;
        let slots = self
            .count
            .iter_mut()
            .zip(self.other.iter_mut())
            .zip(self.spring.iter_mut());
        let mut found = Found::new();
        for (i, ((count, other), spring)) in (self.lo..).zip(slots) {
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            let (bx, by, own) = self.sorted.bin_of(&bins, i);
            #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
            let (bx, by, own) = bins.bucket_of(g, i);
            // Grains are searched in ascending order, so each bucket's grains
            // before i are gone from it: i first, then those searched.
            if let Some(first) = cursors.get_mut(own) {
                *first += 1;
            }
            // The bins left and right, periodic in x (nx ≥ 3).
            let left = if bx == 0 { nx - 1 } else { bx - 1 };
            let right = if bx + 1 >= nx { 0 } else { bx + 1 };
            // The runs of `order` to test: a bucket's grains not yet
            // searched, or a row's three buckets.
            let (mut runs, mut count_runs) = ([(0, 0); 9], 0);
            let mut searched = [usize::MAX; 9];
            // A row's three bins are three buckets side by side in `order`
            // (its middle bucket's neighbours) exactly when no bucket
            // repeats, the bin is not at the seam (a wrap would need nx a
            // multiple of the buckets, which are at least 3 nx) and the
            // middle bucket is neither the first nor the last.
            let inner = !bins.may_repeat && bx >= 1 && bx + 1 < nx;
            for (row, dy) in (0..3u32).enumerate() {
                let Some(nby) = (by + dy).checked_sub(1) else {
                    continue;
                };
                let c = bucket(bx, nby, nx, buckets);
                if inner && c >= 1 && c + 1 < buckets {
                    // One run, from the left one's first grain after those
                    // searched (the middle and right ones' searched grains
                    // are j ≤ i).
                    push_run(&mut runs, &mut count_runs, (cursors[c - 1], end[c + 1]));
                    continue;
                }
                let [l, r] = [left, right].map(|nbx| bucket(nbx, nby, nx, buckets));
                for (s, b) in [l, c, r].into_iter().enumerate() {
                    if bins.may_repeat {
                        if searched.contains(&b) {
                            continue;
                        }
                        searched[3 * row + s] = b;
                    }
                    push_run(&mut runs, &mut count_runs, (cursors[b], end[b]));
                }
            }
            let at = At {
                i,
                x: g.x[i],
                y: g.y[i],
                r: g.r[i],
                skin: bins.skin,
                width: bins.width,
                half_width,
            };
            // Two bins or more from the seam (bins 2 to nx − 3), every
            // grain's periodic image is more than a bin (≥ the cut-off)
            // away, rounding included, so the separation itself decides
            // (one bin would do but for rounding when the cut-off is
            // exactly a bin, which no test provokes: the second bin is a
            // margin). Only a fixed grain tests for fixed–fixed pairs.
            let seam = bx < 2 || bx + 2 >= nx;
            let runs = &runs[..count_runs.min(9)];
            found.len = 0;
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            let in_lanes = !g.fixed[i]
                && super::lanes::test_in_lanes(&at, seam, self.sorted, order, runs, &mut found);
            #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
            let in_lanes = false;
            match (in_lanes, seam, g.fixed[i]) {
                (true, ..) => {}
                (false, false, false) => at.test::<N, false, false>(g, order, runs, &mut found),
                (false, true, false) => at.test::<N, true, false>(g, order, runs, &mut found),
                (false, false, true) => at.test::<N, false, true>(g, order, runs, &mut found),
                (false, true, true) => at.test::<N, true, true>(g, order, runs, &mut found),
            }
            let found = found.sorted(K).ok_or(Error::CapacityExceeded {
                what: Capacity::NeighboursPerGrain,
                capacity: K,
            })?;
            merge_into_slots(count, other, spring, found);
        }
        Ok(())
    }

    fn merge(first: Self::Output, second: Self::Output) -> Self::Output {
        first.and(second)
    }
}

/// Appends `run` to the first `count` of `runs` (at most nine: three rows
/// of one run or three buckets).
#[inline(always)]
fn push_run(runs: &mut [(u32, u32); 9], count: &mut usize, run: (u32, u32)) {
    if let Some(slot) = runs.get_mut(*count) {
        *slot = run;
        *count += 1;
    }
}
