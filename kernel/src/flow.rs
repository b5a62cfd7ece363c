//! The prescribed flow (docs/model.md §6) and the drag it exerts (docs/model.md §3):
//! log-law mean velocity (14), Nezu turbulence intensities (15), sheltering
//! (16) and the drag force (4)–(5). The fluid is not solved, unless the
//! flow's model is [`FlowModel::Coupled`] (docs/model.md §13, in
//! [`crate::fluid`]).
//!
//! Heights `y` here are measured from the mean bed level (docs/model.md §6).
//!
//! One definition per quantity: a [`FlowSpec`] is the flow a user chooses
//! (κ, h, ε0, k_sr, d, the fluctuations, the intervals, the model), the
//! same at every Shields number; a [`FlowConfig`], what a simulation runs,
//! is a `FlowSpec` at a shear velocity u* with the coupled flow's column
//! ([`FluidConfig`], itself a [`crate::fluid::FluidSpec`] with what the bed
//! gives it). [`crate::Scenario::flow`] makes one from the other; the
//! Shields relation between u* and τ* is [`shear_velocity`] and
//! [`shields_number`].

use crate::error::{check, non_negative, positive, Error};
use crate::fluid::FluidConfig;
use crate::random::{Stream, TURBULENCE_STREAM};
use crate::real::Real;
use crate::steps::IntegrationSteps;

/// What drives the grains' drag (docs/model.md §6, §13).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum FlowModel {
    /// The paper's clear water: the prescribed log law (14) (the default).
    #[default]
    ClearWater = 0,
    /// The coupled flow: the column of [`FlowConfig::fluid`], which feels
    /// the grains (docs/model.md §13).
    Coupled = 1,
}

impl FlowModel {
    /// The model of a checkpoint byte.
    pub(crate) fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(FlowModel::ClearWater),
            1 => Some(FlowModel::Coupled),
            _ => None,
        }
    }
}

/// The flow of docs/model.md §6 without its strength: a [`FlowConfig`]
/// without the shear velocity u* and the coupled flow's column, which
/// [`crate::Scenario::flow`] derives from a Shields number and the bed.
/// Defaults are those of docs/model.md §1 ([`FlowSpec::new`]); its
/// intervals count integration steps ([`IntegrationSteps`]).
///
/// ```
/// use mbs_kernel::{FlowModel, FlowSpec, IntegrationSteps};
///
/// let spec = FlowSpec::new(0.5e-3);
/// assert_eq!((spec.kappa, spec.eps0, spec.roughness), (0.4, 0.4, 0.5e-3));
/// assert_eq!(spec.hold_steps, IntegrationSteps(100));
/// let flow = spec.at(0.04);
/// assert_eq!((flow.u_star, flow.spec), (0.04, spec));
/// assert_eq!(flow.spec.model, FlowModel::ClearWater);
/// flow.validate()?;
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlowSpec {
    /// Kármán constant κ.
    pub kappa: f64,
    /// Flow depth h (m), scale of the intensity decay (15).
    pub depth: f64,
    /// Sheltering coefficient at bed level ε0 (16); 1 disables sheltering.
    pub eps0: f64,
    /// Roughness height k_sr of the log law (14) (m); docs/model.md §1: k_sr = d.
    pub roughness: f64,
    /// Grain diameter d of the zero-level shift y + 0.25d in (14), (16) (m).
    pub reference_diameter: f64,
    /// Monte Carlo fluctuations on (15); off gives the mean flow only.
    pub turbulence: bool,
    /// Integration steps a fluctuation is held before it is redrawn (the
    /// paper: 100 steps of Δt).
    pub hold_steps: IntegrationSteps,
    /// Integration steps between recomputations of the mean bed level
    /// (docs/model.md §6, \[choice\] 100 steps of Δt).
    pub bed_level_interval: IntegrationSteps,
    /// Width of the spans in which the mean bed level is found, in largest
    /// diameters (docs/model.md §6 applied per span, \[choice\] 5: the paper's bed,
    /// nld = 5, is one span). See [`crate::Sim::bed_level`].
    pub bed_level_span: f64,
    /// Clear water (the default) or the coupled flow, whose column is
    /// [`FlowConfig::fluid`].
    pub model: FlowModel,
}

impl FlowSpec {
    /// The defaults of docs/model.md §1 for grains of diameter `d`: κ = 0.4,
    /// h = 0.20 m, ε0 = 0.4, k_sr = d, fluctuations held and the bed level
    /// recomputed every 100 integration steps, bed-level spans of 5
    /// diameters, clear water.
    pub const fn new(d: f64) -> Self {
        FlowSpec {
            kappa: 0.4,
            depth: 0.20,
            eps0: 0.4,
            roughness: d,
            reference_diameter: d,
            turbulence: true,
            hold_steps: IntegrationSteps(100),
            bed_level_interval: IntegrationSteps(100),
            bed_level_span: 5.0,
            model: FlowModel::ClearWater,
        }
    }

    /// The kernel's flow at shear velocity `u_star` (m/s), its column the
    /// defaults of [`FluidConfig::new`] without fluid cells: a clear-water flow,
    /// or a coupled one whose column is still to be given
    /// ([`crate::Scenario::flow`] gives it).
    pub const fn at(&self, u_star: f64) -> FlowConfig {
        FlowConfig {
            u_star,
            spec: *self,
            fluid: FluidConfig::new(0, 0.0, 0.0, 0.0),
        }
    }

    /// The height y0 where the log law (14) starts, 30.1 (y0 + 0.25 d)/k_sr
    /// = 1: y0 = k_sr/30.1 − 0.25 d (m above the mean bed level); the mean
    /// velocity is 0 at and below it.
    ///
    /// ```
    /// use mbs_kernel::{flow::LogLaw, FlowConfig};
    ///
    /// let flow = FlowConfig::new(0.04, 0.5e-3);
    /// let y0 = flow.spec.zero_velocity_height();
    /// let log_law = LogLaw::<f64>::new(&flow);
    /// assert_eq!(log_law.mean_velocity(y0 - 1e-9), 0.0);
    /// assert!(log_law.mean_velocity(y0 + 1e-9) > 0.0);
    /// ```
    pub fn zero_velocity_height(&self) -> f64 {
        self.roughness / 30.1 - 0.25 * self.reference_diameter
    }

    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), Error> {
        positive("flow.kappa", self.kappa)?;
        positive("flow.depth", self.depth)?;
        check(
            self.eps0.is_finite() && (0.0..=1.0).contains(&self.eps0),
            "flow.eps0",
            self.eps0,
            "in [0, 1]",
        )?;
        positive("flow.roughness", self.roughness)?;
        non_negative("flow.reference_diameter", self.reference_diameter)?;
        check(
            self.hold_steps.0 >= 1,
            "flow.hold_steps",
            f64::from(self.hold_steps.0),
            ">= 1 integration step",
        )?;
        check(
            self.bed_level_interval.0 >= 1,
            "flow.bed_level_interval",
            f64::from(self.bed_level_interval.0),
            ">= 1 integration step",
        )?;
        check(
            self.bed_level_span.is_finite() && self.bed_level_span >= 1.0,
            "flow.bed_level_span",
            self.bed_level_span,
            ">= 1 (largest diameters)",
        )
    }
}

/// The flow the kernel runs (SI units): a [`FlowSpec`] at a shear velocity
/// u*, with the coupled flow's column. Defaults are those of
/// docs/model.md §1 ([`FlowConfig::new`]).
///
/// ```
/// use mbs_kernel::{shear_velocity, FlowConfig, IntegrationSteps};
///
/// // τ* = 0.2 on 0.5 mm sand: u* ≈ 4.0 cm/s.
/// let u_star = shear_velocity(0.2, 2.65, 9.81, 0.5e-3);
/// assert!((u_star - 0.0402).abs() < 1e-4);
/// let flow = FlowConfig::new(u_star, 0.5e-3);
/// flow.validate()?;
/// assert_eq!((flow.spec.kappa, flow.spec.eps0), (0.4, 0.4));
/// assert_eq!(flow.spec.hold_steps, IntegrationSteps(100));
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlowConfig {
    /// Shear velocity u* (m/s); see [`shear_velocity`].
    pub u_star: f64,
    /// The flow without its strength: κ, h, ε0, k_sr, d, the fluctuations,
    /// the intervals, the model.
    pub spec: FlowSpec,
    /// The coupled flow's column; read only with [`FlowModel::Coupled`].
    /// u* then gives the column's initial profile (the log law (14)) and
    /// the depth h the decay of the fluctuations (15); the driving is
    /// `fluid.driving` plus gravity along the bed slope
    /// ([`crate::SimConfig::slope_angle`]).
    pub fluid: FluidConfig,
}

impl FlowConfig {
    /// The defaults of docs/model.md §1 ([`FlowSpec::new`]) for grains of
    /// diameter `d` at shear velocity `u_star`: clear water.
    pub const fn new(u_star: f64, d: f64) -> Self {
        FlowSpec::new(d).at(u_star)
    }

    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), Error> {
        non_negative("flow.u_star", self.u_star)?;
        self.spec.validate()?;
        match self.spec.model {
            FlowModel::ClearWater => Ok(()),
            // The capacity is checked by `Sim::set_flow`.
            FlowModel::Coupled => self.fluid.validate(usize::MAX),
        }
    }
}

/// u* from the Shields number: τ* = u*²/((s − 1)gd) (docs/model.md §6),
/// u* = √(τ* (s − 1) g d); the inverse of [`shields_number`].
pub fn shear_velocity(tau_star: f64, s: f64, g: f64, d: f64) -> f64 {
    libm::sqrt(tau_star * (s - 1.0) * g * d)
}

/// The Shields number of the shear velocity `u_star`: τ* = u*²/((s − 1)gd)
/// (docs/model.md §6); the inverse of [`shear_velocity`].
///
/// ```
/// use mbs_kernel::{shear_velocity, shields_number};
///
/// let (s, g, d) = (2.65, 9.81, 0.5e-3);
/// let tau_star = shields_number(0.03, s, g, d);
/// assert_eq!(tau_star, 0.03 * 0.03 / ((s - 1.0) * g * d));
/// // The round trip, to round-off.
/// assert!((shear_velocity(tau_star, s, g, d) - 0.03).abs() < 1e-15);
/// assert!((shields_number(shear_velocity(0.2, s, g, d), s, g, d) - 0.2).abs() < 1e-15);
/// ```
pub fn shields_number(u_star: f64, s: f64, g: f64, d: f64) -> f64 {
    u_star * u_star / ((s - 1.0) * g * d)
}

/// The Shields number of a uniform open-channel flow of depth `depth` on
/// the energy slope `slope` S (the sine of its angle): its bed shear
/// stress ρ g h S, u*² = g h S, gives τ* = h S/((s − 1) d) (docs/model.md
/// §6, §13 (C5)); g cancels.
///
/// ```
/// use mbs_kernel::{shields_number, uniform_flow_shields_number};
///
/// let (h, slope, s, d) = (0.05, 0.002, 2.65, 0.5e-3);
/// let tau_star = uniform_flow_shields_number(h, slope, s, d);
/// let u_star = (9.81 * h * slope).sqrt();
/// assert!((tau_star - shields_number(u_star, s, 9.81, d)).abs() < 1e-15);
/// ```
pub fn uniform_flow_shields_number(depth: f64, slope: f64, s: f64, d: f64) -> f64 {
    depth * slope / ((s - 1.0) * d)
}

/// The prescribed clear-water flow (docs/model.md): the log law (14), the
/// turbulence intensity (15) and the sheltering (16), in the working
/// precision, evaluated per grain per step.
///
/// ```
/// use mbs_kernel::{flow::LogLaw, FlowConfig};
///
/// let d = 0.5e-3;
/// let log_law = LogLaw::<f64>::new(&FlowConfig::new(0.04, d));
/// // (14): no flow below the zero level, faster higher up.
/// assert_eq!(log_law.mean_velocity(-d), 0.0);
/// assert!(log_law.mean_velocity(2.0 * d) > log_law.mean_velocity(d));
/// // (16): sheltered at the bed (ε0 = 0.4), exposed well above it.
/// assert_eq!(log_law.sheltering(-d), 0.4);
/// assert!(log_law.sheltering(10.0 * d) > 0.99);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogLaw<R: Real> {
    /// u*/κ.
    pub(crate) u_star_over_kappa: R,
    /// 2.30 u*.
    pub(crate) rms_u0: R,
    /// 1.27 u*.
    pub(crate) rms_v0: R,
    /// −1/h.
    pub(crate) minus_inv_depth: R,
    /// ε0.
    pub(crate) eps0: R,
    /// 1/k_sr.
    pub(crate) inv_roughness: R,
    /// 0.25 d.
    pub(crate) zero_shift: R,
    /// Fluctuations on.
    pub(crate) turbulence: bool,
}

impl<R: Real> LogLaw<R> {
    /// An all-zero log law (no flow).
    pub const ZERO: Self = LogLaw {
        u_star_over_kappa: R::ZERO,
        rms_u0: R::ZERO,
        rms_v0: R::ZERO,
        minus_inv_depth: R::ZERO,
        eps0: R::ZERO,
        inv_roughness: R::ZERO,
        zero_shift: R::ZERO,
        turbulence: false,
    };

    /// Converts a validated [`FlowConfig`] to the working precision.
    pub fn new(c: &FlowConfig) -> Self {
        let f = &c.spec;
        LogLaw {
            u_star_over_kappa: R::from_f64(c.u_star / f.kappa),
            rms_u0: R::from_f64(2.30 * c.u_star),
            rms_v0: R::from_f64(1.27 * c.u_star),
            minus_inv_depth: R::from_f64(-1.0 / f.depth),
            eps0: R::from_f64(f.eps0),
            inv_roughness: R::from_f64(1.0 / f.roughness),
            zero_shift: R::from_f64(0.25 * f.reference_diameter),
            turbulence: f.turbulence,
        }
    }

    /// (14): U = (u*/κ) ln(30.1 (y + 0.25d)/k_sr), and 0 where the argument is ≤ 1.
    #[inline]
    pub fn mean_velocity(&self, y: R) -> R {
        let arg = R::from_f64(30.1) * (y + self.zero_shift) * self.inv_roughness;
        if arg > R::ONE {
            self.u_star_over_kappa * R::ln(arg)
        } else {
            R::ZERO
        }
    }

    /// (15): rms (u, v) = (2.30, 1.27) u* exp(−y/h).
    #[inline]
    pub fn intensity(&self, y: R) -> (R, R) {
        let decay = R::exp(y * self.minus_inv_depth);
        (self.rms_u0 * decay, self.rms_v0 * decay)
    }

    /// (16): ε = ε0 + (1 − ε0)[1 − exp(−((y + 0.25d)/k_sr)²)]; ε = ε0 below the
    /// zero level y + 0.25d ≤ 0 **\[choice\]**: (16) is even in y + 0.25d and
    /// would otherwise expose deeply buried grains.
    #[inline]
    pub fn sheltering(&self, y: R) -> R {
        let z = (y + self.zero_shift) * self.inv_roughness;
        if z > R::ZERO {
            self.eps0 + (R::ONE - self.eps0) * (R::ONE - R::exp(-(z * z)))
        } else {
            self.eps0
        }
    }

    /// The fluctuation (u, v) of held standard-normal draws (z_u, z_v) at
    /// height `y` where the mean velocity is `mean`: (15) scaled draws, zero
    /// where U = 0 or without turbulence (docs/model.md §6).
    #[inline]
    pub fn fluctuation(&self, mean: R, y: R, z_u: R, z_v: R) -> (R, R) {
        if self.turbulence && mean > R::ZERO {
            let (su, sv) = self.intensity(y);
            (z_u * su, z_v * sv)
        } else {
            (R::ZERO, R::ZERO)
        }
    }

    /// Drag force (4)–(5) on a grain at height `y` with velocity (u_p, v_p) and
    /// standard-normal fluctuation draws (z_u, z_v); `coef` = ½ρC_D A2 d².
    /// Fluctuations apply only where U > 0 (docs/model.md §6).
    #[inline]
    pub fn drag(&self, coef: R, y: R, u_p: R, v_p: R, z_u: R, z_v: R) -> (R, R) {
        let mean = self.mean_velocity(y);
        let (fluct_u, fluct_v) = self.fluctuation(mean, y, z_u, z_v);
        let wx = mean + fluct_u - u_p;
        let wy = fluct_v - v_p;
        let xi = coef * self.sheltering(y) * R::sqrt(wx * wx + wy * wy);
        (xi * wx, xi * wy)
    }
}

/// The standard-normal pair (z_u, z_v) of grain `id` in hold period `period`
/// (docs/model.md (15), \[choice\]: per grain, independent u and v, held for
/// [`FlowSpec::hold_steps`]). Keyed, so it does not depend on draw order.
pub fn fluctuation_draw(seed: u64, period: u64, id: u32) -> (f64, f64) {
    Stream::new(seed, TURBULENCE_STREAM, period, id as u64).gaussian_pair()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log_law() -> (FlowConfig, LogLaw<f64>) {
        let c = FlowConfig::new(0.03, 0.5e-3);
        (c, LogLaw::new(&c))
    }

    #[test]
    fn log_law_at_chosen_heights() {
        let (c, p) = log_law();
        let d = 0.5e-3;
        for &y in &[0.0f64, 0.5 * d, 2.0 * d, 10.0 * d] {
            let expect = c.u_star / 0.4 * (30.1 * (y + 0.25 * d) / d).ln();
            assert!((p.mean_velocity(y) - expect).abs() < 1e-12, "y = {y}");
        }
        // Zero-velocity level: 30.1 (y + d/4)/d = 1.
        let y0 = d / 30.1 - 0.25 * d;
        assert_eq!(y0, c.spec.zero_velocity_height());
        assert_eq!(p.mean_velocity(y0 - 1e-9), 0.0);
        assert!(p.mean_velocity(y0 + 1e-9) > 0.0);
        assert_eq!(p.mean_velocity(-d), 0.0);
    }

    #[test]
    fn intensity_and_sheltering_at_chosen_heights() {
        let (c, p) = log_law();
        let (su, sv) = p.intensity(0.0);
        assert!((su - 2.30 * c.u_star).abs() < 1e-15 && (sv - 1.27 * c.u_star).abs() < 1e-15);
        let (su, _) = p.intensity(0.1);
        assert!((su - 2.30 * c.u_star * (-0.5f64).exp()).abs() < 1e-15);
        let d = 0.5e-3;
        // At y = −0.25d, ε = ε0; at y = 0.75d: ε0 + (1 − ε0)(1 − e^{−1}).
        assert!((p.sheltering(-0.25 * d) - 0.4).abs() < 1e-15);
        let e = p.sheltering(0.75 * d);
        assert!((e - (0.4 + 0.6 * (1.0 - (-1.0f64).exp()))).abs() < 1e-14);
        assert!((p.sheltering(10.0 * d) - 1.0).abs() < 1e-12);
        assert_eq!(p.sheltering(-3.0 * d), 0.4);
    }

    #[test]
    fn drag_on_a_grain_at_rest_points_downstream() {
        let (_, p) = log_law();
        let d = 0.5e-3;
        let coef = 0.5 * 1000.0 * 0.4 * core::f64::consts::FRAC_PI_4 * d * d;
        let y = 3.0 * d;
        let (fx, fy) = p.drag(coef, y, 0.0, 0.0, 0.0, 0.0);
        let u = p.mean_velocity(y);
        assert!((fx - coef * p.sheltering(y) * u * u).abs() < 1e-18);
        assert_eq!(fy, 0.0);
    }

    /// (4)–(5) on a moving grain: the drag follows the velocity relative
    /// to the fluid, u_f − u_p: none on a grain moving with the mean flow,
    /// the drag at rest reversed on one moving at twice it, and a vertical
    /// drag against v_p.
    #[test]
    fn drag_follows_the_velocity_relative_to_the_fluid() {
        let (_, p) = log_law();
        let d = 0.5e-3;
        let coef = 0.5 * 1000.0 * 0.4 * core::f64::consts::FRAC_PI_4 * d * d;
        let y = 3.0 * d;
        let u = p.mean_velocity(y);
        assert!(u > 0.0);
        assert_eq!(p.drag(coef, y, u, 0.0, 0.0, 0.0), (0.0, 0.0));
        let (at_rest, _) = p.drag(coef, y, 0.0, 0.0, 0.0, 0.0);
        assert_eq!(p.drag(coef, y, 2.0 * u, 0.0, 0.0, 0.0), (-at_rest, 0.0));
        let v = 0.01;
        let (fx, fy) = p.drag(coef, y, u, v, 0.0, 0.0);
        assert_eq!(fx, 0.0);
        assert!((fy + coef * p.sheltering(y) * v * v).abs() < 1e-18);
    }

    #[test]
    fn validation_names_fields() {
        let mut c = FlowConfig::new(0.03, 0.5e-3);
        c.spec.eps0 = 1.5;
        assert!(matches!(
            c.validate(),
            Err(Error::InvalidParameter {
                name: "flow.eps0",
                ..
            })
        ));
        c.spec.eps0 = 0.4;
        c.spec.hold_steps = IntegrationSteps(0);
        let e = c.validate().unwrap_err();
        assert!(matches!(
            e,
            Error::InvalidParameter {
                name: "flow.hold_steps",
                ..
            }
        ));
        // The kernel counts its intervals in integration steps, and says so.
        assert_eq!(
            std::format!("{e}"),
            "flow.hold_steps = 0: must be >= 1 integration step"
        );
    }
}
