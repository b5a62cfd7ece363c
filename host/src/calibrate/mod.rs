//! `mbs calibrate`: the paper's parameter optimisation (docs/model.md §9),
//! automated.
//!
//! | stage | what | paper |
//! |---|---|---|
//! | 1 | α_m by the fastest settling of a packed bed (α_cn = 1, β = 1) | 20 |
//! | 2 | α_cn the same way, α_m fixed | 1.3 |
//! | 3 | β minimising the q*(τ*) misfit to a reference, coarse then fine | 15.8 |
//! | 4 | constants_dt for other grain sizes d and layer thicknesses nvd | 9.0e-6 s at d = 0.1 mm |
//! | 5 | a mixed bed: fractional transport per size class | — |
//!
//! Every simulation is a cell ([`cells`]) stored as it finishes ([`crate::work::store`]);
//! a stage is recomputed from the store on every invocation, so an
//! interrupted calibration resumes where it stopped and a sharded one is
//! completed by merging the shards' stores.

pub mod calibrated;
pub mod cells;
pub mod curve;
pub mod optimise;
pub mod plan;
pub mod report;
pub mod stages;

pub use curve::{Curve, FAILED_MISFIT, Q_FLOOR};
pub use plan::{Fidelity, Plan, Slots};

use crate::config::{Config, ConfigFile, WindowUntil};
use crate::error::HostError;
use crate::io::log::Log;
use crate::science::references::Reference;
use cells::{Cells, TransportSpec};

/// The calibration's plan in its output directory (only `mbs calibrate`
/// writes it).
pub const PLAN: &str = "plan.json";

use crate::work::store::STORE;

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
                c.time.window_until = WindowUntil::Steady;
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
    /// target factor by more than its 95 % interval (t quantile of its
    /// degrees of freedom), so that more seeds would not change the
    /// verdict.
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
            let dof = curve.dof.get(p).copied().unwrap_or(0);
            r.abs() - crate::science::interval::t95(dof) * sigma > self.plan.target_factor.ln()
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
            dof: Vec::new(),
            classes: vec![Vec::new(); n_classes],
            class_stderr: vec![Vec::new(); n_classes],
            failures: Vec::new(),
            seeds: chunks.iter().map(|c| c.len()).collect(),
            reached: Vec::new(),
        };
        for chunk in chunks {
            let mut cells = Vec::new();
            for r in chunk.iter().flatten() {
                match r {
                    Ok(c) => cells.push(c),
                    Err(message) => curve.failures.push(message.clone()),
                }
            }
            // As in `mbs run`: the seeds' spread, or one seed's batch means.
            let (mean, err, dof) = if cells.len() == chunk.len() {
                let i = crate::work::experiment::q_star_interval(&cells);
                (i.mean, i.stderr, i.dof)
            } else {
                (f64::NAN, f64::NAN, 0)
            };
            let per_class: Vec<Vec<f64>> = (0..n_classes)
                .map(|k| {
                    cells
                        .iter()
                        .filter_map(|c| c.q_star_class.get(k).copied())
                        .collect()
                })
                .collect();
            curve.q_star.push(mean);
            curve.stderr.push(err);
            curve.dof.push(dof);
            for (k, values) in per_class.iter().enumerate() {
                let (mean, stderr) = crate::science::interval::mean_stderr(values);
                curve.classes[k].push(mean);
                curve.class_stderr[k].push(if stderr.is_finite() { stderr } else { 0.0 });
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
pub enum Reached {
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
) -> Result<Reached, HostError> {
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
    crate::io::output::write_json(&dir.join(PLAN), &plan)?;
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
    let waiting = |stage| Ok(Reached::Waiting { stage });
    stage("stage 1 (α_m)");
    let Some(s1) = settling::run(&ctx, 1, ctx.base.scenario.rule.alpha_m)? else {
        return waiting(1);
    };
    if options.last_stage < 2 {
        return Ok(Reached::Done {
            stages: 1,
            calibrated: None,
        });
    }
    stage("stage 2 (α_cn)");
    let Some(s2) = settling::run(&ctx, 2, s1.chosen)? else {
        return waiting(2);
    };
    if options.last_stage < 3 {
        return Ok(Reached::Done {
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
        return Ok(Reached::Done {
            stages: 3,
            calibrated: Some(write_calibrated(None)?),
        });
    }
    stage("stage 4 (constants_dt for d and nvd)");
    let Some(s4) = timestep::run(&ctx, s1.chosen, s2.chosen, s3.beta)? else {
        return waiting(4);
    };
    if options.last_stage < 5 {
        return Ok(Reached::Done {
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
    Ok(Reached::Done {
        stages: 5,
        calibrated: Some(write_calibrated(Some(&s4))?),
    })
}

pub use crate::work::shard::merge;
