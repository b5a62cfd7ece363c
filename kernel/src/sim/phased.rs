//! `impl Sim`: the phased step ([`Sim::step_phased`]), the step's
//! operations in the phases of `step::phased` over ranges of grains, for
//! several cores, with the bits of [`Sim::step`] (docs/model.md §2: (1)–(3);
//! docs/determinism.md, "One bed on several cores"), and the rebuild
//! alone with its search in such ranges ([`Sim::rebuild_neighbours_phased`]).

use crate::error::{check, Error};
use crate::executor::Executor;
use crate::real::Real;
use crate::sim::Sim;
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
use crate::step::batch;
use crate::step::buffers::Phases;
use crate::step::phased::{ClearDrag, MovePhase, PairPhase};
use crate::step::scalar;

impl<R: Real, const N: usize, const K: usize, const C: usize> Sim<R, N, K, C> {
    /// Advances one integration step as [`Sim::step`] does, with the same
    /// bits, in the phases of the phased step (`step::phased`): the pairs'
    /// forces into `phases`, then each grain's sums gathered in the scalar
    /// step's order and its move, each phase run by `executor` over ranges
    /// of grains (whole, cut, on threads: any cut gives the same bits). The
    /// neighbour refresh, the flow's bookkeeping and the coupled flow's drag
    /// run before, on the calling core. One `phases` serves one simulation
    /// (it is re-indexed when given another's, or when the lists change).
    ///
    /// ```
    /// use mbs_kernel::{Phases, Ranges, Scenario, Sim};
    ///
    /// let mut sim = Sim::<f32, 64, 8>::new();
    /// Scenario::paper().build(&mut sim)?;
    /// let mut phases = Phases::<f32, 64, 8>::new();
    /// sim.step_phased(&mut phases, &Ranges(2))?;
    /// assert_eq!(sim.step_count(), 1);
    /// # Ok::<(), mbs_kernel::Error>(())
    /// ```
    pub fn step_phased<E: Executor>(
        &mut self,
        phases: &mut Phases<R, N, K>,
        executor: &E,
    ) -> Result<(), Error> {
        // A stale list's search runs in ranges too, its cursors in the
        // room of `phases`.
        let mut events = self.prepare(|sim| sim.rebuild(phases.scratch(), executor))?;
        events.phased_steps = 1;
        let owner = core::ptr::from_ref(self) as usize;
        let mover = self.mover();
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        {
            let params = self.batch_params(mover);
            let (g, index, nbrs) = (&mut self.grains, &mut self.index, &self.nbrs);
            let fluid = &mut self.fluid;
            let e = &mut events;
            let lanes =
                batch::phased_step(g, index, nbrs, fluid, phases, owner, &params, executor, e);
            if let Some(moved) = lanes {
                events.batched_steps = 1;
                return self.finish(moved, events);
            }
        }
        let drag = if self.flow_on && self.fluid.on {
            scalar::add_coupled_drag(&mut self.grains, &mut self.fluid, &self.log_law);
            None
        } else if self.flow_on {
            Some(ClearDrag {
                log_law: self.log_law,
                bed_level: self.bed_level,
                surface: self.surface,
            })
        } else {
            None
        };
        self.index.history_to_slots(&mut self.nbrs.spring);
        let n = self.grains.len.min(N);
        let moved = match phases.index(&self.nbrs, n, owner) {
            Ok(()) => {
                let pairs = PairPhase::new(
                    &self.grains,
                    &mut self.nbrs,
                    phases,
                    n,
                    self.law,
                    self.width,
                );
                executor.execute(pairs).add_to(&mut events);
                let moves = MovePhase::new(&mut self.grains, &self.nbrs, phases, n, drag, mover);
                executor.execute(moves).map(|(max_v2, crossings)| {
                    events.seam_crossings = events.seam_crossings.wrapping_add(crossings);
                    max_v2
                })
            }
            Err(e) => Err(e),
        };
        self.finish(moved, events)
    }

    /// As [`Sim::rebuild_neighbours`], the search run by `executor` over
    /// ranges of grains as [`Sim::step_phased`] runs it (its cursors in the
    /// room of `phases`): the same lists.
    ///
    /// ```
    /// use mbs_kernel::{Phases, Ranges, Scenario, Sim};
    ///
    /// let mut sim = Sim::<f64, 64, 8>::new();
    /// Scenario::paper().build(&mut sim)?;
    /// let mut cut = sim.clone();
    /// sim.rebuild_neighbours()?;
    /// cut.rebuild_neighbours_phased(&mut Phases::new(), &Ranges(3))?;
    /// sim.step()?;
    /// cut.step()?;
    /// assert_eq!(sim.digest(), cut.digest());
    /// # Ok::<(), mbs_kernel::Error>(())
    /// ```
    pub fn rebuild_neighbours_phased<E: Executor>(
        &mut self,
        phases: &mut Phases<R, N, K>,
        executor: &E,
    ) -> Result<(), Error> {
        check(self.configured, "sim", 0.0, "configured by reset() first")?;
        self.rebuild(phases.scratch(), executor)
    }
}

#[cfg(test)]
mod tests {
    use crate::{Phases, Ranges, Real, Scenario, Sim};
    use std::boxed::Box;

    /// A bed of 30 columns × 12 rows (372 grains) under flow, stepped
    /// whole and by the phased step cut into 2, 3, 5 and 9 ranges: the
    /// same bits, in the phases in lanes where this build has them (every
    /// step), in both precisions (f32: 8 lanes and chunks of 64 pairs;
    /// f64: 4 and 32).
    fn cuts_give_the_bits_of_the_whole<R: Real>() {
        let scenario = Scenario::paper_bed(30, 12);
        let mut whole = Box::new(Sim::<R, 512, 8>::new());
        scenario.build(&mut whole).unwrap();
        whole.set_flow(Some(&scenario.flow(0.3))).unwrap();
        let start = whole.clone();
        for _ in 0..400 {
            whole.step().unwrap();
        }
        let lanes = cfg!(all(target_arch = "x86_64", target_feature = "avx2"));
        let mut phases = Box::new(Phases::<R, 512, 8>::new());
        for parts in [2, 3, 5, 9] {
            let mut cut = start.clone();
            for _ in 0..400 {
                cut.step_phased(&mut phases, &Ranges(parts)).unwrap();
            }
            let with = (R::NAME, parts);
            assert_eq!(cut.digest(), whole.digest(), "{with:?}");
            let events = cut.events();
            assert_eq!(events.phased_steps, 400, "{with:?}");
            assert_eq!(events.batched_steps == 400, lanes, "{with:?}");
        }
    }

    #[test]
    fn cuts_give_the_bits_of_the_whole_f64() {
        cuts_give_the_bits_of_the_whole::<f64>();
    }

    #[test]
    fn cuts_give_the_bits_of_the_whole_f32() {
        cuts_give_the_bits_of_the_whole::<f32>();
    }
}
