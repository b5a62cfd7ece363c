//! The coupled flow's state inside a [`crate::Sim`] (docs/model.md §13): the
//! column, the slabs it is fed from, and what the grains read between two
//! updates.

use super::column::Column;
use super::config::FluidConfig;
use super::slabs::Slabs;
use crate::real::Real;

/// The column of a coupled `Sim`, its scratch slabs and the hindrance
/// factor of each cell. All-zero bits are the value [`Coupling::new`]
/// (off), so it can live in a zeroed `Sim`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Coupling<R: Real, const C: usize> {
    /// The coupled flow is on.
    pub(crate) on: bool,
    /// The fluid: u_f and φ of each cell (state).
    pub(crate) column: Column<R, C>,
    /// Scratch of an update: the grains' slab sums.
    pub(crate) slabs: Slabs<R, C>,
    /// (1 − φ_j)^(−n) of each cell at the last update, docs/model.md (C7); 1
    /// without hindrance. Derived from the state.
    pub(crate) hindrance: [R; C],
    /// The stabiliser's force of each cell at the last update (N),
    /// returned to the fluid at the next (docs/model.md §13): state.
    pub(crate) carried: [R; C],
    /// The streamwise drag the grains received since the last update,
    /// summed per cell with the weights of the interpolation of u_f
    /// ([`Coupling::deposit`]), N: state.
    pub(crate) drag_sum: [R; C],
    /// Scratch of an update: the mobile grains' Σ w Ξ of each cell (kg/s).
    pub(crate) stabiliser: [R; C],
    /// Scratch of an update: u_f of each cell before it.
    pub(crate) previous: [R; C],
    /// The column's time step M step_dt (s).
    pub(crate) exchange_dt: R,
    /// 1/M, the average of the drag summed over M grain steps.
    pub(crate) inv_steps: R,
}

impl<R: Real, const C: usize> Coupling<R, C> {
    /// Off, no cells.
    pub(crate) const fn new() -> Self {
        Coupling {
            on: false,
            column: Column::new(),
            slabs: Slabs::new(),
            hindrance: [R::ZERO; C],
            carried: [R::ZERO; C],
            drag_sum: [R::ZERO; C],
            stabiliser: [R::ZERO; C],
            previous: [R::ZERO; C],
            exchange_dt: R::ZERO,
            inv_steps: R::ZERO,
        }
    }

    /// The stabiliser's momentum in transit (N s): taken from the fluid at
    /// the last update, returned at the next.
    pub(crate) fn in_transit(&self) -> R {
        let mut sum = R::ZERO;
        for &f in &self.carried[..self.column.grid().cells().min(C)] {
            sum += f;
        }
        sum * self.exchange_dt
    }

    /// Adds the streamwise drag `force` (N) a grain at height `y` received
    /// to the cells' sums with the weights by which its u_f was
    /// interpolated ([`Column::velocity_at`]): the two centres around y by
    /// their distances, all of it to the bottom cell below its centre and
    /// to the top cell above its centre (the wall takes nothing), so the
    /// sums take the whole force, to round-off.
    #[inline]
    pub(crate) fn deposit(&mut self, y: R, force: R) {
        let grid = self.column.grid();
        let n = grid.cells().min(C);
        if n == 0 {
            return;
        }
        let s = (y - grid.bottom) * grid.inv_dy - R::HALF;
        // `as usize` saturates; a NaN gives 0.
        let i = if s > R::ZERO { s.to_f64() as usize } else { 0 };
        if s > R::ZERO && i + 1 < n {
            let upper = force * (s - R::from_f64(i as f64));
            self.drag_sum[i] += force - upper;
            self.drag_sum[i + 1] += upper;
        } else {
            let j = if s > R::ZERO { n - 1 } else { 0 };
            self.drag_sum[j] += force;
        }
    }

    /// The hindrance (1 − φ)^(−n) at height `y`: the factor of the cell
    /// that holds it (the nearest cell outside the column).
    #[inline]
    pub(crate) fn hindrance_at(&self, y: R) -> R {
        match self.column.grid().cell(y) {
            Some(j) => self.hindrance.get(j).copied().unwrap_or(R::ONE),
            None => R::ONE,
        }
    }

    /// Recomputes the hindrance of each cell from the column's φ with
    /// exponent `config.hindrance` (f64 `libm::pow`, once per cell and update).
    pub(crate) fn refresh_hindrance(&mut self, config: &FluidConfig) {
        let n = config.hindrance;
        for (h, &phi) in self.hindrance.iter_mut().zip(self.column.solid_fractions()) {
            *h = if n == 0.0 {
                R::ONE
            } else {
                R::from_f64(libm::pow(1.0 - phi.to_f64(), -n))
            };
        }
    }
}
