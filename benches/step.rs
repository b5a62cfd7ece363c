//! Criterion benchmarks of the hot loop in isolation: one step of a settled
//! paper bed (d = 0.5 mm, α_m = 20, α_cn = 1.3, β = 15.8, Δt/8 integration),
//! without and with flow at τ* = 0.2. Throughput is in grain-steps, fixed
//! grains included. Run: `cargo bench --bench step`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use mbs::bench::settled_bed;
use mbs::boxed_sim;
use mbs_kernel::{Real, Sim};

const N: usize = 16_384;

fn settled<R: Real>(columns: u32, flow: bool) -> Box<Sim<R, N, 8>> {
    let mut sim = boxed_sim::<R, N, 8>();
    settled_bed(&mut *sim, columns, flow).expect("bed fits and settles");
    sim
}

fn bench<R: Real>(c: &mut Criterion) {
    let mut group = c.benchmark_group(format!("step_{}", R::NAME));
    for columns in [6u32, 93, 1489] {
        for flow in [false, true] {
            let mut sim = settled::<R>(columns, flow);
            group.throughput(Throughput::Elements(sim.len() as u64));
            let name = if flow { "flow" } else { "still" };
            group.bench_with_input(BenchmarkId::new(name, sim.len()), &(), |b, _| {
                b.iter(|| sim.step().expect("step"))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench::<f64>, bench::<f32>);
criterion_main!(benches);
