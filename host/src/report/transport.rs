//! `transport.csv` and `transport.png`/`.svg`: q*(τ*) per τ*, with the
//! reference relations of docs/model.md §10 and the dimensional forms.

use crate::config::Config;
use crate::error::HostError;
use crate::figures::{PointFlags, TransportFigure};
use crate::io::output::{decimal, decimals, write_csv};
use crate::science::interval::t95;
use crate::work::experiment::TransportRow;
use mbs_kernel::{shear_velocity, transport_scale, G};
use serde::Serialize;
use std::path::Path;

/// A line of `transport.csv`: a [`TransportRow`] with its classes' (mean,
/// stderr) side by side.
#[derive(Serialize)]
struct TransportLine {
    #[serde(serialize_with = "decimal")]
    tau_star: f64,
    #[serde(serialize_with = "decimal")]
    q_star: f64,
    #[serde(serialize_with = "decimal")]
    q_star_stderr: f64,
    #[serde(serialize_with = "decimal")]
    q_star_ci95: f64,
    seeds: usize,
    #[serde(serialize_with = "decimal")]
    mpm: f64,
    #[serde(serialize_with = "decimal")]
    wong_parker: f64,
    #[serde(serialize_with = "decimal")]
    u_star_m_s: f64,
    #[serde(serialize_with = "decimal")]
    q_b_m2_s: f64,
    #[serde(serialize_with = "decimal")]
    q_b_stderr_m2_s: f64,
    #[serde(serialize_with = "decimal")]
    window_s: f64,
    #[serde(serialize_with = "decimal")]
    discarded_s: f64,
    unsteady: usize,
    capped: usize,
    #[serde(serialize_with = "decimals")]
    classes: Vec<f64>,
}

/// Writes `transport.csv`: a line per τ* (q* with its standard error and
/// the half-width of its 95 % interval, the seeds, two reference
/// relations, u* in m/s and q_B with its standard error in m²/s, the mean
/// window and discarded transient, the seeds without a steady part and
/// those capped), and two columns per size class of a mixed bed.
pub fn write_transport(
    path: &Path,
    config: &Config,
    rows: &[TransportRow],
) -> Result<(), HostError> {
    let mut header: Vec<String> = [
        "tau_star",
        "q_star",
        "q_star_stderr",
        "q_star_ci95",
        "seeds",
        "mpm",
        "wong_parker",
        "u_star_m_s",
        "q_b_m2_s",
        "q_b_stderr_m2_s",
        "window_s",
        "discarded_s",
        "unsteady",
        "capped",
    ]
    .map(String::from)
    .to_vec();
    if rows.first().is_some_and(|r| !r.classes.is_empty()) {
        for c in &config.scenario.bed.classes {
            let d = c.diameter * 1e3;
            header.push(format!("q_star_{d}mm"));
            header.push(format!("q_star_{d}mm_stderr"));
        }
    }
    // Dimensional forms on the largest diameter (docs/model.md §6, §8):
    // u* = √(τ* (s − 1) g d), q_B = q* √((s − 1) g d³).
    let (d, s) = (
        config.scenario.bed.max_diameter(),
        config.scenario.material.s,
    );
    let q_scale = transport_scale(d, s, G);
    let lines: Vec<TransportLine> = rows
        .iter()
        .map(|r| TransportLine {
            tau_star: r.tau_star,
            q_star: r.q_star,
            q_star_stderr: r.q_star_stderr,
            q_star_ci95: r.q_star_ci95,
            seeds: r.seeds,
            mpm: r.mpm,
            wong_parker: r.wong_parker,
            u_star_m_s: shear_velocity(r.tau_star, s, G, d),
            q_b_m2_s: r.q_star * q_scale,
            q_b_stderr_m2_s: r.q_star_stderr * q_scale,
            window_s: r.window_s,
            discarded_s: r.discarded_s,
            unsteady: r.unsteady,
            capped: r.capped,
            classes: r.classes.iter().flat_map(|&(q, e)| [q, e]).collect(),
        })
        .collect();
    write_csv(path, Some(&header), &lines)
}

/// The figure of `transport.csv`: all classes together, then each class
/// of a mixed bed; the title names the bed, β and the seeds.
pub fn transport_figure(config: &Config, rows: &[TransportRow]) -> TransportFigure {
    let sc = &config.scenario;
    let classes = &sc.bed.classes;
    let all = rows
        .iter()
        .map(|r| (r.tau_star, r.q_star, r.q_star_ci95))
        .collect();
    let flags = rows
        .iter()
        .map(|r| PointFlags {
            not_steady: r.unsteady > 0,
            capped: r.capped > 0,
        })
        .collect();
    let per_class = if classes.len() > 1 {
        classes
            .iter()
            .enumerate()
            .map(|(k, c)| {
                // The 95 % interval between the seeds (E3).
                let points = rows
                    .iter()
                    .filter_map(|r| {
                        let t = if r.seeds > 1 { t95(r.seeds - 1) } else { 0.0 };
                        r.classes.get(k).map(|&(q, e)| (r.tau_star, q, t * e))
                    })
                    .collect();
                (format!("d = {} mm", c.diameter * 1e3), points)
            })
            .collect()
    } else {
        Vec::new()
    };
    let title = format!(
        "q* against τ*: d = {} mm, {}×{} bed, β = {}, {} seed(s)",
        classes
            .iter()
            .map(|c| (c.diameter * 1e3).to_string())
            .collect::<Vec<_>>()
            .join(", "),
        sc.bed.columns,
        sc.bed.rows,
        sc.rule.beta,
        config.seeds.len()
    );
    TransportFigure::new(title, all, flags, per_class)
}
