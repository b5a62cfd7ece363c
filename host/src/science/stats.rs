//! Statistics of the measured q*: the mean and its standard error, the
//! error target a cell's window runs to, and the drift check of a τ*'s
//! steady parts. The window is cut into blocks of `time.block` seconds
//! (block means remove the correlation of the raw samples, every
//! `time.sample_steps` steps, within a block); the transient is cut off
//! by [`crate::science::truncation`] and the intervals are those of
//! [`crate::science::interval`].

use crate::science::interval::{correlation_time, mean_stderr, Interval, CORRELATION_WINDOWS};
use serde::Serialize;

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
/// let wiggle = |a: f64| -> Vec<f64> { (0..20).map(|i| 1.0 + a * [-1.0, 0.0, 1.0][i % 3]).collect() };
/// // q* = 1 ± 0.006 over five batches of four blocks: within 0.04 × 1.
/// assert!(t.reached(&wiggle(0.06)));
/// // q* = 1 ± 0.06: not yet.
/// assert!(!t.reached(&wiggle(0.6)));
/// // Eight blocks are fewer than ten correlation times.
/// assert!(!t.reached(&wiggle(0.06)[..8]));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// Relative standard error of q*.
    pub relative: f64,
    /// Absolute standard error of q* (floor).
    pub absolute: f64,
}

impl Target {
    /// Whether the steady block means `blocks` of one cell reach the
    /// target: the batch-means standard error
    /// ([`Interval::batch_means`]) is within it, and the blocks span at
    /// least [`CORRELATION_WINDOWS`] correlation times
    /// ([`correlation_time`]), where that interval has its tested coverage.
    pub fn reached(&self, blocks: &[f64]) -> bool {
        let n = blocks.len() as f64;
        // NaN (a constant or too short series) is not long enough.
        let long = n >= CORRELATION_WINDOWS * correlation_time(blocks);
        if n < 2.0 || !long {
            return false;
        }
        let i = Interval::batch_means(blocks);
        i.dof > 0 && i.stderr <= (self.relative * i.mean.abs()).max(self.absolute)
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
