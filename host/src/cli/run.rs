//! `mbs run`: the main job, q*(τ*) over seeds, resumable.

use super::common::logged;
use super::common::on_pool;
use super::common::output_dir;
use super::common::print;
use super::common::print_err;
use super::common::report_warnings;
use super::common::threads_warning;
use super::common::Common;
use super::common::Invocation;
use super::common::Shared;
use super::common::RUN_CONFIG;
use crate::config::long_run_warning;
use crate::config::Config;
use crate::error::ConfigError;
use crate::error::HostError;
use crate::io::log::Log;
use crate::io::output::write_text;
use crate::io::progress::Progress;
use crate::report::timeseries::window_warnings;
use crate::report::RunFacts;
use crate::sim::control::MIN_CHECKPOINT_STEPS;
use crate::work::experiment::aggregate;
use crate::work::experiment::run_all;
use crate::work::experiment::RunControl;
use crate::work::shard::Shard;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::atomic::Ordering;
use std::time::Duration;
use std::time::Instant;

use clap::Args;
use std::path::PathBuf;

/// The arguments of `mbs run`.
#[allow(rustdoc::invalid_html_tags)]
#[derive(Args, Default)]
pub struct RunArgs {
    /// Shared options.
    #[command(flatten)]
    pub shared: Shared,
    /// Configuration file (TOML); the embedded paper's case when omitted.
    #[arg(conflicts_with = "resume")]
    pub config: Option<PathBuf>,
    /// Output directory (default: run.output of the configuration).
    #[arg(long, conflicts_with = "resume")]
    pub out: Option<PathBuf>,
    /// Continue an interrupted run in DIR with the configuration it started with.
    #[arg(long, value_name = "DIR")]
    pub resume: Option<PathBuf>,
    /// Checkpoint every running cell every SECONDS of wall time, and at most once per
    /// 2000 integration steps of a cell (Ctrl-C always checkpoints).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub checkpoint_every: Option<f64>,
    /// Stop every cell after N steps as if interrupted (for tests of resuming).
    #[arg(long, hide = true)]
    pub stop_after_steps: Option<u64>,
    /// Compute only slice I of N of the cells (I = 1..N), e.g. a Slurm array
    /// task; `mbs merge` joins the slices.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<Shard>,
    /// Write particle frames (XML VTK, for ParaView and meshio) of each computed
    /// cell every SECONDS of simulated time under the flow, from the flow's start
    /// (time 0), to DIR/frames/tau<τ*>_seed<seed>/frames.pvd; at least one
    /// integration step, at most time.window. Cells reused from cells.jsonl
    /// write none; a resumed cell continues its frames.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub dump_every: Option<f64>,
}

impl RunArgs {
    /// Checks the arguments, loads the configuration (or the resumed
    /// run's) and runs.
    pub fn execute(self, how: &Invocation) -> Result<(), HostError> {
        // Wall-clock seconds; 1e9 s is 32 years.
        if let Some(s) = self.checkpoint_every.filter(|s| !(*s > 0.0 && *s <= 1e9)) {
            return Err(ConfigError::Invalid {
                key: "--checkpoint-every".into(),
                value: crate::io::text::number(s),
                allowed: "in (0, 1e9] seconds of wall time".into(),
            }
            .into());
        }
        let options = RunOptions {
            checkpoint_every: self.checkpoint_every,
            stop_after_steps: self.stop_after_steps,
            resuming: self.resume.is_some(),
            shard: self.shard.unwrap_or(Shard::ALL),
            dump_every: self.dump_every,
            stop: None,
            progress_to: None,
        };
        let (config, out) = match self.resume {
            Some(dir) => {
                how.refuse_sets(
                    "not with --resume: a resumed run keeps the configuration it started with",
                )?;
                (resumed_config(&dir)?, Some(dir))
            }
            None => (how.load(self.config.as_deref())?, self.out),
        };
        run(&config, out.as_deref(), options, how.common)
    }
}

/// Set by Ctrl-C: running cells checkpoint and stop.
static STOP: AtomicBool = AtomicBool::new(false);

/// Set once every cell is stored and the tables and figures are being
/// written: Ctrl-C (or SIGTERM) then ends the process at once, exit 130 —
/// a rerun writes them again from the store, and every file is replaced
/// atomically, so none is left half-written.
static REPORTING: AtomicBool = AtomicBool::new(false);

/// The Ctrl-C and SIGTERM handler: checkpoint and stop while cells run,
/// end at once while the reports are written.
fn on_signal() {
    if REPORTING.load(Ordering::Relaxed) {
        print_err("stopped while writing the tables and figures: every cell is stored; run the same command again to write them");
        std::process::exit(130);
    }
    STOP.store(true, Ordering::Relaxed);
}

/// Options of `mbs run` beyond the configuration.
#[derive(Debug, Clone, Copy, Default)]
pub struct RunOptions {
    /// Wall-clock seconds between checkpoints of each running cell.
    pub checkpoint_every: Option<f64>,
    /// Stop every cell after this many steps, as if interrupted (tests).
    pub stop_after_steps: Option<u64>,
    /// `--resume`: the configuration is the run directory's own.
    pub resuming: bool,
    /// `--shard I/N`: compute only this slice of the cells, write no table.
    pub shard: Shard,
    /// `--dump-every SECONDS`: particle frames of each computed cell every
    /// SECONDS of simulated time under the flow ([`dump_steps`]).
    pub dump_every: Option<f64>,
    /// A stop flag the caller sets (a library user, e.g. Python on
    /// KeyboardInterrupt): running cells checkpoint and stop as on Ctrl-C,
    /// and no signal handler is installed. `None`: Ctrl-C and SIGTERM.
    pub stop: Option<&'static AtomicBool>,
    /// Where to hand a handle on the run's progress bar (steps done and
    /// their total), for a library user's own display (Python's tqdm).
    pub progress_to: Option<&'static std::sync::Mutex<Option<indicatif::ProgressBar>>>,
}

/// `--dump-every SECONDS` in integration steps (rounded): from one
/// integration step to the longest window (`time.window`), else a
/// configuration error (exit 2).
pub fn dump_steps(config: &Config, seconds: f64) -> Result<u64, HostError> {
    let step_dt = config.scenario.step_dt();
    let most = config.durations.window();
    let steps = seconds / step_dt;
    // A float-to-int cast saturates; NaN and infinities fail the range.
    if seconds.is_finite() && steps >= 1.0 - 1e-9 && (steps.round() as u64) <= most {
        return Ok((steps.round() as u64).max(1));
    }
    Err(ConfigError::Invalid {
        key: "--dump-every".into(),
        value: crate::io::text::number(seconds),
        allowed: format!(
            "from one integration step (step_dt = constants_dt/substeps = {} s) to time.window ({} s) of simulated time",
            crate::io::text::number(step_dt),
            crate::io::text::number(most as f64 * step_dt)
        ),
    }
    .into())
}

/// The configuration an interrupted run in `dir` started with
/// (`mbs run --resume DIR`); a directory without one holds nothing to resume.
pub fn resumed_config(dir: &Path) -> Result<Config, HostError> {
    let path = dir.join(RUN_CONFIG);
    if !path.is_file() {
        let why = format!(
            "nothing to resume here: no run was started with `mbs run CONFIG --out {}`",
            dir.display()
        );
        return Err(ConfigError::Read {
            path,
            source: std::io::Error::new(std::io::ErrorKind::NotFound, why),
        }
        .into());
    }
    Ok(Config::load(Some(&path))?)
}

/// `mbs run`: q*(τ*) over seeds → `transport.csv`, `transport.png`/`.svg`,
/// `summary.json` in `out` (or the configuration's `run.output`). Finished
/// cells are kept in `cells.jsonl` and reused; running cells checkpoint
/// every `checkpoint_every` seconds and on Ctrl-C.
pub fn run(
    config: &Config,
    out: Option<&Path>,
    options: RunOptions,
    common: Common,
) -> Result<(), HostError> {
    if let Some(seconds) = options.dump_every {
        dump_steps(config, seconds)?;
    }
    let dir = output_dir(config, out)?;
    let _lock = crate::io::output::lock_dir(&dir)?;
    crate::io::output::not_holding(&dir, crate::calibrate::PLAN, "mbs calibrate")?;
    logged(config, &dir, "run", options.resuming, |log, text| {
        run_logged(config, &dir, text, options, common, log)
    })
}

/// The whole command that resumes a run stopped in `dir`: `--resume DIR`
/// with the options the directory does not keep (the slice of a shard,
/// the frames' and the checkpoints' intervals), so that following the hint
/// loses nothing.
pub fn resume_command(dir: &Path, options: &RunOptions) -> String {
    let mut command = format!("mbs run --resume {}", dir.display());
    if !options.shard.is_all() {
        let Shard { index, count } = options.shard;
        command += &format!(" --shard {}/{count}", index + 1);
    }
    if let Some(s) = options.dump_every {
        command += &format!(" --dump-every {}", crate::io::text::number(s));
    }
    if let Some(s) = options.checkpoint_every {
        command += &format!(" --checkpoint-every {}", crate::io::text::number(s));
    }
    command
}

/// [`run`] once its directory is locked and its log open.
fn run_logged(
    config: &Config,
    dir: &Path,
    text: &str,
    options: RunOptions,
    common: Common,
    log: &Log,
) -> Result<(), HostError> {
    report_warnings(config, log, true);
    let threads = on_pool(common.threads, rayon::current_num_threads)?;
    if let Some(w) = long_run_warning(config, threads) {
        log.warn(&w);
    }
    if let Some(w) = threads_warning(threads) {
        log.warn(&w);
    }
    if let Some(every) = options.checkpoint_every.filter(|&s| s < 1.0) {
        log.warn(&format!(
            "--checkpoint-every {} s: each cell writes a checkpoint at most once per \
             {MIN_CHECKPOINT_STEPS} integration steps",
            crate::io::text::number(every)
        ));
    }
    let started =
        crate::io::input::read_own_text_bounded(&dir.join(RUN_CONFIG), crate::config::CONFIG_BOUND)
            .ok();
    let has_checkpoints = std::fs::read_dir(dir.join("checkpoints"))
        .map(|mut d| d.next().is_some())
        .unwrap_or(false);
    // The parsed configurations are compared, not their text: a comment or a
    // missing final newline in DIR/config.toml is the same run.
    let same = |old: &String| Config::from_toml(old).is_ok_and(|c| c.file == config.file);
    if started.as_ref().is_some_and(|old| !same(old)) && has_checkpoints {
        // Resuming, the configuration was read from that very file: it
        // changed meanwhile (another program wrote it).
        let advice = if options.resuming {
            format!("{RUN_CONFIG} changed while it was being read; run the same command again")
        } else {
            format!(
                "resume it with `mbs run --resume {}` or choose another --out",
                dir.display()
            )
        };
        return Err(HostError::Checkpoint {
            path: dir.join("checkpoints"),
            message: format!(
                "{} holds an interrupted run of another configuration ({RUN_CONFIG}); {advice}",
                dir.display(),
            ),
        });
    }
    write_text(&dir.join(RUN_CONFIG), text)?;
    // A second handler cannot be installed (e.g. in-process tests); Ctrl-C then just kills.
    if options.stop.is_none() {
        let _ = ctrlc::set_handler(on_signal);
    }
    let cells = (0..config.tau_stars.len() * config.seeds.len())
        .filter(|&k| options.shard.owns(k))
        .count() as u64;
    // Beds may come to rest before time.settle: the bar's length is the most.
    let beds = config.seeds.len() as u64 * config.durations.settle;
    let progress = Progress::steps(
        beds + cells * config.durations.cell(),
        &format!("cells 0/{cells}"),
        common.quiet,
    );
    if let Some(Ok(mut slot)) = options.progress_to.map(|m| m.lock()) {
        *slot = Some(progress.bar().clone());
    }
    let start = Instant::now();
    let control = RunControl {
        dir,
        every: options.checkpoint_every.map(Duration::from_secs_f64),
        stop: options.stop.unwrap_or(&STOP),
        stop_after: options.stop_after_steps,
        shard: options.shard,
        log,
        dump_every: options
            .dump_every
            .map(|s| dump_steps(config, s))
            .transpose()?,
    };
    let outcome = on_pool(common.threads, || run_all(config, progress.bar(), &control))?;
    progress.finish();
    let outcome = match outcome {
        Err(HostError::Interrupted { jobs }) => {
            print_err(&format!(
                "stopped: {jobs} settling bed(s) or running cell(s) checkpointed in {}/beds and {}/checkpoints; resume with `{}`",
                dir.display(),
                dir.display(),
                resume_command(dir, &options)
            ));
            return Err(HostError::Interrupted { jobs });
        }
        other => other?,
    };
    let results = &outcome.results;
    let rows = aggregate(config, results);
    if options.shard.is_all() {
        for w in window_warnings(config, &rows) {
            log.warn(&w);
        }
    }
    if !options.shard.is_all() {
        if common.quiet {
            return Ok(());
        }
        let Shard { index, count } = options.shard;
        return print(&format!(
            "shard {}/{count}: {} cells in {}/cells.jsonl; merge the shards with `mbs merge DIRS --out DIR`, then `mbs run CONFIG --out DIR` writes the table\n",
            index + 1,
            results.len(),
            dir.display()
        ));
    }
    let facts = RunFacts {
        threads,
        wall_time_s: start.elapsed().as_secs_f64(),
        warnings: log.warnings(),
    };
    REPORTING.store(true, Ordering::Relaxed);
    let console = crate::report::write_run(dir, config, &outcome, &rows, &facts);
    REPORTING.store(false, Ordering::Relaxed);
    let console = console?;
    if !common.quiet {
        print(&console)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hint after Ctrl-C gives every option the directory does not
    /// keep: following it, a shard stays a shard and frames go on.
    #[test]
    fn the_resume_hint_is_the_whole_command() {
        let dir = Path::new("out");
        assert_eq!(
            resume_command(dir, &RunOptions::default()),
            "mbs run --resume out"
        );
        let options = RunOptions {
            shard: Shard { index: 1, count: 3 },
            dump_every: Some(0.01),
            checkpoint_every: Some(30.0),
            ..RunOptions::default()
        };
        assert_eq!(
            resume_command(dir, &options),
            "mbs run --resume out --shard 2/3 --dump-every 0.01 --checkpoint-every 30"
        );
    }
}
