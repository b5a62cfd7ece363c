//! `mbs calibrate`: the paper's parameter optimisation (docs/model.md §9),
//! automated.
//!
//! | stage | what | paper |
//! |---|---|---|
//! | 1 | α_m by the fastest settling of a packed bed (α_cn = 1, β = 1) | 20 |
//! | 2 | α_cn the same way, α_m fixed | 1.3 |
//! | 3 | β minimising the q*(τ*) misfit to a reference, coarse then precise | 15.8 |
//! | 4 | constants_dt for other grain sizes d and layer thicknesses nvd | 9.0e-6 s at d = 0.1 mm |
//! | 5 | a mixed bed: fractional transport per size class | — |
//!
//! Every simulation is a cell ([`cells`]) stored as it finishes ([`crate::work::store`]);
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
use crate::io::log::Log;
use crate::science::references::Reference;
use cells::{Cells, TransportSpec};
use serde::{Deserialize, Serialize};

use crate::work::store::STORE;

/// How precisely the points of a curve are computed (docs/calibration.md,
/// "Precision-driven points"). A cell averages from `window_min` on, in
/// blocks of `window_min`/5, until its standard error reaches the base
/// configuration's `[target]` or `window` is up; a point starts with
/// `seeds` seeds (1, 2, …) and adds `seeds` more while the standard error
/// of their mean misses the same target, up to its cap, unless the point is
/// already beyond the fit's target factor by twice its error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Fidelity {
    /// Shortest averaging window of a cell (s).
    pub window_min: f64,
    /// Longest averaging window of a cell (s): the cap.
    pub window: f64,
    /// Seeds a point starts with, and adds at a time.
    pub seeds: usize,
    /// The most seeds of a point above `threshold_tau_star`.
    pub seeds_max: usize,
    /// The most seeds of a point at τ* ≤ `threshold_tau_star`, where q*
    /// comes from rare events.
    pub threshold_seeds_max: usize,
}

impl Fidelity {
    /// One seed and one fixed window: a cheap look.
    pub fn coarse(window: f64) -> Fidelity {
        Fidelity {
            window_min: window,
            window,
            seeds: 1,
            seeds_max: 1,
            threshold_seeds_max: 1,
        }
    }

    /// The block of a cell's window (s).
    pub fn block(&self) -> f64 {
        self.window_min / 5.0
    }
}

/// The grids, fidelities and durations of a calibration.
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
    /// Stages 3–5: lattice columns instead of the base bed's (near the
    /// threshold q* depends on the width below 40; docs/findings/bed-width.md).
    pub flow_columns: Option<u32>,
    /// Stage 4: lattice columns instead of the flow stages' (its τ* ≥ 0.1
    /// converge by 20 columns; docs/findings/bed-width.md), so the 50-layer
    /// beds stay affordable.
    pub timestep_columns: Option<u32>,
    /// Stages 1–2: settled when |y_gc − final y_gc| stays below this (diameters).
    pub settle_tolerance_d: f64,
    /// Stages 1–2: at rest when the largest speed at the end is below this (m/s).
    pub rest_speed: f64,
    /// Stage 3: the coarse grid of β.
    pub beta_grid: Vec<f64>,
    /// Stage 3: the ratio between the first three precise β.
    pub beta_step: f64,
    /// Stage 3: the search ends when the parabola's vertex is within this
    /// ratio of a β already evaluated precisely.
    pub beta_tolerance: f64,
    /// Stage 3: the most precise curves.
    pub beta_evaluations: usize,
    /// The worst factor to the reference the fit aims at; a point beyond it
    /// by twice its error adds no seeds (its verdict is clear).
    pub target_factor: f64,
    /// Stages 3, 5: Shields numbers of the fit.
    pub tau_stars: Vec<f64>,
    /// The largest τ* that counts as near the threshold
    /// ([`Fidelity::threshold_seeds_max`]).
    pub threshold_tau_star: f64,
    /// Stage 3's coarse grid.
    pub coarse: Fidelity,
    /// Stage 3's fine search and stage 5.
    pub fine: Fidelity,
    /// Stage 4.
    pub timestep: Fidelity,
    /// Stage 4: grain diameters (mm), searched at the first of `layers`.
    pub sizes_mm: Vec<f64>,
    /// Stage 4: layer thicknesses nvd, searched at the study diameter.
    pub layers: Vec<u32>,
    /// Stage 4: the diameter of the layer study (mm).
    pub study_mm: f64,
    /// Stage 4: the first step of the secant search, as a ratio of constants_dt.
    pub constants_dt_step: f64,
    /// Stage 4: the most curves per (d, nvd) search.
    pub constants_dt_evaluations: usize,
    /// Stage 4: Shields numbers.
    pub timestep_tau_stars: Vec<f64>,
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
            beta_step: 1.3,
            beta_tolerance: 1.05,
            beta_evaluations: 8,
            target_factor: 1.5,
            tau_stars: vec![0.06, 0.08, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5],
            threshold_tau_star: 0.06,
            coarse: Fidelity::coarse(0.5),
            fine: Fidelity {
                window_min: 0.5,
                window: 2.0,
                seeds: 4,
                seeds_max: 4,
                threshold_seeds_max: 12,
            },
            timestep: Fidelity {
                window_min: 0.5,
                window: 1.0,
                seeds: 2,
                seeds_max: 2,
                threshold_seeds_max: 2,
            },
            sizes_mm: vec![0.1, 0.2, 0.5, 1.0, 2.0],
            layers: vec![10, 20, 30, 40, 50],
            study_mm: 0.5,
            constants_dt_step: 1.5,
            constants_dt_evaluations: 4,
            timestep_tau_stars: vec![0.1, 0.2, 0.4],
            mixed: vec![(0.7, 0.5), (0.5, 0.5)],
        }
    }

    /// Under 3 minutes on 2 cores: the same packing stages (seconds), a
    /// coarser β grid, fewer seeds, shorter windows, two grain sizes and two
    /// layer thicknesses; the fit leaves out τ* = 0.06, where q* needs a
    /// dozen seeds.
    pub fn quick() -> Plan {
        Plan {
            quick: true,
            beta_grid: vec![1.5, 3.0, 6.0, 12.0],
            tau_stars: vec![0.08, 0.1, 0.2, 0.4],
            threshold_tau_star: 0.08,
            fine: Fidelity {
                window_min: 0.5,
                window: 1.0,
                seeds: 2,
                seeds_max: 2,
                threshold_seeds_max: 4,
            },
            timestep: Fidelity::coarse(0.5),
            sizes_mm: vec![0.1, 0.5],
            layers: vec![10, 20],
            constants_dt_evaluations: 2,
            timestep_tau_stars: vec![0.1, 0.4],
            ..Plan::full()
        }
    }

    /// The most seeds of a point at `tau_star` under `fidelity`.
    pub fn seeds_max(&self, fidelity: &Fidelity, tau_star: f64) -> usize {
        if tau_star <= self.threshold_tau_star {
            fidelity.threshold_seeds_max.max(fidelity.seeds)
        } else {
            fidelity.seeds_max.max(fidelity.seeds)
        }
    }
}

/// How the cells of a request are numbered for sharding.
#[derive(Debug, Clone, Copy)]
pub enum Slots {
    /// One number per cell from this one on: cells spread over the shards.
    From(usize),
    /// This number for every cell: the whole request on one shard.
    All(usize),
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
    /// Seeds averaged per τ*.
    #[serde(default)]
    pub seeds: Vec<usize>,
    /// Per τ*: whether the point's standard error reached the target (or
    /// its verdict was clear) before the seed cap.
    #[serde(default)]
    pub reached: Vec<bool>,
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

    /// The log-ratio ln(q*/q*_ref) of every point, q* floored at
    /// [`MISFIT_FLOOR`] × reference, with its relative standard error.
    pub fn log_ratios(&self, reference: Reference) -> Vec<(f64, f64)> {
        self.tau_stars
            .iter()
            .zip(self.q_star.iter().zip(&self.stderr))
            .map(|(&t, (&q, &e))| {
                let q_ref = reference.q_star(t).max(Q_FLOOR);
                let q = q.max(MISFIT_FLOOR * q_ref);
                let relative = e / q;
                (
                    (q / q_ref).ln(),
                    if relative.is_finite() { relative } else { 0.0 },
                )
            })
            .collect()
    }

    /// The weight of a point with relative standard error `relative`:
    /// 1/(relative² + floor²). A point resolved to the `floor` (the target's
    /// relative error) weighs about fully, a noisier one less.
    fn weight(relative: f64, floor: f64) -> f64 {
        1.0 / (relative * relative + floor * floor)
    }

    /// The misfit (the objective of stage 3): the mean squared log-ratio of
    /// q* to `reference`, each point weighted by its error ([`Self::log_ratios`],
    /// weights 1/(σ_r² + floor²), `floor` the target's relative error);
    /// [`FAILED_MISFIT`] if any cell failed.
    pub fn misfit(&self, reference: Reference, floor: f64) -> f64 {
        if !self.failures.is_empty() {
            return FAILED_MISFIT;
        }
        self.weighted(reference, floor, |r, _| r * r)
    }

    /// The misfit that noise alone gives: the weighted mean of the squared
    /// relative standard errors σ_r², the expected misfit of a curve that
    /// matches the reference and scatters by its errors.
    pub fn misfit_noise(&self, reference: Reference, floor: f64) -> f64 {
        self.weighted(reference, floor, |_, e| e * e)
    }

    /// The weighted mean log-ratio (the root stage 4 searches) and its
    /// standard error.
    pub fn mean_log_ratio(&self, reference: Reference, floor: f64) -> (f64, f64) {
        let ratios = self.log_ratios(reference);
        let weights: Vec<f64> = ratios
            .iter()
            .map(|&(_, e)| Self::weight(e, floor))
            .collect();
        let total: f64 = weights.iter().sum();
        let mean = ratios
            .iter()
            .zip(&weights)
            .map(|(p, w)| w * p.0)
            .sum::<f64>()
            / total;
        let variance: f64 = ratios
            .iter()
            .zip(&weights)
            .map(|(p, w)| (w / total * p.1).powi(2))
            .sum();
        (mean, variance.sqrt())
    }

    fn weighted(&self, reference: Reference, floor: f64, f: impl Fn(f64, f64) -> f64) -> f64 {
        let ratios = self.log_ratios(reference);
        let (sum, total) = ratios.iter().fold((0.0, 0.0), |(s, w), &(r, e)| {
            let weight = Self::weight(e, floor);
            (s + weight * f(r, e), w + weight)
        });
        if total > 0.0 {
            sum / total
        } else {
            FAILED_MISFIT
        }
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

    /// The relative standard error the fit aims at (the base configuration's
    /// `[target] stderr_relative`), also the floor of the misfit's weights.
    pub fn floor(&self) -> f64 {
        self.base.file.target.stderr_relative
    }

    /// The transport curves of `configs` at `tau_stars`, computed to
    /// `fidelity` ([`Fidelity`]) in rounds: every point's first seeds, then
    /// more seeds for the points that miss the target, until none does or
    /// all are capped. `judge`: the reference whose verdict also ends a
    /// point (beyond `target_factor` by twice its error). `None` while cells
    /// owned by other shards are missing; `slots` numbers the cells for
    /// sharding.
    pub fn curves(
        &self,
        configs: &[ConfigFile],
        tau_stars: &[f64],
        fidelity: &Fidelity,
        judge: Option<Reference>,
        slots: Slots,
    ) -> Result<Option<Vec<Curve>>, HostError> {
        let caps: Vec<usize> = tau_stars
            .iter()
            .map(|&t| self.plan.seeds_max(fidelity, t))
            .collect();
        let per_config: usize = caps.iter().sum();
        let configs: Vec<ConfigFile> = configs
            .iter()
            .map(|c| {
                let mut c = c.clone();
                c.time.window = fidelity.window;
                c.time.window_min = fidelity.window_min;
                c.time.block = fidelity.block();
                c
            })
            .collect();
        let mut seeds: Vec<Vec<usize>> = vec![
            caps.iter()
                .map(|&cap| fidelity.seeds.min(cap).max(1))
                .collect();
            configs.len()
        ];
        loop {
            let mut specs = Vec::new();
            let mut numbers = Vec::new();
            for (c, config) in configs.iter().enumerate() {
                let mut slot = c * per_config;
                for (p, &t) in tau_stars.iter().enumerate() {
                    for seed in 1..=seeds[c][p] {
                        specs.push(TransportSpec::new(config, t, seed as u64));
                        numbers.push(match slots {
                            Slots::From(first) => first + slot + seed - 1,
                            Slots::All(unit) => unit,
                        });
                    }
                    slot += caps[p];
                }
            }
            let results = self.cells.transport(&specs, &|k| numbers[k])?;
            if results.iter().any(Option::is_none) {
                return Ok(None);
            }
            let mut rest = results.as_slice();
            let mut curves = Vec::new();
            let mut more = false;
            for (c, config) in configs.iter().enumerate() {
                let mut chunks = Vec::new();
                for &n in &seeds[c] {
                    let (chunk, tail) = rest.split_at(n);
                    rest = tail;
                    chunks.push(chunk);
                }
                let mut curve = self.curve_of(config, tau_stars, &chunks);
                for p in 0..tau_stars.len() {
                    let done = self.point_done(&curve, p, judge);
                    if !done && seeds[c][p] < caps[p] {
                        seeds[c][p] = (seeds[c][p] + fidelity.seeds).min(caps[p]);
                        more = true;
                    }
                    curve.reached.push(done);
                }
                curves.push(curve);
            }
            if !more {
                if fidelity.threshold_seeds_max.max(fidelity.seeds_max) > fidelity.seeds {
                    self.log_capped(&configs, &curves);
                }
                return Ok(Some(curves));
            }
        }
    }

    /// Logs each point of `curves` that ended at its seed cap short of the
    /// target.
    fn log_capped(&self, configs: &[ConfigFile], curves: &[Curve]) {
        for (config, curve) in configs.iter().zip(curves) {
            for (p, &t) in curve.tau_stars.iter().enumerate() {
                if !curve.reached[p] {
                    self.cells.log.event(&format!(
                        "capped  tau* {t} beta {}: q* {} ± {} with {} seeds (target not reached)",
                        config.contact.beta, curve.q_star[p], curve.stderr[p], curve.seeds[p]
                    ));
                }
            }
        }
    }

    /// Whether point `p` of `curve` needs no more seeds: its standard error
    /// reaches the target, or its factor to `judge` exceeds the plan's
    /// target factor by twice its relative error.
    fn point_done(&self, curve: &Curve, p: usize, judge: Option<Reference>) -> bool {
        let (q, e) = (curve.q_star[p], curve.stderr[p]);
        if !q.is_finite() || !e.is_finite() {
            return true;
        }
        let target = &self.base.file.target;
        if e <= (target.stderr_relative * q.abs()).max(target.stderr_absolute) {
            return true;
        }
        judge.is_some_and(|reference| {
            let (r, sigma) = curve.log_ratios(reference)[p];
            r.abs() - 2.0 * sigma > self.plan.target_factor.ln()
        })
    }

    /// The curve of the finished cells `chunks` (one chunk of seeds per τ*).
    fn curve_of(
        &self,
        config: &ConfigFile,
        tau_stars: &[f64],
        chunks: &[&[Option<cells::Outcome<crate::work::cell::CellResult>>]],
    ) -> Curve {
        let n_classes = config.grains.classes.as_ref().map_or(1, Vec::len);
        let mut curve = Curve {
            tau_stars: tau_stars.to_vec(),
            q_star: Vec::new(),
            stderr: Vec::new(),
            classes: vec![Vec::new(); n_classes],
            failures: Vec::new(),
            seeds: chunks.iter().map(|c| c.len()).collect(),
            reached: Vec::new(),
        };
        for chunk in chunks {
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
            let (mean, err) = if q.len() == chunk.len() && q.len() == 1 {
                (q[0], crate::science::stats::block_stderr(&blocks).1)
            } else if q.len() == chunk.len() {
                crate::science::stats::mean_stderr(&q)
            } else {
                (f64::NAN, f64::NAN)
            };
            curve.q_star.push(mean);
            curve.stderr.push(err);
            for (k, values) in per_class.iter().enumerate() {
                curve.classes[k].push(crate::science::stats::mean_stderr(values).0);
            }
        }
        curve
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
    let _lock = crate::io::output::lock_dir(dir)?;
    crate::io::output::remove_temporaries(dir)?;
    let store = crate::work::store::Store::open(&dir.join(STORE))?;
    crate::io::output::write_json(&dir.join("plan.json"), &plan)?;
    let progress = crate::io::progress::Progress::counter("cells computed", options.quiet);
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

pub use crate::work::shard::merge;

#[cfg(test)]
mod tests {
    use super::Plan;

    #[test]
    fn threshold_points_get_their_own_seed_cap() {
        let plan = Plan::full();
        assert_eq!(plan.seeds_max(&plan.fine, 0.06), 12);
        assert_eq!(plan.seeds_max(&plan.fine, 0.08), 4);
        assert_eq!(plan.seeds_max(&plan.coarse, 0.06), 1);
    }

    fn curve(factors: &[f64], relative: &[f64]) -> super::Curve {
        let r = crate::science::references::Reference::MeyerPeterMuller;
        let tau_stars = vec![0.1, 0.2];
        let q_star: Vec<f64> = tau_stars
            .iter()
            .zip(factors)
            .map(|(&t, f)| f * r.q_star(t))
            .collect();
        super::Curve {
            stderr: q_star.iter().zip(relative).map(|(q, e)| q * e).collect(),
            q_star,
            tau_stars,
            classes: vec![],
            failures: vec![],
            seeds: vec![4, 4],
            reached: vec![true, true],
        }
    }

    #[test]
    fn the_misfit_weights_each_point_by_its_error() {
        let r = crate::science::references::Reference::MeyerPeterMuller;
        let ln2 = 2f64.ln();
        let exact = curve(&[1.0, 1.0], &[0.0, 0.0]);
        assert_eq!(exact.misfit(r, 0.1), 0.0);
        assert_eq!(exact.mean_log_ratio(r, 0.1), (0.0, 0.0));
        let double = curve(&[2.0, 2.0], &[0.0, 0.3]);
        assert!((double.misfit(r, 0.1) - ln2 * ln2).abs() < 1e-12);
        // A precise point off by 2 (weight 100) and a noisy exact one (σ_r
        // 0.3: weight 10): the precise one dominates.
        let mixed = curve(&[2.0, 1.0], &[0.0, 0.3]);
        assert!((mixed.misfit(r, 0.1) - ln2 * ln2 * 100.0 / 110.0).abs() < 1e-12);
        let (mean, sigma) = mixed.mean_log_ratio(r, 0.1);
        assert!((mean - ln2 * 100.0 / 110.0).abs() < 1e-12);
        assert!((sigma - 0.3 * 10.0 / 110.0).abs() < 1e-12);
        assert!((mixed.misfit_noise(r, 0.1) - 0.09 * 10.0 / 110.0).abs() < 1e-12);
        let mut failed = mixed.clone();
        failed.failures.push("lost".into());
        assert_eq!(failed.misfit(r, 0.1), super::FAILED_MISFIT);
    }
}
