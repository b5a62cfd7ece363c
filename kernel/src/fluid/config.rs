//! The coupled flow's parameters (docs/model.md §13), in SI units and `f64`,
//! checked once by [`FluidConfig::validate`].
//!
//! One definition per quantity: [`FluidSpec`] is what a user chooses for
//! the coupled flow whatever the bed (ν, φ_max, the update interval M, the
//! hindrance n), and a [`FluidConfig`] holds a `FluidSpec` plus what the
//! bed, the material and the flow give it (its cells, bottom, surface and
//! cross-section, the density ρ, the flow's κ, the driving g S), as
//! [`crate::Scenario::column`] and [`crate::Scenario::flow`] derive them.
//! The largest cell height a user chooses is no field of either: with the
//! bed it makes the column's `cells` ([`crate::Scenario::fluid_cell_height`]),
//! and a `FluidConfig` holds only the cells it made, the grid a column and
//! a checkpoint know, so that a configuration restored from a checkpoint
//! equals the one written. κ and ρ are fields of their own, not read
//! through the flow or the material, because a [`super::Column`] stands
//! alone (it knows no flow) and a checkpoint carries them apart.

use super::grid::Grid;
use crate::error::{check, finite, non_negative, positive, Capacity, Error};
use crate::real::Real;
use crate::steps::IntegrationSteps;

/// The drag law of the coupled flow's grains (docs/model.md (C8)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum DragLaw {
    /// The paper's (4)–(5): a constant drag coefficient C_D (the default).
    #[default]
    Paper = 0,
    /// Dallavalle's, as HydroForceEngine codes it: C_D = 0.44 + 24.4/Re_p,
    /// Re_p = |u_r| d/ν, i.e. Ξ = ½ρ A2 d² (0.44 |u_r| + 24.4 ν/d).
    Dallavalle = 1,
}

/// The turbulent fluctuations of the coupled flow (docs/model.md (C9)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Fluctuations {
    /// The paper's (15) with the local shear velocity u*_loc: independent
    /// u and v of rms (2.30, 1.27) u*_loc exp(−y/h), held
    /// [`crate::FlowSpec::hold_steps`] (the default).
    #[default]
    Paper = 0,
    /// HydroForceEngine's discrete random walk: v' = r₁ u*_loc,
    /// u' = (r₂ − r₁) u*_loc (rms √2 u*_loc, ⟨u'v'⟩ = −u*_loc²), none below
    /// the mean bed level, all redrawn at once every eddy turnover
    /// (h − y_bed)/⟨u_f⟩ of the water above the bed.
    Hfe = 1,
}

impl DragLaw {
    /// The law of a checkpoint byte.
    pub(crate) fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(DragLaw::Paper),
            1 => Some(DragLaw::Dallavalle),
            _ => None,
        }
    }
}

impl Fluctuations {
    /// The model of a checkpoint byte.
    pub(crate) fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Fluctuations::Paper),
            1 => Some(Fluctuations::Hfe),
            _ => None,
        }
    }
}

/// The coupled flow's parameters a user chooses (docs/model.md §13): the
/// same whatever the bed; the rest of a [`FluidConfig`] follows from the
/// bed, the material and the flow ([`crate::Scenario::flow`]).
///
/// ```
/// use mbs_kernel::{fluid::FluidSpec, IntegrationSteps};
///
/// let spec = FluidSpec::new();
/// assert_eq!((spec.viscosity, spec.hindrance), (1.0e-6, 0.0));
/// assert_eq!(spec.update_steps, IntegrationSteps(100));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FluidSpec {
    /// Kinematic viscosity of the fluid ν (m²/s).
    pub viscosity: f64,
    /// Solid fraction of the packed bed φ_max, where the mixing length stops
    /// growing, docs/model.md (C3).
    pub phi_max: f64,
    /// Integration steps M between two updates of the column in a coupled
    /// [`crate::Sim`] (docs/model.md §13): the column advances by M step_dt
    /// with the grains' drag averaged over those steps. \[choice\] 100, the
    /// paper's hold period of the fluctuations: the column's step is then
    /// ~1e-4 s, far below its drag relaxation time (~0.03 s in a bed) and
    /// the update costs well under 1 % of the grain steps.
    pub update_steps: IntegrationSteps,
    /// Exponent n of the hindrance (1 − φ)^(−n) of the grains' drag,
    /// docs/model.md (C7); 0 (the default) turns it off, Richardson–Zaki
    /// give about 3.1.
    pub hindrance: f64,
    /// Width W of a channel whose two side walls hold the water back
    /// (m), docs/model.md (C10); 0 (the default): no walls, an unbounded
    /// slice.
    pub channel_width: f64,
    /// A factor on the side walls' friction factor f (C10),
    /// HydroForceEngine's `fluidFrictionCoef`: 1 (the default) is
    /// Blasius's smooth wall.
    pub wall_friction: f64,
    /// The grains' friction coefficient on the side walls μ_w (C11), 0 (the
    /// default): none. A grain is pressed on a wall by the drag of the
    /// spanwise fluctuation, as in Maurin et al.'s (2015) YADE runs.
    pub grain_wall_friction: f64,
    /// Janssen's ratio K of the lateral to the vertical granular stress
    /// (C12): a grain is also pressed on a wall by K times the weight of
    /// the grains above it, besides the spanwise fluctuation's drag (C11);
    /// 0 (the default): not.
    pub lateral_ratio: f64,
    /// The grains' drag law (docs/model.md (C8)).
    pub drag: DragLaw,
    /// The turbulent fluctuations (docs/model.md (C9)).
    pub fluctuations: Fluctuations,
}

impl FluidSpec {
    /// Water (ν = 1.0e-6 m²/s), φ_max = π/4 (docs/model.md §13: the largest
    /// solid fraction of a slab of spheres in a slice one diameter thick),
    /// updates every 100 integration steps, no hindrance (C7), no side walls
    /// (C10), the paper's drag and fluctuations.
    pub const fn new() -> Self {
        FluidSpec {
            viscosity: 1.0e-6,
            phi_max: core::f64::consts::FRAC_PI_4,
            update_steps: IntegrationSteps(100),
            hindrance: 0.0,
            channel_width: 0.0,
            wall_friction: 1.0,
            grain_wall_friction: 0.0,
            lateral_ratio: 0.0,
            drag: DragLaw::Paper,
            fluctuations: Fluctuations::Paper,
        }
    }
}

impl Default for FluidSpec {
    fn default() -> Self {
        FluidSpec::new()
    }
}

/// Parameters of a [`super::Column`]: a [`FluidSpec`] and what the bed,
/// the material and the flow give it (see the module's documentation).
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
    /// What a user chooses: ν, φ_max, the update interval M, the hindrance n.
    pub spec: FluidSpec,
    /// Number of cells (slabs) of the column, at most the capacity `C`.
    pub cells: usize,
    /// Height of the column's bottom, the bottom of the fixed layer (m).
    pub bottom: f64,
    /// Height of the free surface (m).
    pub surface: f64,
    /// Horizontal area of a slab (m²): the periodic width times the
    /// thickness of the slice (docs/model.md §13: one largest diameter).
    pub cross_section: f64,
    /// Density of the fluid ρ (kg/m³), the material's.
    pub density: f64,
    /// Kármán constant κ of the mixing length, docs/model.md (C3): the
    /// flow's ([`crate::FlowSpec::kappa`]).
    pub kappa: f64,
    /// The driving acceleration g S (m/s²), gravity along the energy slope
    /// S: the driving stress over a depth h is ρ g S h = ρ u*²
    /// ([`Self::driving_for`]).
    pub driving: f64,
}

impl FluidConfig {
    /// `cells` cells from `bottom` to `surface`, slabs of `cross_section`,
    /// the [`FluidSpec::new`] defaults, water (1000 kg/m³), κ = 0.4, no
    /// driving.
    pub const fn new(cells: usize, bottom: f64, surface: f64, cross_section: f64) -> Self {
        FluidConfig {
            spec: FluidSpec::new(),
            cells,
            bottom,
            surface,
            cross_section,
            density: 1000.0,
            kappa: 0.4,
            driving: 0.0,
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
        let spec = &self.spec;
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
        positive("fluid.viscosity", spec.viscosity)?;
        positive("fluid.kappa", self.kappa)?;
        check(
            spec.phi_max > 0.0 && spec.phi_max < 1.0,
            "fluid.phi_max",
            spec.phi_max,
            "in (0, 1)",
        )?;
        non_negative("fluid.driving", self.driving)?;
        check(
            spec.update_steps.0 >= 1,
            "fluid.update_steps",
            f64::from(spec.update_steps.0),
            ">= 1 integration step",
        )?;
        check(
            spec.hindrance.is_finite() && (0.0..=10.0).contains(&spec.hindrance),
            "fluid.hindrance",
            spec.hindrance,
            "in [0, 10]",
        )?;
        check(
            spec.channel_width == 0.0
                || (spec.channel_width.is_finite() && spec.channel_width > 0.0),
            "channel.width",
            spec.channel_width,
            "> 0 m (0: no side walls)",
        )?;
        check(
            spec.wall_friction.is_finite() && (0.0..=10.0).contains(&spec.wall_friction),
            "channel.wall_friction",
            spec.wall_friction,
            "in [0, 10] (1: Blasius's smooth wall)",
        )?;
        check(
            spec.grain_wall_friction.is_finite()
                && (0.0..=10.0).contains(&spec.grain_wall_friction),
            "channel.grain_friction",
            spec.grain_wall_friction,
            "in [0, 10] (glass on glass: 0.4)",
        )?;
        check(
            spec.lateral_ratio.is_finite() && (0.0..=10.0).contains(&spec.lateral_ratio),
            "channel.lateral_ratio",
            spec.lateral_ratio,
            "in [0, 10] (0: no overburden on the walls)",
        )
    }
}
