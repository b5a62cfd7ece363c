//! The phased step in lanes ([`crate::Sim::step_phased`] where the pair
//! index is ready): the batched step's passes regrouped into the two
//! phases of [`crate::step::phased`], each over ranges that the caller's
//! [`Executor`](crate::step::phased::Executor) may run on different cores.
//!
//! 1. **Pairs** (`PairLanes`): the pair pass over a range of chunks of
//!    pairs, each batch's rows (f_x, f_y, −r_i f_s, −r_j f_s) stored at its
//!    pairs' places in [`Phases`](crate::step::phased::Phases) instead of
//!    added to the sums; each pair's history stays at its own place.
//! 2. **Moves** (`MoveLanes`): over a range of whole groups of lanes'
//!    worth of grains, each group's clear-water drag, then each grain's
//!    rows gathered in pair order — the pairs that name it as second grain
//!    (their rows as its own: force negated, its own torque), then its own
//!    pairs — and the grain pass's motion.
//!
//! The batched step adds to each grain's sums exactly these rows in this
//! order (pair order), one vector add each, so the sums, and the motion,
//! have its bits, which are the scalar step's, for any cut. Padding pairs
//! (w, w) are skipped: they add zeros.
//!
//! Written once for both precisions: `phases!` writes the module `phases`
//! into each precision's module of the batched step (`lanes!` in
//! [`super`]).

/// Writes the module `phases` (the phases `PairLanes`, `MoveLanes` and
/// the entry `phased_step`) in the lanes of `lanes::$lanes`
/// ([`super::lanes`]).
macro_rules! phases {
    ($lanes:ident) => {
        /// The phased step in these lanes (`step/batch/phases.rs`).
        pub(super) mod phases {
            use super::{drag, grains, pairs};
            use crate::error::Error;
            use crate::step::batch::lanes::$lanes::*;
            use crate::step::batch::params::{Moving, PairRange};
            use crate::step::index::{Listed, CHUNK, PAIRS, SELF_PAIR};
            use crate::step::mover::Mover;
            use crate::step::phased::{ClearDrag, Moved, Phase};
            use crate::step::scalar::Counts;

            /// Pairs per chunk.
            const PER_CHUNK: usize = CHUNK * L;

            /// The pair phase over a range of chunks (module docs, phase 1).
            pub(crate) struct PairLanes<'a, const N: usize> {
                pub(crate) range: PairRange<'a, R, N>,
                /// The rows of the range's pairs, from its first pair.
                pub(crate) rows: &'a mut [[R; 4]],
                /// Each grain's first pair, and the grains.
                pub(crate) start: &'a [u32; N],
                pub(crate) n: usize,
                /// Count the events; the law (8') (no tension).
                pub(crate) count: bool,
                pub(crate) no_tension: bool,
            }

            impl<const N: usize> PairLanes<'_, N> {
                /// The first grain of chunk `c` (`n` past the last).
                fn grain_at(&self, c: usize) -> usize {
                    let q = c.saturating_mul(PER_CHUNK);
                    let Listed { pair_i, pairs, .. } = self.range.listed;
                    match pair_i.as_flattened().get(q) {
                        Some(&i) if q < pairs => (i as usize).min(self.n),
                        _ => self.n,
                    }
                }
            }

            impl<const N: usize> Phase for PairLanes<'_, N> {
                type Output = Counts;

                fn grains(&self) -> usize {
                    let chunks = &self.range.chunks;
                    self.grain_at(chunks.end) - self.grain_at(chunks.start)
                }

                /// Cuts at the chunk of grain `mid`'s first pair.
                fn split_at(self, mid: usize) -> (Self, Self) {
                    let (c0, c1) = (self.range.chunks.start, self.range.chunks.end);
                    let target = self.grain_at(c0).saturating_add(mid);
                    let c = match self.start.get(target) {
                        Some(&q) if target < self.n => q as usize / PER_CHUNK,
                        _ => c1,
                    }
                    .clamp(c0, c1);
                    let at = (c - c0) * PER_CHUNK;
                    let r = self.range;
                    let (e_n, e_n1) = r.e_n.split_at_mut(at.min(r.e_n.len()));
                    let (e_s, e_s1) = r.e_s.split_at_mut(at.min(r.e_s.len()));
                    let (rows, rows1) = self.rows.split_at_mut(at.min(self.rows.len()));
                    let part = |chunks, e_n, e_s, rows| PairLanes {
                        range: PairRange {
                            chunks,
                            e_n,
                            e_s,
                            ..r
                        },
                        rows,
                        ..self
                    };
                    (part(c0..c, e_n, e_s, rows), part(c..c1, e_n1, e_s1, rows1))
                }

                #[allow(unsafe_code)]
                fn run(mut self) -> Counts {
                    // SAFETY: this module is compiled only with AVX2 enabled
                    // for the whole build, so the CPU running it has AVX2.
                    unsafe { pair_rows(&mut self) }
                }

                fn merge(first: Counts, second: Counts) -> Counts {
                    first.merge(second)
                }
            }

            /// Runs a [`PairLanes`]: its rows stored at their pairs' places.
            #[target_feature(enable = "avx2")]
            fn pair_rows<const N: usize>(p: &mut PairLanes<'_, N>) -> Counts {
                let first = p.range.chunks.start * PER_CHUNK;
                let rows = &mut *p.rows;
                let mut sink = |q: usize, batch: [Row; L]| {
                    for (l, row) in batch.into_iter().enumerate() {
                        if let Some(place) = rows.get_mut((q + l).wrapping_sub(first)) {
                            put_row(place, row);
                        }
                    }
                };
                let r = &mut p.range;
                match (p.count, p.no_tension) {
                    (true, false) => pairs::pair_range::<N, true, false, _>(r, &mut sink),
                    (false, false) => pairs::pair_range::<N, false, false, _>(r, &mut sink),
                    (true, true) => pairs::pair_range::<N, true, true, _>(r, &mut sink),
                    (false, true) => pairs::pair_range::<N, false, true, _>(r, &mut sink),
                }
            }

            /// The move phase over a range of whole groups (module docs,
            /// phase 2).
            pub(crate) struct MoveLanes<'a, const N: usize> {
                pub(crate) moving: Moving<'a, R>,
                /// Every pair's row, grains and slot (shared).
                pub(crate) rows: &'a [[R; 4]],
                pub(crate) listed: Listed<'a, R, N>,
                pub(crate) pair_k: &'a [[u8; PAIRS]; N],
                /// Each grain's first pair, and the grains.
                pub(crate) start: &'a [u32; N],
                pub(crate) n: usize,
                /// The pairs that name each grain as second grain, as pair
                /// places, grain after grain (shared), and the range's
                /// grains' first and one-past-last entries there.
                pub(crate) incoming: &'a [u32],
                pub(crate) from: &'a [u32],
                pub(crate) to: &'a [u32],
                pub(crate) mover: Mover<R>,
                pub(crate) drag: Option<ClearDrag<R>>,
            }

            impl<const N: usize> MoveLanes<'_, N> {
                /// The first pair of grain `g` (past the last pair: the pairs).
                fn first_pair(&self, g: usize) -> usize {
                    match self.start.get(g) {
                        Some(&q) if g < self.n => q as usize,
                        _ => self.listed.pairs,
                    }
                }
            }

            impl<const N: usize> Phase for MoveLanes<'_, N> {
                type Output = Moved<R>;

                fn grains(&self) -> usize {
                    self.moving.len()
                }

                /// Cuts at the group of grain `mid`.
                fn split_at(self, mid: usize) -> (Self, Self) {
                    let mid = (mid / L * L).min(self.moving.len());
                    let (moving, moving1) = self.moving.split_at(mid);
                    let (from, from1) = self.from.split_at(mid.min(self.from.len()));
                    let (to, to1) = self.to.split_at(mid.min(self.to.len()));
                    let second = MoveLanes {
                        moving: moving1,
                        from: from1,
                        to: to1,
                        ..self
                    };
                    (
                        MoveLanes {
                            moving,
                            from,
                            to,
                            ..self
                        },
                        second,
                    )
                }

                #[allow(unsafe_code)]
                fn run(mut self) -> Moved<R> {
                    // SAFETY: this module is compiled only with AVX2 enabled
                    // for the whole build, so the CPU running it has AVX2.
                    unsafe { gather_and_move(&mut self) }
                }

                fn merge(first: Moved<R>, second: Moved<R>) -> Moved<R> {
                    let (v_a, c_a) = first?;
                    let (v_b, c_b) = second?;
                    Ok((
                        <R as crate::real::Real>::max(v_a, v_b),
                        c_a.wrapping_add(c_b),
                    ))
                }
            }

            /// Runs a [`MoveLanes`] over grains g0..g1: the clear-water drag
            /// to the sums; then the rows of the pairs (i < g0, j) that name
            /// the range's grains (each grain's in pair order); then, in pair
            /// order, every pair (i, j) of the range's first grains, its row
            /// to i and, if j is in the range, its row as j's to j (as the
            /// batched pair pass adds them: i's sums held in a register from
            /// one of its pairs to the next); then the grain pass. Each
            /// grain's sums get its rows in pair order.
            #[target_feature(enable = "avx2")]
            fn gather_and_move<const N: usize>(
                p: &mut MoveLanes<'_, N>,
            ) -> Result<(R, u64), Error> {
                let g0 = p.moving.first;
                let (q0, q1) = (p.first_pair(g0), p.first_pair(g0 + p.moving.len()));
                let (rows, incoming) = (p.rows, p.incoming);
                let (pair_i, pair_j) = (
                    p.listed.pair_i.as_flattened(),
                    p.listed.pair_j.as_flattened(),
                );
                let pair_k = p.pair_k.as_flattened();
                let no_row = [0.0; 4];
                let row = |q: usize| load_row(rows.get(q).unwrap_or(&no_row));
                if let Some(d) = &p.drag {
                    drag::drag_pass(&mut p.moving, d);
                }
                let sums = &mut *p.moving.sums;
                // The pairs from earlier ranges: each list's entries before q0.
                for ((sum, &a), &b) in sums.iter_mut().zip(p.from).zip(p.to) {
                    let list = incoming.get(a as usize..b as usize).unwrap_or(&[]);
                    let mut earlier = list.iter().take_while(|&&q| (q as usize) < q0).peekable();
                    if earlier.peek().is_some() {
                        let mut s = load_row(sum);
                        for &q in earlier {
                            s = row_add(s, second_row(row(q as usize)));
                        }
                        put_row(sum, s);
                    }
                }
                // The range's pairs, in pair order.
                let mut last = (usize::MAX, load_row(&no_row));
                let q1 = q1.min(pair_i.len()).min(pair_j.len()).min(pair_k.len());
                for q in q0.min(q1)..q1 {
                    if pair_k[q] == SELF_PAIR {
                        continue;
                    }
                    let i = (pair_i[q] as usize).wrapping_sub(g0);
                    let j = (pair_j[q] as usize).wrapping_sub(g0);
                    let r = row(q);
                    let base = if i == last.0 {
                        last.1
                    } else {
                        if let Some(s) = sums.get_mut(last.0) {
                            put_row(s, last.1);
                        }
                        load_row(sums.get(i).unwrap_or(&no_row))
                    };
                    last = (i, row_add(base, r));
                    if let Some(s) = sums.get_mut(j) {
                        add_row(s, second_row(r));
                    }
                }
                if let Some(s) = sums.get_mut(last.0) {
                    put_row(s, last.1);
                }
                grains::grain_pass(&mut p.moving, &p.mover, |_, _| {})
            }
        }
    };
}
pub(super) use phases;
