//! What the batched step reads and writes: its parameters from the
//! simulation ([`Params`]: the periodic width, the contact law (6)–(9),
//! the integrator (1)–(3), the flow whose drag (4)–(5) it adds first,
//! [`Flow`]), and, for one step in one precision, its borrow of the grains
//! and the pair index ([`BatchStep`]) and of what the clear-water drag
//! reads ([`Drag`]). Implements no equation itself.

use crate::contact::ContactLaw;
use crate::flow::LogLaw;
use crate::grains::Grains;
use crate::real::Real;
use crate::step::index::{Listed, CHUNK};
use crate::step::mover::Mover;
use crate::step::phased::ClearDrag;
use core::ops::Range;

/// What the batched step reads besides the grains, the pair index and
/// the coupled flow: the periodic width, the contact law, the integrator,
/// and the flow.
#[derive(Clone, Copy)]
pub(crate) struct Params<R: Real> {
    pub(crate) width: R,
    pub(crate) law: ContactLaw<R>,
    pub(crate) mover: Mover<R>,
    pub(crate) flow: Flow<R>,
    /// Count the contacts made, broken and sliding ([`crate::Sim::count_events`]).
    pub(crate) count_events: bool,
}

impl<R: Real> Params<R> {
    /// The clear-water drag's parameters, if the flow is clear water.
    pub(crate) fn clear_drag(&self) -> Option<ClearDrag<R>> {
        match self.flow {
            Flow::Clear(log_law, bed_level) => Some(ClearDrag {
                log_law,
                bed_level,
                surface: self.mover.surface,
            }),
            _ => None,
        }
    }
}

/// The flow whose drag the batched step adds first.
#[derive(Clone, Copy)]
pub(crate) enum Flow<R: Real> {
    /// No flow: no drag.
    Off,
    /// The clear-water flow: its log law and the mean bed level.
    Clear(LogLaw<R>, R),
    /// The coupled flow, from its column (the `Coupling` passed along);
    /// the fluctuations (15) on or off (`LogLaw::turbulence`).
    Coupled { turbulence: bool },
}

/// What the pair pass reads and writes over a range of chunks of
/// [`CHUNK`](crate::step::index::CHUNK) batches: the pair list, every
/// grain's start-of-step x, y, u, v, ω, the law, the periodic width, and
/// the range's spring history (from its first pair).
pub(super) struct PairRange<'a, R: Real, const N: usize> {
    pub(super) listed: Listed<'a, N>,
    pub(super) grains: &'a Grains<R, N>,
    pub(super) law: ContactLaw<R>,
    pub(super) width: R,
    /// The range's chunks (indices of chunks).
    pub(super) chunks: Range<usize>,
    /// The history (e_n, e_s) of the range's pairs, from its first pair:
    /// whole chunks (the pair pass reads them chunk by chunk).
    pub(super) e_n: &'a mut [R],
    pub(super) e_s: &'a mut [R],
}

impl<'a, R: Real, const N: usize> PairRange<'a, R, N> {
    /// Every chunk of the pair list `listed` over the grains `g`, with the
    /// law and width of `p` and the history `e_n`, `e_s`; `lanes` pairs per
    /// batch.
    pub(super) fn whole(
        listed: Listed<'a, N>,
        g: &'a Grains<R, N>,
        p: &Params<R>,
        e_n: &'a mut [R],
        e_s: &'a mut [R],
        lanes: usize,
    ) -> Self {
        PairRange {
            listed,
            grains: g,
            law: p.law,
            width: p.width,
            chunks: 0..listed.pairs.div_ceil(CHUNK * lanes),
            e_n,
            e_s,
        }
    }
}

/// The grains of a range of whole groups of lanes' worth (from grain
/// `first`, a multiple of the lanes) as the drag and grain passes read and
/// move them: state, inverse mass and inertia, lane mask of the mobile,
/// sums, and what the clear-water drag reads (½ρC_D A2 d², the held
/// fluctuation draws).
pub(super) struct Moving<'a, R: Real> {
    pub(super) first: usize,
    pub(super) x: &'a mut [R],
    pub(super) y: &'a mut [R],
    pub(super) u: &'a mut [R],
    pub(super) v: &'a mut [R],
    pub(super) w: &'a mut [R],
    pub(super) inv_mass: &'a [R],
    pub(super) inv_inertia: &'a [R],
    pub(super) mobile: &'a [R],
    pub(super) sums: &'a mut [[R; 4]],
    pub(super) coef: &'a [R],
    pub(super) z_u: &'a [R],
    pub(super) z_v: &'a [R],
}

impl<'a, R: Real> Moving<'a, R> {
    /// The first `groups` groups of `lanes` grains of `g`, with the pair
    /// index's lane masks `mobile` and `sums`.
    pub(super) fn new<const N: usize>(
        g: &'a mut Grains<R, N>,
        mobile: &'a [R; N],
        sums: &'a mut [[R; 4]; N],
        groups: usize,
        lanes: usize,
    ) -> Self {
        let n = (groups * lanes).min(N);
        Moving {
            first: 0,
            x: &mut g.x[..n],
            y: &mut g.y[..n],
            u: &mut g.u[..n],
            v: &mut g.v[..n],
            w: &mut g.w[..n],
            inv_mass: &g.inv_mass[..n],
            inv_inertia: &g.inv_inertia[..n],
            mobile: &mobile[..n],
            sums: &mut sums[..n],
            coef: &g.drag_coef[..n],
            z_u: &g.z_u[..n],
            z_v: &g.z_v[..n],
        }
    }

    /// Grains in the range.
    pub(super) fn len(&self) -> usize {
        self.x.len()
    }

    /// The first `mid` grains of the range and the rest (`mid` clamped).
    #[allow(clippy::needless_update)] // `cut_at!` names every field here
    pub(super) fn split_at(mut self, mid: usize) -> (Self, Self) {
        let mid = mid.min(self.x.len());
        crate::step::phased::cut_at!(self, mid;
            mut x, y, u, v, w, sums;
            ref inv_mass, inv_inertia, mobile, coef, z_u, z_v)
    }
}
