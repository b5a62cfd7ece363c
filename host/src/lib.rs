//! Host side of mbs: heap allocation of kernel simulations and the
//! transport-rate experiment. (The full command — configuration files,
//! outputs, plots, calibration — is built out on top of this.)

use mbs_kernel::{q_star, Error, Real, Scenario, Sim, G};

/// Grain capacity of the host's standard simulation.
pub const GRAINS: usize = 4096;
/// Neighbour slots per grain of the host's standard simulation.
pub const NEIGHBOURS: usize = 8;

/// The host's standard simulation type.
pub type HostSim<R> = Sim<R, GRAINS, NEIGHBOURS>;

/// A simulation allocated directly on the heap, never built on the stack.
pub fn boxed_sim<R: Real, const N: usize, const K: usize>() -> Box<Sim<R, N, K>> {
    let zeroed = Box::<Sim<R, N, K>>::new_zeroed();
    // SAFETY: `Sim` documents (kernel/src/sim.rs) that every field is a
    // number, a bool, or a struct or array of those, and `Real` is sealed to
    // f32 and f64; so the all-zero bit pattern is a valid `Sim`, equal to
    // `Sim::new()` (checked by `tests::zeroed_box_equals_new`).
    unsafe { zeroed.assume_init() }
}

/// Meyer-Peter & Müller (1948): q* = 8 (τ* − 0.047)^1.5 (SPEC §10).
pub fn meyer_peter_muller(tau_star: f64) -> f64 {
    8.0 * (tau_star - 0.047).max(0.0).powf(1.5)
}

/// Result of one transport run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TransportPoint {
    /// Shields number.
    pub tau_star: f64,
    /// Time-averaged q* over the window.
    pub q_star: f64,
    /// Grain-steps computed (for throughput figures).
    pub grain_steps: u64,
}

/// Builds the scenario's bed, settles it for `settle_s` seconds, switches
/// the flow on, spins up for `spin_up_s` and averages q* (SPEC §8) over
/// `window_s`, sampling every 100 steps.
pub fn transport<R: Real>(
    sc: &Scenario,
    settle_s: f64,
    spin_up_s: f64,
    window_s: f64,
) -> Result<TransportPoint, Error> {
    let mut sim = boxed_sim::<R, GRAINS, NEIGHBOURS>();
    sc.build(&mut *sim)?;
    let steps = |t: f64| (t / sc.dt).round() as u64;
    sim.run(steps(settle_s))?;
    sim.set_flow(Some(&sc.flow()))?;
    sim.run(steps(spin_up_s))?;
    let d = sc.bed.max_diameter();
    let (mut sum, mut samples) = (0.0, 0u64);
    let chunks = steps(window_s) / 100;
    for _ in 0..chunks {
        sim.run(100)?;
        sum += sim.observe().q_b(d);
        samples += 1;
    }
    let q_b = if samples > 0 {
        sum / samples as f64
    } else {
        0.0
    };
    Ok(TransportPoint {
        tau_star: sc.tau_star,
        q_star: q_star(q_b, d, sc.material.s, G),
        grain_steps: sim.step_count() * sim.len() as u64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zeroed_box_equals_new() {
        let sc = Scenario::paper();
        let mut a = boxed_sim::<f64, 64, 8>();
        let mut b = Box::new(Sim::<f64, 64, 8>::new());
        assert_eq!(a.digest(), b.digest());
        assert_eq!(
            sc.digests(&mut *a, 200, 200).unwrap(),
            sc.digests(&mut *b, 200, 200).unwrap()
        );
    }

    #[test]
    fn mpm_reference() {
        assert_eq!(meyer_peter_muller(0.04), 0.0);
        assert!((meyer_peter_muller(0.147) - 8.0 * 0.1f64.powf(1.5)).abs() < 1e-12);
    }
}
