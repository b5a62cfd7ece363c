//! One transport cell — a (τ*, seed) run of the main job — as a resumable
//! state machine: settle, spin up, average over the window. Between chunks
//! of steps the cell can write a checkpoint (its progress and accumulated
//! sums plus the kernel's checkpoint) and stop; restoring it continues bit
//! for bit, so a cell stopped anywhere gives the same result as one never
//! stopped.
//!
//! Checkpoint file (version 2, little-endian): magic `MBSC`, version u16,
//! the cell's key (FNV-1a of its specification) u64, phase u8, steps done in
//! the phase u64, samples u64, Σq* (f64 bits), the class count u32 and Σq*
//! per class, Σq* per batch (f64 bits) and batch counts (u64), the kernel
//! checkpoint (u64 length, bytes), and a CRC-32 (IEEE) of everything before
//! it. The CRC detects damage, not deliberate edits: a loaded state is
//! checked field by field against the configuration ([`CellState::check`])
//! and the restored kernel against the cell's scenario, so an edited file is
//! refused or, if consistent, gives a cell this configuration could have
//! produced (docs/guarantees.md).

use crate::config::{Config, ConfigFile};
use crate::error::HostError;
use crate::sims::{check_restored, with_sim, SimJob, NEIGHBOURS};
use crate::text::number;
use indicatif::ProgressBar;
use mbs_kernel::{Fnv1a, Real, Sim, G};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Steps run between checks for stopping and checkpointing.
const CHUNK: u64 = 2000;

/// The fewest integration steps between two timed checkpoints of a cell
/// (`--checkpoint-every`): a shorter interval would write checkpoints more
/// often than the cell steps (each is a file synced to disk).
pub const MIN_CHECKPOINT_STEPS: u64 = CHUNK;

const MAGIC: [u8; 4] = *b"MBSC";
const VERSION: u16 = 2;

/// Batches of the window used for the standard error of a single seed.
pub const BATCHES: usize = 10;

/// What one (τ*, seed) cell measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellResult {
    /// Shields number.
    pub tau_star: f64,
    /// Seed.
    pub seed: u64,
    /// Time-averaged q* over the window (all classes, d = d_max).
    pub q_star: f64,
    /// Time-averaged q* per size class (its own diameter).
    pub q_star_class: Vec<f64>,
    /// q* averaged over each of [`BATCHES`] consecutive parts of the window.
    pub batch_means: Vec<f64>,
    /// Mean bed level at the end (m, relative to the fixed grains' mean).
    pub bed_level: f64,
    /// Grain-steps computed.
    pub grain_steps: u64,
}

/// Where a cell is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Settling without flow.
    Settle = 0,
    /// Under the flow, before averaging.
    SpinUp = 1,
    /// Averaging q*.
    Window = 2,
}

/// Progress and sums of a cell.
#[derive(Debug, Clone, PartialEq)]
pub struct CellState {
    /// Current phase.
    pub phase: Phase,
    /// Steps done in the phase.
    pub done: u64,
    /// Window samples taken.
    pub samples: u64,
    /// Σ q*.
    pub total: f64,
    /// Σ q* per class.
    pub per_class: Vec<f64>,
    /// Σ q* per batch.
    pub batch_sum: [f64; BATCHES],
    /// Samples per batch.
    pub batch_n: [u64; BATCHES],
}

impl CellState {
    /// Checks a loaded state against the configuration it claims to belong
    /// to: `classes` size classes, phases of `phase_steps` steps, `samples`
    /// window samples every `sample` steps. Settling and spin-up hold no
    /// sums; in the window, the steps, samples and batch counts are exactly
    /// those of the loop in [`CellJob`], with checked arithmetic, and the sums
    /// are finite and agree with each other. Names the first field that does
    /// not fit.
    pub fn check(
        &self,
        classes: usize,
        phase_steps: impl Fn(Phase) -> u64,
        sample: u64,
        samples: u64,
    ) -> Result<(), CheckpointError> {
        let bad = |what| Err(CheckpointError::Value(what));
        if self.per_class.len() != classes {
            return bad("size classes");
        }
        if self.done > phase_steps(self.phase) {
            return bad("steps done in the phase");
        }
        let sums = self
            .per_class
            .iter()
            .chain(&self.batch_sum)
            .chain([&self.total]);
        if self.phase != Phase::Window {
            let empty = self.samples == 0
                && self.batch_n == [0; BATCHES]
                && sums.clone().all(|x| x.to_bits() == 0);
            return if empty {
                Ok(())
            } else {
                bad("sums before the window")
            };
        }
        if self.samples > samples || self.samples.checked_mul(sample) != Some(self.done) {
            return bad("window samples");
        }
        let mut expected = [0u64; BATCHES];
        for k in 0..self.samples {
            // The batch of sample k, as in the window loop (k < samples, so < BATCHES).
            let b = u128::from(k) * BATCHES as u128 / u128::from(samples.max(1));
            expected[b.min(BATCHES as u128 - 1) as usize] += 1;
        }
        if self.batch_n != expected {
            return bad("batch counts");
        }
        if !sums.clone().all(|x| x.is_finite())
            || self
                .batch_sum
                .iter()
                .zip(self.batch_n)
                .any(|(s, n)| n == 0 && s.to_bits() != 0)
        {
            return bad("sums");
        }
        // Σq* and the batch sums add the same samples in other groupings:
        // equal up to rounding.
        let batches: f64 = self.batch_sum.iter().sum();
        let scale: f64 = self.batch_sum.iter().map(|s| s.abs()).sum::<f64>() + self.total.abs();
        if (self.total - batches).abs() > 1e-9 * scale {
            return bad("total");
        }
        Ok(())
    }

    fn new(classes: usize) -> Self {
        CellState {
            phase: Phase::Settle,
            done: 0,
            samples: 0,
            total: 0.0,
            per_class: vec![0.0; classes],
            batch_sum: [0.0; BATCHES],
            batch_n: [0; BATCHES],
        }
    }
}

/// A cell's checkpoint: its key, state and the kernel's checkpoint.
#[derive(Debug, Clone, PartialEq)]
pub struct CellCheckpoint {
    /// FNV-1a of the cell's specification.
    pub key: u64,
    /// Progress and sums.
    pub state: CellState,
    /// Kernel checkpoint bytes.
    pub sim: Vec<u8>,
}

/// Why a cell checkpoint was refused.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CheckpointError {
    /// Shorter than its contents.
    Truncated,
    /// Not a cell checkpoint.
    Magic,
    /// Another format version.
    Version(u16),
    /// Checksum mismatch: damaged.
    Checksum,
    /// Written for another configuration, τ* or seed.
    OtherCell,
    /// A field is out of range.
    Value(&'static str),
}

impl std::fmt::Display for CheckpointError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CheckpointError::Truncated => write!(f, "truncated"),
            CheckpointError::Magic => write!(f, "not an mbs cell checkpoint"),
            CheckpointError::Version(v) => {
                write!(f, "format version {v}, this mbs reads {VERSION}")
            }
            CheckpointError::Checksum => write!(f, "checksum mismatch (damaged)"),
            CheckpointError::OtherCell => {
                write!(f, "written for another configuration, tau* or seed")
            }
            CheckpointError::Value(what) => write!(f, "{what} out of range"),
        }
    }
}

/// The key of a cell: FNV-1a of its canonical specification text.
pub fn cell_key(spec_json: &str) -> u64 {
    Fnv1a::of(spec_json.as_bytes())
}

impl CellCheckpoint {
    /// Encodes the checkpoint.
    pub fn encode(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(self.sim.len() + 256);
        b.extend_from_slice(&MAGIC);
        b.extend_from_slice(&VERSION.to_le_bytes());
        b.extend_from_slice(&self.key.to_le_bytes());
        let s = &self.state;
        b.push(s.phase as u8);
        b.extend_from_slice(&s.done.to_le_bytes());
        b.extend_from_slice(&s.samples.to_le_bytes());
        b.extend_from_slice(&s.total.to_bits().to_le_bytes());
        b.extend_from_slice(&(s.per_class.len() as u32).to_le_bytes());
        for x in &s.per_class {
            b.extend_from_slice(&x.to_bits().to_le_bytes());
        }
        for x in &s.batch_sum {
            b.extend_from_slice(&x.to_bits().to_le_bytes());
        }
        for n in &s.batch_n {
            b.extend_from_slice(&n.to_le_bytes());
        }
        b.extend_from_slice(&(self.sim.len() as u64).to_le_bytes());
        b.extend_from_slice(&self.sim);
        let sum = crc32fast::hash(&b);
        b.extend_from_slice(&sum.to_le_bytes());
        b
    }

    /// The length of the largest cell checkpoint with `classes` size classes
    /// and a kernel checkpoint of at most `sim_max` bytes.
    pub fn max_len(classes: usize, sim_max: usize) -> usize {
        // Magic, version, key, phase, done, samples, Σq*, class count.
        let head = 4 + 2 + 8 + 1 + 8 + 8 + 8 + 4;
        head + 8 * classes + 16 * BATCHES + 8 + sim_max + 4
    }

    /// Decodes and checks a checkpoint written for the cell `key`.
    pub fn decode(bytes: &[u8], key: u64) -> Result<CellCheckpoint, CheckpointError> {
        let mut at = 0usize;
        let mut take = |n: usize| -> Result<&[u8], CheckpointError> {
            let end = at
                .checked_add(n)
                .filter(|&e| e <= bytes.len())
                .ok_or(CheckpointError::Truncated)?;
            let out = &bytes[at..end];
            at = end;
            Ok(out)
        };
        let u64_of = |b: &[u8]| u64::from_le_bytes(b.try_into().unwrap_or([0; 8]));
        if take(4)? != MAGIC {
            return Err(CheckpointError::Magic);
        }
        let version = u16::from_le_bytes([take(1)?[0], take(1)?[0]]);
        if version != VERSION {
            return Err(CheckpointError::Version(version));
        }
        if bytes.len() < 4 {
            return Err(CheckpointError::Truncated);
        }
        let (body, sum) = bytes.split_at(bytes.len() - 4);
        if crc32fast::hash(body).to_le_bytes() != sum {
            return Err(CheckpointError::Checksum);
        }
        if u64_of(take(8)?) != key {
            return Err(CheckpointError::OtherCell);
        }
        let phase = match take(1)?[0] {
            0 => Phase::Settle,
            1 => Phase::SpinUp,
            2 => Phase::Window,
            _ => return Err(CheckpointError::Value("phase")),
        };
        let done = u64_of(take(8)?);
        let samples = u64_of(take(8)?);
        let total = f64::from_bits(u64_of(take(8)?));
        let classes = u32::from_le_bytes(take(4)?.try_into().unwrap_or([0; 4])) as usize;
        if classes > mbs_kernel::MAX_CLASSES {
            return Err(CheckpointError::Value("size classes"));
        }
        let mut per_class = Vec::with_capacity(classes);
        for _ in 0..classes {
            per_class.push(f64::from_bits(u64_of(take(8)?)));
        }
        let mut batch_sum = [0.0; BATCHES];
        for x in batch_sum.iter_mut() {
            *x = f64::from_bits(u64_of(take(8)?));
        }
        let mut batch_n = [0u64; BATCHES];
        for n in batch_n.iter_mut() {
            *n = u64_of(take(8)?);
        }
        let len = u64_of(take(8)?);
        let len = usize::try_from(len).map_err(|_| CheckpointError::Truncated)?;
        let sim = take(len)?.to_vec();
        if at != body.len() {
            return Err(CheckpointError::Value("length"));
        }
        Ok(CellCheckpoint {
            key,
            state: CellState {
                phase,
                done,
                samples,
                total,
                per_class,
                batch_sum,
                batch_n,
            },
            sim,
        })
    }
}

/// A transport cell: one (configuration, τ*, seed) run of the main job.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransportSpec {
    /// Kind tag (keeps kinds apart in the store).
    pub kind: &'static str,
    /// The configuration, with `flow.tau_star = [τ*]`, `run.seeds = [seed]`.
    pub config: ConfigFile,
}

impl TransportSpec {
    /// The cell of `config` at `tau_star` and `seed`.
    pub fn new(config: &ConfigFile, tau_star: f64, seed: u64) -> Self {
        let mut config = canonical(config);
        config.flow.tau_star = vec![tau_star];
        config.run.seeds = vec![seed];
        TransportSpec {
            kind: "transport",
            config,
        }
    }
}

/// Fields that do not change a cell's result are fixed, so equal cells get
/// equal keys whatever the configuration file said about them.
pub fn canonical(config: &ConfigFile) -> ConfigFile {
    let mut c = config.clone();
    c.run.output = "-".into();
    c
}

/// When a cell stops early and where it checkpoints.
pub struct Control<'a> {
    /// Checkpoint file of this cell.
    pub path: Option<PathBuf>,
    /// Wall-clock interval between checkpoints (and at least
    /// [`MIN_CHECKPOINT_STEPS`] steps).
    pub every: Option<Duration>,
    /// Set asynchronously (Ctrl-C): checkpoint and stop at the next chunk.
    pub stop: &'a AtomicBool,
    /// Stop (with a checkpoint) after this many steps of this invocation (tests).
    pub stop_after: Option<u64>,
}

/// How a cell ended.
#[derive(Debug, Clone, PartialEq)]
pub enum CellOutcome {
    /// Finished.
    Done(CellResult),
    /// Stopped after writing its checkpoint.
    Stopped,
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
    /// Where to continue from.
    pub resume: Option<CellCheckpoint>,
    /// Stopping and checkpointing.
    pub control: &'a Control<'a>,
    /// Progress (steps).
    pub progress: &'a ProgressBar,
}

impl SimJob for CellJob<'_> {
    type Output = Result<CellOutcome, HostError>;

    fn run<R: Real, const N: usize>(self, sim: &mut Sim<R, N, NEIGHBOURS>) -> Self::Output {
        let setup = self.config.setup(self.tau_star, self.seed);
        let sc = &setup.scenario;
        let context = format!("tau* = {}, seed {}", number(self.tau_star), self.seed);
        let fail = || HostError::kernel(context.clone());
        let classes = &sc.bed.classes;
        let durations = self.config.durations;
        let (sample, samples) = (durations.sample, durations.samples);
        let phase_steps = |p: Phase| match p {
            Phase::Settle => durations.settle,
            Phase::SpinUp => durations.spin_up,
            Phase::Window => durations.window(),
        };
        let refuse = |message: String| HostError::Checkpoint {
            path: self.control.path.clone().unwrap_or_default(),
            message,
        };
        let mut state = match self.resume {
            Some(ck) => {
                let s = &ck.state;
                s.check(classes.len(), phase_steps, sample, samples)
                    .map_err(|e| {
                        refuse(format!("its progress does not fit this configuration: {e}"))
                    })?;
                sim.restore(&ck.sim).map_err(fail())?;
                // The steps the kernel has taken: the earlier phases' and this one's.
                let steps = match s.phase {
                    Phase::Settle => Some(s.done),
                    Phase::SpinUp => durations.settle.checked_add(s.done),
                    Phase::Window => durations
                        .settle
                        .checked_add(durations.spin_up)
                        .and_then(|n| n.checked_add(s.done)),
                };
                let flow = (s.phase != Phase::Settle).then_some(&setup.flow);
                let Some(steps) = steps else {
                    return Err(refuse("its progress overflows the step count".into()));
                };
                check_restored(sim, sc, flow, steps).map_err(|why| {
                    refuse(format!(
                        "{why}: it is not this cell's (phase {:?})",
                        s.phase
                    ))
                })?;
                ck.state
            }
            None => {
                sc.build(sim).map_err(fail())?;
                CellState::new(classes.len())
            }
        };
        let (d_max, s) = (sc.bed.max_diameter(), sc.material.s);
        let mut last_checkpoint = Instant::now();
        let mut stepped = 0u64;
        let mut stepped_at_checkpoint = 0u64;
        loop {
            if state.done >= phase_steps(state.phase) {
                match state.phase {
                    Phase::Settle => {
                        sim.set_flow(Some(&setup.flow)).map_err(fail())?;
                        state.phase = Phase::SpinUp;
                    }
                    Phase::SpinUp => state.phase = Phase::Window,
                    Phase::Window => break,
                }
                state.done = 0;
                continue;
            }
            let stop_now = self.control.stop.load(Ordering::Relaxed)
                || self.control.stop_after.is_some_and(|n| stepped >= n);
            let due = self.control.every.is_some_and(|every| {
                last_checkpoint.elapsed() >= every
                    && stepped - stepped_at_checkpoint >= MIN_CHECKPOINT_STEPS
            });
            if stop_now || due {
                if let Some(path) = &self.control.path {
                    let mut bytes = Vec::new();
                    sim.checkpoint(|b| bytes.extend_from_slice(b));
                    let ck = CellCheckpoint {
                        key: self.key,
                        state: state.clone(),
                        sim: bytes,
                    };
                    crate::output::write_atomic(path, &ck.encode())?;
                }
                last_checkpoint = Instant::now();
                stepped_at_checkpoint = stepped;
                if stop_now {
                    return Ok(CellOutcome::Stopped);
                }
            }
            if state.phase == Phase::Window {
                sim.run(sample).map_err(fail())?;
                let o = sim.observe();
                let q = o.q_star(d_max, s, G);
                state.total += q;
                let b = (state.samples as usize * BATCHES) / samples as usize;
                state.batch_sum[b] += q;
                state.batch_n[b] += 1;
                for (c, sum) in state.per_class.iter_mut().enumerate() {
                    // Each class on the total's scale d_max: the classes add up to q*.
                    *sum += o.q_star_class(c, d_max, s, G);
                }
                state.samples += 1;
                state.done += sample;
                stepped += sample;
                self.progress.inc(sample);
            } else {
                let n = (phase_steps(state.phase) - state.done).min(CHUNK);
                sim.run(n).map_err(fail())?;
                state.done += n;
                stepped += n;
                self.progress.inc(n);
            }
        }
        let n = state.samples.max(1) as f64;
        Ok(CellOutcome::Done(CellResult {
            tau_star: self.tau_star,
            seed: self.seed,
            q_star: state.total / n,
            q_star_class: state.per_class.iter().map(|q| q / n).collect(),
            batch_means: state
                .batch_sum
                .iter()
                .zip(state.batch_n)
                .filter(|(_, n)| *n > 0)
                .map(|(s, n)| s / n as f64)
                .collect(),
            bed_level: sim.bed_level(),
            grain_steps: sim.step_count() * sim.len() as u64,
        }))
    }
}

/// Runs a cell job on a simulation of the configuration's precision and capacity.
pub fn run_cell_job(job: CellJob<'_>) -> Result<CellOutcome, HostError> {
    let (precision, capacity) = (job.config.precision, job.config.capacity);
    with_sim(precision, capacity, job)
}

/// Runs one cell from the start to the end (no checkpoints).
pub fn run_cell(
    config: &Config,
    tau_star: f64,
    seed: u64,
    progress: &ProgressBar,
) -> Result<CellResult, HostError> {
    let never = AtomicBool::new(false);
    let control = Control {
        path: None,
        every: None,
        stop: &never,
        stop_after: None,
    };
    let job = CellJob {
        config,
        tau_star,
        seed,
        key: 0,
        resume: None,
        control: &control,
        progress,
    };
    match run_cell_job(job)? {
        CellOutcome::Done(r) => Ok(r),
        CellOutcome::Stopped => Err(HostError::Interrupted { cells: 1 }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkpoints_round_trip_and_damage_is_named() {
        let ck = CellCheckpoint {
            key: 42,
            state: CellState {
                phase: Phase::Window,
                done: 1230,
                samples: 123,
                total: 0.125,
                per_class: vec![0.5, 0.25],
                batch_sum: [0.1; BATCHES],
                batch_n: [3; BATCHES],
            },
            sim: vec![1, 2, 3, 4, 5],
        };
        let bytes = ck.encode();
        assert_eq!(bytes.len(), CellCheckpoint::max_len(2, 5));
        assert_eq!(CellCheckpoint::decode(&bytes, 42), Ok(ck));
        assert_eq!(
            CellCheckpoint::decode(&bytes, 43),
            Err(CheckpointError::OtherCell)
        );
        for len in 0..bytes.len() {
            assert!(
                CellCheckpoint::decode(&bytes[..len], 42).is_err(),
                "length {len}"
            );
        }
        let mut bad = bytes.clone();
        bad[30] ^= 1;
        assert_eq!(
            CellCheckpoint::decode(&bad, 42),
            Err(CheckpointError::Checksum)
        );
        let mut bad = bytes.clone();
        bad[4] = 9;
        assert_eq!(
            CellCheckpoint::decode(&bad, 42),
            Err(CheckpointError::Version(9))
        );
        assert_eq!(
            CellCheckpoint::decode(b"nope", 42),
            Err(CheckpointError::Magic)
        );
    }
}
