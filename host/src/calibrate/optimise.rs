//! The one-dimensional model fits of the searches: a least-squares parabola
//! (stage 3's minimum of the misfit in ln β) and false position (stage 4's
//! root of the mean log-ratio in ln constants_dt).

use serde::{Deserialize, Serialize};

/// y = y_min + curvature (x − x_min)², fitted by least squares.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Parabola {
    /// Where the parabola is lowest (or highest, if `curvature` < 0).
    pub x_min: f64,
    /// Its value there.
    pub y_min: f64,
    /// The coefficient of (x − x_min)².
    pub curvature: f64,
}

impl Parabola {
    /// The least-squares parabola through `points` (x, y); `None` with
    /// fewer than three distinct x or a degenerate fit.
    ///
    /// ```
    /// use mbs::calibrate::optimise::Parabola;
    ///
    /// let p = Parabola::fit(&[(0.0, 5.0), (1.0, 2.0), (2.0, 1.0), (3.0, 2.0)]).unwrap();
    /// assert!((p.x_min - 2.0).abs() < 0.3 && p.curvature > 0.0);
    /// let exact = Parabola::fit(&[(-1.0, 4.0), (1.0, 0.0), (2.0, 1.0)]).unwrap();
    /// assert!((exact.x_min - 1.0).abs() < 1e-12 && exact.y_min.abs() < 1e-12);
    /// assert!((exact.at(3.0) - 4.0).abs() < 1e-12);
    /// ```
    pub fn fit(points: &[(f64, f64)]) -> Option<Parabola> {
        let n = points.len() as f64;
        if points.len() < 3 {
            return None;
        }
        // Centre x for conditioning, then solve the 3×3 normal equations.
        let mean = points.iter().map(|p| p.0).sum::<f64>() / n;
        let mut s = [0.0f64; 5];
        let mut t = [0.0f64; 3];
        for &(x, y) in points {
            let u = x - mean;
            let mut power = 1.0;
            for (k, sk) in s.iter_mut().enumerate() {
                *sk += power;
                if k < 3 {
                    t[k] += power * y;
                }
                power *= u;
            }
        }
        let m = [[s[0], s[1], s[2]], [s[1], s[2], s[3]], [s[2], s[3], s[4]]];
        let det = |m: &[[f64; 3]; 3]| {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        };
        let d = det(&m);
        // Fewer than three distinct x: the determinant vanishes against the
        // product of the diagonal.
        if d.is_nan() || d.abs() <= 1e-12 * s[0] * s[2] * s[4] {
            return None;
        }
        // Cramer's rule for the coefficients (a, b, c) of a + b u + c u².
        let solve = |col: usize| {
            let mut mk = m;
            for (row, value) in mk.iter_mut().zip(t) {
                row[col] = value;
            }
            det(&mk) / d
        };
        let (a, b, c) = (solve(0), solve(1), solve(2));
        if c == 0.0 || !c.is_finite() {
            return None;
        }
        let u_min = -b / (2.0 * c);
        Some(Parabola {
            x_min: mean + u_min,
            y_min: a - b * b / (4.0 * c),
            curvature: c,
        })
    }

    /// The parabola at `x`.
    pub fn at(&self, x: f64) -> f64 {
        self.y_min + self.curvature * (x - self.x_min).powi(2)
    }

    /// The x where the parabola is within `excess` of its minimum:
    /// (x_min − w, x_min + w), w = √(excess / curvature); `None` unless convex.
    pub fn within(&self, excess: f64) -> Option<(f64, f64)> {
        (self.curvature > 0.0).then(|| {
            let w = (excess.max(0.0) / self.curvature).sqrt();
            (self.x_min - w, self.x_min + w)
        })
    }
}

/// The next x of a root search of a decreasing f from the evaluations
/// (x, f) so far: where the line through the nearest pair with opposite
/// signs crosses zero (false position, never outside the bracket), or else
/// one `step` from the evaluation nearest zero, towards the root (up where
/// f > 0). `None` without evaluations.
///
/// ```
/// use mbs::calibrate::optimise::next_root_guess;
///
/// // f(x) = 1 − 2x: bracketed by 0 and 1, the line's root is exact.
/// assert_eq!(next_root_guess(&[(0.0, 1.0), (1.0, -1.0)], 0.4), Some(0.5));
/// // Not bracketed yet: one step up from the point nearest zero.
/// assert_eq!(next_root_guess(&[(0.0, 1.0), (0.2, 0.6)], 0.4), Some(0.6000000000000001));
/// // A noisy pair that would extrapolate far is never followed outside.
/// let x = next_root_guess(&[(0.0, 0.10), (0.1, 0.097), (0.5, -0.3)], 0.4).unwrap();
/// assert!(x > 0.1 && x < 0.5);
/// ```
pub fn next_root_guess(points: &[(f64, f64)], step: f64) -> Option<f64> {
    let mut bracket: Option<((f64, f64), (f64, f64))> = None;
    for &p in points.iter().filter(|p| p.1 > 0.0) {
        for &n in points.iter().filter(|n| n.1 < 0.0) {
            if bracket.is_none_or(|(a, b)| (p.0 - n.0).abs() < (a.0 - b.0).abs()) {
                bracket = Some((p, n));
            }
        }
    }
    if let Some((p, n)) = bracket {
        return Some(p.0 + (n.0 - p.0) * p.1 / (p.1 - n.1));
    }
    let nearest = points
        .iter()
        .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
    Some(nearest.0 + step * nearest.1.signum())
}
