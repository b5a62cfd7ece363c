//! The time series of a run: each cell's q*(t) as block means and its bed
//! level at each block's end (`timeseries.csv`), drawn per τ*
//! (`timeseries.png`/`.svg`) with each seed's discarded transient and
//! steady mean, and the warnings of the τ*s whose windows found no steady
//! part, drift, or did not reach their target.

use crate::config::Config;
use crate::error::HostError;
use crate::figures::{LinesFigure, Panels};
use crate::io::output::{decimal, write_csv};
use crate::io::text::number;
use crate::work::cell::CellResult;
use crate::work::experiment::TransportRow;
use serde::Serialize;
use std::path::Path;

/// A line of `timeseries.csv`.
#[derive(Serialize)]
struct Line {
    #[serde(serialize_with = "decimal")]
    tau_star: f64,
    seed: u64,
    block: usize,
    #[serde(serialize_with = "decimal")]
    t_s: f64,
    #[serde(serialize_with = "decimal")]
    q_star: f64,
    #[serde(serialize_with = "decimal")]
    bed_level_m: f64,
    /// "transient" (discarded by MSER) or "steady" (averaged).
    part: &'static str,
}

/// The end of block `k` (s after the flow was switched on).
fn block_end(config: &Config, k: usize) -> f64 {
    let d = &config.durations;
    let step_dt = config.scenario.step_dt();
    (d.spin_up + (k as u64 + 1) * d.block()) as f64 * step_dt
}

/// Writes `timeseries.csv`: one line per block of every cell, in the
/// results' order (τ* major, seeds minor): τ*, seed, block, its end t (s
/// after the flow was switched on), q* over the block, the mean bed
/// level at its end (m) and its part: the discarded transient or the
/// averaged steady part.
pub fn write_timeseries(
    path: &Path,
    config: &Config,
    results: &[CellResult],
) -> Result<(), HostError> {
    let lines: Vec<Line> = results
        .iter()
        .flat_map(|r| {
            r.blocks.iter().enumerate().map(|(k, b)| Line {
                tau_star: r.tau_star,
                seed: r.seed,
                block: k,
                t_s: block_end(config, k),
                q_star: b.q_star,
                bed_level_m: b.bed_level,
                part: if k < r.discarded {
                    "transient"
                } else {
                    "steady"
                },
            })
        })
        .collect();
    write_csv(path, None, &lines)
}

/// q*(t) per τ*: a panel per τ* with a line per seed (block means), each
/// seed's discarded transient shaded from the end of the spin-up and the
/// mean of its steady part dashed over it; a τ* with a seed without a
/// steady part says so in its title.
pub fn timeseries_figure(config: &Config, results: &[CellResult]) -> Panels {
    let d = &config.durations;
    let start = d.spin_up as f64 * config.scenario.step_dt();
    let block = d.block() as f64 * config.scenario.step_dt();
    Panels {
        panels: config
            .tau_stars
            .iter()
            .map(|&tau| {
                let cells: Vec<&CellResult> =
                    results.iter().filter(|r| r.tau_star == tau).collect();
                let unsteady: Vec<String> = cells
                    .iter()
                    .filter(|r| !r.steady)
                    .map(|r| r.seed.to_string())
                    .collect();
                let flag = if unsteady.is_empty() {
                    String::new()
                } else {
                    format!(" — NOT STEADY (seed {})", unsteady.join(", "))
                };
                LinesFigure {
                    series: cells
                        .iter()
                        .map(|r| {
                            let points = r
                                .blocks
                                .iter()
                                .enumerate()
                                .map(|(k, b)| (block_end(config, k), b.q_star))
                                .collect();
                            (format!("seed {}", r.seed), points)
                        })
                        .collect(),
                    spans: cells
                        .iter()
                        .filter(|r| r.discarded > 0)
                        .map(|r| (start, block_end(config, r.discarded - 1)))
                        .collect(),
                    levels: cells
                        .iter()
                        .enumerate()
                        .filter(|(_, r)| r.discarded < r.blocks.len())
                        .map(|(i, r)| {
                            let from = block_end(config, r.discarded) - block;
                            (i, from, block_end(config, r.blocks.len() - 1), r.q_star)
                        })
                        .collect(),
                    title: format!(
                        "τ* = {}: q* per {} s block after a spin-up of {} s{flag}",
                        number(tau),
                        config.file.time.block,
                        config.file.time.spin_up
                    ),
                    x_label: "t since the flow started (s); grey: discarded transient, dashed: \
                              steady mean"
                        .into(),
                    y_label: "q* (block mean)".into(),
                    end_labels: true,
                    ..LinesFigure::default()
                }
            })
            .collect(),
        side_by_side: false,
    }
}

/// The warnings of the τ*s of a run: windows not steady (first against
/// last third), cells that ended at `time.window` without their target.
pub fn window_warnings(config: &Config, rows: &[TransportRow]) -> Vec<String> {
    let mut out = Vec::new();
    for r in rows {
        let tau = number(r.tau_star);
        if r.unsteady > 0 {
            out.push(format!(
                "not-steady: tau* = {tau}: in {} of {} seed(s) no steady part was found within \
                 time.window = {} s (MSER discarded more than half of the window): q* there is \
                 the mean of a series still changing, not a result; lengthen time.window",
                r.unsteady, r.seeds, config.file.time.window
            ));
        } else if let Some(s) = r.steadiness.filter(|s| !s.steady) {
            out.push(format!(
                "unsteady: tau* = {tau}: q* over the first third of the steady parts {:.4} ± \
                 {:.4}, over the last third {:.4} ± {:.4} (they differ by more than twice their \
                 combined standard error): the bed drifts after its transient; lengthen \
                 time.window",
                s.first, s.first_stderr, s.last, s.last_stderr
            ));
        }
        if r.capped > 0 {
            out.push(format!(
                "target-not-reached: tau* = {tau}: {} of {} seed(s) averaged for the whole \
                 time.window = {} s without reaching the target standard error \
                 ([target]); lengthen time.window or add seeds",
                r.capped, r.seeds, config.file.time.window
            ));
        }
    }
    out
}
