//! The subcommands of `mbs`, each a function from parsed arguments to files
//! and a short report on standard output.

use crate::config::{long_run_warning, warnings, Config, ConfigError, Precision, DEFAULT_TOML};
use crate::error::HostError;
use crate::io::input::read_text_bounded;
use crate::io::log::{Header, Log};
use crate::io::output::{create_dir, write_json, write_text};
use crate::io::progress::Progress;
use crate::report::timeseries::window_warnings;
use crate::report::RunFacts;
use crate::sim::control::MIN_CHECKPOINT_STEPS;
use crate::sim::sims::{with_sim, HostSim, SimJob};
use crate::tools::bench::bench;
use crate::tools::pack::{packing, write_packing, Packing};
use crate::tools::snapshot::{snapshots, write_picture, Snapshots};
use crate::tools::trace::TRACE_BOUND;
use crate::work::experiment::RunControl;
use crate::work::experiment::{aggregate, run_all};
use crate::work::shard::Shard;
use indicatif::ProgressBar;
use mbs_kernel::{Real, Scenario};
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;
use std::time::Instant;

/// Options shared by every subcommand.
#[derive(Debug, Clone, Copy, Default)]
pub struct Common {
    /// No progress bars, no report on standard output.
    pub quiet: bool,
    /// Worker threads (0: one per core).
    pub threads: usize,
}

/// Writes `text` to standard output; a closed pipe (`mbs | head`) is not an error.
pub fn print(text: &str) -> Result<(), HostError> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(HostError::io("<stdout>")(e)),
        _ => Ok(()),
    }
}

pub use crate::io::text::print_err;

/// The configuration's warnings ([`warnings`]) into `log`: printed even
/// when quiet, logged, kept for `summary.json`.
fn report_warnings(config: &Config, log: &Log, under_flow: bool) {
    for w in warnings(config, under_flow) {
        log.warn(&w);
    }
}

/// `out`, else the configuration's output directory; an existing path
/// that is not a directory is refused (`--out /dev/null`, exit 2).
fn output_dir(config: &Config, out: Option<&Path>) -> Result<PathBuf, HostError> {
    match out {
        Some(dir) => directory("--out", dir),
        None => directory("run.output", &config.output),
    }
}

/// `dir`, given as `key`, if it is a directory or does not exist yet;
/// anything else is refused (`--out /dev/null: not a directory`, exit 2).
pub fn directory(key: &str, dir: &Path) -> Result<PathBuf, HostError> {
    if dir.exists() && !dir.is_dir() {
        return Err(ConfigError::Invalid {
            key: key.into(),
            value: dir.display().to_string(),
            allowed: "a directory (it exists and is not one)".into(),
        }
        .into());
    }
    Ok(dir.to_path_buf())
}

/// Opens `dir/mbs.log` for `command` on `config` and runs `f` with it and
/// the configuration's canonical text; the outcome (done, or the error and
/// its exit status) ends the invocation's lines.
fn logged(
    config: &Config,
    dir: &Path,
    command: &'static str,
    resumed: bool,
    f: impl FnOnce(&Log, &str) -> Result<(), HostError>,
) -> Result<(), HostError> {
    let text = config_text(config, dir)?;
    let header = Header {
        command,
        resumed,
        config: &text,
    };
    let log = Log::open(dir, header)?;
    let result = f(&log, &text);
    log.end(&result);
    result
}

/// The canonical text of a configuration (what `DIR/config.toml` holds).
fn config_text(config: &Config, dir: &Path) -> Result<String, HostError> {
    toml::to_string(&config.file)
        .map_err(|e| HostError::io(dir.join(RUN_CONFIG))(std::io::Error::other(e)))
}

/// Threads above this are refused: more than any machine `mbs` runs on
/// has cores, and each worker holds a simulation in memory.
pub const MAX_THREADS: usize = 1024;

/// Checks `--threads`: at most [`MAX_THREADS`] (exit 2 above); more than
/// the machine's cores is a warning (results are the same, not faster).
pub fn check_threads(threads: usize) -> Result<(), HostError> {
    if threads > MAX_THREADS {
        return Err(ConfigError::Invalid {
            key: "--threads".into(),
            value: threads.to_string(),
            allowed: format!("0 (one per core) to {MAX_THREADS}"),
        }
        .into());
    }
    Ok(())
}

/// The warning for `threads` workers on a machine with fewer cores.
fn threads_warning(threads: usize) -> Option<String> {
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    (threads > cores).then(|| {
        format!(
            "--threads {threads} on {cores} core(s): the results are the same, the run is not faster"
        )
    })
}

/// Runs `f` on a rayon pool of `threads` workers (0: rayon's default).
pub fn on_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> Result<T, HostError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| HostError::io("<thread pool>")(std::io::Error::other(e)))?;
    Ok(pool.install(f))
}

/// `mbs config`: the embedded default configuration.
pub fn config() -> Result<(), HostError> {
    print(DEFAULT_TOML)
}

/// Set by Ctrl-C: running cells checkpoint and stop.
static STOP: AtomicBool = AtomicBool::new(false);

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

/// The configuration a run directory was started with (`mbs run --resume`).
pub const RUN_CONFIG: &str = "config.toml";

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
    logged(config, &dir, "run", options.resuming, |log, text| {
        run_logged(config, &dir, text, options, common, log)
    })
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
    if let Some(w) = threads_warning(common.threads) {
        log.warn(&w);
    }
    if let Some(every) = options.checkpoint_every.filter(|&s| s < 1.0) {
        log.warn(&format!(
            "--checkpoint-every {} s: each cell writes a checkpoint at most once per \
             {MIN_CHECKPOINT_STEPS} integration steps",
            crate::io::text::number(every)
        ));
    }
    let started = std::fs::read_to_string(dir.join(RUN_CONFIG)).ok();
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
    let _ = ctrlc::set_handler(|| STOP.store(true, Ordering::Relaxed));
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
    let start = Instant::now();
    let control = RunControl {
        dir,
        every: options.checkpoint_every.map(Duration::from_secs_f64),
        stop: &STOP,
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
                "stopped: {jobs} settling bed(s) or running cell(s) checkpointed in {}/beds and {}/checkpoints; resume with `mbs run --resume {}`",
                dir.display(),
                dir.display(),
                dir.display()
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
    let console = crate::report::write_run(dir, config, &outcome, &rows, &facts)?;
    if !common.quiet {
        print(&console)?;
    }
    Ok(())
}

/// `mbs pack`: the packing test → `packing.csv`, `packing.png`/`.svg`.
pub fn pack(
    config: &Config,
    out: Option<&Path>,
    duration: Option<f64>,
    common: Common,
) -> Result<(), HostError> {
    let dir = output_dir(config, out)?;
    create_dir(&dir)?;
    logged(config, &dir, "pack", false, |log, _| {
        pack_logged(config, &dir, duration, common, log)
    })
}

/// [`pack`] once its log is open.
fn pack_logged(
    config: &Config,
    dir: &Path,
    duration: Option<f64>,
    common: Common,
    log: &Log,
) -> Result<(), HostError> {
    report_warnings(config, log, false);
    let steps = duration.map_or(config.durations.settle, |d| config.steps_of(d));
    let seed = config.seeds[0];
    let every = u64::from(config.scenario.substeps) * 10;
    let progress = Progress::steps(steps, "packing", common.quiet);
    let samples = packing(Packing {
        config,
        seed,
        steps,
        every,
        progress: progress.bar(),
    })?;
    progress.finish();
    let sc = &config.scenario;
    let title = format!(
        "Packing: d = {} mm, {}×{}, α_m = {}, α_cn = {}, β = {}",
        sc.bed.max_diameter() * 1e3,
        sc.bed.columns,
        sc.bed.rows,
        sc.rule.alpha_m,
        sc.rule.alpha_cn,
        sc.rule.beta
    );
    write_packing(dir, &samples, &title)?;
    if let (Some(first), Some(last)) = (samples.first(), samples.last()) {
        log.event(&format!(
            "packed  y_gc {:.4} mm -> {:.4} mm over {:.3} s",
            first.y_gc * 1e3,
            last.y_gc * 1e3,
            last.time
        ));
    }
    if !common.quiet
        && let (Some(first), Some(last)) = (samples.first(), samples.last())
    {
        print(&format!(
                "y_gc {:.4} mm -> {:.4} mm over {:.3} s; kinetic energy at the end {:.3e} J; wrote {}/packing.csv, packing.png, packing.svg\n",
                first.y_gc * 1e3,
                last.y_gc * 1e3,
                last.time,
                last.kinetic_energy,
                dir.display()
            ))?;
    }
    Ok(())
}

/// `mbs snapshot`: pictures and particle frames of the bed under the flow.
pub fn snapshot(
    config: &Config,
    out: Option<&Path>,
    tau_star: f64,
    frames: u64,
    every: f64,
    common: Common,
) -> Result<(), HostError> {
    let dir = output_dir(config, out)?;
    create_dir(&dir)?;
    logged(config, &dir, "snapshot", false, |log, _| {
        report_warnings(config, log, true);
        let every = config.steps_of(every);
        let progress = Progress::steps(
            config.durations.settle + frames * every,
            "snapshot",
            common.quiet,
        );
        let done = snapshots(Snapshots {
            config,
            tau_star,
            seed: config.seeds[0],
            frames,
            every,
            dir: &dir.join("snapshot"),
            progress: progress.bar(),
        })?;
        progress.finish();
        write_picture(&dir, &done.last, &format!("τ* = {tau_star}"))?;
        log.event(&format!("{} frames at tau* {tau_star}", done.frames));
        snapshot_report(&dir, done.frames, common)
    })
}

/// What `mbs snapshot` prints when done.
fn snapshot_report(dir: &Path, frames: usize, common: Common) -> Result<(), HostError> {
    if !common.quiet {
        print(&format!(
            "{frames} frames; wrote {dir}/snapshot/bed_NNNN.vtu (open bed.pvd in ParaView; meshio reads the .vtu files), {dir}/snapshot.png, snapshot.svg\n",
            dir = dir.display()
        ))?;
    }
    Ok(())
}

struct DigestJob {
    scenario: Scenario,
    tau_star: f64,
    steps: (u64, u64),
}

impl SimJob for DigestJob {
    type Output = Result<(u64, u64), mbs_kernel::Error>;

    fn run<R: Real, const N: usize>(self, sim: &mut HostSim<R, N>) -> Self::Output {
        self.scenario
            .digests(sim, self.tau_star, self.steps.0, self.steps.1)
    }
}

/// What `mbs digest --trace` records besides the digests: the file, the
/// configuration's name, and the records' spacing, span and states.
#[derive(Debug, Clone)]
pub struct TraceArgs<'a> {
    /// The trace file to write.
    pub path: &'a Path,
    /// The configuration file's name, `None` for the golden run.
    pub config: Option<String>,
    /// The `--set` overrides on top of it.
    pub overrides: Vec<String>,
    /// Steps between records.
    pub every: u64,
    /// The first recorded step.
    pub from: u64,
    /// The last step run (`None`: both phases).
    pub until: Option<u64>,
    /// Records carry the whole kernel state.
    pub states: bool,
}

/// `mbs digest`: state digests after `steps.0` settling steps and
/// `steps.1` flow steps at τ* — what a board run is compared with; with
/// `trace`, also writes the trace of that run ([`crate::tools::trace`]).
pub fn digest(
    config: &Config,
    steps: (u64, u64),
    precision: Precision,
    tau_star: f64,
    trace: Option<TraceArgs<'_>>,
) -> Result<(), HostError> {
    if let Some(t) = trace {
        let run = crate::tools::trace::TraceRun {
            scenario: config.scenario_at(config.seeds[0]),
            capacity: config.capacity,
            spec: crate::tools::trace::TraceSpec {
                config: t.config,
                overrides: t.overrides,
                tau_star,
                settle_steps: steps.0,
                flow_steps: steps.1,
                every: t.every,
                from: t.from,
                until: t.until.unwrap_or(u64::MAX),
                states: t.states,
                precision,
            },
        };
        if let Err(allowed) = run.fits() {
            return Err(crate::config::ConfigError::Invalid {
                key: "--every".into(),
                value: t.every.to_string(),
                allowed,
            }
            .into());
        }
        let trace = run.run().map_err(trace_error("digest trace"))?;
        let text = crate::tools::trace::to_text(&trace).map_err(|e| HostError::Io {
            path: t.path.to_path_buf(),
            error: e.into(),
        })?;
        write_text(t.path, &text)?;
    }
    let job = DigestJob {
        scenario: config.scenario_at(config.seeds[0]),
        tau_star,
        steps,
    };
    let (settled, flow) = with_sim(precision, config.capacity, job)
        .map_err(HostError::kernel(format!("digest, tau* = {tau_star}")))?;
    print(&format!("settling {settled:#018x}\nflow {flow:#018x}\n"))
}

/// A trace run's error as the command's: the kernel's (exit 1), a nudge
/// that cannot be applied (exit 2, `--nudge`), a trace whose state cannot
/// start the run (exit 2, refused).
fn trace_error(what: &'static str) -> impl Fn(crate::tools::trace::RunError) -> HostError {
    move |e| match e {
        crate::tools::trace::RunError::Kernel(e) => HostError::kernel(what.to_string())(e),
        crate::tools::trace::RunError::Nudge(nudge, e) => crate::ConfigError::Invalid {
            key: "--nudge".into(),
            value: nudge.to_string(),
            allowed: format!(
                "an existing grain and a value that stays finite and inside the domain (here {e})"
            ),
        }
        .into(),
        crate::tools::trace::RunError::State(message) => HostError::Trace {
            path: what.into(),
            message,
        },
    }
}

/// `mbs digest --check FILE [--nudge N]`: re-runs the trace's scenario
/// (changing one value by `nudge`, if given) and compares every record; a
/// mismatch is located ([`crate::tools::trace::check`]) and reported as
/// [`HostError::Mismatch`] (exit 1); a damaged, edited, truncated or
/// foreign trace, or one whose configuration no longer gives its scenario,
/// is refused ([`HostError::Trace`], exit 2).
pub fn check_trace(
    path: &Path,
    nudge: Option<crate::tools::trace::Nudge>,
) -> Result<(), HostError> {
    let refuse = |message: String| HostError::Trace {
        path: path.to_path_buf(),
        message,
    };
    let text = read_text_bounded(path, TRACE_BOUND).map_err(|e| match e.kind() {
        std::io::ErrorKind::InvalidData => refuse(e.to_string()),
        _ => HostError::io(path)(e),
    })?;
    let recorded = crate::tools::trace::parse(&text).map_err(refuse)?;
    let config = match &recorded.spec.config {
        Some(file) => Config::load_with(Some(Path::new(file)), &recorded.spec.overrides)?,
        None => Config::golden_with(&recorded.spec.overrides)?,
    };
    let run = crate::tools::trace::TraceRun {
        scenario: config.scenario_at(config.seeds[0]),
        capacity: config.capacity,
        // The check compares digests; it keeps no states of its own.
        spec: crate::tools::trace::TraceSpec {
            states: false,
            ..recorded.spec.clone()
        },
    };
    let hash = format!("{:#018x}", run.scenario_hash());
    if hash != recorded.scenario_hash {
        return Err(refuse(format!(
            "its scenario hash is {}, the configuration now gives {hash}",
            recorded.scenario_hash
        )));
    }
    let verdict = crate::tools::trace::check(&run, &recorded, nudge).map_err(|e| match e {
        crate::tools::trace::RunError::State(message) => refuse(message),
        e => trace_error("digest --check")(e),
    })?;
    match verdict {
        crate::tools::trace::Verdict::Mismatch(message) => Err(HostError::Mismatch(message)),
        crate::tools::trace::Verdict::Matches(records, last) => print(&format!(
            "trace matches: {records} records, steps {} to {last}\n",
            recorded.spec.from
        )),
    }
}

/// `mbs calibrate`: the calibration into `dir` ([`crate::calibrate`]),
/// logged in `dir/mbs.log`, with `dir/summary.json` (its warnings and
/// wall time); returns what it got to.
pub fn calibrate(
    base: Config,
    dir: &Path,
    options: crate::calibrate::Options,
    threads: usize,
) -> Result<crate::calibrate::Progress, HostError> {
    let dir = directory("--out", dir)?;
    create_dir(&dir)?;
    let mut reached = None;
    let logged_config = base.clone();
    logged(&logged_config, &dir, "calibrate", false, |log, _| {
        let start = Instant::now();
        report_warnings(&base, log, true);
        if let Some(w) = threads_warning(threads) {
            log.warn(&w);
        }
        let progress = on_pool(threads, || {
            crate::calibrate::calibrate(base, &dir, options, log)
        })??;
        let stages = match &progress {
            crate::calibrate::Progress::Done { stages, .. } => *stages,
            crate::calibrate::Progress::Waiting { stage } => stage - 1,
        };
        log.event(&format!("stages 1-{stages} done"));
        write_json(
            &dir.join("summary.json"),
            &CalibrationSummary {
                program: "mbs",
                version: env!("CARGO_PKG_VERSION"),
                command: "calibrate",
                stages_done: stages,
                wall_time_s: start.elapsed().as_secs_f64(),
                warnings: log.warnings(),
            },
        )?;
        reached = Some(progress);
        Ok(())
    })?;
    reached.ok_or_else(|| HostError::io(&dir)(std::io::Error::other("no calibration result")))
}

/// `summary.json` of `mbs calibrate`.
#[derive(Serialize)]
struct CalibrationSummary {
    program: &'static str,
    version: &'static str,
    command: &'static str,
    /// Stages finished (all of them, or those before the one waiting for
    /// other shards).
    stages_done: usize,
    /// Wall time of this invocation.
    wall_time_s: f64,
    /// The warnings (also on standard error and in `mbs.log`).
    warnings: Vec<String>,
}

/// `mbs bench`: ns per grain-step of one case on a prepared bed.
pub fn bench_command(
    precision: Precision,
    job: crate::tools::bench::Bench<'_>,
    common: Common,
) -> Result<(), HostError> {
    let spinner = if common.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new_spinner()
    };
    spinner.set_message("preparing the bed, then timing");
    spinner.enable_steady_tick(std::time::Duration::from_millis(200));
    let (case, beta) = (job.case, job.bed.beta);
    let sc = job.bed.scenario(job.bed.columns());
    // A physics warning: printed even when quiet.
    if precision == Precision::F32
        && let Some(w) = crate::config::f32_width_warning(sc.bed.width(), sc.step_dt())
    {
        print_err(&format!("warning: {w}"));
    }
    let r = bench(precision, job);
    spinner.finish_and_clear();
    let r = r?;
    print(&format!(
        "{} grains, {:?}, beta {}, {}: {:.1} ns per grain-step over {} repetitions ({} rounds: min {:.1}, median {:.1}, max {:.1}), {:.2} contacts per grain, {} neighbour rebuilds ({:.0} % of the time in the steps that rebuilt)\n",
        r.grains,
        precision,
        beta,
        case.name(),
        r.ns_per_grain_step,
        r.repetitions,
        r.rounds,
        r.ns_spread.0,
        r.ns_spread.1,
        r.ns_spread.2,
        r.contacts_per_grain,
        r.rebuilds,
        100.0 * r.rebuild_share
    ))
}
