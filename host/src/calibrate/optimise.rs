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
