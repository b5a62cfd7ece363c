//! One-dimensional minimisation by golden-section search.

use crate::error::HostError;
use serde::{Deserialize, Serialize};

/// The result of a search.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Minimum {
    /// Best argument found.
    pub x: f64,
    /// Objective there.
    pub value: f64,
    /// Every (argument, objective) evaluated, in order.
    pub evaluations: Vec<(f64, f64)>,
}

/// Minimises `f` over `[a, b]` by golden-section search until the bracket is
/// narrower than `tol`. `f` returns `None` when it cannot be evaluated yet
/// (cells owned by other shards): the search then returns `None`.
pub fn golden_section(
    mut a: f64,
    mut b: f64,
    tol: f64,
    mut f: impl FnMut(f64) -> Result<Option<f64>, HostError>,
) -> Result<Option<Minimum>, HostError> {
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let mut evaluations = Vec::new();
    let mut eval = |x: f64, log: &mut Vec<(f64, f64)>| -> Result<Option<f64>, HostError> {
        let v = f(x)?;
        if let Some(v) = v {
            log.push((x, v));
        }
        Ok(v)
    };
    let mut c = b - ratio * (b - a);
    let mut d = a + ratio * (b - a);
    let (Some(mut fc), Some(mut fd)) = (eval(c, &mut evaluations)?, eval(d, &mut evaluations)?)
    else {
        return Ok(None);
    };
    while (b - a).abs() > tol {
        if fc <= fd {
            b = d;
            (d, fd) = (c, fc);
            c = b - ratio * (b - a);
            let Some(v) = eval(c, &mut evaluations)? else {
                return Ok(None);
            };
            fc = v;
        } else {
            a = c;
            (c, fc) = (d, fd);
            d = a + ratio * (b - a);
            let Some(v) = eval(d, &mut evaluations)? else {
                return Ok(None);
            };
            fd = v;
        }
    }
    let (x, value) = if fc <= fd { (c, fc) } else { (d, fd) };
    Ok(Some(Minimum {
        x,
        value,
        evaluations,
    }))
}

/// A grid scan refined by golden section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Search {
    /// (argument, objective) on the grid.
    pub grid: Vec<(f64, f64)>,
    /// (argument, objective) of the golden-section refinement, in order.
    pub refinement: Vec<(f64, f64)>,
    /// The best (argument, objective) of all.
    pub best: (f64, f64),
}

/// Minimises `f` over positive arguments: evaluates every `grid` point
/// (all of them, so a shard computes all its cells), then searches ln x by
/// golden section between the neighbours of the best grid point (half or
/// twice the end point beyond the grid's ends) until the bracket ratio is
/// below `ratio`. Returns the best evaluation of all (the objective may be
/// rough), or `None` while any value is missing.
pub fn grid_then_golden(
    grid: &[f64],
    ratio: f64,
    mut f: impl FnMut(f64) -> Result<Option<f64>, HostError>,
) -> Result<Option<Search>, HostError> {
    let mut scanned = Vec::new();
    for &x in grid {
        if let Some(v) = f(x)? {
            scanned.push((x, v));
        }
    }
    if scanned.len() < grid.len() || scanned.is_empty() {
        return Ok(None);
    }
    let best = scanned
        .iter()
        .enumerate()
        .min_by(|a, b| a.1 .1.total_cmp(&b.1 .1))
        .map_or(0, |(i, _)| i);
    let lo = if best == 0 {
        scanned[0].0 / 2.0
    } else {
        scanned[best - 1].0
    };
    let hi = if best + 1 == scanned.len() {
        scanned[best].0 * 2.0
    } else {
        scanned[best + 1].0
    };
    let Some(m) = golden_section(lo.ln(), hi.ln(), ratio.ln(), |x| f(x.exp()))? else {
        return Ok(None);
    };
    let refinement: Vec<(f64, f64)> = m.evaluations.iter().map(|&(x, v)| (x.exp(), v)).collect();
    let best = scanned
        .iter()
        .chain(&refinement)
        .copied()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or(scanned[0]);
    Ok(Some(Search {
        grid: scanned,
        refinement,
        best,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_minimum_of_a_parabola_within_the_tolerance() {
        let m = golden_section(0.0, 3.0, 1e-4, |x| Ok(Some((x - 1.3) * (x - 1.3) + 2.0)))
            .unwrap()
            .unwrap();
        assert!((m.x - 1.3).abs() < 1e-4, "{}", m.x);
        assert!((m.value - 2.0).abs() < 1e-8);
        // Each iteration shrinks the bracket by 0.618: ln(3e4)/ln(1/0.618) ≈ 22.
        assert!(m.evaluations.len() <= 25, "{}", m.evaluations.len());
    }

    #[test]
    fn grid_then_golden_refines_around_the_best_grid_point() {
        let f = |x: f64| Ok(Some((x.ln() - 3.1f64.ln()).powi(2)));
        let s = grid_then_golden(&[1.0, 2.0, 4.0, 8.0], 1.01, f)
            .unwrap()
            .unwrap();
        assert_eq!(s.grid.len(), 4);
        assert!((s.best.0 / 3.1 - 1.0).abs() < 0.01, "{:?}", s.best);
        // The best grid point is 4: the search runs between its neighbours 2 and 8.
        assert!(s
            .refinement
            .iter()
            .all(|&(x, _)| (1.999..=8.001).contains(&x)));
        let beyond = grid_then_golden(&[1.0, 2.0], 1.01, |x| Ok(Some((x - 3.0).abs())))
            .unwrap()
            .unwrap();
        assert!(
            (beyond.best.0 - 3.0).abs() < 0.05,
            "past the end: {:?}",
            beyond.best
        );
        let missing = grid_then_golden(&[1.0, 2.0], 1.1, |x| Ok((x < 1.5).then_some(x))).unwrap();
        assert_eq!(missing, None);
    }

    #[test]
    fn stops_when_a_value_is_missing() {
        let mut n = 0;
        let r = golden_section(0.0, 1.0, 1e-3, |x| {
            n += 1;
            Ok(if n < 4 { Some(x) } else { None })
        })
        .unwrap();
        assert_eq!(r, None);
    }
}
