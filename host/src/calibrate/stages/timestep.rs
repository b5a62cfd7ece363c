//! Stage 4 (docs/model.md §9 steps 4–5): for other grain sizes d and layer
//! thicknesses nvd, keep α_m, α_cn and β and search the constants' time step
//! constants_dt that restores agreement with the reference: the root of the
//! curve's weighted mean log-ratio to it ([`Curve::mean_log_ratio`]) in
//! ln constants_dt, from the base constants_dt scaled by √(d/d_base) (the
//! grains' gravity time scale √(d/g)), by steps and false position
//! ([`next_root_guess`]), until the mean log-ratio is within twice its
//! error of zero.
//! Each (d, nvd) search is one unit of sharding.

use super::save_stage;
use crate::calibrate::optimise::next_root_guess;
use crate::calibrate::{Context, Curve, Slots};
use crate::error::HostError;
use crate::figures::{save, LinesFigure, TransportFigure, Q_STAR_AXIS, TAU_STAR_AXIS};
use crate::io::output::{decimal, write_csv};
use serde::{Deserialize, Serialize};

/// The paper's constants_dt (Fig. 11): (d in mm, constants_dt in s) at its
/// fine grain and at the grain where it fitted α_m, α_cn and β.
pub const PAPER_CONSTANTS_DT: [(f64, f64); 2] = [(0.1, 9.0e-6), (0.5, 2.0e-5)];

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
    /// q*(τ*) at the start: the base constants_dt × √(d/d_base).
    pub before: Curve,
    /// q*(τ*) at the fitted constants_dt.
    pub after: Curve,
    /// Every (constants_dt, mean log-ratio, its standard error) evaluated.
    pub evaluations: Vec<(f64, f64, f64)>,
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
    let (reference, floor) = (ctx.reference, ctx.floor());
    let base_constants_dt = ctx.base.scenario.rule.constants_dt;
    let base_d = ctx.base.scenario.bed.max_diameter() * 1e3;
    let mut rows = Vec::new();
    let mut complete = true;
    for (unit, &(d, layers)) in units(plan).iter().enumerate() {
        let curve_at = |constants_dt: f64| -> Result<Option<Curve>, HostError> {
            let mut c = ctx.configure(alpha_m, alpha_cn, beta);
            c.grains.diameter_mm = Some(d);
            c.grains.classes = None;
            c.bed.rows = layers;
            if let Some(columns) = plan.timestep_columns {
                c.bed.columns = columns;
            }
            c.time.constants_dt = constants_dt;
            Ok(ctx
                .curves(
                    &[c],
                    &plan.timestep_tau_stars,
                    &plan.timestep,
                    None,
                    Slots::All(unit),
                )?
                .map(|mut curves| curves.remove(0)))
        };
        // Secant iterations on x = ln constants_dt; f = the mean log-ratio.
        let mut points: Vec<(f64, f64, f64)> = Vec::new();
        let mut curves = Vec::new();
        let mut x = (base_constants_dt * (d / base_d).sqrt()).ln();
        let step = plan.constants_dt_step.ln();
        let waiting = loop {
            let Some(curve) = curve_at(x.exp())? else {
                break true;
            };
            let (f, sigma) = if curve.failures.is_empty() {
                curve.mean_log_ratio(reference, floor)
            } else {
                (f64::NAN, f64::NAN)
            };
            points.push((x, f, sigma));
            curves.push(curve);
            let resolved = f.abs() <= 2.0 * sigma;
            if resolved || !f.is_finite() || points.len() >= plan.constants_dt_evaluations {
                break false;
            }
            // Too much transport (f > 0): a longer constants_dt (softer,
            // more damped contacts) lowers it.
            let tried: Vec<(f64, f64)> = points.iter().map(|p| (p.0, p.1)).collect();
            x = next_root_guess(&tried, step).unwrap_or(x);
        };
        if waiting {
            complete = false;
            continue;
        }
        let chosen = points
            .iter()
            .enumerate()
            .min_by(|a, b| a.1 .1.abs().total_cmp(&b.1 .1.abs()))
            .map_or(0, |(k, _)| k);
        let after = curves[chosen].clone();
        rows.push(TimestepRow {
            diameter_mm: d,
            layers,
            constants_dt: points[chosen].0.exp(),
            misfit: after.misfit(reference, floor),
            worst_factor: after.worst_factor(reference),
            before: curves[0].clone(),
            after,
            evaluations: points.iter().map(|p| (p.0.exp(), p.1, p.2)).collect(),
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
                 title: String,
                 dots: Vec<(String, Vec<(f64, f64)>)>| LinesFigure {
        series: vec![(
            "mbs".into(),
            rows.iter().map(|row| (x(row), row.constants_dt)).collect(),
        )],
        title,
        x_label: x_label.into(),
        y_label: "constants' time step constants_dt (s)".into(),
        log_axes: true,
        markers: true,
        dots,
        x_ticks: rows.iter().map(|row| x(row)).collect(),
        marks: Vec::new(),
        ..LinesFigure::default()
    };
    save(
        &chart(
            &by_size,
            &|row| row.diameter_mm,
            "grain diameter d (mm)",
            format!(
                "Stage 4: constants_dt restoring agreement against d (nvd = {first_layers}; paper Fig. 11)"
            ),
            vec![(
                "the paper (Fig. 11): 9.0e-6 s at 0.1 mm, 2.0e-5 s at 0.5 mm".into(),
                PAPER_CONSTANTS_DT.to_vec(),
            )],
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
            Vec::new(),
        ),
        &ctx.dir,
        "stage4_dt_layers",
    )?;
    // Figs. 7–10: q* at the base and the fitted constants_dt, per d and per nvd.
    for (name, title, rows) in [
        (
            "stage4_sizes",
            format!("Stage 4: q* for each d (nvd = {first_layers}), start and fitted constants_dt"),
            &by_size,
        ),
        (
            "stage4_layers",
            format!("Stage 4: q* for each nvd (d = {study_d} mm), start and fitted constants_dt"),
            &by_layers,
        ),
    ] {
        let mut series = Vec::new();
        for row in rows.iter() {
            let label = format!("d = {} mm, nvd = {}", row.diameter_mm, row.layers);
            series.push((
                format!(
                    "{label}, constants_dt = {:.2e} s (start)",
                    row.evaluations.first().map_or(f64::NAN, |e| e.0)
                ),
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
            flags: Vec::new(),
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
            dof: vec![],
            classes: vec![],
            class_stderr: vec![],
            failures: vec![],
            seeds: vec![],
            reached: vec![],
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
