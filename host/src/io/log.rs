//! `DIR/mbs.log`: what a command did, one event per line, each line led by
//! its UTC time (RFC 3339) and written through at once, so a killed job
//! leaves its log; and the warnings of a command, printed, logged and kept
//! for `summary.json`. A [`Log`] is shared by the worker threads.
//!
//! Every invocation appends to the directory's log: a line `=== mbs …
//! started` (or `… resumed` for `mbs run --resume`), then the command line,
//! the version and the configuration's hash.

use crate::error::HostError;
use std::fs::File;
use std::io::Write;
use std::path::Path;
use std::sync::Mutex;
use std::time::{SystemTime, UNIX_EPOCH};

/// The log's file name in an output directory.
pub const LOG: &str = "mbs.log";

/// A command's log and warnings.
#[derive(Debug, Default)]
pub struct Log {
    /// `DIR/mbs.log` opened for appending (`None`: warnings only).
    file: Option<Mutex<File>>,
    /// The warnings so far, in order.
    warnings: Mutex<Vec<String>>,
}

/// What the first lines of an invocation's log say.
#[derive(Debug, Clone, Copy)]
pub struct Header<'a> {
    /// The subcommand (`run`, `calibrate`, `pack`, `snapshot`).
    pub command: &'a str,
    /// `mbs run --resume`: the separator says "resumed".
    pub resumed: bool,
    /// The configuration as TOML (as `mbs run` saves it in
    /// `DIR/config.toml`): its FNV-1a is logged.
    pub config: &'a str,
}

impl Log {
    /// A log that writes no file: warnings are printed and kept only.
    pub fn discard() -> Log {
        Log::default()
    }

    /// Opens `dir/mbs.log` for appending (created if missing) and writes
    /// the invocation's header.
    pub fn open(dir: &Path, header: Header<'_>) -> Result<Log, HostError> {
        let path = dir.join(LOG);
        let file = crate::io::output::open_own(
            &path,
            std::fs::OpenOptions::new().create(true).append(true),
        )?;
        let log = Log {
            file: Some(Mutex::new(file)),
            warnings: Mutex::default(),
        };
        let how = if header.resumed { "resumed" } else { "started" };
        log.event(&format!("=== mbs {} {how}", header.command));
        log.event(&format!("command {}", command_line()));
        log.event(&format!("version {}", version()));
        log.event(&format!(
            "config fnv1a {:#018x} (of the configuration as TOML)",
            mbs_kernel::Fnv1a::of(header.config.as_bytes()),
        ));
        Ok(log)
    }

    /// Appends `text` as one line after the current time. A log that
    /// cannot be written does not stop the command (its outputs can).
    pub fn event(&self, text: &str) {
        if let Some(file) = &self.file {
            let line = format!("{}  {}\n", utc_now(), text.replace('\n', " | "));
            if let Ok(mut f) = file.lock() {
                let _ = f.write_all(line.as_bytes());
            }
        }
    }

    /// A warning: printed on standard error (even with `--quiet`), logged
    /// and kept for [`Log::warnings`].
    pub fn warn(&self, text: &str) {
        crate::io::text::print_err(&format!("warning: {text}"));
        self.event(&format!("warning {text}"));
        if let Ok(mut w) = self.warnings.lock() {
            w.push(text.to_string());
        }
    }

    /// The warnings so far, in order.
    pub fn warnings(&self) -> Vec<String> {
        self.warnings.lock().map(|w| w.clone()).unwrap_or_default()
    }

    /// Logs how the command ended: `done` or the error with its exit status.
    pub fn end(&self, result: &Result<(), HostError>) {
        match result {
            Ok(()) => self.event("done (exit 0)"),
            Err(e) => self.event(&format!("error (exit {}) {e}", e.exit_code())),
        }
    }
}

/// The command line, arguments with spaces or quotes quoted.
fn command_line() -> String {
    std::env::args_os()
        .map(|a| {
            let a = a.to_string_lossy().to_string();
            if a.is_empty() || a.contains([' ', '"', '\'', '\t']) {
                format!("{a:?}")
            } else {
                a
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// `mbs VERSION`, with the git commit when the build recorded one.
pub fn version() -> String {
    match option_env!("MBS_GIT_COMMIT") {
        Some(commit) => format!("mbs {} (commit {commit})", env!("CARGO_PKG_VERSION")),
        None => format!("mbs {}", env!("CARGO_PKG_VERSION")),
    }
}

/// The current UTC time as RFC 3339 with milliseconds.
fn utc_now() -> String {
    let since = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    rfc3339(since.as_secs(), since.subsec_millis())
}

/// `secs` after the Unix epoch as `YYYY-MM-DDThh:mm:ss.mmmZ` (the civil
/// date by Howard Hinnant's `civil_from_days`).
fn rfc3339(secs: u64, millis: u32) -> String {
    let days = (secs / 86400) as i64;
    let rest = secs % 86400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{millis:03}Z",
        rest / 3600,
        rest / 60 % 60,
        rest % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_are_rfc3339_utc() {
        assert_eq!(rfc3339(0, 0), "1970-01-01T00:00:00.000Z");
        assert_eq!(rfc3339(951_782_400, 5), "2000-02-29T00:00:00.005Z");
        assert_eq!(rfc3339(1_795_635_161, 999), "2026-11-25T19:32:41.999Z");
    }

    #[test]
    fn lines_are_appended_and_warnings_kept() {
        let dir = tempfile::tempdir().unwrap();
        let header = Header {
            command: "run",
            resumed: false,
            config: "a = 1\n",
        };
        Log::open(dir.path(), header).unwrap().event("first");
        let log = Log::open(
            dir.path(),
            Header {
                resumed: true,
                ..header
            },
        )
        .unwrap();
        log.warn("narrow");
        assert_eq!(log.warnings(), ["narrow"]);
        let text = std::fs::read_to_string(dir.path().join(LOG)).unwrap();
        let events: Vec<&str> = text
            .lines()
            .map(|l| l.split_once("  ").unwrap().1)
            .collect();
        assert_eq!(events[0], "=== mbs run started");
        assert_eq!(events[4], "first");
        assert_eq!(events[5], "=== mbs run resumed");
        assert_eq!(events[9], "warning narrow");
    }
}
