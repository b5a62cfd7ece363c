//! What the batched step reads and writes: its parameters from the
//! simulation ([`Params`]: the periodic width, the contact law (6)–(9),
//! the integrator (1)–(3), the flow whose drag (4)–(5) it adds first,
//! [`Flow`]), and, for one step in one precision, its borrow of the grains
//! and the pair index ([`BatchStep`]) and of what the clear-water drag
//! reads ([`Drag`]). Implements no equation itself.

use crate::contact::ContactLaw;
use crate::events::Events;
use crate::flow::LogLaw;
use crate::grains::Grains;
use crate::real::Real;
use crate::step::index::PairIndex;
use crate::step::mover::Mover;

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

/// What the batched step of one precision reads and writes: the grains
/// (first `n`) and the pair index.
pub(super) struct BatchStep<'a, R: Real, const N: usize, const K: usize> {
    pub(super) n: usize,
    /// x, y, u, v, ω (moved; the radii are in the pair index).
    pub(super) x: &'a mut [R; N],
    pub(super) y: &'a mut [R; N],
    pub(super) u: &'a mut [R; N],
    pub(super) v: &'a mut [R; N],
    pub(super) w: &'a mut [R; N],
    pub(super) inv_mass: &'a [R; N],
    pub(super) inv_inertia: &'a [R; N],
    pub(super) width: R,
    pub(super) law: ContactLaw<R>,
    pub(super) mover: Mover<R>,
    pub(super) batch: &'a mut PairIndex<R, N, K>,
    /// The clear-water flow's drag, added to the forces first, or None.
    pub(super) drag: Option<Drag<'a, R, N>>,
    /// The contacts made, broken and sliding and the seam crossings.
    pub(super) events: &'a mut Events,
}

impl<'a, R: Real, const N: usize, const K: usize> BatchStep<'a, R, N, K> {
    /// The grains `g`, the pair index `batch` and the parameters `p` of a step.
    /// The step's events are added to `events`.
    pub(super) fn new(
        g: &'a mut Grains<R, N>,
        batch: &'a mut PairIndex<R, N, K>,
        p: &Params<R>,
        events: &'a mut Events,
    ) -> Self {
        BatchStep {
            n: g.len.min(N),
            x: &mut g.x,
            y: &mut g.y,
            u: &mut g.u,
            v: &mut g.v,
            w: &mut g.w,
            inv_mass: &g.inv_mass,
            inv_inertia: &g.inv_inertia,
            width: p.width,
            law: p.law,
            mover: p.mover,
            batch,
            drag: match p.flow {
                Flow::Clear(log_law, bed_level) => Some(Drag {
                    log_law,
                    bed_level,
                    coef: &g.drag_coef,
                    z_u: &g.z_u,
                    z_v: &g.z_v,
                }),
                _ => None,
            },
            events,
        }
    }
}

/// What the drag (4)–(5) of [`LogLaw::drag`] reads: the log law, the mean
/// bed level heights are measured from, and per grain ½ρC_D A2 d² and the
/// held fluctuation draws.
#[derive(Clone, Copy)]
pub(super) struct Drag<'a, R: Real, const N: usize> {
    pub(super) log_law: LogLaw<R>,
    pub(super) bed_level: R,
    pub(super) coef: &'a [R; N],
    pub(super) z_u: &'a [R; N],
    pub(super) z_v: &'a [R; N],
}
