//! Slab averages of the grains (docs/model.md (C2)): each grain is shared
//! among the slabs it cuts in proportion to its exact slice volumes
//! (docs/model.md (C1)).

use super::grid::Grid;
use super::slice::slice_volume;
use crate::error::{finite, non_negative, positive, Capacity, Error};
use crate::real::Real;

/// Per-slab sums over the grains, filled by [`Slabs::add_grain`] and read by
/// [`super::Column::advance`]. The all-zero value ([`Slabs::new`]) has no
/// cells; [`Slabs::clear`] sets the grid and empties the sums.
///
/// ```
/// use mbs_kernel::fluid::{Column, FluidConfig, Slabs};
///
/// let d = 0.5e-3;
/// let mut column = Column::<f64, 8>::new();
/// column.reset(&FluidConfig::new(8, 0.0, 8.0 * d, 4.0 * d * d))?;
/// let mut slabs = Slabs::<f64, 8>::new();
/// slabs.clear(column.grid())?;
/// // Two grains at rest centred in slab 1, each Ξ = 1e-4 kg/s.
/// slabs.add_grain(1.5 * d, 0.5 * d, 0.0, 1e-4)?;
/// slabs.add_grain(1.5 * d, 0.5 * d, 0.0, 1e-4)?;
/// // Two spheres in a slab of 4 d × d × d: φ = 2 (π/6) / 4.
/// let expect = core::f64::consts::PI / 12.0;
/// assert!((slabs.solid_fraction(1) - expect).abs() < 1e-12);
/// assert_eq!(slabs.solid_fraction(3), 0.0);
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slabs<R: Real, const C: usize> {
    /// The cells the sums belong to.
    pub(crate) grid: Grid<R>,
    /// Σ_i V_ij: the grains' volume in slab j (m³).
    pub(crate) solid: [R; C],
    /// Σ_i V_ij u_p,i (m⁴/s), for the mean grain velocity.
    pub(crate) momentum: [R; C],
    /// Σ_i w_ij Ξ_i (kg/s), w_ij = V_ij / V_i the grain's share of the slab.
    pub(crate) drag: [R; C],
    /// Σ_i w_ij Ξ_i u_p,i (N) of [`Slabs::add_grain`], plus the sources of
    /// [`Slabs::add_source`].
    pub(crate) drag_velocity: [R; C],
}

impl<R: Real, const C: usize> Default for Slabs<R, C> {
    fn default() -> Self {
        Self::new()
    }
}

impl<R: Real, const C: usize> Slabs<R, C> {
    /// No cells, all sums zero.
    pub const fn new() -> Self {
        Slabs {
            grid: Grid::EMPTY,
            solid: [R::ZERO; C],
            momentum: [R::ZERO; C],
            drag: [R::ZERO; C],
            drag_velocity: [R::ZERO; C],
        }
    }

    /// Empties the sums for the cells of `grid` ([`super::Column::grid`]);
    /// an error if it has more cells than the capacity `C`.
    pub fn clear(&mut self, grid: Grid<R>) -> Result<(), Error> {
        if grid.cells > C {
            return Err(Error::CapacityExceeded {
                what: Capacity::FluidCells,
                capacity: C,
            });
        }
        self.grid = grid;
        self.solid.fill(R::ZERO);
        self.momentum.fill(R::ZERO);
        self.drag.fill(R::ZERO);
        self.drag_velocity.fill(R::ZERO);
        Ok(())
    }

    /// Adds a sphere of radius `r` centred at height `y`, moving downstream
    /// at `u_p`, with drag factor `xi` (kg/s: its drag is Ξ (u_f − u_p)),
    /// to the slabs it cuts, docs/model.md (C1)–(C2). The parts outside the
    /// column are left out. Fixed grains are added with u_p = 0.
    pub fn add_grain(&mut self, y: R, r: R, u_p: R, xi: R) -> Result<(), Error> {
        self.add(y, r, u_p, xi, true)
    }

    /// Adds a sphere of radius `r` centred at height `y`, moving downstream
    /// at `u_p`, with drag factor `xi` (kg/s): its volume and velocity as
    /// [`Slabs::add_grain`] and Ξ to k_j, but nothing to m_j: the caller
    /// sets the explicit part of the sink with [`Slabs::add_source`] (the
    /// coupled `Sim`'s stabiliser, docs/model.md §13).
    pub fn add_exchange(&mut self, y: R, r: R, u_p: R, xi: R) -> Result<(), Error> {
        self.add(y, r, u_p, xi, false)
    }

    /// [`Slabs::add_grain`] (`explicit`: with its part of m_j) or
    /// [`Slabs::add_exchange`] (without).
    fn add(&mut self, y: R, r: R, u_p: R, xi: R, explicit: bool) -> Result<(), Error> {
        finite("fluid.grain_height", y.to_f64())?;
        positive("fluid.grain_radius", r.to_f64())?;
        finite("fluid.grain_velocity", u_p.to_f64())?;
        non_negative("fluid.grain_drag", xi.to_f64())?;
        let Some((first, last)) = self.grid.span(y - r, y + r) else {
            return Ok(());
        };
        let inv_volume = R::ONE / slice_volume(r, -r, r);
        for j in first..=last {
            let part = slice_volume(r, self.grid.face(j) - y, self.grid.face(j + 1) - y);
            let share = part * inv_volume * xi;
            self.solid[j] += part;
            self.momentum[j] += part * u_p;
            self.drag[j] += share;
            if explicit {
                self.drag_velocity[j] += share * u_p;
            }
        }
        Ok(())
    }

    /// Σ_i w_ij Ξ_i of slab `j` (kg/s): k_j times the slab's volume; 0
    /// outside the column.
    pub fn drag_factor(&self, j: usize) -> R {
        match self.drag.get(j) {
            Some(&k) if j < self.grid.cells => k,
            _ => R::ZERO,
        }
    }

    /// Adds `force` (N) to slab `j`'s explicit source m_j V_slab (nothing
    /// outside the column).
    pub fn add_source(&mut self, j: usize, force: R) {
        if let (true, Some(m)) = (j < self.grid.cells, self.drag_velocity.get_mut(j)) {
            *m += force;
        }
    }

    /// Solid fraction φ_j of slab `j` (docs/model.md (C2)); 0 outside the column.
    pub fn solid_fraction(&self, j: usize) -> R {
        self.per_volume(&self.solid, j)
    }

    /// Volume-weighted mean grain velocity of slab `j` (m/s, docs/model.md (C2)); 0 where
    /// there is no grain.
    pub fn grain_velocity(&self, j: usize) -> R {
        match (self.solid.get(j), self.momentum.get(j)) {
            (Some(&v), Some(&m)) if j < self.grid.cells && v > R::ZERO => m / v,
            _ => R::ZERO,
        }
    }

    /// The grains' volume in slab `j` (m³).
    pub fn solid_volume(&self, j: usize) -> R {
        if j < self.grid.cells {
            self.solid.get(j).copied().unwrap_or(R::ZERO)
        } else {
            R::ZERO
        }
    }

    /// Σ w Ξ / V_slab of slab `j` (kg/(m³ s)), the coefficient k_j of the
    /// drag sink k_j u_f − m_j (docs/model.md (C2)), and m_j (N/m³).
    pub fn drag_coefficients(&self, j: usize) -> (R, R) {
        (
            self.per_volume(&self.drag, j),
            self.per_volume(&self.drag_velocity, j),
        )
    }

    /// `sums[j]` over the slab volume, 0 outside the column.
    fn per_volume(&self, sums: &[R; C], j: usize) -> R {
        match sums.get(j) {
            Some(&s) if j < self.grid.cells => s / self.grid.slab_volume,
            _ => R::ZERO,
        }
    }
}
