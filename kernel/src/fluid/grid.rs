//! The column's cells: `cells` slabs of equal height Δy from the bottom of the
//! fixed layer to the free surface (docs/model.md §13). Cell j spans the
//! faces j and j + 1; its velocity lives at its centre.

use crate::real::Real;

/// The geometry of the column in the working precision. The all-zero value
/// is the grid of no cells.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Grid<R: Real> {
    /// Height of face 0, the bottom (m).
    pub(crate) bottom: R,
    /// Height of a cell Δy (m).
    pub(crate) dy: R,
    /// 1/Δy.
    pub(crate) inv_dy: R,
    /// Volume of a slab, cross-section × Δy (m³).
    pub(crate) slab_volume: R,
    /// Number of cells.
    pub(crate) cells: usize,
}

impl<R: Real> Grid<R> {
    /// The grid of no cells.
    pub(crate) const EMPTY: Self = Grid {
        bottom: R::ZERO,
        dy: R::ZERO,
        inv_dy: R::ZERO,
        slab_volume: R::ZERO,
        cells: 0,
    };

    /// `cells` cells from `bottom` to `surface` with slabs of `cross_section`
    /// (validated by [`super::FluidConfig::validate`]).
    pub(crate) fn new(cells: usize, bottom: f64, surface: f64, cross_section: f64) -> Self {
        let dy = (surface - bottom) / cells as f64;
        Grid {
            bottom: R::from_f64(bottom),
            dy: R::from_f64(dy),
            inv_dy: R::from_f64(1.0 / dy),
            slab_volume: R::from_f64(cross_section * dy),
            cells,
        }
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.cells
    }

    /// Height of a cell Δy (m).
    pub fn dy(&self) -> R {
        self.dy
    }

    /// Volume of a slab (m³).
    pub fn slab_volume(&self) -> R {
        self.slab_volume
    }

    /// Height of face `j` (m): the bottom of cell `j`; face `cells` is the
    /// free surface. Every use of a face's height goes through here, so the
    /// two cells of a face see the same bits.
    pub fn face(&self, j: usize) -> R {
        self.bottom + R::from_f64(j as f64) * self.dy
    }

    /// Height of the centre of cell `j` (m).
    pub fn centre(&self, j: usize) -> R {
        self.bottom + (R::from_f64(j as f64) + R::HALF) * self.dy
    }

    /// The cell that holds height `y`, the nearest cell for heights
    /// outside the column; `None` without cells or for a NaN.
    pub fn cell(&self, y: R) -> Option<usize> {
        let s = (y - self.bottom) * self.inv_dy;
        if self.cells == 0 || s.to_f64().is_nan() {
            return None;
        }
        // `as usize` saturates: a negative offset gives cell 0.
        Some((s.to_f64() as usize).min(self.cells - 1))
    }

    /// The cells that the heights [lo, hi] touch, first and last, or `None`
    /// if they are all outside the column (or not numbers).
    pub(crate) fn span(&self, lo: R, hi: R) -> Option<(usize, usize)> {
        let top = self.face(self.cells);
        if !(hi > self.bottom && lo < top) || self.cells == 0 {
            return None;
        }
        // `as usize` saturates: a negative offset gives cell 0.
        let first = ((lo - self.bottom) * self.inv_dy).to_f64() as usize;
        let last = ((hi - self.bottom) * self.inv_dy).to_f64() as usize;
        Some((first.min(self.cells - 1), last.min(self.cells - 1)))
    }
}
