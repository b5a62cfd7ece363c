//! The transport-rate experiment (docs/model.md §8, §9 step 3): the bed
//! of every seed is built and settled once ([`crate::work::beds`]); every
//! (τ*, seed) cell restores its seed's bed, switches the flow on, spins up
//! and averages q* over a window. Beds, then cells, run in parallel
//! (rayon); each is computed alone from its own seed and the results are
//! combined in a fixed order, so the output does not depend on the number
//! of threads.

use crate::config::Config;
use crate::error::HostError;
use crate::io::input::{read_own_bounded, Bound};
use crate::io::log::Log;
use crate::io::output::{create_dir, remove_if_present, remove_temporaries};
use crate::io::text::number;
use crate::science::interval::{mean_stderr, Interval};
use crate::science::references::Reference;
use crate::science::stats::Steadiness;
use crate::sim::control::Control;
use crate::sim::sims::{compiled_capacity, max_checkpoint_len};
use crate::work::beds::{bed_warnings, BedState, Beds};
use crate::work::cell::{cell_key, CellCheckpoint, CellOutcome, CellResult, TransportSpec};
use crate::work::job::{run_cell_job, CellJob, FramePlan};
use crate::work::shard::Shard;
use crate::work::store::{Store, STORE};
use indicatif::ProgressBar;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// Where `run_all` keeps finished cells and checkpoints, and when it stops.
pub struct RunControl<'a> {
    /// Output directory: `cells.jsonl` and `checkpoints/` live here.
    pub dir: &'a Path,
    /// Wall-clock interval between checkpoints of a running cell.
    pub every: Option<Duration>,
    /// Set by Ctrl-C: running cells checkpoint and stop.
    pub stop: &'a AtomicBool,
    /// Stop every running cell after this many steps (tests of resuming).
    pub stop_after: Option<u64>,
    /// The slice of the cells to compute ([`Shard::ALL`] for every cell).
    pub shard: Shard,
    /// Each cell's start and end are logged here.
    pub log: &'a Log,
    /// Integration steps between particle frames of each computed cell
    /// (`--dump-every`, in [`frames_dir`]); none without.
    pub dump_every: Option<u64>,
}

/// What `run_all` did.
#[derive(Debug, Clone, PartialEq)]
pub struct RunOutcome {
    /// Cell results in τ*-major, seed-minor order (complete runs only).
    pub results: Vec<CellResult>,
    /// Cells taken from the store.
    pub reused: usize,
    /// Cells continued from a checkpoint.
    pub resumed: usize,
    /// Beds settled in this invocation (not read from their files).
    pub beds_settled: usize,
    /// Beds continued from a checkpoint.
    pub beds_resumed: usize,
    /// Grain-steps of the beds settled in this invocation.
    pub bed_grain_steps: u64,
    /// Grain-steps of the cells computed (not reused) by this call.
    pub computed_grain_steps: u64,
}

/// The checkpoint file of a cell: `tau<τ*>_seed<seed>.ckpt`, τ* as
/// [`number`] writes it (`tau0.1_seed1.ckpt`; `tau1e-300_seed1.ckpt` for a
/// τ* whose decimal form would not fit a file name).
pub fn checkpoint_path(dir: &Path, tau_star: f64, seed: u64) -> PathBuf {
    dir.join("checkpoints")
        .join(format!("tau{}_seed{seed}.ckpt", number(tau_star)))
}

/// The particle frames' directory of a cell (`--dump-every`):
/// `frames/tau<τ*>_seed<seed>/`, τ* as in [`checkpoint_path`].
pub fn frames_dir(dir: &Path, tau_star: f64, seed: u64) -> PathBuf {
    dir.join("frames")
        .join(format!("tau{}_seed{seed}", number(tau_star)))
}

/// Settles the bed of every seed whose cells are still to compute, then
/// runs every (τ*, seed) cell, each in parallel on the current rayon pool:
/// cells already in `DIR/cells.jsonl` are reused, beds already in
/// `DIR/beds/` are read, beds and cells with a checkpoint continue from it,
/// every finished cell is stored at once. Errors: the first failing bed or
/// cell in (seed, τ*) order; [`HostError::Interrupted`] if any stopped.
pub fn run_all(
    config: &Config,
    progress: &ProgressBar,
    control: &RunControl<'_>,
) -> Result<RunOutcome, HostError> {
    create_dir(&control.dir.join("checkpoints"))?;
    remove_temporaries(control.dir)?;
    remove_temporaries(&control.dir.join("checkpoints"))?;
    let store = Store::open(&control.dir.join(STORE))?;
    let max_len = CellCheckpoint::max_len(
        config.scenario.bed.classes.len(),
        config.durations.max_blocks,
        crate::work::profiles::ProfileGrid::of(config).grid.cells(),
        max_checkpoint_len(config.precision, config.capacity),
    );
    let reason = format!(
        "the largest cell checkpoint of this configuration ({} grains, {:?})",
        compiled_capacity(config.capacity),
        config.precision
    );
    let checkpoint_bound = Bound {
        bytes: max_len as u64,
        reason: &reason,
    };
    // Cell k (τ* major, seeds minor) belongs to slice k mod N.
    let cells: Vec<(f64, u64)> = config
        .tau_stars
        .iter()
        .flat_map(|&t| config.seeds.iter().map(move |&s| (t, s)))
        .enumerate()
        .filter(|&(k, _)| control.shard.owns(k))
        .map(|(_, cell)| cell)
        .collect();
    let todo = |&(t, s): &(f64, u64)| {
        !matches!(
            stored(&store, &TransportSpec::new(&config.file, t, s)),
            Ok(Some(_))
        )
    };
    let mut seeds: Vec<u64> = cells.iter().filter(|c| todo(c)).map(|c| c.1).collect();
    seeds.sort_unstable();
    seeds.dedup();
    let beds = Beds {
        dir: control.dir.join("beds"),
        checkpoints: control.dir.join("checkpoints"),
        every: control.every,
        stop: control.stop,
        stop_after: control.stop_after,
    };
    create_dir(&beds.dir)?;
    remove_temporaries(&beds.dir)?;
    let obtained: Vec<_> = seeds
        .par_iter()
        .map(|&seed| beds.obtain(config, seed, progress))
        .collect();
    let mut settled: BTreeMap<u64, BedState> = BTreeMap::new();
    let (mut beds_stopped, mut beds_settled, mut beds_resumed, mut bed_grain_steps) = (0, 0, 0, 0);
    for (&seed, o) in seeds.iter().zip(obtained) {
        let o = o?;
        beds_resumed += usize::from(o.resumed);
        beds_settled += usize::from(o.computed);
        bed_grain_steps += o.grain_steps;
        match o.bed {
            Some(bed) => {
                control.log.event(&format!(
                    "bed  seed {seed}  {:?} after {:.3} s of settling{}",
                    bed.status,
                    bed.seconds(config.scenario.step_dt()),
                    if o.computed {
                        ""
                    } else {
                        " (read from its file)"
                    }
                ));
                for w in bed_warnings(config, seed, &bed) {
                    control.log.warn(&w);
                }
                settled.insert(seed, bed);
            }
            None => beds_stopped += 1,
        }
    }
    if beds_stopped > 0 {
        return Err(HostError::Interrupted { jobs: beds_stopped });
    }
    let cell_threads = threads_per_cell(config.file.run.threads_per_cell, cells.len());
    let finished = AtomicUsize::new(0);
    let count = |progress: &ProgressBar| {
        let k = finished.fetch_add(1, Ordering::Relaxed) + 1;
        progress.set_message(format!("cells {k}/{}", cells.len()));
    };
    progress.set_message(format!("cells 0/{}", cells.len()));
    let log = control.log;
    let outcomes: Vec<Result<(CellOutcome, u8), HostError>> = cells
        .par_iter()
        .map(|&(tau_star, seed)| {
            let spec = TransportSpec::new(&config.file, tau_star, seed);
            let path = checkpoint_path(control.dir, tau_star, seed);
            let reuse = stored(&store, &spec).unwrap_or_else(|field| {
                log.warn(&format!(
                    "{STORE}: the stored result of tau* {tau_star} seed {seed} is refused (its \
                     {field} does not fit the cell): computed again"
                ));
                None
            });
            if let Some(done) = reuse {
                // A checkpoint left by a crash between storing and removing it.
                remove_if_present(&path)?;
                progress.inc(config.durations.cell());
                log.event(&format!(
                    "cell reused  tau* {tau_star} seed {seed}  q* {}",
                    done.q_star
                ));
                count(progress);
                return Ok((CellOutcome::Done(Box::new(done), 0), 1));
            }
            let key = cell_key(&serde_json::to_string(&spec).unwrap_or_default());
            let refuse = |message: String| HostError::Checkpoint {
                path: path.clone(),
                message,
            };
            let resume = match read_own_bounded(&path, checkpoint_bound) {
                Ok(bytes) => {
                    Some(CellCheckpoint::decode(&bytes, key).map_err(|e| refuse(e.to_string()))?)
                }
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
                Err(e) if e.kind() == std::io::ErrorKind::InvalidData => {
                    return Err(refuse(e.to_string()))
                }
                Err(e) => return Err(HostError::io(&path)(e)),
            };
            let resumed = u8::from(resume.is_some()) * 2;
            // Every seed of a cell still to compute has its bed.
            let Some(bed) = settled.get(&seed) else {
                return Err(HostError::Checkpoint {
                    path: beds.dir.clone(),
                    message: format!("no settled bed of seed {seed}"),
                });
            };
            let cell_control = Control {
                path: Some(path.clone()),
                every: control.every,
                stop: control.stop,
                stop_after: control.stop_after,
            };
            let cell = format!("tau* {tau_star} seed {seed}");
            let from = if resume.is_some() {
                " (from its checkpoint)"
            } else {
                ""
            };
            log.event(&format!("cell start  {cell}{from}"));
            let clock = Instant::now();
            let outcome = run_cell_job(CellJob {
                config,
                tau_star,
                seed,
                key,
                bed,
                resume,
                control: &cell_control,
                progress,
                frames: control.dump_every.map(|every| FramePlan {
                    dir: frames_dir(control.dir, tau_star, seed),
                    every,
                }),
                threads: cell_threads,
            })
            .inspect_err(|e| log.event(&format!("cell failed  {cell}: {e}")))?;
            let wall = clock.elapsed().as_secs_f64();
            match &outcome {
                CellOutcome::Done(result, _) => {
                    store.put(&spec, &Ok::<_, String>(result.as_ref().clone()))?;
                    remove_if_present(&path)?;
                    log.event(&format!(
                        "cell end  {cell}  q* {}  wall {wall:.3} s",
                        result.q_star
                    ));
                    count(progress);
                }
                CellOutcome::Stopped => {
                    log.event(&format!(
                        "cell stopped  {cell}  checkpointed, wall {wall:.3} s"
                    ));
                }
            }
            Ok((outcome, resumed))
        })
        .collect();
    let mut out = RunOutcome {
        results: Vec::new(),
        reused: 0,
        resumed: 0,
        beds_settled,
        beds_resumed,
        bed_grain_steps,
        computed_grain_steps: 0,
    };
    let mut stopped = 0;
    for o in outcomes {
        let (outcome, how) = o?;
        out.reused += usize::from(how == 1);
        out.resumed += usize::from(how == 2);
        match outcome {
            CellOutcome::Done(r, now) => {
                out.computed_grain_steps += now;
                out.results.push(*r);
            }
            CellOutcome::Stopped => stopped += 1,
        }
    }
    if stopped > 0 {
        return Err(HostError::Interrupted { jobs: stopped });
    }
    Ok(out)
}

/// One row of `transport.csv`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransportRow {
    /// Shields number.
    pub tau_star: f64,
    /// Mean q* over the seeds (each the mean of its steady part).
    pub q_star: f64,
    /// Its standard error: between seeds, or from the batch means of one
    /// seed ([`q_star_interval`]).
    pub q_star_stderr: f64,
    /// The half-width of its 95 % interval (t quantile).
    pub q_star_ci95: f64,
    /// Seeds averaged.
    pub seeds: usize,
    /// The seeds' mean recorded window (s), discarded part included.
    pub window_s: f64,
    /// The seeds' mean discarded transient (s), MSER.
    pub discarded_s: f64,
    /// Seeds without a steady part (MSER discarded more than half).
    pub unsteady: usize,
    /// Seeds whose window ended at `time.window` without the target.
    pub capped: usize,
    /// The first and the last third of the steady parts compared.
    pub steadiness: Option<Steadiness>,
    /// Meyer-Peter & Müller at τ*.
    pub mpm: f64,
    /// Wong & Parker at τ*.
    pub wong_parker: f64,
    /// (mean, stderr) of q* per size class (only for mixed beds).
    pub classes: Vec<(f64, f64)>,
}

/// The interval of q* over the cells of one τ* (docs/model.md (E2), (E3)):
/// the seeds' steady means as independent replicates, or one seed's
/// batch means.
///
/// ```
/// # use mbs::work::cell::{Block, CellResult};
/// # use mbs::work::beds::{BedRecord, BedStatus};
/// use mbs::work::experiment::q_star_interval;
///
/// # let cell = |seed, q: f64| CellResult { tau_star: 0.1, seed, q_star: q, q_star_class: vec![q],
/// #     blocks: (0..10).map(|k| Block { q_star: q + k as f64 * 1e-3, bed_level: 0.0, q_star_class: vec![q] }).collect(),
/// #     discarded: 0, steady: true, window_s: 1.0, target_reached: true, bed_level: 0.0, grain_steps: 0,
/// #     bed: BedRecord { status: BedStatus::AtRest, settle_s: 0.0, max_overlap_d: 0.0 }, profile: None };
/// let (a, b) = (cell(1, 0.1), cell(2, 0.2));
/// let two = q_star_interval(&[&a, &b]);
/// assert_eq!((two.dof, two.stderr), (1, 0.05));
/// let one = q_star_interval(&[&a]);
/// assert_eq!(one.dof, 4); // five batches of two blocks
/// ```
pub fn q_star_interval(cells: &[&CellResult]) -> Interval {
    match cells {
        [one] => Interval {
            mean: one.q_star,
            ..Interval::batch_means(&one.steady_means())
        },
        _ => Interval::replicates(&cells.iter().map(|c| c.q_star).collect::<Vec<_>>()),
    }
}

/// The finished result of the cell `spec` in `store`, if one is stored;
/// `Err(field)` if the stored result does not fit the cell
/// ([`TransportSpec::check`]): it is refused, and the cell computed again
/// (its new line is read instead from then on).
fn stored(store: &Store, spec: &TransportSpec) -> Result<Option<CellResult>, &'static str> {
    match store.get::<_, Result<CellResult, String>>(spec) {
        Some(Ok(done)) => spec.check(&done).map(|()| Some(done)),
        _ => Ok(None),
    }
}

/// Combines cell results into one row per τ*, in the configuration's order.
pub fn aggregate(config: &Config, results: &[CellResult]) -> Vec<TransportRow> {
    let n_classes = config.scenario.bed.classes.len();
    let block_s = config.durations.block() as f64 * config.scenario.step_dt();
    config
        .tau_stars
        .iter()
        .map(|&tau| {
            let cells: Vec<&CellResult> = results.iter().filter(|r| r.tau_star == tau).collect();
            let interval = q_star_interval(&cells);
            let classes = if n_classes > 1 {
                (0..n_classes)
                    .map(|k| {
                        let values: Vec<f64> = cells.iter().map(|c| c.q_star_class[k]).collect();
                        mean_stderr(&values)
                    })
                    .collect()
            } else {
                Vec::new()
            };
            let blocks: Vec<Vec<f64>> = cells.iter().map(|c| c.steady_means()).collect();
            let mean_of = |value: &dyn Fn(&CellResult) -> f64| {
                mean_stderr(&cells.iter().map(|c| value(c)).collect::<Vec<_>>()).0
            };
            TransportRow {
                tau_star: tau,
                q_star: interval.mean,
                q_star_stderr: interval.stderr,
                q_star_ci95: interval.half_width(),
                seeds: cells.len(),
                window_s: mean_of(&|c| c.window_s),
                discarded_s: mean_of(&|c| c.discarded as f64 * block_s),
                unsteady: cells.iter().filter(|c| !c.steady).count(),
                capped: cells.iter().filter(|c| !c.target_reached).count(),
                steadiness: Steadiness::of(&blocks),
                mpm: Reference::MeyerPeterMuller.q_star(tau),
                wong_parker: Reference::WongParker.q_star(tau),
                classes,
            }
        })
        .collect()
}

/// Threads inside each cell's bed: `[run] threads_per_cell`, or with 0 the
/// cores of the pool left over when each of `cells` has one, shared among
/// them (one thread each when there are more cells than cores).
pub fn threads_per_cell(asked: u32, cells: usize) -> usize {
    match asked {
        0 => (rayon::current_num_threads() / cells.max(1)).max(1),
        n => n as usize,
    }
}
