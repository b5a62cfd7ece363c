//! Stages 1 and 2 (docs/model.md §9 steps 1–2): packing runs over a range
//! of α_m (then α_cn); the settling time is the time after which |y_gc − final y_gc|
//! stays below a tolerance; the fastest value that comes to rest wins.

use super::save_stage;
use crate::calibrate::cells::{PackCurve, PackSpec};
use crate::calibrate::Context;
use crate::config::ConfigFile;
use crate::error::HostError;
use crate::figures::save;
use crate::io::output::{decimal, write_csv};
use crate::tools::pack::settling_figure;
use serde::{Deserialize, Serialize};

/// One value of the swept parameter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SettlingRow {
    /// The parameter value.
    pub value: f64,
    /// Mean settling time over seeds (s); NaN if a seed never settled.
    pub settling_time: f64,
    /// Largest speed at the end over seeds (m/s).
    pub final_speed: f64,
    /// Settled within 80 % of the run and at rest at the end in every seed.
    pub stable: bool,
    /// Why not stable (kernel error, not settled, still moving).
    pub note: String,
}

/// The outcome of stage 1 or 2.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SettlingStage {
    /// `alpha_m` or `alpha_cn`.
    pub parameter: String,
    /// α_m, α_cn and β of the runs (the swept one varies).
    pub alpha_m: f64,
    /// α_cn of the runs (stage 1).
    pub alpha_cn: f64,
    /// Tolerance on |y_gc − final y_gc| (m).
    pub tolerance: f64,
    /// At-rest speed (m/s).
    pub rest_speed: f64,
    /// Packing duration (s).
    pub duration: f64,
    /// One row per value.
    pub rows: Vec<SettlingRow>,
    /// The chosen value: the fastest stable one.
    pub chosen: f64,
    /// y_gc(t) of the first seed per value (for the figure).
    pub curves: Vec<(f64, Vec<(f64, f64)>)>,
}

/// The settling time of a curve: the first sample time after which
/// |y_gc − final y_gc| < `tolerance` for good.
pub fn settling_time(curve: &PackCurve, tolerance: f64) -> f64 {
    let Some(&last) = curve.y_gc.last() else {
        return f64::NAN;
    };
    let mut t = curve.time.first().copied().unwrap_or(0.0);
    for (time, y) in curve.time.iter().zip(&curve.y_gc) {
        if (y - last).abs() >= tolerance {
            t = *time;
        }
    }
    t
}

/// Runs stage 1 (`parameter = "alpha_m"`, α_cn = 1) or stage 2
/// (`"alpha_cn"`, α_m from stage 1), β = 1, on the base bed narrowed to
/// the packing columns of the plan (docs/model.md §9 step 1: nld = 5), at
/// the base constants_dt.
pub fn run(
    ctx: &Context<'_>,
    stage: usize,
    alpha_m: f64,
) -> Result<Option<SettlingStage>, HostError> {
    let plan = &ctx.plan;
    let (parameter, values) = if stage == 1 {
        ("alpha_m", &plan.alpha_m)
    } else {
        ("alpha_cn", &plan.alpha_cn)
    };
    let configure = |v: f64| -> ConfigFile {
        let (alpha_m, alpha_cn) = if stage == 1 { (v, 1.0) } else { (alpha_m, v) };
        let mut c = ctx.configure(alpha_m, alpha_cn, 1.0);
        c.bed.columns = plan.pack_columns;
        c
    };
    let specs: Vec<PackSpec> = values
        .iter()
        .flat_map(|&v| {
            let c = configure(v);
            plan.pack_seeds
                .iter()
                .map(move |&s| PackSpec::new(&c, s, plan.pack_duration))
        })
        .collect();
    let results = ctx.cells.packing(&specs, &|k| k)?;
    if results.iter().any(Option::is_none) {
        return Ok(None);
    }
    let d = ctx.base.scenario.bed.max_diameter();
    let tolerance = plan.settle_tolerance_d * d;
    let n = plan.pack_seeds.len();
    let mut rows = Vec::new();
    let mut curves = Vec::new();
    for (v, chunk) in values.iter().zip(results.chunks(n)) {
        let mut times = Vec::new();
        let mut speed: f64 = 0.0;
        let mut note = String::new();
        for r in chunk.iter().flatten() {
            match r {
                Ok(curve) => {
                    let t = settling_time(curve, tolerance);
                    if t > 0.8 * plan.pack_duration {
                        note = format!("y_gc still moving after {t:.3} s");
                    }
                    times.push(t);
                    speed = speed.max(curve.final_speed);
                    if curves.len() < rows.len() + 1 {
                        let points = curve
                            .time
                            .iter()
                            .zip(&curve.y_gc)
                            .map(|(t, y)| (*t, y * 1e3));
                        curves.push((*v, points.collect()));
                    }
                }
                Err(message) => note = message.clone(),
            }
        }
        if note.is_empty() && speed >= plan.rest_speed {
            note = format!("grains still moving at {speed:.2e} m/s");
        }
        let settling = if times.len() == n {
            times.iter().sum::<f64>() / n as f64
        } else {
            f64::NAN
        };
        rows.push(SettlingRow {
            value: *v,
            settling_time: settling,
            final_speed: speed,
            stable: note.is_empty(),
            note,
        });
    }
    let chosen = rows
        .iter()
        .filter(|r| r.stable)
        .min_by(|a, b| a.settling_time.total_cmp(&b.settling_time))
        .map(|r| r.value)
        .ok_or_else(|| {
            HostError::Calibration(format!(
                "stage {stage}: no {parameter} in {values:?} settles"
            ))
        })?;
    let result = SettlingStage {
        parameter: parameter.into(),
        alpha_m,
        alpha_cn: 1.0,
        tolerance,
        rest_speed: plan.rest_speed,
        duration: plan.pack_duration,
        rows,
        chosen,
        curves,
    };
    write_outputs(ctx, stage, &result)?;
    Ok(Some(result))
}

/// A line of `stage1.csv` or `stage2.csv`: a [`SettlingRow`].
#[derive(Serialize)]
struct SettlingLine<'a> {
    #[serde(serialize_with = "decimal")]
    value: f64,
    #[serde(serialize_with = "decimal")]
    settling_time: f64,
    #[serde(serialize_with = "decimal")]
    final_speed: f64,
    stable: bool,
    note: &'a str,
}

fn write_outputs(ctx: &Context<'_>, stage: usize, r: &SettlingStage) -> Result<(), HostError> {
    let name = format!("stage{stage}");
    let lines: Vec<SettlingLine> = r
        .rows
        .iter()
        .map(|row| SettlingLine {
            value: row.value,
            settling_time: row.settling_time,
            final_speed: row.final_speed,
            stable: row.stable,
            note: &row.note,
        })
        .collect();
    write_csv(&ctx.dir.join(format!("{name}.csv")), None, &lines)?;
    let symbol = if stage == 1 { "α_m" } else { "α_cn" };
    let figure = settling_figure(
        r.curves
            .iter()
            .map(|(v, points)| (format!("{symbol} = {v}"), points.clone()))
            .collect(),
        format!("Stage {stage}: settling of the packed bed against {symbol} (β = 1)"),
    );
    save(&figure, &ctx.dir, &name)?;
    save_stage(&ctx.dir, &name, r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settling_time_is_the_last_excursion_beyond_the_tolerance() {
        let curve = PackCurve {
            time: vec![0.0, 0.1, 0.2, 0.3, 0.4],
            y_gc: vec![5.0, 3.0, 2.2, 2.05, 2.0],
            final_speed: 0.0,
        };
        assert_eq!(settling_time(&curve, 0.1), 0.2);
        assert_eq!(settling_time(&curve, 1.0), 0.1);
    }
}
