//! q*(τ*) of one configuration over seeds, and its misfit to a reference
//! relation (docs/calibration.md).

use crate::science::references::Reference;
use serde::{Deserialize, Serialize};

/// q*(τ*) of one configuration, averaged over seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Curve {
    /// Shields numbers.
    pub tau_stars: Vec<f64>,
    /// Mean q* over seeds (NaN where a cell failed).
    pub q_star: Vec<f64>,
    /// Standard error between seeds (one seed: of its batch means).
    pub stderr: Vec<f64>,
    /// Degrees of freedom of each standard error (its t quantile; 0: none).
    #[serde(default)]
    pub dof: Vec<usize>,
    /// Per size class: mean q* per τ*.
    pub classes: Vec<Vec<f64>>,
    /// Per size class: the standard error of that mean between seeds (0
    /// with one seed).
    #[serde(default)]
    pub class_stderr: Vec<Vec<f64>>,
    /// Kernel failures (cell message), if any.
    pub failures: Vec<String>,
    /// Seeds averaged per τ*.
    #[serde(default)]
    pub seeds: Vec<usize>,
    /// Per τ*: whether the point's standard error reached the target (or
    /// its verdict was clear) before the seed cap.
    #[serde(default)]
    pub reached: Vec<bool>,
}

/// Misfit of a failed or non-positive point: a large but finite penalty so
/// the search moves away from it.
pub const FAILED_MISFIT: f64 = 100.0;

/// Smallest q* used in a logarithm: about what a window resolves (one
/// grain of the default bed, 40 columns, moving one diameter in a 2-s
/// window gives q* ≈ 4e-5), so a point with no transport counts as 1e-4,
/// a few such grains, whatever its reference. (Until
/// 2026-11 a q* below a tenth of the reference counted as a tenth, which
/// hid how far off a curve was near the threshold.)
pub const Q_FLOOR: f64 = 1e-4;

impl Curve {
    /// (τ*, q*, stderr) of every point, for error bars.
    pub fn points(&self) -> Vec<(f64, f64, f64)> {
        self.tau_stars
            .iter()
            .zip(self.q_star.iter().zip(&self.stderr))
            .map(|(&t, (&q, &e))| (t, q, e))
            .collect()
    }

    /// The log-ratio ln(q*/q*_ref) of every point, both floored at
    /// [`Q_FLOOR`], with its relative standard error.
    pub fn log_ratios(&self, reference: Reference) -> Vec<(f64, f64)> {
        self.tau_stars
            .iter()
            .zip(self.q_star.iter().zip(&self.stderr))
            .map(|(&t, (&q, &e))| {
                let q_ref = reference.q_star(t).max(Q_FLOOR);
                let q = q.max(Q_FLOOR);
                let relative = e / q;
                (
                    (q / q_ref).ln(),
                    if relative.is_finite() { relative } else { 0.0 },
                )
            })
            .collect()
    }

    /// The weight of a point with relative standard error `relative`:
    /// 1/(relative² + floor²). A point resolved to the `floor` (the target's
    /// relative error) weighs about fully, a noisier one less.
    fn weight(relative: f64, floor: f64) -> f64 {
        1.0 / (relative * relative + floor * floor)
    }

    /// The misfit (the objective of stage 3): the mean squared log-ratio of
    /// q* to `reference`, each point weighted by its error ([`Self::log_ratios`],
    /// weights 1/(σ_r² + floor²), `floor` the target's relative error);
    /// [`FAILED_MISFIT`] if any cell failed.
    pub fn misfit(&self, reference: Reference, floor: f64) -> f64 {
        if !self.failures.is_empty() {
            return FAILED_MISFIT;
        }
        self.weighted(reference, floor, |r, _| r * r)
    }

    /// The misfit that noise alone gives: the weighted mean of the squared
    /// relative standard errors σ_r², the expected misfit of a curve that
    /// matches the reference and scatters by its errors.
    pub fn misfit_noise(&self, reference: Reference, floor: f64) -> f64 {
        self.weighted(reference, floor, |_, e| e * e)
    }

    /// The weighted mean log-ratio (the root stage 4 searches) and its
    /// standard error.
    pub fn mean_log_ratio(&self, reference: Reference, floor: f64) -> (f64, f64) {
        let ratios = self.log_ratios(reference);
        let weights: Vec<f64> = ratios
            .iter()
            .map(|&(_, e)| Self::weight(e, floor))
            .collect();
        let total: f64 = weights.iter().sum();
        let mean = ratios
            .iter()
            .zip(&weights)
            .map(|(p, w)| w * p.0)
            .sum::<f64>()
            / total;
        let variance: f64 = ratios
            .iter()
            .zip(&weights)
            .map(|(p, w)| (w / total * p.1).powi(2))
            .sum();
        (mean, variance.sqrt())
    }

    fn weighted(&self, reference: Reference, floor: f64, f: impl Fn(f64, f64) -> f64) -> f64 {
        let ratios = self.log_ratios(reference);
        let (sum, total) = ratios.iter().fold((0.0, 0.0), |(s, w), &(r, e)| {
            let weight = Self::weight(e, floor);
            (s + weight * f(r, e), w + weight)
        });
        if total > 0.0 {
            sum / total
        } else {
            FAILED_MISFIT
        }
    }

    /// Largest factor between q* and `reference` (either way) over the curve.
    pub fn worst_factor(&self, reference: Reference) -> f64 {
        self.tau_stars
            .iter()
            .zip(&self.q_star)
            .map(|(&t, &q)| {
                let r = q.max(Q_FLOOR) / reference.q_star(t).max(Q_FLOOR);
                r.max(1.0 / r)
            })
            .fold(1.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    fn curve(factors: &[f64], relative: &[f64]) -> super::Curve {
        let r = crate::science::references::Reference::MeyerPeterMuller;
        let tau_stars = vec![0.1, 0.2];
        let q_star: Vec<f64> = tau_stars
            .iter()
            .zip(factors)
            .map(|(&t, f)| f * r.q_star(t))
            .collect();
        super::Curve {
            stderr: q_star.iter().zip(relative).map(|(q, e)| q * e).collect(),
            dof: vec![3, 3],
            q_star,
            tau_stars,
            classes: vec![],
            class_stderr: vec![],
            failures: vec![],
            seeds: vec![4, 4],
            reached: vec![true, true],
        }
    }

    #[test]
    fn the_misfit_weights_each_point_by_its_error() {
        let r = crate::science::references::Reference::MeyerPeterMuller;
        let ln2 = 2f64.ln();
        let exact = curve(&[1.0, 1.0], &[0.0, 0.0]);
        assert_eq!(exact.misfit(r, 0.1), 0.0);
        assert_eq!(exact.mean_log_ratio(r, 0.1), (0.0, 0.0));
        let double = curve(&[2.0, 2.0], &[0.0, 0.3]);
        assert!((double.misfit(r, 0.1) - ln2 * ln2).abs() < 1e-12);
        // A point of small error off by 2 (weight 100) and a noisy exact one (σ_r
        // 0.3: weight 10): the one of small error dominates.
        let mixed = curve(&[2.0, 1.0], &[0.0, 0.3]);
        assert!((mixed.misfit(r, 0.1) - ln2 * ln2 * 100.0 / 110.0).abs() < 1e-12);
        let (mean, sigma) = mixed.mean_log_ratio(r, 0.1);
        assert!((mean - ln2 * 100.0 / 110.0).abs() < 1e-12);
        assert!((sigma - 0.3 * 10.0 / 110.0).abs() < 1e-12);
        assert!((mixed.misfit_noise(r, 0.1) - 0.09 * 10.0 / 110.0).abs() < 1e-12);
        let mut failed = mixed.clone();
        failed.failures.push("lost".into());
        assert_eq!(failed.misfit(r, 0.1), super::FAILED_MISFIT);
    }

    #[test]
    fn points_far_below_the_reference_count_as_far_as_they_are() {
        let r = crate::science::references::Reference::MeyerPeterMuller;
        // A point 20× and one 100× below the reference: told apart (a
        // floor at a tenth of the reference made them equal).
        let (far, farther) = (
            curve(&[0.05, 1.0], &[0.1, 0.1]),
            curve(&[0.01, 1.0], &[0.1, 0.1]),
        );
        assert!(farther.misfit(r, 0.1) > far.misfit(r, 0.1) * 2.0);
        assert!((far.log_ratios(r)[0].0 - 0.05f64.ln()).abs() < 1e-12);
        // No transport at all counts as Q_FLOOR.
        let none = curve(&[0.0, 1.0], &[0.0, 0.1]);
        let q_ref = r.q_star(0.1);
        assert!((none.log_ratios(r)[0].0 - (super::Q_FLOOR / q_ref).ln()).abs() < 1e-12);
    }
}
