//! Running a transport cell ([`CellJob`], [`run_cell_job`], [`run_cell`]):
//! restore the seed's settled bed ([`crate::work::beds`]), switch the flow
//! on, spin up, average over the window, writing a [`CellCheckpoint`]
//! between chunks of steps when asked and stopping, and with a
//! [`FramePlan`] particle frames ([`Dumps`]), which change none of its
//! numbers; the cell's data and its checkpoint are in
//! [`crate::work::cell`].

use crate::config::Config;
use crate::error::HostError;
use crate::io::text::number;
use crate::sim::control::{Checkpoints, Control};
use crate::sim::frames::Dumps;
use crate::sim::sims::{check_restored, with_sim, HostSim, SimJob, NEIGHBOURS};
use crate::sim::threads::Stepping;
use crate::work::beds::{BedRecord, BedState};
use crate::work::cell::{
    kept_means, q_means, Block, CellCheckpoint, CellOutcome, CellResult, CellState, Phase,
    WindowRule,
};
use crate::work::profiles::{Sampler, PROFILE_SAMPLES};
use indicatif::ProgressBar;
use mbs_kernel::{Real, G};
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

/// Steps run between checks for stopping and checkpointing.
const CHUNK: u64 = crate::sim::control::MIN_CHECKPOINT_STEPS;

/// Where and how often a cell writes particle frames (`mbs run
/// --dump-every`, [`Dumps`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FramePlan {
    /// The cell's frame directory.
    pub dir: PathBuf,
    /// Integration steps between frames (at least 1).
    pub every: u64,
}

/// Runs `n` steps by `stepping`, through `dumps` if the cell writes
/// frames: the same bits.
fn advance<R: Real, const N: usize>(
    sim: &mut HostSim<R, N>,
    stepping: &mut Stepping<R, N, NEIGHBOURS>,
    dumps: Option<&mut Dumps>,
    n: u64,
    fail: &dyn Fn(mbs_kernel::Error) -> HostError,
) -> Result<(), HostError> {
    match dumps {
        Some(d) => d.run(sim, stepping, n, fail),
        None => stepping.run(sim, n).map_err(fail),
    }
}

/// A cell to run, possibly from a checkpoint.
pub struct CellJob<'a> {
    /// Configuration.
    pub config: &'a Config,
    /// Shields number.
    pub tau_star: f64,
    /// Seed.
    pub seed: u64,
    /// The cell's key.
    pub key: u64,
    /// The seed's settled bed.
    pub bed: &'a BedState,
    /// Where to continue from.
    pub resume: Option<CellCheckpoint>,
    /// Stopping and checkpointing.
    pub control: &'a Control<'a>,
    /// Progress (steps).
    pub progress: &'a ProgressBar,
    /// Particle frames under the flow, if any.
    pub frames: Option<FramePlan>,
    /// Threads of the cell's steps (`[run] threads_per_cell`; the same bits
    /// on any number, [`Stepping`]).
    pub threads: usize,
}

impl SimJob for CellJob<'_> {
    type Output = Result<CellOutcome, HostError>;

    fn run<R: Real, const N: usize>(self, sim: &mut HostSim<R, N>) -> Self::Output {
        let setup = self.config.setup(self.tau_star, self.seed);
        let sc = &setup.scenario;
        let context = format!("tau* = {}, seed {}", number(self.tau_star), self.seed);
        let fail = || HostError::kernel(context.clone());
        let classes = &sc.bed.classes;
        let rule = WindowRule::of(self.config);
        let durations = rule.durations;
        let refuse = |message: String| HostError::Checkpoint {
            path: self.control.path.clone().unwrap_or_default(),
            message,
        };
        let settled = self.bed.steps;
        let resumed = self.resume.is_some();
        let mut state = match self.resume {
            Some(ck) => {
                let s = &ck.state;
                s.check(classes.len(), &rule).map_err(|e| {
                    refuse(format!("its progress does not fit this configuration: {e}"))
                })?;
                sim.restore(&ck.sim).map_err(fail())?;
                // The steps the kernel has taken: the bed's settling, the
                // earlier phase's and this one's.
                let steps = match s.phase {
                    Phase::SpinUp => settled.checked_add(s.done),
                    Phase::Window => settled
                        .checked_add(durations.spin_up)
                        .and_then(|n| n.checked_add(s.done)),
                };
                let Some(steps) = steps else {
                    return Err(refuse("its progress overflows the step count".into()));
                };
                check_restored(sim, sc, Some(&setup.flow), steps).map_err(|why| {
                    refuse(format!(
                        "{why}: it is not this cell's (phase {:?})",
                        s.phase
                    ))
                })?;
                ck.state
            }
            None => {
                sim.restore(&self.bed.sim).map_err(fail())?;
                check_restored(sim, sc, None, settled).map_err(|why| HostError::Checkpoint {
                    path: Default::default(),
                    message: format!("the settled bed of seed {}: {why}", self.seed),
                })?;
                sim.set_flow(Some(&setup.flow)).map_err(fail())?;
                CellState::new(classes.len(), rule.cells)
            }
        };
        // The frames' time is the time since the flow started (step `settled`).
        let mut stepping = Stepping::new(self.threads);
        let mut dumps = match &self.frames {
            None => None,
            Some(f) if resumed => Some(Dumps::resume(&f.dir, f.every, settled, sim)?),
            Some(f) => Some(Dumps::start(&f.dir, f.every, settled, sim)?),
        };
        let kernel_error = |e| fail()(e);
        // Where this invocation starts: a resumed cell did its earlier steps before.
        let started = sim.step_count();
        let (d_max, s) = (sc.bed.max_diameter(), sc.material.s);
        // q* per unit of the slice's thickness b (a channel's width with
        // side walls): the kernel's is per d_max (docs/model.md §8).
        let per_slice = d_max / sc.slice_thickness();
        let mut sampler = Sampler::new(self.config);
        let mut checkpoints = Checkpoints::new(self.control);
        let mut stepped = 0u64;
        loop {
            let ended = match state.phase {
                Phase::SpinUp => state.done >= durations.spin_up,
                Phase::Window => {
                    state.samples % durations.block_samples == 0 && rule.ends(&state.blocks)
                }
            };
            if ended {
                match state.phase {
                    Phase::SpinUp => state.phase = Phase::Window,
                    Phase::Window => break,
                }
                state.done = 0;
                continue;
            }
            let mut saved = Ok(());
            let stop = checkpoints.due(stepped, || {
                // The frames' record first: a crash between the two leaves
                // a record that does not fit the checkpoint.
                if let Some(d) = dumps.as_mut() {
                    saved = d.save(sim);
                }
                let mut bytes = Vec::new();
                sim.checkpoint(|b| bytes.extend_from_slice(b));
                CellCheckpoint {
                    key: self.key,
                    state: state.clone(),
                    sim: bytes,
                }
                .encode()
            })?;
            saved?;
            if stop {
                return Ok(CellOutcome::Stopped);
            }
            if state.phase == Phase::Window {
                let sample = durations.sample;
                advance(sim, &mut stepping, dumps.as_mut(), sample, &kernel_error)?;
                let o = sim.observe();
                state.block_sum += o.q_star(d_max, s, G) * per_slice;
                for (c, sum) in state.class_sums.iter_mut().enumerate() {
                    // Each class on the total's scale d_max: the classes add up to q*.
                    *sum += o.q_star_class(c, d_max, s, G) * per_slice;
                }
                state.samples += 1;
                if state.samples % PROFILE_SAMPLES == 0 {
                    sampler.sample(sim, &mut state.profile).map_err(fail())?;
                }
                if state.samples % durations.block_samples == 0 {
                    let n = durations.block_samples as f64;
                    state.blocks.push(Block {
                        q_star: state.block_sum / n,
                        bed_level: sim.bed_level(),
                        q_star_class: state.class_sums.iter().map(|q| q / n).collect(),
                    });
                    state.block_sum = 0.0;
                    state.class_sums.iter_mut().for_each(|q| *q = 0.0);
                }
                state.done += sample;
                stepped += sample;
                self.progress.inc(sample);
            } else {
                let n = (durations.spin_up - state.done).min(CHUNK);
                advance(sim, &mut stepping, dumps.as_mut(), n, &kernel_error)?;
                state.done += n;
                stepped += n;
                self.progress.inc(n);
            }
        }
        if let Some(d) = dumps {
            d.finish()?;
        }
        let step_dt = sc.step_dt();
        let (truncation, reached) = rule.verdict(&q_means(&state.blocks));
        let kept = &state.blocks[truncation.discard..];
        // Fewer than all blocks: the rule stopped it on the target.
        let target_reached = (state.blocks.len() as u64) < durations.max_blocks || reached;
        let (q_star, q_star_class) = kept_means(kept, classes.len());
        let grain_steps_now = (sim.step_count() - started) * sim.len() as u64;
        Ok(CellOutcome::Done(
            Box::new(CellResult {
                tau_star: self.tau_star,
                seed: self.seed,
                q_star,
                q_star_class,
                discarded: truncation.discard,
                steady: truncation.steady,
                window_s: state.done as f64 * step_dt,
                target_reached,
                blocks: state.blocks,
                bed_level: sim.bed_level(),
                grain_steps: (sim.step_count() - settled) * sim.len() as u64,
                bed: BedRecord {
                    status: self.bed.status,
                    settle_s: self.bed.seconds(step_dt),
                    max_overlap_d: self.bed.max_overlap / d_max,
                },
                profile: Some(state.profile.means()),
            }),
            grain_steps_now,
        ))
    }
}

/// Runs a cell job on a simulation of the configuration's precision and capacity.
pub fn run_cell_job(job: CellJob<'_>) -> Result<CellOutcome, HostError> {
    let (precision, capacity) = (job.config.precision, job.config.capacity);
    with_sim(precision, capacity, job)
}

/// Runs one cell from its settled bed to the end (no checkpoints).
pub fn run_cell(
    config: &Config,
    tau_star: f64,
    seed: u64,
    bed: &BedState,
    progress: &ProgressBar,
) -> Result<CellResult, HostError> {
    let never = AtomicBool::new(false);
    let control = Control::never(&never);
    let job = CellJob {
        config,
        tau_star,
        seed,
        key: 0,
        bed,
        resume: None,
        control: &control,
        progress,
        frames: None,
        threads: 1,
    };
    match run_cell_job(job)? {
        CellOutcome::Done(r, _) => Ok(*r),
        CellOutcome::Stopped => Err(HostError::Interrupted { jobs: 1 }),
    }
}
