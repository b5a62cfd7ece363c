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
        let mut before: Option<P::Output> = None;
        let last = cut_ranges(phase, self.0, |range| {
            let out = range.run();
            before = Some(match before.take() {
                Some(first) => P::merge(first, out),
                None => out,
            });
        });
        let last = last.run();
        match before {
            Some(first) => P::merge(first, last),
            None => last,
        }
    }
}

/// Cuts `phase` into `parts` ranges of about equal size (at least one; a
/// phase in lanes cuts at its groups, so a range may be empty): hands the
/// first `parts − 1` to `each` in grain order and returns the last. The
/// cut of [`Ranges`] and of the host's threads.
///
/// ```
/// use mbs_kernel::cut_ranges;
/// # use mbs_kernel::Phase;
/// # struct Span(core::ops::Range<usize>);
/// # impl Phase for Span {
/// #     type Output = ();
/// #     fn grains(&self) -> usize { self.0.len() }
/// #     fn split_at(self, mid: usize) -> (Self, Self) {
/// #         let m = (self.0.start + mid).min(self.0.end);
/// #         (Span(self.0.start..m), Span(m..self.0.end))
/// #     }
/// #     fn run(self) {}
/// #     fn merge(_: (), _: ()) {}
/// # }
/// let mut firsts = [0..0, 0..0];
/// let mut k = 0;
/// let last = cut_ranges(Span(0..10), 3, |range| {
///     firsts[k] = range.0;
///     k += 1;
/// });
/// assert_eq!((firsts, last.0), ([0..3, 3..6], 6..10));
/// ```
pub fn cut_ranges<P: Phase>(phase: P, parts: usize, mut each: impl FnMut(P)) -> P {
    let grains = phase.grains();
    let parts = parts.max(1);
    let (mut rest, mut taken) = (phase, 0usize);
    for k in 1..parts {
        let at = grains.saturating_mul(k) / parts;
        let (range, after) = rest.split_at(at.saturating_sub(taken));
        taken = taken.saturating_add(range.grains());
        each(range);
        rest = after;
    }
    rest
}
