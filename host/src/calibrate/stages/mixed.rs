//! Stage 5 (docs/model.md §9 step 6): a mixed bed with the constants of
//! stage 3 set for the largest grain; fractional transport per size class
//! (volume fractions, each class on its own scale) against the reference
//! relation evaluated per class (no hiding) and against Wilcock & Crowe
//! (2003), a surface-based relation with hiding. The integration step is refined
//! by (d_max/d_min)³ so that the finest grains stay inside the explicit
//! damping limit (docs/findings/explicit-damping-limit.md).

use super::save_stage;
use crate::calibrate::{Context, Curve, Slots, Q_FLOOR};
use crate::config::{ClassEntry, Config, Substeps};
use crate::error::HostError;
use crate::figures::{save, TransportFigure};
use crate::io::output::{decimal, write_csv};
use crate::science::mixture::{geometric_mean, wilcock_crowe};
use serde::{Deserialize, Serialize};

/// One size class at one τ*.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClassPoint {
    /// Shields number of the bed (largest grain).
    pub tau_star: f64,
    /// Class diameter (mm).
    pub diameter_mm: f64,
    /// Its volume fraction of the bed.
    pub fraction: f64,
    /// Shields number of the class: τ* d_max/d.
    pub tau_star_class: f64,
    /// Fractional transport q*_k / f_k, q*_k on the class's own scale
    /// (q_Bk/√((s − 1) g d_k³)) and f_k its volume fraction.
    pub q_star_fraction: f64,
    /// Its standard error between seeds (0 with one seed).
    #[serde(default)]
    pub q_star_fraction_stderr: f64,
    /// Reference at the class's Shields number (no hiding).
    pub reference: f64,
    /// Wilcock & Crowe (2003) for this class in this mixture (hiding).
    pub wilcock_crowe: f64,
}

impl ClassPoint {
    /// q*_k/f_k over the reference (both floored at the smallest q* the
    /// fit resolves); NaN for a failed cell.
    pub fn ratio(&self) -> f64 {
        self.q_star_fraction.max(Q_FLOOR) / self.reference.max(Q_FLOOR)
    }

    /// q*_k/f_k over Wilcock & Crowe, floored alike.
    pub fn ratio_hiding(&self) -> f64 {
        self.q_star_fraction.max(Q_FLOOR) / self.wilcock_crowe.max(Q_FLOOR)
    }
}

/// The worst factor max(r, 1/r) of `ratios`; a failed cell (NaN) counts as
/// an infinite factor, never as a good one.
fn worst(ratios: impl Iterator<Item = f64>) -> f64 {
    ratios
        .map(|r| {
            if r.is_finite() {
                r.max(1.0 / r)
            } else {
                f64::INFINITY
            }
        })
        .fold(1.0, f64::max)
}

/// The outcome of stage 5.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MixedStage {
    /// Substeps used.
    pub substeps: u32,
    /// The bed's curve (all classes, d = d_max).
    pub curve: Curve,
    /// Per class and τ*.
    pub points: Vec<ClassPoint>,
    /// Worst factor between fractional transport and reference per class.
    pub worst_factor: f64,
    /// Worst factor between fractional transport and Wilcock & Crowe.
    pub worst_factor_hiding: f64,
}

/// Runs stage 5.
pub fn run(
    ctx: &Context<'_>,
    alpha_m: f64,
    alpha_cn: f64,
    beta: f64,
) -> Result<Option<MixedStage>, HostError> {
    let plan = &ctx.plan;
    let mut c = ctx.configure(alpha_m, alpha_cn, beta);
    c.grains.diameter_mm = None;
    c.grains.classes = Some(
        plan.mixed
            .iter()
            .map(|&(d, f)| ClassEntry {
                diameter_mm: d,
                fraction: f,
            })
            .collect(),
    );
    let d_max = plan.mixed.iter().map(|c| c.0).fold(0.0, f64::max);
    // The finest class sets the substeps (its damping number grows as (d_max/d)³).
    c.time.substeps = Substeps::Auto;
    let curve_substeps = Config::validate(c.clone()).map_or(0, |v| v.scenario.substeps);
    let Some(curve) = ctx
        .curves(&[c], &plan.tau_stars, &plan.fine, None, Slots::From(0))?
        .map(|mut curves| curves.remove(0))
    else {
        return Ok(None);
    };
    // Volume fractions (the configuration's `grains.fractions` is "volume"),
    // the surface's mean for Wilcock & Crowe (taken as the bulk's) and its
    // sand fraction (< 2 mm).
    let (diameters, fractions): (Vec<f64>, Vec<f64>) = plan.mixed.iter().copied().unzip();
    let d_sm = geometric_mean(&diameters, &fractions);
    let sand: f64 = plan.mixed.iter().filter(|c| c.0 < 2.0).map(|c| c.1).sum();
    let mut points = Vec::new();
    for (k, &(d, f)) in plan.mixed.iter().enumerate() {
        // From the total's scale d_max (on which the classes add up) to the class's own.
        let own_scale = (d_max / d).powf(1.5);
        for (i, &t) in curve.tau_stars.iter().enumerate() {
            let tau_k = t * d_max / d;
            let q_k = curve.classes.get(k).and_then(|q| q.get(i)).copied();
            let e_k = curve.class_stderr.get(k).and_then(|e| e.get(i)).copied();
            points.push(ClassPoint {
                tau_star: t,
                diameter_mm: d,
                fraction: f,
                tau_star_class: tau_k,
                q_star_fraction: q_k.unwrap_or(f64::NAN) * own_scale / f,
                q_star_fraction_stderr: e_k.unwrap_or(0.0) * own_scale / f,
                reference: ctx.reference.q_star(tau_k),
                wilcock_crowe: wilcock_crowe(tau_k, d, d_sm, sand),
            });
        }
    }
    let worst_factor = worst(points.iter().map(ClassPoint::ratio));
    let worst_factor_hiding = worst(points.iter().map(ClassPoint::ratio_hiding));
    let result = MixedStage {
        substeps: curve_substeps,
        curve,
        points,
        worst_factor,
        worst_factor_hiding,
    };
    write_outputs(ctx, &result)?;
    Ok(Some(result))
}

/// A line of `stage5.csv`: a [`ClassPoint`].
#[derive(Serialize)]
struct ClassLine {
    #[serde(serialize_with = "decimal")]
    tau_star: f64,
    #[serde(serialize_with = "decimal")]
    diameter_mm: f64,
    #[serde(serialize_with = "decimal")]
    fraction: f64,
    #[serde(serialize_with = "decimal")]
    tau_star_class: f64,
    #[serde(serialize_with = "decimal")]
    q_star_fraction: f64,
    #[serde(serialize_with = "decimal")]
    q_star_fraction_stderr: f64,
    #[serde(serialize_with = "decimal")]
    reference: f64,
    #[serde(serialize_with = "decimal")]
    wilcock_crowe: f64,
}

fn write_outputs(ctx: &Context<'_>, r: &MixedStage) -> Result<(), HostError> {
    let lines: Vec<ClassLine> = r
        .points
        .iter()
        .map(|p| ClassLine {
            tau_star: p.tau_star,
            diameter_mm: p.diameter_mm,
            fraction: p.fraction,
            tau_star_class: p.tau_star_class,
            q_star_fraction: p.q_star_fraction,
            q_star_fraction_stderr: p.q_star_fraction_stderr,
            reference: p.reference,
            wilcock_crowe: p.wilcock_crowe,
        })
        .collect();
    write_csv(&ctx.dir.join("stage5.csv"), None, &lines)?;
    let mut diameters: Vec<f64> = r.points.iter().map(|p| p.diameter_mm).collect();
    diameters.dedup();
    // Each class's points, then what Wilcock & Crowe (2003) give them (the
    // table's comparison).
    let class = |d: f64, value: &dyn Fn(&ClassPoint) -> (f64, f64)| -> Vec<(f64, f64, f64)> {
        r.points
            .iter()
            .filter(|p| p.diameter_mm == d)
            .map(|p| {
                let (v, e) = value(p);
                (p.tau_star_class, v, e)
            })
            .collect()
    };
    let series = diameters
        .iter()
        .map(|&d| {
            (
                format!("class d = {d} mm"),
                class(d, &|p| (p.q_star_fraction, p.q_star_fraction_stderr)),
            )
        })
        .chain(diameters.iter().map(|&d| {
            (
                format!("Wilcock & Crowe 2003, class d = {d} mm"),
                class(d, &|p| (p.wilcock_crowe, 0.0)),
            )
        }))
        .collect();
    let figure = TransportFigure {
        series,
        references: vec![ctx.reference],
        title: format!(
            "Stage 5: fractional transport per class, d = {} mm (bars: ±1 s.e. over seeds)",
            diameters
                .iter()
                .map(f64::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
        x_label: "class Shields number τ*_k = τ* d_max / d_k".into(),
        y_label: "fractional transport q*_k / f_k (q*_k: class k's q*, f_k: its fraction)".into(),
        flags: Vec::new(),
    };
    save(&figure, &ctx.dir, "stage5")?;
    save_stage(&ctx.dir, "stage5", r)
}
