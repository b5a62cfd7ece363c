//! Counts of integration steps. docs/model.md has two time steps: the
//! constants' time step Δt, from which the contact constants derive (§5),
//! and the integration step step_dt = Δt/substeps, by which the integrator
//! advances (§12). A configuration file counts the flow's intervals in
//! steps of Δt; the kernel counts them in integration steps. Each such
//! interval of the kernel is an [`IntegrationSteps`], so that the two
//! counts cannot be confused, and [`IntegrationSteps::from_constants_steps`]
//! is the one place that converts (multiplies by the substeps).

/// A count of integration steps step_dt = Δt/substeps (docs/model.md §12):
/// the unit of the kernel's intervals ([`crate::FlowSpec::hold_steps`],
/// [`crate::FlowSpec::bed_level_interval`], [`crate::fluid::FluidSpec::update_steps`]).
///
/// ```
/// use mbs_kernel::IntegrationSteps;
///
/// // The paper's hold of 100 steps of Δt, integrated with 8 substeps.
/// let hold = IntegrationSteps::from_constants_steps(100, 8);
/// assert_eq!(hold, IntegrationSteps(800));
/// assert_eq!(hold.to_constants_steps(8), 100);
/// assert_eq!(u64::from(hold), 800);
/// // Saturating, never a panic.
/// assert_eq!(IntegrationSteps::from_constants_steps(u32::MAX, 2).0, u32::MAX);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IntegrationSteps(pub u32);

impl IntegrationSteps {
    /// `steps` steps of the constants' time step Δt as integration steps,
    /// `substeps` to each (docs/model.md §12: step_dt = Δt/substeps):
    /// `steps` × `substeps`, saturating at `u32::MAX`.
    pub const fn from_constants_steps(steps: u32, substeps: u32) -> Self {
        IntegrationSteps(steps.saturating_mul(substeps))
    }

    /// The whole steps of Δt these are with `substeps` integration steps
    /// to each (docs/model.md §12), rounded down; all of them for 0 substeps.
    pub const fn to_constants_steps(self, substeps: u32) -> u32 {
        match self.0.checked_div(substeps) {
            Some(steps) => steps,
            None => self.0,
        }
    }
}

impl From<IntegrationSteps> for u64 {
    fn from(steps: IntegrationSteps) -> u64 {
        u64::from(steps.0)
    }
}
