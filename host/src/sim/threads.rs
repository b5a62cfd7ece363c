//! One bed on several cores: the kernel's phased step
//! ([`mbs_kernel::Sim::step_phased`]) with each phase cut among the
//! threads of a [`Team`]. Any cut gives the bits of the whole (the kernel's
//! `step::phased` says why), so results do not depend on the thread count.

use std::sync::OnceLock;

use mbs_kernel::{Executor, Phase, Phases, Real, Sim};

use super::team::Team;

/// Beds smaller than this many grains per range are not cut further: a
/// range's work must outweigh the cost of handing it to a thread (under a
/// microsecond to a spinning helper, tens to one asleep, against about
/// 5–10 ns per grain-step).
pub const MIN_GRAINS_PER_RANGE: usize = 2048;

/// Cuts each phase into `parts` ranges of about equal size and runs them
/// on a [`Team`] of as many threads, started at the first phase cut.
///
/// ```
/// use mbs::sim::threads::Threads;
/// use mbs_kernel::{Phases, Scenario, Sim};
///
/// let scenario = Scenario::paper();
/// let mut one = Sim::<f64, 64, 8>::new();
/// scenario.build(&mut one)?;
/// let mut three = one.clone();
/// let mut phases = Box::new(Phases::<f64, 64, 8>::new());
/// let threads = Threads::exactly(3);
/// for _ in 0..100 {
///     one.step()?;
///     three.step_phased(&mut phases, &threads)?;
/// }
/// assert_eq!(one.digest(), three.digest());
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug)]
pub struct Threads {
    /// Ranges per phase (at least 1).
    parts: usize,
    /// The fewest grains a range is cut to.
    min_grains: usize,
    /// The threads that run the ranges.
    team: OnceLock<Team>,
}

impl Threads {
    /// `threads` ranges per phase, each at least [`MIN_GRAINS_PER_RANGE`]
    /// grains (a small bed gets fewer ranges).
    pub fn new(threads: usize) -> Threads {
        Threads {
            parts: threads.max(1),
            min_grains: MIN_GRAINS_PER_RANGE,
            team: OnceLock::new(),
        }
    }

    /// `parts` ranges per phase however small (for tests: every range
    /// boundary exercised on a small bed).
    pub fn exactly(parts: usize) -> Threads {
        Threads {
            parts: parts.max(1),
            min_grains: 1,
            team: OnceLock::new(),
        }
    }
}

impl Executor for Threads {
    fn execute<P: Phase>(&self, phase: P) -> P::Output {
        let parts = self
            .parts
            .min(phase.grains() / self.min_grains.max(1))
            .max(1);
        if parts == 1 {
            return phase.run();
        }
        let team = self.team.get_or_init(|| Team::new(self.parts));
        team.run(phase, parts)
    }
}

/// A heap [`Phases`] for a simulation of `N` grains, never built on the
/// stack.
pub fn boxed_phases<R: Real, const N: usize, const K: usize>() -> Box<Phases<R, N, K>> {
    let zeroed = Box::<Phases<R, N, K>>::new_zeroed();
    // SAFETY: `Phases` documents (kernel/src/step/buffers.rs) that all-zero
    // bits are a valid, empty value: every field is a number or an array
    // of numbers, and `Real` is sealed to f32 and f64.
    unsafe { zeroed.assume_init() }
}

/// How a host simulation's steps run: [`Sim::run`] on the calling core, or
/// the phased step on threads where the bed is large enough to cut in two
/// ranges of [`MIN_GRAINS_PER_RANGE`] (the same bits either way).
pub struct Stepping<R: Real, const N: usize, const K: usize> {
    phased: Option<(Box<Phases<R, N, K>>, Threads)>,
}

impl<R: Real, const N: usize, const K: usize> Stepping<R, N, K> {
    /// Steps on `threads` threads ([`Threads::new`]); 0 or 1: on the
    /// calling core.
    pub fn new(threads: usize) -> Self {
        Stepping {
            phased: (threads > 1).then(|| (boxed_phases(), Threads::new(threads))),
        }
    }

    /// The buffers and executor of the phased step, if it runs on threads
    /// and a bed of `grains` is large enough to cut in two ranges of
    /// [`MIN_GRAINS_PER_RANGE`] (else the calling core runs it).
    fn cut(&mut self, grains: usize) -> Option<(&mut Phases<R, N, K>, &Threads)> {
        let (phases, threads) = self.phased.as_mut()?;
        (grains >= 2 * threads.min_grains).then_some((&mut **phases, &*threads))
    }

    /// Advances `sim` by `steps` steps.
    pub fn run<const C: usize>(
        &mut self,
        sim: &mut Sim<R, N, K, C>,
        steps: u64,
    ) -> Result<(), mbs_kernel::Error> {
        match self.cut(sim.len()) {
            Some((phases, threads)) => {
                (0..steps).try_for_each(|_| sim.step_phased(phases, threads))
            }
            None => sim.run(steps),
        }
    }

    /// Rebuilds `sim`'s neighbour lists `times` times (a benchmark of the
    /// rebuild alone), the search cut among the threads as a step's is.
    pub fn rebuild<const C: usize>(
        &mut self,
        sim: &mut Sim<R, N, K, C>,
        times: u64,
    ) -> Result<(), mbs_kernel::Error> {
        match self.cut(sim.len()) {
            Some((phases, threads)) => {
                (0..times).try_for_each(|_| sim.rebuild_neighbours_phased(phases, threads))
            }
            None => (0..times).try_for_each(|_| sim.rebuild_neighbours()),
        }
    }
}
