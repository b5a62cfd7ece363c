//! Stage 4 (SPEC §9 steps 4–5): for other grain sizes d and layer
//! thicknesses nvd, keep α_m, α_cn and β and search the Δt that restores
//! agreement with the reference (a grid of Δt, then golden section on ln Δt).
//! Each (d, nvd) search is one unit of sharding.

use super::save_stage;
use crate::calibrate::optimise::grid_then_golden;
use crate::calibrate::{Context, Curve};
use crate::error::HostError;
use crate::output::{decimal, write_csv};
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

impl TimestepStage {
    /// Δt of the (d, nvd) search, if it ran.
    pub fn dt_at(&self, diameter_mm: f64, layers: u32) -> Option<f64> {
        self.rows
            .iter()
            .find(|r| r.diameter_mm == diameter_mm && r.layers == layers)
            .map(|r| r.dt)
    }

    /// The exponent p of Δt ∝ d^p: least-squares slope of ln Δt against
    /// ln d over the sizes searched at `layers` (None with fewer than two).
    pub fn size_exponent(&self, layers: u32) -> Option<f64> {
        let points: Vec<(f64, f64)> = self
            .rows
            .iter()
            .filter(|r| r.layers == layers && r.diameter_mm > 0.0 && r.dt > 0.0)
            .map(|r| (r.diameter_mm.ln(), r.dt.ln()))
            .collect();
        let n = points.len() as f64;
        let mean_x = points.iter().map(|p| p.0).sum::<f64>() / n;
        let mean_y = points.iter().map(|p| p.1).sum::<f64>() / n;
        let sxx: f64 = points.iter().map(|p| (p.0 - mean_x).powi(2)).sum();
        let sxy: f64 = points.iter().map(|p| (p.0 - mean_x) * (p.1 - mean_y)).sum();
        (points.len() >= 2 && sxx > 0.0).then(|| sxy / sxx)
    }
}

/// The (d, nvd) searches: every size at the first layer thickness (the d
/// study), then every other thickness at the study diameter (the nvd study).
pub fn units(plan: &crate::calibrate::Plan) -> Vec<(f64, u32)> {
    let first = plan.layers.first().copied().unwrap_or(10);
    let mut units: Vec<(f64, u32)> = plan.sizes_mm.iter().map(|&d| (d, first)).collect();
    units.extend(plan.layers.iter().skip(1).map(|&n| (plan.study_mm, n)));
    units
}

/// Runs stage 4 with the constants of stage 3.
pub fn run(
    ctx: &Context<'_>,
    alpha_m: f64,
    alpha_cn: f64,
    beta: f64,
) -> Result<Option<TimestepStage>, HostError> {
    let plan = &ctx.plan;
    let base_dt = ctx.base.scenario.rule.constants_dt;
    let mut rows = Vec::new();
    let mut complete = true;
    let units = units(plan);
    let points: Vec<(f64, &[u64])> = plan
        .dt_tau_stars
        .iter()
        .map(|&t| (t, plan.dt_seeds.as_slice()))
        .collect();
    for (unit, &(d, layers)) in units.iter().enumerate() {
        let slot = move |_k: usize| unit;
        let curve_at = |dt: f64| {
            let mut c = ctx.configure(alpha_m, alpha_cn, beta);
            c.grains.diameter_mm = Some(d);
            c.grains.classes = None;
            c.bed.rows = layers;
            if let Some(columns) = plan.timestep_columns {
                c.bed.columns = columns;
            }
            c.time.dt = dt;
            ctx.curve(&c, &points, plan.dt_window, &slot)
        };
        let grid: Vec<f64> = plan.dt_grid.iter().map(|m| base_dt * m).collect();
        let search = grid_then_golden(&grid, plan.dt_tolerance, |dt| {
            Ok(curve_at(dt)?.map(|c| c.misfit(ctx.reference)))
        })?;
        let Some(search) = search else {
            complete = false;
            continue;
        };
        let (dt, misfit) = search.best;
        let mut evaluations = search.grid;
        evaluations.extend(search.refinement);
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

/// A line of `stage4.csv`: one (d, nvd) search.
#[derive(Serialize)]
struct TimestepLine {
    #[serde(serialize_with = "decimal")]
    diameter_mm: f64,
    layers: u32,
    #[serde(serialize_with = "decimal")]
    dt: f64,
    #[serde(serialize_with = "decimal")]
    dt_over_base: f64,
    #[serde(serialize_with = "decimal")]
    misfit: f64,
    #[serde(serialize_with = "decimal")]
    worst_factor: f64,
}

fn write_outputs(ctx: &Context<'_>, r: &TimestepStage) -> Result<(), HostError> {
    let lines: Vec<TimestepLine> = r
        .rows
        .iter()
        .map(|row| TimestepLine {
            diameter_mm: row.diameter_mm,
            layers: row.layers,
            dt: row.dt,
            dt_over_base: row.dt / r.base_dt,
            misfit: row.misfit,
            worst_factor: row.worst_factor,
        })
        .collect();
    write_csv(&ctx.dir.join("stage4.csv"), None, &lines)?;
    // Fig. 11: Δt against d (first nvd) and against nvd (study diameter).
    let first_layers = r.rows.first().map_or(10, |row| row.layers);
    let study_d = ctx.plan.study_mm;
    let by_size: Vec<&TimestepRow> = r
        .rows
        .iter()
        .filter(|row| row.layers == first_layers)
        .collect();
    let by_layers: Vec<&TimestepRow> = r
        .rows
        .iter()
        .filter(|row| row.diameter_mm == study_d)
        .collect();
    let chart = |rows: &[&TimestepRow],
                 x: &dyn Fn(&TimestepRow) -> f64,
                 x_label: &str,
                 title: String| LinesFigure {
        series: vec![(
            String::new(),
            rows.iter().map(|row| (x(row), row.dt)).collect(),
        )],
        title,
        x_label: x_label.into(),
        y_label: "time step Δt (s)".into(),
        log_axes: true,
        markers: true,
    };
    save(
        &chart(
            &by_size,
            &|row| row.diameter_mm,
            "grain diameter d (mm)",
            format!(
                "Stage 4: Δt restoring agreement against d (nvd = {first_layers}; paper Fig. 11)"
            ),
        ),
        &ctx.dir,
        "stage4_dt",
    )?;
    save(
        &chart(
            &by_layers,
            &|row| f64::from(row.layers),
            "layer thickness nvd",
            format!(
                "Stage 4: Δt restoring agreement against nvd (d = {study_d} mm; paper Fig. 11)"
            ),
        ),
        &ctx.dir,
        "stage4_dt_layers",
    )?;
    // Figs. 7–10: q* at the base and the fitted Δt, per d and per nvd.
    for (name, title, rows) in [
        (
            "stage4_sizes",
            format!("Stage 4: q* for each d (nvd = {first_layers}), base and fitted Δt"),
            &by_size,
        ),
        (
            "stage4_layers",
            format!("Stage 4: q* for each nvd (d = {study_d} mm), base and fitted Δt"),
            &by_layers,
        ),
    ] {
        let mut series = Vec::new();
        for row in rows.iter() {
            let label = format!("d = {} mm, nvd = {}", row.diameter_mm, row.layers);
            series.push((
                format!("{label}, Δt = {:.2e} s", r.base_dt),
                row.before.points(),
            ));
            series.push((
                format!("{label}, Δt = {:.2e} s", row.dt),
                row.after.points(),
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

#[cfg(test)]
mod tests {
    use super::*;

    fn row(diameter_mm: f64, layers: u32, dt: f64) -> TimestepRow {
        let curve = Curve {
            tau_stars: vec![],
            q_star: vec![],
            stderr: vec![],
            classes: vec![],
            failures: vec![],
        };
        TimestepRow {
            diameter_mm,
            layers,
            dt,
            misfit: 0.0,
            worst_factor: 1.0,
            before: curve.clone(),
            after: curve,
            evaluations: vec![],
        }
    }

    #[test]
    fn size_exponent_recovers_a_power_law_and_ignores_other_layers() {
        let mut rows: Vec<TimestepRow> = [0.1, 0.2, 0.5, 1.0, 2.0]
            .iter()
            .map(|&d| row(d, 10, 2.0e-5 * (d / 0.5f64).powf(0.5)))
            .collect();
        rows.push(row(0.5, 30, 1.0));
        let stage = TimestepStage {
            base_dt: 2.0e-5,
            rows,
        };
        let p = stage.size_exponent(10).unwrap();
        assert!((p - 0.5).abs() < 1e-12, "p = {p}");
        assert_eq!(stage.dt_at(0.5, 30), Some(1.0));
        assert_eq!(stage.size_exponent(30), None, "one size is no fit");
        assert_eq!(stage.size_exponent(20), None);
    }
}
