//! What every subcommand uses: the shared options, the output directory,
//! the log, the thread pool, standard output.

use crate::config::{warnings, Config, ConfigError};
use crate::error::HostError;
use crate::io::log::{Header, Log};
use clap::Args;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Options a subcommand offers where they apply (each subcommand hides
/// the others, still accepted as before).
#[derive(Args, Clone, Default)]
pub struct Shared {
    /// No progress and no report on standard output (warnings are still printed).
    #[arg(long, short)]
    pub quiet: bool,
    /// Worker threads (0: one per core; at most 1024). Results do not depend on it.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Override one configuration key, e.g. --set flow.tau_star=[0.1,0.2]
    /// (repeatable; checked like the file, saved in DIR/config.toml).
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    pub sets: Vec<String>,
}

impl Shared {
    /// These options given before the subcommand together with `sub`, given after it.
    pub fn and(self, sub: Shared) -> Shared {
        Shared {
            quiet: self.quiet || sub.quiet,
            threads: if sub.threads != 0 {
                sub.threads
            } else {
                self.threads
            },
            sets: [self.sets, sub.sets].concat(),
        }
    }
}

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
pub(crate) fn report_warnings(config: &Config, log: &Log, under_flow: bool) {
    for w in warnings(config, under_flow) {
        log.warn(&w);
    }
}

/// `out`, else the configuration's output directory; an existing path
/// that is not a directory is refused (`--out /dev/null`, exit 2).
pub(crate) fn output_dir(config: &Config, out: Option<&Path>) -> Result<PathBuf, HostError> {
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
pub(crate) fn logged(
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
pub(crate) fn config_text(config: &Config, dir: &Path) -> Result<String, HostError> {
    toml::to_string(&config.file)
        .map_err(|e| HostError::io(dir.join(RUN_CONFIG))(std::io::Error::other(e)))
}

pub use crate::io::output::RUN_CONFIG;

pub use crate::config::MAX_THREADS;

/// Checks `--threads`: at most [`MAX_THREADS`] (exit 2 above); more than
/// the machine's cores is a warning (results are the same, not faster).
/// Without it (0), the pool takes rayon's `RAYON_NUM_THREADS` (or its
/// older `RAYON_RS_NUM_CPUS`) from the environment: each is checked the
/// same way, read as rayon reads it (a positive whole number, else
/// ignored). `mbs bench` and a bed's own threads do not read them.
pub fn check_threads(threads: usize) -> Result<(), HostError> {
    let from_env = |name: &'static str| {
        let n = std::env::var(name).ok()?.parse::<usize>().ok()?;
        (n > 0).then_some((name, n))
    };
    let given = [("--threads", threads)];
    let env = if threads == 0 {
        ["RAYON_NUM_THREADS", "RAYON_RS_NUM_CPUS"].map(from_env)
    } else {
        [None, None]
    };
    for (key, n) in given.into_iter().chain(env.into_iter().flatten()) {
        if n > MAX_THREADS {
            return Err(ConfigError::Invalid {
                key: key.into(),
                value: n.to_string(),
                allowed: format!("0 (one per core) to {MAX_THREADS}"),
            }
            .into());
        }
    }
    Ok(())
}

/// The warning for `threads` workers (the pool's, `--threads` or the
/// environment's) on a machine with fewer cores.
pub(crate) fn threads_warning(threads: usize) -> Option<String> {
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    (threads > cores).then(|| {
        format!(
            "{threads} threads on {cores} core(s): the results are the same, the run is not faster"
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

/// What every subcommand gets from the shared options: [`Common`] and the
/// `--set` overrides.
pub struct Invocation {
    /// Quiet, threads.
    pub common: Common,
    /// `--set SECTION.KEY=VALUE`, in order.
    pub sets: Vec<String>,
}

impl Invocation {
    /// The configuration `path` (the embedded default without one), with
    /// the `--set` overrides.
    pub fn load(&self, path: Option<&Path>) -> Result<Config, HostError> {
        Config::load_with(path, &self.sets).map_err(HostError::from)
    }

    /// Refuses `--set` where `why` says it does not apply.
    pub fn refuse_sets(&self, why: &str) -> Result<(), HostError> {
        if self.sets.is_empty() {
            return Ok(());
        }
        Err(ConfigError::Invalid {
            key: "--set".into(),
            value: self.sets.join(" "),
            allowed: why.into(),
        }
        .into())
    }
}

/// Checks a Shields number given on the command line.
pub fn tau_arg(tau: f64) -> Result<f64, HostError> {
    Ok(crate::config::tau_star_arg("--tau", tau)?)
}

/// Checks a physical time given on the command line: in (0, 1000] s, the
/// limit of the configuration's phases ([`crate::config::MAX_PHASE_S`]).
pub fn seconds_arg(key: &str, seconds: f64) -> Result<(), HostError> {
    let max = crate::config::MAX_PHASE_S;
    if seconds > 0.0 && seconds <= max {
        Ok(())
    } else {
        Err(ConfigError::Invalid {
            key: key.into(),
            value: crate::io::text::number(seconds),
            allowed: format!("in (0, {max}] s of physical time"),
        }
        .into())
    }
}
