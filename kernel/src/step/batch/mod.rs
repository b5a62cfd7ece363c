//! The batched step (x86-64 with AVX2): the drag (docs/model.md (4)–(5),
//! flow on; with the coupled flow from its column, docs/model.md §13) on
//! every grain, every listed pair's contact force (docs/model.md §2
//! geometry, law (6)–(9)), then every grain's force sum and motion
//! (docs/model.md (1)–(3)), all in vector lanes, with the bits of the
//! scalar step ([`super::scalar`], which runs on every other target).
//!
//! Pairs are independent until their forces are summed, and the sums fix
//! the bits. Every lane does the operations of the scalar step in their
//! order; branches become selects. The three passes, one file each:
//!
//! - `drag`: the drag of every mobile grain, clear water (4)–(5) with
//!   (14)–(16) or the coupled flow's (§13, (C7)), added to its sums;
//! - `pairs`: every listed pair's geometry and law (6)–(9), its force and
//!   torques added to its two grains' sums in pair order, which is the
//!   scalar step's order for each grain (a pair that exerts no force adds
//!   +0 or −0: neither changes a sum's bits, since a sum starts at +0, or
//!   at a drag force added to +0, so it is never −0, and s + 0 = s for
//!   every other s);
//! - `grains`: every grain's motion (1)–(3) from its sums.
//!
//! `phases` regroups the same passes into the phased step's phases over
//! ranges of chunks of pairs and of groups of grains, for several cores,
//! with the same bits ([`phased_step`]; docs/determinism.md).
//!
//! The pairs come from the [pair index](super::index::PairIndex), which
//! lists them in this order and holds their history while it is ready;
//! `params` holds what the passes read ([`Params`], [`Flow`], and the
//! ranges of pairs and of grains they work on).
//!
//! Lanes exist on x86-64 with AVX2 (`target-cpu=x86-64-v3` or newer, the
//! host default), for f64 (four per vector) and f32 (eight), with
//! capacities that are powers of two (every host capacity), so that masked
//! indices need no bounds checks. Elsewhere the scalar step runs. The
//! passes are written once, against the operations of a lane module
//! (`lanes`: [`crate::lanes::f64x4`], [`crate::lanes::f32x8`]); `lanes!` writes the step
//! in each precision's lanes.
//!
//! `unsafe` in the batched step: ten blocks and one `unsafe fn`, audited. Two in `lanes`
//! (`read` and `write`: a vector from and to an array of exactly its
//! size), two here, in `lanes!` (the entry points' calls of the passes,
//! `#[target_feature(enable = "avx2")]` functions), and three in `phases`
//! (each phase's `run`, which calls its pass): all sound because the
//! module is compiled only where the whole build enables AVX2. Two in
//! `pairs`, in the pair phase's copy for chunks whose grains its range
//! all sums: a grain's sums addressed by its number from the range's
//! first grain, sound because every pair's grains lie in the range: the
//! pair phase vouches for a run whose chunks' spans say so (the `unsafe
//! fn` `Out::vouched`, called in `phases`' fourth block: the spans are
//! built from the very pair list the phase reads, keyed by the stamp its
//! indexing drew), and the copy checks any other run itself
//! (`grains_within`; else the tested copy runs).

mod drag;
mod grains;
mod pairs;
mod params;
mod phases;

use crate::error::Error;
use crate::events::Events;
use crate::executor::Executor;
use crate::fluid::Coupling;
use crate::grains::Grains;
use crate::neighbours::Neighbours;
use crate::real::Real;
pub(crate) use crate::step::batch::params::{Flow, Params};
use crate::step::buffers::Phases;
use crate::step::index::PairIndex;
use core::any::Any;

/// Runs the batched step if the pair index is ready: the largest squared
/// speed, or the first grain's error in grain order (as the scalar step).
/// `None`: run the scalar step.
///
/// The vector code exists for `f64` and `f32`; [`Real`] knows nothing of
/// it. The precision is picked by downcasting the (`'static`) grains,
/// index and parameters to each precision's types ([`Any`]): a comparison
/// of two constant type ids, which each monomorphised copy folds away.
#[inline]
pub(crate) fn batched_step<R: Real, const N: usize, const K: usize, const C: usize>(
    grains: &mut Grains<R, N>,
    index: &mut PairIndex<R, N, K>,
    fluid: &mut Coupling<R, C>,
    params: &Params<R>,
    events: &mut Events,
) -> Option<Result<R, Error>> {
    // Cell indices of the coupled flow are exact in f32 lanes below 2^24.
    if !index.ready || C >= 1 << 24 {
        return None;
    }
    let (grains, index, fluid, params): (&mut dyn Any, &mut dyn Any, &mut dyn Any, &dyn Any) =
        (grains, index, fluid, params);
    if let (Some(g), Some(b), Some(f), Some(p)) = (
        grains.downcast_mut::<Grains<f64, N>>(),
        index.downcast_mut::<PairIndex<f64, N, K>>(),
        fluid.downcast_mut::<Coupling<f64, C>>(),
        params.downcast_ref::<Params<f64>>(),
    ) {
        if let Flow::Coupled { turbulence } = p.flow {
            in_f64x4::coupled_drag(g, b, f.cells(), turbulence);
        }
        let max_v2 = in_f64x4::batched_step(g, b, p, events);
        return Some(max_v2.map(R::from_f64));
    }
    if let (Some(g), Some(b), Some(f), Some(p)) = (
        grains.downcast_mut::<Grains<f32, N>>(),
        index.downcast_mut::<PairIndex<f32, N, K>>(),
        fluid.downcast_mut::<Coupling<f32, C>>(),
        params.downcast_ref::<Params<f32>>(),
    ) {
        if let Flow::Coupled { turbulence } = p.flow {
            in_f32x8::coupled_drag(g, b, f.cells(), turbulence);
        }
        let max_v2 = in_f32x8::batched_step(g, b, p, events);
        // Exact: every f32 is an f64.
        return Some(max_v2.map(|v| R::from_f64(f64::from(v))));
    }
    None
}

/// Runs the phased step in lanes (`phases`) if the pair index is ready:
/// as [`batched_step`], with the buffers `phases` of the simulation at
/// `owner` and each phase run by `executor`. `None`: run the scalar phases.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn phased_step<R: Real, const N: usize, const K: usize, const C: usize, E: Executor>(
    grains: &mut Grains<R, N>,
    index: &mut PairIndex<R, N, K>,
    nbrs: &Neighbours<R, N, K>,
    fluid: &mut Coupling<R, C>,
    phases: &mut Phases<R, N, K>,
    owner: usize,
    params: &Params<R>,
    executor: &E,
    events: &mut Events,
) -> Option<Result<R, Error>> {
    if !index.ready || C >= 1 << 24 {
        return None;
    }
    let (grains, index, fluid): (&mut dyn Any, &mut dyn Any, &mut dyn Any) = (grains, index, fluid);
    let (nbrs, phases, params): (&dyn Any, &mut dyn Any, &dyn Any) = (nbrs, phases, params);
    // The step in precision `$t`'s lanes (`$module`), if these are its
    // types; its largest squared speed as an `R` (exact: every f32 is an
    // f64).
    macro_rules! in_lanes {
        ($t:ty, $module:ident) => {
            if let (Some(g), Some(b), Some(nb), Some(f), Some(ph), Some(p)) = (
                grains.downcast_mut::<Grains<$t, N>>(),
                index.downcast_mut::<PairIndex<$t, N, K>>(),
                nbrs.downcast_ref::<Neighbours<$t, N, K>>(),
                fluid.downcast_mut::<Coupling<$t, C>>(),
                phases.downcast_mut::<Phases<$t, N, K>>(),
                params.downcast_ref::<Params<$t>>(),
            ) {
                if let Flow::Coupled { turbulence } = p.flow {
                    $module::coupled_drag(g, b, f.cells(), turbulence);
                }
                let moved = $module::phased_step(g, b, nb, ph, owner, p, executor, events);
                return Some(moved.map(|v| R::from_f64(f64::from(v))));
            }
        };
    }
    in_lanes!(f64, in_f64x4);
    in_lanes!(f32, in_f32x8);
    None
}

/// Writes the batched step in the lanes of one precision as the module
/// `$module`: `$lanes` is the lane module ([`crate::lanes::f64x4`] or
/// [`crate::lanes::f32x8`]: the lane type, its scalar, the row type, the
/// operations) the passes are written in. The passes come from `drag.rs`,
/// `pairs.rs` and `grains.rs`, the phases from `phases.rs` (each writes its
/// own module with its own macro); the entry points call them. Their two `unsafe` blocks call
/// `#[target_feature(enable = "avx2")]` functions from functions that are
/// not: sound because this module is compiled only where the whole build
/// enables AVX2 (`cfg(target_feature = "avx2")`), so the CPU running it
/// has AVX2.
macro_rules! lanes {
    ($module:ident, $lanes:ident) => {
        /// The batched step in these lanes (`lanes!`).
        mod $module {
            use crate::contact::Tension;
            use crate::error::Error;
            use crate::events::Events;
            use crate::executor::Executor;
            use crate::fluid::Cells;
            use crate::grains::Grains;
            use crate::lanes::$lanes::{L, R};
            use crate::neighbours::Neighbours;
            use crate::step::batch::pairs::pair_range_for;
            use crate::step::batch::params::{Moving, PairRange, Params};
            use crate::step::buffers::Phases;
            use crate::step::index::PairIndex;
            use pairs::Out;
            use phases::{DragLanes, MoveLanes, PairLanes};

            crate::step::batch::drag::drag!($lanes);
            crate::step::batch::pairs::pairs!($lanes);
            crate::step::batch::grains::grains!($lanes);
            crate::step::batch::phases::phases!($lanes);

            /// The batched step ([`super::batched_step`]) of the grains `g`
            /// over the pair index `b`. Never inlined: its registers are
            /// allocated on their own, every array one offset from `g` or
            /// `b` (inlined into the step's dispatch, f64 spilled the
            /// grains' base: 7 % more instructions per grain-step).
            #[inline(never)]
            #[allow(unsafe_code)]
            pub(super) fn batched_step<const N: usize, const K: usize>(
                g: &mut Grains<R, N>,
                b: &mut PairIndex<R, N, K>,
                p: &Params<R>,
                events: &mut Events,
            ) -> Result<R, Error> {
                let groups = g.len.min(N).div_ceil(L).min(N / L);
                let parts = b.parts();
                // SAFETY: this module is compiled only with AVX2 enabled for the
                // whole build, so the CPU running it has AVX2.
                unsafe {
                    if let Some(d) = p.clear_drag() {
                        let s = &mut Moving::new(g, parts.mobile, parts.sums, groups, L);
                        drag::drag_pass(s, &d);
                    }
                    let range = &mut PairRange::whole(parts.listed, g, p, parts.e_n, parts.e_s, L);
                    // One copy of the pair pass per (counting, tension
                    // rule): the paper's rule keeps its instructions.
                    let no_tension = p.law.tension == Tension::None;
                    let out = &mut Out::new(0, &mut *parts.sums, &[], &mut []);
                    let counts = pair_range_for!(pairs::<N, pairs::EVERY>(
                        p.count_events,
                        no_tension,
                        range,
                        out
                    ));
                    // Always `Some` in the batched pass.
                    counts.unwrap_or_default().add_to(events);
                    let s = &mut Moving::new(g, parts.mobile, parts.sums, groups, L);
                    let (max_v2, crossings) = grains::grain_pass(s, &p.mover, |_, _| {})?;
                    events.seam_crossings = events.seam_crossings.wrapping_add(crossings);
                    Ok(max_v2)
                }
            }

            /// The phased step in these lanes ([`super::phased_step`]): the
            /// grains `g` over the pair index `b` (built from the lists
            /// `nb`) with the buffers `phases` of the simulation at `owner`,
            /// each phase run by `executor`.
            #[allow(clippy::too_many_arguments)]
            pub(super) fn phased_step<const N: usize, const K: usize, E: Executor>(
                g: &mut Grains<R, N>,
                b: &mut PairIndex<R, N, K>,
                nb: &Neighbours<R, N, K>,
                phases: &mut Phases<R, N, K>,
                owner: usize,
                p: &Params<R>,
                executor: &E,
                events: &mut Events,
            ) -> Result<R, Error> {
                let n = g.len.min(N);
                let groups = n.div_ceil(L).min(N / L);
                let parts = b.parts();
                let lists = phases.index_pairs(nb, &parts, n, owner)?;
                let moved = groups * L;
                if let Some(drag) = p.clear_drag() {
                    let (mobile, sums) = (parts.mobile, &mut *parts.sums);
                    let moving = Moving::new(g, mobile, sums, groups, L);
                    executor.execute(DragLanes { moving, drag });
                }
                let pairs = PairLanes {
                    range: PairRange::whole(parts.listed, g, p, parts.e_n, parts.e_s, L),
                    rows: &mut *lists.rows,
                    start: parts.start,
                    span: lists.span,
                    chunk_span: lists.chunk_span,
                    n,
                    g0: 0,
                    sums: &mut parts.sums[..moved],
                    done: &mut lists.done[..moved],
                    pass: lists.pass,
                    marks: &mut *lists.marks,
                    count: p.count_events,
                    no_tension: p.law.tension == Tension::None,
                };
                executor.execute(pairs).add_to(events);
                let moves = MoveLanes {
                    moving: Moving::new(g, parts.mobile, parts.sums, groups, L),
                    rows: lists.rows,
                    incoming: lists.incoming,
                    from: &lists.from[..moved],
                    to: &lists.to[..moved],
                    own: &parts.start[..moved],
                    count: &nb.count[..moved],
                    done: &lists.done[..moved],
                    mover: p.mover,
                };
                let (max_v2, crossings) = executor.execute(moves)?;
                events.seam_crossings = events.seam_crossings.wrapping_add(crossings);
                Ok(max_v2)
            }

            /// The coupled flow's drag on the grains `g` from its `cells`
            /// into the sums of the pair index `b`, before
            /// [`batched_step`] (`drag::coupled_pass`; the fluctuations on
            /// if `turbulence`). Never inlined, and apart from the batched
            /// step: the clear-water step keeps its code.
            #[inline(never)]
            #[allow(unsafe_code)]
            pub(super) fn coupled_drag<const N: usize, const K: usize>(
                g: &Grains<R, N>,
                b: &mut PairIndex<R, N, K>,
                mut cells: Cells<'_, R>,
                turbulence: bool,
            ) {
                // SAFETY: this module is compiled only with AVX2 enabled for the
                // whole build, so the CPU running it has AVX2.
                unsafe { drag::coupled_pass(g, b, &mut cells, turbulence) }
            }
        }
    };
}

lanes!(in_f64x4, f64x4);
lanes!(in_f32x8, f32x8);
