//! Stage 4 (SPEC §9 steps 4–5): for other grain sizes d and layer
//! thicknesses nvd, keep α_m, α_cn and β and search the Δt that restores
//! agreement with the reference (a grid of Δt, then golden section on ln Δt).
//! Each (d, nvd) search is one unit of sharding.

use super::{beta::configure, beta::points, save_stage};
use crate::calibrate::optimise::golden_section;
use crate::calibrate::{Context, Curve};
use crate::error::HostError;
use crate::output::write_csv;
use crate::plot::{save, LinesFigure, TransportFigure};
use serde::{Deserialize, Serialize};

/// One (d, nvd) search.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimestepRow {
    /// Grain diameter (mm).
    pub diameter_mm: f64,
    /// Layer thickness nvd.
    pub layers: u32,
    /// The Δt restoring agreement (s).
    pub dt: f64,
    /// Misfit there.
    pub misfit: f64,
    /// Worst factor to the reference there.
    pub worst_factor: f64,
    /// q*(τ*) at the base Δt.
    pub before: Curve,
    /// q*(τ*) at the fitted Δt.
    pub after: Curve,
    /// Every (Δt, misfit) evaluated.
    pub evaluations: Vec<(f64, f64)>,
}

/// The outcome of stage 4.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimestepStage {
    /// The base Δt (s).
    pub base_dt: f64,
    /// One row per (d, nvd), sizes outer, layers inner.
    pub rows: Vec<TimestepRow>,
}

/// Runs stage 4 with the constants of stage 3.
pub fn run(
    ctx: &Context<'_>,
    alpha_m: f64,
    alpha_cn: f64,
    beta: f64,
) -> Result<Option<TimestepStage>, HostError> {
    let plan = &ctx.plan;
    let base_dt = ctx.base.time.dt;
    let mut rows = Vec::new();
    let mut complete = true;
    let units: Vec<(f64, u32)> = plan
        .sizes_mm
        .iter()
        .flat_map(|&d| plan.layers.iter().map(move |&n| (d, n)))
        .collect();
    for (unit, &(d, layers)) in units.iter().enumerate() {
        let slot = move |_k: usize| unit;
        let curve_at = |dt: f64| {
            let mut c = configure(&ctx.base, alpha_m, alpha_cn, beta);
            c.grains.diameter_mm = Some(d);
            c.grains.classes = None;
            c.bed.rows = layers;
            c.time.dt = dt;
            ctx.curve(
                &c,
                &plan.dt_tau_stars,
                &plan.dt_seeds,
                plan.dt_window,
                &slot,
            )
        };
        let mut grid = Vec::new();
        for &m in &plan.dt_grid {
            if let Some(c) = curve_at(base_dt * m)? {
                grid.push((base_dt * m, c.misfit(ctx.reference)));
            }
        }
        if grid.len() < plan.dt_grid.len() {
            complete = false;
            continue;
        }
        let best = grid
            .iter()
            .enumerate()
            .min_by(|a, b| a.1 .1.total_cmp(&b.1 .1))
            .map_or(0, |(i, _)| i);
        let lo = if best == 0 {
            grid[0].0 / 2.0
        } else {
            grid[best - 1].0
        };
        let hi = if best + 1 == grid.len() {
            grid[best].0 * 2.0
        } else {
            grid[best + 1].0
        };
        let search = golden_section(lo.ln(), hi.ln(), plan.dt_tolerance.ln(), |x| {
            Ok(curve_at(x.exp())?.map(|c| c.misfit(ctx.reference)))
        })?;
        let Some(search) = search else {
            complete = false;
            continue;
        };
        let mut evaluations = grid.clone();
        evaluations.extend(search.evaluations.iter().map(|&(x, v)| (x.exp(), v)));
        let (dt, misfit) = evaluations
            .iter()
            .copied()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((base_dt, f64::NAN));
        let (Some(before), Some(after)) = (curve_at(base_dt)?, curve_at(dt)?) else {
            complete = false;
            continue;
        };
        rows.push(TimestepRow {
            diameter_mm: d,
            layers,
            dt,
            misfit,
            worst_factor: after.worst_factor(ctx.reference),
            before,
            after,
            evaluations,
        });
    }
    if !complete {
        return Ok(None);
    }
    let result = TimestepStage { base_dt, rows };
    write_outputs(ctx, &result)?;
    Ok(Some(result))
}

fn write_outputs(ctx: &Context<'_>, r: &TimestepStage) -> Result<(), HostError> {
    let header = [
        "diameter_mm",
        "layers",
        "dt",
        "dt_over_base",
        "misfit",
        "worst_factor",
    ]
    .map(String::from);
    let body: Vec<Vec<String>> = r
        .rows
        .iter()
        .map(|row| {
            vec![
                row.diameter_mm.to_string(),
                row.layers.to_string(),
                row.dt.to_string(),
                (row.dt / r.base_dt).to_string(),
                row.misfit.to_string(),
                row.worst_factor.to_string(),
            ]
        })
        .collect();
    write_csv(&ctx.dir.join("stage4.csv"), &header, &body)?;
    // Fig. 11: Δt against d, one line per nvd.
    let mut layers: Vec<u32> = r.rows.iter().map(|row| row.layers).collect();
    layers.dedup();
    layers.sort_unstable();
    layers.dedup();
    let chart = LinesFigure {
        series: layers
            .iter()
            .map(|&n| {
                let points = r
                    .rows
                    .iter()
                    .filter(|row| row.layers == n)
                    .map(|row| (row.diameter_mm, row.dt))
                    .collect();
                (format!("nvd = {n}"), points)
            })
            .collect(),
        title: "Stage 4: the Δt restoring agreement against d and nvd (paper Fig. 11)".into(),
        x_label: "grain diameter d (mm)".into(),
        y_label: "time step Δt (s)".into(),
        log_axes: true,
    };
    save(&chart, &ctx.dir, "stage4_dt")?;
    // Figs. 7–10: q* before and after the Δt change, per d (first nvd) and per nvd (d = 0.5 mm or the first d).
    let first_layers = layers.first().copied().unwrap_or(10);
    let study_d = if r.rows.iter().any(|row| row.diameter_mm == 0.5) {
        0.5
    } else {
        r.rows.first().map_or(0.5, |row| row.diameter_mm)
    };
    for (name, title, keep) in [
        (
            "stage4_sizes",
            format!("Stage 4: q* for each d (nvd = {first_layers}), base and fitted Δt"),
            Box::new(move |row: &TimestepRow| row.layers == first_layers)
                as Box<dyn Fn(&TimestepRow) -> bool>,
        ),
        (
            "stage4_layers",
            format!("Stage 4: q* for each nvd (d = {study_d} mm), base and fitted Δt"),
            Box::new(move |row: &TimestepRow| row.diameter_mm == study_d),
        ),
    ] {
        let mut series = Vec::new();
        for row in r.rows.iter().filter(|row| keep(row)) {
            let label = format!("d = {} mm, nvd = {}", row.diameter_mm, row.layers);
            series.push((
                format!("{label}, Δt = {:.2e} s", r.base_dt),
                points(&row.before),
            ));
            series.push((
                format!("{label}, Δt = {:.2e} s", row.dt),
                points(&row.after),
            ));
        }
        let figure = TransportFigure {
            series,
            references: vec![ctx.reference],
            title,
        };
        save(&figure, &ctx.dir, name)?;
    }
    save_stage(&ctx.dir, "stage4", r)
}
