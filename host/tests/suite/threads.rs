//! One bed on several cores (issue 44): the phased step gives the bits of
//! the step on one core for any thread count, any cut, with clear water and
//! the coupled flow, across a checkpoint and restore; in vector lanes where
//! the pair index is ready (x86-64 with AVX2, a capacity that is a power of
//! two), and by the scalar phases elsewhere.

use mbs::sim::sims::{boxed_sim, HostSim, NEIGHBOURS};
use mbs::sim::threads::{boxed_phases, Threads};
use mbs_kernel::{BedSpec, Executor, Phase, Phases, Real, Scenario};

/// Grains of the test bed: 60 columns × 12 rows of the paper's bed, so
/// that 7 ranges of a phase hold about 100 grains each.
const N: usize = 1024;
type TestSim = HostSim<f64, N>;

/// A capacity that is no power of two: the pair index is never ready, and
/// the phased step runs its scalar phases.
const NO_LANES: usize = 1000;

/// Whether this build has the batched step's lanes.
const LANES: bool = cfg!(all(target_arch = "x86_64", target_feature = "avx2"));

fn scenario(coupled: bool) -> Scenario {
    let base = if coupled {
        Scenario::paper_coupled()
    } else {
        Scenario::paper()
    };
    Scenario {
        bed: BedSpec {
            columns: 60,
            rows: 12,
            ..base.bed.clone()
        },
        ..base
    }
}

fn boxed() -> Box<TestSim> {
    boxed_sim::<f64, N, NEIGHBOURS>()
}

/// Steps in each part (settling, flow) of [`run`].
const STEPS: u64 = 1500;

/// Digests after settling and after a flow at τ* = 0.3, stepping with
/// `step` (the event counts too).
fn run<R: Real, const M: usize>(
    coupled: bool,
    step: &mut dyn FnMut(&mut HostSim<R, M>) -> Result<(), mbs_kernel::Error>,
) -> (u64, u64, mbs_kernel::Events) {
    let sc = scenario(coupled);
    let mut sim = boxed_sim::<R, M, NEIGHBOURS>();
    sc.build(&mut *sim).unwrap();
    sim.count_events(true);
    for _ in 0..STEPS {
        step(&mut sim).unwrap();
    }
    let settled = sim.digest();
    sim.set_flow(Some(&sc.flow(0.3))).unwrap();
    for _ in 0..STEPS {
        step(&mut sim).unwrap();
    }
    (settled, sim.digest(), sim.events())
}

/// 1, 2, 3 and 7 threads, clear water and the coupled flow: the bits and
/// the events of one core, the phased step in lanes where they exist (as
/// many steps in lanes as on one core), and by the scalar phases on a
/// capacity the lanes do not fit.
#[test]
fn any_thread_count_gives_the_bits_of_one_core() {
    for coupled in [false, true] {
        let (a, b, events) = run::<f64, N>(coupled, &mut |s| s.step());
        assert_eq!(events.batched_steps > 0, LANES, "{events:?}");
        let mut phases = boxed_phases::<f64, N, NEIGHBOURS>();
        let (c, d, scalar) = run::<f64, NO_LANES>(coupled, &mut |s| s.step());
        assert_eq!(scalar.batched_steps, 0);
        let mut no_lanes = boxed_phases::<f64, NO_LANES, NEIGHBOURS>();
        for threads in [1, 2, 3, 7] {
            let exec = Threads::exactly(threads);
            let got = run::<f64, N>(coupled, &mut |s| s.step_phased(&mut phases, &exec));
            let with = format!("coupled {coupled}, {threads} threads");
            assert_eq!((got.0, got.1), (a, b), "{with}");
            let phased = |e: mbs_kernel::Events| mbs_kernel::Events {
                phased_steps: 2 * STEPS,
                ..e
            };
            assert_eq!(got.2, phased(events), "{with}");
            let got = run::<f64, NO_LANES>(coupled, &mut |s| s.step_phased(&mut no_lanes, &exec));
            assert_eq!((got.0, got.1), (c, d), "{with}, no lanes");
            assert_eq!(got.2, phased(scalar), "{with}, no lanes");
        }
    }
}

/// Cuts each phase at seeded random grains, down to single grains.
struct RandomCuts(std::cell::Cell<u64>);

impl Executor for RandomCuts {
    fn execute<P: Phase>(&self, phase: P) -> P::Output {
        if phase.grains() < 2 {
            return phase.run();
        }
        let s = self
            .0
            .get()
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0.set(s);
        if (s >> 60) == 0 {
            return phase.run();
        }
        let mid = 1 + (s >> 33) as usize % (phase.grains() - 1);
        let (a, b) = phase.split_at(mid);
        let a = self.execute(a);
        P::merge(a, self.execute(b))
    }
}

/// The bits of one core from the phased step run by `exec`, in precision
/// `R`, with clear water and the coupled flow.
fn same_bits_as_one_core<R: Real>(exec: &impl Executor) {
    for coupled in [false, true] {
        let (a, b, _) = run::<R, N>(coupled, &mut |s| s.step());
        let mut phases = boxed_phases::<R, N, NEIGHBOURS>();
        let got = run::<R, N>(coupled, &mut |s| s.step_phased(&mut phases, exec));
        assert_eq!((got.0, got.1), (a, b), "{}, coupled {coupled}", R::NAME);
    }
}

/// Random cuts in both precisions (f32's lanes hold 8 grains and its
/// chunks 64 pairs, f64's 4 and 32), clear water and the coupled flow.
#[test]
fn any_cut_gives_the_same_bits() {
    same_bits_as_one_core::<f64>(&RandomCuts(std::cell::Cell::new(7)));
    same_bits_as_one_core::<f32>(&RandomCuts(std::cell::Cell::new(11)));
}

/// Cuts the phases into ranges whose number changes from call to call
/// (2, 3, 2, 7, 1, …): the pair phase meets the same cut on two passes in
/// a row, and again after other cuts, whether a step has two phases or
/// three.
struct CuttingAnew(std::cell::Cell<usize>);

impl Executor for CuttingAnew {
    fn execute<P: Phase>(&self, phase: P) -> P::Output {
        let k = self.0.get();
        self.0.set(k + 1);
        mbs_kernel::Ranges([2, 3, 2, 7, 1][k % 5]).execute(phase)
    }
}

/// A range of the pair phase in lanes keeps the flags of the grains it
/// sums only if it ran the last pass: cuts that change between steps and
/// come back give the bits of one core, in both precisions (they do not if
/// it keeps them after another cut, tried).
#[test]
fn cuts_that_change_between_steps_give_the_same_bits() {
    same_bits_as_one_core::<f64>(&CuttingAnew(std::cell::Cell::new(0)));
    same_bits_as_one_core::<f32>(&CuttingAnew(std::cell::Cell::new(0)));
}

#[test]
fn a_restart_and_a_shared_buffer_keep_the_bits() {
    let sc = scenario(false);
    let mut one = boxed();
    sc.build(&mut *one).unwrap();
    one.set_flow(Some(&sc.flow(0.3))).unwrap();
    one.run(600).unwrap();
    let mut bytes = Vec::new();
    one.checkpoint(|b| bytes.extend_from_slice(b));
    one.run(900).unwrap();
    // A restored simulation and another one stepped in turn with the same
    // buffers: each re-indexes them when it finds another's lists.
    let mut restored = boxed();
    restored.restore(&bytes).unwrap();
    let mut other = boxed();
    sc.build(&mut *other).unwrap();
    let mut phases: Box<Phases<f64, N, NEIGHBOURS>> = boxed_phases();
    let exec = Threads::exactly(3);
    for _ in 0..900 {
        restored.step_phased(&mut phases, &exec).unwrap();
        other.step_phased(&mut phases, &exec).unwrap();
    }
    assert_eq!(restored.digest(), one.digest());
    let mut alone = boxed();
    sc.build(&mut *alone).unwrap();
    alone.run(900).unwrap();
    assert_eq!(other.digest(), alone.digest());
}

/// The host's `Stepping` (what `run.threads_per_cell`, `mbs bench
/// --threads` and the Python `Sim` use) steps a bed large enough to cut by
/// the phased step, with the bits of one core.
#[test]
fn stepping_on_threads_cuts_a_large_bed_with_the_same_bits() {
    use mbs::sim::threads::{Stepping, MIN_GRAINS_PER_RANGE};
    const BIG: usize = 8192;
    let sc = Scenario {
        bed: BedSpec {
            columns: 420,
            rows: 10,
            ..Scenario::paper().bed.clone()
        },
        ..Scenario::paper()
    };
    let run = |threads: usize| {
        let mut sim = boxed_sim::<f64, BIG, NEIGHBOURS>();
        sc.build(&mut *sim).unwrap();
        assert!(
            sim.len() >= 2 * MIN_GRAINS_PER_RANGE,
            "{} grains",
            sim.len()
        );
        sim.set_flow(Some(&sc.flow(0.3))).unwrap();
        let mut stepping = Stepping::new(threads);
        stepping.run(&mut *sim, 300).unwrap();
        (sim.digest(), sim.events())
    };
    let (one, events) = run(1);
    let (three, phased) = run(3);
    assert_eq!(three, one);
    assert_eq!(events.phased_steps, 0);
    assert_eq!(
        phased.phased_steps, 300,
        "three threads ran the phased step"
    );
    assert_eq!(phased.batched_steps, events.batched_steps, "in lanes");
    assert_eq!(events.batched_steps > 0, LANES);
}
