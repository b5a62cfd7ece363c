//! A complete, named run set-up: the paper's case by default. The host's
//! configuration, the golden-digest tests and the firmware all build their
//! simulations through this one type, so they compute the same thing.

use crate::bed::{BedInfo, BedSpec};
use crate::constants::{contact_constants, ContactConstants, Material, TimeStepRule};
use crate::error::Error;
use crate::flow::{shear_velocity, FlowConfig};
use crate::real::Real;
use crate::sim::{Sim, SimConfig};

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
/// // the flow): two runs, the same bits.
/// let (mut a, mut b) = (Sim::<f32, 64, 8>::new(), Sim::<f32, 64, 8>::new());
/// assert_eq!(scenario.digests(&mut a, 100, 100)?, scenario.digests(&mut b, 100, 100)?);
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
    /// Integration steps per Δt: the kernel integrates with Δt/substeps and
    /// keeps every constant derived from Δt. Flow hold and bed-level
    /// intervals are counted in steps of Δt, so they keep their duration.
    pub substeps: u32,
    /// The initial bed (docs/model.md §7).
    pub bed: BedSpec,
    /// Shields number τ* of the flow phase.
    pub tau_star: f64,
    /// The flow of docs/model.md §6; its `u_star` is replaced by the one of `tau_star`
    /// and its `depth` is also the top of the domain.
    pub flow: FlowConfig,
    /// Largest neighbour skin in units of the largest diameter.
    pub skin: f64,
    /// Seed of every random draw.
    pub seed: u64,
}

impl Scenario {
    /// The paper's case (docs/model.md §9): d = 0.5 mm, nld = 5, nvd = 10, spacing
    /// 1.05 d, Δt = 2.0e-5 s, α_m = 20, α_cn = 1.3, β = 15.8, τ* = 0.2,
    /// integrated with 8 substeps: at Δt itself the tangential dashpot of
    /// rule (17) is beyond the explicit damping limit
    /// ([`crate::explicit_damping_number`] ≈ 2.85) and the bed never settles;
    /// with 4 substeps q* still depends on the step, with 8 and 16 it does
    /// not (README, "The explicit damping limit").
    pub fn paper() -> Self {
        Scenario {
            material: Material::default(),
            rule: TimeStepRule {
                alpha_m: 20.0,
                alpha_cn: 1.3,
                beta: 15.8,
                constants_dt: 2.0e-5,
            },
            explicit_contact: None,
            substeps: 8,
            bed: BedSpec::uniform(0.5e-3, 5, 10),
            tau_star: 0.2,
            flow: FlowConfig::new(0.0, 0.5e-3),
            skin: 0.1,
            seed: 1,
        }
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
    /// top of the domain at the flow depth. Width and y_min are set by
    /// [`Sim::build_bed`].
    pub fn sim_config(&self) -> Result<SimConfig, Error> {
        let d = self.bed.max_diameter();
        Ok(SimConfig {
            step_dt: self.step_dt(),
            material: self.material,
            contact: self.contact()?,
            gravity: [0.0, -G],
            width: self.bed.width(),
            y_min: -10.0 * d,
            y_max: self.flow.depth,
            skin: self.skin * d,
            seed: self.seed,
        })
    }

    /// The integration time step Δt/substeps (s).
    pub fn step_dt(&self) -> f64 {
        self.rule.constants_dt / f64::from(self.substeps.max(1))
    }

    /// The flow at this scenario's τ*: u* from τ* for the largest grain, hold
    /// and bed-level intervals converted to integration steps (saturating).
    pub fn flow(&self) -> FlowConfig {
        let d = self.bed.max_diameter();
        let n = self.substeps.max(1);
        FlowConfig {
            u_star: shear_velocity(self.tau_star, self.material.s, G, d),
            hold_steps: self.flow.hold_steps.saturating_mul(n),
            bed_level_interval: self.flow.bed_level_interval.saturating_mul(n),
            ..self.flow
        }
    }

    /// Resets `sim` and builds the initial bed.
    pub fn build<R: Real, const N: usize, const K: usize>(
        &self,
        sim: &mut Sim<R, N, K>,
    ) -> Result<BedInfo, Error> {
        sim.build_bed(&self.sim_config()?, &self.bed)
    }

    /// The fixed golden-digest run: build the bed, `settle_steps` steps
    /// without flow, then `flow_steps` steps under the flow. Returns the
    /// digests after each phase.
    pub fn digests<R: Real, const N: usize, const K: usize>(
        &self,
        sim: &mut Sim<R, N, K>,
        settle_steps: u64,
        flow_steps: u64,
    ) -> Result<(u64, u64), Error> {
        self.build(sim)?;
        sim.run(settle_steps)?;
        let settled = sim.digest();
        sim.set_flow(Some(&self.flow()))?;
        sim.run(flow_steps)?;
        Ok((settled, sim.digest()))
    }
}
