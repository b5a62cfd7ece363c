//! What a run writes, as a function of its outcome: the transport table
//! and figure, the time series, the profiles, the summary and the console
//! table. Nothing here runs a cell, so every report can be tested on a
//! made-up [`RunOutcome`].

pub mod profiles;
pub mod summary;
pub mod timeseries;
pub mod transport;

use crate::config::Config;
use crate::error::HostError;
use crate::figures::save;
use crate::work::experiment::{RunOutcome, TransportRow};
use crate::work::store::STORE;
use std::path::Path;

/// What a run's report needs beyond its outcome: facts of this invocation.
#[derive(Debug, Clone, Default)]
pub struct RunFacts {
    /// Threads of the pool.
    pub threads: usize,
    /// Wall time of this invocation (s).
    pub wall_time_s: f64,
    /// The warnings of the run (also on standard error and in `mbs.log`).
    pub warnings: Vec<String>,
}

impl RunFacts {
    /// Cells computed by this invocation (resumed ones included).
    pub fn computed(&self, outcome: &RunOutcome) -> usize {
        outcome.results.len() - outcome.reused
    }

    /// Grain-steps per second of this invocation; `None` when every cell
    /// was reused (only the cells computed now took this wall time).
    pub fn rate(&self, outcome: &RunOutcome) -> Option<f64> {
        (self.computed(outcome) > 0).then(|| {
            (outcome.computed_grain_steps + outcome.bed_grain_steps) as f64 / self.wall_time_s
        })
    }
}

/// The files every complete run writes in its directory.
pub const RUN_FILES: [&str; 10] = [
    "transport.csv",
    "transport.png",
    "transport.svg",
    "timeseries.csv",
    "timeseries.png",
    "timeseries.svg",
    "profiles.csv",
    "profiles.png",
    "profiles.svg",
    "summary.json",
];

/// Writes the report of a complete run into `dir` ([`RUN_FILES`]) and
/// returns the console table: a line per τ*, then what was computed and
/// written.
pub fn write_run(
    dir: &Path,
    config: &Config,
    outcome: &RunOutcome,
    rows: &[TransportRow],
    facts: &RunFacts,
) -> Result<String, HostError> {
    let results = &outcome.results;
    transport::write_transport(&dir.join("transport.csv"), config, rows)?;
    save(&transport::transport_figure(config, rows), dir, "transport")?;
    timeseries::write_timeseries(&dir.join("timeseries.csv"), config, results)?;
    save(
        &timeseries::timeseries_figure(config, results),
        dir,
        "timeseries",
    )?;
    profiles::write_profiles(&dir.join("profiles.csv"), config, results)?;
    save(&profiles::profiles_figure(config, results), dir, "profiles")?;
    summary::write_summary(&dir.join("summary.json"), config, outcome, rows, facts)?;
    Ok(console_table(dir, outcome, rows, facts))
}

/// The console's summary of a run.
fn console_table(
    dir: &Path,
    outcome: &RunOutcome,
    rows: &[TransportRow],
    facts: &RunFacts,
) -> String {
    let mut text = String::from("tau_star  q_star    stderr    MPM       Wong-Parker\n");
    for r in rows {
        text += &format!(
            "{:<9} {:<9.4} {:<9.4} {:<9.4} {:<9.4}\n",
            r.tau_star, r.q_star, r.q_star_stderr, r.mpm, r.wong_parker
        );
    }
    let (computed, wall) = (facts.computed(outcome), facts.wall_time_s);
    let speed = match facts.rate(outcome) {
        Some(rate) => format!("{computed} computed in {wall:.1} s ({rate:.3e} grain-steps/s)"),
        None => format!("all reused from {STORE}"),
    };
    text += &format!(
        "{} cells, {speed}; wrote {}/{}\n",
        outcome.results.len(),
        dir.display(),
        RUN_FILES.join(", ")
    );
    text
}
