//! A tridiagonal linear system and its solution by the Thomas algorithm
//! (docs/model.md (C6)), in fixed-size arrays.

use crate::error::{check, Capacity, Error};
use crate::real::Real;

/// The system lower_i x_{i−1} + diag_i x_i + upper_i x_{i+1} = rhs_i of `n`
/// unknowns (`lower[0]` and `upper[n − 1]` are not read), stored in arrays
/// of the capacity `C`. [`Tridiagonal::solve`] overwrites `upper` and `rhs`.
///
/// ```
/// use mbs_kernel::fluid::Tridiagonal;
///
/// // 2x + y = 3, x + 2y = 3: x = y = 1.
/// let mut t = Tridiagonal::<f64, 4>::new();
/// t.diag[..2].copy_from_slice(&[2.0, 2.0]);
/// t.lower[1] = 1.0;
/// t.upper[0] = 1.0;
/// t.rhs[..2].copy_from_slice(&[3.0, 3.0]);
/// assert_eq!(t.solve(2)?, &[1.0, 1.0]);
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tridiagonal<R: Real, const C: usize> {
    /// Coefficients of x_{i−1}.
    pub lower: [R; C],
    /// Coefficients of x_i.
    pub diag: [R; C],
    /// Coefficients of x_{i+1}.
    pub upper: [R; C],
    /// Right-hand sides; the solution after [`Tridiagonal::solve`].
    pub rhs: [R; C],
}

impl<R: Real, const C: usize> Default for Tridiagonal<R, C> {
    fn default() -> Self {
        Self::new()
    }
}

impl<R: Real, const C: usize> Tridiagonal<R, C> {
    /// All zero.
    pub const fn new() -> Self {
        Tridiagonal {
            lower: [R::ZERO; C],
            diag: [R::ZERO; C],
            upper: [R::ZERO; C],
            rhs: [R::ZERO; C],
        }
    }

    /// Solves the first `n` equations in place (forward elimination, then
    /// back substitution, in index order) and returns x. An error if `n`
    /// exceeds `C` or a pivot is zero or not finite.
    pub fn solve(&mut self, n: usize) -> Result<&[R], Error> {
        if n > C {
            return Err(Error::CapacityExceeded {
                what: Capacity::FluidCells,
                capacity: C,
            });
        }
        let mut prev_upper = R::ZERO;
        let mut prev_rhs = R::ZERO;
        for i in 0..n {
            let lower = if i > 0 { self.lower[i] } else { R::ZERO };
            let upper = if i + 1 < n { self.upper[i] } else { R::ZERO };
            let pivot = self.diag[i] - lower * prev_upper;
            check(
                R::is_finite(pivot) && pivot != R::ZERO,
                "fluid.pivot",
                pivot.to_f64(),
                "finite and non-zero (the system is singular)",
            )?;
            self.upper[i] = upper / pivot;
            self.rhs[i] = (self.rhs[i] - lower * prev_rhs) / pivot;
            prev_upper = self.upper[i];
            prev_rhs = self.rhs[i];
        }
        for i in (0..n.saturating_sub(1)).rev() {
            let next = self.rhs[i + 1];
            self.rhs[i] -= self.upper[i] * next;
        }
        Ok(&self.rhs[..n])
    }
}
