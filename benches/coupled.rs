//! Criterion benchmark of the coupled flow's step against the clear-water
//! step (docs/model.md §13, issue 31: at most 15 % more at N = 16 k grains):
//! the bed of `mbs::tools::bench` of 16 368 grains, β = 15.8, after its warm-up
//! under the clear-water flow at τ* = 0.2 (`mbs::tools::bench::prepare`, beds kept
//! in target/tmp/bench-beds), then stepped
//!
//! - `clear`: under the clear-water flow, in the host's `Sim<R, N, 8>`;
//! - `coupled`: under the coupled flow started from that state (the column
//!   from the bottom of the fixed grains to the surface, 0.2 m, in cells
//!   of d/2, 805 cells; an update every 100 steps; hindrance n = 3.1), in a
//!   `Sim<R, N, 8, 1024>`.
//!
//! Both are timed within their first 400 steps, rewound between stretches,
//! as `benches/step.rs`. Throughput is in grain-steps: criterion's elem/s
//! inverted is ns per grain-step.
//!
//! The coupled bed moves more (no sheltering), so its neighbour lists are
//! rebuilt more often: the number of rebuilds within the 400 steps of each
//! is printed, and `clear-rebuild` and `coupled-rebuild` time one rebuild
//! (`Sim::rebuild_neighbours`, per grain) from each start, so that the
//! step's cost without its rebuilds is the step's less rebuilds / 400 times
//! a rebuild's. `MBS_UPDATE_STEPS=M` sets the coupled
//! flow's update interval (e.g. 100000: no update within the timed
//! stretches, the cost of the grains' drag alone).
//!
//! Run from the repository's root: `cargo bench --manifest-path
//! benches/Cargo.toml --bench coupled`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use mbs::sim::sims::{boxed_sim, NEIGHBOURS};
use mbs::tools::bench::{prepare, BenchBed, TAU_STAR};
use mbs_kernel::fluid::FluidConfig;
use mbs_kernel::{Error, FlowModel, IntegrationSteps, Real, Sim};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Grain capacity: the 16 368-grain bed.
const N: usize = 16_384;
/// Cell capacity of the coupled simulation.
const CELLS: usize = 1024;
/// Steps timed from the prepared state before it is rewound.
const WINDOW_STEPS: u64 = 400;

fn beds() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/tmp/bench-beds")
}

/// A coupled simulation allocated zeroed on the heap.
fn boxed_coupled<R: Real>() -> Box<Sim<R, N, NEIGHBOURS, CELLS>> {
    let zeroed = Box::<Sim<R, N, NEIGHBOURS, CELLS>>::new_zeroed();
    // SAFETY: as `mbs::sim::sims::boxed_sim`: the all-zero bit pattern is a valid
    // `Sim` (kernel/src/sim/mod.rs), whatever its capacities.
    unsafe { zeroed.assume_init() }
}

/// A simulation stepped from a saved state, rewound every `WINDOW_STEPS`.
struct Window<S> {
    sim: S,
    start: Vec<u8>,
    taken: u64,
}

/// What the window needs of a simulation of any capacity.
trait Steps {
    fn restore_at(&mut self, bytes: &[u8]) -> Result<(), Error>;
    fn steps(&mut self, n: u64) -> Result<(), Error>;
    fn rebuild(&mut self) -> Result<(), Error>;
    fn rebuilds(&self) -> u64;
}

impl<R: Real, const K: usize, const C: usize> Steps for Box<Sim<R, N, K, C>> {
    fn restore_at(&mut self, bytes: &[u8]) -> Result<(), Error> {
        self.restore(bytes)?;
        self.rebuild_neighbours()
    }
    fn steps(&mut self, n: u64) -> Result<(), Error> {
        self.run(n)
    }
    fn rebuild(&mut self) -> Result<(), Error> {
        self.rebuild_neighbours()
    }
    fn rebuilds(&self) -> u64 {
        self.events().neighbour_rebuilds
    }
}

impl<S: Steps> Window<S> {
    /// The neighbour rebuilds within the window's steps from its start.
    fn rebuilds(&mut self) -> u64 {
        self.sim.restore_at(&self.start).expect("rewind");
        let before = self.sim.rebuilds();
        self.sim.steps(WINDOW_STEPS).expect("steps");
        self.taken = WINDOW_STEPS;
        self.sim.rebuilds() - before
    }

    /// `times` rebuilds of the neighbour lists from the window's start.
    fn time_rebuilds(&mut self, times: u64) -> Duration {
        self.sim.restore_at(&self.start).expect("rewind");
        self.taken = WINDOW_STEPS;
        let clock = Instant::now();
        for _ in 0..times {
            self.sim.rebuild().expect("rebuild");
        }
        clock.elapsed()
    }

    fn time(&mut self, times: u64) -> Duration {
        let mut total = Duration::ZERO;
        let mut left = times;
        while left > 0 {
            if self.taken >= WINDOW_STEPS {
                self.sim.restore_at(&self.start).expect("rewind");
                self.taken = 0;
            }
            let chunk = left.min(WINDOW_STEPS - self.taken);
            let clock = Instant::now();
            self.sim.steps(chunk).expect("steps");
            total += clock.elapsed();
            self.taken += chunk;
            left -= chunk;
        }
        total
    }
}

fn bench<R: Real>(c: &mut Criterion) {
    let bed = BenchBed {
        grains: 16_384,
        beta: 15.8,
    };
    let mut clear = boxed_sim::<R, N, NEIGHBOURS>();
    prepare(&mut *clear, &bed, true, Some(&beds())).expect("bench bed");
    clear.step().expect("first step");
    let mut start = Vec::new();
    clear.checkpoint(|b| start.extend_from_slice(b));
    let grains = clear.len();

    let mut coupled = boxed_coupled::<R>();
    coupled.restore(&start).expect("restore");
    let d = 0.5e-3;
    let bottom = (0..grains)
        .filter_map(|i| coupled.grain(i))
        .filter(|g| g.fixed)
        .map(|g| g.y - 0.5 * g.diameter)
        .fold(f64::INFINITY, f64::min);
    let sc = bed.scenario(bed.columns());
    let mut flow = sc.flow(TAU_STAR);
    let depth = flow.spec.depth;
    let cells = ((depth - bottom) / (0.5 * d)).round() as usize;
    let width = coupled.config().width;
    let mut fluid = FluidConfig::new(cells, bottom, depth, width * d);
    fluid.driving = FluidConfig::driving_for(flow.u_star, depth);
    fluid.spec.hindrance = 3.1;
    if let Some(m) = std::env::var("MBS_UPDATE_STEPS")
        .ok()
        .and_then(|m| m.parse().ok())
    {
        fluid.spec.update_steps = IntegrationSteps(m);
    }
    (flow.spec.model, flow.fluid) = (FlowModel::Coupled, fluid);
    coupled.set_flow(Some(&flow)).expect("coupled flow");
    coupled.step().expect("first coupled step");
    let mut coupled_start = Vec::new();
    coupled.checkpoint(|b| coupled_start.extend_from_slice(b));

    let mut group = c.benchmark_group(format!("{}/coupled-vs-clear", R::NAME));
    group.throughput(Throughput::Elements(grains as u64));
    let mut clear = Window {
        sim: clear,
        start,
        taken: WINDOW_STEPS,
    };
    let mut coupled = Window {
        sim: coupled,
        start: coupled_start,
        taken: WINDOW_STEPS,
    };
    eprintln!(
        "{}: neighbour rebuilds in {WINDOW_STEPS} steps: clear {}, coupled {}",
        R::NAME,
        clear.rebuilds(),
        coupled.rebuilds()
    );
    group.bench_function(BenchmarkId::new("clear", grains), |b| {
        b.iter_custom(|n| clear.time(n))
    });
    group.bench_function(BenchmarkId::new("coupled", grains), |b| {
        b.iter_custom(|n| coupled.time(n))
    });
    group.bench_function(BenchmarkId::new("clear-rebuild", grains), |b| {
        b.iter_custom(|n| clear.time_rebuilds(n))
    });
    group.bench_function(BenchmarkId::new("coupled-rebuild", grains), |b| {
        b.iter_custom(|n| coupled.time_rebuilds(n))
    });
    group.finish();
}

fn f64_bed(c: &mut Criterion) {
    bench::<f64>(c);
}

fn f32_bed(c: &mut Criterion) {
    bench::<f32>(c);
}

fn config() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
}

criterion_group! {
    name = benches;
    config = config();
    targets = f64_bed, f32_bed
}
criterion_main!(benches);
