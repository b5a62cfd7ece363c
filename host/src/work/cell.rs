//! One transport cell — a (τ*, seed) run of the main job — as data: its
//! specification ([`TransportSpec`]), its state machine's state
//! ([`CellState`]: spin-up, then the window's sums) and rule
//! ([`WindowRule`]), its result ([`CellResult`]) and its checkpoint
//! ([`CellCheckpoint`]: its progress and accumulated sums plus the kernel's
//! checkpoint); restoring it continues bit for bit, so a cell stopped
//! anywhere gives the same result as one never stopped. Running it is
//! [`crate::work::job`].
//!
//! Checkpoint file (version 6, framed by [`crate::io::framing`]): magic `MBSC`,
//! the cell's key (FNV-1a of its specification) u64, phase u8 (1 spin-up,
//! 2 window), steps done in the phase u64, samples u64, the class count u32,
//! Σq* of the current block and its Σq* per class (f64 bits), the finished
//! blocks (count u64, then q*, bed level and q* per class of each, f64
//! bits),
//! the profile sums (samples u64, cell count u32, then Σφ, Σφ u_p, Σu_f and
//! the Σ of the four shear stresses of each cell, f64 bits;
//! [`crate::work::profiles`]), the kernel checkpoint (u64
//! length, bytes). The CRC detects
//! damage, not deliberate edits: a loaded state is
//! checked field by field against the configuration ([`CellState::check`])
//! and the restored kernel against the cell's scenario, so an edited file is
//! refused or, if consistent, gives a cell this configuration could have
//! produced (docs/guarantees.md).

use crate::config::{canonical, Config, ConfigFile, Durations, WindowUntil};
pub use crate::io::framing::CheckpointError;
use crate::io::framing::{Reader, Writer};
use crate::science::stats::Target;
use crate::science::truncation::{Truncation, MIN_TAIL};
use crate::work::beds::BedRecord;
use crate::work::profiles::{CellProfile, ProfileSums, Stresses, PROFILE_SAMPLES};
use mbs_kernel::Fnv1a;
use serde::{Deserialize, Serialize};

const MAGIC: [u8; 4] = *b"MBSC";
const VERSION: u16 = 6;

/// One block of a cell's window (`time.block`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Block {
    /// q* averaged over the block's samples.
    pub q_star: f64,
    /// The mean bed level at the block's end (m).
    pub bed_level: f64,
    /// q* per size class averaged over the block's samples (on d_max: they
    /// add up to q*).
    pub q_star_class: Vec<f64>,
}

/// What one (τ*, seed) cell measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellResult {
    /// Shields number.
    pub tau_star: f64,
    /// Seed.
    pub seed: u64,
    /// q* averaged over the window's steady part (all classes, d = d_max):
    /// the mean of its blocks after the `discarded` ones.
    pub q_star: f64,
    /// The same per size class (on d_max: they add up to q*).
    pub q_star_class: Vec<f64>,
    /// The window's blocks, in time order: q*(t) and the bed level.
    pub blocks: Vec<Block>,
    /// Leading blocks discarded as the transient (MSER,
    /// [`crate::science::truncation`]).
    pub discarded: usize,
    /// Whether MSER found a steady part (at most half the blocks
    /// discarded); if not, q* is the mean of a series still changing.
    pub steady: bool,
    /// The window recorded, discarded blocks included (s).
    pub window_s: f64,
    /// Whether the window ended on the target standard error (else at
    /// `time.window`).
    pub target_reached: bool,
    /// Mean bed level at the end (m, relative to the fixed grains' mean).
    pub bed_level: f64,
    /// Grain-steps computed under the flow (the bed's settling not included).
    pub grain_steps: u64,
    /// The settled bed the cell started from.
    pub bed: BedRecord,
    /// Profiles over the window (absent in results of earlier versions).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile: Option<CellProfile>,
}

impl CellResult {
    /// The block means of q* of the steady part (after the discarded
    /// blocks).
    pub fn steady_means(&self) -> Vec<f64> {
        q_means(&self.blocks[self.discarded.min(self.blocks.len())..])
    }
}

/// The q* of each block.
pub fn q_means(blocks: &[Block]) -> Vec<f64> {
    blocks.iter().map(|b| b.q_star).collect()
}

/// The means over the `kept` blocks (the steady part) of q* and of each of
/// `classes` size classes' q*, as a cell's result holds them.
pub fn kept_means(kept: &[Block], classes: usize) -> (f64, Vec<f64>) {
    let mean = |value: &dyn Fn(&Block) -> f64| {
        kept.iter().map(value).sum::<f64>() / kept.len().max(1) as f64
    };
    let class = |c: usize| move |b: &Block| b.q_star_class.get(c).copied().unwrap_or(f64::NAN);
    (
        mean(&|b| b.q_star),
        (0..classes).map(|c| mean(&class(c))).collect(),
    )
}

impl CellResult {
    /// Checks a result read back from a cell store against the cell it is
    /// stored for (`tau_star`, `seed`, `classes` size classes, the window
    /// `rule`): its τ* and seed, its blocks (finite, as many classes, no
    /// more than the longest window), the transient MSER finds in them and
    /// the means of the rest (bit for bit what the cell computed), its
    /// window and bed level finite, its profiles on the column's cells.
    /// Names the first field that does not fit: such a line was not
    /// written by mbs for this cell (crafted or damaged with its checksum).
    pub fn check(
        &self,
        tau_star: f64,
        seed: u64,
        classes: usize,
        rule: &WindowRule,
    ) -> Result<(), &'static str> {
        if self.tau_star.to_bits() != tau_star.to_bits() || self.seed != seed {
            return Err("tau_star and seed");
        }
        let finite = |values: &[f64]| values.iter().all(|x| x.is_finite());
        let blocks_fit = !self.blocks.is_empty()
            && self.blocks.len() as u64 <= rule.durations.max_blocks
            && self.blocks.iter().all(|b| {
                b.q_star_class.len() == classes
                    && finite(&[b.q_star, b.bed_level])
                    && finite(&b.q_star_class)
            });
        if !blocks_fit {
            return Err("blocks");
        }
        let (truncation, _) = rule.verdict(&q_means(&self.blocks));
        if truncation.discard != self.discarded || truncation.steady != self.steady {
            return Err("discarded");
        }
        let (q_star, q_class) = kept_means(&self.blocks[truncation.discard..], classes);
        if q_star.to_bits() != self.q_star.to_bits() {
            return Err("q_star");
        }
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
        };
        if !same(&q_class, &self.q_star_class) {
            return Err("q_star_class");
        }
        if !finite(&[self.window_s, self.bed_level]) || self.window_s < 0.0 {
            return Err("window_s and bed_level");
        }
        if let Some(p) = &self.profile {
            let columns = [&p.solid_fraction, &p.grain_velocity, &p.fluid_velocity];
            let stresses = p.stresses.columns();
            // Stresses are absent (empty) in results of earlier versions.
            let old = stresses.iter().all(|c| c.is_empty());
            let on_cells = |c: &&Vec<f64>| c.len() == rule.cells && finite(c);
            if !columns.iter().all(on_cells) || !(old || stresses.iter().all(on_cells)) {
                return Err("profile");
            }
        }
        Ok(())
    }
}

/// Where a cell is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
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
    /// The finished blocks.
    pub blocks: Vec<Block>,
    /// Σ q* of the current block's samples.
    pub block_sum: f64,
    /// Σ q* per class of the current block's samples.
    pub class_sums: Vec<f64>,
    /// The profiles' sums.
    pub profile: ProfileSums,
}

/// When a cell's window ends: the durations and the target.
#[derive(Debug, Clone, Copy)]
pub struct WindowRule {
    /// Phase lengths and blocks.
    pub durations: Durations,
    /// The standard error aimed at.
    pub target: Target,
    /// Cells of the profiles ([`crate::work::profiles`]).
    pub cells: usize,
}

impl WindowRule {
    /// The rule of `config`.
    pub fn of(config: &Config) -> WindowRule {
        WindowRule {
            durations: config.durations,
            target: Target {
                relative: config.file.target.stderr_relative,
                absolute: config.file.target.stderr_absolute,
            },
            cells: crate::work::profiles::ProfileGrid::of(config).grid.cells(),
        }
    }

    /// Whether a window with these finished blocks (and no partial one)
    /// ends: at the longest window, or when MSER finds a steady part
    /// ([`Truncation`]) at least as long as the shortest window that
    /// reaches the target (`time.window_until = "target"`) or at all, in a
    /// window of at least 2 × [`MIN_TAIL`] blocks (`"steady"`). Before that
    /// the discarded blocks are the spin-up's automatic extension.
    pub fn ends(&self, blocks: &[Block]) -> bool {
        if blocks.len() as u64 >= self.durations.max_blocks {
            return true;
        }
        let q = q_means(blocks);
        let (t, reached) = self.verdict(&q);
        // "steady" alone once MSER could have discarded half the series
        // (n − MIN_TAIL ≥ n/2); before that it cannot tell a transient.
        let enough = match self.durations.window_until {
            WindowUntil::Target => reached,
            WindowUntil::Steady => t.steady && q.len() >= 2 * MIN_TAIL,
        };
        enough && (q.len() - t.discard) as u64 >= self.durations.min_blocks
    }

    /// MSER's truncation of the block means `q` and whether it found a
    /// steady part that reaches the target.
    pub fn verdict(&self, q: &[f64]) -> (Truncation, bool) {
        let t = Truncation::of(q);
        (t, t.steady && self.target.reached(t.kept(q)))
    }
}

impl CellState {
    /// Checks a loaded state against the rule of the configuration it
    /// claims to belong to, with `classes` size classes. Spin-up holds no
    /// sums; in the window, the steps, samples and blocks are exactly those
    /// of the loop in [`crate::work::job::CellJob`] (with checked arithmetic), the window has
    /// not yet ended by the rule at any block, and the sums are finite and
    /// agree with each other. Names the first field that does not fit.
    pub fn check(&self, classes: usize, rule: &WindowRule) -> Result<(), CheckpointError> {
        let bad = |what| Err(CheckpointError::Value(what));
        let d = &rule.durations;
        if self.class_sums.len() != classes
            || self.blocks.iter().any(|b| b.q_star_class.len() != classes)
        {
            return bad("size classes");
        }
        let p = &self.profile;
        let columns = p.columns();
        if columns.iter().any(|c| c.len() != rule.cells) {
            return bad("profile cells");
        }
        let profile = columns.into_iter().flatten();
        if p.samples != self.samples / PROFILE_SAMPLES || !profile.clone().all(|x| x.is_finite()) {
            return bad("profile sums");
        }
        let sums = self
            .class_sums
            .iter()
            .chain([&self.block_sum])
            .chain(profile);
        if self.phase == Phase::SpinUp {
            let empty = self.samples == 0
                && self.blocks.is_empty()
                && sums.clone().all(|x| x.to_bits() == 0);
            return match (self.done <= d.spin_up, empty) {
                (false, _) => bad("steps done in the phase"),
                (_, false) => bad("sums before the window"),
                _ => Ok(()),
            };
        }
        let finished = self.blocks.len() as u64;
        let partial = self
            .samples
            .checked_sub(finished.saturating_mul(d.block_samples))
            .filter(|&p| p < d.block_samples);
        if partial.is_none() || self.samples.checked_mul(d.sample) != Some(self.done) {
            return bad("window samples");
        }
        if (0..=self.blocks.len()).any(|k| rule.ends(&self.blocks[..k])) {
            return bad("blocks");
        }
        let values = self.blocks.iter().flat_map(|b| {
            [b.q_star, b.bed_level]
                .into_iter()
                .chain(b.q_star_class.clone())
        });
        let empty =
            self.block_sum.to_bits() == 0 && self.class_sums.iter().all(|x| x.to_bits() == 0);
        if !sums.clone().copied().chain(values).all(f64::is_finite)
            || (partial == Some(0) && !empty)
        {
            return bad("sums");
        }
        Ok(())
    }

    pub(crate) fn new(classes: usize, cells: usize) -> Self {
        CellState {
            profile: ProfileSums::new(cells),
            phase: Phase::SpinUp,
            done: 0,
            samples: 0,
            blocks: Vec::new(),
            block_sum: 0.0,
            class_sums: vec![0.0; classes],
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

/// The key of a cell: FNV-1a of its canonical specification text.
pub fn cell_key(spec_json: &str) -> u64 {
    Fnv1a::of(spec_json.as_bytes())
}

impl CellCheckpoint {
    /// Encodes the checkpoint.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::new(MAGIC, VERSION);
        w.u64(self.key);
        let s = &self.state;
        w.u8(s.phase as u8);
        w.u64(s.done);
        w.u64(s.samples);
        w.u32(s.class_sums.len() as u32);
        w.f64(s.block_sum);
        for &x in &s.class_sums {
            w.f64(x);
        }
        w.u64(s.blocks.len() as u64);
        for b in &s.blocks {
            w.f64(b.q_star);
            w.f64(b.bed_level);
            for &x in &b.q_star_class {
                w.f64(x);
            }
        }
        let p = &s.profile;
        w.u64(p.samples);
        w.u32(p.solid.len() as u32);
        for x in p.columns().into_iter().flatten() {
            w.f64(*x);
        }
        w.bytes(&self.sim);
        w.seal()
    }

    /// The length of the largest cell checkpoint with `classes` size
    /// classes, at most `blocks` blocks and a kernel checkpoint of at most
    /// `sim_max` bytes, profiles of `cells` cells.
    pub fn max_len(classes: usize, blocks: u64, cells: usize, sim_max: usize) -> usize {
        // Key, phase, done, samples, class count, the block's sums.
        let head = 8 + 1 + 8 + 8 + 4 + 8 + 8 * classes;
        let blocks = usize::try_from(blocks).unwrap_or(usize::MAX / 64);
        let block = 16 + 8 * classes;
        let profile = 8 + 4 + 8 * ProfileSums::COLUMNS * cells;
        Writer::OVERHEAD + head + 8 + block * blocks + profile + 8 + sim_max
    }

    /// Decodes and checks a checkpoint written for the cell `key`.
    pub fn decode(bytes: &[u8], key: u64) -> Result<CellCheckpoint, CheckpointError> {
        let mut r = Reader::open(bytes, MAGIC, VERSION, "cell checkpoint")?;
        if r.u64()? != key {
            return Err(CheckpointError::OtherCell);
        }
        let phase = match r.u8()? {
            1 => Phase::SpinUp,
            2 => Phase::Window,
            _ => return Err(CheckpointError::Value("phase")),
        };
        let (done, samples) = (r.u64()?, r.u64()?);
        let classes = r.u32()? as usize;
        if classes > mbs_kernel::MAX_CLASSES {
            return Err(CheckpointError::Value("size classes"));
        }
        let block_sum = r.f64()?;
        let class_sums = (0..classes).map(|_| r.f64()).collect::<Result<_, _>>()?;
        let count = r.u64()?;
        // Each block takes 16 bytes or more: a count beyond the file is
        // truncation.
        if count > (bytes.len() / 16) as u64 {
            return Err(CheckpointError::Truncated);
        }
        let blocks = (0..count)
            .map(|_| {
                Ok(Block {
                    q_star: r.f64()?,
                    bed_level: r.f64()?,
                    q_star_class: (0..classes).map(|_| r.f64()).collect::<Result<_, _>>()?,
                })
            })
            .collect::<Result<_, CheckpointError>>()?;
        let profile_samples = r.u64()?;
        let cells = r.u32()? as usize;
        // Each cell takes 8 bytes per column: a count beyond the file is
        // truncation.
        if cells > bytes.len() / (8 * ProfileSums::COLUMNS) {
            return Err(CheckpointError::Truncated);
        }
        let mut column = || (0..cells).map(|_| r.f64()).collect::<Result<Vec<_>, _>>();
        let (solid, momentum, fluid) = (column()?, column()?, column()?);
        let stresses = [column()?, column()?, column()?, column()?];
        let sim = r.bytes()?.to_vec();
        r.finish()?;
        Ok(CellCheckpoint {
            key,
            state: CellState {
                phase,
                done,
                samples,
                blocks,
                block_sum,
                class_sums,
                profile: ProfileSums {
                    samples: profile_samples,
                    solid,
                    momentum,
                    fluid,
                    stresses: Stresses::from_columns(stresses),
                },
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
    /// Checks `result`, read back from a cell store under this cell's key,
    /// against the cell ([`CellResult::check`]); a configuration that no
    /// longer validates fits no result.
    pub fn check(&self, result: &CellResult) -> Result<(), &'static str> {
        let config = Config::validate(self.config.clone()).map_err(|_| "configuration")?;
        let (Some(&tau_star), Some(&seed)) = (config.tau_stars.first(), config.seeds.first())
        else {
            return Err("configuration");
        };
        let classes = config.scenario.bed.classes.len();
        result.check(tau_star, seed, classes, &WindowRule::of(&config))
    }

    /// The cell of `config` at `tau_star` and `seed`.
    pub fn new(config: &ConfigFile, tau_star: f64, seed: u64) -> Self {
        let mut config = canonical(config);
        config.flow.tau_stars = vec![tau_star];
        config.run.seeds = vec![seed];
        TransportSpec {
            kind: "transport",
            config,
        }
    }
}

/// How a cell ended.
#[derive(Debug, Clone, PartialEq)]
pub enum CellOutcome {
    /// Finished (boxed: a result with its profiles is large), with the
    /// grain-steps this invocation computed (less than the result's
    /// `grain_steps` for a cell resumed from its checkpoint, 0 if reused).
    Done(Box<CellResult>, u64),
    /// Stopped after writing its checkpoint.
    Stopped,
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
                blocks: vec![
                    Block {
                        q_star: 0.1,
                        bed_level: 1e-3,
                        q_star_class: vec![0.06, 0.04],
                    };
                    3
                ],
                block_sum: 0.2,
                class_sums: vec![0.5, 0.25],
                profile: ProfileSums {
                    samples: 12,
                    solid: vec![0.5, 0.25, 0.0, 0.0],
                    momentum: vec![1e-3, 2e-3, 0.0, 0.0],
                    fluid: vec![0.0, 0.1, 0.2, 0.3],
                    stresses: Stresses::from_columns([
                        vec![0.5, 0.25, 0.0, 0.0],
                        vec![0.1, 0.0, 0.0, 0.0],
                        vec![0.0, 1e-3, 1e-3, 1e-4],
                        vec![0.0, 0.2, 0.1, 0.0],
                    ]),
                },
            },
            sim: vec![1, 2, 3, 4, 5],
        };
        let bytes = ck.encode();
        assert_eq!(bytes.len(), CellCheckpoint::max_len(2, 3, 4, 5));
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
            Err(CheckpointError::Version {
                found: 9,
                reads: VERSION
            })
        );
        assert_eq!(
            CellCheckpoint::decode(b"nope", 42),
            Err(CheckpointError::Magic("cell checkpoint"))
        );
    }

    #[test]
    fn a_steady_window_ends_at_its_shortest_a_target_window_when_precise() {
        let rule = |until| WindowRule {
            durations: Durations {
                settle_until: crate::config::SettleUntil::Rest,
                settle: 0,
                spin_up: 0,
                sample: 1,
                block_samples: 1,
                min_blocks: 5,
                max_blocks: 40,
                window_until: until,
            },
            target: Target {
                relative: 1e-3,
                absolute: 0.0,
            },
            cells: 1,
        };
        let blocks = |q: &[f64]| -> Vec<Block> {
            q.iter()
                .map(|&q_star| Block {
                    q_star,
                    bed_level: 0.0,
                    q_star_class: vec![q_star],
                })
                .collect()
        };
        // A transient of three blocks, then noise of 10 % about 1: steady
        // from the first window MSER can judge (ten blocks), far from a 0.1 %
        // error.
        let mut q = vec![5.0, 3.0, 2.0];
        let mut state = 3u64;
        q.extend((0..37).map(|_| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            1.0 + 0.2 * ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
        }));
        let (steady, target) = (rule(WindowUntil::Steady), rule(WindowUntil::Target));
        let first = |r: &WindowRule| (1..=q.len()).find(|&n| r.ends(&blocks(&q[..n])));
        assert_eq!(first(&steady), Some(10));
        assert_eq!(first(&target), Some(40), "the cap");
        // Precise enough for the target too: both end once steady.
        let quiet: Vec<f64> = q
            .iter()
            .map(|&x| if x < 1.5 { 1.0 + (x - 1.0) * 1e-3 } else { x })
            .collect();
        let first = |r: &WindowRule| (1..=quiet.len()).find(|&n| r.ends(&blocks(&quiet[..n])));
        assert_eq!(first(&steady), Some(10));
        assert!(first(&target).is_some_and(|n| (10..40).contains(&n)));
    }
}
