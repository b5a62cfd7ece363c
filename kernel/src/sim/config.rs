//! [`SimConfig`]: what a simulation needs besides its grains and its flow,
//! its checks, and what it derives (docs/model.md (2): the reduced gravity,
//! the whole weight out of the water, the slope's driving).

use crate::constants::{ContactConstants, Material};
use crate::contact::Tension;
use crate::error::{check, finite, positive, Capacity, Error};
use crate::grains::{GrainSpec, MAX_CLASSES};

/// Everything a simulation needs besides its grains and its flow (SI units).
///
/// ```
/// use mbs_kernel::Scenario;
///
/// let scenario = Scenario::paper();
/// let config = scenario.sim_config()?;
/// config.validate()?;
/// // The integration step: the constants' Δt over 8 substeps.
/// assert_eq!(config.step_dt, scenario.rule.constants_dt / 8.0);
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SimConfig {
    /// The integration step (s): Δt/substeps of the constants' time step.
    pub step_dt: f64,
    /// Fluid and grain material.
    pub material: Material,
    /// Contact springs and dashpots, e.g. from [`crate::contact_constants`].
    pub contact: ContactConstants,
    /// What part of the normal force may pull: the paper's rule (8) by
    /// default, or none (8').
    pub tension: Tension,
    /// Gravity (g_x, g_y) (m/s²); (0, −9.81) by default. Tilt it to incline
    /// the bed as a whole, water included (the buoyancy then tilts too); for
    /// a river bed use [`SimConfig::slope_angle`].
    pub gravity: [f64; 2],
    /// Periodic width L (m); grains live in 0 ≤ x < L.
    pub width: f64,
    /// Lowest allowed grain height (m): below it a grain has left the domain.
    pub y_min: f64,
    /// Highest allowed grain height (m): above it a grain has left the
    /// domain. [`crate::Scenario`] puts it as far above the free surface as
    /// y_min lies below it.
    pub y_max: f64,
    /// Height of the free surface (m) (docs/model.md §2): a grain whose
    /// centre lies above it is out of the water, with no drag, no buoyancy
    /// and no added mass, as HydroForceEngine treats a grain above its last
    /// fluid cell; at or above `y_max`, none is.
    pub surface: f64,
    /// Largest neighbour-list skin (m); each rebuild sizes the skin from the
    /// fastest grain, down to 0.3 of it. Results do not depend on it; speed does.
    pub skin: f64,
    /// Seed of every random draw (docs/model.md §7: all randomness from one seed).
    pub seed: u64,
    /// Bed slope angle θ (rad), 0 ≤ θ < 0.5; 0 by default: an angle, not
    /// the energy slope S = sin θ of a uniform flow
    /// ([`crate::uniform_flow_shields_number`]). x runs down the slope, y
    /// normal to the bed. The water is in uniform open-channel flow (Maurin
    /// et al. 2015): its pressure is hydrostatic normal to the bed, so a
    /// grain feels its whole weight along the slope and its buoyant weight
    /// normal to it: accelerations g sin θ · s/(s + C_M) along x and
    /// −g cos θ · (s − 1)/(s + C_M) along y (docs/model.md (2) with a slope),
    /// g = −`gravity.y`. A slope needs the vertical gravity (`gravity.x` = 0);
    /// θ = 0 is the paper's horizontal bed, bit for bit. The coupled flow is
    /// driven by g sin θ besides its own `driving` (docs/model.md §13).
    pub slope_angle: f64,
}

impl SimConfig {
    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), Error> {
        positive("step_dt", self.step_dt)?;
        self.material.validate()?;
        self.contact.validate()?;
        finite("gravity.x", self.gravity[0])?;
        finite("gravity.y", self.gravity[1])?;
        positive("width", self.width)?;
        finite("y_min", self.y_min)?;
        check(
            self.y_max.is_finite() && self.y_max > self.y_min,
            "y_max",
            self.y_max,
            "finite and > y_min",
        )?;
        check(
            self.surface.is_finite() && self.surface > self.y_min,
            "surface",
            self.surface,
            "finite and > y_min",
        )?;
        crate::error::non_negative("skin", self.skin)?;
        check(
            self.slope_angle.is_finite() && (0.0..0.5).contains(&self.slope_angle),
            "slope_angle",
            self.slope_angle,
            "in [0, 0.5) rad",
        )?;
        check(
            self.slope_angle == 0.0 || self.gravity[0] == 0.0,
            "gravity.x",
            self.gravity[0],
            "0 with a bed slope (the slope tilts the vertical gravity)",
        )
    }

    /// The acceleration of weight less buoyancy over inertia (m/s²) along x
    /// and y: (g_x, g_y)(s − 1)/(s + C_M) (docs/model.md (2)); with a
    /// slope θ, (g sin θ · s, −g cos θ · (s − 1))/(s + C_M), g = −g_y
    /// (see [`SimConfig::slope_angle`]).
    pub fn reduced_gravity(&self) -> [f64; 2] {
        let m = &self.material;
        let reduce = (m.s - 1.0) / (m.s + m.c_m);
        if self.slope_angle == 0.0 {
            return [self.gravity[0] * reduce, self.gravity[1] * reduce];
        }
        let g = -self.gravity[1];
        [
            g * libm::sin(self.slope_angle) * m.s / (m.s + m.c_m),
            self.gravity[1] * libm::cos(self.slope_angle) * reduce,
        ]
    }

    /// The acceleration of the whole weight (m/s²) along x and y, of a grain
    /// out of the water (above [`SimConfig::surface`]): (g_x, g_y); with a
    /// slope θ, (g sin θ, −g cos θ), g = −g_y.
    pub fn air_gravity(&self) -> [f64; 2] {
        if self.slope_angle == 0.0 {
            return self.gravity;
        }
        let g = -self.gravity[1];
        [
            g * libm::sin(self.slope_angle),
            self.gravity[1] * libm::cos(self.slope_angle),
        ]
    }

    /// m'/m_s = (s + C_M)/s: a force's acceleration out of the water over
    /// its acceleration in it (docs/model.md (2): no added mass in air).
    pub fn air_inertia_ratio(&self) -> f64 {
        let m = &self.material;
        (m.s + m.c_m) / m.s
    }

    /// g sin θ (m/s²): gravity along the bed slope, which drives the
    /// coupled flow (docs/model.md §13); 0 without a slope.
    pub fn slope_driving(&self) -> f64 {
        if self.slope_angle == 0.0 {
            0.0
        } else {
            -self.gravity[1] * libm::sin(self.slope_angle)
        }
    }
}

/// The checks of [`Sim::add_grain`] against a configuration: diameter > 0,
/// position inside the domain, finite velocities, a known size class and,
/// for a mobile grain, the stability bound (11).
pub(crate) fn check_grain(c: &SimConfig, spec: &GrainSpec) -> Result<(), Error> {
    positive("grain.diameter", spec.diameter)?;
    check(
        spec.x.is_finite() && spec.x >= 0.0 && spec.x < c.width,
        "grain.x",
        spec.x,
        "in [0, width)",
    )?;
    check(
        spec.y.is_finite() && spec.y >= c.y_min && spec.y <= c.y_max,
        "grain.y",
        spec.y,
        "in [y_min, y_max]",
    )?;
    finite("grain.u", spec.u)?;
    finite("grain.v", spec.v)?;
    finite("grain.spin", spec.spin)?;
    if usize::from(spec.class) >= MAX_CLASSES {
        return Err(Error::CapacityExceeded {
            what: Capacity::SizeClasses,
            capacity: MAX_CLASSES,
        });
    }
    if !spec.fixed {
        let limit = c
            .contact
            .stable_dt_limit(c.material.translational_mass(spec.diameter));
        check(
            c.step_dt <= limit,
            "step_dt",
            c.step_dt,
            "<= 2 sqrt(m/k_n) of every grain (stability bound, docs/model.md (11); step_dt = constants_dt/substeps)",
        )?;
    }
    Ok(())
}
