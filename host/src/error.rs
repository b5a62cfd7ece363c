//! Every way the `mbs` command can fail, and its exit status.

use crate::io::text::number;
use std::fmt;
use std::path::PathBuf;

/// An error of the host.
#[derive(Debug)]
pub enum HostError {
    /// A bad configuration or command line: exit status 2; checked before
    /// anything is written (a calibration stage's own bad cell is a failed
    /// cell instead).
    Config(ConfigError),
    /// The kernel refused or failed a run.
    Kernel {
        /// What was being run, e.g. `τ* = 0.4, seed 2`.
        context: String,
        /// The kernel's error (names step, grain and value).
        error: mbs_kernel::Error,
    },
    /// A file could not be written or read.
    Io {
        /// The file or directory.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// The output directory is locked by another live `mbs` (exit status 1:
    /// the command is valid, the directory is busy; run it again later or
    /// choose another one).
    Busy {
        /// The directory.
        dir: PathBuf,
        /// The holder's process id, as it wrote it in the lock file.
        holder: Option<u32>,
    },
    /// Beds or cells stopped (Ctrl-C or a test's step budget) after writing
    /// their checkpoints.
    Interrupted {
        /// How many.
        jobs: usize,
    },
    /// A checkpoint file was refused; nothing was changed.
    Checkpoint {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// A calibration stage cannot proceed (e.g. no candidate settles).
    Calibration(String),
    /// A trace file is damaged, edited, truncated or foreign (exit 2).
    Trace {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// A re-run does not reproduce a trace (exit 1): where it first differs.
    Mismatch(String),
    /// A plot could not be drawn.
    Plot {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
}

impl HostError {
    /// Process exit status: 2 for bad input, 1 for a failed run.
    pub fn exit_code(&self) -> u8 {
        match self {
            HostError::Config(_) | HostError::Trace { .. } => 2,
            HostError::Interrupted { .. } => 130,
            _ => 1,
        }
    }

    /// Wraps a kernel error with what was being run.
    pub fn kernel(context: impl Into<String>) -> impl FnOnce(mbs_kernel::Error) -> HostError {
        let context = context.into();
        move |error| HostError::Kernel { context, error }
    }

    /// Wraps an I/O error with its path.
    pub fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> HostError {
        let path = path.into();
        move |error| HostError::Io { path, error }
    }
}

impl fmt::Display for HostError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HostError::Config(e) => write!(f, "configuration: {e}"),
            HostError::Kernel { context, error } => write!(f, "{context}: {error}"),
            HostError::Io { path, error } => write!(f, "{}: {error}", path.display()),
            HostError::Calibration(message) => write!(f, "calibration: {message}"),
            HostError::Busy { dir, holder } => write!(
                f,
                "{} is in use by another mbs ({}); wait for it to finish or choose another output directory",
                dir.display(),
                holder.map_or_else(|| "process id unknown".into(), |p| format!("process {p}"))
            ),
            HostError::Interrupted { jobs } => write!(
                f,
                "interrupted: {jobs} settling bed(s) or running cell(s) checkpointed; finished cells are stored"
            ),
            HostError::Checkpoint { path, message } => write!(
                f,
                "{}: checkpoint refused: {message}; nothing changed (delete the file to run that cell afresh)",
                path.display()
            ),
            HostError::Plot { path, message } => write!(f, "{}: {message}", path.display()),
            HostError::Trace { path, message } => {
                write!(f, "{}: trace refused: {message}", path.display())
            }
            HostError::Mismatch(message) => write!(f, "trace mismatch: {message}"),
        }
    }
}

impl std::error::Error for HostError {}

impl From<ConfigError> for HostError {
    fn from(e: ConfigError) -> Self {
        HostError::Config(e)
    }
}

/// A configuration that cannot be used. Nothing has been written when this
/// is returned.
#[derive(Debug)]
pub enum ConfigError {
    /// The file could not be read.
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not TOML, an unknown key, or a value of the wrong type.
    Parse(String),
    /// A value outside its allowed range.
    Invalid {
        /// Dotted key, e.g. `grains.diameter_mm`.
        key: String,
        /// The value as given.
        value: String,
        /// The allowed range.
        allowed: String,
    },
    /// A value the kernel's own validation refused.
    Kernel {
        /// The configuration key it came from, e.g. `flow.fluid_density`.
        key: &'static str,
        /// The kernel's error (value and allowed range).
        source: mbs_kernel::Error,
    },
    /// One of the errors above, with where the value was given: a line
    /// of the configuration file or a `--set`.
    Given {
        /// The error.
        error: Box<ConfigError>,
        /// Where, e.g. `--set flow.kappa=2` or `case.toml line 12`.
        at: String,
    },
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConfigError::Read { path, source } => write!(f, "{}: {source}", path.display()),
            ConfigError::Parse(message) => write!(f, "{}", message.trim_end()),
            ConfigError::Invalid {
                key,
                value,
                allowed,
            } => write!(f, "{key} = {value}: must be {allowed}"),
            ConfigError::Kernel {
                key,
                source: mbs_kernel::Error::InvalidParameter { value, allowed, .. },
            } => write!(f, "{key} = {}: must be {allowed}", number(*value)),
            ConfigError::Kernel { key, source } => write!(f, "{key}: {source}"),
            ConfigError::Given { error, at } => write!(f, "{error} (given by {at})"),
        }
    }
}

impl std::error::Error for ConfigError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ConfigError::Read { source, .. } => Some(source),
            ConfigError::Kernel { source, .. } => Some(source),
            ConfigError::Given { error, .. } => Some(error.as_ref()),
            _ => None,
        }
    }
}
