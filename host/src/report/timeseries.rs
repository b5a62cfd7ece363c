//! The time series of a run: each cell's q*(t) as block means and its bed
//! level at each block's end (`timeseries.csv`), drawn per τ*
//! (`timeseries.png`/`.svg`), and the warnings of the τ*s whose windows are
//! not steady or did not reach their target.

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
}

/// The end of block `k` (s after the flow was switched on).
fn block_end(config: &Config, k: usize) -> f64 {
    let d = &config.durations;
    let step_dt = config.scenario.step_dt();
    (d.spin_up + (k as u64 + 1) * d.block()) as f64 * step_dt
}

/// Writes `timeseries.csv`: one line per block of every cell, in the
/// results' order (τ* major, seeds minor): τ*, seed, block, its end t (s
/// after the flow was switched on), q* over the block and the mean bed
/// level at its end (m).
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
            })
        })
        .collect();
    write_csv(path, None, &lines)
}

/// q*(t) per τ*: a panel per τ* with a line per seed (block means).
pub fn timeseries_figure(config: &Config, results: &[CellResult]) -> Panels {
    Panels {
        panels: config
            .tau_stars
            .iter()
            .map(|&tau| LinesFigure {
                series: results
                    .iter()
                    .filter(|r| r.tau_star == tau)
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
                dots: Vec::new(),
                title: format!(
                    "τ* = {}: q* over blocks of {} s",
                    number(tau),
                    config.file.time.block
                ),
                x_label: "t since the flow started (s)".into(),
                y_label: "q* (block mean)".into(),
                log_axes: false,
                markers: false,
                x_ticks: Vec::new(),
                marks: Vec::new(),
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
        if let Some(s) = r.steadiness.filter(|s| !s.steady) {
            out.push(format!(
                "unsteady: tau* = {tau}: q* over the first third of the windows {:.4} ± {:.4}, \
                 over the last third {:.4} ± {:.4} (they differ by more than twice their \
                 combined standard error): the bed is still changing; lengthen time.spin_up",
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
