//! Cells: the independent simulations a calibration is made of, each a pure
//! function of its specification. A cell is looked up in the [`Store`] first;
//! otherwise it is computed (in parallel with the other cells of the same
//! request) if this shard owns it, and stored as soon as it finishes.

use crate::config::canonical;
use crate::config::{Config, ConfigFile};
use crate::error::HostError;
use crate::io::log::Log;
use crate::tools::pack::{packing, Packing};
use crate::work::beds::{BedKey, BedState, Beds};
use crate::work::cell::CellResult;
pub use crate::work::cell::TransportSpec;
use crate::work::job::run_cell;
use crate::work::store::{Store, STORE};
use indicatif::ProgressBar;
use rayon::prelude::*;
use serde::{de::DeserializeOwned, Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

pub use crate::work::shard::Shard;

/// A packing cell: the bed of `config` settling for `duration`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PackSpec {
    /// Kind tag.
    pub kind: &'static str,
    /// The configuration, with `run.seeds = [seed]`.
    pub config: ConfigFile,
    /// Duration (s).
    pub duration: f64,
}

impl PackSpec {
    /// The packing cell of `config` with `seed` for `duration` seconds.
    pub fn new(config: &ConfigFile, seed: u64, duration: f64) -> Self {
        let mut config = canonical(config);
        config.run.seeds = vec![seed];
        PackSpec {
            kind: "pack",
            config,
            duration,
        }
    }
}

/// The settling curve of a packing cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PackCurve {
    /// Sample times (s).
    pub time: Vec<f64>,
    /// y_gc at those times (m).
    pub y_gc: Vec<f64>,
    /// Largest mobile-grain speed at the end (m/s).
    pub final_speed: f64,
}

/// A cell's outcome: a kernel failure (e.g. grains leaving a fluidised bed)
/// is a result too, stored with its message.
pub type Outcome<T> = Result<T, String>;

/// A result read back from the store, checked against the cell `S` it is
/// stored for: `Err(field)` names what does not fit (the cell is then
/// computed again).
pub trait Fits<S> {
    /// Whether this result fits the cell `spec`.
    fn fits(&self, spec: &S) -> Result<(), &'static str>;
}

impl Fits<TransportSpec> for CellResult {
    fn fits(&self, spec: &TransportSpec) -> Result<(), &'static str> {
        spec.check(self)
    }
}

impl Fits<PackSpec> for PackCurve {
    /// A curve is drawn as it is, so only its shape is checked: as many
    /// times as heights, all finite.
    fn fits(&self, _: &PackSpec) -> Result<(), &'static str> {
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        let ok = self.time.len() == self.y_gc.len()
            && finite(&self.time)
            && finite(&self.y_gc)
            && self.final_speed.is_finite();
        ok.then_some(()).ok_or("packing curve")
    }
}

/// Computes and stores cells.
pub struct Cells<'a> {
    /// The store.
    pub store: &'a Store,
    /// This machine's slice of each stage.
    pub shard: Shard,
    /// Progress (cells).
    pub progress: &'a ProgressBar,
    /// Where the settled beds are kept.
    pub beds: PathBuf,
    /// Each computed transport cell's end is logged here.
    pub log: &'a Log,
}

/// A calibration's beds are never stopped (its cells are not checkpointed).
static NEVER: AtomicBool = AtomicBool::new(false);

impl Cells<'_> {
    /// The stored outcome of the cell `spec`, if any. A stored result that
    /// does not fit the cell ([`Fits`]) is none (the cell is computed
    /// again), with a warning if `warn`.
    fn stored<S: Serialize, T: DeserializeOwned + Fits<S>>(
        &self,
        spec: &S,
        warn: bool,
    ) -> Option<Outcome<T>> {
        let done = self.store.get::<S, Outcome<T>>(spec)?;
        if let Ok(result) = &done
            && let Err(field) = result.fits(spec)
        {
            if warn {
                self.log.warn(&format!(
                    "{STORE}: a stored cell is refused (its {field} does not fit the cell): \
                     computed again"
                ));
            }
            return None;
        }
        Some(done)
    }

    /// Results of `specs`: stored ones, computed ones, and `None` for cells
    /// another shard owns that are not in the store yet. `slot(k)` numbers
    /// the k-th spec within its stage for sharding.
    fn evaluate<S, T>(
        &self,
        specs: &[S],
        slot: &(dyn Fn(usize) -> usize + Sync),
        compute: impl Fn(&S) -> Result<Outcome<T>, HostError> + Sync,
    ) -> Result<Vec<Option<Outcome<T>>>, HostError>
    where
        S: Serialize + Sync,
        T: Serialize + DeserializeOwned + Send + Fits<S>,
    {
        let results: Vec<Result<Option<Outcome<T>>, HostError>> = specs
            .par_iter()
            .enumerate()
            .map(|(k, spec)| {
                if let Some(done) = self.stored(spec, true) {
                    return Ok(Some(done));
                }
                if !self.shard.owns(slot(k)) {
                    return Ok(None);
                }
                let outcome = compute(spec)?;
                self.store.put(spec, &outcome)?;
                self.progress.inc(1);
                Ok(Some(outcome))
            })
            .collect();
        results.into_iter().collect()
    }

    /// Transport cells. The settled bed of every (configuration, seed) of
    /// a cell still to compute is settled first, once, in parallel; a bed
    /// that fails (e.g. grains leaving a fluidised bed) fails its cells.
    pub fn transport(
        &self,
        specs: &[TransportSpec],
        slot: &(dyn Fn(usize) -> usize + Sync),
    ) -> Result<Vec<Option<Outcome<CellResult>>>, HostError> {
        let mut needed: BTreeMap<u64, Config> = BTreeMap::new();
        for (k, spec) in specs.iter().enumerate() {
            if !self.shard.owns(slot(k)) || self.stored::<_, CellResult>(spec, false).is_some() {
                continue;
            }
            if let Ok(config) = Config::validate(spec.config.clone()) {
                needed
                    .entry(BedKey::new(&config.file, config.seeds[0]).hash())
                    .or_insert(config);
            }
        }
        let beds = Beds {
            dir: self.beds.clone(),
            checkpoints: self.beds.clone(),
            every: None,
            stop: &NEVER,
            stop_after: None,
        };
        crate::io::output::create_dir(&beds.dir)?;
        let settled: Vec<Result<Outcome<BedState>, HostError>> = needed
            .par_iter()
            .map(
                |(_, config)| match beds.obtain(config, config.seeds[0], &ProgressBar::hidden()) {
                    Ok(o) => Ok(o.bed.ok_or_else(|| "settling stopped".to_string())),
                    Err(HostError::Kernel { context, error }) => {
                        Ok(Err(format!("{context}: {error}")))
                    }
                    Err(e) => Err(e),
                },
            )
            .collect();
        let settled: BTreeMap<u64, Outcome<BedState>> = needed
            .keys()
            .copied()
            .zip(settled)
            .map(|(k, b)| b.map(|b| (k, b)))
            .collect::<Result<_, _>>()?;
        self.evaluate(specs, slot, |spec| {
            let config = match Config::validate(spec.config.clone()) {
                Ok(c) => c,
                Err(e) => return Ok(Err(format!("configuration: {e}"))),
            };
            let (tau, seed) = (config.tau_stars[0], config.seeds[0]);
            let bed = match settled.get(&BedKey::new(&config.file, seed).hash()) {
                Some(Ok(bed)) => bed,
                Some(Err(e)) => return Ok(Err(e.clone())),
                None => return Ok(Err(format!("no settled bed of seed {seed}"))),
            };
            let clock = std::time::Instant::now();
            let cell = format!("tau* {tau} seed {seed} beta {}", config.scenario.rule.beta);
            match run_cell(&config, tau, seed, bed, &ProgressBar::hidden()) {
                Ok(r) => {
                    self.log.event(&format!(
                        "cell end  {cell}  q* {}  wall {:.3} s",
                        r.q_star,
                        clock.elapsed().as_secs_f64()
                    ));
                    Ok(Ok(r))
                }
                Err(HostError::Kernel { context, error }) => {
                    let message = format!("{context}: {error}");
                    self.log.event(&format!("cell failed  {cell}: {message}"));
                    Ok(Err(message))
                }
                Err(e) => Err(e),
            }
        })
    }

    /// Packing cells, sampled every 50 steps of constants_dt (1 ms at the
    /// paper's constants_dt).
    pub fn packing(
        &self,
        specs: &[PackSpec],
        slot: &(dyn Fn(usize) -> usize + Sync),
    ) -> Result<Vec<Option<Outcome<PackCurve>>>, HostError> {
        self.evaluate(specs, slot, |spec| {
            let config = match Config::validate(spec.config.clone()) {
                Ok(c) => c,
                Err(e) => return Ok(Err(format!("configuration: {e}"))),
            };
            let every = u64::from(config.scenario.substeps) * 50;
            let run = packing(Packing {
                config: &config,
                seed: config.seeds[0],
                steps: config.steps_of(spec.duration),
                every,
                progress: &ProgressBar::hidden(),
            });
            match run {
                Ok(samples) => Ok(Ok(PackCurve {
                    time: samples.iter().map(|s| s.time).collect(),
                    y_gc: samples.iter().map(|s| s.y_gc).collect(),
                    final_speed: samples.last().map_or(0.0, |s| s.max_speed),
                })),
                Err(HostError::Kernel { context, error }) => Ok(Err(format!("{context}: {error}"))),
                Err(e) => Err(e),
            }
        })
    }
}
