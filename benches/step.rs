//! Criterion benchmarks of the hot loop in isolation (`mbs::tools::bench`): settled
//! beds of the paper's grains (d = 0.5 mm, α_m = 20, α_cn = 1.3, constants
//! from constants_dt = 2.0e-5 s, integrated at constants_dt/8), 10 rows over a fixed row,
//! periodic in x, of about 64, 1 024, 16 384 and 65 536 grains (f32: up to
//! 16 384), β = 15.8 and 1, f64 and f32; cases: step without flow, step with flow at τ* = 0.2,
//! neighbour rebuild alone, contact law alone. Each bed runs on the same
//! capacity as `mbs bench` gives it.
//!
//! Throughput is in grain-steps with every grain counted (fixed ones
//! included): criterion's "elem/s" inverted is ns per grain-step. Prepared
//! beds are kept in target/tmp/bench-beds (shared with
//! `benches/instructions.sh`), so only the first run settles them. Step
//! cases are timed within their first `WINDOW_STEPS` (400) steps from the
//! prepared bed, rewound between stretches (`Prepared::time`), like
//! `mbs bench`.
//!
//! Run from the repository's root: `cargo bench --manifest-path
//! benches/Cargo.toml` (all), or e.g. `cargo bench --manifest-path
//! benches/Cargo.toml -- 'f64/still/beta15.8/16368'`; one bed on several
//! cores (`mbs bench --threads`): `-- threads`.

use criterion::measurement::WallTime;
use criterion::{
    criterion_group, criterion_main, BenchmarkGroup, BenchmarkId, Criterion, Throughput,
};
use mbs::sim::sims::{with_sim, HostSim, SimJob};
use mbs::tools::bench::{BenchBed, Case, Prepared};
use mbs::Precision;
use mbs_kernel::Real;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Grains wanted; the beds have whole columns (66, 1 023, 16 368, 65 472).
const SIZES: [usize; 4] = [64, 1_024, 16_384, 65_536];

/// Largest f32 bed: the 65 472-grain bed is 3.1 m wide, where an f32
/// position is quantised to 0.24 µm, a quarter of a typical overlap, and the
/// bed never settles (docs/performance.md).
const F32_MAX_GRAINS: usize = 16_384;

/// β of the paper, and 1.
const BETAS: [f64; 2] = [15.8, 1.0];

/// Prepared beds, shared with `benches/instructions.sh`: the top-level
/// workspace's target/tmp/bench-beds.
fn beds() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/tmp/bench-beds")
}

/// One benchmark: prepare `bed`, then time `case` on it, stepping on
/// `threads` threads (1: the step of one core; more: the phased step).
struct Measure<'g, 'c> {
    group: &'g mut BenchmarkGroup<'c, WallTime>,
    bed: BenchBed,
    case: Case,
    threads: usize,
}

impl SimJob for Measure<'_, '_> {
    type Output = ();

    fn run<R: Real, const N: usize>(self, sim: &mut HostSim<R, N>) {
        let mut bed = Prepared::new(sim, &self.bed, self.case, Some(&beds())).expect("bench bed");
        bed.threads(self.threads);
        let grains = bed.sim().len();
        self.group.throughput(Throughput::Elements(grains as u64));
        let id = match self.threads {
            1 => BenchmarkId::new(format!("beta{}", self.bed.beta), grains),
            t => BenchmarkId::new(format!("beta{}/threads{t}", self.bed.beta), grains),
        };
        self.group
            .bench_function(id, |b| b.iter_custom(|n| bed.time(n).expect("repetitions")));
    }
}

fn bench(c: &mut Criterion, precision: Precision) {
    let name = format!("{precision:?}").to_lowercase();
    for case in Case::ALL {
        let mut group = c.benchmark_group(format!("{name}/{}", case.name()));
        for beta in BETAS {
            for grains in SIZES {
                if precision == Precision::F32 && grains > F32_MAX_GRAINS {
                    continue;
                }
                let bed = BenchBed { grains, beta };
                let group = &mut group;
                let job = Measure {
                    group,
                    bed,
                    case,
                    threads: 1,
                };
                with_sim(precision, bed.grain_count(), job);
            }
        }
        group.finish();
    }
}

fn f64_beds(c: &mut Criterion) {
    bench(c, Precision::F64);
}

fn f32_beds(c: &mut Criterion) {
    bench(c, Precision::F32);
}

/// One bed on several cores: f64, β = 15.8, still and flow, 16 k and 65 k
/// grains, on 2 threads and on every core (the phased step; its bits are
/// those of one thread, whose timings are `f64_beds`'), and the rebuild
/// alone (its search cut among the threads: the same lists).
fn threads(c: &mut Criterion) {
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut counts = vec![2, all];
    counts.dedup();
    for case in [Case::Still, Case::Flow, Case::Rebuild] {
        let mut group = c.benchmark_group(format!("f64/{}", case.name()));
        for grains in [16_384, 65_536] {
            for &threads in counts.iter().filter(|&&t| t > 1) {
                let bed = BenchBed { grains, beta: 15.8 };
                let group = &mut group;
                let job = Measure {
                    group,
                    bed,
                    case,
                    threads,
                };
                with_sim(Precision::F64, bed.grain_count(), job);
            }
        }
        group.finish();
    }
}

fn config() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
}

criterion_group! {
    name = benches;
    config = config();
    targets = f64_beds, f32_beds, threads
}
criterion_main!(benches);
