//! `mbs calibrate`: the paper's parameter optimisation (docs/model.md §9),
//! automated.
//!
//! | stage | what | paper |
//! |---|---|---|
//! | 1 | α_m by the fastest settling of a packed bed (α_cn = 1, β = 1) | 20 |
//! | 2 | α_cn the same way, α_m fixed | 1.3 |
//! | 3 | β by golden-section search of the q*(τ*) misfit to a reference | 15.8 |
//! | 4 | constants_dt for other grain sizes d and layer thicknesses nvd | 9.0e-6 s at d = 0.1 mm |
//! | 5 | a mixed bed: fractional transport per size class | — |
//!
//! Every simulation is a cell ([`cells`]) stored as it finishes ([`store`]);
//! a stage is recomputed from the store on every invocation, so an
//! interrupted calibration resumes where it stopped and a sharded one is
//! completed by merging the shards' stores.

pub mod calibrated;
pub mod cells;
pub mod optimise;
pub mod report;
pub mod stages;

use crate::config::{Config, ConfigFile};
use crate::error::HostError;
use crate::log::Log;
use crate::references::Reference;
use cells::{Cells, TransportSpec};
use serde::{Deserialize, Serialize};

use crate::store::STORE;

/// The grids, seeds and durations of a calibration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// Quick mode.
    pub quick: bool,
    /// Stage 1: α_m values.
    pub alpha_m: Vec<f64>,
    /// Stage 2: α_cn values.
    pub alpha_cn: Vec<f64>,
    /// Stages 1–2: packing duration (s).
    pub pack_duration: f64,
    /// Stages 1–2: seeds.
    pub pack_seeds: Vec<u64>,
    /// Stages 1–2: lattice columns of the packing bed (docs/model.md §9
    /// step 1: nld = 5); the flow stages use the base bed's columns.
    pub pack_columns: u32,
    /// Stages 3–5: lattice columns instead of the base bed's (the quick plan
    /// uses 10: q* above τ* = 0.1 is the same as on 40, near the threshold
    /// it is not; docs/findings/bed-width.md).
    pub flow_columns: Option<u32>,
    /// Stage 4: lattice columns instead of the flow stages' (its τ* ≥ 0.1
    /// converge by 20 columns; docs/findings/bed-width.md), so the 50-layer
    /// beds stay affordable.
    pub timestep_columns: Option<u32>,
    /// Stages 1–2: settled when |y_gc − final y_gc| stays below this (diameters).
    pub settle_tolerance_d: f64,
    /// Stages 1–2: at rest when the largest speed at the end is below this (m/s).
    pub rest_speed: f64,
    /// Stage 3: β grid (searched first; the search refines around its best).
    pub beta_grid: Vec<f64>,
    /// Stage 3: stop when the β bracket is narrower than this ratio.
    pub beta_tolerance: f64,
    /// Stages 3, 5: Shields numbers of the fit.
    pub tau_stars: Vec<f64>,
    /// Stages 3, 5: seeds.
    pub seeds: Vec<u64>,
    /// Stages 3, 5: seeds instead of `seeds` at τ* ≤ `threshold_tau_star`,
    /// where q* comes from rare events and 4 seeds leave ±45 %
    /// (docs/calibration.md).
    pub threshold_seeds: Vec<u64>,
    /// Stages 3, 5: the largest τ* that uses `threshold_seeds`.
    pub threshold_tau_star: f64,
    /// Transport window (s) of stages 3 and 5.
    pub window: f64,
    /// Transport window (s) of stage 4.
    pub timestep_window: f64,
    /// Stage 4: grain diameters (mm), searched at the first of `layers`.
    pub sizes_mm: Vec<f64>,
    /// Stage 4: layer thicknesses nvd, searched at the study diameter.
    pub layers: Vec<u32>,
    /// Stage 4: the diameter of the layer study (mm).
    pub study_mm: f64,
    /// Stage 4: constants_dt grid as multiples of the base configuration's.
    pub constants_dt_grid: Vec<f64>,
    /// Stage 4: stop when the constants_dt bracket is narrower than this ratio.
    pub constants_dt_tolerance: f64,
    /// Stage 4: Shields numbers.
    pub timestep_tau_stars: Vec<f64>,
    /// Stage 4: seeds.
    pub timestep_seeds: Vec<u64>,
    /// Stage 5: size classes (mm, fraction).
    pub mixed: Vec<(f64, f64)>,
}

impl Plan {
    /// The full calibration.
    pub fn full() -> Plan {
        Plan {
            quick: false,
            alpha_m: vec![5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0],
            alpha_cn: vec![0.5, 0.7, 1.0, 1.3, 1.6, 2.0, 2.5, 3.0],
            pack_duration: 0.5,
            pack_seeds: vec![1, 2, 3, 4],
            pack_columns: 5,
            flow_columns: None,
            timestep_columns: Some(20),
            settle_tolerance_d: 0.01,
            rest_speed: 5e-3,
            beta_grid: vec![1.0, 1.6, 2.5, 4.0, 6.3, 10.0, 15.8, 25.0],
            beta_tolerance: 1.05,
            tau_stars: vec![0.06, 0.08, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5],
            seeds: vec![1, 2, 3, 4],
            threshold_seeds: (1..=12).collect(),
            threshold_tau_star: 0.06,
            window: 2.0,
            timestep_window: 1.0,
            sizes_mm: vec![0.1, 0.2, 0.5, 1.0, 2.0],
            layers: vec![10, 20, 30, 40, 50],
            study_mm: 0.5,
            constants_dt_grid: vec![0.5, 1.0, 2.0],
            constants_dt_tolerance: 1.15,
            timestep_tau_stars: vec![0.1, 0.2, 0.4],
            timestep_seeds: vec![1, 2],
            mixed: vec![(0.7, 0.5), (0.5, 0.5)],
        }
    }

    /// A few minutes on 2 cores: coarser grids, one or two seeds, short windows.
    pub fn quick() -> Plan {
        Plan {
            quick: true,
            alpha_m: vec![10.0, 20.0, 40.0],
            alpha_cn: vec![0.7, 1.3, 2.5],
            pack_duration: 0.25,
            pack_seeds: vec![1],
            flow_columns: Some(10),
            timestep_columns: None,
            beta_grid: vec![1.5, 3.0, 6.0, 12.0],
            beta_tolerance: 1.25,
            tau_stars: vec![0.06, 0.1, 0.2, 0.4],
            seeds: vec![1],
            threshold_seeds: vec![1],
            window: 0.5,
            timestep_window: 0.5,
            sizes_mm: vec![0.1, 0.5],
            layers: vec![10, 20],
            constants_dt_grid: vec![0.5, 1.0],
            constants_dt_tolerance: 1.5,
            timestep_tau_stars: vec![0.1, 0.4],
            timestep_seeds: vec![1],
            study_mm: 0.5,
            ..Plan::full()
        }
    }

    /// The (τ*, seeds) of the transport curves of stages 3 and 5.
    pub fn fit_points(&self) -> Vec<(f64, &[u64])> {
        self.tau_stars
            .iter()
            .map(|&t| {
                let seeds = if t <= self.threshold_tau_star {
                    &self.threshold_seeds
                } else {
                    &self.seeds
                };
                (t, seeds.as_slice())
            })
            .collect()
    }
}

/// Everything a stage needs.
pub struct Context<'a> {
    /// The base configuration: its file is what the stages vary.
    pub base: Config,
    /// Grids and durations.
    pub plan: Plan,
    /// The reference relation of stages 3–5.
    pub reference: Reference,
    /// Cell evaluation.
    pub cells: Cells<'a>,
    /// Output directory.
    pub dir: std::path::PathBuf,
}

/// q*(τ*) of one configuration, averaged over seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Curve {
    /// Shields numbers.
    pub tau_stars: Vec<f64>,
    /// Mean q* over seeds (NaN where a cell failed).
    pub q_star: Vec<f64>,
    /// Standard error between seeds.
    pub stderr: Vec<f64>,
    /// Per size class: mean q* per τ*.
    pub classes: Vec<Vec<f64>>,
    /// Kernel failures (cell message), if any.
    pub failures: Vec<String>,
}

/// Misfit of a failed or non-positive point: a large but finite penalty so
/// the search moves away from it.
pub const FAILED_MISFIT: f64 = 100.0;

/// Smallest q* used in a logarithm.
pub const Q_FLOOR: f64 = 1e-4;

/// In the misfit a q* below this fraction of the reference counts as this
/// fraction: one point with (nearly) no transport near the threshold adds
/// ln²(10) ≈ 5.3 instead of dominating the sum with an arbitrary floor.
pub const MISFIT_FLOOR: f64 = 0.1;

impl Curve {
    /// (τ*, q*, stderr) of every point, for error bars.
    pub fn points(&self) -> Vec<(f64, f64, f64)> {
        self.tau_stars
            .iter()
            .zip(self.q_star.iter().zip(&self.stderr))
            .map(|(&t, (&q, &e))| (t, q, e))
            .collect()
    }

    /// Mean squared log-ratio of q* to `reference` (the objective of stages
    /// 3 and 4), q* floored at [`MISFIT_FLOOR`] × reference;
    /// [`FAILED_MISFIT`] if any cell failed.
    pub fn misfit(&self, reference: Reference) -> f64 {
        if !self.failures.is_empty() {
            return FAILED_MISFIT;
        }
        let n = self.tau_stars.len().max(1) as f64;
        self.tau_stars
            .iter()
            .zip(&self.q_star)
            .map(|(&t, &q)| {
                let q_ref = reference.q_star(t).max(Q_FLOOR);
                let r = (q.max(MISFIT_FLOOR * q_ref) / q_ref).ln();
                r * r
            })
            .sum::<f64>()
            / n
    }

    /// The misfit that noise alone gives: the mean over τ* of the squared
    /// relative standard error (σ/q*)², the expected ln²(q*/q*_ref) of a
    /// curve that matches the reference and scatters by its errors.
    pub fn misfit_noise(&self) -> f64 {
        let n = self.tau_stars.len().max(1) as f64;
        self.q_star
            .iter()
            .zip(&self.stderr)
            .map(|(&q, &e)| {
                let r = e / q.abs().max(Q_FLOOR);
                if r.is_finite() {
                    r * r
                } else {
                    0.0
                }
            })
            .sum::<f64>()
            / n
    }

    /// Largest factor between q* and `reference` (either way) over the curve.
    pub fn worst_factor(&self, reference: Reference) -> f64 {
        self.tau_stars
            .iter()
            .zip(&self.q_star)
            .map(|(&t, &q)| {
                let r = q.max(Q_FLOOR) / reference.q_star(t).max(Q_FLOOR);
                r.max(1.0 / r)
            })
            .fold(1.0, f64::max)
    }
}

impl Context<'_> {
    /// The base configuration with the contact constants α_m, α_cn and β of
    /// a stage (the settling stages also pack on their own bed).
    pub fn configure(&self, alpha_m: f64, alpha_cn: f64, beta: f64) -> ConfigFile {
        let mut c = self.base.file.clone();
        c.contact.alpha_m = alpha_m;
        c.contact.alpha_cn = alpha_cn;
        c.contact.beta = beta;
        c
    }

    /// The transport curve of `config` at `points` (τ* and the seeds averaged
    /// there); `None` while cells owned by other shards are missing.
    /// `slot(k)` numbers the cells for sharding.
    pub fn curve(
        &self,
        config: &ConfigFile,
        points: &[(f64, &[u64])],
        window: f64,
        slot: &(dyn Fn(usize) -> usize + Sync),
    ) -> Result<Option<Curve>, HostError> {
        let mut config = config.clone();
        // Fixed windows of ten blocks (the calibration's own plan).
        config.time.window = window;
        config.time.window_min = window;
        config.time.block = window / 10.0;
        let specs: Vec<TransportSpec> = points
            .iter()
            .flat_map(|&(t, seeds)| seeds.iter().map(move |&s| (t, s)))
            .map(|(t, s)| TransportSpec::new(&config, t, s))
            .collect();
        let results = self.cells.transport(&specs, slot)?;
        if results.iter().any(Option::is_none) {
            return Ok(None);
        }
        let n_classes = config.grains.classes.as_ref().map_or(1, Vec::len);
        let mut curve = Curve {
            tau_stars: points.iter().map(|p| p.0).collect(),
            q_star: Vec::new(),
            stderr: Vec::new(),
            classes: vec![Vec::new(); n_classes],
            failures: Vec::new(),
        };
        let mut rest = results.as_slice();
        for &(_, seeds) in points {
            let (chunk, tail) = rest.split_at(seeds.len().min(rest.len()));
            rest = tail;
            let mut q = Vec::new();
            let mut blocks = Vec::new();
            let mut per_class = vec![Vec::new(); n_classes];
            for r in chunk.iter().flatten() {
                match r {
                    Ok(c) => {
                        q.push(c.q_star);
                        blocks = c.block_means();
                        for (k, v) in c.q_star_class.iter().enumerate().take(n_classes) {
                            per_class[k].push(*v);
                        }
                    }
                    Err(message) => curve.failures.push(message.clone()),
                }
            }
            // One seed: the error of its window's blocks (as in `mbs run`).
            let (mean, err) = if q.len() == seeds.len() && q.len() == 1 {
                (q[0], crate::stats::block_stderr(&blocks).1)
            } else if q.len() == seeds.len() {
                crate::stats::mean_stderr(&q)
            } else {
                (f64::NAN, f64::NAN)
            };
            curve.q_star.push(mean);
            curve.stderr.push(err);
            for (k, values) in per_class.iter().enumerate() {
                curve.classes[k].push(crate::stats::mean_stderr(values).0);
            }
        }
        Ok(Some(curve))
    }
}

/// Options of `mbs calibrate`.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// The quick plan.
    pub quick: bool,
    /// Run stages up to this one only (1–5).
    pub last_stage: usize,
    /// This machine's slice.
    pub shard: cells::Shard,
    /// Reference relation of stages 3–5.
    pub reference: Reference,
    /// No progress, no report on standard output.
    pub quiet: bool,
}

/// How far a calibration got.
#[derive(Debug, Clone, PartialEq)]
pub enum Progress {
    /// Every requested stage finished (the report is written after stage 5).
    Done {
        /// Stages finished.
        stages: usize,
        /// The calibrated constants, written to `calibrated.toml` (from
        /// stage 3 on).
        calibrated: Option<calibrated::Calibrated>,
    },
    /// Stage `stage` waits for cells of other shards: merge and rerun.
    Waiting {
        /// The first unfinished stage.
        stage: usize,
    },
}

/// Runs the calibration into `dir` (resuming from its cell store).
pub fn calibrate(
    base: Config,
    dir: &std::path::Path,
    options: Options,
    log: &Log,
) -> Result<Progress, HostError> {
    use stages::{beta, mixed, settling, timestep};
    let plan = if options.quick {
        Plan::quick()
    } else {
        Plan::full()
    };
    let base = match plan.flow_columns {
        Some(columns) => {
            let mut file = base.file;
            file.bed.columns = columns;
            Config::validate(file)?
        }
        None => base,
    };
    let _lock = crate::output::lock_dir(dir)?;
    crate::output::remove_temporaries(dir)?;
    let store = crate::store::Store::open(&dir.join(STORE))?;
    crate::output::write_json(&dir.join("plan.json"), &plan)?;
    let progress = crate::progress::Progress::counter("cells computed", options.quiet);
    let stage = |name: &str| {
        progress.bar().set_message(name.to_string());
        log.event(name);
    };
    let ctx = Context {
        base,
        plan,
        reference: options.reference,
        cells: Cells {
            store: &store,
            shard: options.shard,
            progress: progress.bar(),
            log,
            beds: dir.join("beds"),
        },
        dir: dir.to_path_buf(),
    };
    let waiting = |stage| Ok(Progress::Waiting { stage });
    stage("stage 1 (α_m)");
    let Some(s1) = settling::run(&ctx, 1, ctx.base.scenario.rule.alpha_m)? else {
        return waiting(1);
    };
    if options.last_stage < 2 {
        return Ok(Progress::Done {
            stages: 1,
            calibrated: None,
        });
    }
    stage("stage 2 (α_cn)");
    let Some(s2) = settling::run(&ctx, 2, s1.chosen)? else {
        return waiting(2);
    };
    if options.last_stage < 3 {
        return Ok(Progress::Done {
            stages: 2,
            calibrated: None,
        });
    }
    stage("stage 3 (β)");
    let Some(s3) = beta::run(&ctx, s1.chosen, s2.chosen)? else {
        return waiting(3);
    };
    let write_calibrated = |timestep| {
        let file = ctx.configure(s3.alpha_m, s3.alpha_cn, s3.beta);
        calibrated::write(dir, &file, &s3, timestep, options.reference)
    };
    if options.last_stage < 4 {
        return Ok(Progress::Done {
            stages: 3,
            calibrated: Some(write_calibrated(None)?),
        });
    }
    stage("stage 4 (constants_dt for d and nvd)");
    let Some(s4) = timestep::run(&ctx, s1.chosen, s2.chosen, s3.beta)? else {
        return waiting(4);
    };
    if options.last_stage < 5 {
        return Ok(Progress::Done {
            stages: 4,
            calibrated: Some(write_calibrated(Some(&s4))?),
        });
    }
    stage("stage 5 (mixed sizes)");
    let Some(s5) = mixed::run(&ctx, s1.chosen, s2.chosen, s3.beta)? else {
        return waiting(5);
    };
    report::write_report(
        dir,
        &ctx.plan,
        options.reference,
        &ctx.base,
        &report::Stages {
            alpha_m: &s1,
            alpha_cn: &s2,
            beta: &s3,
            timestep: &s4,
            mixed: &s5,
        },
    )?;
    Ok(Progress::Done {
        stages: 5,
        calibrated: Some(write_calibrated(Some(&s4))?),
    })
}

pub use crate::shard::merge;

#[cfg(test)]
mod tests {
    use super::Plan;

    #[test]
    fn threshold_points_get_their_own_seeds() {
        let plan = Plan::full();
        let points = plan.fit_points();
        let taus: Vec<f64> = points.iter().map(|p| p.0).collect();
        assert_eq!(taus, plan.tau_stars);
        assert_eq!(points[0], (0.06, &(1..=12).collect::<Vec<u64>>()[..]));
        assert!(points[1..].iter().all(|p| p.1 == [1, 2, 3, 4]));
    }
}
