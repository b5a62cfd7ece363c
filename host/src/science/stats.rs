//! Statistics of the measured q*: the mean and its standard error, the
//! error target a cell's window runs to, and the steadiness check of a
//! τ*'s time series.
//!
//! Block means (batch means): the window is cut into blocks of
//! `time.block` seconds and the standard error is that of the mean of the
//! block means, which removes the correlation of the raw samples (every
//! `time.sample_steps` steps) within a block. Blocks of 0.1 s are still
//! correlated with their neighbours (lag-1 autocorrelation 0.1–0.8 on the
//! default bed), so [`block_stderr`] widens the error by the factor
//! √((1 + ρ)/(1 − ρ)) of a first-order autoregressive series with the
//! blocks' lag-1 autocorrelation ρ (clamped to [0, 0.9]).

use serde::Serialize;

/// Mean and standard error of the mean (0 for fewer than two values; NaN
/// for none).
///
/// ```
/// use mbs::science::stats::mean_stderr;
///
/// let (m, e) = mean_stderr(&[1.0, 2.0, 3.0, 4.0]);
/// assert_eq!(m, 2.5);
/// assert!((e - (5.0f64 / 3.0 / 4.0).sqrt()).abs() < 1e-15);
/// assert_eq!(mean_stderr(&[7.0]), (7.0, 0.0));
/// ```
pub fn mean_stderr(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    if values.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let mean = values.iter().sum::<f64>() / n;
    if values.len() < 2 {
        return (mean, 0.0);
    }
    let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// Mean of block means and its standard error corrected for the
/// correlation between neighbouring blocks: the plain standard error times
/// √((1 + ρ)/(1 − ρ)), ρ the lag-1 autocorrelation of the blocks clamped
/// to [0, 0.9] (0 with fewer than three blocks).
///
/// ```
/// use mbs::science::stats::{block_stderr, mean_stderr};
///
/// // Alternating blocks: negatively correlated, no widening.
/// let alternating = [1.0, 2.0, 1.0, 2.0, 1.0, 2.0];
/// assert_eq!(block_stderr(&alternating), mean_stderr(&alternating));
/// // A steady drift: ρ = 8.75/17.5 = 0.5, widened by √3.
/// let drift = [1.0, 1.1, 1.2, 1.3, 1.4, 1.5];
/// let (m, e) = block_stderr(&drift);
/// assert!((e - mean_stderr(&drift).1 * 3f64.sqrt()).abs() < 1e-12 && m == mean_stderr(&drift).0);
/// ```
pub fn block_stderr(blocks: &[f64]) -> (f64, f64) {
    let (mean, stderr) = mean_stderr(blocks);
    if blocks.len() < 3 {
        return (mean, stderr);
    }
    let var: f64 = blocks.iter().map(|b| (b - mean) * (b - mean)).sum();
    let lag: f64 = blocks
        .windows(2)
        .map(|w| (w[0] - mean) * (w[1] - mean))
        .sum();
    let rho = if var > 0.0 {
        (lag / var).clamp(0.0, 0.9)
    } else {
        0.0
    };
    (mean, stderr * ((1.0 + rho) / (1.0 - rho)).sqrt())
}

/// The standard error each cell's window aims at: the larger of
/// `relative` × |q*| and `absolute` (the floor near the threshold, where
/// q* → 0). It is the error of one seed's window, so that a cell's result
/// does not depend on how many seeds the run has; the mean of n seeds then
/// has about 1/√n of it when the seeds' beds differ no more than their
/// windows do (the reported error is measured between the seeds).
///
/// ```
/// use mbs::science::stats::Target;
///
/// let t = Target { relative: 0.04, absolute: 4e-4 };
/// // q* = 1 ± 0.0245 (uncorrelated block means): within 0.04 × 1.
/// assert!(t.reached(&[0.94, 1.0, 1.06, 0.94, 1.0, 1.06]));
/// // q* = 1 ± 0.082: not yet.
/// assert!(!t.reached(&[0.8, 1.0, 1.2, 0.8, 1.0, 1.2]));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// Relative standard error of q*.
    pub relative: f64,
    /// Absolute standard error of q* (floor).
    pub absolute: f64,
}

impl Target {
    /// Whether the block means `blocks` of one cell (at least two) reach
    /// the target, by [`block_stderr`].
    pub fn reached(&self, blocks: &[f64]) -> bool {
        if blocks.len() < 2 {
            return false;
        }
        let (mean, stderr) = block_stderr(blocks);
        stderr <= (self.relative * mean.abs()).max(self.absolute)
    }
}

/// The steadiness check of a τ*: q* over the first and the last third of
/// each of its cells' windows (their block means pooled over the seeds).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Steadiness {
    /// Mean q* over the first thirds.
    pub first: f64,
    /// Its standard error.
    pub first_stderr: f64,
    /// Mean q* over the last thirds.
    pub last: f64,
    /// Its standard error.
    pub last_stderr: f64,
    /// The two agree within twice their combined standard error.
    pub steady: bool,
}

impl Steadiness {
    /// The check over the block means of each cell of a τ*; `None` when a
    /// cell has fewer than three blocks (no thirds to compare).
    ///
    /// ```
    /// use mbs::science::stats::Steadiness;
    ///
    /// let flat = [vec![1.0, 1.1, 0.9, 1.0, 1.1, 0.9]];
    /// assert!(Steadiness::of(&flat).unwrap().steady);
    /// let falling = [vec![2.0, 2.1, 1.5, 1.4, 1.0, 1.1]];
    /// assert!(!Steadiness::of(&falling).unwrap().steady);
    /// ```
    pub fn of(cells: &[Vec<f64>]) -> Option<Steadiness> {
        if cells.is_empty() {
            return None;
        }
        let (mut first, mut last) = (Vec::new(), Vec::new());
        for blocks in cells {
            let third = blocks.len() / 3;
            if third == 0 {
                return None;
            }
            first.extend_from_slice(&blocks[..third]);
            last.extend_from_slice(&blocks[blocks.len() - third..]);
        }
        let (f, fe) = mean_stderr(&first);
        let (l, le) = mean_stderr(&last);
        Some(Steadiness {
            first: f,
            first_stderr: fe,
            last: l,
            last_stderr: le,
            steady: (l - f).abs() <= 2.0 * (fe * fe + le * le).sqrt(),
        })
    }
}
