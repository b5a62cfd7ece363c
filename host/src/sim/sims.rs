//! Heap-allocated kernel simulations of a capacity and precision chosen at
//! run time. The kernel's `Sim<R, N, K>` fixes them at compile time; the host
//! is compiled for [`crate::config::CAPACITIES`] × {f32, f64}, the dispatch
//! ([`with_sim`], [`max_checkpoint_len`], [`compiled_capacity`]) expanded
//! by `by_capacity!` from the one list of capacities,
//! `crate::config::grain_capacities!`.

use crate::config::{grain_capacities, Precision, FLUID_CELLS};
use indicatif::ProgressBar;
use mbs_kernel::{FlowConfig, Real, Scenario, Sim, SimConfig, MAX_CLASSES};

/// Neighbour slots per grain of every host simulation (the kernel's `K`).
pub const NEIGHBOURS: usize = 8;

/// A host simulation: `N` grains in precision `R`.
pub type HostSim<R, const N: usize> = Sim<R, N, NEIGHBOURS, FLUID_CELLS>;

/// Steps run between progress updates.
const CHUNK: u64 = 2000;

/// A simulation allocated directly on the heap, never built on the stack.
pub fn boxed_sim<R: Real, const N: usize, const K: usize>() -> Box<Sim<R, N, K, FLUID_CELLS>> {
    let zeroed = Box::<Sim<R, N, K, FLUID_CELLS>>::new_zeroed();
    // SAFETY: `Sim` documents (kernel/src/sim/mod.rs) that every field is a
    // number, a bool, or a struct or array of those, and `Real` is sealed to
    // f32 and f64; so the all-zero bit pattern is a valid `Sim`, equal to
    // `Sim::new()` (checked by `tests::zeroed_box_equals_new`).
    unsafe { zeroed.assume_init() }
}

/// Work to do on a fresh simulation of any precision and capacity.
pub trait SimJob {
    /// What the job returns.
    type Output;
    /// Runs the job on `sim` (all zero, unconfigured).
    fn run<R: Real, const N: usize>(self, sim: &mut HostSim<R, N>) -> Self::Output;
}

/// `by_capacity!(capacity, N => body; CAPACITIES…)`: `body` with the const
/// `N` the compiled capacity of `capacity`, the smallest of the capacities
/// (listed smallest first) ≥ `capacity`, the largest if none is; one branch
/// per capacity. Called through `grain_capacities!`, which lists them.
macro_rules! by_capacity {
    ($capacity:expr, $n:ident => $body:expr; $last:literal) => {{
        const $n: usize = $last;
        $body
    }};
    ($capacity:expr, $n:ident => $body:expr; $first:literal, $($rest:literal),+) => {
        if $capacity <= $first {
            const $n: usize = $first;
            $body
        } else {
            by_capacity!($capacity, $n => $body; $($rest),+)
        }
    };
}

/// The compiled capacity a simulation of `capacity` grains gets: the
/// smallest of [`crate::config::CAPACITIES`] ≥ `capacity`, the largest if
/// none is.
pub fn compiled_capacity(capacity: usize) -> usize {
    grain_capacities!(by_capacity!(capacity, N => N;))
}

/// Runs `job` on a fresh heap simulation of `precision` with the
/// [`compiled_capacity`] of `capacity`.
pub fn with_sim<J: SimJob>(precision: Precision, capacity: usize, job: J) -> J::Output {
    match precision {
        Precision::F32 => grain_capacities!(by_capacity!(
            capacity, N => job.run(&mut *boxed_sim::<f32, N, NEIGHBOURS>());
        )),
        Precision::F64 => grain_capacities!(by_capacity!(
            capacity, N => job.run(&mut *boxed_sim::<f64, N, NEIGHBOURS>());
        )),
    }
}

/// Whether a restored kernel state belongs where it is used: `scenario`'s
/// configuration and seed (its width and floor are set by the bed it
/// built), the `flow` expected (`None` while settling), `steps`
/// integration steps taken, and the grains its bed builds (as many fixed
/// ones, and as many mobile ones of each size class as its lattice sites
/// hold: [`BedSpec::sites`](mbs_kernel::BedSpec::sites)). Else why not: a
/// crafted or foreign state is refused, never trusted.
pub fn check_restored<R: Real, const N: usize>(
    sim: &HostSim<R, N>,
    scenario: &Scenario,
    flow: Option<&FlowConfig>,
    steps: u64,
) -> Result<(), &'static str> {
    let got = *sim.config();
    if !of_scenario(&got, scenario) {
        return Err("its kernel state has another configuration or seed");
    }
    if sim.flow() != flow {
        return Err("its kernel state has another flow (tau*) or phase");
    }
    if sim.step_count() != steps {
        return Err("its kernel state's step count does not fit");
    }
    let bed = &scenario.bed;
    let mut built = [0usize; MAX_CLASSES];
    for class in bed.sites(got.seed).flatten() {
        if let Some(n) = built.get_mut(class) {
            *n += 1;
        }
    }
    let (mut fixed, mut mobile) = (0, [0usize; MAX_CLASSES]);
    for grain in (0..sim.len()).filter_map(|i| sim.grain(i)) {
        match mobile.get_mut(usize::from(grain.class)) {
            _ if grain.fixed => fixed += 1,
            Some(n) => *n += 1,
            None => return Err("its kernel state holds other grains than its bed builds"),
        }
    }
    let fixed_built = (bed.columns as usize).saturating_mul(bed.fixed_per_column());
    if fixed != fixed_built || mobile != built {
        return Err("its kernel state holds other grains than its bed builds");
    }
    Ok(())
}

/// Whether the configuration `got` of a simulation is `scenario`'s (its
/// width and floor aside: the bed it built sets them).
pub fn of_scenario(got: &SimConfig, scenario: &Scenario) -> bool {
    scenario.sim_config().is_ok_and(|c| {
        SimConfig {
            width: got.width,
            y_min: got.y_min,
            ..c
        } == *got
    })
}

/// The length of a kernel checkpoint of `grains` grains and `contacts`
/// contacts in `precision` (`Sim::checkpoint_len`).
pub fn checkpoint_len(precision: Precision, grains: usize, contacts: usize) -> usize {
    match precision {
        Precision::F32 => HostSim::<f32, 1>::checkpoint_len(grains, contacts),
        Precision::F64 => HostSim::<f64, 1>::checkpoint_len(grains, contacts),
    }
}

/// The largest kernel checkpoint of the simulation [`with_sim`] gives
/// (`Sim::MAX_CHECKPOINT_LEN`): longer files are refused unread.
pub fn max_checkpoint_len(precision: Precision, capacity: usize) -> usize {
    match precision {
        Precision::F32 => grain_capacities!(by_capacity!(
            capacity, N => HostSim::<f32, N>::MAX_CHECKPOINT_LEN;
        )),
        Precision::F64 => grain_capacities!(by_capacity!(
            capacity, N => HostSim::<f64, N>::MAX_CHECKPOINT_LEN;
        )),
    }
}

/// Runs `steps` steps in chunks, reporting progress.
pub fn run_with_progress<R: Real, const N: usize>(
    sim: &mut HostSim<R, N>,
    steps: u64,
    progress: &ProgressBar,
) -> Result<(), mbs_kernel::Error> {
    let mut left = steps;
    while left > 0 {
        let n = left.min(CHUNK);
        sim.run(n)?;
        progress.inc(n);
        left -= n;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use mbs_kernel::Scenario;

    /// Every capacity of the list is compiled, and a simulation gets the
    /// smallest that holds it.
    #[test]
    fn capacities_dispatch_from_the_one_list() {
        use crate::config::{CAPACITIES, MAX_CAPACITY};
        struct Capacity;
        impl SimJob for Capacity {
            type Output = usize;
            fn run<R: Real, const N: usize>(self, _: &mut HostSim<R, N>) -> usize {
                N
            }
        }
        let mut below = 0;
        for &n in CAPACITIES {
            for asked in [below + 1, n] {
                assert_eq!(compiled_capacity(asked), n);
                for precision in [Precision::F32, Precision::F64] {
                    assert_eq!(with_sim(precision, asked, Capacity), n);
                }
            }
            type F64 = HostSim<f64, 1>;
            let largest = F64::checkpoint_len(n, n * NEIGHBOURS);
            assert_eq!(
                max_checkpoint_len(Precision::F64, n),
                largest.saturating_add(F64::fluid_len(FLUID_CELLS))
            );
            below = n;
        }
        assert_eq!(compiled_capacity(0), CAPACITIES[0]);
        assert_eq!(compiled_capacity(MAX_CAPACITY + 1), MAX_CAPACITY);
    }

    #[test]
    fn zeroed_box_equals_new() {
        let sc = Scenario::paper();
        let mut a = boxed_sim::<f64, 64, 8>();
        let mut b = Box::new(HostSim::<f64, 64>::new());
        // Every field, not only the digested state.
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        assert_eq!(
            format!("{:?}", boxed_sim::<f32, 64, 8>()),
            format!("{:?}", HostSim::<f32, 64>::new())
        );
        assert_eq!(a.digest(), b.digest());
        assert_eq!(
            sc.digests(&mut *a, 0.2, 200, 200).unwrap(),
            sc.digests(&mut *b, 0.2, 200, 200).unwrap()
        );
        // And under the coupled flow, whose column the zeroed box holds too.
        let mut coupled = sc;
        coupled.flow.model = mbs_kernel::FlowModel::Coupled;
        let (mut a, mut b) = (
            boxed_sim::<f64, 64, 8>(),
            Box::new(HostSim::<f64, 64>::new()),
        );
        assert_eq!(
            coupled.digests(&mut *a, 0.2, 200, 200).unwrap(),
            coupled.digests(&mut *b, 0.2, 200, 200).unwrap()
        );
    }
}
