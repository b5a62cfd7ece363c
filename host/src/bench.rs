//! The hot-loop benchmark shared by `mbs bench` and the criterion benches:
//! a settled bed of the paper's grains, 10 rows deep, periodic in x.

use crate::sims::{with_sim, SimJob, NEIGHBOURS};
use mbs_kernel::{BedSpec, Error, Real, Scenario, Sim};
use std::time::Instant;

/// Rows of the benchmark bed.
pub const ROWS: u32 = 10;

/// Most steps of settling before timing (0.5 s at Δt/8).
pub const SETTLE_MAX_STEPS: u64 = 200_000;

/// Settled: every mobile grain slower than this (m/s).
pub const REST_SPEED: f64 = 1e-3;

/// Lattice columns giving about `grains` grains (fixed row included).
pub fn columns_for(grains: usize) -> u32 {
    (grains / (ROWS as usize + 1)).clamp(3, u32::MAX as usize) as u32
}

/// Builds the paper's bed with `columns` columns into `sim`, settles it
/// until every grain is slower than [`REST_SPEED`] (at most
/// [`SETTLE_MAX_STEPS`]) and switches the flow (τ* = 0.2) on if `flow`.
pub fn settled_bed<R: Real, const N: usize, const K: usize>(
    sim: &mut Sim<R, N, K>,
    columns: u32,
    flow: bool,
) -> Result<(), Error> {
    let mut sc = Scenario::paper();
    sc.bed = BedSpec::uniform(0.5e-3, columns, ROWS);
    sc.build(sim)?;
    sim.settle(SETTLE_MAX_STEPS, REST_SPEED)?;
    if flow {
        sim.set_flow(Some(&sc.flow()))?;
    }
    Ok(())
}

/// What `mbs bench` measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BenchResult {
    /// Grains (fixed included).
    pub grains: usize,
    /// Steps timed.
    pub steps: u64,
    /// Wall time per grain-step (ns).
    pub ns_per_grain_step: f64,
    /// Contacts per grain at the end.
    pub contacts_per_grain: f64,
}

/// `mbs bench`: settle, then time `steps` steps of the step loop alone.
pub struct Bench {
    /// Lattice columns.
    pub columns: u32,
    /// Steps timed.
    pub steps: u64,
    /// Flow on.
    pub flow: bool,
}

impl SimJob for Bench {
    type Output = Result<BenchResult, Error>;

    fn run<R: Real, const N: usize>(self, sim: &mut Sim<R, N, NEIGHBOURS>) -> Self::Output {
        settled_bed(sim, self.columns, self.flow)?;
        let start = Instant::now();
        sim.run(self.steps)?;
        let elapsed = start.elapsed().as_secs_f64();
        let n = sim.len() as f64;
        Ok(BenchResult {
            grains: sim.len(),
            steps: self.steps,
            ns_per_grain_step: elapsed * 1e9 / (n * self.steps.max(1) as f64),
            contacts_per_grain: sim.observe().contacts as f64 / n,
        })
    }
}

/// Runs [`Bench`] on the smallest compiled capacity that holds the bed.
pub fn bench(
    precision: crate::config::Precision,
    grains: usize,
    steps: u64,
    flow: bool,
) -> Result<BenchResult, Error> {
    let columns = columns_for(grains);
    let needed = columns as usize * (ROWS as usize + 1);
    with_sim(
        precision,
        needed,
        Bench {
            columns,
            steps,
            flow,
        },
    )
}
