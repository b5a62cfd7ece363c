//! Material constants and the contact constants derived from the time step,
//! docs/model.md §5, eqs. (10)–(13), (17), (18).
//!
//! All values are SI. The paper prints its worked example in a gram-based
//! system, so its k_n = 2.54e2 and η_n = 4.58e-1 are 1000× the SI values
//! 0.2543 N/m and 4.580e-4 N·s/m computed here (see the unit test).

use crate::error::{check, positive, Error};
use core::f64::consts::PI;

/// A2 = π/4: projected-area coefficient of a sphere (docs/model.md §1).
pub const A2: f64 = PI / 4.0;
/// A3 = π/6: volume coefficient of a sphere (docs/model.md §1).
pub const A3: f64 = PI / 6.0;

/// Fluid and grain material (docs/model.md §1 defaults in [`Material::default`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Material {
    /// Water density ρ (kg/m³).
    pub rho: f64,
    /// Specific gravity s = σ/ρ of the grains.
    pub s: f64,
    /// Added-mass coefficient C_M.
    pub c_m: f64,
    /// Drag coefficient C_D.
    pub c_d: f64,
    /// Coulomb friction coefficient μ.
    pub mu: f64,
    /// Poisson ratio ν.
    pub nu: f64,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            rho: 1000.0,
            s: 2.65,
            c_m: 0.5,
            c_d: 0.4,
            mu: 0.577,
            nu: 0.3,
        }
    }
}

impl Material {
    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), Error> {
        positive("material.rho", self.rho)?;
        check(
            self.s.is_finite() && self.s > 1.0,
            "material.s",
            self.s,
            "finite and > 1",
        )?;
        crate::error::non_negative("material.c_m", self.c_m)?;
        crate::error::non_negative("material.c_d", self.c_d)?;
        crate::error::non_negative("material.mu", self.mu)?;
        check(
            self.nu.is_finite() && self.nu > -1.0 && self.nu < 0.5,
            "material.nu",
            self.nu,
            "in (-1, 0.5)",
        )
    }

    /// Translational inertia including added mass, m = ρ(s + C_M)A3 d³
    /// (docs/model.md (1)–(2), §5).
    pub fn translational_mass(&self, d: f64) -> f64 {
        self.rho * (self.s + self.c_m) * A3 * d * d * d
    }

    /// Moment of inertia of the sphere, σπd⁵/60 (docs/model.md (3)); no added mass.
    pub fn moment_of_inertia(&self, d: f64) -> f64 {
        self.rho * self.s * PI * d * d * d * d * d / 60.0
    }

    /// Submerged weight ρ(s − 1)A3 d³ g (docs/model.md (2)).
    pub fn submerged_weight(&self, d: f64, g: f64) -> f64 {
        self.rho * (self.s - 1.0) * A3 * d * d * d * g
    }
}

/// Spring and dashpot constants of the contact law (docs/model.md (6)–(9)),
/// SI units. The subscript s is the tangential (shear) direction of the
/// contact throughout, as in the paper (e_s, f_s, Δξ_s); the roughness
/// height of the log law (14) is k_sr ([`crate::FlowSpec::roughness`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ContactConstants {
    /// Normal spring k_n (N/m).
    pub k_n: f64,
    /// Tangential spring k_s (N/m).
    pub k_s: f64,
    /// Normal dashpot η_n (N·s/m).
    pub eta_n: f64,
    /// Tangential dashpot η_s (N·s/m).
    pub eta_s: f64,
}

impl ContactConstants {
    /// The constants of the normal spring `k_n` (N/m) and dashpot `eta_n`
    /// (N·s/m), with the tangential ones of docs/model.md (12)–(13) for the
    /// Poisson ratio `poisson` ν: k_s = k_n/(2(1 + ν)),
    /// η_s = η_n/√(2(1 + ν)). Not validated ([`Self::validate`]).
    ///
    /// ```
    /// use mbs_kernel::ContactConstants;
    ///
    /// let c = ContactConstants::from_normal(0.26, 4.6e-4, 0.3);
    /// assert_eq!((c.k_n, c.eta_n), (0.26, 4.6e-4));
    /// assert_eq!(c.k_s, 0.26 / 2.6);
    /// assert_eq!(c.eta_s, 4.6e-4 / 2.6f64.sqrt());
    /// c.validate()?;
    /// # Ok::<(), mbs_kernel::Error>(())
    /// ```
    pub fn from_normal(k_n: f64, eta_n: f64, poisson: f64) -> Self {
        let two_one_plus_nu = 2.0 * (1.0 + poisson);
        ContactConstants {
            k_n,
            k_s: k_n / two_one_plus_nu,
            eta_n,
            eta_s: eta_n / libm::sqrt(two_one_plus_nu),
        }
    }

    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), Error> {
        positive("contact.k_n", self.k_n)?;
        positive("contact.k_s", self.k_s)?;
        crate::error::non_negative("contact.eta_n", self.eta_n)?;
        crate::error::non_negative("contact.eta_s", self.eta_s)
    }

    /// The classical stability bound of docs/model.md (11) on the integration
    /// step: step_dt ≤ 2√(m/k_n).
    pub fn stable_dt_limit(&self, mass: f64) -> f64 {
        2.0 * libm::sqrt(mass / self.k_n)
    }
}

/// The explicit-integration damping number of a contact between two mobile
/// grains of diameter `d` integrated with the step `step_dt`: the largest
/// of η_n step_dt (2/m) (normal) and η_s step_dt (2/m + 2(d/2)²/I)
/// (tangential, through both spins), with m the translational inertia
/// (added mass included) and I = σπd⁵/60.
///
/// Above 2 the dashpot over-corrects within one step and the contact
/// oscillates with growing amplitude until Coulomb sliding caps it: beds
/// jitter instead of coming to rest. With the paper's rule (17) and
/// step_dt = Δt (no substeps) the number is ≈ 2.19 α_cn for d = d_max
/// whatever Δt and β (it depends on α_cn/α_m only); substeps divide it,
/// and it grows as (d_max/d)³ for the finer grains of a mixed bed.
pub fn explicit_damping_number(
    c: &ContactConstants,
    material: &Material,
    d: f64,
    step_dt: f64,
) -> f64 {
    let m = material.translational_mass(d);
    let r = 0.5 * d;
    let normal = c.eta_n * step_dt * 2.0 / m;
    let tangential = c.eta_s * step_dt * (2.0 / m + 2.0 * r * r / material.moment_of_inertia(d));
    if normal > tangential {
        normal
    } else {
        tangential
    }
}

/// The inputs of the paper's parameter choice: α_m, α_cn, β and Δt.
///
/// ```
/// use mbs_kernel::{contact_constants, Material, Scenario};
///
/// let rule = Scenario::paper().rule;
/// let material = Material::default();
/// let c = contact_constants(&rule, 0.5e-3, &material)?;
/// // α_m = 20 steps per spring period: Δt is within the bound (11).
/// assert!(rule.constants_dt < c.stable_dt_limit(material.translational_mass(0.5e-3)));
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimeStepRule {
    /// α_m = T/Δt: steps per spring period (paper: 20).
    pub alpha_m: f64,
    /// α_cn: dashpot factor (paper: 1.0 for packing, 1.3 calibrated).
    pub alpha_cn: f64,
    /// β of (18): α_m' = βα_m, α_cn' = βα_cn (paper: 15.8).
    pub beta: f64,
    /// The constants' time step Δt (s) from which (10)–(13) derive k_n and
    /// η_n; the integration step is Δt/substeps ([`crate::SimConfig::step_dt`]).
    pub constants_dt: f64,
}

/// Derives (k_n, k_s, η_n, η_s) from the time step for a grain of diameter `d`
/// (the largest grain for mixed sizes), docs/model.md (10), (12), (13), (17), (18),
/// the tangential ones by [`ContactConstants::from_normal`]:
///
/// m = ρ(s + C_M)A3 d³,  α_m' = βα_m,  α_cn' = βα_cn,
/// k_n = 2π² m/(α_m' Δt)²,  k_s = k_n/(2(1+ν)),
/// η_n = (α_cn'/α_m')·2√2·π·m/Δt,  η_s = η_n/√(2(1+ν)).
///
/// ```
/// use mbs_kernel::{contact_constants, Material, TimeStepRule};
///
/// // The paper's worked example (docs/model.md §5): Δt = 2.0e-4 s, d = 0.5 mm.
/// let rule = TimeStepRule { alpha_m: 20.0, alpha_cn: 1.0, beta: 1.0, constants_dt: 2.0e-4 };
/// let c = contact_constants(&rule, 0.5e-3, &Material::default())?;
/// assert!((c.k_n - 0.2543).abs() < 2e-4); // N/m; the paper prints 2.54e2 in g/s²
/// assert!((c.eta_n - 4.580e-4).abs() < 1e-6); // N·s/m
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
pub fn contact_constants(
    rule: &TimeStepRule,
    d: f64,
    material: &Material,
) -> Result<ContactConstants, Error> {
    positive("contact.alpha_m", rule.alpha_m)?;
    crate::error::non_negative("contact.alpha_cn", rule.alpha_cn)?;
    positive("contact.beta", rule.beta)?;
    positive("time.constants_dt", rule.constants_dt)?;
    positive("grain.diameter", d)?;
    material.validate()?;
    let m = material.translational_mass(d);
    let alpha_m = rule.beta * rule.alpha_m;
    let alpha_cn = rule.beta * rule.alpha_cn;
    let k_n = 2.0 * PI * PI * m / ((alpha_m * rule.constants_dt) * (alpha_m * rule.constants_dt));
    let eta_n = (alpha_cn / alpha_m) * 2.0 * core::f64::consts::SQRT_2 * PI * m / rule.constants_dt;
    let out = ContactConstants::from_normal(k_n, eta_n, material.nu);
    out.validate()?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, rel: f64) -> bool {
        ((a - b) / b).abs() < rel
    }

    /// docs/model.md §5 worked example: Δt = 2.0e-4 s, d = 0.5 mm, α_m = 20, α_cn = 1.
    #[test]
    fn paper_worked_example_in_si() {
        let rule = TimeStepRule {
            alpha_m: 20.0,
            alpha_cn: 1.0,
            beta: 1.0,
            constants_dt: 2.0e-4,
        };
        let c = contact_constants(&rule, 0.5e-3, &Material::default()).unwrap();
        assert!(close(c.k_n, 0.2543, 5e-4), "k_n = {}", c.k_n);
        assert!(close(c.k_s, 0.09783, 5e-4), "k_s = {}", c.k_s);
        assert!(close(c.eta_n, 4.580e-4, 5e-4), "eta_n = {}", c.eta_n);
        assert!(close(c.eta_s, 2.840e-4, 5e-4), "eta_s = {}", c.eta_s);
        // The paper's printed numbers are these ×1000 (gram-based units).
        assert!(close(c.k_n * 1000.0, 2.54e2, 2e-3));
    }

    /// (13) and (17) are the same dashpot; (18) softens springs by β² at fixed η_n.
    #[test]
    fn dashpot_forms_agree_and_beta_scales_springs() {
        let mat = Material::default();
        let d = 0.5e-3;
        let base = TimeStepRule {
            alpha_m: 20.0,
            alpha_cn: 1.3,
            beta: 1.0,
            constants_dt: 2.0e-5,
        };
        let c1 = contact_constants(&base, d, &mat).unwrap();
        let m = mat.translational_mass(d);
        assert!(close(c1.eta_n, 1.3 * 2.0 * (m * c1.k_n).sqrt(), 1e-12));
        let c2 = contact_constants(&TimeStepRule { beta: 15.8, ..base }, d, &mat).unwrap();
        assert!(close(c1.k_n / c2.k_n, 15.8 * 15.8, 1e-12));
        assert!(close(c1.eta_n, c2.eta_n, 1e-12));
        // α_m = 20 is inside the stability bound (11).
        assert!(base.constants_dt < c1.stable_dt_limit(m));
    }

    #[test]
    fn paper_rule_damping_number_depends_on_alpha_ratio_only() {
        let mat = Material::default();
        for (beta, dt) in [(1.0, 2e-5), (15.8, 2e-5), (1.0, 9e-6)] {
            let rule = TimeStepRule {
                alpha_m: 20.0,
                alpha_cn: 1.0,
                beta,
                constants_dt: dt,
            };
            let c = contact_constants(&rule, 0.5e-3, &mat).unwrap();
            let n = explicit_damping_number(&c, &mat, 0.5e-3, dt);
            assert!((n - 2.19).abs() < 0.01, "beta {beta}, dt {dt}: {n}");
            // Half the step, half the number; finer grains, larger numbers.
            assert!((explicit_damping_number(&c, &mat, 0.5e-3, dt / 2.0) - n / 2.0).abs() < 1e-12);
            assert!(explicit_damping_number(&c, &mat, 0.25e-3, dt) > 7.9 * n);
        }
    }

    #[test]
    fn bad_inputs_are_named() {
        let rule = TimeStepRule {
            alpha_m: 20.0,
            alpha_cn: 1.0,
            beta: 1.0,
            constants_dt: -1.0,
        };
        match contact_constants(&rule, 0.5e-3, &Material::default()) {
            Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, "time.constants_dt"),
            other => panic!("{other:?}"),
        }
        let rule = TimeStepRule {
            constants_dt: 1e-5,
            ..rule
        };
        assert!(contact_constants(&rule, f64::NAN, &Material::default()).is_err());
    }
}
