//! Neighbour search and contact-history storage.
//!
//! Each grain i owns `K` slots holding the grains j > i within the cut-off
//! (d_i + d_j)/2 + skin, sorted by j, each with the pair's spring history.
//! The contact loop therefore visits pairs in the fixed order (i ascending,
//! j ascending), whatever the binning: that order, and skipping pairs that
//! do not overlap, make results independent of the skin, of when the list is
//! rebuilt and of the bins, bit for bit.
//!
//! The list is rebuilt by binning the grains (square bins, side ≥ largest
//! cut-off, periodic in x) when grains may have moved half a skin since the last build. Each
//! build sizes the skin from the fastest grain's speed, between a floor and
//! the configured skin ([`adapted_skin`]): a still bed lists fewer pairs that
//! are not in contact, a moving one rebuilds seldom. Bins are
//! hashed into one bucket per grain, so any bed height fits; a bucket shared by two
//! bins only costs extra distance checks. The grains are counting-sorted by
//! bucket and searched in ascending order, each bucket dropping a grain
//! once it is searched, so a search meets only grains j > i, and tests
//! them without a branch on the outcome; where there are vector lanes
//! (x86-64 with AVX2) the sort also notes each grain's bin and copies the
//! grains' positions and radii in that order, and a mobile grain tests a
//! run of candidates four (f64) or eight (f32) at a time (`lanes`), with
//! the same lists. A grain within the cut-off lies in one of the nine bins
//! around (a bin is at least a cut-off wide), so the distance test alone
//! decides. History moves from the old slots to
//! the new ones by merging the two sorted lists, so no contact is lost.
//! A build is a serial sort ([`Neighbours::sort`]) and a search
//! ([`Search`]) that can be cut into ranges of grains run on their own
//! (the phased step runs it on the host's threads): a range after the
//! first sets its bucket cursors past the grains before it, and the lists
//! are those of the whole.
//!
//! The batched step's pair index, built from these slots, is not kept here:
//! it is a field of [`crate::Sim`] (`step::index`), which lends the slots
//! the history it holds ([`Neighbours::contacts`]).

mod bins;
mod found;
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
mod lanes;
mod search;

use bins::bucket_count;
pub(crate) use bins::Bins;
pub(crate) use search::Search;

use crate::contact::Spring;
use crate::error::Error;
use crate::grains::Grains;
use crate::real::Real;

/// Steps of the fastest grain's travel that a build's skin leaves room for
/// ([`adapted_skin`]).
const SKIN_STEPS: f64 = 100.0;

/// The smallest skin, as a fraction of the configured one.
const SKIN_FLOOR: f64 = 0.3;

/// The skin of a build: room for [`SKIN_STEPS`] steps of the fastest
/// grain's travel per step at its speed then (the list is stale once twice
/// the travel exceeds the skin), at least [`SKIN_FLOOR`] of the `largest`
/// and at most the `largest` (the floor if the travel is NaN). Results do
/// not depend on it; it depends only on the grains' state (a run restored
/// from a checkpoint rebuilds as one that rebuilt at that point). A
/// settled bed at the floor lists ~9 % fewer pairs than at the largest
/// (docs/performance.md).
fn adapted_skin<R: Real>(largest: R, step_travel: R) -> R {
    let floor = largest * R::from_f64(SKIN_FLOOR);
    let wanted = step_travel * R::from_f64(2.0 * SKIN_STEPS);
    if wanted > largest {
        largest
    } else if wanted > floor {
        wanted
    } else {
        floor
    }
}

/// Neighbour slots with spring history, and the binning scratch.
#[derive(Debug, Clone)]
pub struct Neighbours<R: Real, const N: usize, const K: usize> {
    /// Used slots per grain.
    pub(crate) count: [u8; N],
    /// Neighbour index j (> i) per slot, ascending.
    pub(crate) other: [[u32; K]; N],
    /// Spring history per slot.
    pub(crate) spring: [[Spring<R>; K]; N],
    /// Per bucket, where its grains not yet searched start in `order`
    /// (during a build), and where they end.
    first: [u32; N],
    end: [u32; N],
    /// The grains sorted by bucket (a counting sort), ascending within
    /// each.
    order: [u32; N],
    /// Each grain's bin, and the grains' positions and radii in `order`'s
    /// order (the search in lanes).
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    sorted: lanes::Sorted<R, N>,
    /// Largest distance any grain may have travelled since the last build.
    pub(crate) travel: R,
    /// Skin (m) of the last build, the configured (largest) skin, and the
    /// integration step.
    pub(crate) skin: R,
    skin_max: R,
    step_dt: R,
    /// Whether the list must be rebuilt before the next use.
    pub(crate) stale: bool,
    /// Rebuilds since the simulation was reset (a diagnostic).
    pub(crate) rebuilds: u64,
    /// Changes of the lists (rebuilds and clears), never reset: what the
    /// phased step's list of incoming pairs was built from
    /// ([`crate::Phases`]).
    pub(crate) generation: u64,
    /// Largest cut-off of the last build: largest diameter + skin.
    pub(crate) cutoff: R,
}

impl<R: Real, const N: usize, const K: usize> Neighbours<R, N, K> {
    /// Empty storage (all zero bits).
    pub const fn new() -> Self {
        Neighbours {
            count: [0; N],
            other: [[0; K]; N],
            spring: [[Spring::ZERO; K]; N],
            first: [0; N],
            end: [0; N],
            order: [0; N],
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            sorted: lanes::Sorted::new(),
            travel: R::ZERO,
            skin: R::ZERO,
            skin_max: R::ZERO,
            step_dt: R::ZERO,
            stale: false,
            rebuilds: 0,
            generation: 0,
            cutoff: R::ZERO,
        }
    }

    /// Forgets every pair and its history.
    pub(crate) fn clear(&mut self) {
        self.count = [0; N];
        self.travel = R::ZERO;
        self.stale = true;
        self.rebuilds = 0;
        self.generation = self.generation.wrapping_add(1);
    }

    /// Sets the largest skin (m) and the integration step (s).
    pub(crate) fn set_skin(&mut self, skin: R, step_dt: R) {
        (self.skin, self.skin_max, self.step_dt) = (skin, skin, step_dt);
    }

    /// Records one step's largest grain displacement; marks the list stale
    /// once two grains approaching each other could have closed the skin.
    #[inline]
    pub(crate) fn add_travel(&mut self, distance: R) {
        self.travel += distance;
        if self.travel + self.travel > self.skin {
            self.stale = true;
        }
    }

    /// Bins the grains and rebuilds every grain's slots, carrying
    /// the history of pairs present in both lists. Fixed–fixed pairs are
    /// never listed (they exert no force). The slots must hold the history
    /// (the batched step's pair index gives it back first). A simulation
    /// runs the three parts itself (`Sim::rebuild_in`).
    #[cfg(test)]
    pub(crate) fn rebuild(&mut self, g: &Grains<R, N>, width: R, y_min: R) -> Result<(), Error> {
        let bins = self.sort(g, width, y_min)?;
        crate::executor::Phase::run(self.search(g, bins, &mut []))?;
        self.built();
        Ok(())
    }

    /// The first part of a build: sizes the skin from the fastest grain
    /// and the bins from the largest cut-off, and counting-sorts the grains
    /// by bucket (each bucket's grains ascending, `first` its start, `end`
    /// its end); the [`Bins`] a search reads.
    pub(crate) fn sort(&mut self, g: &Grains<R, N>, width: R, y_min: R) -> Result<Bins<R>, Error> {
        let n = g.len.min(N);
        let (mut r_max, mut max_v2) = (R::ZERO, R::ZERO);
        for ((&r, &u), &v) in g.r[..n].iter().zip(&g.u[..n]).zip(&g.v[..n]) {
            r_max = R::max(r_max, r);
            max_v2 = R::max(max_v2, u * u + v * v);
        }
        // At least three bins across, so the 3×3 stencil of bins visits distinct
        // bins, at any skin up to the largest.
        let fewest = libm::floor((width / (r_max + r_max + self.skin_max)).to_f64());
        if fewest.is_nan() || fewest < 3.0 {
            return Err(Error::InvalidParameter {
                name: "width",
                value: width.to_f64(),
                allowed: ">= 3 × (largest diameter + skin)",
            });
        }
        self.skin = adapted_skin(self.skin_max, R::sqrt(max_v2) * self.step_dt);
        let cutoff = r_max + r_max + self.skin;
        self.cutoff = cutoff;
        let nx_f = libm::floor((width / cutoff).to_f64());
        let nx = if nx_f > 65_536.0 {
            65_536u32
        } else {
            nx_f as u32
        };
        let bin = width / R::from_f64(nx as f64);
        // About one bucket per grain (clearing costs O(n), not O(N)), a
        // power of two so that a bin's bucket is a mask, not a division.
        let buckets = bucket_count(n, N);
        let bins = Bins {
            nx,
            inv_bin: R::ONE / bin,
            y_min,
            buckets,
            // The nine bins around a grain are nine buckets unless the bed
            // is so thin that their cells (within 3 nx of each other) wrap
            // around the buckets; then a bucket met twice is searched once.
            may_repeat: (buckets as u64) < 3 * u64::from(nx),
            width,
            skin: self.skin,
        };
        // Counting sort by bucket: each bucket's end, then its grains placed
        // from the last down, so that each lists its grains in ascending
        // order, from `first` (each bucket's start once all are placed).
        self.end[..buckets].fill(0);
        for i in 0..n {
            let (_bx, _by, b) = bins.bucket_of(g, i);
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            self.sorted.note_bin(i, _bx, _by);
            self.end[b] += 1;
        }
        let mut placed = 0;
        for end in &mut self.end[..buckets] {
            placed += *end;
            *end = placed;
        }
        self.first[..buckets].copy_from_slice(&self.end[..buckets]);
        for i in (0..n).rev() {
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            let (.., b) = self.sorted.bin_of(&bins, i);
            #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
            let (.., b) = bins.bucket_of(g, i);
            let place = self.first[b] - 1;
            self.first[b] = place;
            self.order[place as usize] = i as u32;
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            self.sorted.place(place as usize, g.x[i], g.y[i], g.r[i]);
        }
        Ok(bins)
    }

    /// The second part of a build: the search of every grain's list
    /// ([`Search`]) over the sort's `bins`, the whole bed one range whose
    /// bucket cursors are `first`; `spare` holds the cursors of further
    /// ranges if it is cut (`bins.buckets` each; none: it is not cut).
    pub(crate) fn search<'a>(
        &'a mut self,
        g: &'a Grains<R, N>,
        bins: Bins<R>,
        spare: &'a mut [u32],
    ) -> Search<'a, R, N, K> {
        let n = g.len.min(N);
        Search {
            g,
            bins,
            order: &self.order,
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            sorted: &self.sorted,
            end: &self.end,
            lo: 0,
            count: &mut self.count[..n],
            other: &mut self.other[..n],
            spring: &mut self.spring[..n],
            cursors: &mut self.first,
            ready: true,
            spare,
        }
    }

    /// The end of a build: the travel since it 0, the lists fresh.
    pub(crate) fn built(&mut self) {
        self.travel = R::ZERO;
        self.stale = false;
        self.rebuilds = self.rebuilds.saturating_add(1);
        self.generation = self.generation.wrapping_add(1);
    }

    /// The history of grain i's used slot k, wherever it lives: `lent`
    /// gives it while the batched step's pair index holds it, else the slot.
    #[inline]
    fn spring_at(
        &self,
        i: usize,
        k: usize,
        lent: impl Fn(usize, usize) -> Option<Spring<R>>,
    ) -> Spring<R> {
        lent(i, k).unwrap_or(self.spring[i][k])
    }

    /// The pairs (i, j, history) with non-zero spring history among the first
    /// `n` grains, in (i, j) order: the contacts (`lent`: see
    /// [`Neighbours::spring_at`]).
    pub(crate) fn contacts<'a>(
        &'a self,
        n: usize,
        lent: impl Fn(usize, usize) -> Option<Spring<R>> + Copy + 'a,
    ) -> impl Iterator<Item = (usize, usize, Spring<R>)> + 'a {
        (0..n.min(N)).flat_map(move |i| {
            let count = usize::from(self.count[i]).min(K);
            (0..count).filter_map(move |k| {
                let (j, h) = (self.other[i][k] as usize, self.spring_at(i, k, lent));
                let active = h.e_n != R::ZERO || h.e_s != R::ZERO;
                (active && j < n).then_some((i, j, h))
            })
        })
    }

    /// Appends pair (i, j) with its history to grain i's slots (restoring a
    /// checkpoint: pairs arrive in (i, j) order and the caller has checked
    /// that at most `K` arrive per grain).
    pub(crate) fn push_history(&mut self, i: usize, j: usize, spring: Spring<R>) {
        let Some(count) = self.count.get_mut(i) else {
            return;
        };
        let k = usize::from(*count);
        if k < K {
            self.other[i][k] = j as u32;
            self.spring[i][k] = spring;
            *count += 1;
        }
    }

    /// The history of pair (i, j), if listed (`lent`: see
    /// [`Neighbours::spring_at`]).
    pub(crate) fn history(
        &self,
        i: usize,
        j: usize,
        lent: impl Fn(usize, usize) -> Option<Spring<R>>,
    ) -> Option<Spring<R>> {
        let (a, b) = if i < j { (i, j) } else { (j, i) };
        let count = usize::from(*self.count.get(a)?).min(K);
        let slots = self.other.get(a)?;
        let k = slots[..count].iter().position(|&o| o as usize == b)?;
        Some(self.spring_at(a, k, lent))
    }
}

impl<R: Real, const N: usize, const K: usize> Default for Neighbours<R, N, K> {
    fn default() -> Self {
        Self::new()
    }
}

/// Replaces a grain's `count` slots (`other`, `spring`) by `found`
/// (sorted), keeping the history of pairs present before.
#[inline(always)]
pub(super) fn merge_into_slots<R: Real, const K: usize>(
    count: &mut u8,
    other: &mut [u32; K],
    spring: &mut [Spring<R>; K],
    found: &[u32],
) {
    // Most builds list the pairs listed before (a word-by-word test: the
    // lists are a few words long), and need no call.
    if usize::from(*count) == found.len() && other.iter().zip(found).all(|(a, b)| a == b) {
        return;
    }
    replace_slots(count, other, spring, found);
}

/// [`merge_into_slots`] where the list changed.
#[inline(never)]
fn replace_slots<R: Real, const K: usize>(
    count: &mut u8,
    other: &mut [u32; K],
    spring: &mut [Spring<R>; K],
    found: &[u32],
) {
    let old_count = usize::from(*count).min(K);
    let (old_other, old_spring) = (*other, *spring);
    let mut k_old = 0;
    for (k, &j) in found.iter().enumerate().take(K) {
        while k_old < old_count && old_other[k_old] < j {
            k_old += 1;
        }
        other[k] = j;
        spring[k] = if k_old < old_count && old_other[k_old] == j {
            old_spring[k_old]
        } else {
            Spring::ZERO
        };
    }
    *count = found.len().min(K) as u8;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::periodic::periodic;
    use std::boxed::Box;
    use std::vec::Vec;

    /// Grain i's listed neighbours.
    fn listed<const N: usize, const K: usize>(nbrs: &Neighbours<f64, N, K>, i: usize) -> &[u32] {
        &nbrs.other[i][..usize::from(nbrs.count[i])]
    }

    /// Uniform numbers in [0, 1) from a xorshift seeded with `state`.
    fn uniform(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Every grain j > i within r_i + r_j + skin of grain i (periodic in
    /// x), unless both are fixed: the search by brute force.
    fn brute_force<R: Real, const N: usize>(
        g: &Grains<R, N>,
        width: R,
        skin: R,
        i: usize,
    ) -> Vec<u32> {
        (i + 1..g.len)
            .filter(|&j| !(g.fixed[i] && g.fixed[j]))
            .filter(|&j| {
                let ddx = periodic(g.x[j] - g.x[i], width, width * R::HALF);
                let ddy = g.y[j] - g.y[i];
                let reach = g.r[i] + g.r[j] + skin;
                ddx * ddx + ddy * ddy < reach * reach
            })
            .map(|j| j as u32)
            .collect()
    }

    /// Random grains (a seeded xorshift): dense beds, thin strips whose
    /// bins share buckets (more bins across than a third of the buckets),
    /// grains at the periodic seam and far above the bed, fixed grains.
    /// Each build lists exactly the brute force's pairs, ascending, and
    /// keeps the history of the pairs listed before; a grain with more
    /// than K fails the build.
    #[test]
    fn the_search_lists_exactly_the_pairs_within_the_cutoff() {
        const N: usize = 256;
        const K: usize = 8;
        let mut uniform = uniform(0x9e37_79b9_7f4a_7c15);
        let (mut builds, mut overflows, mut kept) = (0, 0, 0);
        for case in 0..400 {
            let mut g = Box::new(Grains::<f64, N>::new());
            // Every tenth bed full: runs that end at the last place of the
            // sorted grains (fewer than a vector's lanes left).
            let n = 1 + (uniform() * N as f64) as usize % N;
            let n = if case % 10 == 9 { N } else { n };
            let width = 3.5 + uniform() * [2.0, 40.0, 200.0][case % 3];
            let rows = n as f64 / width;
            let height = rows * [0.7, 2.0, 20.0][case / 3 % 3] * (1.0 + uniform());
            g.len = n;
            for i in 0..n {
                g.r[i] = 0.3 + 0.2 * uniform();
                g.x[i] = match (case + i) % 7 {
                    0 => width * (1.0 - 1e-3 * uniform()),
                    1 => 1e-3 * uniform(),
                    _ => width * uniform(),
                };
                g.y[i] = height * uniform() + if i % 37 == 5 { 1e4 } else { 0.0 };
                g.fixed[i] = g.y[i] < 0.2 * height && i % 2 == 0;
            }
            let mut nbrs = Box::new(Neighbours::<f64, N, K>::new());
            nbrs.set_skin(0.1, 1e-4);
            // A first build, its history marked, then a build after a move.
            for round in 0..2 {
                let built = nbrs.rebuild(&g, width, -0.5);
                assert_eq!(nbrs.skin, 0.1 * SKIN_FLOOR);
                let expected: Vec<Vec<u32>> = (0..n)
                    .map(|i| brute_force(&g, width, nbrs.skin, i))
                    .collect();
                if expected.iter().any(|js| js.len() > K) {
                    assert!(built.is_err(), "case {case}: more than K found");
                    overflows += 1;
                    break;
                }
                assert!(built.is_ok(), "case {case}: {built:?}");
                builds += 1;
                for (i, js) in expected.iter().enumerate() {
                    assert_eq!(listed(&nbrs, i), &js[..], "case {case}, grain {i}");
                    for (k, &j) in js.iter().enumerate() {
                        let e_n = nbrs.spring[i][k].e_n;
                        if round == 1 && e_n != 0.0 {
                            assert_eq!(e_n, (i * N) as f64 + f64::from(j));
                            kept += 1;
                        }
                        nbrs.spring[i][k].e_n = (i * N) as f64 + f64::from(j);
                    }
                }
                for i in 0..n {
                    g.x[i] = (g.x[i] + 0.05 * uniform()) % width;
                    g.y[i] += 0.05 * uniform();
                }
            }
        }
        assert!(
            builds > 500 && overflows > 10 && kept > 1000,
            "{builds} {overflows} {kept}"
        );
    }

    /// Bins exactly a cut-off wide (no skin, every radius the largest or
    /// less), 3 to 9 and 40 across, in f32 and f64: grains on the bins'
    /// edges and a few ulps either side, at 0 and just below the width, in
    /// rows a cut-off apart. Every list is the brute force's: the search's
    /// tests without the periodic image (two bins or more from the seam)
    /// decide as the image would, rounding included.
    fn edges_list_what_the_brute_force_lists<R: Real>(seed: u64) {
        const N: usize = 128;
        const K: usize = 16;
        let mut uniform = uniform(seed);
        let mut checked = 0;
        for case in 0..600 {
            let across = [3u32, 4, 5, 6, 7, 9, 40][case % 7];
            let r_max = R::from_f64([0.5, 0.3][case / 7 % 2]);
            let cut = r_max + r_max;
            let width = cut * R::from_f64(f64::from(across));
            let bin = width.to_f64() / f64::from(across);
            let mut g = Box::new(Grains::<R, N>::new());
            g.len = 2 + case % (N - 2);
            for i in 0..g.len {
                let edge = (uniform() * f64::from(across)) as u32;
                let ulps = (uniform() * 7.0) as i64 - 3;
                let x = match (i + case) % 5 {
                    0 => R::from_f64(f64::from(edge) * bin),
                    1 => R::ZERO,
                    2 => R::from_f64(width.to_f64() * (1.0 - 1e-7 * uniform())),
                    _ => R::from_f64(f64::from(edge) * bin * (1.0 + ulps as f64 * 1e-7)),
                };
                g.x[i] = if x >= width || x < R::ZERO {
                    R::ZERO
                } else {
                    x
                };
                g.y[i] = cut * R::from_f64(f64::from((uniform() * 3.0) as u32));
                g.r[i] = if uniform() < 0.7 {
                    r_max
                } else {
                    r_max * R::from_f64(uniform())
                };
                g.fixed[i] = uniform() < 0.2;
            }
            let mut nbrs = Box::new(Neighbours::<R, N, K>::new());
            nbrs.set_skin(R::ZERO, R::ONE);
            let expected: Vec<Vec<u32>> = (0..g.len)
                .map(|i| brute_force(&g, width, R::ZERO, i))
                .collect();
            let built = nbrs.rebuild(&g, width, R::ZERO);
            if expected.iter().any(|js| js.len() > K) {
                assert!(built.is_err(), "case {case}");
                continue;
            }
            assert!(built.is_ok(), "case {case}: {built:?}");
            for (i, js) in expected.iter().enumerate() {
                let listed = &nbrs.other[i][..usize::from(nbrs.count[i])];
                assert_eq!(listed, &js[..], "{} case {case}, grain {i}", R::NAME);
                checked += js.len();
            }
        }
        assert!(checked > 5000, "{checked}");
    }

    #[test]
    fn bins_a_cutoff_wide_list_what_the_brute_force_lists_f32() {
        edges_list_what_the_brute_force_lists::<f32>(0x2545_f491_4f6c_dd1d);
    }

    #[test]
    fn bins_a_cutoff_wide_list_what_the_brute_force_lists_f64() {
        edges_list_what_the_brute_force_lists::<f64>(0x9e37_79b9_7f4a_7c15);
    }

    /// The search cut into ranges (2, 3, 5 and 8, each after the first
    /// with cursors of its own; 9 with room for 8, so one range is left
    /// uncut) lists what the whole lists, with the same history, on the
    /// random beds of the test above, before and after a move; a build that
    /// fails, fails cut.
    #[test]
    fn a_search_cut_into_ranges_lists_what_the_whole_lists() {
        use crate::executor::{Executor, Ranges};
        const N: usize = 256;
        const K: usize = 8;
        let mut uniform = uniform(0x2545_f491_4f6c_dd1d);
        let mut spare = std::vec![0u32; 8 * N];
        let (mut compared, mut failed) = (0, 0);
        for case in 0..120 {
            let mut g = Box::new(Grains::<f64, N>::new());
            let n = 1 + (uniform() * N as f64) as usize % N;
            let width = 3.5 + uniform() * [2.0, 40.0, 200.0][case % 3];
            let height = n as f64 / width * [0.7, 2.0, 20.0][case / 3 % 3];
            g.len = n;
            for i in 0..n {
                g.r[i] = 0.3 + 0.2 * uniform();
                g.x[i] = width * uniform();
                g.y[i] = height * uniform();
                g.fixed[i] = g.y[i] < 0.2 * height && i % 2 == 0;
            }
            let parts = [2, 3, 5, 8, 9][case % 5];
            let mut whole = Box::new(Neighbours::<f64, N, K>::new());
            whole.set_skin(0.1, 1e-4);
            let mut cut = whole.clone();
            for _ in 0..2 {
                let expected = whole.rebuild(&g, width, -0.5);
                let bins = cut.sort(&g, width, -0.5).unwrap();
                let found = Ranges(parts).execute(cut.search(&g, bins, &mut spare));
                assert_eq!(found.is_ok(), expected.is_ok(), "case {case}");
                if expected.is_err() {
                    failed += 1;
                    break;
                }
                cut.built();
                assert_eq!(cut.count, whole.count, "case {case}");
                assert_eq!(cut.other, whole.other, "case {case}");
                assert!(cut.spring == whole.spring, "case {case}");
                compared += 1;
                for i in 0..n {
                    for k in 0..usize::from(whole.count[i]) {
                        let mark = (i * K + k) as f64 + uniform();
                        (whole.spring[i][k].e_n, cut.spring[i][k].e_n) = (mark, mark);
                    }
                    g.x[i] = (g.x[i] + 0.3 * uniform()) % width;
                    g.y[i] += 0.3 * uniform();
                }
            }
        }
        assert!(compared > 150 && failed > 0, "{compared} {failed}");
    }

    /// A still bed gets the floor, a fast one the largest skin, one in
    /// between room for 100 steps; a NaN travel the floor.
    #[test]
    fn the_skin_leaves_room_for_a_hundred_steps_within_its_bounds() {
        let largest = 5e-5;
        assert_eq!(adapted_skin(largest, 0.0), 0.3 * largest);
        assert_eq!(adapted_skin(largest, 1e-9), 0.3 * largest);
        assert_eq!(adapted_skin(largest, 1e-7), 200.0 * 1e-7);
        assert_eq!(adapted_skin(largest, 1e-3), largest);
        assert_eq!(adapted_skin(largest, f64::NAN), 0.3 * largest);
        assert_eq!(adapted_skin(0.0f32, 1.0), 0.0);
    }
}
