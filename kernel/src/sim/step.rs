//! `impl Sim`: the step (docs/model.md §2: equations of motion (1)–(3),
//! symplectic Euler). [`Sim::step`] refreshes the neighbour slots and the
//! pair index, does the flow's bookkeeping (the coupled flow's update every
//! M steps, `Sim::exchange`; the mean bed level; the fluctuation draws),
//! then moves every grain by one of the two paths of [`crate::step`],
//! which give the same bits: the **batched step** (x86-64 with AVX2) where
//! its pair index is ready, else the **scalar step**.

use crate::error::{check, Error};
use crate::events::Events;
use crate::executor::{Executor, Serial};
use crate::flow::fluctuation_draw;
use crate::real::Real;
use crate::sim::{Redraw, Sim};
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
use crate::step::batch;
use crate::step::scalar;
use crate::step::GEOMETRY_AHEAD;

impl<R: Real, const N: usize, const K: usize, const C: usize> Sim<R, N, K, C> {
    /// Advances `steps` steps.
    pub fn run(&mut self, steps: u64) -> Result<(), Error> {
        for _ in 0..steps {
            self.step()?;
        }
        Ok(())
    }

    /// Advances one integration step ([`crate::SimConfig::step_dt`]):
    /// neighbour refresh, flow bookkeeping, forces, symplectic Euler
    /// (velocities, then positions), checks.
    pub fn step(&mut self) -> Result<(), Error> {
        // No buffers at all on microcontrollers (their stacks are small).
        if GEOMETRY_AHEAD {
            self.step_with::<K, true>()
        } else {
            self.step_with::<0, true>()
        }
    }

    /// [`Sim::step`] with the batched step where it has lanes and its index
    /// is ready (`BATCHED`, `batch::batched_step`), else the scalar step
    /// with buffers of `BUFFER` contacts to find the pair geometry one grain
    /// ahead, or none ([`scalar::step`]). All give the same bits.
    fn step_with<const BUFFER: usize, const BATCHED: bool>(&mut self) -> Result<(), Error> {
        let mut events = self.prepare(|sim| sim.rebuild(&mut [], &Serial))?;
        let coupled = self.flow_on && self.fluid.on;
        let mover = self.mover();
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        let batched = if BATCHED {
            let params = self.batch_params(mover);
            let (g, index, fluid) = (&mut self.grains, &mut self.index, &mut self.fluid);
            batch::batched_step(g, index, fluid, &params, &mut events)
        } else {
            None
        };
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
        let batched = None;
        let moved = match batched {
            Some(moved) => {
                events.batched_steps = 1;
                moved
            }
            None => {
                if coupled {
                    scalar::add_coupled_drag(&mut self.grains, &mut self.fluid, &self.log_law);
                } else if self.flow_on {
                    scalar::add_drag(
                        &mut self.grains,
                        &self.log_law,
                        self.bed_level,
                        self.surface,
                    );
                }
                self.index.history_to_slots(&mut self.nbrs.spring);
                let (g, nb) = (&mut self.grains, &mut self.nbrs);
                scalar::step::<R, N, K, BUFFER>(g, nb, self.law, self.width, mover, &mut events)
            }
        };
        self.finish(moved, events)
    }

    /// The step's start, shared with [`Sim::step_phased`]: the neighbour
    /// refresh (`rebuild` where the lists are stale) and the flow's
    /// bookkeeping (the coupled flow's update every M steps, the mean bed
    /// level, the fluctuation draws); the events so far.
    pub(super) fn prepare(
        &mut self,
        rebuild: impl FnOnce(&mut Self) -> Result<(), Error>,
    ) -> Result<Events, Error> {
        check(self.configured, "sim", 0.0, "configured by reset() first")?;
        if self.nbrs.stale {
            rebuild(self)?;
        }
        let mut events = Events::ZERO;
        if self.flow_on {
            let since = self.step.saturating_sub(self.flow_epoch);
            let update = u64::from(self.flow.fluid.spec.update_steps.0.max(1));
            let exchange = self.fluid.on && since > 0 && since.is_multiple_of(update);
            if exchange {
                self.exchange()?;
            }
            let bed_level =
                since.is_multiple_of(u64::from(self.flow.spec.bed_level_interval.0.max(1)));
            if bed_level {
                self.update_bed_level();
                events.bed_level_updates = 1;
            }
            if self.fluid.on && (exchange || bed_level) {
                self.refresh_coupling();
            }
            let hold = u64::from(self.flow.spec.hold_steps.0.max(1));
            let turbulence = self.log_law.turbulence;
            if turbulence && self.fluid.on && self.fluid.closures.hfe {
                // HydroForceEngine's (C9): every eddy turnover.
                if self.step >= self.redraw.next {
                    self.draw_fluctuations(self.redraw.period);
                    self.redraw = Redraw {
                        next: self.step.saturating_add(self.eddy_turnover_steps()),
                        period: self.redraw.period.wrapping_add(1),
                    };
                    events.turbulence_redraws = 1;
                }
            } else if turbulence && since.is_multiple_of(hold) {
                self.draw_fluctuations(since / hold);
                events.turbulence_redraws = 1;
            }
        }
        Ok(events)
    }

    /// The step's end, shared with [`Sim::step_phased`]: on success the travel since
    /// the last rebuild, the step count and the events; on failure the
    /// forces cleared.
    pub(super) fn finish(
        &mut self,
        moved: Result<R, Error>,
        mut events: Events,
    ) -> Result<(), Error> {
        match moved {
            Ok(max_v2) => {
                // The grains moved at most max_v2^½ step_dt.
                self.nbrs.add_travel(R::sqrt(max_v2) * self.step_dt);
                self.step = self.step.saturating_add(1); // a restored count may be u64::MAX
                if !self.count_events {
                    // Contacts and seam crossings are counted only on request.
                    events = Events {
                        bed_level_updates: events.bed_level_updates,
                        turbulence_redraws: events.turbulence_redraws,
                        batched_steps: events.batched_steps,
                        phased_steps: events.phased_steps,
                        ..Events::ZERO
                    };
                }
                self.events.add(&events);
                Ok(())
            }
            Err(e) => {
                self.clear_forces();
                Err(e)
            }
        }
    }

    /// Rebuilds the neighbour slots, their search run by `executor` over
    /// ranges of grains (`spare`: room for the bucket cursors of ranges
    /// after the first, [`Neighbours::search`]; the same lists), then the
    /// batched step's pair index from them (the slots first get the
    /// history back from the index).
    pub(super) fn rebuild<E: Executor>(
        &mut self,
        spare: &mut [u32],
        executor: &E,
    ) -> Result<(), Error> {
        self.index.history_to_slots(&mut self.nbrs.spring);
        let bins = self.nbrs.sort(&self.grains, self.width, self.y_min)?;
        executor.execute(self.nbrs.search(&self.grains, bins, spare))?;
        self.nbrs.built();
        // A pair across the seam has both grains (so its first) within the
        // cut-off of it, and a grain moves less than half a skin before the
        // next rebuild.
        let margin = self.nbrs.cutoff + self.nbrs.skin;
        self.index
            .index(&self.grains, &self.nbrs, self.width, margin);
        Ok(())
    }

    /// Rebuilds the neighbour lists now. Results never depend on when the
    /// lists are rebuilt; this is for benchmarks of the rebuild alone.
    pub fn rebuild_neighbours(&mut self) -> Result<(), Error> {
        check(self.configured, "sim", 0.0, "configured by reset() first")?;
        self.rebuild(&mut [], &Serial)
    }

    /// Zeroes every force and torque. They are zero between steps: both
    /// steps zero each grain's once it is integrated, and a failed step
    /// calls this.
    fn clear_forces(&mut self) {
        let n = self.grains.len;
        let g = &mut self.grains;
        g.fx[..n].fill(R::ZERO);
        g.fy[..n].fill(R::ZERO);
        g.torque[..n].fill(R::ZERO);
    }

    /// Redraws every grain's held fluctuation (docs/model.md (15)) for hold `period`.
    fn draw_fluctuations(&mut self, period: u64) {
        let seed = self.config.seed;
        let g = &mut self.grains;
        for i in 0..g.len {
            let (a, b) = fluctuation_draw(seed, period, i as u32);
            g.z_u[i] = R::from_f64(a);
            g.z_v[i] = R::from_f64(b);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{GrainSpec, Scenario, Tension};

    /// Whether this build has the batched step's lanes.
    const LANES: bool = cfg!(all(target_arch = "x86_64", target_feature = "avx2"));

    /// `events` without the count of batched steps, which is all that may
    /// differ between the two paths.
    fn without_path(events: Events) -> Events {
        Events {
            batched_steps: 0,
            ..events
        }
    }

    /// The paper's scenario with the `tension` rule, settling then flow,
    /// stepped with the batched step where it has lanes (`BATCHED`) or the
    /// scalar step with the pair geometry found ahead (`BUFFER` > 0) or
    /// not: (settled, flow) digests and the events.
    fn digests<R: Real, const BUFFER: usize, const BATCHED: bool>(
        tension: Tension,
    ) -> (u64, u64, Events) {
        let mut sim = Sim::<R, 64, 8>::new();
        let sc = Scenario {
            tension,
            ..Scenario::paper()
        };
        sc.build(&mut sim).unwrap();
        sim.count_events(true);
        for _ in 0..1500 {
            sim.step_with::<BUFFER, BATCHED>().unwrap();
        }
        let settled = sim.digest();
        sim.set_flow(Some(&sc.flow(Scenario::PAPER_TAU_STAR)))
            .unwrap();
        for _ in 0..1500 {
            sim.step_with::<BUFFER, BATCHED>().unwrap();
        }
        let flow = sim.digest();
        // Wherever the history lives, each contact's is found by its pair.
        let contacts = sim.contacts().collect::<heapless::Vec<_, 512>>();
        assert!(contacts.len() > 32, "{}", contacts.len());
        for &(i, j, h) in &contacts {
            let h = (h.e_n.to_f64(), h.e_s.to_f64());
            assert_eq!(sim.contact_history(j, i), Some(h));
        }
        // The batched step runs where it has lanes (both precisions have
        // them), and only where asked.
        let events = sim.events();
        assert_eq!(events.batched_steps > 0, BATCHED && LANES, "{events:?}");
        for made in [
            events.contacts_made,
            events.contacts_broken,
            events.contacts_sliding,
        ] {
            assert!(made > 0, "{events:?}");
        }
        (settled, flow, without_path(events))
    }

    /// The host's loop shapes (batched step in lanes; scalar step with the
    /// geometry one grain ahead) and the microcontroller's (scalar step, in
    /// order) give the same bits, with either tension rule; the rules differ.
    #[test]
    fn batched_and_scalar_ahead_or_not_give_the_same_bits() {
        let mut paper = None;
        for tension in [Tension::Dashpot, Tension::None] {
            let scalar = digests::<f64, 0, false>(tension);
            assert_eq!(digests::<f64, 8, false>(tension), scalar);
            assert_eq!(digests::<f64, 8, true>(tension), scalar);
            let scalar32 = digests::<f32, 0, false>(tension);
            assert_eq!(digests::<f32, 8, false>(tension), scalar32);
            assert_eq!(digests::<f32, 8, true>(tension), scalar32);
            match paper {
                None => paper = Some((scalar, scalar32)),
                Some((a, b)) => assert!(a.1 != scalar.1 && b.1 != scalar32.1),
            }
        }
    }

    /// The paper's bed settled, then under the coupled flow at the paper's
    /// τ* (hindrance on, an update every 100 steps), stepped as
    /// [`digests`] does: the digest. With `closures`, HydroForceEngine's
    /// (Dallavalle's drag, its fluctuations, side walls 1.1 d apart) under
    /// a free surface 9 d above the fixed grains, below the bed's top
    /// grains: some are out of the water (asserted); with `overburden` too,
    /// the walls' load of the grains above (C12, K = 0.5).
    fn coupled_digest<R: Real, const BUFFER: usize, const BATCHED: bool>(
        closures: bool,
        overburden: bool,
    ) -> u64 {
        let mut sim = std::boxed::Box::new(Sim::<R, 64, 8, 1024>::new());
        let mut sc = Scenario::paper();
        let d = sc.bed.max_diameter();
        if closures {
            sc.flow.depth = 9.0 * d;
        }
        let info = sc.build(&mut *sim).unwrap();
        for _ in 0..1500 {
            sim.step_with::<BUFFER, BATCHED>().unwrap();
        }
        let tau_star = if closures {
            0.6
        } else {
            Scenario::PAPER_TAU_STAR
        };
        let mut flow = sc.flow(tau_star);
        let bottom = info.y_min + 1.5 * d;
        let depth = flow.spec.depth;
        let fluid_cells = ((depth - bottom) / (0.5 * d)) as usize;
        let mut fluid = crate::fluid::FluidConfig::new(fluid_cells, bottom, depth, info.width * d);
        fluid.driving = crate::fluid::FluidConfig::driving_for(flow.u_star, depth);
        fluid.spec.hindrance = 3.1;
        if closures {
            fluid.spec.drag = crate::DragLaw::Dallavalle;
            fluid.spec.fluctuations = crate::Fluctuations::Hfe;
            fluid.spec.channel_width = 1.1 * d;
            fluid.spec.grain_wall_friction = 0.4;
            fluid.spec.lateral_ratio = if overburden { 0.5 } else { 0.0 };
        }
        (flow.spec.model, flow.fluid) = (crate::FlowModel::Coupled, fluid);
        sim.set_flow(Some(&flow)).unwrap();
        let mut aloft = 0;
        for _ in 0..2000 {
            sim.step_with::<BUFFER, BATCHED>().unwrap();
            let g = &sim.grains;
            aloft += (0..g.len).filter(|&i| g.y[i] > sim.surface).count();
        }
        assert_eq!(aloft > 0, closures, "grain steps out of the water: {aloft}");
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        assert_eq!(sim.index.ready, BATCHED);
        assert_eq!(sim.events().batched_steps > 0, BATCHED && LANES);
        assert!(sim.fluid_in_transit() != 0.0, "the column was updated");
        sim.digest()
    }

    /// The coupled flow: the batched step and the scalar step (geometry
    /// ahead or not) give the same bits, in both precisions, with the
    /// paper's closures and with HydroForceEngine's under a free surface,
    /// with and without the overburden's load on the walls (C12).
    #[test]
    fn coupled_flow_is_batched_with_the_scalar_bits() {
        let mut seen = std::vec::Vec::new();
        for (closures, overburden) in [(false, false), (true, false), (true, true)] {
            let scalar = coupled_digest::<f64, 0, false>(closures, overburden);
            assert!(!seen.contains(&scalar), "each option changes the run");
            seen.push(scalar);
            assert_eq!(
                coupled_digest::<f64, 8, false>(closures, overburden),
                scalar
            );
            assert_eq!(coupled_digest::<f64, 8, true>(closures, overburden), scalar);
            let scalar = coupled_digest::<f32, 0, false>(closures, overburden);
            assert_eq!(
                coupled_digest::<f32, 8, false>(closures, overburden),
                scalar
            );
            assert_eq!(coupled_digest::<f32, 8, true>(closures, overburden), scalar);
        }
    }

    /// A grain in many pairs (a large grain ringed by 14 small ones, as
    /// first or as second grain of its pairs, so that one batch adds to its
    /// sums in many lanes): the batched step gives the scalar step's bits.
    #[test]
    fn a_grain_in_many_pairs_is_batched_with_the_scalar_bits() {
        for big_first in [true, false] {
            let ring = |batched: bool| ring_digest::<f64>(big_first, batched);
            assert_eq!(ring(true), ring(false));
            let ring = |batched: bool| ring_digest::<f32>(big_first, batched);
            assert_eq!(ring(true), ring(false));
        }
    }

    /// A bed 24 columns wide drifting across the periodic seam at 1 m/s
    /// (grains of the last column wrap around between rebuilds), so that
    /// chunks of pairs away from the seam skip the periodic image and those
    /// near it do not: the batched step gives the scalar step's bits step after
    /// step, in both precisions. It fails if the chunks near the seam are
    /// not marked.
    #[test]
    fn a_bed_drifting_across_the_seam_steps_batched_as_scalar() {
        drifts_across_the_seam::<f64>();
        drifts_across_the_seam::<f32>();
    }

    fn drifts_across_the_seam<R: Real>() {
        let mut sc = Scenario::paper();
        sc.bed.columns = 24;
        let mut batched = std::boxed::Box::new(Sim::<R, 512, 8>::new());
        sc.build(&mut batched).unwrap();
        batched.count_events(true);
        batched.run(8000).unwrap();
        for i in 0..batched.len() {
            if !batched.grains.fixed[i] {
                batched.grains.u[i] = R::from_f64(1.0);
            }
        }
        let mut scalar = batched.clone();
        let crossed = batched.events().seam_crossings;
        let before = batched.events().batched_steps;
        let mut wraps = 0;
        for _ in 0..400 {
            let xs = batched.grains.x;
            batched.step_with::<8, true>().unwrap();
            scalar.step_with::<0, false>().unwrap();
            assert_eq!(batched.digest(), scalar.digest());
            assert_eq!(
                without_path(batched.events()),
                without_path(scalar.events())
            );
            let half = 0.5 * batched.width.to_f64();
            wraps += (0..batched.len())
                .filter(|&i| (xs[i] - batched.grains.x[i]).to_f64() > half)
                .count();
        }
        assert!(wraps >= 10, "{wraps} grains wrapped around");
        // The 400 steps compared ran batched (where there are lanes) and scalar.
        assert_eq!(
            batched.events().batched_steps - before,
            if LANES { 400 } else { 0 }
        );
        assert_eq!(scalar.events().batched_steps, before);
        assert_eq!(batched.events().seam_crossings - crossed, wraps as u64);
        assert!(
            batched.contacts().count() > batched.len(),
            "a bed in contact"
        );
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        {
            let (marked, chunks) = batched.index.chunks_near_the_seam();
            assert!(marked > 0 && marked < chunks, "{marked} of {chunks}");
        }
    }

    /// An empty 0.02 m wide box of the paper's constants and the `tension`
    /// rule, floor at −0.01 m, room for 64 grains of up to 16 neighbours
    /// (and C fluid cells of a coupled flow).
    fn small_box<R: Real, const C: usize>(tension: Tension) -> Sim<R, 64, 16, C> {
        let mut sim = Sim::new();
        let mut config = Scenario::paper().sim_config().unwrap();
        (config.width, config.y_min, config.tension) = (0.02, -0.01, tension);
        sim.reset(&config).unwrap();
        sim.count_events(true);
        sim
    }

    /// One step of a [`small_box`], batched or scalar (no buffer).
    fn step_small_box<R: Real, const C: usize>(
        sim: &mut Sim<R, 64, 16, C>,
        batched: bool,
    ) -> Result<(), Error> {
        if batched {
            sim.step_with::<16, true>()
        } else {
            sim.step_with::<0, false>()
        }
    }

    fn ring_digest<R: Real>(big_first: bool, batched: bool) -> u64 {
        let mut sim = small_box::<R, 0>(Tension::Dashpot);
        let big = GrainSpec {
            x: 0.01,
            y: 0.005,
            diameter: 2e-3,
            ..GrainSpec::default()
        };
        if big_first {
            sim.add_grain(&big).unwrap();
        }
        for k in 0..14 {
            let angle = core::f64::consts::TAU * f64::from(k) / 14.0;
            let reach = 1.249e-3;
            sim.add_grain(&GrainSpec {
                x: big.x + reach * libm::cos(angle),
                y: big.y + reach * libm::sin(angle),
                diameter: 0.5e-3,
                ..GrainSpec::default()
            })
            .unwrap();
        }
        if !big_first {
            sim.add_grain(&big).unwrap();
        }
        for _ in 0..20 {
            step_small_box(&mut sim, batched).unwrap();
        }
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        assert_eq!(sim.index.ready, batched);
        assert_eq!(sim.events().batched_steps > 0, batched && LANES);
        assert_eq!(sim.contacts().count(), 14);
        sim.digest()
    }

    /// A grain of a random cluster: x, y (m), u, v (m/s), spin (rad/s),
    /// size class (0.4, 0.5 or 0.7 mm) and whether it is fixed.
    type Loose = (f64, f64, f64, f64, f64, usize, bool);

    /// Up to 60 random grains for `cluster`: (x, y, u, v, spin, size
    /// class, fixed).
    fn cluster_grains(
    ) -> impl proptest::strategy::Strategy<Value = std::vec::Vec<(f64, f64, f64, f64, f64, usize, bool)>>
    {
        proptest::collection::vec(
            (
                0.0..0.02f64,
                0.0..0.0015f64,
                -0.05..0.05f64,
                -0.05..0.05f64,
                -50.0..50.0f64,
                0..3usize,
                proptest::bool::weighted(0.15),
            ),
            1..60,
        )
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            cases: 48,
            ..proptest::prelude::ProptestConfig::default()
        })]
        /// Random clusters of mixed sizes, some fixed, some overlapping, with
        /// and without flow: the batched step gives the scalar step's bits
        /// step after step, or the same error.
        #[test]
        fn random_clusters_step_batched_as_scalar(
            grains in cluster_grains(),
            flow: bool,
            no_tension: bool,
        ) {
            let t = if no_tension { Tension::None } else { Tension::Dashpot };
            let flow = flow.then(|| Scenario::paper().flow(Scenario::PAPER_TAU_STAR));
            let flow = flow.as_ref();
            proptest::prop_assert_eq!(cluster::<f64, 0>(&grains, flow, t, true), cluster::<f64, 0>(&grains, flow, t, false));
            proptest::prop_assert_eq!(cluster::<f32, 0>(&grains, flow, t, true), cluster::<f32, 0>(&grains, flow, t, false));
        }

        /// Random clusters under the coupled flow, its column from below
        /// the grains or from among them, to among them or above them (so
        /// that grains lie below the first fluid cell's centre, between the
        /// centres and above the last), hindrance on or off, the
        /// fluctuations on or off, an update every few steps: the batched
        /// step gives the scalar step's bits step after step, or the same
        /// error.
        #[test]
        fn random_clusters_under_the_coupled_flow_step_batched_as_scalar(
            grains in cluster_grains(),
            bottom in -0.002..0.001f64,
            height in 0.0005..0.004f64,
            fluid_cells in 2..16usize,
            hindered: bool,
            turbulence: bool,
            update_steps in 1..8u32,
        ) {
            let mut flow = Scenario::paper().flow(Scenario::PAPER_TAU_STAR);
            flow.spec.turbulence = turbulence;
            let mut fluid = crate::fluid::FluidConfig::new(fluid_cells, bottom, bottom + height, 0.02 * 0.5e-3);
            fluid.driving = crate::fluid::FluidConfig::driving_for(flow.u_star, flow.spec.depth);
            fluid.spec.hindrance = if hindered { 3.1 } else { 0.0 };
            fluid.spec.update_steps = crate::IntegrationSteps(update_steps);
            (flow.spec.model, flow.fluid) = (crate::FlowModel::Coupled, fluid);
            let (flow, t) = (Some(&flow), Tension::Dashpot);
            proptest::prop_assert_eq!(cluster::<f64, 16>(&grains, flow, t, true), cluster::<f64, 16>(&grains, flow, t, false));
            proptest::prop_assert_eq!(cluster::<f32, 16>(&grains, flow, t, true), cluster::<f32, 16>(&grains, flow, t, false));
        }
    }

    /// Steps a random cluster 40 times with the `tension` rule under
    /// `flow` (or none), batched or scalar: each step's outcome, digest and
    /// events so far, up to the first error.
    fn cluster<R: Real, const C: usize>(
        grains: &[Loose],
        flow: Option<&crate::FlowConfig>,
        tension: Tension,
        batched: bool,
    ) -> std::vec::Vec<(Result<(), Error>, u64, Events)> {
        let mut sim = small_box::<R, C>(tension);
        for &(x, y, u, v, spin, class, fixed) in grains {
            let spec = GrainSpec {
                x,
                y,
                u,
                v,
                spin,
                diameter: [0.4e-3, 0.5e-3, 0.7e-3][class],
                fixed,
                ..GrainSpec::default()
            };
            sim.add_grain(&spec).unwrap();
        }
        if flow.is_some() {
            sim.set_flow(flow).unwrap();
        }
        let mut outcomes = std::vec::Vec::new();
        for _ in 0..40 {
            let outcome = step_small_box(&mut sim, batched);
            let failed = outcome.is_err();
            outcomes.push((outcome, sim.digest(), without_path(sim.events())));
            if failed {
                break;
            }
        }
        outcomes
    }

    /// Each build sizes the skin from the fastest grain's speed: the floor
    /// for a bed at rest, between floor and configured skin for a settling
    /// one, the configured skin once a grain is fast.
    #[test]
    fn the_skin_follows_the_fastest_grain() {
        let mut sim = Sim::<f64, 64, 8>::new();
        Scenario::paper().build(&mut sim).unwrap();
        sim.run(3000).unwrap();
        let largest = sim.config.skin;
        sim.rebuild_neighbours().unwrap();
        assert!(sim.nbrs.skin > 0.3 * largest && sim.nbrs.skin < largest);
        for a in [&mut sim.grains.u, &mut sim.grains.v, &mut sim.grains.w] {
            a.fill(0.0);
        }
        sim.step().unwrap();
        sim.rebuild_neighbours().unwrap();
        assert_eq!(sim.nbrs.skin, 0.3 * largest);
        let i = (0..sim.len()).rfind(|&i| !sim.grains.fixed[i]).unwrap();
        sim.grains.u[i] = 0.5;
        sim.step().unwrap();
        sim.rebuild_neighbours().unwrap();
        assert_eq!(sim.nbrs.skin, largest);
    }

    /// A grain thrown out of the domain fails the batched and the scalar
    /// steps alike, in both precisions: the same error, the same state
    /// left behind.
    #[test]
    fn batched_and_scalar_fail_alike() {
        fails_alike::<f64>();
        fails_alike::<f32>();
    }

    fn fails_alike<R: Real>() {
        // The paper's bed after 100 steps with grains `bad` thrown up.
        let thrown = |bad: &[usize]| {
            let mut sim = Sim::<R, 64, 8>::new();
            Scenario::paper().build(&mut sim).unwrap();
            sim.run(100).unwrap();
            for &i in bad {
                sim.grains.v[i] = R::from_f64(1e9);
            }
            sim
        };
        let sim = thrown(&[]);
        let last = (0..sim.len())
            .rev()
            .find(|&i| !sim.grains.fixed[i])
            .unwrap();
        let i = last - 2;
        let fail = |batched: bool| {
            let mut sim = thrown(&[i]);
            let error = if batched {
                sim.step_with::<8, true>()
            } else {
                sim.step_with::<0, false>()
            };
            (error, sim.digest())
        };
        let (error, digest) = fail(false);
        assert!(matches!(error, Err(Error::LeftDomain { .. })), "{error:?}");
        assert_eq!(fail(true), (error, digest));
        // The phased step reports the same error (the first grain's in
        // grain order; here a second failing grain lies in an earlier
        // range), however cut; its state after it is left undefined.
        let expected = thrown(&[i, i - 20]).step_with::<0, false>();
        for parts in [1, 2, 5] {
            let mut phases = crate::Phases::<R, 64, 8>::new();
            let phased = thrown(&[i, i - 20]).step_phased(&mut phases, &crate::Ranges(parts));
            assert_eq!(phased, expected, "{parts} ranges");
        }
    }
}
