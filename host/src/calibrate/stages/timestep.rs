//! Stage 4 (docs/model.md §9 steps 4–5): for other grain sizes d and layer
//! thicknesses nvd, keep α_m, α_cn and β and search the constants' time step
//! constants_dt that restores agreement with the reference (a grid of
//! constants_dt, then golden section on its logarithm).
//! Each (d, nvd) search is one unit of sharding.

use super::save_stage;
use crate::calibrate::optimise::grid_then_golden;
use crate::calibrate::{Context, Curve};
use crate::error::HostError;
use crate::output::{decimal, write_csv};
use crate::plot::{save, LinesFigure, TransportFigure, Q_STAR_AXIS, TAU_STAR_AXIS};
use serde::{Deserialize, Serialize};

/// One (d, nvd) search.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimestepRow {
    /// Grain diameter (mm).
    pub diameter_mm: f64,
    /// Layer thickness nvd.
    pub layers: u32,
    /// The constants_dt restoring agreement (s).
    pub constants_dt: f64,
    /// Misfit there.
    pub misfit: f64,
    /// Worst factor to the reference there.
    pub worst_factor: f64,
    /// q*(τ*) at the base constants_dt.
    pub before: Curve,
    /// q*(τ*) at the fitted constants_dt.
    pub after: Curve,
    /// Every (constants_dt, misfit) evaluated.
    pub evaluations: Vec<(f64, f64)>,
}

/// The outcome of stage 4.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimestepStage {
    /// The base configuration's constants_dt (s).
    pub base_constants_dt: f64,
    /// One row per (d, nvd), sizes outer, layers inner.
    pub rows: Vec<TimestepRow>,
}

impl TimestepStage {
    /// constants_dt of the (d, nvd) search, if it ran.
    pub fn constants_dt_at(&self, diameter_mm: f64, layers: u32) -> Option<f64> {
        self.rows
            .iter()
            .find(|r| r.diameter_mm == diameter_mm && r.layers == layers)
            .map(|r| r.constants_dt)
    }

    /// The exponent p of constants_dt ∝ d^p: least-squares slope of its log against
    /// ln d over the sizes searched at `layers` (None with fewer than two).
    pub fn size_exponent(&self, layers: u32) -> Option<f64> {
        let points: Vec<(f64, f64)> = self
            .rows
            .iter()
            .filter(|r| r.layers == layers && r.diameter_mm > 0.0 && r.constants_dt > 0.0)
            .map(|r| (r.diameter_mm.ln(), r.constants_dt.ln()))
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
    let base_constants_dt = ctx.base.scenario.rule.constants_dt;
    let mut rows = Vec::new();
    let mut complete = true;
    let units = units(plan);
    let points: Vec<(f64, &[u64])> = plan
        .timestep_tau_stars
        .iter()
        .map(|&t| (t, plan.timestep_seeds.as_slice()))
        .collect();
    for (unit, &(d, layers)) in units.iter().enumerate() {
        let slot = move |_k: usize| unit;
        let curve_at = |constants_dt: f64| {
            let mut c = ctx.configure(alpha_m, alpha_cn, beta);
            c.grains.diameter_mm = Some(d);
            c.grains.classes = None;
            c.bed.rows = layers;
            if let Some(columns) = plan.timestep_columns {
                c.bed.columns = columns;
            }
            c.time.constants_dt = constants_dt;
            ctx.curve(&c, &points, plan.timestep_window, &slot)
        };
        let grid: Vec<f64> = plan
            .constants_dt_grid
            .iter()
            .map(|m| base_constants_dt * m)
            .collect();
        let search = grid_then_golden(&grid, plan.constants_dt_tolerance, |constants_dt| {
            Ok(curve_at(constants_dt)?.map(|c| c.misfit(ctx.reference)))
        })?;
        let Some(search) = search else {
            complete = false;
            continue;
        };
        let (constants_dt, misfit) = search.best;
        let mut evaluations = search.grid;
        evaluations.extend(search.refinement);
        let (Some(before), Some(after)) = (curve_at(base_constants_dt)?, curve_at(constants_dt)?)
        else {
            complete = false;
            continue;
        };
        rows.push(TimestepRow {
            diameter_mm: d,
            layers,
            constants_dt,
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
    let result = TimestepStage {
        base_constants_dt,
        rows,
    };
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
    constants_dt: f64,
    #[serde(serialize_with = "decimal")]
    constants_dt_over_base: f64,
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
            constants_dt: row.constants_dt,
            constants_dt_over_base: row.constants_dt / r.base_constants_dt,
            misfit: row.misfit,
            worst_factor: row.worst_factor,
        })
        .collect();
    write_csv(&ctx.dir.join("stage4.csv"), None, &lines)?;
    // Fig. 11: constants_dt against d (first nvd) and against nvd (study diameter).
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
            rows.iter().map(|row| (x(row), row.constants_dt)).collect(),
        )],
        title,
        x_label: x_label.into(),
        y_label: "constants' time step constants_dt (s)".into(),
        log_axes: true,
        markers: true,
        dots: Vec::new(),
        x_ticks: Vec::new(),
        marks: Vec::new(),
    };
    save(
        &chart(
            &by_size,
            &|row| row.diameter_mm,
            "grain diameter d (mm)",
            format!(
                "Stage 4: constants_dt restoring agreement against d (nvd = {first_layers}; paper Fig. 11)"
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
                "Stage 4: constants_dt restoring agreement against nvd (d = {study_d} mm; paper Fig. 11)"
            ),
        ),
        &ctx.dir,
        "stage4_dt_layers",
    )?;
    // Figs. 7–10: q* at the base and the fitted constants_dt, per d and per nvd.
    for (name, title, rows) in [
        (
            "stage4_sizes",
            format!("Stage 4: q* for each d (nvd = {first_layers}), base and fitted constants_dt"),
            &by_size,
        ),
        (
            "stage4_layers",
            format!("Stage 4: q* for each nvd (d = {study_d} mm), base and fitted constants_dt"),
            &by_layers,
        ),
    ] {
        let mut series = Vec::new();
        for row in rows.iter() {
            let label = format!("d = {} mm, nvd = {}", row.diameter_mm, row.layers);
            series.push((
                format!("{label}, constants_dt = {:.2e} s", r.base_constants_dt),
                row.before.points(),
            ));
            series.push((
                format!("{label}, constants_dt = {:.2e} s", row.constants_dt),
                row.after.points(),
            ));
        }
        let figure = TransportFigure {
            series,
            references: vec![ctx.reference],
            title,
            x_label: TAU_STAR_AXIS.into(),
            y_label: Q_STAR_AXIS.into(),
        };
        save(&figure, &ctx.dir, name)?;
    }
    save_stage(&ctx.dir, "stage4", r)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(diameter_mm: f64, layers: u32, constants_dt: f64) -> TimestepRow {
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
            constants_dt,
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
            base_constants_dt: 2.0e-5,
            rows,
        };
        let p = stage.size_exponent(10).unwrap();
        assert!((p - 0.5).abs() < 1e-12, "p = {p}");
        assert_eq!(stage.constants_dt_at(0.5, 30), Some(1.0));
        assert_eq!(stage.size_exponent(30), None, "one size is no fit");
        assert_eq!(stage.size_exponent(20), None);
    }
}
