//! Limits: the bounds a configuration's values are checked against that
//! are not the kernel's (capacities, the longest file, the longest phase
//! and cell, the smallest step and grain, the column's fluid cells, the damping
//! number of automatic substeps) and the step speed estimates use.

use crate::io::input::Bound;

/// The longest configuration file read: its longest lists (1000 τ*, 1000
/// seeds, the size classes) take well under 100 kB, even with comments.
pub const CONFIG_BOUND: Bound = Bound {
    bytes: 1 << 20,
    reason: "the largest configuration mbs reads (its longest lists, 1000 tau* and 1000 seeds, \
             take under 100 kB)",
};

/// Expands `callback!(ARGS…)` to `callback!(ARGS… 256, 4096, 65536)`: the
/// grain capacities the host is compiled for (the kernel's `N`), smallest
/// first. The one list of them: [`CAPACITIES`], the message of a bad
/// `run.capacity`, the range of `mbs bench --grains` and the simulations
/// [`crate::sim::sims::with_sim`] dispatches to all come from it.
macro_rules! grain_capacities {
    ($callback:ident!($($args:tt)*)) => {
        $callback!($($args)* 256, 4096, 65536)
    };
}
pub(crate) use grain_capacities;

/// The array of the capacities `grain_capacities!` gives.
macro_rules! capacity_array {
    ($($n:literal),+) => {
        [$($n),+]
    };
}

/// Grain capacities the host is compiled for (the kernel's `N`), smallest
/// first (`grain_capacities!`).
pub const CAPACITIES: &[usize] = &grain_capacities!(capacity_array!());

/// The largest of [`CAPACITIES`]: the most grains a simulation holds.
pub const MAX_CAPACITY: usize = CAPACITIES[CAPACITIES.len() - 1];

/// [`CAPACITIES`] as a message writes them: "256, 4096 or 65536".
pub fn capacities_listed() -> String {
    let shown: Vec<String> = CAPACITIES.iter().map(usize::to_string).collect();
    match shown.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    }
}

/// The longest settling, spin-up or window (s of physical time).
pub const MAX_PHASE_S: f64 = 1000.0;

/// Why [`MAX_PHASE_S`].
pub(super) const PHASE_REASON: &str =
    " of physical time: beds settle and q* converges within seconds, \
     a longer phase is a mistake (milliseconds meant?)";

/// The most integration steps of a cell (settling, spin-up and window).
pub const MAX_CELL_STEPS: u64 = 100_000_000_000;

/// The largest Shields number: sheet flow.
pub const MAX_TAU_STAR: f64 = 5.0;

/// Threads above this are refused (`--threads`, `run.threads_per_cell`):
/// more than any machine `mbs` runs on has cores, and each worker holds a
/// simulation in memory.
pub const MAX_THREADS: usize = 1024;

/// Checks a Shields number given as `key` (`--tau`, a trace's, a `Sim`'s):
/// in (0, [`MAX_TAU_STAR`]], as `flow.tau_star`.
///
/// ```
/// assert_eq!(mbs::config::tau_star_arg("--tau", 0.2).unwrap(), 0.2);
/// let e = mbs::config::tau_star_arg("--tau", 9.0).unwrap_err();
/// assert_eq!(e.to_string(), "--tau = 9: must be in (0, 5]");
/// ```
pub fn tau_star_arg(key: &str, tau_star: f64) -> Result<f64, crate::error::ConfigError> {
    super::errors::need(
        tau_star.is_finite() && tau_star > 0.0 && tau_star <= MAX_TAU_STAR,
        key,
        crate::io::text::number(tau_star),
        &format!("in (0, {MAX_TAU_STAR}]"),
    )
    .map(|()| tau_star)
}

/// Checks a count of integration steps given on the command line (`mbs
/// digest --steps`, a trace's phases): at most [`MAX_CELL_STEPS`], the
/// limit of a cell of the main job.
///
/// ```
/// assert!(mbs::config::steps_arg("--steps", 2000).is_ok());
/// let e = mbs::config::steps_arg("--flow-steps", 1_000_000_000_000).unwrap_err();
/// assert!(e.to_string().starts_with("--flow-steps = 1000000000000: must be <= 1e11"), "{e}");
/// ```
pub fn steps_arg(key: &str, steps: u64) -> Result<(), crate::error::ConfigError> {
    super::errors::need(
        steps <= MAX_CELL_STEPS,
        key,
        steps,
        &format!(
            "<= {MAX_CELL_STEPS:e} integration steps (the limit of a cell of the main job: at \
             ~{GRAIN_STEPS_PER_S_PER_CORE:e} grain-steps/s, days even for 100 grains)"
        ),
    )
}

/// The smallest constants' time step constants_dt (s).
pub const MIN_CONSTANTS_DT: f64 = 1e-8;

/// The smallest grain diameter (mm).
pub const MIN_DIAMETER_MM: f64 = 1e-3;

/// A rough speed of the step for wall-time estimates: the main job runs
/// 5–6e7 grain-steps per second on 2 cores (docs/performance.md).
pub const GRAIN_STEPS_PER_S_PER_CORE: f64 = 2.5e7;

/// The explicit damping number `time.substeps = "auto"` stays at or below:
/// the default constants (α_cn = 1.3) reach 0.356 at 8 substeps, where q*
/// agrees with 16 (docs/findings/explicit-damping-limit.md).
pub const SUBSTEP_DAMPING_NUMBER: f64 = 0.36;

/// Cells of the coupled flow's column at most: the fluid capacity `C` of
/// every host simulation ([`crate::sim::sims::HostSim`]), 0.2 m of water over
/// 0.5 mm grains in fluid cells of d/4.
pub const FLUID_CELLS: usize = 2048;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::DEFAULT_TOML;
    use mbs_kernel::{Material, Scenario};

    /// The capacities are listed once; the embedded default file, which
    /// cannot be generated, names them as the list does.
    #[test]
    fn the_capacities_are_one_list() {
        assert_eq!(CAPACITIES, [256, 4096, 65536]);
        assert!(CAPACITIES.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(MAX_CAPACITY, 65536);
        assert_eq!(capacities_listed(), "256, 4096 or 65536");
        assert!(
            DEFAULT_TOML.contains(&format!(
                "Grain capacity of the simulation: {}.",
                capacities_listed()
            )),
            "host/default.toml's run.capacity comment"
        );
    }

    #[test]
    fn the_density_and_diameter_limits_keep_inverse_inertias_finite_in_f32() {
        let paper = Scenario::paper().material;
        for rho in [1e-3, 1e5] {
            for s in [1.0 + 1e-9, 20.0] {
                for d in [MIN_DIAMETER_MM * 1e-3, 0.1] {
                    let m = Material { rho, s, ..paper };
                    for x in [m.translational_mass(d), m.moment_of_inertia(d)] {
                        let inverse = (1.0 / x) as f32;
                        assert!(inverse.is_normal(), "rho {rho}, s {s}, d {d}: {x}");
                    }
                }
            }
        }
    }
}
