//! Who runs the phases of the [phased step](crate::Sim::step_phased): a
//! [`Phase`] is work over a range of grains that can be cut at any grain,
//! each part run on its own and the outputs merged in grain order; an
//! [`Executor`] runs it whole ([`Serial`]), cut into ranges one after the
//! other ([`Ranges`], as a board does) or on a host's threads. The kernel
//! holds no thread: any cut gives the bits of the whole.

/// One phase of the [phased step](crate::Sim::step_phased) over a range of
/// grains: it can be cut in two at any grain, each part run on its own,
/// and the outputs merged in grain order give what the whole gives.
pub trait Phase: Send + Sized {
    /// What a range gives.
    type Output: Send;
    /// Grains in the range.
    fn grains(&self) -> usize;
    /// The first `mid` grains and the rest (`mid` is clamped to the range;
    /// a phase in lanes cuts at the boundary of its group of grains or
    /// chunk of pairs at or before it, so either part may be empty).
    fn split_at(self, mid: usize) -> (Self, Self);
    /// Runs the range.
    fn run(self) -> Self::Output;
    /// The output of two adjacent ranges, `first` before `second`.
    fn merge(first: Self::Output, second: Self::Output) -> Self::Output;
}

/// Runs the phases of the [phased step](crate::Sim::step_phased): whole,
/// cut into ranges, on one core or many. Any cut gives the same bits.
pub trait Executor {
    /// Runs `phase` and returns its output.
    fn execute<P: Phase>(&self, phase: P) -> P::Output;
}

/// Runs each phase whole, on the calling core.
#[derive(Debug, Clone, Copy, Default)]
pub struct Serial;

impl Executor for Serial {
    fn execute<P: Phase>(&self, phase: P) -> P::Output {
        phase.run()
    }
}

/// Cuts each phase into this many ranges of about equal size (at least
/// one) and runs them one after the other on the calling core: what a
/// host's threads would run, in order, on a board.
///
/// ```
/// use mbs_kernel::{Phases, Ranges, Scenario, Sim};
///
/// let scenario = Scenario::paper();
/// let mut whole = Sim::<f64, 64, 8>::new();
/// scenario.build(&mut whole)?;
/// whole.set_flow(Some(&scenario.flow(0.2)))?;
/// let mut cut = whole.clone();
/// let mut phases = Phases::<f64, 64, 8>::new();
/// for _ in 0..300 {
///     whole.step()?;
///     cut.step_phased(&mut phases, &Ranges(3))?;
/// }
/// assert_eq!(whole.digest(), cut.digest());
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Ranges(pub usize);

impl Executor for Ranges {
    fn execute<P: Phase>(&self, phase: P) -> P::Output {
        fn cut<P: Phase>(phase: P, parts: usize) -> P::Output {
            if parts <= 1 || phase.grains() < 2 {
                return phase.run();
            }
            let mid = phase.grains() * (parts / 2) / parts;
            let (first, second) = phase.split_at(mid);
            let first = cut(first, parts / 2);
            P::merge(first, cut(second, parts - parts / 2))
        }
        cut(phase, self.0)
    }
}
