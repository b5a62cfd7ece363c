//! Where a cell's transient ends: the MSER truncation rule (White 1997;
//! docs/model.md §8, (E1)) applied to the block means of its window.
//!
//! MSER picks the number d of leading blocks to discard that minimises the
//! squared standard error of the remaining mean computed as if they were
//! independent,
//!
//! MSER(d) = Σ_{i>d} (y_i − ȳ_d)² / (n − d)²,
//!
//! over d = 0 … n − [`MIN_TAIL`]. Each block is already a batch mean of
//! `time.block / time.sample_steps` samples, so this is White, Cobb &
//! Spratt's (2000) MSER-m with m the block's samples (MSER-5 batches five).
//! A minimum in the second half of the series means the series is too short
//! to hold a steady part (White 1997): the cell is then not steady, and
//! keeps its last half, the most the rule lets it discard.

/// The fewest blocks MSER keeps: enough for the window's batch-means
/// interval ([`crate::science::interval::BATCHES`]).
pub const MIN_TAIL: usize = crate::science::interval::BATCHES;

/// The transient MSER finds in a series of block means.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Truncation {
    /// Leading blocks discarded (the transient): MSER's minimum, at most
    /// half the series.
    pub discard: usize,
    /// The discarded part is at most half the series: a steady part was
    /// found.
    pub steady: bool,
}

impl Truncation {
    /// The MSER truncation of `blocks` (time order). A series shorter than
    /// [`MIN_TAIL`] discards nothing and is not steady; one with a
    /// non-finite value likewise.
    ///
    /// ```
    /// use mbs::science::truncation::Truncation;
    ///
    /// // A decay onto a level: the decay is discarded.
    /// let decay = [8.0, 4.0, 2.0, 1.0, 1.1, 0.9, 1.0, 1.1, 0.9, 1.0, 1.05, 0.95];
    /// assert_eq!(Truncation::of(&decay), Truncation { discard: 3, steady: true });
    /// // Noise about a level: nothing to discard.
    /// let flat = [1.0, 1.2, 0.8, 1.1, 0.9, 1.0, 1.2, 0.8];
    /// assert_eq!(Truncation::of(&flat).discard, 0);
    /// // Still falling at the end: no steady part; the last half is kept.
    /// let falling = [9.0, 8.0, 7.0, 6.0, 5.0, 4.0, 3.0, 2.0, 1.9, 2.1, 1.95, 2.05];
    /// assert_eq!(Truncation::of(&falling), Truncation { discard: 6, steady: false });
    /// ```
    pub fn of(blocks: &[f64]) -> Truncation {
        let n = blocks.len();
        if n < MIN_TAIL || !blocks.iter().all(|y| y.is_finite()) {
            return Truncation {
                discard: 0,
                steady: false,
            };
        }
        // Sums over the tail y_d … y_{n−1}, from the end: MSER(d) =
        // (Σy² − (Σy)²/m)/m² with m = n − d, centred on the series' mean
        // to keep the difference of sums accurate.
        let centre = blocks.iter().sum::<f64>() / n as f64;
        let (mut sum, mut squares) = (0.0, 0.0);
        let mut best = (f64::INFINITY, 0);
        for d in (0..n).rev() {
            let y = blocks[d] - centre;
            sum += y;
            squares += y * y;
            let m = (n - d) as f64;
            if n - d < MIN_TAIL {
                continue;
            }
            let mser = (squares - sum * sum / m).max(0.0) / (m * m);
            // Ties go to the smaller d (less discarded).
            if mser <= best.0 {
                best = (mser, d);
            }
        }
        Truncation {
            discard: best.1.min(n / 2),
            steady: 2 * best.1 <= n,
        }
    }

    /// The steady part of `blocks`: those after the discarded ones.
    pub fn kept<'a>(&self, blocks: &'a [f64]) -> &'a [f64] {
        &blocks[self.discard.min(blocks.len())..]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// MSER(d) straight from its definition.
    fn mser(blocks: &[f64], d: usize) -> f64 {
        let tail = &blocks[d..];
        let m = tail.len() as f64;
        let mean = tail.iter().sum::<f64>() / m;
        tail.iter().map(|y| (y - mean) * (y - mean)).sum::<f64>() / (m * m)
    }

    #[test]
    fn the_discard_minimises_the_statistic_of_its_definition() {
        let mut state = 7u64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for n in [5, 6, 11, 40, 100] {
            for _ in 0..50 {
                let level = 1.0 + uniform();
                let blocks: Vec<f64> = (0..n)
                    .map(|i| level * (1.0 + 3.0 * (-(i as f64) / 4.0).exp()) + uniform() - 0.5)
                    .collect();
                let t = Truncation::of(&blocks);
                let (best, at) = (0..=n - MIN_TAIL)
                    .map(|d| (mser(&blocks, d), d))
                    .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a });
                assert_eq!(t.steady, 2 * at <= n, "n {n}: {t:?}");
                if t.steady {
                    assert!(
                        (mser(&blocks, t.discard) - best).abs() <= 1e-12 * best.max(1e-300),
                        "n {n}: {t:?}"
                    );
                } else {
                    assert_eq!(t.discard, n / 2);
                }
            }
        }
    }

    #[test]
    fn short_or_broken_series_are_not_steady() {
        assert!(!Truncation::of(&[1.0, 2.0, 3.0, 4.0]).steady);
        assert!(!Truncation::of(&[1.0, 2.0, f64::NAN, 4.0, 5.0, 6.0]).steady);
        assert!(Truncation::of(&[1.0; 5]).steady);
        assert_eq!(Truncation::of(&[1.0; 5]).discard, 0);
    }
}
