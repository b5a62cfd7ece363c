//! The pair forces in lanes, the batched step's second pass: every listed
//! pair of the [pair index](crate::step::index::PairIndex), L pairs at a
//! time, lane by lane the operations of the scalar step's `State::contact`
//! (the pair geometry: distance, unit normal, relative speeds, docs/model.md
//! §2) and of [`ContactLaw::apply`](crate::contact::ContactLaw::apply)
//! (the law (6)–(9) with its spring history, (8) or (8')); branches become
//! selects.
//!
//! Each pair's force and torques are then added to its two grains' sums
//! lane by lane, in pair order: one row (f_x, f_y, torque) per grain, one
//! vector add per side, the second grain's force negated (s + (−f) is
//! s − f, bit for bit; each torque adds its own −r f_s, the product the
//! scalar step forms). Pairs are listed by first grain, so grain i
//! receives the pairs (m, i), m ascending, then its own pairs (i, j) in
//! slot order: exactly the scalar step's order, so the sums have its bits.
//! A pair that exerts no force adds +0 or −0, which changes no sum.
//!
//! Written once for both precisions: `pairs!` writes the module `pairs`
//! into each precision's module of the batched step (`lanes!` in
//! [`super`]).

/// Writes the module `pairs` (the pass `pair_range`) in the lanes of
/// `lanes::$lanes` ([`crate::lanes`]).
macro_rules! pairs {
    ($lanes:ident) => {
        /// The pair pass in these lanes (`step/batch/pairs.rs`).
        pub(super) mod pairs {
            use crate::lanes::$lanes::*;
            use crate::step::batch::params::PairRange;
            use crate::step::index::{second_window, window_start, List, CHUNK, FAR, PAIRS};
            use crate::step::scalar::Counts;
            use core::arch::x86_64::{
                __m256i, _mm256_cvtepu8_epi32, _mm256_setzero_si256, _mm256_slli_epi32,
                _mm_cvtsi64_si128,
            };
            use core::ops::Range;

            /// Second grains from a window ([`second_window`]).
            const SECOND_WINDOW: bool = second_window(L) == 2 * L;

            /// Where [`pair_range`] puts the rows: the sums of the grains from
            /// `g0` (the batched pass: every grain's, from 0), and, for the
            /// pair phase's tested chunks ([`MARKED`]), which of them it sums
            /// (`done`) and the rows of the run's pairs (from its first pair)
            /// that it does not.
            pub(crate) struct Out<'a> {
                pub(crate) g0: usize,
                pub(crate) sums: &'a mut [[R; 4]],
                pub(crate) done: &'a [u8],
                pub(crate) rows: &'a mut [[R; 4]],
                /// For [`EVERY_IN_PHASE`]: the caller vouched that every
                /// pair's grains lie in the sums ([`Out::vouched`]); else
                /// `pair_range` checks them (`grains_within`).
                within: bool,
            }

            impl<'a> Out<'a> {
                /// Rows to the sums of the grains from `g0`, the flags
                /// `done` and the places `rows` (module docs of `pair_range`).
                pub(crate) fn new(
                    g0: usize,
                    sums: &'a mut [[R; 4]],
                    done: &'a [u8],
                    rows: &'a mut [[R; 4]],
                ) -> Self {
                    Out {
                        g0,
                        sums,
                        done,
                        rows,
                        within: false,
                    }
                }

                /// The same, for a run whose pairs the caller has vouched
                /// for: [`EVERY_IN_PHASE`] then addresses their grains'
                /// sums unchecked, without a pass over their grain numbers.
                ///
                /// # Safety
                ///
                /// Both grains of every pair of the run that `pair_range`
                /// is given, as it reads them (masked below N), lie in
                /// `g0..g0 + sums.len()`.
                #[allow(unsafe_code)]
                pub(crate) unsafe fn vouched(self) -> Self {
                    Out {
                        within: true,
                        ..self
                    }
                }
            }

            /// [`pair_range`] sums every pair's grains: the batched pass.
            pub(crate) const EVERY: u8 = 0;
            /// The same in the pair phase: its own copy, so that each copy
            /// has one caller and is inlined there (shared, neither was:
            /// ~50 more instructions per grain-step).
            pub(crate) const EVERY_IN_PHASE: u8 = 1;
            /// [`pair_range`] sums the grains `Out::done` marks and keeps the
            /// rows of the others.
            pub(crate) const MARKED: u8 = 2;

            /// A batch's geometry and relative speeds: what its laws need of it
            /// (`State::contact`).
            #[derive(Clone, Copy)]
            struct Geometry {
                /// Unit normal, r_i + r_j − distance, radii.
                nx: V,
                ny: V,
                overlap: V,
                ri: V,
                rj: V,
                /// Lane masks: in contact (not apart, not coincident); coincident
                /// (keeps its history).
                touching: V,
                keeps: V,
                /// Normal and tangential relative speeds.
                v_n: V,
                v_s: V,
            }

            /// Every listed pair's geometry and law over the range `r`'s
            /// chunks, L pairs at a time, lane by lane as `State::contact` and
            /// `ContactLaw::apply`; each pair's row (f_x, f_y, −r_i f_s,
            /// −r_j f_s) to its grains' sums in `out` (as its own to the first
            /// grain; as the second grain's, the force negated and with its
            /// own torque), in pair order. The events are counted if `COUNT`;
            /// `NO_TENSION`: the law (8')
            /// ([`Tension::None`](crate::contact::Tension::None)), else the
            /// paper's (8).
            ///
            /// A row to the sums is one vector add (s + (−f) is s − f, bit
            /// for bit; each torque adds its own −r f_s, the product the
            /// scalar step forms). Pairs are listed by first grain, so grain i
            /// receives the pairs (m, i), m ascending, then its own pairs
            /// (i, j) in slot order: exactly the scalar step's order, so the
            /// sums have its bits. A first grain's pairs are consecutive, and
            /// no other pair adds to its sums between them (its second-grain
            /// pairs all come earlier; a padding pair (w, w) adds zeros, to
            /// the stale copy in memory that the store overwrites), so its
            /// sums stay in a register from one to the next and are stored
            /// once, when the next first grain comes or the pass ends.
            ///
            /// `SUMS`: [`EVERY`] or [`EVERY_IN_PHASE`], every pair's grains
            /// (the batched pass; the pair phase's chunks whose grains its
            /// range all sums); [`MARKED`] (the pair phase's chunks near a
            /// cut or the seam, `step/batch/phases.rs`), only the grains
            /// `out.done` marks, a pair with a grain it does not mark
            /// storing its row in `out.rows`.
            ///
            /// The counts of events; `None` (nothing read or written) only
            /// from [`EVERY_IN_PHASE`], if a pair names a grain outside
            /// `out.sums` (`grains_within`, unless the caller vouched for
            /// them, [`Out::vouched`]) or the sums do not fit N: then run
            /// [`MARKED`].
            #[allow(unsafe_code)]
            #[target_feature(enable = "avx2")]
            pub(crate) fn pair_range<
                const N: usize,
                const COUNT: bool,
                const NO_TENSION: bool,
                const SUMS: u8,
            >(
                r: &mut PairRange<'_, R, N>,
                out: &mut Out<'_>,
            ) -> Option<Counts> {
                let zero = zero();
                let sign = splat(-0.0);
                let all = splat(TRUE);
                let neg = |a: V| xor(a, sign);
                let (width, half_width) = (splat(r.width), splat(r.width * 0.5));
                let law = &r.law;
                let (dt, k_n, k_s) = (splat(law.step_dt), splat(law.k_n), splat(law.k_s));
                let (eta_n, eta_s, mu) = (splat(law.eta_n), splat(law.eta_s), splat(law.mu));
                let tested = SUMS == MARKED;
                // The pair phase's copy for chunks whose grains its range
                // all sums: the sums addressed by grain, as the batched pass
                // does (no offset, no bounds check per lane), once every
                // pair's grains are found in the range's sums (else `None`:
                // the caller runs the tested copy).
                let in_phase = SUMS == EVERY_IN_PHASE;
                let b = r.listed.list;
                let g = r.grains;
                let [x, y, u, v, w, radius] = [&g.x, &g.y, &g.u, &g.v, &g.w, &g.r];
                // The slices in locals (behind `r` and `out` their addresses
                // would be read again after every store), the history as
                // chunks of CHUNK batches of L pairs (no bounds to check
                // within a chunk): whole chunks, as ranges and runs are cut
                // at chunks and the places are whole chunks
                // (`index::lanes_fit`).
                let hist_n = r.e_n.as_chunks_mut::<L>().0.as_chunks_mut::<CHUNK>().0;
                let hist_s = r.e_s.as_chunks_mut::<L>().0.as_chunks_mut::<CHUNK>().0;
                let (g0, done) = (out.g0, out.done);
                let (sums, out_rows) = (&mut *out.sums, &mut *out.rows);
                // The range's first pair: its history's offset.
                let first_pair = r.chunks.start * CHUNK * L;
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
                    (window_start::<N>(first, L), lanes)
                };
                // Batch t's second grains' x, y, u, v, ω and radii: from
                // its second window (from `start`), or gathered.
                let second_grains = |t: usize, start: usize| {
                    let grains = [x, y, u, v, w, radius];
                    let c = b.second_lanes[t & (N - 1)];
                    if SECOND_WINDOW && c[0] != FAR {
                        let lanes = control(c);
                        let high = to_mask(_mm256_slli_epi32::<28>(lanes));
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
                let batches = r.listed.pairs.min(cap) / L;
                let range =
                    (r.chunks.start * CHUNK).min(batches)..(r.chunks.end * CHUNK).min(batches);
                let pairs = range.start * L..range.end * L;
                if in_phase {
                    let found = if out.within {
                        debug_assert!(grains_within(b, pairs.clone(), g0, sums.len()));
                        sums_fit::<N>(g0, sums.len())
                    } else {
                        grains_within(b, pairs, g0, sums.len())
                    };
                    if !found {
                        return None;
                    }
                }
                // Grain g's sums at `by_grain + g` (an address computed
                // with wrapping arithmetic, dereferenced only for grains in
                // the range's sums).
                let by_grain = sums.as_mut_ptr().wrapping_sub(g0);
                // The last first grain to sum, and its sums.
                let mut last = (usize::MAX, load_row(&[0.0; 4]));
                // One buffer for every chunk (zeroing it per chunk cost ~8
                // instructions per grain-step).
                // Per lane, the contacts made, broken and sliding if COUNT
                // (each mask lane, all ones, is −1 as an integer; counting
                // costs ~7 % more instructions per grain-step).
                let count = |n: __m256i, mask: V| int_sub(n, to_int(mask));
                let (mut made_n, mut broken_n, mut sliding_n) = (
                    _mm256_setzero_si256(),
                    _mm256_setzero_si256(),
                    _mm256_setzero_si256(),
                );
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
                for (k, chunk) in range.clone().step_by(CHUNK).enumerate() {
                    // Never short (above): a chunk past the history would
                    // be a pair list longer than the places.
                    let (Some(h_n), Some(h_s)) = (hist_n.get_mut(k), hist_s.get_mut(k)) else {
                        break;
                    };
                    let seam = b.seam[(chunk / CHUNK) & (N - 1)];
                    let chunk = chunk..range.end.min(chunk + CHUNK);
                    // Geometry (State::contact).
                    for (t, g) in chunk.clone().zip(&mut geometry) {
                        let (start, lanes) = first_window(t);
                        let own = |a: &[R; N]| window(a, start, lanes);
                        let [x_j, y_j, u_j, v_j, w_j, rj] = second_grains(t, start);
                        // The periodic image: d itself (within half the width)
                        // away from the seam.
                        let d = sub(x_j, own(x));
                        let dx = if seam {
                            select(
                                select(d, add(d, width), lt(d, neg(half_width))),
                                sub(d, width),
                                gt(d, half_width),
                            )
                        } else {
                            d
                        };
                        let dy = sub(y_j, own(y));
                        let ri = own(radius);
                        let reach = add(ri, rj);
                        let dist2 = add(mul(dx, dx), mul(dy, dy));
                        let apart = ge(dist2, mul(reach, reach));
                        let dist = sqrt(dist2);
                        let coincident = eq(dist, zero);
                        let inv = div(splat(1.0), dist);
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
                            touching: andnot(apart, andnot(coincident, all)),
                            keeps: andnot(apart, coincident),
                            v_n,
                            v_s,
                        };
                    }
                    let history = h_n.iter_mut().zip(h_s.iter_mut());
                    for ((t, g), (h_n, h_s)) in chunk.zip(&geometry).zip(history) {
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
                        let (e_n0, e_s0) = (load(h_n), load(h_s));

                        // Law (ContactLaw::apply).
                        let first = eq(e_n0, zero);
                        let e_n = add(e_n0, mul(k_n, select(mul(v_n, dt), overlap, first)));
                        let broken = lt(e_n, zero);
                        let f_n = add(e_n, mul(eta_n, v_n));
                        // (8'): f_n < 0 becomes +0 (−0 and NaN kept, as
                        // the scalar step), and the cap follows f_n.
                        let (f_n, normal) = if NO_TENSION {
                            let f_n = andnot(lt(f_n, zero), f_n);
                            (f_n, f_n)
                        } else {
                            (f_n, e_n)
                        };
                        let e_s = add(e_s0, mul(mul(k_s, v_s), dt));
                        let limit = mul(mu, normal);
                        let slides = gt(andnot(sign, e_s), limit);
                        let e_s_slid = select(neg(limit), limit, gt(e_s, zero));
                        let e_s_new = select(e_s, e_s_slid, slides);
                        let f_s = select(add(e_s, mul(eta_s, v_s)), e_s_new, slides);

                        // Outcomes: apart or broken drop the history; coincident keeps
                        // it; otherwise the new history and a force.
                        let acts = andnot(broken, touching);
                        // Events: made (first and acts), broken (had history,
                        // neither acts nor keeps it), sliding (and acts).
                        if COUNT {
                            let held = xor(acts, keeps);
                            made_n = count(made_n, and(first, acts));
                            let dropped = andnot(first, andnot(held, all));
                            broken_n = count(broken_n, dropped);
                            sliding_n = count(sliding_n, and(slides, acts));
                        }
                        // Padding pairs (w, w) are coincident: their history stays zero.
                        // The lanes that act and those that keep are disjoint, so
                        // one of each pair of terms is +0: a bitwise merge, which
                        // the optimiser does not turn into a masked store
                        // (`vmaskmovpd`, slow on AMD cores) as it did a select.
                        let e_n_out = xor(and(e_n, acts), and(e_n0, keeps));
                        let e_s_out = xor(and(e_s_new, acts), and(e_s0, keeps));
                        put(h_n, e_n_out);
                        put(h_s, e_s_out);
                        let fx = and(add(mul(neg(f_n), nx), mul(f_s, tx)), acts);
                        let fy = and(add(mul(neg(f_n), ny), mul(f_s, ty)), acts);
                        let f_s = and(f_s, acts);
                        let rows = to_rows([fx, fy, neg(mul(ri, f_s)), neg(mul(rj, f_s))]);
                        for (l, row) in rows.into_iter().enumerate() {
                            if in_phase {
                                let (i, j) = (index(&b.pair_i, q + l), index(&b.pair_j, q + l));
                                // SAFETY: `grains_within`, or the caller
                                // (`Out::vouched`), found both grains of
                                // every pair of the range in
                                // g0..g0 + sums.len(), so grains i, j and
                                // last.0 (an earlier pair's i) lie in `sums`,
                                // which this copy reads and writes only
                                // through `by_grain`.
                                unsafe {
                                    let base = if i == last.0 {
                                        last.1
                                    } else {
                                        if last.0 != usize::MAX {
                                            put_row(&mut *by_grain.wrapping_add(last.0), last.1);
                                        }
                                        load_row(&*by_grain.wrapping_add(i))
                                    };
                                    last = (i, row_add(base, row));
                                    add_row(&mut *by_grain.wrapping_add(j), second_row(row));
                                }
                                continue;
                            }
                            let i = index(&b.pair_i, q + l).wrapping_sub(g0);
                            let j = index(&b.pair_j, q + l).wrapping_sub(g0);
                            let summed = |g: usize| !tested || done.get(g).is_some_and(|&d| d != 0);
                            let (sum_i, sum_j) = (summed(i), summed(j));
                            if sum_i {
                                let base = if i == last.0 {
                                    last.1
                                } else {
                                    if let Some(sums) = sums.get_mut(last.0) {
                                        put_row(sums, last.1);
                                    }
                                    load_row(sums.get(i).unwrap_or(&[0.0; 4]))
                                };
                                last = (i, row_add(base, row));
                            }
                            if sum_j && let Some(sums) = sums.get_mut(j) {
                                add_row(sums, second_row(row));
                            }
                            if tested
                                && !(sum_i && sum_j)
                                && let Some(place) =
                                    out_rows.get_mut((q + l).wrapping_sub(first_pair))
                            {
                                put_row(place, row);
                            }
                        }
                    }
                }
                if in_phase {
                    if last.0 != usize::MAX {
                        // SAFETY: as in the loop (last.0 is a pair's i).
                        put_row(unsafe { &mut *by_grain.wrapping_add(last.0) }, last.1);
                    }
                } else if let Some(sums) = sums.get_mut(last.0) {
                    put_row(sums, last.1);
                }
                let total = |n: __m256i| {
                    lanes(to_mask(n))
                        .into_iter()
                        .map(|c| u64::from(c.to_bits()))
                        .sum::<u64>()
                };
                Some(Counts {
                    made: total(made_n),
                    broken: total(broken_n),
                    sliding: total(sliding_n),
                })
            }

            /// Whether both grains of every pair `pairs` of the list `b`,
            /// masked below N as `pair_range` reads them, lie in
            /// `g0..g0 + len`, a range of grains below N; and the pairs'
            /// places are those `pair_range` reads (N a power of two, so
            /// its masked places are the places themselves).
            fn grains_within<const N: usize>(
                b: &List<N>,
                pairs: Range<usize>,
                g0: usize,
                len: usize,
            ) -> bool {
                if !sums_fit::<N>(g0, len) {
                    return false;
                }
                let (Ok(g0), Ok(len), Ok(mask)) =
                    (u32::try_from(g0), u32::try_from(len), u32::try_from(N - 1))
                else {
                    return false;
                };
                let firsts = b.pair_i.as_flattened().get(pairs.clone());
                let seconds = b.pair_j.as_flattened().get(pairs);
                // The largest offset from g0 (wrapping: a grain below g0
                // is far above), one fold per array (vector code).
                let reach = |a: &[u32]| {
                    a.iter()
                        .fold(0, |m: u32, &g| m.max((g & mask).wrapping_sub(g0)))
                };
                match (firsts, seconds) {
                    (Some(i), Some(j)) => len > 0 && reach(i) < len && reach(j) < len,
                    _ => false,
                }
            }

            /// Whether the sums of the grains `g0..g0 + len` lie below N, a
            /// power of two (so a grain number masked below N, as
            /// `pair_range` reads it, is the number itself).
            fn sums_fit<const N: usize>(g0: usize, len: usize) -> bool {
                N.is_power_of_two() && len > 0 && g0.checked_add(len).is_some_and(|end| end <= N)
            }

            #[cfg(test)]
            mod tests {
                use super::{grains_within, pair_range, Out, EVERY_IN_PHASE, L, R};
                use crate::contact::{ContactLaw, Spring};
                use crate::grains::Grains;
                use crate::neighbours::Neighbours;
                use crate::step::batch::params::PairRange;
                use crate::step::index::{PairIndex, CHUNK};
                use std::boxed::Box;

                /// The pair phase's copy that addresses sums by grain
                /// number refuses a range whose sums lack a pair's grain,
                /// before it reads or writes anything (its caller then runs
                /// the tested copy), and runs one that has them all.
                #[test]
                #[allow(unsafe_code)]
                fn a_pair_outside_the_sums_runs_nothing() {
                    const N: usize = 64;
                    let n = 40;
                    let mut index = Box::new(PairIndex::<R, N, 4>::new());
                    let mut nbrs = Box::new(Neighbours::<R, N, 4>::new());
                    for m in 0..n - 1 {
                        nbrs.push_history(m, m + 1, Spring::ZERO);
                    }
                    // Grains a unit apart: every pair apart, its history
                    // dropped (set to zero) when the pair is run.
                    let mut grains = Box::new(Grains::<R, N>::new());
                    grains.len = n;
                    for m in 0..n {
                        (grains.x[m], grains.r[m]) = (m as R, 0.1);
                    }
                    index.index(&grains, &nbrs, 100.0, 1.0);
                    assert!(index.ready);
                    let parts = index.parts();
                    parts.e_n.fill(1.0);
                    let chunks = 0..parts.listed.pairs.div_ceil(CHUNK * L);
                    let range = &mut PairRange {
                        listed: parts.listed,
                        grains: &grains,
                        law: ContactLaw::ZERO,
                        width: 100.0,
                        chunks,
                        e_n: parts.e_n,
                        e_s: parts.e_s,
                    };
                    let sums = parts.sums;
                    let run = |range: &mut PairRange<'_, R, N>, g0: usize, sums: &mut [[R; 4]]| {
                        let out = &mut Out::new(g0, sums, &[], &mut []);
                        // SAFETY: this module is compiled only with AVX2
                        // enabled for the whole build.
                        unsafe { pair_range::<N, false, false, EVERY_IN_PHASE>(range, out) }
                    };
                    // Grain 0's sums are not the range's.
                    assert!(run(range, 1, &mut sums[1..]).is_none());
                    assert!(range.e_n.iter().all(|&e| e == 1.0), "history untouched");
                    assert!(run(range, 0, &mut sums[..]).is_some());
                    let listed = &range.e_n[..range.listed.pairs];
                    assert!(listed.iter().any(|&e| e == 0.0), "history dropped");
                }

                /// The check before sums are addressed by grain number:
                /// every grain of the pairs inside, none below, none past.
                #[test]
                fn grains_within_finds_a_grain_outside() {
                    let mut index = Box::new(PairIndex::<super::R, 64, 4>::new());
                    let list = &mut index.list;
                    for (q, (i, j)) in list
                        .pair_i
                        .as_flattened_mut()
                        .iter_mut()
                        .zip(list.pair_j.as_flattened_mut())
                        .take(8)
                        .enumerate()
                    {
                        (*i, *j) = (10 + q as u32, 12 + q as u32);
                    }
                    let list = &index.list;
                    assert!(grains_within(list, 0..8, 10, 10));
                    assert!(!grains_within(list, 0..8, 11, 20), "grain 10 below");
                    assert!(!grains_within(list, 0..8, 10, 9), "grain 19 past");
                    assert!(grains_within(list, 1..7, 11, 8));
                    assert!(!grains_within(list, 0..300, 0, 64), "pairs past the list");
                    assert!(!grains_within(list, 0..0, 0, 0), "no grains");
                    assert!(!grains_within(list, 0..8, 10, 55), "grains past N");
                    // Read masked below N = 64: grain 64 + 10 is grain 10.
                    index.list.pair_j.as_flattened_mut()[0] = 64 + 10;
                    assert!(grains_within(&index.list, 0..8, 10, 10));
                    index.list.pair_j.as_flattened_mut()[0] = 64 + 5;
                    assert!(!grains_within(&index.list, 0..8, 10, 64), "grain 5 below");
                }
            }
        }
    };
}
pub(super) use pairs;

/// Calls the copy of `$pairs::pair_range` for the run-time flags
/// (`$count`, `$no_tension`) and the summing `$sums` on `($r, $out)`: each
/// copy from one call site only, so that each is inlined where it is
/// called (a copy called from two places was inlined into neither: ~50
/// more instructions per grain-step).
macro_rules! pair_range_for {
    ($pairs:ident::<$n:ident, $sums:path>($count:expr, $no_tension:expr, $r:expr, $out:expr)) => {
        match ($count, $no_tension) {
            (true, false) => $pairs::pair_range::<$n, true, false, { $sums }>($r, $out),
            (false, false) => $pairs::pair_range::<$n, false, false, { $sums }>($r, $out),
            (true, true) => $pairs::pair_range::<$n, true, true, { $sums }>($r, $out),
            (false, true) => $pairs::pair_range::<$n, false, true, { $sums }>($r, $out),
        }
    };
}
pub(super) use pair_range_for;
