//! Criterion benchmarks of one bed on several cores (`mbs bench
//! --threads`): the settled and the flowing bed of `benches/step.rs` (f64,
//! β = 15.8) of about 16 384 and 65 536 grains, stepped on one thread (the
//! step of one core) and by the phased step on 2 threads and on every core
//! of the machine (`Prepared::threads`; the same bits on any number).
//!
//! Throughput is in grain-steps: criterion's "elem/s" inverted is ns per
//! grain-step of wall time. Run from the repository's root: `cargo bench
//! --manifest-path benches/Cargo.toml --bench threads`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use mbs::sim::sims::{with_sim, HostSim, SimJob};
use mbs::tools::bench::{BenchBed, Case, Prepared};
use mbs::Precision;
use mbs_kernel::Real;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Grains wanted (beds of 16 368 and 65 472).
const SIZES: [usize; 2] = [16_384, 65_536];

/// Prepared beds, shared with `benches/step.rs`.
fn beds() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/tmp/bench-beds")
}

/// One benchmark: `case` on `bed` with `threads` threads per step.
struct Measure<'g, 'c> {
    group: &'g mut criterion::BenchmarkGroup<'c, criterion::measurement::WallTime>,
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
        let id = BenchmarkId::new(format!("threads{}", self.threads), grains);
        self.group
            .bench_function(id, |b| b.iter_custom(|n| bed.time(n).expect("repetitions")));
    }
}

fn threads(c: &mut Criterion) {
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut counts = vec![1, 2, all];
    counts.dedup();
    for case in [Case::Still, Case::Flow] {
        let mut group = c.benchmark_group(format!("f64/{}", case.name()));
        for grains in SIZES {
            for &threads in &counts {
                let bed = BenchBed {
                    grains,
                    beta: 15.8,
                };
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
    targets = threads
}
criterion_main!(benches);
