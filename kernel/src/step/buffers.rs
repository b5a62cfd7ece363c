//! The phased step's buffers ([`Phases`]), beside a [`crate::Sim`]: each
//! listed pair's force and tangential force (the scalar phases,
//! [`super::phased`]), the pairs that name each grain, listed again only
//! when the neighbour lists (or, in lanes, the pair list: its stamp)
//! change, and in lanes each pair's row, each grain's and each chunk's span
//! of pair places, the flags of the grains the pair phase summed and what
//! each of its ranges last flagged (`step::batch::phases`).

use crate::error::{Capacity, Error};
use crate::neighbours::Neighbours;
use crate::real::Real;
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
use crate::step::index::{lanes, CHUNK};
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
use crate::step::index::{PAIRS, SELF_PAIR};

/// The phased step's buffers, beside a [`crate::Sim`] of the same `R`,
/// `N`, `K`: each listed pair's force and tangential force, and each
/// grain's list of the pairs that name it. All-zero bits are a valid,
/// empty value (allocate it zeroed, as a `Sim`).
#[derive(Debug, Clone)]
pub struct Phases<R: Real, const N: usize, const K: usize> {
    /// Per slot (i, k): the pair's force on grain i, x and y.
    pub(super) fx: [[R; K]; N],
    pub(super) fy: [[R; K]; N],
    /// Per slot: the pair's tangential force f_s (torques −r f_s).
    pub(super) fs: [[R; K]; N],
    /// Per grain j: its first entry in `incoming`.
    pub(super) start: [u32; N],
    /// Per grain j: one past its last entry in `incoming`.
    pub(super) end: [u32; N],
    /// The pairs (i, k) that name grain j, as i·K + k, i ascending,
    /// grain after grain.
    pub(super) incoming: [[u32; K]; N],
    /// The neighbour lists `incoming` was built from: their generation
    /// plus one (0: never built), the simulation's address, the lists'
    /// cut-off (its bits: it depends on the grains' speeds at the rebuild),
    /// the grains, and the stamp of the pair index whose places it lists
    /// (the phased step in lanes; 0: it lists slots); all must match for
    /// the lists to be reused.
    built: Built,
    /// Per place of the pair index, its pair's row (f_x, f_y, −r_i f_s,
    /// −r_j f_s): the phased step in lanes (`step::batch::phases`).
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    rows: [[[R; 4]; PAIRS]; N],
    /// Per grain, the first and one-past-last pair place that names it
    /// (u32::MAX and 0 if none): the phased step in lanes.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    span: [[u32; 2]; N],
    /// Per chunk of the pair pass, the union of its grains' spans and its
    /// lowest and highest grain ([`ChunkSpan`]): the phased step in lanes.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    chunk_span: [ChunkSpan; N],
    /// Per grain, 1 if the pair phase in lanes summed its pairs (all in
    /// one range), else 0 (the move phase gathers their rows).
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    done: [u8; N],
    /// The pair phase's passes in lanes ([`Phases::index_pairs`]), plus
    /// one more at each new list: a range that ran the last pass may keep
    /// its `done` flags.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    pass: u64,
    /// Per range of the pair phase in lanes, at its first chunk, what it
    /// last flagged ([`MARK`] words per chunk: `step::batch::phases`).
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    marks: [u32; N],
}

/// Words of [`Phases::marks`] per chunk of the pair pass: a chunk holds at
/// least PAIRS · 8 pairs and the pair places N · PAIRS, so N words hold
/// every chunk's.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub(crate) const MARK: usize = 8;

/// What [`Phases::incoming`] was built from ([`Phases::built`]).
type Built = (u64, usize, u64, usize, u64);

/// Never built.
const NEVER: Built = (0, 0, 0, 0, 0);

impl<R: Real, const N: usize, const K: usize> Phases<R, N, K> {
    /// Empty buffers (all-zero bits).
    pub const fn new() -> Self {
        Phases {
            fx: [[R::ZERO; K]; N],
            fy: [[R::ZERO; K]; N],
            fs: [[R::ZERO; K]; N],
            start: [0; N],
            end: [0; N],
            incoming: [[0; K]; N],
            built: NEVER,
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            rows: [[[R::ZERO; 4]; PAIRS]; N],
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            span: [[0; 2]; N],
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            chunk_span: [[0; 4]; N],
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            done: [0; N],
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            pass: 0,
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            marks: [0; N],
        }
    }

    /// Room for the bucket cursors of a rebuild's search in ranges
    /// ([`crate::neighbours::Search`]): the list of incoming pairs, which
    /// the new lists make stale anyway (marked never built).
    pub(crate) fn scratch(&mut self) -> &mut [u32] {
        self.built = NEVER;
        self.incoming.as_flattened_mut()
    }

    /// Lists, for each of the first `n` grains, the pairs that name it, if
    /// the lists `nb` (of the simulation at address `owner`) changed since
    /// the last call: as slots i·K + k. A counting sort: O(pairs).
    pub(crate) fn index(
        &mut self,
        nb: &Neighbours<R, N, K>,
        n: usize,
        owner: usize,
    ) -> Result<(), Error> {
        let n = n.min(N);
        let listed = |i: usize| nb.other[i][..usize::from(nb.count[i]).min(K)].iter();
        let pairs = (0..n).flat_map(|i| {
            listed(i)
                .enumerate()
                .map(move |(k, &j)| ((i * K + k) as u32, j))
        });
        self.build(key(nb, n, owner, 0), n, pairs).map(|_| ())
    }

    /// As [`Phases::index`], the pairs that name each grain as pair
    /// places of the pair index `parts` (built from the lists `nb`),
    /// padding pairs left out, with each grain's span of pair places; then
    /// what the phased step in lanes reads and writes ([`LaneLists`]).
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    pub(crate) fn index_pairs(
        &mut self,
        nb: &Neighbours<R, N, K>,
        parts: &crate::step::index::Parts<'_, R, N>,
        n: usize,
        owner: usize,
    ) -> Result<LaneLists<'_, R, N>, Error> {
        let n = n.min(N);
        let (pair_j, pair_k) = (
            parts.listed.list.pair_j.as_flattened(),
            parts.pair_k.as_flattened(),
        );
        let places = parts.listed.pairs.min(pair_j.len()).min(pair_k.len());
        let (pair_i, listed) = (parts.listed.list.pair_i.as_flattened(), |q: &usize| {
            pair_k[*q] != SELF_PAIR
        });
        let places = places.min(pair_i.len());
        let pairs = (0..places).filter(listed).map(|q| (q as u32, pair_j[q]));
        let stamp = parts.listed.list.stamp;
        // This call's pass: the last one's plus one, plus one more with
        // new lists (no range's flags then carry over).
        self.pass = self.pass.wrapping_add(1);
        if self.build(key(nb, n, owner, stamp.max(1)), n, pairs)? {
            self.pass = self.pass.wrapping_add(1);
            // Never built until the spans below are (the pair phase trusts
            // them: `Out::vouched`).
            let built = core::mem::replace(&mut self.built, NEVER);
            // Whole groups of lanes (grains past n: none).
            let groups = n.next_multiple_of(8).min(N);
            self.span[..groups].fill([u32::MAX, 0]);
            for q in (0..places).filter(listed) {
                for g in [pair_i[q], pair_j[q]] {
                    if let Some(span) = self.span.get_mut(g as usize) {
                        *span = [span[0].min(q as u32), span[1].max(q as u32 + 1)];
                    }
                }
            }
            // Every place, padding pairs included: their grain appears in
            // the chunk too.
            let per_chunk = CHUNK * lanes::<R>();
            let chunks = pair_i[..places]
                .chunks(per_chunk)
                .zip(pair_j[..places].chunks(per_chunk));
            for ((firsts, seconds), summary) in chunks.zip(&mut self.chunk_span) {
                *summary = [u32::MAX, 0, u32::MAX, 0];
                for &g in firsts.iter().chain(seconds) {
                    let span = self.span.get(g as usize).unwrap_or(&[0, u32::MAX]);
                    *summary = [
                        summary[0].min(span[0]),
                        summary[1].max(span[1]),
                        summary[2].min(g),
                        summary[3].max(g),
                    ];
                }
            }
            self.built = built;
        }
        Ok(LaneLists {
            rows: self.rows.as_flattened_mut(),
            incoming: self.incoming.as_flattened(),
            from: &self.start,
            to: &self.end,
            span: &self.span,
            chunk_span: &self.chunk_span,
            done: &mut self.done,
            pass: self.pass,
            marks: &mut self.marks,
        })
    }

    /// Lists the pairs `(place, second grain)` by second grain (each
    /// grain's in their order), unless already built for `key`: whether
    /// it built them.
    fn build<I>(&mut self, key: Built, n: usize, pairs: I) -> Result<bool, Error>
    where
        I: Iterator<Item = (u32, u32)> + Clone,
    {
        if self.built == key {
            return Ok(false);
        }
        self.built = NEVER;
        if u32::try_from(N.saturating_mul(K)).is_err() {
            return Err(Error::CapacityExceeded {
                what: Capacity::Grains,
                capacity: u32::MAX as usize / K.max(1),
            });
        }
        self.end[..n].fill(0);
        for (_, j) in pairs.clone() {
            if let Some(e) = self.end.get_mut(j as usize).filter(|_| (j as usize) < n) {
                *e += 1;
            }
        }
        let mut total = 0u32;
        for j in 0..n {
            self.start[j] = total;
            total += self.end[j];
            self.end[j] = self.start[j];
        }
        let incoming = self.incoming.as_flattened_mut();
        for (place, j) in pairs {
            let j = j as usize;
            if j < n {
                let at = self.end[j] as usize;
                if let Some(slot) = incoming.get_mut(at) {
                    *slot = place;
                    self.end[j] += 1;
                }
            }
        }
        self.built = key;
        Ok(true)
    }
}

/// The lists `nb` of the simulation at `owner` for `n` grains, as the
/// pair places of the pair index stamped `stamp` or (0) as slots: the key
/// of [`Phases::built`]. N·K fits u32
/// wherever the key is used ([`Phases::build`] checks it first).
fn key<R: Real, const N: usize, const K: usize>(
    nb: &Neighbours<R, N, K>,
    n: usize,
    owner: usize,
    stamp: u64,
) -> Built {
    (
        nb.generation.wrapping_add(1).max(1),
        owner,
        nb.cutoff.to_f64().to_bits(),
        n,
        stamp,
    )
}

/// What the phased step in lanes reads and writes of a [`Phases`]
/// ([`Phases::index_pairs`]): the rows, the incoming lists with each
/// grain's first and one-past-last entry, each grain's span of pair
/// places, and the flags of the grains the pair phase summed, with this
/// pass and what each range last flagged.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub(crate) struct LaneLists<'a, R: Real, const N: usize> {
    pub(crate) rows: &'a mut [[R; 4]],
    pub(crate) incoming: &'a [u32],
    pub(crate) from: &'a [u32; N],
    pub(crate) to: &'a [u32; N],
    pub(crate) span: &'a [[u32; 2]; N],
    pub(crate) chunk_span: &'a [ChunkSpan; N],
    pub(crate) done: &'a mut [u8; N],
    pub(crate) pass: u64,
    pub(crate) marks: &'a mut [u32; N],
}

/// Of a chunk of the pair pass's pairs: the first and one-past-last pair
/// place of the pairs that name its grains, and its lowest and highest
/// grain. A range of the pair phase sums every grain of the chunk if the
/// places lie in the range's and the grains among the range's grains: then
/// the chunk needs no test of which grains the range sums.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub(crate) type ChunkSpan = [u32; 4];

/// Whether the pair places `places` (first, one past last) hold every
/// place of `span`: the pair phase in lanes sums a grain (or a chunk's
/// grains) whose span they hold.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[inline]
pub(crate) fn holds(places: [u32; 2], span: [u32; 2]) -> bool {
    span[0] >= places[0] && span[1] <= places[1]
}

impl<R: Real, const N: usize, const K: usize> Default for Phases<R, N, K> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
mod tests {
    use crate::step::index::{lanes, CHUNK};
    use crate::{Phases, Ranges, Scenario, Sim};
    use std::boxed::Box;

    type Bed = Sim<f64, 512, 8>;

    /// A flowing bed of 30 columns × 12 rows and the phased step's buffers.
    fn flowing() -> (Box<Bed>, Box<Phases<f64, 512, 8>>) {
        let scenario = Scenario::paper_bed(30, 12);
        let mut sim = Box::new(Bed::new());
        scenario.build(&mut sim).unwrap();
        sim.set_flow(Some(&scenario.flow(1.0))).unwrap();
        (sim, Box::new(Phases::new()))
    }

    /// The lists of `phases` are keyed by the stamp of `sim`'s pair list,
    /// and each chunk's lowest and highest grain are those of its pairs.
    fn spans_hold_the_pairs(sim: &Bed, phases: &Phases<f64, 512, 8>) {
        let (list, places) = (&sim.index.list, sim.index.pairs);
        assert_eq!(phases.built.4, list.stamp);
        let per_chunk = CHUNK * lanes::<f64>();
        let firsts = list.pair_i.as_flattened()[..places].chunks(per_chunk);
        let seconds = list.pair_j.as_flattened()[..places].chunks(per_chunk);
        for (c, (i, j)) in firsts.zip(seconds).enumerate() {
            let grains = || i.iter().chain(j);
            let (low, high) = (grains().min(), grains().max());
            let span = phases.chunk_span[c];
            assert_eq!((Some(&span[2]), Some(&span[3])), (low, high), "chunk {c}");
        }
    }

    /// What the pair phase's copy without tests relies on to address the
    /// sums by grain number unchecked (`Out::vouched`): after every phased
    /// step of a flowing bed (its lists rebuilt), the lists are keyed by
    /// the pair index's stamp and the chunk spans hold their pairs'
    /// grains; each indexing draws a new stamp, a clone keeps its pairs'.
    #[test]
    fn chunk_spans_hold_their_pairs_grains_under_the_stamp() {
        let (mut sim, mut phases) = flowing();
        let mut stamps = std::vec::Vec::new();
        for _ in 0..400 {
            sim.step_phased(&mut phases, &Ranges(3)).unwrap();
            spans_hold_the_pairs(&sim, &phases);
            if stamps.last() != Some(&sim.index.list.stamp) {
                stamps.push(sim.index.list.stamp);
            }
        }
        assert!(sim.nbrs.rebuilds >= 3, "{} rebuilds", sim.nbrs.rebuilds);
        assert_eq!(stamps.len() as u64, sim.nbrs.rebuilds, "{stamps:?}");
        assert!(stamps.windows(2).all(|w| w[0] < w[1]), "{stamps:?}");
        let copy = sim.clone();
        assert_eq!(copy.index.list.stamp, sim.index.list.stamp);
    }

    /// Another pair list under a key the neighbour lists alone cannot tell
    /// apart (the same generation, simulation, cut-off and grains: here a
    /// pair dropped in place and the index rebuilt) has a new stamp, and
    /// the phased step's lists are built again for it (without the stamp
    /// in the key they were not, tried).
    #[test]
    fn a_new_pair_list_under_the_same_lists_key_is_indexed_again() {
        let (mut sim, mut phases) = flowing();
        for _ in 0..400 {
            sim.step_phased(&mut phases, &Ranges(2)).unwrap();
        }
        let n = sim.len();
        let owner = core::ptr::from_ref(&*sim) as usize;
        let before = (phases.built, sim.index.list.stamp);
        let most = (0..n).max_by_key(|&i| sim.nbrs.count[i]).unwrap();
        assert!(sim.nbrs.count[most] >= 1);
        sim.nbrs.count[most] -= 1;
        let margin = sim.nbrs.cutoff + sim.nbrs.skin;
        let width = sim.width;
        sim.index.index(&sim.grains, &sim.nbrs, width, margin);
        assert!(sim.index.ready);
        assert_ne!(sim.index.list.stamp, before.1);
        let (nb, parts) = (&sim.nbrs, sim.index.parts());
        phases.index_pairs(nb, &parts, n, owner).unwrap();
        let (old, new) = (before.0, phases.built);
        assert_eq!((old.0, old.1, old.2, old.3), (new.0, new.1, new.2, new.3));
        spans_hold_the_pairs(&sim, &phases);
    }
}
