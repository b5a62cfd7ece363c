//! Every way the kernel can fail. The kernel never panics: each failure is one
//! of these values, returned to the caller with enough context to act on.

use core::fmt;

/// A fixed capacity of the simulation that an operation would exceed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Capacity {
    /// Grain slots (`N` of [`crate::Sim`]).
    Grains,
    /// Neighbour (and contact-history) slots per grain (`K` of [`crate::Sim`]).
    NeighboursPerGrain,
    /// Size classes ([`crate::MAX_CLASSES`]).
    SizeClasses,
    /// Fluid cells of the coupled flow's column (`C` of [`crate::fluid::Column`]).
    FluidCells,
}

impl Capacity {
    /// Human-readable name of the capacity.
    pub const fn name(self) -> &'static str {
        match self {
            Capacity::Grains => "grains (N)",
            Capacity::NeighboursPerGrain => "neighbours per grain (K)",
            Capacity::SizeClasses => "size classes (MAX_CLASSES)",
            Capacity::FluidCells => "fluid cells (C)",
        }
    }
}

/// A per-grain quantity that became non-finite.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Quantity {
    /// Position.
    Position,
    /// Translational velocity.
    Velocity,
    /// Spin.
    Spin,
}

/// Why a checkpoint was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CheckpointFault {
    /// It ends before the state does.
    Truncated,
    /// It does not start with the checkpoint magic.
    Magic,
    /// Written by another format version.
    Version,
    /// Written in the other precision.
    Precision,
    /// A field is out of range (a non-finite number, an index, a flag).
    Value,
    /// Bytes follow the state.
    Trailing,
}

/// An error returned by the kernel.
///
/// ```
/// use mbs_kernel::{Error, Scenario, Sim};
///
/// let mut config = Scenario::paper().sim_config()?;
/// config.step_dt = -1.0;
/// let mut sim = Sim::<f64, 8, 4>::new();
/// let error = sim.reset(&config).unwrap_err();
/// assert!(matches!(error, Error::InvalidParameter { name: "step_dt", .. }));
/// assert_eq!(error.to_string(), "step_dt = -1: must be finite and > 0");
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// A fixed capacity would be exceeded; nothing was dropped or clamped.
    CapacityExceeded {
        /// Which capacity.
        what: Capacity,
        /// Its size.
        capacity: usize,
    },
    /// A grain's state became infinite or NaN (typically the integration
    /// step `step_dt` beyond the stability bound, docs/model.md (11)).
    NonFinite {
        /// Step count at which it was detected.
        step: u64,
        /// Grain index.
        grain: u32,
        /// What became non-finite.
        quantity: Quantity,
    },
    /// A grain left the vertical extent of the domain, or moved more than the
    /// periodic width in one step.
    LeftDomain {
        /// Step count at which it was detected.
        step: u64,
        /// Grain index.
        grain: u32,
        /// Its height y (m).
        y: f64,
    },
    /// A checkpoint could not be restored; the simulation is unchanged.
    BadCheckpoint {
        /// What is wrong.
        fault: CheckpointFault,
        /// Byte offset where it was found.
        offset: usize,
    },
    /// A parameter is outside its allowed range.
    InvalidParameter {
        /// Parameter name, e.g. `"step_dt"`.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// The allowed range, e.g. `"> 0"`.
        allowed: &'static str,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::CapacityExceeded { what, capacity } => {
                write!(f, "capacity exceeded: {} = {capacity}", what.name())
            }
            Error::NonFinite {
                step,
                grain,
                quantity,
            } => write!(
                f,
                "non-finite {quantity:?} of grain {grain} at step {step} (is step_dt within the stability bound?)"
            ),
            Error::LeftDomain { step, grain, y } => {
                write!(f, "grain {grain} left the domain at step {step} (y = {y:e} m)")
            }
            Error::BadCheckpoint { fault, offset } => {
                write!(f, "checkpoint refused: {fault:?} at byte {offset}")
            }
            Error::InvalidParameter {
                name,
                value,
                allowed,
            } => write!(f, "{name} = {value}: must be {allowed}"),
        }
    }
}

impl core::error::Error for Error {}

/// Returns `Err(InvalidParameter)` unless `ok`.
#[inline]
pub(crate) fn check(
    ok: bool,
    name: &'static str,
    value: f64,
    allowed: &'static str,
) -> Result<(), Error> {
    if ok {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name,
            value,
            allowed,
        })
    }
}

/// `value` must be finite and > 0.
pub(crate) fn positive(name: &'static str, value: f64) -> Result<(), Error> {
    check(
        value.is_finite() && value > 0.0,
        name,
        value,
        "finite and > 0",
    )
}

/// `value` must be finite and ≥ 0.
pub(crate) fn non_negative(name: &'static str, value: f64) -> Result<(), Error> {
    check(
        value.is_finite() && value >= 0.0,
        name,
        value,
        "finite and >= 0",
    )
}

/// `value` must be finite.
pub(crate) fn finite(name: &'static str, value: f64) -> Result<(), Error> {
    check(value.is_finite(), name, value, "finite")
}
