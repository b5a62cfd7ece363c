//! Stage 3 (docs/model.md §9 step 3): scale α_m and α_cn by β (18) until
//! q*(τ*) matches the reference relation: a grid of β first (its cells can
//! be sharded), then a golden-section search on ln β around the best grid
//! point.

use super::{save_stage, slot_of};
use crate::calibrate::optimise::{grid_then_golden, Search};
use crate::calibrate::{Context, Curve};
use crate::error::HostError;
use crate::output::{decimal, write_csv};
use crate::plot::{save, LinesFigure, TransportFigure, Q_STAR_AXIS, TAU_STAR_AXIS};
use serde::{Deserialize, Serialize};

/// The outcome of stage 3.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BetaStage {
    /// α_m of stage 1.
    pub alpha_m: f64,
    /// α_cn of stage 2.
    pub alpha_cn: f64,
    /// The grid scan and its golden-section refinement in β.
    pub search: Search,
    /// The fitted β.
    pub beta: f64,
    /// q*(τ*) at β = 1 (before).
    pub before: Curve,
    /// q*(τ*) at the fitted β (after).
    pub after: Curve,
    /// Largest factor between q* and the reference after the fit.
    pub worst_factor: f64,
    /// Misfit (mean squared log-ratio) after the fit.
    pub misfit: f64,
    /// β's uncertainty: the smallest and largest β evaluated whose misfit
    /// is within twice the noise misfit of the minimum ([`beta_range`]).
    #[serde(default)]
    pub beta_range: (f64, f64),
}

/// The β evaluated (grid and refinement) whose misfit lies within
/// `2 noise` of the smallest misfit: (smallest, largest) of them. Misfits
/// that differ by less than what the points' standard errors give alone
/// (`noise`, [`Curve::misfit_noise`]) do not tell the β apart.
///
/// ```
/// use mbs::calibrate::stages::beta::beta_range;
///
/// let evaluations = [(1.0, 2.0), (2.0, 0.30), (4.0, 0.10), (8.0, 0.25), (16.0, 1.0)];
/// assert_eq!(beta_range(&evaluations, 0.1), (2.0, 8.0));
/// assert_eq!(beta_range(&evaluations, 0.01), (4.0, 4.0));
/// ```
pub fn beta_range(evaluations: &[(f64, f64)], noise: f64) -> (f64, f64) {
    let best = evaluations
        .iter()
        .map(|e| e.1)
        .fold(f64::INFINITY, f64::min);
    evaluations
        .iter()
        .filter(|e| e.1 <= best + 2.0 * noise)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), e| {
            (lo.min(e.0), hi.max(e.0))
        })
}

/// Runs stage 3.
pub fn run(ctx: &Context<'_>, alpha_m: f64, alpha_cn: f64) -> Result<Option<BetaStage>, HostError> {
    let plan = &ctx.plan;
    let points = plan.fit_points();
    let cells = points.iter().map(|p| p.1.len()).sum();
    let window = plan.window;
    let curve_at = |beta: f64, evaluation: usize| {
        let c = ctx.configure(alpha_m, alpha_cn, beta);
        ctx.curve(&c, &points, window, &slot_of(evaluation, cells))
    };
    // The grid's cells can go to other shards; the refinement follows it.
    let mut evaluation = 0;
    let search = grid_then_golden(&plan.beta_grid, plan.beta_tolerance, |beta| {
        let curve = curve_at(beta, evaluation)?;
        evaluation += 1;
        Ok(curve.map(|c| c.misfit(ctx.reference)))
    })?;
    let Some(search) = search else {
        return Ok(None);
    };
    let beta = search.best.0;
    let extra = evaluation;
    let (Some(before), Some(after)) = (curve_at(1.0, extra)?, curve_at(beta, extra + 1)?) else {
        return Ok(None);
    };
    let evaluations: Vec<(f64, f64)> = search
        .grid
        .iter()
        .chain(&search.refinement)
        .copied()
        .collect();
    let result = BetaStage {
        alpha_m,
        alpha_cn,
        beta_range: beta_range(&evaluations, after.misfit_noise()),
        worst_factor: after.worst_factor(ctx.reference),
        misfit: after.misfit(ctx.reference),
        search,
        beta,
        before,
        after,
    };
    write_outputs(ctx, &result)?;
    Ok(Some(result))
}

/// A line of `stage3.csv`: one evaluation of the search.
#[derive(Serialize)]
struct EvaluationLine {
    #[serde(serialize_with = "decimal")]
    beta: f64,
    #[serde(serialize_with = "decimal")]
    misfit: f64,
}

/// A line of `stage3_transport.csv`: q* at one τ* before and after the fit.
#[derive(Serialize)]
struct TransportLine {
    #[serde(serialize_with = "decimal")]
    tau_star: f64,
    #[serde(serialize_with = "decimal")]
    q_star_before: f64,
    #[serde(serialize_with = "decimal")]
    stderr_before: f64,
    #[serde(serialize_with = "decimal")]
    q_star_after: f64,
    #[serde(serialize_with = "decimal")]
    stderr_after: f64,
    #[serde(serialize_with = "decimal")]
    reference: f64,
}

fn write_outputs(ctx: &Context<'_>, r: &BetaStage) -> Result<(), HostError> {
    let mut evaluations: Vec<(f64, f64)> = r.search.grid.clone();
    evaluations.extend(r.search.refinement.iter().copied());
    let lines: Vec<EvaluationLine> = evaluations
        .iter()
        .map(|&(beta, misfit)| EvaluationLine { beta, misfit })
        .collect();
    write_csv(&ctx.dir.join("stage3.csv"), None, &lines)?;
    let lines: Vec<TransportLine> = (0..r.after.tau_stars.len())
        .map(|k| {
            let t = r.after.tau_stars[k];
            TransportLine {
                tau_star: t,
                q_star_before: r.before.q_star[k],
                stderr_before: r.before.stderr[k],
                q_star_after: r.after.q_star[k],
                stderr_after: r.after.stderr[k],
                reference: ctx.reference.q_star(t),
            }
        })
        .collect();
    write_csv(&ctx.dir.join("stage3_transport.csv"), None, &lines)?;
    let figure = TransportFigure {
        series: vec![
            (format!("β = {:.3} (fitted)", r.beta), r.after.points()),
            ("β = 1 (before)".to_string(), r.before.points()),
        ],
        references: vec![ctx.reference],
        title: format!(
            "Stage 3: q* before and after β (α_m = {}, α_cn = {})",
            r.alpha_m, r.alpha_cn
        ),
        x_label: TAU_STAR_AXIS.into(),
        y_label: Q_STAR_AXIS.into(),
    };
    save(&figure, &ctx.dir, "stage3")?;
    let mut grid = r.search.grid.clone();
    grid.sort_by(|a, b| a.0.total_cmp(&b.0));
    let misfit = LinesFigure {
        x_ticks: grid.iter().map(|p| p.0).collect(),
        series: vec![("grid".into(), grid)],
        dots: vec![("golden-section search".into(), r.search.refinement.clone())],
        title: format!("Stage 3: misfit to {} against β", ctx.reference.label()),
        x_label: "β".into(),
        y_label: "misfit: mean squared ln(q*/q*_ref)".into(),
        log_axes: true,
        markers: true,
        marks: vec![(r.beta, format!("chosen β = {:.3}", r.beta))],
    };
    save(&misfit, &ctx.dir, "stage3_misfit")?;
    save_stage(&ctx.dir, "stage3", r)
}
