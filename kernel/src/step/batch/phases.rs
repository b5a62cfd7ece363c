//! The phased step in lanes ([`crate::Sim::step_phased`] where the pair
//! index is ready): the batched step's passes regrouped into phases over
//! ranges that the caller's [`Executor`](crate::executor::Executor) may
//! run on different cores.
//!
//! 0. **Drag** (`DragLanes`, clear water only): each group's drag to its
//!    grains' sums (the coupled flow's is added before the phases).
//! 1. **Pairs** (`PairLanes`): the pair pass over a range of chunks of
//!    pairs. A grain whose pairs (as first or second grain) all lie in the
//!    range, and whose first pair (or place in the list) too, is *summed
//!    here*: its rows go to its sums in pair order, as in the batched pass
//!    (i's sums held in a register from one of its pairs to the next), and
//!    it is marked done (the marks are found again only if the range or
//!    the lists differ from the last pass's: a range that ran the last
//!    pass alone marked its grains since). A pair with a grain not summed
//!    here stores its row (f_x, f_y, −r_i f_s, −r_j f_s) at its place in
//!    [`Phases`](crate::step::buffers::Phases). Each pair's history stays at
//!    its place. Only the grains near a cut are not summed here. A run of
//!    chunks whose grains this range all sums (their `ChunkSpan`s, found
//!    with the lists) runs the batched pass's code, without those tests
//!    and without checking its grains again (it vouches for them: the
//!    spans were built from this very pair list, whose stamp keys them).
//! 2. **Moves** (`MoveLanes`): over a range of whole groups of lanes'
//!    worth of grains, each grain not done gathers its rows in pair order
//!    — the pairs that name it as second grain (their rows as its own:
//!    force negated, its own torque), then its own pairs — and the grain
//!    pass moves the group.
//!
//! The batched step adds to each grain's sums exactly these rows in this
//! order (pair order), one vector add each, so the sums, and the motion,
//! have its bits, which are the scalar step's, for any cut. Padding pairs
//! (w, w) add zeros.
//!
//! Written once for both precisions: `phases!` writes the module `phases`
//! into each precision's module of the batched step (`lanes!` in
//! [`super`]).

/// Writes the module `phases` (the phases `DragLanes`, `PairLanes` and
/// `MoveLanes`, which the lanes' `phased_step` runs) in the lanes of
/// `lanes::$lanes` ([`crate::lanes`]).
macro_rules! phases {
    ($lanes:ident) => {
        /// The phased step in these lanes (`step/batch/phases.rs`).
        pub(super) mod phases {
            use super::pairs::{self, Out};
            use super::{drag, grains};
            use crate::error::Error;
            use crate::executor::Phase;
            use crate::lanes::$lanes::*;
            use crate::step::batch::pairs::pair_range_for;
            use crate::step::batch::params::{Moving, PairRange};
            use crate::step::buffers::{holds, ChunkSpan, MARK};
            use crate::step::index::{Listed, CHUNK};
            use crate::step::mover::Mover;
            use crate::step::phased::{merge_moved, ClearDrag, Moved};
            use crate::step::scalar::Counts;

            /// Pairs per chunk.
            const PER_CHUNK: usize = CHUNK * L;

            /// The drag phase over a range of whole groups (module docs,
            /// phase 0).
            pub(crate) struct DragLanes<'a> {
                pub(crate) moving: Moving<'a, R>,
                pub(crate) drag: ClearDrag<R>,
            }

            impl Phase for DragLanes<'_> {
                type Output = ();

                fn grains(&self) -> usize {
                    self.moving.len()
                }

                /// Cuts at the group of grain `mid`.
                fn split_at(self, mid: usize) -> (Self, Self) {
                    let (moving, moving1) = self.moving.split_at(mid / L * L);
                    let second = DragLanes {
                        moving: moving1,
                        ..self
                    };
                    (DragLanes { moving, ..self }, second)
                }

                #[allow(unsafe_code)]
                fn run(mut self) {
                    // SAFETY: this module is compiled only with AVX2 enabled
                    // for the whole build, so the CPU running it has AVX2.
                    unsafe { drag::drag_pass(&mut self.moving, &self.drag) }
                }

                fn merge(_: (), _: ()) {}
            }

            /// The pair phase over a range of chunks (module docs, phase 1).
            pub(crate) struct PairLanes<'a, const N: usize> {
                pub(crate) range: PairRange<'a, R, N>,
                /// The rows of the range's pairs, from its first pair.
                pub(crate) rows: &'a mut [[R; 4]],
                /// Each grain's first pair and span of pair places, and the
                /// grains (shared).
                pub(crate) start: &'a [u32; N],
                pub(crate) span: &'a [[u32; 2]; N],
                pub(crate) chunk_span: &'a [ChunkSpan; N],
                pub(crate) n: usize,
                /// The sums and done flags of the range's grains (those whose
                /// first pair lies in it), from grain `g0`.
                pub(crate) g0: usize,
                pub(crate) sums: &'a mut [[R; 4]],
                pub(crate) done: &'a mut [u8],
                /// This pass ([`Phases::index_pairs`](crate::Phases)) and
                /// the range's chunks' words of what each range last
                /// flagged, [`MARK`] per chunk (`record`).
                pub(crate) pass: u64,
                pub(crate) marks: &'a mut [u32],
                /// Count the events; the law (8') (no tension).
                pub(crate) count: bool,
                pub(crate) no_tension: bool,
            }

            impl<const N: usize> PairLanes<'_, N> {
                /// The first grain of chunk `c` (`n` past the last).
                fn grain_at(&self, c: usize) -> usize {
                    let q = c.saturating_mul(PER_CHUNK);
                    let Listed { list, pairs } = self.range.listed;
                    let pair_i = &list.pair_i;
                    match pair_i.as_flattened().get(q) {
                        Some(&i) if q < pairs => (i as usize).min(self.n),
                        _ => self.n,
                    }
                }

                /// The first grain whose first pair lies at or past chunk `c`
                /// (all the grains' sums past the last chunk).
                fn home(&self, c: usize) -> usize {
                    let q = c.saturating_mul(PER_CHUNK);
                    if q >= self.range.listed.pairs {
                        return self.g0 + self.sums.len();
                    }
                    let firsts = &self.start[..self.n.min(N)];
                    firsts.partition_point(|&s| (s as usize) < q)
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
                    let home = self.home(c).clamp(self.g0, self.g0 + self.sums.len());
                    let r = self.range;
                    let (e_n, e_n1) = r.e_n.split_at_mut(at.min(r.e_n.len()));
                    let (e_s, e_s1) = r.e_s.split_at_mut(at.min(r.e_s.len()));
                    let (rows, rows1) = self.rows.split_at_mut(at.min(self.rows.len()));
                    let words = (c - c0).saturating_mul(MARK).min(self.marks.len());
                    let (marks, marks1) = self.marks.split_at_mut(words);
                    let (sums, sums1) = self.sums.split_at_mut(home - self.g0);
                    let (done, done1) = self
                        .done
                        .split_at_mut((home - self.g0).min(self.done.len()));
                    let part = |chunks, e_n, e_s, rows, g0, sums, done, marks| PairLanes {
                        range: PairRange {
                            chunks,
                            e_n,
                            e_s,
                            ..r
                        },
                        rows,
                        g0,
                        sums,
                        done,
                        marks,
                        ..self
                    };
                    (
                        part(c0..c, e_n, e_s, rows, self.g0, sums, done, marks),
                        part(c..c1, e_n1, e_s1, rows1, home, sums1, done1, marks1),
                    )
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

            /// Runs a [`PairLanes`] (module docs, phase 1).
            #[allow(unsafe_code)]
            #[target_feature(enable = "avx2")]
            fn pair_rows<const N: usize>(p: &mut PairLanes<'_, N>) -> Counts {
                let first = p.range.chunks.start * PER_CHUNK;
                let end = (p.range.chunks.end.saturating_mul(PER_CHUNK)).min(p.range.listed.pairs);
                let (q0, q1) = (first as u32, end as u32);
                let (c0, c1) = (p.range.chunks.start, p.range.chunks.end);
                // The range's grains whose pairs all lie in it: flagged
                // again unless this range ran the last pass (then it alone
                // flagged its grains since, from the same lists).
                let (g0, held) = (p.g0, p.done.len());
                let flagged = |pass| record(pass, c1, g0, held);
                let last = p.pass.wrapping_sub(1);
                let kept = match (p.marks.first_chunk::<WORDS>(), flagged(last)) {
                    (Some(words), Some(then)) => *words == then,
                    _ => false,
                };
                if !kept {
                    let spans = p.span.get(p.g0..).unwrap_or(&[]);
                    for (done, span) in p.done.iter_mut().zip(spans) {
                        *done = u8::from(holds([q0, q1], *span));
                    }
                }
                if let (Some(words), Some(now)) = (p.marks.first_chunk_mut(), flagged(p.pass)) {
                    *words = now;
                }
                // Whether the range sums every grain of chunk `c` (its
                // pairs' places and its grains all in the range).
                let grains = p.g0..p.g0 + p.sums.len().min(p.done.len());
                let sums_all = |c: usize| {
                    p.chunk_span.get(c).is_some_and(|s| {
                        holds([q0, q1], [s[0], s[1]])
                            && grains.contains(&(s[2] as usize))
                            && grains.contains(&(s[3] as usize))
                    })
                };
                let mut counts = Counts::default();
                // Runs of chunks that need the tests (near a cut or the
                // seam) and runs that do not, each by its own copy of the
                // pair pass (a run of the second kind: the batched pass's
                // instructions).
                let mut c = c0;
                while c < c1 {
                    let tested = !sums_all(c);
                    let end = (c + 1..c1).find(|&e| sums_all(e) == tested).unwrap_or(c1);
                    let (from, to) = ((c - c0) * PER_CHUNK, (end - c0) * PER_CHUNK);
                    let r = &mut PairRange {
                        chunks: c..end,
                        e_n: part(p.range.e_n, from, to),
                        e_s: part(p.range.e_s, from, to),
                        ..p.range
                    };
                    let out = Out::new(p.g0, &mut *p.sums, &*p.done, part(p.rows, from, to));
                    let out = &mut if tested {
                        out
                    } else {
                        // SAFETY: `sums_all` found every chunk of the run
                        // to hold only grains of `grains`, the range's sums:
                        // its lowest and highest grain (its `ChunkSpan`)
                        // are those of its places, padding included, in the
                        // pair list this pass reads (`Phases::index_pairs`
                        // builds the spans from that list, keyed by the
                        // stamp its indexing drew, and `chunk_spans_*`
                        // tests them); a ready index has N a power of two
                        // (`lanes_fit`), so the masked numbers are these.
                        unsafe { out.vouched() }
                    };
                    use pairs::{EVERY_IN_PHASE as ALL, MARKED};
                    let (count, no_tension) = (p.count, p.no_tension);
                    // The copy without tests refuses (None) a run whose
                    // sums do not fit N (never, for a ready index).
                    let all = if tested {
                        None
                    } else {
                        pair_range_for!(pairs::<N, ALL>(count, no_tension, r, out))
                    };
                    let part = match all {
                        Some(part) => part,
                        None => pair_range_for!(pairs::<N, MARKED>(count, no_tension, r, out))
                            .unwrap_or_default(),
                    };
                    counts = counts.merge(part);
                    c = end;
                }
                counts
            }

            /// Words of a range's record in [`PairLanes::marks`].
            const WORDS: usize = 5;
            const _: () = assert!(WORDS <= MARK);

            /// What a range of the pair phase flagged in pass `pass`: the
            /// pass, its last chunk (one past) and its grains (first,
            /// count); its first chunk is where the record lies. `None` if
            /// a number does not fit (then it flags again every pass).
            fn record(pass: u64, c1: usize, g0: usize, len: usize) -> Option<[u32; WORDS]> {
                let word = |v: usize| u32::try_from(v).ok();
                let (lo, hi) = (pass as u32, (pass >> 32) as u32);
                Some([lo, hi, word(c1)?, word(g0)?, word(len)?])
            }

            /// The places `from..to` of `a` (clamped to it).
            fn part<T>(a: &mut [T], from: usize, to: usize) -> &mut [T] {
                let len = a.len();
                a.get_mut(from.min(len)..to.min(len)).unwrap_or_default()
            }

            /// The move phase over a range of whole groups (module docs,
            /// phase 2).
            pub(crate) struct MoveLanes<'a> {
                pub(crate) moving: Moving<'a, R>,
                /// Every pair's row (shared).
                pub(crate) rows: &'a [[R; 4]],
                /// The pairs that name each grain as second grain, as pair
                /// places, grain after grain (shared), and the range's
                /// grains' first and one-past-last entries there.
                pub(crate) incoming: &'a [u32],
                pub(crate) from: &'a [u32],
                pub(crate) to: &'a [u32],
                /// The range's grains' first pair, listed pairs, and done
                /// flags.
                pub(crate) own: &'a [u32],
                pub(crate) count: &'a [u8],
                pub(crate) done: &'a [u8],
                pub(crate) mover: Mover<R>,
            }

            impl Phase for MoveLanes<'_> {
                type Output = Moved<R>;

                fn grains(&self) -> usize {
                    self.moving.len()
                }

                /// Cuts at the group of grain `mid`.
                fn split_at(self, mid: usize) -> (Self, Self) {
                    fn cut<T>(a: &[T], mid: usize) -> (&[T], &[T]) {
                        a.split_at(mid.min(a.len()))
                    }
                    let mid = (mid / L * L).min(self.moving.len());
                    let (moving, moving1) = self.moving.split_at(mid);
                    let ((from, from1), (to, to1)) = (cut(self.from, mid), cut(self.to, mid));
                    let ((own, own1), (count, count1)) = (cut(self.own, mid), cut(self.count, mid));
                    let (done, done1) = cut(self.done, mid);
                    let second = MoveLanes {
                        moving: moving1,
                        from: from1,
                        to: to1,
                        own: own1,
                        count: count1,
                        done: done1,
                        ..self
                    };
                    let first = MoveLanes {
                        moving,
                        from,
                        to,
                        own,
                        count,
                        done,
                        ..self
                    };
                    (first, second)
                }

                #[allow(unsafe_code)]
                fn run(mut self) -> Moved<R> {
                    // SAFETY: this module is compiled only with AVX2 enabled
                    // for the whole build, so the CPU running it has AVX2.
                    unsafe { gather_and_move(&mut self) }
                }

                fn merge(first: Moved<R>, second: Moved<R>) -> Moved<R> {
                    merge_moved(first, second)
                }
            }

            /// Runs a [`MoveLanes`]: each grain of a group of mobile grains
            /// that the pair phase did not sum gets its rows in pair order,
            /// then the group moves.
            #[target_feature(enable = "avx2")]
            fn gather_and_move(p: &mut MoveLanes<'_>) -> Result<(R, u64), Error> {
                let (rows, incoming) = (p.rows, p.incoming);
                let (from, to, own, count, done) = (p.from, p.to, p.own, p.count, p.done);
                let no_row = [0.0; 4];
                let row = |q: usize| load_row(rows.get(q).unwrap_or(&no_row));
                let before = |grp: usize, sums: &mut [[R; 4]; L]| {
                    // A group whose grains are all done (flags of 1): one
                    // compare of the flags as a word.
                    let group = done.get(grp * L..).and_then(|d| d.first_chunk::<L>());
                    if group == Some(&[1; L]) {
                        return;
                    }
                    for (l, sums) in sums.iter_mut().enumerate() {
                        let k = grp * L + l;
                        if done.get(k).is_some_and(|&d| d != 0) {
                            continue;
                        }
                        let mut sum = load_row(sums);
                        let seconds = match (from.get(k), to.get(k)) {
                            (Some(&a), Some(&b)) => incoming.get(a as usize..b as usize),
                            _ => None,
                        };
                        for &q in seconds.unwrap_or(&[]) {
                            sum = row_add(sum, second_row(row(q as usize)));
                        }
                        let first = own.get(k).map_or(0, |&q| q as usize);
                        let listed = count.get(k).map_or(0, |&c| usize::from(c));
                        for q in first..first + listed {
                            sum = row_add(sum, row(q));
                        }
                        put_row(sums, sum);
                    }
                };
                grains::grain_pass(&mut p.moving, &p.mover, before)
            }
        }
    };
}
pub(super) use phases;
