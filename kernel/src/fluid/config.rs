//! The coupled flow's parameters (docs/model.md §13), in SI units and `f64`,
//! checked once by [`FluidConfig::validate`].

use super::grid::Grid;
use crate::error::{check, finite, non_negative, positive, Capacity, Error};
use crate::real::Real;

/// Parameters of a [`super::Column`].
///
/// ```
/// use mbs_kernel::fluid::FluidConfig;
///
/// // 0.5 mm grains, 0.2 m of water over the bed, u* = 3 cm/s.
/// let d = 0.5e-3;
/// let mut config = FluidConfig::new(400, 0.0, 0.2 + d, 20.0 * d * d);
/// config.driving = FluidConfig::driving_for(0.03, 0.2);
/// config.validate(400)?;
/// assert!(config.validate(200).is_err()); // 400 cells do not fit in 200
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FluidConfig {
    /// Number of cells (slabs) of the column, at most the capacity `C`.
    pub cells: usize,
    /// Height of the column's bottom, the bottom of the fixed layer (m).
    pub bottom: f64,
    /// Height of the free surface (m).
    pub surface: f64,
    /// Horizontal area of a slab (m²): the periodic width times the
    /// thickness of the slice (docs/model.md §13: one largest diameter).
    pub cross_section: f64,
    /// Density of the fluid ρ (kg/m³).
    pub density: f64,
    /// Kinematic viscosity of the fluid ν (m²/s).
    pub viscosity: f64,
    /// Kármán constant κ of the mixing length, docs/model.md (C3).
    pub kappa: f64,
    /// Solid fraction of the packed bed φ_max, where the mixing length stops
    /// growing, docs/model.md (C3).
    pub phi_max: f64,
    /// The driving acceleration g S (m/s²), gravity along the slope S: the
    /// driving stress over a depth h is ρ g S h = ρ u*² ([`Self::driving_for`]).
    pub driving: f64,
    /// Grain steps M between two updates of the column in a coupled
    /// [`crate::Sim`] (docs/model.md §13): the column advances by M step_dt
    /// with the grains' drag averaged over those steps. \[choice\] 100, the
    /// paper's hold period of the fluctuations: the column's step is then
    /// ~1e-4 s, far below its drag relaxation time (~0.03 s in a bed) and
    /// the update costs well under 1 % of the grain steps.
    pub update_steps: u32,
    /// Exponent n of the hindrance (1 − φ)^(−n) of the grains' drag,
    /// docs/model.md (C7); 0 (the default) turns it off, Richardson–Zaki
    /// give about 3.1.
    pub hindrance: f64,
}

impl FluidConfig {
    /// `cells` cells from `bottom` to `surface`, slabs of `cross_section`,
    /// water (1000 kg/m³, ν = 1.0e-6 m²/s), κ = 0.4, φ_max = π/4
    /// (docs/model.md §13: the largest solid fraction of a slab of spheres
    /// in a slice one diameter thick), no driving, updates every 100 grain
    /// steps, no hindrance.
    pub const fn new(cells: usize, bottom: f64, surface: f64, cross_section: f64) -> Self {
        FluidConfig {
            cells,
            bottom,
            surface,
            cross_section,
            density: 1000.0,
            viscosity: 1.0e-6,
            kappa: 0.4,
            phi_max: core::f64::consts::FRAC_PI_4,
            driving: 0.0,
            update_steps: 100,
            hindrance: 0.0,
        }
    }

    /// g S = u*²/h: the driving acceleration whose stress over the depth `h`
    /// is ρ u*² (docs/model.md (C5)).
    pub fn driving_for(u_star: f64, depth: f64) -> f64 {
        u_star * u_star / depth
    }

    /// The column's cells in precision `R` (meaningful once
    /// [`Self::validate`] accepts the configuration), e.g. for
    /// [`super::Slabs::clear`] outside a column.
    pub fn grid<R: Real>(&self) -> Grid<R> {
        Grid::new(self.cells, self.bottom, self.surface, self.cross_section)
    }

    /// Checks every field against the capacity `capacity` (the `C` of the
    /// column); the error names the first bad one.
    pub fn validate(&self, capacity: usize) -> Result<(), Error> {
        check(self.cells >= 2, "fluid.cells", self.cells as f64, ">= 2")?;
        if self.cells > capacity {
            return Err(Error::CapacityExceeded {
                what: Capacity::FluidCells,
                capacity,
            });
        }
        finite("fluid.bottom", self.bottom)?;
        finite("fluid.surface", self.surface)?;
        check(
            self.surface > self.bottom,
            "fluid.surface",
            self.surface,
            "above fluid.bottom",
        )?;
        positive("fluid.cross_section", self.cross_section)?;
        positive("fluid.density", self.density)?;
        positive("fluid.viscosity", self.viscosity)?;
        positive("fluid.kappa", self.kappa)?;
        check(
            self.phi_max > 0.0 && self.phi_max < 1.0,
            "fluid.phi_max",
            self.phi_max,
            "in (0, 1)",
        )?;
        non_negative("fluid.driving", self.driving)?;
        check(
            self.update_steps >= 1,
            "fluid.update_steps",
            f64::from(self.update_steps),
            ">= 1",
        )?;
        check(
            self.hindrance.is_finite() && (0.0..=10.0).contains(&self.hindrance),
            "fluid.hindrance",
            self.hindrance,
            "in [0, 10]",
        )
    }
}
