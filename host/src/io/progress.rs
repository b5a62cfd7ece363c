//! Progress on standard error: a bar on a terminal; elsewhere (a batch job,
//! `nohup`, CI) plain lines at a sensible rate, e.g.
//! `progress  35 %  cells 7/20  elapsed 0:21  eta 0:39`; nothing with
//! `--quiet`. Work reports to the [`ProgressBar`] ([`Progress::bar`]); the
//! plain lines are written by a thread that reads it.

use crate::io::text::print_err;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::mpsc::{channel, RecvTimeoutError, Sender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A plain line is written when the work advanced by this share since
/// the last one and [`PLAIN_EVERY`] passed (the rarer of the two) …
const PLAIN_STEP: f64 = 0.1;
/// … see [`PLAIN_STEP`].
const PLAIN_EVERY: Duration = Duration::from_secs(30);
/// … and at least this often, and at the start, the end and when the
/// message changes (a calibration's stage).
const PLAIN_AT_LEAST: Duration = Duration::from_secs(60);

/// Progress of one command: the bar work reports to and, off a terminal,
/// the thread writing plain lines (stopped by [`Progress::finish`] or drop).
pub struct Progress {
    bar: ProgressBar,
    plain: Option<(Sender<()>, JoinHandle<()>)>,
}

impl Progress {
    /// Progress over `len` integration steps, labelled `what`.
    pub fn steps(len: u64, what: &str, quiet: bool) -> Progress {
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::hidden());
        if let Ok(style) = ProgressStyle::with_template(
            "{msg:12} [{elapsed_precise}] {wide_bar} {percent:>3}% (eta {eta})",
        ) {
            bar.set_style(style);
        }
        bar.set_message(what.to_string());
        Progress::start(bar, quiet, "")
    }

    /// Progress counted in `unit` without a known total (a calibration's
    /// cells), labelled by its message.
    pub fn counter(unit: &str, quiet: bool) -> Progress {
        let bar = ProgressBar::hidden();
        if let Ok(style) = ProgressStyle::with_template(&format!(
            "{{spinner}} [{{elapsed_precise}}] {{pos}} {unit}, {{msg}}"
        )) {
            bar.set_style(style);
        }
        let terminal = !quiet && std::io::stderr().is_terminal();
        if terminal {
            bar.enable_steady_tick(Duration::from_millis(250));
        }
        Progress::start(bar, quiet, unit)
    }

    fn start(bar: ProgressBar, quiet: bool, unit: &str) -> Progress {
        if quiet {
            return Progress { bar, plain: None };
        }
        if std::io::stderr().is_terminal() {
            bar.set_draw_target(ProgressDrawTarget::stderr());
            return Progress { bar, plain: None };
        }
        let (stop, stopped) = channel();
        let (watched, unit) = (bar.clone(), unit.to_string());
        let mut last = Plain::of(&watched, &unit);
        print_err(&last.line);
        let thread = std::thread::spawn(move || loop {
            // A message or a closed channel: finish.
            let done = !matches!(
                stopped.recv_timeout(Duration::from_secs(1)),
                Err(RecvTimeoutError::Timeout)
            );
            let now = Plain::of(&watched, &unit);
            if done || now.due_after(&last) {
                print_err(&now.line);
                last = now;
            }
            if done {
                return;
            }
        });
        Progress {
            bar,
            plain: Some((stop, thread)),
        }
    }

    /// The bar the work reports to.
    pub fn bar(&self) -> &ProgressBar {
        &self.bar
    }

    /// Ends the progress: the bar is cleared, the last plain line written.
    pub fn finish(mut self) {
        self.stop();
    }

    fn stop(&mut self) {
        // The last plain line first: finishing sets the bar to its end.
        if let Some((stop, thread)) = self.plain.take() {
            let _ = stop.send(());
            let _ = thread.join();
        }
        self.bar.finish_and_clear();
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.stop();
    }
}

/// One plain progress line and what decides when the next one is due.
struct Plain {
    line: String,
    at: Instant,
    share: f64,
    message: String,
}

impl Plain {
    fn of(bar: &ProgressBar, unit: &str) -> Plain {
        let elapsed = bar.elapsed();
        let message = bar.message();
        let (mut parts, share) = match bar.length() {
            Some(len) => {
                let share = bar.position() as f64 / len.max(1) as f64;
                (vec![format!("progress {:3.0} %", 100.0 * share)], share)
            }
            None => (vec![format!("progress  {} {unit}", bar.position())], 0.0),
        };
        if !message.is_empty() {
            parts.push(message.clone());
        }
        parts.push(format!("elapsed {}", clock(elapsed)));
        if bar.length().is_some() {
            let eta = if share > 0.0 {
                clock(elapsed.mul_f64((1.0 - share).max(0.0) / share))
            } else {
                "?".into()
            };
            parts.push(format!("eta {eta}"));
        }
        let line = parts.join("  ");
        Plain {
            line,
            at: Instant::now(),
            share,
            message,
        }
    }

    /// Whether `self` is worth a line after `last` was written.
    fn due_after(&self, last: &Plain) -> bool {
        let since = self.at - last.at;
        since >= PLAIN_AT_LEAST
            || self.message != last.message
            || (since >= PLAIN_EVERY && self.share - last.share >= PLAIN_STEP)
    }
}

/// A duration as `m:ss`, or `h:mm:ss` from an hour on.
fn clock(d: Duration) -> String {
    let s = d.as_secs();
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clock_times() {
        assert_eq!(clock(Duration::from_secs(21)), "0:21");
        assert_eq!(clock(Duration::from_secs(3723)), "1:02:03");
    }

    #[test]
    fn lines_are_due_at_the_rarer_rate_but_once_a_minute() {
        let at = Instant::now();
        let plain = |secs: u64, share: f64, message: &str| Plain {
            line: String::new(),
            at: at + Duration::from_secs(secs),
            share,
            message: message.into(),
        };
        let last = plain(0, 0.1, "a");
        assert!(!plain(29, 0.5, "a").due_after(&last));
        assert!(!plain(40, 0.15, "a").due_after(&last));
        assert!(plain(30, 0.2, "a").due_after(&last));
        assert!(plain(60, 0.1, "a").due_after(&last));
        assert!(plain(1, 0.1, "b").due_after(&last));
    }
}
