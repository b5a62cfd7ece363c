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

/// The table of a complete run (`mbs calibrate` refuses its directory).
pub const TRANSPORT: &str = "transport.csv";

/// The files every complete run writes in its directory.
pub const RUN_FILES: [&str; 10] = [
    TRANSPORT,
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

/// `x` in at most 9 characters for the console's table: as given where
/// that fits (`0.06`), else to 4 significant digits (a τ* derived from u*,
/// `0.05606`); transport.csv keeps every digit.
fn column(x: f64) -> String {
    let plain = x.to_string();
    if plain.len() <= 9 {
        return plain;
    }
    if (1e-3..1e4).contains(&x) {
        let decimals = (3 - x.log10().floor() as i32).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.3e}")
    }
}

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
    transport::write_transport(&dir.join(TRANSPORT), config, rows)?;
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
            column(r.tau_star),
            r.q_star,
            r.q_star_stderr,
            r.mpm,
            r.wong_parker
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::work::beds::{BedRecord, BedStatus};
    use crate::work::cell::{Block, CellResult};
    use crate::work::experiment::aggregate;

    /// A made-up cell: q* constant over its blocks.
    fn cell(tau_star: f64, seed: u64, q_star: f64) -> CellResult {
        CellResult {
            tau_star,
            seed,
            q_star,
            q_star_class: vec![],
            blocks: vec![
                Block {
                    q_star,
                    bed_level: 1e-3,
                    q_star_class: vec![],
                };
                10
            ],
            discarded: 0,
            steady: true,
            window_s: 1.0,
            target_reached: true,
            bed_level: 1e-3,
            grain_steps: 1_000,
            bed: BedRecord {
                status: BedStatus::AtRest,
                settle_s: 0.1,
                max_overlap_d: 0.01,
            },
            profile: None,
        }
    }

    /// Every file of a run comes from its outcome alone: no cell is run,
    /// and the table holds the seeds' mean per τ*.
    #[test]
    fn a_run_is_reported_from_its_outcome_alone() {
        let config = Config::from_toml("[flow]\ntau_star = [0.1, 0.2]\n[run]\nseeds = [1, 2]\n")
            .expect("valid");
        let outcome = RunOutcome {
            results: vec![
                cell(0.1, 1, 0.02),
                cell(0.1, 2, 0.04),
                cell(0.2, 1, 0.2),
                cell(0.2, 2, 0.4),
            ],
            reused: 1,
            resumed: 0,
            beds_settled: 2,
            beds_resumed: 0,
            bed_grain_steps: 500,
            computed_grain_steps: 3_000,
        };
        let facts = RunFacts {
            threads: 2,
            wall_time_s: 2.0,
            warnings: vec!["a warning".into()],
        };
        let rows = aggregate(&config, &outcome.results);
        let dir = tempfile::tempdir().expect("temporary directory");
        let console = write_run(dir.path(), &config, &outcome, &rows, &facts).expect("written");
        for file in RUN_FILES {
            // The cells carry no profiles: profiles.csv has nothing to say.
            let len = std::fs::metadata(dir.path().join(file)).map(|m| m.len());
            assert!(len.is_ok_and(|n| n > 0 || file == "profiles.csv"), "{file}");
        }
        let csv = std::fs::read_to_string(dir.path().join("transport.csv")).expect("csv");
        let q: Vec<&str> = csv
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(1).unwrap())
            .collect();
        assert_eq!(q, ["0.03", "0.30000000000000004"]);
        let summary = std::fs::read_to_string(dir.path().join("summary.json")).expect("json");
        assert!(summary.contains("\"cells_computed\": 3"), "{summary}");
        assert!(
            summary.contains("\"warnings\": [\n    \"a warning\"\n  ]"),
            "{summary}"
        );
        assert_eq!(
            [0.06, 0.056057825966082844, 1.23456789e-7, 1234.56789].map(column),
            ["0.06", "0.05606", "1.235e-7", "1235"]
        );
        // 3 cells and their beds computed in 2 s: 3500 grain-steps / 2 s.
        assert!(
            console.contains("4 cells, 3 computed in 2.0 s (1.750e3 grain-steps/s)"),
            "{console}"
        );
    }
}
