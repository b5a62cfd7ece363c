//! One bed held between calls, for interactive work (what the Python
//! package's `mbs.Sim` wraps): built, settled exactly as `mbs run` settles
//! a seed's bed ([`BedJob`]), stepped under the flow, observed, digested,
//! checkpointed and restored. The simulation's precision and capacity are
//! chosen at run time; a private object-safe trait hides them.

use super::beds::{BedJob, BedKey, BedState, BedStatus};
use super::cell::CellResult;
use super::job::run_cell;
use super::profiles::{CellProfile, ProfileGrid, ProfileSums, Sampler};
use crate::config::{grain_capacities, Config, Precision};
use crate::error::HostError;
use crate::sim::control::Control;
use crate::sim::sims::{boxed_sim, with_sim, HostSim, NEIGHBOURS};
use crate::sim::threads::Stepping;
use mbs_kernel::{FlowConfig, Real, Scenario, G};
use std::sync::atomic::AtomicBool;

/// Every grain's values, copied out of the simulation (SI units).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GrainArrays {
    /// Streamwise positions x (m), in [0, L).
    pub x: Vec<f64>,
    /// Heights y (m).
    pub y: Vec<f64>,
    /// Streamwise velocities u (m/s).
    pub u: Vec<f64>,
    /// Vertical velocities v (m/s).
    pub v: Vec<f64>,
    /// Spins ω (rad/s).
    pub spin: Vec<f64>,
    /// Radii (m).
    pub radius: Vec<f64>,
    /// Fixed grains.
    pub fixed: Vec<bool>,
    /// Size classes.
    pub class: Vec<u8>,
}

/// Every contact's force as the next step applies it (docs/model.md §2).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactArrays {
    /// First grains.
    pub i: Vec<usize>,
    /// Second grains.
    pub j: Vec<usize>,
    /// Forces on i from j, x (N).
    pub fx: Vec<f64>,
    /// Forces on i from j, y (N).
    pub fy: Vec<f64>,
}

/// A simulation of some precision and capacity, as a [`Session`] uses it.
trait Held: Send + Sync {
    fn build(&mut self, scenario: &Scenario) -> Result<(), mbs_kernel::Error>;
    fn run(&mut self, steps: u64) -> Result<(), mbs_kernel::Error>;
    fn set_flow(&mut self, flow: Option<&FlowConfig>) -> Result<(), mbs_kernel::Error>;
    fn restore(&mut self, bytes: &[u8]) -> Result<(), mbs_kernel::Error>;
    fn checkpoint(&self) -> Vec<u8>;
    fn digest(&self) -> u64;
    fn step_count(&self) -> u64;
    fn time(&self) -> f64;
    fn grains(&self) -> GrainArrays;
    fn contacts(&self) -> ContactArrays;
    fn q_star(&self, d_max: f64, s: f64, per_slice: f64) -> f64;
    fn profile(
        &self,
        sampler: &mut Sampler,
        cells: usize,
    ) -> Result<CellProfile, mbs_kernel::Error>;
}

/// A host simulation and how its steps run ([`Stepping`]: on one core or,
/// with `run.threads_per_cell`, on several, the same bits).
struct Stepped<R: Real, const N: usize> {
    sim: Box<HostSim<R, N>>,
    stepping: Stepping<R, N, NEIGHBOURS>,
}

impl<R: Real, const N: usize> Held for Stepped<R, N> {
    fn build(&mut self, scenario: &Scenario) -> Result<(), mbs_kernel::Error> {
        scenario.build(&mut *self.sim).map(|_| ())
    }
    fn run(&mut self, steps: u64) -> Result<(), mbs_kernel::Error> {
        self.stepping.run(&mut *self.sim, steps)
    }
    fn set_flow(&mut self, flow: Option<&FlowConfig>) -> Result<(), mbs_kernel::Error> {
        HostSim::set_flow(&mut *self.sim, flow)
    }
    fn restore(&mut self, bytes: &[u8]) -> Result<(), mbs_kernel::Error> {
        HostSim::restore(&mut *self.sim, bytes)
    }
    fn checkpoint(&self) -> Vec<u8> {
        let mut out = Vec::new();
        HostSim::checkpoint(&*self.sim, |b| out.extend_from_slice(b));
        out
    }
    fn digest(&self) -> u64 {
        HostSim::digest(&*self.sim)
    }
    fn step_count(&self) -> u64 {
        HostSim::step_count(&*self.sim)
    }
    fn time(&self) -> f64 {
        HostSim::time(&*self.sim)
    }
    fn grains(&self) -> GrainArrays {
        let mut a = GrainArrays::default();
        for g in (0..self.sim.len()).filter_map(|i| self.sim.grain(i)) {
            a.x.push(g.x);
            a.y.push(g.y);
            a.u.push(g.u);
            a.v.push(g.v);
            a.spin.push(g.spin);
            a.radius.push(g.diameter / 2.0);
            a.fixed.push(g.fixed);
            a.class.push(g.class);
        }
        a
    }
    fn contacts(&self) -> ContactArrays {
        let mut a = ContactArrays::default();
        self.sim.contact_forces(|c| {
            a.i.push(c.i);
            a.j.push(c.j);
            a.fx.push(c.force[0]);
            a.fy.push(c.force[1]);
        });
        a
    }
    fn q_star(&self, d_max: f64, s: f64, per_slice: f64) -> f64 {
        self.sim.observe().q_star(d_max, s, G) * per_slice
    }
    fn profile(
        &self,
        sampler: &mut Sampler,
        cells: usize,
    ) -> Result<CellProfile, mbs_kernel::Error> {
        let mut sums = ProfileSums::new(cells);
        sampler.sample(&*self.sim, &mut sums)?;
        Ok(sums.means())
    }
}

macro_rules! held_of_capacity {
    ($capacity:expr, $threads:expr, $r:ty; $last:literal) => {{
        let held: Box<dyn Held> = Box::new(Stepped {
            sim: boxed_sim::<$r, $last, NEIGHBOURS>(),
            stepping: Stepping::new($threads),
        });
        held
    }};
    ($capacity:expr, $threads:expr, $r:ty; $first:literal, $($rest:literal),+) => {
        if $capacity <= $first {
            held_of_capacity!($capacity, $threads, $r; $first)
        } else {
            held_of_capacity!($capacity, $threads, $r; $($rest),+)
        }
    };
}

/// An empty simulation of `precision` and the smallest compiled capacity
/// holding `capacity` grains, stepped on `threads` threads.
fn held(precision: Precision, capacity: usize, threads: usize) -> Box<dyn Held> {
    match precision {
        Precision::F32 => grain_capacities!(held_of_capacity!(capacity, threads, f32;)),
        Precision::F64 => grain_capacities!(held_of_capacity!(capacity, threads, f64;)),
    }
}

/// One (τ*, seed) bed of a configuration, held between calls.
///
/// ```
/// let config = mbs::Config::golden()?;
/// let mut s = mbs::work::session::Session::new(&config, 0.2, 1)?;
/// s.settle()?;
/// let settled = s.digest();
/// s.step(100)?;
/// assert_eq!(s.grains().x.len(), 55);
/// let saved = s.checkpoint();
/// s.step(100)?;
/// let after = s.digest();
/// s.restore(&saved)?;
/// s.step(100)?;
/// assert_eq!(s.digest(), after, "restored and continued bit for bit");
/// assert_ne!(settled, after);
/// # Ok::<(), mbs::HostError>(())
/// ```
pub struct Session {
    config: Config,
    tau_star: f64,
    seed: u64,
    sim: Box<dyn Held>,
    bed: Option<BedState>,
}

impl Session {
    /// The bed of `seed` of `config`, built (its lattice, not settled), to
    /// run under the flow of `tau_star`.
    pub fn new(config: &Config, tau_star: f64, seed: u64) -> Result<Session, HostError> {
        crate::config::tau_star_arg("tau_star", tau_star)?;
        // One bed: `run.threads_per_cell` threads, 0 the whole pool.
        let threads = super::experiment::threads_per_cell(config.file.run.threads_per_cell, 1);
        let mut sim = held(config.precision, config.capacity, threads);
        let scenario = config.scenario_at(seed);
        sim.build(&scenario).map_err(HostError::kernel(format!(
            "building the bed of seed {seed}"
        )))?;
        Ok(Session {
            config: config.clone(),
            tau_star,
            seed,
            sim,
            bed: None,
        })
    }

    /// Settles the bed exactly as `mbs run` settles a seed's bed (until at
    /// rest, at most `time.settle`) and starts the flow: the state a cell
    /// of `mbs run` starts from, bit for bit.
    pub fn settle(&mut self) -> Result<BedStatus, HostError> {
        let never = AtomicBool::new(false);
        let control = Control::never(&never);
        let progress = indicatif::ProgressBar::hidden();
        let job = BedJob {
            config: &self.config,
            seed: self.seed,
            key: BedKey::new(&self.config.file, self.seed).hash(),
            resume: None,
            control: &control,
            progress: &progress,
        };
        let (bed, _) = with_sim(self.config.precision, self.config.capacity, job)?;
        let bed = bed.ok_or(HostError::Interrupted { jobs: 1 })?;
        let context = || HostError::kernel(format!("the settled bed of seed {}", self.seed));
        self.sim.restore(&bed.sim).map_err(context())?;
        let flow = self.config.scenario.flow(self.tau_star);
        self.sim.set_flow(Some(&flow)).map_err(context())?;
        let status = bed.status;
        self.bed = Some(bed);
        Ok(status)
    }

    /// Runs `steps` integration steps.
    pub fn step(&mut self, steps: u64) -> Result<(), HostError> {
        crate::config::steps_arg("steps", steps)?;
        let (tau, seed) = (self.tau_star, self.seed);
        self.sim
            .run(steps)
            .map_err(HostError::kernel(format!("tau* = {tau}, seed {seed}")))
    }

    /// The whole cell `mbs run` computes for this τ* and seed, from the
    /// settled bed (settling it first if needed): the same result, bit for
    /// bit, as the cell in `DIR/cells.jsonl`. The held bed is not stepped.
    pub fn run_cell(&mut self) -> Result<CellResult, HostError> {
        if self.bed.is_none() {
            self.settle()?;
        }
        let Some(bed) = &self.bed else {
            return Err(HostError::Interrupted { jobs: 1 });
        };
        run_cell(
            &self.config,
            self.tau_star,
            self.seed,
            bed,
            &indicatif::ProgressBar::hidden(),
        )
    }

    /// The simulated time (s).
    pub fn time(&self) -> f64 {
        self.sim.time()
    }

    /// Integration steps since the bed was built.
    pub fn step_count(&self) -> u64 {
        self.sim.step_count()
    }

    /// Every grain's values.
    pub fn grains(&self) -> GrainArrays {
        self.sim.grains()
    }

    /// Every contact's force.
    pub fn contacts(&self) -> ContactArrays {
        self.sim.contacts()
    }

    /// q* now, as a window samples it (docs/model.md §8): all classes, on
    /// the largest diameter, per unit of the slice's thickness.
    pub fn q_star(&self) -> f64 {
        let sc = &self.config.scenario;
        let d_max = sc.bed.max_diameter();
        self.sim
            .q_star(d_max, sc.material.s, d_max / sc.slice_thickness())
    }

    /// The profiles now, as a window samples them (docs/model.md §8): φ,
    /// u_p, u_f and the shear stresses per cell of the column, bottom up,
    /// at the heights [`Session::profile_heights_d`].
    pub fn profile(&self) -> Result<CellProfile, HostError> {
        let mut sampler = Sampler::new(&self.config);
        let (tau, seed) = (self.tau_star, self.seed);
        let cells = ProfileGrid::of(&self.config).grid.cells();
        self.sim
            .profile(&mut sampler, cells)
            .map_err(HostError::kernel(format!(
                "tau* = {tau}, seed {seed}: profiles"
            )))
    }

    /// The heights of [`Session::profile`]'s cells over the largest
    /// diameter (y = 0: the fixed grains' mean centre height).
    pub fn profile_heights_d(&self) -> Vec<f64> {
        ProfileGrid::heights_d(&self.config)
    }

    /// The state digest (docs/determinism.md).
    pub fn digest(&self) -> u64 {
        self.sim.digest()
    }

    /// The kernel checkpoint: every bit of the state.
    pub fn checkpoint(&self) -> Vec<u8> {
        self.sim.checkpoint()
    }

    /// Continues from `bytes`, a [`Session::checkpoint`] of a bed of this
    /// configuration; refused (nothing changed) if damaged or of another.
    pub fn restore(&mut self, bytes: &[u8]) -> Result<(), HostError> {
        self.sim.restore(bytes).map_err(|e| HostError::Checkpoint {
            path: "<bytes>".into(),
            message: format!("checkpoint refused: {e}"),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The Shields number of the flow.
    pub fn tau_star(&self) -> f64 {
        self.tau_star
    }

    /// The seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A session's settled bed is the run's, and its cell the run's cell.
    #[test]
    fn a_session_settles_and_runs_the_cell_mbs_run_runs() {
        let config = Config::from_toml(
            "[bed]\ncolumns = 5\nrows = 4\n[time]\nsettle = 0.02\nspin_up = 0.005\nwindow = 0.02\nwindow_min = 0.02\nblock = 0.005\n[run]\ncapacity = 256\n",
        )
        .unwrap();
        let mut a = Session::new(&config, 0.3, 2).unwrap();
        a.settle().unwrap();
        let mut b = Session::new(&config, 0.3, 2).unwrap();
        b.settle().unwrap();
        assert_eq!(a.digest(), b.digest());
        let cell = a.run_cell().unwrap();
        let bed = a.bed.clone().unwrap();
        let progress = indicatif::ProgressBar::hidden();
        let direct = run_cell(&config, 0.3, 2, &bed, &progress).unwrap();
        assert_eq!(cell, direct);
        assert!(Session::new(&config, 9.0, 1).is_err());
        assert!(a.restore(b"not a checkpoint").is_err());
    }
}
