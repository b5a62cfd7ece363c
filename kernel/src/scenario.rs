//! A complete, named run set-up: the paper's case by default. The host's
//! configuration, the golden-digest tests and the firmware all build their
//! simulations through this one type, so they compute the same thing.

use crate::bed::{BedInfo, BedSpec};
use crate::constants::{contact_constants, ContactConstants, Material, TimeStepRule};
use crate::contact::Tension;
use crate::error::Error;
use crate::flow::{shear_velocity, FlowConfig, FlowModel, FlowSpec};
use crate::fluid::{FluidConfig, FluidSpec};
use crate::real::Real;
use crate::sim::{Sim, SimConfig};
use crate::steps::IntegrationSteps;

/// Standard gravity (m/s²).
pub const G: f64 = 9.81;

/// Everything needed to build, settle and drive a bed.
///
/// ```
/// use mbs_kernel::{Scenario, Sim};
///
/// let scenario = Scenario::paper();
/// assert_eq!(scenario.step_dt(), 2.0e-5 / 8.0);
/// // The golden-digest run in miniature (100 steps settling, 100 under
/// // the flow at the paper's τ*): two runs, the same bits.
/// let tau_star = Scenario::PAPER_TAU_STAR;
/// let (mut a, mut b) = (Sim::<f32, 64, 8>::new(), Sim::<f32, 64, 8>::new());
/// assert_eq!(
///     scenario.digests(&mut a, tau_star, 100, 100)?,
///     scenario.digests(&mut b, tau_star, 100, 100)?
/// );
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Fluid and grain material.
    pub material: Material,
    /// α_m, α_cn, β and the Δt the contact constants derive from (docs/model.md §5).
    pub rule: TimeStepRule,
    /// Contact constants given explicitly instead of derived from `rule`.
    pub explicit_contact: Option<ContactConstants>,
    /// What part of the normal force may pull (docs/model.md (8), (8')).
    pub tension: Tension,
    /// Integration steps per constants' time step: the kernel integrates
    /// with step_dt = constants_dt/substeps and keeps every constant derived
    /// from constants_dt.
    pub substeps: u32,
    /// The initial bed (docs/model.md §7).
    pub bed: BedSpec,
    /// The flow without its strength ([`Scenario::flow`] adds the u* of a
    /// τ*); its `depth` is also the top of the domain.
    pub flow: FlowSpec,
    /// The coupled flow's parameters a user chooses (docs/model.md §13);
    /// [`Scenario::column`] adds what the bed gives. Read only with
    /// [`FlowModel::Coupled`].
    pub fluid: FluidSpec,
    /// Largest height of a fluid cell of the coupled flow's column Δy (m): the
    /// column has the fewest equal fluid cells no higher than this
    /// ([`Scenario::column`]). Read only with [`FlowModel::Coupled`].
    pub fluid_cell_height: f64,
    /// Bed slope angle θ (rad), [`SimConfig::slope_angle`]: x runs down the
    /// slope.
    pub slope_angle: f64,
    /// Largest neighbour skin in units of the largest diameter.
    pub skin: f64,
    /// Seed of every random draw.
    pub seed: u64,
}

impl Scenario {
    /// The Shields number of the paper's flow phase (and of the golden digests).
    pub const PAPER_TAU_STAR: f64 = 0.2;

    /// The paper's case on a bed of `columns` × `rows` (the kernel's unit
    /// tests).
    #[cfg(test)]
    pub(crate) fn paper_bed(columns: u32, rows: u32) -> Self {
        let paper = Self::paper();
        let bed = BedSpec {
            columns,
            rows,
            ..paper.bed.clone()
        };
        Scenario { bed, ..paper }
    }

    /// The paper's case (docs/model.md §9): d = 0.5 mm, nld = 5, nvd = 10,
    /// spacing 1.05 d, Δt = 2.0e-5 s, α_m = 20, α_cn = 1.3, β = 15.8, the
    /// flow of [`FlowConfig::new`] with fluctuations held and the bed level
    /// recomputed every 100 steps of Δt, integrated with 8 substeps: at Δt
    /// itself the tangential dashpot of rule (17) is beyond the explicit
    /// damping limit ([`crate::explicit_damping_number`] ≈ 2.85) and the bed
    /// never settles; with 4 substeps q* still depends on the step, with 8
    /// and 16 it does not (docs/findings/explicit-damping-limit.md).
    pub fn paper() -> Self {
        const D: f64 = 0.5e-3;
        const SUBSTEPS: u32 = 8;
        Scenario {
            material: Material::default(),
            rule: TimeStepRule {
                alpha_m: 20.0,
                alpha_cn: 1.3,
                beta: 15.8,
                constants_dt: 2.0e-5,
            },
            explicit_contact: None,
            tension: Tension::Dashpot,
            substeps: SUBSTEPS,
            bed: BedSpec::uniform(D, 5, 10),
            flow: FlowSpec {
                hold_steps: IntegrationSteps::from_constants_steps(100, SUBSTEPS),
                bed_level_interval: IntegrationSteps::from_constants_steps(100, SUBSTEPS),
                ..FlowSpec::new(D)
            },
            // \[choice\] fluid cells of d/2; φ_max 0.6 of a packed bed, the
            // largest mean solid fraction of the quasi-2-D beds of Frey
            // (2014) (0.58–0.60), so that the mixing length (C3) starts at
            // the bed's surface; the column updated every 10 Δt, a tenth of
            // the fluctuations' hold (far below its drag relaxation time);
            // Richardson–Zaki's hindrance 3.1, as in Maurin et al. (2015)
            // (C7) (docs/model.md §13).
            fluid: FluidSpec {
                phi_max: 0.6,
                update_steps: IntegrationSteps::from_constants_steps(10, SUBSTEPS),
                hindrance: 3.1,
                ..FluidSpec::new()
            },
            fluid_cell_height: 0.5 * D,
            slope_angle: 0.0,
            skin: 0.1,
            seed: 1,
        }
    }

    /// Cells of [`Scenario::paper_coupled`]'s column: a coupled simulation of
    /// it needs a fluid capacity `C` of at least this many.
    pub const PAPER_COUPLED_CELLS: usize = 100;

    /// The coupled golden scenario: [`Scenario::paper`] under the coupled
    /// flow (docs/model.md §13) in a column of fluid cells of 4 d, 100 fluid cells from
    /// the fixed grains' mean centre to the depth of 0.2 m, small enough
    /// for the boards. The golden test (tests/golden/coupled.txt), the firmware and
    /// `mbs digest --set flow.model=coupled --set fluid.cell_d=4` run it.
    ///
    /// ```
    /// use mbs_kernel::{FlowModel, Scenario, Sim};
    ///
    /// let scenario = Scenario::paper_coupled();
    /// assert_eq!(scenario.flow.model, FlowModel::Coupled);
    /// assert_eq!(scenario.column().cells, Scenario::PAPER_COUPLED_CELLS);
    /// // Only the flow differs from the paper's case.
    /// assert_eq!(scenario.bed, Scenario::paper().bed);
    /// // The coupled golden run in miniature: two runs, the same bits.
    /// const C: usize = Scenario::PAPER_COUPLED_CELLS;
    /// let tau_star = Scenario::PAPER_TAU_STAR;
    /// let mut a = Box::new(Sim::<f32, 64, 8, C>::new());
    /// let mut b = Box::new(Sim::<f32, 64, 8, C>::new());
    /// assert_eq!(
    ///     scenario.digests(&mut *a, tau_star, 100, 100)?,
    ///     scenario.digests(&mut *b, tau_star, 100, 100)?
    /// );
    /// # Ok::<(), mbs_kernel::Error>(())
    /// ```
    pub fn paper_coupled() -> Self {
        let mut scenario = Scenario::paper();
        scenario.flow.model = FlowModel::Coupled;
        scenario.fluid_cell_height = 4.0 * scenario.bed.max_diameter();
        scenario
    }

    /// The contact constants: the explicit ones, else derived from Δt for the
    /// largest grain (docs/model.md §5).
    pub fn contact(&self) -> Result<ContactConstants, Error> {
        match self.explicit_contact {
            Some(c) => c.validate().map(|()| c),
            None => contact_constants(&self.rule, self.bed.max_diameter(), &self.material),
        }
    }

    /// The simulation configuration: [`Scenario::contact`], gravity (0, −g),
    /// the free surface at the flow depth h, the domain from 10 d_max below
    /// the fixed grains' mean centre to as far above the surface (a grain
    /// leaving the water vertically at √(2 g (h + 10 d_max)) would reach
    /// it: more than twice the fastest grain of Frey's (2014) runs at
    /// h = 5.3 cm). Width and y_min are set by [`Sim::build_bed`].
    pub fn sim_config(&self) -> Result<SimConfig, Error> {
        let d = self.bed.max_diameter();
        Ok(SimConfig {
            step_dt: self.step_dt(),
            material: self.material,
            contact: self.contact()?,
            tension: self.tension,
            gravity: [0.0, -G],
            width: self.bed.width(),
            y_min: -10.0 * d,
            y_max: 2.0 * self.flow.depth + 10.0 * d,
            surface: self.flow.depth,
            skin: self.skin * d,
            seed: self.seed,
            slope_angle: self.slope_angle,
        })
    }

    /// The integration time step Δt/substeps (s).
    pub fn step_dt(&self) -> f64 {
        self.rule.constants_dt / f64::from(self.substeps.max(1))
    }

    /// The flow at Shields number `tau_star`: u* from τ* for the largest
    /// grain (docs/model.md §6). The coupled flow (docs/model.md §13) gets
    /// the [`Scenario::column`] driven by g S = u*²/h, of which the bed
    /// slope gives g sin θ (at most: a larger slope is an invalid
    /// `fluid.driving`), so that the total shear stress at y = 0, the fixed
    /// grains' mean centre height, is ρ u*².
    ///
    /// ```
    /// use mbs_kernel::{FlowModel, Scenario};
    ///
    /// let mut sc = Scenario::paper();
    /// sc.flow.model = FlowModel::Coupled;
    /// let flow = sc.flow(0.2);
    /// assert_eq!(flow.spec.model, FlowModel::Coupled);
    /// assert!((flow.fluid.driving * 0.2 - flow.u_star * flow.u_star).abs() < 1e-15);
    /// ```
    pub fn flow(&self, tau_star: f64) -> FlowConfig {
        let d = self.bed.max_diameter();
        let u_star = shear_velocity(tau_star, self.material.s, G, d);
        let mut flow = self.flow.at(u_star);
        if self.flow.model == FlowModel::Coupled {
            let mut fluid = self.column();
            let slope_drive = G * libm::sin(self.slope_angle);
            let drive = FluidConfig::driving_for(u_star, fluid.surface) - slope_drive;
            // A uniform flow, u*² = g h sin θ, to round-off: the slope alone.
            fluid.driving = if drive < 0.0 && drive >= -1e-9 * slope_drive {
                0.0
            } else {
                drive
            };
            flow.fluid = fluid;
        }
        flow
    }

    /// The coupled flow's column without driving (docs/model.md §13): from
    /// the fixed grains' mean centre height y = 0, as HydroForceEngine's
    /// (Maurin et al. 2015: below it the fixed layer holds the water at
    /// rest, and a column reaching below the fixed grains carries a
    /// spurious fast layer under them), to the top of the domain, the
    /// depth h, in equal fluid cells of at most [`Scenario::fluid_cell_height`];
    /// its slabs as wide as the bed and [`Scenario::slice_thickness`]
    /// thick; the
    /// [`Scenario::fluid`], the material's density and the flow's κ.
    ///
    /// ```
    /// use mbs_kernel::Scenario;
    ///
    /// let column = Scenario::paper().column();
    /// assert_eq!((column.bottom, column.cells), (0.0, 800)); // 0.2 m in fluid cells of d/2
    /// assert_eq!(column.surface, 0.2);
    /// ```
    pub fn column(&self) -> FluidConfig {
        let bottom = 0.0;
        let surface = self.flow.depth;
        let fluid_cells = libm::ceil((surface - bottom) / self.fluid_cell_height);
        // A NaN or huge count fails `FluidConfig::validate`.
        let fluid_cells = if fluid_cells.is_finite() && fluid_cells < 1e9 {
            fluid_cells as usize
        } else {
            usize::MAX
        };
        FluidConfig {
            spec: self.fluid,
            density: self.material.rho,
            kappa: self.flow.kappa,
            ..FluidConfig::new(
                fluid_cells,
                bottom,
                surface,
                self.bed.width() * self.slice_thickness(),
            )
        }
    }

    /// The thickness b of the simulated slice (m): the channel's width W
    /// with side walls (the coupled flow's `FluidSpec::channel_width`,
    /// docs/model.md (C10)), else one largest diameter (docs/model.md §13).
    /// The fluid's slabs are L b, and q* is per unit of b (docs/model.md
    /// §8): with walls, φ and q* are the channel's, as Frey (2014) measured
    /// them.
    ///
    /// ```
    /// use mbs_kernel::{FlowModel, Scenario};
    ///
    /// let mut sc = Scenario::paper_coupled();
    /// assert_eq!(sc.slice_thickness(), 0.5e-3);
    /// sc.fluid.channel_width = 0.6e-3;
    /// assert_eq!(sc.slice_thickness(), 0.6e-3);
    /// ```
    pub fn slice_thickness(&self) -> f64 {
        let width = self.fluid.channel_width;
        if self.flow.model == FlowModel::Coupled && width > 0.0 {
            width
        } else {
            self.bed.max_diameter()
        }
    }

    /// Resets `sim` and builds the initial bed.
    pub fn build<R: Real, const N: usize, const K: usize, const C: usize>(
        &self,
        sim: &mut Sim<R, N, K, C>,
    ) -> Result<BedInfo, Error> {
        sim.build_bed(&self.sim_config()?, &self.bed)
    }

    /// The fixed golden-digest run: build the bed, `settle_steps` steps
    /// without flow, then `flow_steps` steps under the flow at `tau_star`.
    /// Returns the digests after each phase.
    pub fn digests<R: Real, const N: usize, const K: usize, const C: usize>(
        &self,
        sim: &mut Sim<R, N, K, C>,
        tau_star: f64,
        settle_steps: u64,
        flow_steps: u64,
    ) -> Result<(u64, u64), Error> {
        self.build(sim)?;
        sim.run(settle_steps)?;
        let settled = sim.digest();
        sim.set_flow(Some(&self.flow(tau_star)))?;
        sim.run(flow_steps)?;
        Ok((settled, sim.digest()))
    }
}
