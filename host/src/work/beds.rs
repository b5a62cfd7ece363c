//! The settled bed of a (configuration, seed) (docs/model.md §7 step 3):
//! built and settled without flow once, until at rest or for a fixed time
//! (`time.settle_until`), kept as a file, and restored by every τ* of the
//! seed. Settling is resumable like a cell: between windows it can write its
//! progress (steps, the rest criterion's state, the kernel's checkpoint) and
//! stop; continuing gives the same bed bit for bit.
//!
//! A settled bed is kept in `DIR/beds/<key>.bed`, a settling bed's
//! checkpoint in `DIR/checkpoints/bed_<key>.ckpt`, both in one format
//! (version 1, framed by
//! [`crate::io::framing`]): magic `MBSB`, the bed's key (FNV-1a of its
//! specification) u64, status u8 (0 settling, 1 at rest, 2 settled for
//! the whole `time.settle` without rest), steps u64, the rest criterion's
//! y_gc (f64 bits) and checks passed u32, the last check's speed and drift
//! (f64 bits), the largest overlap (f64 bits), the kernel checkpoint.

use crate::config::{Config, ConfigFile, SettleUntil};
use crate::error::HostError;
use crate::io::framing::{CheckpointError, Reader, Writer};
use crate::io::input::{read_own_bounded, Bound};
use crate::io::output::{remove_if_present, write_atomic};
use crate::sim::control::{Checkpoints, Control};
use crate::sim::sims::{check_restored, max_checkpoint_len, with_sim, HostSim, SimJob};
use indicatif::ProgressBar;
use mbs_kernel::{Fnv1a, Real, Rest, RestWatch, G};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

const MAGIC: [u8; 4] = *b"MBSB";
const VERSION: u16 = 1;

/// Steps run between checks for stopping and checkpointing.
const CHUNK: u64 = crate::sim::control::MIN_CHECKPOINT_STEPS;

/// What determines a settled bed: the configuration without what only
/// matters under the flow (τ*, spin-up, window, sampling), and the seed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BedKey {
    /// Kind tag.
    pub kind: &'static str,
    /// The configuration, with the flow-only keys fixed and `run.seeds = [seed]`.
    pub config: ConfigFile,
}

impl BedKey {
    /// The bed of `config` with `seed`.
    pub fn new(config: &ConfigFile, seed: u64) -> BedKey {
        let mut config = crate::config::canonical(config);
        config.flow.tau_stars = Vec::new();
        // Beds settle without flow: clear water and the coupled flow share them.
        config.flow.model = Default::default();
        config.fluid = Default::default();
        config.time.spin_up = 0.0;
        config.time.window = 0.0;
        config.time.sample_steps = 0;
        config.run.seeds = vec![seed];
        BedKey {
            kind: "bed",
            config,
        }
    }

    /// FNV-1a of the canonical JSON: the file's key and name.
    pub fn hash(&self) -> u64 {
        Fnv1a::of(serde_json::to_string(self).unwrap_or_default().as_bytes())
    }
}

/// How settling ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BedStatus {
    /// Still settling (only in a checkpoint).
    Settling = 0,
    /// At rest.
    AtRest = 1,
    /// Settled for the whole `time.settle` without coming to rest.
    NotAtRest = 2,
}

/// A bed's settling: finished or in progress.
#[derive(Debug, Clone, PartialEq)]
pub struct BedState {
    /// The bed's key.
    pub key: u64,
    /// How it stands.
    pub status: BedStatus,
    /// Integration steps of settling so far.
    pub steps: u64,
    /// The rest criterion's state.
    pub watch: RestWatch,
    /// The last check's largest mobile speed (m/s).
    pub speed: f64,
    /// The last check's drift of y_gc over a window (m).
    pub drift: f64,
    /// The largest overlap at the end (m; 0 while settling).
    pub max_overlap: f64,
    /// The kernel checkpoint.
    pub sim: Vec<u8>,
}

impl BedState {
    /// Encodes the file.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::new(MAGIC, VERSION);
        w.u64(self.key);
        w.u8(self.status as u8);
        w.u64(self.steps);
        w.f64(self.watch.y_gc);
        w.u32(self.watch.passed);
        w.f64(self.speed);
        w.f64(self.drift);
        w.f64(self.max_overlap);
        w.bytes(&self.sim);
        w.seal()
    }

    /// The length of the largest file with a kernel checkpoint of at most
    /// `sim_max` bytes.
    pub fn max_len(sim_max: usize) -> usize {
        Writer::OVERHEAD + 8 + 1 + 8 + 8 + 4 + 8 + 8 + 8 + 8 + sim_max
    }

    /// Decodes a file written for the bed `key`; the numbers are checked
    /// to be finite and non-negative, the kernel state by its user.
    pub fn decode(bytes: &[u8], key: u64) -> Result<BedState, CheckpointError> {
        let mut r = Reader::open(bytes, MAGIC, VERSION, "settled-bed file")?;
        if r.u64()? != key {
            return Err(CheckpointError::OtherCell);
        }
        let status = match r.u8()? {
            0 => BedStatus::Settling,
            1 => BedStatus::AtRest,
            2 => BedStatus::NotAtRest,
            _ => return Err(CheckpointError::Value("status")),
        };
        let steps = r.u64()?;
        let watch = RestWatch {
            y_gc: r.f64()?,
            passed: r.u32()?,
        };
        let (speed, drift, max_overlap) = (r.f64()?, r.f64()?, r.f64()?);
        if !watch.y_gc.is_finite() {
            return Err(CheckpointError::Value("y_gc"));
        }
        if ![speed, drift, max_overlap]
            .iter()
            .all(|x| x.is_finite() && *x >= 0.0)
        {
            return Err(CheckpointError::Value("speed, drift or overlap"));
        }
        let sim = r.bytes()?.to_vec();
        r.finish()?;
        Ok(BedState {
            key,
            status,
            steps,
            watch,
            speed,
            drift,
            max_overlap,
            sim,
        })
    }

    /// The settling time (s) at integration steps of `step_dt`.
    pub fn seconds(&self, step_dt: f64) -> f64 {
        self.steps as f64 * step_dt
    }
}

/// What a cell records of its bed (in `summary.json`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BedRecord {
    /// How settling ended.
    pub status: BedStatus,
    /// Settling time (s).
    pub settle_s: f64,
    /// Largest overlap at the end, in diameters d_max.
    pub max_overlap_d: f64,
}

/// A bed to settle, possibly from a checkpoint.
pub struct BedJob<'a> {
    /// Configuration.
    pub config: &'a Config,
    /// Seed.
    pub seed: u64,
    /// The bed's key.
    pub key: u64,
    /// Where to continue from.
    pub resume: Option<BedState>,
    /// Stopping and checkpointing.
    pub control: &'a Control<'a>,
    /// Progress (steps).
    pub progress: &'a ProgressBar,
}

impl SimJob for BedJob<'_> {
    type Output = Result<(Option<BedState>, u64), HostError>;

    /// Settles in chunks, checking the rest criterion at the end of each
    /// of its windows (docs/model.md §7 step 3):
    /// the bed (`None` if stopped after writing its checkpoint) and the
    /// grain-steps computed.
    fn run<R: Real, const N: usize>(self, sim: &mut HostSim<R, N>) -> Self::Output {
        let sc = self.config.scenario_at(self.seed);
        let fail = || HostError::kernel(format!("settling the bed of seed {}", self.seed));
        let refuse = |message: String| HostError::Checkpoint {
            path: self.control.path.clone().unwrap_or_default(),
            message,
        };
        let durations = self.config.durations;
        let mut state = match self.resume {
            Some(state) => {
                if state.status != BedStatus::Settling || state.steps > durations.settle {
                    return Err(refuse(
                        "its progress does not fit this configuration".into(),
                    ));
                }
                sim.restore(&state.sim).map_err(fail())?;
                check_restored(sim, &sc, None, state.steps)
                    .map_err(|why| refuse(format!("{why}: it is not this seed's bed")))?;
                BedState {
                    sim: Vec::new(),
                    ..state
                }
            }
            None => {
                sc.build(sim).map_err(fail())?;
                BedState {
                    key: self.key,
                    status: BedStatus::Settling,
                    steps: 0,
                    watch: RestWatch::start(sim),
                    speed: sim.max_speed(),
                    drift: 0.0,
                    max_overlap: 0.0,
                    sim: Vec::new(),
                }
            }
        };
        let rest = Rest::for_bed(sc.bed.max_diameter(), sc.material.s, G, sc.step_dt());
        let mut checkpoints = Checkpoints::new(self.control);
        let mut stepped = 0u64;
        while state.steps < durations.settle {
            let stop = checkpoints.due(stepped, || {
                let mut s = state.clone();
                sim.checkpoint(|b| s.sim.extend_from_slice(b));
                s.encode()
            })?;
            if stop {
                return Ok((None, stepped * sim.len() as u64));
            }
            // Chunks end at every window's end, where the criterion is checked.
            let to_check = rest.window - state.steps % rest.window;
            let n = (durations.settle - state.steps).min(to_check).min(CHUNK);
            sim.run(n).map_err(fail())?;
            state.steps += n;
            stepped += n;
            self.progress.inc(n);
            if n == to_check {
                let check = state.watch.check(sim, &rest);
                (state.speed, state.drift) = (check.speed, check.drift);
                if check.at_rest && durations.settle_until == SettleUntil::Rest {
                    break;
                }
            } else if state.steps == durations.settle {
                // Ended within a window: the speed now, no drift of a whole window.
                state.speed = sim.max_speed();
            }
        }
        state.status = if state.watch.passed >= rest.checks {
            BedStatus::AtRest
        } else {
            BedStatus::NotAtRest
        };
        state.max_overlap = sim.observe().max_overlap;
        sim.checkpoint(|b| state.sim.extend_from_slice(b));
        Ok((Some(state), stepped * sim.len() as u64))
    }
}

/// The file of the bed `key` in `dir`.
pub fn bed_path(dir: &Path, key: u64) -> PathBuf {
    dir.join(format!("{key:016x}.bed"))
}

/// The settled beds of a directory: each read from its file if finished,
/// else settled (from its checkpoint if any) and written.
pub struct Beds<'a> {
    /// Where the settled beds' files are.
    pub dir: PathBuf,
    /// Where a settling bed's checkpoint is (`bed_<key>.ckpt`).
    pub checkpoints: PathBuf,
    /// Wall-clock interval between checkpoints of a settling bed.
    pub every: Option<Duration>,
    /// Set by Ctrl-C: settling beds checkpoint and stop.
    pub stop: &'a AtomicBool,
    /// Stop settling beds after this many steps (tests of resuming).
    pub stop_after: Option<u64>,
}

/// A settled bed and how it was obtained.
pub struct Obtained {
    /// The bed (status [`BedStatus::AtRest`] or [`BedStatus::NotAtRest`]),
    /// `None` if it stopped with a checkpoint.
    pub bed: Option<BedState>,
    /// Continued from a checkpoint.
    pub resumed: bool,
    /// Settled in this call (not read from a finished file).
    pub computed: bool,
    /// Grain-steps computed in this call.
    pub grain_steps: u64,
}

impl Beds<'_> {
    /// The settled bed of `config` with `seed`: read, or settled and written.
    pub fn obtain(
        &self,
        config: &Config,
        seed: u64,
        progress: &ProgressBar,
    ) -> Result<Obtained, HostError> {
        let key = BedKey::new(&config.file, seed).hash();
        let bound = Bound {
            bytes: BedState::max_len(max_checkpoint_len(config.precision, config.capacity)) as u64,
            reason: "the largest settled-bed file of this configuration",
        };
        let read = |path: &Path| -> Result<Option<BedState>, HostError> {
            let refuse = |message: String| HostError::Checkpoint {
                path: path.to_path_buf(),
                message,
            };
            match read_own_bounded(path, bound) {
                Ok(bytes) => Ok(Some(
                    BedState::decode(&bytes, key).map_err(|e| refuse(e.to_string()))?,
                )),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
                Err(e) if e.kind() == std::io::ErrorKind::InvalidData => Err(refuse(e.to_string())),
                Err(e) => Err(HostError::io(path)(e)),
            }
        };
        let finished = bed_path(&self.dir, key);
        if let Some(bed) = read(&finished)? {
            if bed.status == BedStatus::Settling {
                return Err(HostError::Checkpoint {
                    path: finished,
                    message: "a bed still settling where a settled one belongs".into(),
                });
            }
            // Settling stops at time.settle at the latest.
            if bed.steps > config.durations.settle {
                return Err(HostError::Checkpoint {
                    path: finished,
                    message: format!(
                        "a bed settled for {} integration steps, more than time.settle's {}",
                        bed.steps, config.durations.settle
                    ),
                });
            }
            return Ok(Obtained {
                bed: Some(bed),
                resumed: false,
                computed: false,
                grain_steps: 0,
            });
        }
        let checkpoint = self.checkpoints.join(format!("bed_{key:016x}.ckpt"));
        let found = read(&checkpoint)?;
        let resumed = found.is_some();
        let control = Control {
            path: Some(checkpoint.clone()),
            every: self.every,
            stop: self.stop,
            stop_after: self.stop_after,
        };
        let job = BedJob {
            config,
            seed,
            key,
            resume: found,
            control: &control,
            progress,
        };
        let (bed, grain_steps) = with_sim(config.precision, config.capacity, job)?;
        if let Some(bed) = &bed {
            write_atomic(&finished, &bed.encode())?;
            remove_if_present(&checkpoint)?;
        }
        Ok(Obtained {
            bed,
            resumed,
            computed: true,
            grain_steps,
        })
    }
}

/// The warnings of a settled bed of `seed` (docs/model.md §7 step 3): not
/// at rest, or grains overlapping by more than [`OVERLAP_WARNING_D`] d_max.
pub fn bed_warnings(config: &Config, seed: u64, bed: &BedState) -> Vec<String> {
    let sc = &config.scenario;
    let (d, step_dt) = (sc.bed.max_diameter(), sc.step_dt());
    let rest = Rest::for_bed(d, sc.material.s, G, step_dt);
    let mut out = Vec::new();
    if bed.status == BedStatus::NotAtRest {
        out.push(format!(
            "bed-not-at-rest: the bed of seed {seed} is not at rest after {:.3} s of settling \
             (time.settle): largest grain speed {:.2e} m/s (rest: < {:.2e}), centre of gravity \
             moved {:.2e} m in the last 0.05 s (rest: < {:.2e}); raise time.settle",
            bed.seconds(step_dt),
            bed.speed,
            rest.speed,
            bed.drift,
            rest.drift
        ));
    }
    let overlap = bed.max_overlap / d;
    if overlap > OVERLAP_WARNING_D {
        out.push(format!(
            "bed-overlap: in the settled bed of seed {seed} two grains overlap by {:.0} % of d \
             (more than {:.0} %): the contact springs are soft (alpha_m beta = {}); grains \
             interpenetrate and the bed is compressed",
            overlap * 100.0,
            OVERLAP_WARNING_D * 100.0,
            sc.rule.alpha_m * sc.rule.beta
        ));
    }
    out
}

/// The largest overlap of a settled bed, in diameters, above which it is
/// reported: soft springs beyond it compress the bed by a sizeable part of
/// a grain.
pub const OVERLAP_WARNING_D: f64 = 0.1;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_round_trip_and_damage_is_named() {
        let bed = BedState {
            key: 9,
            status: BedStatus::AtRest,
            steps: 1234,
            watch: RestWatch {
                y_gc: 1e-3,
                passed: 4,
            },
            speed: 1e-4,
            drift: 1e-7,
            max_overlap: 5e-5,
            sim: vec![7; 11],
        };
        let bytes = bed.encode();
        assert_eq!(bytes.len(), BedState::max_len(11));
        assert_eq!(BedState::decode(&bytes, 9), Ok(bed.clone()));
        assert_eq!(BedState::decode(&bytes, 8), Err(CheckpointError::OtherCell));
        for len in 0..bytes.len() {
            assert!(BedState::decode(&bytes[..len], 9).is_err(), "length {len}");
        }
        let mut bad = bytes.clone();
        bad[20] ^= 1;
        assert_eq!(BedState::decode(&bad, 9), Err(CheckpointError::Checksum));
        let mut nan = bed;
        nan.speed = f64::NAN;
        assert_eq!(
            BedState::decode(&nan.encode(), 9),
            Err(CheckpointError::Value("speed, drift or overlap"))
        );
    }
}
