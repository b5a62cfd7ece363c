//! Kernel specifications of the grains, the bed, the material and the
//! contact: `[grains]`, `[bed]`, `[contact]` and `time.constants_dt` into
//! the kernel's [`BedSpec`], [`Material`], [`TimeStepRule`] and explicit
//! [`ContactConstants`], each checked as it is built; the number of
//! substeps (`"auto"`) and the stability bound on the integration step.
//! The flow's are in `flow.rs`.

use super::errors::need;
use super::file::{ClassEntry, ConfigFile, ContactSection, FractionBasis, Substeps};
use super::limits::{MIN_CONSTANTS_DT, MIN_DIAMETER_MM, SUBSTEP_DAMPING_NUMBER};
use crate::error::ConfigError;
use mbs_kernel::{
    contact_constants, explicit_damping_number, BedSpec, ContactConstants, Material, Scenario,
    SizeClass, TimeStepRule, MAX_CLASSES,
};

/// The fraction of the lattice sites (by number) of each class that gives
/// the volume fractions `volume` to grains of `diameters` (spheres, volume
/// ∝ d³): n_k ∝ f_k / d_k³ (docs/model.md §7).
///
/// ```
/// use mbs::config::number_fractions;
///
/// // 0.7 and 0.5 mm, half and half by volume: 0.267 and 0.733 by number.
/// let n = number_fractions(&[0.7, 0.5], &[0.5, 0.5]);
/// assert!((n[0] - 0.125 / 0.468).abs() < 1e-12 && (n[1] - 0.343 / 0.468).abs() < 1e-12);
/// ```
pub fn number_fractions(diameters: &[f64], volume: &[f64]) -> Vec<f64> {
    let weights: Vec<f64> = diameters
        .iter()
        .zip(volume)
        .map(|(d, f)| f / (d * d * d))
        .collect();
    let total: f64 = weights.iter().sum();
    weights.iter().map(|w| w / total).collect()
}

/// The volume fractions of classes of `diameters` present in the fractions
/// `number` by number: f_k ∝ n_k d_k³ (the inverse of [`number_fractions`]).
///
/// ```
/// use mbs::config::volume_fractions;
///
/// // The issue's case: 0.7/0.5 mm at 0.5/0.5 by number is 0.733/0.267 by volume.
/// let f = volume_fractions(&[0.7, 0.5], &[0.5, 0.5]);
/// assert!((f[0] - 0.343 / 0.468).abs() < 1e-12 && (f[1] - 0.125 / 0.468).abs() < 1e-12);
/// ```
pub fn volume_fractions(diameters: &[f64], number: &[f64]) -> Vec<f64> {
    let weights: Vec<f64> = diameters
        .iter()
        .zip(number)
        .map(|(d, n)| n * d * d * d)
        .collect();
    let total: f64 = weights.iter().sum();
    weights.iter().map(|w| w / total).collect()
}

impl Substeps {
    /// The count: as given, or for `"auto"` the fewest (at most 10 000)
    /// with the explicit damping number of every class of `bed` with the
    /// constants `contact` at or below [`SUBSTEP_DAMPING_NUMBER`] (it falls
    /// as 1/substeps).
    ///
    /// ```
    /// let c = mbs::Config::from_toml("[time]\nsubsteps = \"auto\"")?;
    /// assert_eq!(c.scenario.substeps, 8); // the default constants: 0.356
    /// let c = mbs::Config::from_toml("[time]\nsubsteps = \"auto\"\n[contact]\nalpha_cn = 0.65")?;
    /// assert_eq!(c.scenario.substeps, 4);
    /// # Ok::<(), mbs::ConfigError>(())
    /// ```
    pub fn resolve(
        self,
        contact: &ContactConstants,
        material: &Material,
        bed: &BedSpec,
        constants_dt: f64,
    ) -> u32 {
        match self {
            Substeps::Count(n) => n,
            Substeps::Auto => {
                let n1 = bed
                    .classes
                    .iter()
                    .map(|c| explicit_damping_number(contact, material, c.diameter, constants_dt))
                    .fold(0.0, f64::max);
                (n1 / SUBSTEP_DAMPING_NUMBER).ceil().clamp(1.0, 10_000.0) as u32
            }
        }
    }
}

/// `[grains]` and `[bed]` into the kernel's bed specification.
pub(super) fn bed_spec(file: &ConfigFile) -> Result<BedSpec, ConfigError> {
    let g = &file.grains;
    let entries = match (&g.diameter_mm, &g.classes) {
        (Some(_), Some(_)) => {
            return Err(ConfigError::Invalid {
                key: "grains.classes".into(),
                value: "(given with grains.diameter_mm)".into(),
                allowed: "given alone: use either diameter_mm or classes".into(),
            })
        }
        (Some(d), None) => vec![ClassEntry {
            diameter_mm: *d,
            fraction: 1.0,
        }],
        (None, Some(c)) => c.clone(),
        (None, None) => vec![ClassEntry {
            diameter_mm: Scenario::paper().bed.max_diameter() * 1e3,
            fraction: 1.0,
        }],
    };
    need(
        (1..=MAX_CLASSES).contains(&entries.len()),
        "grains.classes",
        format!("{} classes", entries.len()),
        &format!("1 to {MAX_CLASSES} classes"),
    )?;
    let single = g.classes.is_none();
    for (k, c) in entries.iter().enumerate() {
        let key = |field: &str| {
            if single {
                format!("grains.{field}")
            } else {
                format!("grains.classes[{k}].{field}")
            }
        };
        need(
            c.diameter_mm.is_finite() && c.diameter_mm > 0.0 && c.diameter_mm <= 100.0,
            &key("diameter_mm"),
            c.diameter_mm,
            "> 0 and <= 100",
        )?;
        need(
            c.diameter_mm >= MIN_DIAMETER_MM,
            &key("diameter_mm"),
            c.diameter_mm,
            &format!(
                ">= {MIN_DIAMETER_MM} mm (1 µm: smaller grains' inertias rho s pi d^5/60 \
                 leave the range of floating-point numbers)"
            ),
        )?;
        need(
            c.fraction.is_finite() && c.fraction > 0.0 && c.fraction <= 1.0,
            &key("fraction"),
            c.fraction,
            "in (0, 1]",
        )?;
    }
    let given: f64 = entries.iter().map(|c| c.fraction).sum();
    need(
        (given - 1.0).abs() < 1e-9,
        "grains.classes (sum of fractions)",
        given,
        "= 1",
    )?;
    // The kernel draws each lattice site's class by number.
    let diameters: Vec<f64> = entries.iter().map(|c| c.diameter_mm).collect();
    let fractions: Vec<f64> = entries.iter().map(|c| c.fraction).collect();
    let by_number = match g.fractions {
        FractionBasis::Volume => number_fractions(&diameters, &fractions),
        FractionBasis::Number => fractions,
    };
    let mut classes = heapless::Vec::<SizeClass, MAX_CLASSES>::new();
    for (d, n) in diameters.iter().zip(by_number) {
        // Capacity checked above; a failed push cannot happen.
        let _ = classes.push(SizeClass {
            diameter: d * 1e-3,
            fraction: n,
        });
    }
    let b = &file.bed;
    need(
        (3..=100_000).contains(&b.columns),
        "bed.columns",
        b.columns,
        "in [3, 100000]",
    )?;
    need(
        (1..=10_000).contains(&b.rows),
        "bed.rows",
        b.rows,
        "in [1, 10000]",
    )?;
    let bed = BedSpec {
        columns: b.columns,
        rows: b.rows,
        spacing: b.spacing,
        vacancy: b.vacancy,
        fixed_spread: b.fixed_spread,
        classes,
    };
    // Spacing, vacancy, spread and the sum of the fractions.
    bed.validate().map_err(ConfigError::kernel)?;
    Ok(bed)
}

/// Grain and fluid material.
pub(super) fn material(file: &ConfigFile) -> Result<Material, ConfigError> {
    let s = file.grains.specific_gravity;
    need(
        s.is_finite() && s > 1.0 && s <= 20.0,
        "grains.specific_gravity",
        s,
        "in (1, 20]",
    )?;
    let (f, c) = (&file.flow, &file.contact);
    for (key, value, max, why) in [
        (
            "contact.friction",
            c.friction,
            10.0,
            "Coulomb's coefficient mu of (9): sand 0.5-0.7, glass 0.1-0.4; beyond 10 a \
             contact never slides",
        ),
        (
            "flow.drag_coefficient",
            f.drag_coefficient,
            100.0,
            "C_D of a sphere: 0.4 at the grain Reynolds numbers of bed load; 100 is its \
             value at Re = 0.25, a creeping flow the quadratic drag (6) does not describe",
        ),
        (
            "flow.added_mass",
            f.added_mass,
            10.0,
            "C_M of a sphere: 0.5; near a wall at most about 1",
        ),
    ] {
        need(
            value.is_finite() && (0.0..=max).contains(&value),
            key,
            value,
            &format!("in [0, {max}] ({why})"),
        )?;
    }
    let material = Material {
        rho: f.fluid_density,
        s,
        c_m: f.added_mass,
        c_d: f.drag_coefficient,
        mu: c.friction,
        nu: c.poisson,
    };
    material.validate().map_err(ConfigError::kernel)?;
    let rho = material.rho;
    need(
        (1e-3..=1e5).contains(&rho),
        "flow.fluid_density",
        rho,
        "in [0.001, 100000] kg/m^3 (from a thin gas to beyond any liquid; outside, the \
         grains' masses rho (s + C_M) pi d^3/6 and inertias rho s pi d^5/60 leave the \
         range of floating-point numbers)",
    )?;
    Ok(material)
}

/// α_m, α_cn, β and constants_dt, checked by deriving the contact constants of the
/// largest grain `d` from them (also where `contact.k_n` gives the constants).
pub(super) fn time_rule(
    file: &ConfigFile,
    d: f64,
    material: &Material,
) -> Result<TimeStepRule, ConfigError> {
    let c = &file.contact;
    need(
        file.time.constants_dt.is_finite()
            && file.time.constants_dt >= MIN_CONSTANTS_DT
            && file.time.constants_dt <= 1.0,
        "time.constants_dt",
        file.time.constants_dt,
        &format!(
            "in [{MIN_CONSTANTS_DT:e}, 1] s (below, every second of physical time takes more \
             than 1e8 integration steps)"
        ),
    )?;
    for (key, value, least) in [
        ("contact.alpha_m", c.alpha_m, 0.01),
        ("contact.beta", c.beta, 0.01),
        ("contact.alpha_cn", c.alpha_cn, 0.0),
    ] {
        need(
            value.is_finite() && value >= least && value <= 1e4,
            key,
            value,
            &format!(
                "in [{least}, 10000] (docs/model.md (10), (17), (18): a contact's period is \
                 alpha_m beta steps of constants_dt, the paper's 20 x 15.8; outside, k_n or \
                 eta_n leave the range of floating-point numbers before any grain moves)"
            ),
        )?;
    }
    let rule = TimeStepRule {
        alpha_m: c.alpha_m,
        alpha_cn: c.alpha_cn,
        beta: c.beta,
        constants_dt: file.time.constants_dt,
    };
    contact_constants(&rule, d, material).map_err(ConfigError::kernel)?;
    Ok(rule)
}

/// Explicit k_n and η_n, with k_s and η_s from (12), (13) by the kernel's
/// [`ContactConstants::from_normal`] (the kernel checks them in
/// [`Scenario::contact`]).
pub(super) fn explicit_contact(
    c: &ContactSection,
    nu: f64,
) -> Result<Option<ContactConstants>, ConfigError> {
    match (c.k_n, c.eta_n) {
        (None, None) => Ok(None),
        (Some(k_n), Some(eta_n)) => Ok(Some(ContactConstants::from_normal(k_n, eta_n, nu))),
        (Some(k), None) => need(false, "contact.k_n", k, "given with contact.eta_n").map(|()| None),
        (None, Some(e)) => need(false, "contact.eta_n", e, "given with contact.k_n").map(|()| None),
    }
}

/// The neighbour search's bins: at least three across the periodic width,
/// each the largest diameter plus the skin wide (else every step fails).
/// `bed.columns` is named, with the fewest that give that width (a hair
/// more than the bound, so that rounding in f32 keeps three bins).
pub(super) fn wide_enough(sc: &Scenario) -> Result<(), ConfigError> {
    let bed = &sc.bed;
    let d = bed.max_diameter();
    let needed = 3.0 * (d + sc.skin * d) * (1.0 + 1e-6);
    let fewest = (needed / bed.pitch()).ceil();
    need(
        bed.width() >= needed,
        "bed.columns",
        bed.columns,
        &format!(
            ">= {fewest} for bed.spacing = {} and run.skin_d = {} (the neighbour search needs \
             a periodic width of 3 (largest diameter + skin))",
            bed.spacing, sc.skin
        ),
    )
}

/// The classical stability bound docs/model.md (11) on the integration step
/// for the lightest grain: step_dt = constants_dt/substeps ≤ 2√(m/k_n).
pub(super) fn stability(sc: &Scenario, c: &ContactConstants) -> Result<(), ConfigError> {
    let d_min = sc
        .bed
        .classes
        .iter()
        .map(|k| k.diameter)
        .fold(f64::INFINITY, f64::min);
    let limit = c.stable_dt_limit(sc.material.translational_mass(d_min));
    need(
        sc.step_dt() <= limit,
        "step_dt",
        format!("{:e} s", sc.step_dt()),
        &format!(
            "<= {limit:.4e} s, the stability bound 2 sqrt(m/k_n) of the lightest grain \
             (docs/model.md (11)), with step_dt = constants_dt/substeps = {} s/{}; \
             raise time.substeps",
            sc.rule.constants_dt, sc.substeps
        ),
    )
}

#[cfg(test)]
mod tests {
    use crate::config::Config;

    #[test]
    fn mixed_fractions_are_by_volume_unless_said_otherwise() {
        let mixed = "[grains]\nclasses = [{ diameter_mm = 0.7, fraction = 0.5 }, { diameter_mm = 0.5, fraction = 0.5 }]\n";
        let sites = |text: &str| -> Vec<f64> {
            let c = Config::from_toml(text).unwrap();
            c.scenario.bed.classes.iter().map(|k| k.fraction).collect()
        };
        // Half and half by volume: n_k ∝ f_k/d_k³, 0.125/0.468 and 0.343/0.468 by number.
        let by_volume = sites(mixed);
        assert!(
            (by_volume[0] - 0.125 / 0.468).abs() < 1e-12,
            "{by_volume:?}"
        );
        assert!(
            (by_volume[1] - 0.343 / 0.468).abs() < 1e-12,
            "{by_volume:?}"
        );
        assert_eq!(
            sites(&format!("{mixed}fractions = \"volume\"\n")),
            by_volume
        );
        assert_eq!(
            sites(&format!("{mixed}fractions = \"number\"\n")),
            [0.5, 0.5]
        );
        // A single size is one class of fraction 1 either way: the same bits.
        assert_eq!(sites(""), [1.0]);
        assert!(Config::from_toml("[grains]\nfractions = \"mass\"\n").is_err());
    }
}
