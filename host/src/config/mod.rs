//! The TOML configuration: parsed with serde (`deny_unknown_fields`), every
//! missing key taken from the paper's case, then validated into typed
//! parameters. Every invalid value is reported as `key = value: must be …`.

pub use crate::error::ConfigError;
use crate::io::input::{read_text_bounded, Bound};
use crate::io::text::{excerpt, shown, QUOTE};
use crate::science::measured::MeasuredProfile;
use mbs_kernel::{
    contact_constants, explicit_damping_number, BedSpec, ContactConstants, FlowConfig, FlowModel,
    FlowSpec, FluidSpec, Material, Scenario, SizeClass, Tension, TimeStepRule, G, MAX_CLASSES,
};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::{Path, PathBuf};

/// The embedded default configuration (the paper's case), commented.
pub const DEFAULT_TOML: &str = include_str!("../../default.toml");

/// The longest configuration file read: its longest lists (1000 τ*, 1000
/// seeds, the size classes) take well under 100 kB, even with comments.
pub const CONFIG_BOUND: Bound = Bound {
    bytes: 1 << 20,
    reason: "the largest configuration mbs reads (its longest lists, 1000 tau* and 1000 seeds, \
             take under 100 kB)",
};

/// Grain capacities the host is compiled for (the kernel's `N`).
pub const CAPACITIES: [usize; 3] = [256, 4096, 65536];

impl ConfigError {
    /// A kernel error under the configuration key of the parameter it names.
    fn kernel(source: mbs_kernel::Error) -> ConfigError {
        let key = match source {
            mbs_kernel::Error::InvalidParameter { name, .. } => config_key(name),
            _ => "configuration",
        };
        ConfigError::Kernel { key, source }
    }
}

/// The configuration key of a kernel parameter: the kernel names most
/// parameters by their key already, the material's are spread over sections.
fn config_key(name: &'static str) -> &'static str {
    match name {
        "material.rho" => "flow.fluid_density",
        "material.c_d" => "flow.drag_coefficient",
        "material.c_m" => "flow.added_mass",
        "material.s" => "grains.specific_gravity",
        "material.mu" => "contact.friction",
        "material.nu" => "contact.poisson",
        "grains.fraction (sum)" => "grains.classes (sum of fractions)",
        "slope" => "bed.slope_rad",
        "fluid.viscosity" => "fluid.viscosity_m2_s",
        "fluid.cells" => "fluid.cell_d",
        "fluid.density" => "flow.fluid_density",
        "fluid.kappa" => "flow.kappa",
        "fluid.driving" => "flow.tau_star",
        other => other,
    }
}

/// Keys of earlier versions of mbs and what they are now.
const RENAMED: [(&str, &str); 1] = [(
    "time.dt",
    "time.constants_dt (the constants' time step; the integration step is \
     step_dt = constants_dt/substeps)",
)];

/// toml's message, long lines quoted as excerpts; for a key that was
/// renamed, also its new name.
fn parse_message(text: &str, e: &toml::de::Error) -> String {
    let message = excerpt(e.to_string().trim_end(), QUOTE);
    let Some(span) = e
        .span()
        .filter(|_| e.message().starts_with("unknown field"))
    else {
        return message;
    };
    let before = text.get(..span.start).unwrap_or("");
    let section = before
        .lines()
        .rev()
        .find_map(|line| line.trim().strip_prefix('[')?.split(']').next())
        .unwrap_or("");
    let key = format!("{section}.{}", text.get(span).unwrap_or("").trim());
    match RENAMED.iter().find(|(old, _)| *old == key) {
        Some((old, new)) => format!("{message}\n{old} is now {new}"),
        None => message,
    }
}

/// Fails with [`ConfigError::Invalid`] unless `ok`.
fn need(ok: bool, key: &str, value: impl fmt::Display, allowed: &str) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError::Invalid {
            key: key.to_string(),
            value: shown(value.to_string()),
            allowed: allowed.to_string(),
        })
    }
}

/// Working precision of the kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Single precision (the board's native float).
    F32,
    /// Double precision.
    F64,
}

/// One size class of a mixed bed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClassEntry {
    /// Diameter (mm).
    pub diameter_mm: f64,
    /// Fraction of the bed: by volume (a sieve fraction) or by number of
    /// grains, as [`GrainsSection::fractions`] says.
    pub fraction: f64,
}

/// What the classes' fractions measure (`grains.fractions`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FractionBasis {
    /// Volume (mass) fractions, as a sieve analysis gives them.
    Volume,
    /// Fractions of the number of grains (of the lattice sites).
    Number,
}

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

/// `[grains]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GrainsSection {
    /// Diameter of a single-size bed (mm); exclusive with `classes`.
    pub diameter_mm: Option<f64>,
    /// Size classes of a mixed bed.
    pub classes: Option<Vec<ClassEntry>>,
    /// What the classes' fractions measure: `volume` (default) or `number`.
    pub fractions: FractionBasis,
    /// Specific gravity s.
    pub specific_gravity: f64,
}

/// `[bed]` (docs/model.md §7).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BedSection {
    /// nld.
    pub columns: u32,
    /// nvd.
    pub rows: u32,
    /// Lattice spacing (diameters).
    pub spacing: f64,
    /// Vacancy probability.
    pub vacancy: f64,
    /// Fixed-grain height spread (diameters).
    pub fixed_spread: f64,
    /// Bed slope θ (rad), the kernel's `SimConfig::slope`; 0 (the paper's
    /// horizontal bed) is not written out, so that the keys of cells stay
    /// as they were.
    #[serde(skip_serializing_if = "is_zero")]
    pub slope_rad: f64,
}

/// Whether a value is 0 (a key left out of the echo when it is).
fn is_zero(value: &f64) -> bool {
    *value == 0.0
}

/// `contact.tension`: what part of the normal force may pull a separating
/// pair (docs/model.md (8), (8')), the kernel's [`Tension`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TensionRule {
    /// The paper's rule (8): the spring never pulls, the dashpot may.
    #[default]
    Dashpot,
    /// No tension (8'): f_n = max(0, e_n + d_n).
    None,
}

impl TensionRule {
    /// The kernel's rule.
    pub fn kernel(self) -> Tension {
        match self {
            TensionRule::Dashpot => Tension::Dashpot,
            TensionRule::None => Tension::None,
        }
    }

    /// The paper's rule: not written out, so that the keys of cells (and
    /// the echoed configuration) of the paper's law stay as they were.
    fn is_paper(&self) -> bool {
        *self == TensionRule::Dashpot
    }
}

/// `flow.model`: what drives the grains' drag, the kernel's [`FlowModel`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FlowModelKey {
    /// The paper's prescribed log law (docs/model.md §6).
    #[default]
    ClearWater,
    /// The coupled flow (docs/model.md §13), its column in `[fluid]`.
    Coupled,
}

impl FlowModelKey {
    /// The kernel's model.
    pub fn kernel(self) -> FlowModel {
        match self {
            FlowModelKey::ClearWater => FlowModel::ClearWater,
            FlowModelKey::Coupled => FlowModel::Coupled,
        }
    }

    /// The paper's clear water: not written out, so that the keys of cells
    /// stay as they were.
    fn is_paper(&self) -> bool {
        *self == FlowModelKey::ClearWater
    }
}

/// `time.settle_until`: when the initial bed's settling ends
/// (docs/model.md §7 step 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SettleUntil {
    /// At rest ([`mbs_kernel::Rest::for_bed`]), after at most `time.settle`.
    #[default]
    Rest,
    /// After exactly `time.settle`.
    Time,
}

/// `[contact]` (docs/model.md §4–§5).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ContactSection {
    /// α_m.
    pub alpha_m: f64,
    /// α_cn.
    pub alpha_cn: f64,
    /// β.
    pub beta: f64,
    /// μ.
    pub friction: f64,
    /// ν.
    pub poisson: f64,
    /// Explicit k_n (N/m), with `eta_n`.
    pub k_n: Option<f64>,
    /// Explicit η_n (N s/m), with `k_n`.
    pub eta_n: Option<f64>,
    /// What part of the normal force may pull.
    #[serde(skip_serializing_if = "TensionRule::is_paper")]
    pub tension: TensionRule,
}

/// `[time]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TimeSection {
    /// The constants' time step Δt (s), from which the contact constants
    /// derive (docs/model.md (10)–(13)).
    pub constants_dt: f64,
    /// Integration steps per constants_dt: step_dt = constants_dt/substeps.
    pub substeps: Substeps,
    /// When settling ends: at rest or after `settle`.
    pub settle_until: SettleUntil,
    /// Settling time (s): the most (`settle_until = "rest"`) or exactly.
    pub settle: f64,
    /// Spin-up time (s).
    pub spin_up: f64,
    /// The longest averaging window (s): the cap when the target is not reached.
    pub window: f64,
    /// The shortest averaging window (s).
    pub window_min: f64,
    /// Block of the window (s): q* is averaged per block (the time series,
    /// the batch-means standard error, the stopping rule).
    pub block: f64,
    /// Sampling interval of q* (integration steps).
    pub sample_steps: u32,
}

/// `[target]`: the standard error of q* each cell's window aims at (it runs
/// until it is reached, from `time.window_min` to `time.window`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TargetSection {
    /// Relative standard error of q*.
    pub stderr_relative: f64,
    /// Absolute standard error of q* (the floor near the threshold).
    pub stderr_absolute: f64,
}

impl Default for TargetSection {
    fn default() -> Self {
        TargetSection {
            stderr_relative: 0.1,
            stderr_absolute: 5e-4,
        }
    }
}

/// `time.substeps`: a count, or `"auto"`: the fewest that keep the
/// explicit damping number of every size class at or below
/// [`SUBSTEP_DAMPING_NUMBER`] ([`Substeps::resolve`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Substeps {
    /// This many integration steps per constants_dt.
    Count(u32),
    /// From the constants in use.
    Auto,
}

impl Serialize for Substeps {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Substeps::Count(n) => s.serialize_u32(*n),
            Substeps::Auto => s.serialize_str("auto"),
        }
    }
}

impl<'de> Deserialize<'de> for Substeps {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl serde::de::Visitor<'_> for Visitor {
            type Value = Substeps;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an integer in [1, 10000] or \"auto\"")
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Substeps, E> {
                u32::try_from(v)
                    .map(Substeps::Count)
                    .map_err(|_| E::invalid_value(serde::de::Unexpected::Signed(v), &self))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Substeps, E> {
                u32::try_from(v)
                    .map(Substeps::Count)
                    .map_err(|_| E::invalid_value(serde::de::Unexpected::Unsigned(v), &self))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Substeps, E> {
                if v == "auto" {
                    Ok(Substeps::Auto)
                } else {
                    Err(E::invalid_value(serde::de::Unexpected::Str(v), &self))
                }
            }
        }
        d.deserialize_any(Visitor)
    }
}

/// The explicit damping number `time.substeps = "auto"` stays at or below:
/// the default constants (α_cn = 1.3) reach 0.356 at 8 substeps, where q*
/// agrees with 16 (docs/findings/explicit-damping-limit.md).
pub const SUBSTEP_DAMPING_NUMBER: f64 = 0.36;

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

/// `[flow]` (docs/model.md §6).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FlowSection {
    /// Shields numbers.
    pub tau_star: Vec<f64>,
    /// Shear velocities u* (m/s), instead of `tau_star` ([`flow_forms`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u_star_m_s: Option<Vec<f64>>,
    /// Slopes S of a uniform flow of depth h, instead of `tau_star`
    /// ([`flow_forms`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slope: Option<Vec<f64>>,
    /// κ.
    pub kappa: f64,
    /// h (m).
    pub depth: f64,
    /// ε0.
    pub eps0: f64,
    /// k_s / d.
    pub roughness_d: f64,
    /// Monte Carlo turbulence on.
    pub turbulence: bool,
    /// Hold of a fluctuation (steps of constants_dt).
    pub hold_steps: u32,
    /// Bed-level interval (steps of constants_dt).
    pub bed_level_interval: u32,
    /// Width of the bed-level windows, in largest diameters.
    pub bed_level_window: f64,
    /// ρ (kg/m³).
    pub fluid_density: f64,
    /// C_D.
    pub drag_coefficient: f64,
    /// C_M.
    pub added_mass: f64,
    /// Clear water (the paper) or the coupled flow.
    #[serde(skip_serializing_if = "FlowModelKey::is_paper")]
    pub model: FlowModelKey,
}

/// `[fluid]`: the coupled flow's column (docs/model.md §13), read with
/// `flow.model = "coupled"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FluidSection {
    /// Largest cell height (largest diameters).
    pub cell_d: f64,
    /// Kinematic viscosity ν (m²/s).
    pub viscosity_m2_s: f64,
    /// φ_max of the mixing length (C3).
    pub phi_max: f64,
    /// Steps of constants_dt between two updates of the column.
    pub update_steps: u32,
    /// Exponent n of the hindrance (C7).
    pub hindrance: f64,
}

/// `[run]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunSection {
    /// Seeds.
    pub seeds: Vec<u64>,
    /// Precision.
    pub precision: Precision,
    /// Output directory.
    pub output: PathBuf,
    /// Grain capacity.
    pub capacity: usize,
    /// Largest neighbour skin (diameters; each rebuild adapts it, down to 0.3 of it).
    pub skin_d: f64,
    /// A measured profile drawn over `profiles.png` ([`MeasuredProfile`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured_profiles: Option<PathBuf>,
    /// Its heights are drawn at z/d minus this (largest diameters).
    #[serde(skip_serializing_if = "is_zero")]
    pub measured_shift_d: f64,
}

/// A configuration file as written (every section optional).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ConfigFile {
    /// `[grains]`.
    pub grains: GrainsSection,
    /// `[bed]`.
    pub bed: BedSection,
    /// `[contact]`.
    pub contact: ContactSection,
    /// `[time]`.
    pub time: TimeSection,
    /// `[flow]`.
    pub flow: FlowSection,
    /// `[fluid]`, not written out at its defaults (the keys of cells stay
    /// as they were).
    #[serde(skip_serializing_if = "FluidSection::is_default")]
    pub fluid: FluidSection,
    /// `[target]`.
    pub target: TargetSection,
    /// `[run]`.
    pub run: RunSection,
}

// The defaults are the kernel's `Scenario::paper()`; `default.toml` must
// agree with them (test `embedded_file_is_the_default`).

impl Default for GrainsSection {
    fn default() -> Self {
        let p = Scenario::paper();
        GrainsSection {
            diameter_mm: None,
            classes: None,
            fractions: FractionBasis::Volume,
            specific_gravity: p.material.s,
        }
    }
}

/// Lattice columns of the default bed: the narrowest measured whose q* does
/// not depend on the width at any τ* in [0.06, 0.5]
/// (docs/findings/bed-width.md; the paper's 5 columns move collectively, 10
/// lock near the threshold).
pub const DEFAULT_COLUMNS: u32 = 40;

impl Default for BedSection {
    fn default() -> Self {
        let b = Scenario::paper().bed;
        BedSection {
            columns: DEFAULT_COLUMNS,
            rows: b.rows,
            spacing: b.spacing,
            vacancy: b.vacancy,
            fixed_spread: b.fixed_spread,
            slope_rad: 0.0,
        }
    }
}

impl Default for ContactSection {
    fn default() -> Self {
        let p = Scenario::paper();
        ContactSection {
            alpha_m: p.rule.alpha_m,
            alpha_cn: p.rule.alpha_cn,
            beta: p.rule.beta,
            friction: p.material.mu,
            poisson: p.material.nu,
            k_n: None,
            eta_n: None,
            tension: TensionRule::Dashpot,
        }
    }
}

impl Default for TimeSection {
    fn default() -> Self {
        let p = Scenario::paper();
        TimeSection {
            constants_dt: p.rule.constants_dt,
            substeps: Substeps::Auto,
            settle_until: SettleUntil::Rest,
            settle: 3.0,
            spin_up: 0.2,
            window: 2.0,
            window_min: 1.0,
            block: 0.1,
            sample_steps: 10,
        }
    }
}

impl Default for FlowSection {
    fn default() -> Self {
        let p = Scenario::paper();
        let f = p.flow;
        FlowSection {
            tau_star: vec![0.03, 0.06, 0.1, 0.2, 0.4],
            kappa: f.kappa,
            depth: f.depth,
            eps0: f.eps0,
            roughness_d: f.roughness / p.bed.max_diameter(),
            turbulence: f.turbulence,
            hold_steps: f.hold_steps / p.substeps,
            bed_level_interval: f.bed_level_interval / p.substeps,
            bed_level_window: f.bed_level_window,
            fluid_density: p.material.rho,
            drag_coefficient: p.material.c_d,
            added_mass: p.material.c_m,
            u_star_m_s: None,
            slope: None,
            model: FlowModelKey::ClearWater,
        }
    }
}

/// Cells of the coupled flow's column at most: the fluid capacity `C` of
/// every host simulation ([`crate::sim::sims::HostSim`]), 0.2 m of water over
/// 0.5 mm grains in cells of d/4.
pub const FLUID_CELLS: usize = 2048;

impl Default for FluidSection {
    fn default() -> Self {
        let p = Scenario::paper();
        let f = p.flow.fluid;
        FluidSection {
            cell_d: f.cell_height / p.bed.max_diameter(),
            viscosity_m2_s: f.viscosity,
            phi_max: f.phi_max,
            update_steps: f.update_steps / p.substeps,
            hindrance: f.hindrance,
        }
    }
}

impl FluidSection {
    fn is_default(&self) -> bool {
        *self == FluidSection::default()
    }
}

impl Default for RunSection {
    fn default() -> Self {
        RunSection {
            seeds: vec![1, 2, 3, 4],
            precision: Precision::F64,
            output: PathBuf::from("mbs-out"),
            capacity: 4096,
            skin_d: Scenario::paper().skin,
            measured_profiles: None,
            measured_shift_d: 0.0,
        }
    }
}

/// The run plan: a validated configuration, read by every command. Times
/// are integration steps, the flow is the kernel's [`FlowSpec`] (intervals in
/// integration steps, u* per τ* from [`Config::setup`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// The file with every default filled in: only echoed (`config.toml`,
    /// `summary.json`) and hashed into the keys of cells, never read for
    /// values.
    pub file: ConfigFile,
    /// Material, contact rule, bed, flow without u*, skin; the seed is the
    /// first of `seeds` ([`Config::scenario_at`] gives the others).
    pub scenario: Scenario,
    /// Derived contact constants (SI).
    pub contact: ContactConstants,
    /// Shields numbers, as given.
    pub tau_stars: Vec<f64>,
    /// Seeds, as given.
    pub seeds: Vec<u64>,
    /// Phase lengths of a transport cell.
    pub durations: Durations,
    /// Output directory (`--out` overrides).
    pub output: PathBuf,
    /// Working precision.
    pub precision: Precision,
    /// Grain capacity (one of [`CAPACITIES`]).
    pub capacity: usize,
    /// `run.measured_profiles`, read, its heights shifted.
    pub measured: Option<MeasuredProfile>,
}

/// Phase lengths of a transport cell, in integration steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Durations {
    /// When settling ends.
    pub settle_until: SettleUntil,
    /// Settling without flow: the most or exactly (`settle_until`).
    pub settle: u64,
    /// Spin-up under the flow, before averaging.
    pub spin_up: u64,
    /// Between two samples of q* in the window.
    pub sample: u64,
    /// Samples of q* per block (at least 1).
    pub block_samples: u64,
    /// Blocks of the shortest window (at least 2).
    pub min_blocks: u64,
    /// Blocks of the longest window (at least `min_blocks`).
    pub max_blocks: u64,
}

impl Durations {
    /// A block: `block_samples` × `sample`.
    pub fn block(&self) -> u64 {
        self.block_samples * self.sample
    }

    /// The longest averaging window: `max_blocks` blocks.
    pub fn window(&self) -> u64 {
        self.max_blocks * self.block()
    }

    /// A cell under the flow: spin-up and window (its bed settles once
    /// per seed, [`crate::work::beds`]).
    pub fn cell(&self) -> u64 {
        self.spin_up + self.window()
    }
}

/// What the kernel runs for one (τ*, seed) cell.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// The scenario with the cell's seed.
    pub scenario: Scenario,
    /// The flow at the cell's τ*.
    pub flow: FlowConfig,
}

/// Applies `--set SECTION.KEY=VALUE` overrides to a configuration's TOML
/// text: each VALUE is TOML (`0.3`, `[0.1, 0.2]`, `"f32"`, `{ … }`) or else
/// taken as a string, and replaces or adds the key. The result is parsed
/// and validated like any file, so an override is checked exactly as the
/// same line in the file would be, and echoed wherever the configuration is.
///
/// ```
/// use mbs::config::apply_overrides;
///
/// let text = apply_overrides("[flow]\ntau_star = [0.1]\n", &["flow.tau_star=[0.2, 0.3]".into(), "run.precision=f32".into()])?;
/// let c = mbs::Config::from_toml(&text)?;
/// assert_eq!(c.tau_stars, [0.2, 0.3]);
/// assert!(apply_overrides("", &["tau_star=0.2".into()]).is_err());
/// # Ok::<(), mbs::ConfigError>(())
/// ```
pub fn apply_overrides(text: &str, sets: &[String]) -> Result<String, ConfigError> {
    if sets.is_empty() {
        return Ok(text.to_string());
    }
    let mut table: toml::Table =
        toml::from_str(text).map_err(|e| ConfigError::Parse(parse_message(text, &e)))?;
    for set in sets {
        let bad = |allowed: String| ConfigError::Invalid {
            key: "--set".into(),
            value: shown(set.clone()),
            allowed,
        };
        let usage = || bad("SECTION.KEY=VALUE, e.g. flow.tau_star=[0.1, 0.2]".into());
        let (path, value) = set.split_once('=').ok_or_else(usage)?;
        let keys: Vec<&str> = path.trim().split('.').map(str::trim).collect();
        let Some((last, sections)) = keys.split_last().filter(|(_, s)| !s.is_empty()) else {
            return Err(usage());
        };
        if keys.iter().any(|k| k.is_empty()) {
            return Err(usage());
        }
        let value = value.trim();
        let value = toml::from_str::<toml::Table>(&format!("v = {value}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(value.to_string()));
        let mut at = &mut table;
        for section in sections {
            at = at
                .entry(section.to_string())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                .as_table_mut()
                .ok_or_else(|| bad(format!("{section} is a key, not a section")))?;
        }
        at.insert(last.to_string(), value);
    }
    toml::to_string(&table).map_err(|e| ConfigError::Parse(e.to_string()))
}

impl Config {
    /// Parses and validates TOML text.
    pub fn from_toml(text: &str) -> Result<Config, ConfigError> {
        let file: ConfigFile =
            toml::from_str(text).map_err(|e| ConfigError::Parse(parse_message(text, &e)))?;
        Config::validate(file)
    }

    /// Reads and validates a file, or the embedded default when `path` is None.
    pub fn load(path: Option<&Path>) -> Result<Config, ConfigError> {
        Config::load_with(path, &[])
    }

    /// [`Config::load`] with `--set` overrides ([`apply_overrides`]).
    pub fn load_with(path: Option<&Path>, sets: &[String]) -> Result<Config, ConfigError> {
        match path {
            None => Config::from_toml(&apply_overrides(DEFAULT_TOML, sets)?),
            Some(p) => {
                let text =
                    read_text_bounded(p, CONFIG_BOUND).map_err(|source| ConfigError::Read {
                        path: p.to_path_buf(),
                        source,
                    })?;
                let in_file = |e| match e {
                    ConfigError::Parse(m) => ConfigError::Parse(format!("{}: {m}", p.display())),
                    other => other,
                };
                Config::from_toml(&apply_overrides(&text, sets).map_err(in_file)?).map_err(in_file)
            }
        }
    }

    /// The golden-digest configuration: the embedded default on the kernel's
    /// `Scenario::paper()` bed (5 columns), which the firmware runs.
    pub fn golden() -> Result<Config, ConfigError> {
        Config::golden_with(&[])
    }

    /// [`Config::golden`] with `--set` overrides on top.
    pub fn golden_with(sets: &[String]) -> Result<Config, ConfigError> {
        let mut file = Config::load(None)?.file;
        file.bed.columns = Scenario::paper().bed.columns;
        if sets.is_empty() {
            return Config::validate(file);
        }
        let text = toml::to_string(&file).map_err(|e| ConfigError::Parse(e.to_string()))?;
        Config::from_toml(&apply_overrides(&text, sets)?)
    }

    /// The scenario of one seed.
    pub fn scenario_at(&self, seed: u64) -> Scenario {
        Scenario {
            seed,
            ..self.scenario.clone()
        }
    }

    /// The scenario and flow of the (τ*, seed) cell: u* from τ*.
    pub fn setup(&self, tau_star: f64, seed: u64) -> Setup {
        Setup {
            flow: self.scenario.flow(tau_star),
            scenario: self.scenario_at(seed),
        }
    }

    /// Integration steps of `seconds` (rounded).
    pub fn steps_of(&self, seconds: f64) -> u64 {
        steps_of(seconds, self.scenario.step_dt())
    }

    /// Checks every value and builds the typed configuration.
    pub fn validate(mut file: ConfigFile) -> Result<Config, ConfigError> {
        let bed = bed_spec(&file)?;
        let d = bed.max_diameter();
        let slope = file.bed.slope_rad;
        need(
            slope.is_finite() && (0.0..0.5).contains(&slope),
            "bed.slope_rad",
            slope,
            "in [0, 0.5) rad (0: the paper's horizontal bed)",
        )?;
        let material = material(&file)?;
        flow_forms(&mut file, material.s, d)?;
        let rule = time_rule(&file, d, &material)?;
        let explicit_contact = explicit_contact(&file.contact, material.nu)?;
        let t = &file.time;
        if let Substeps::Count(n) = t.substeps {
            need(
                (1..=10_000).contains(&n),
                "time.substeps",
                n,
                "in [1, 10000] or \"auto\"",
            )?;
        }
        let mut substeps = match t.substeps {
            Substeps::Count(n) => n,
            Substeps::Auto => 1,
        };
        let mut flow = flow_spec(&file, d, substeps)?;
        // A window holds at least one step; settling and spin-up may be skipped.
        for (key, value, zero_allowed) in [
            ("time.settle", t.settle, true),
            ("time.spin_up", t.spin_up, true),
            ("time.window", t.window, false),
            ("time.window_min", t.window_min, false),
            ("time.block", t.block, false),
        ] {
            let least = if zero_allowed { "[0" } else { "(0" };
            need(
                value <= MAX_PHASE_S && (value > 0.0 || (zero_allowed && value == 0.0)),
                key,
                value,
                &format!("in {least}, {MAX_PHASE_S}] s{PHASE_REASON}"),
            )?;
        }
        need(
            t.sample_steps >= 1,
            "time.sample_steps",
            t.sample_steps,
            ">= 1",
        )?;
        let r = &file.run;
        need(
            !r.seeds.is_empty() && r.seeds.len() <= 1000,
            "run.seeds",
            format!("{:?}", r.seeds),
            "a list of 1 to 1000 seeds",
        )?;
        let mut sorted = r.seeds.clone();
        sorted.sort_unstable();
        sorted.dedup();
        need(
            sorted.len() == r.seeds.len(),
            "run.seeds",
            format!("{:?}", r.seeds),
            "distinct",
        )?;
        need(
            !r.output.as_os_str().is_empty(),
            "run.output",
            "\"\"",
            "a directory path",
        )?;
        need(
            r.skin_d.is_finite() && r.skin_d > 0.0 && r.skin_d <= 1.0,
            "run.skin_d",
            r.skin_d,
            "in (0, 1]",
        )?;
        need(
            r.measured_shift_d.is_finite(),
            "run.measured_shift_d",
            r.measured_shift_d,
            "finite",
        )?;
        let measured =
            match &r.measured_profiles {
                None => None,
                Some(path) => Some(MeasuredProfile::read(path, r.measured_shift_d).map_err(
                    |why| ConfigError::Invalid {
                        key: "run.measured_profiles".into(),
                        value: shown(path.display().to_string()),
                        allowed: format!(
                            "a CSV with columns z_over_d, solid_fraction, particle_velocity_m_s \
                         (and optionally fluid_velocity_m_s), as validation/*/*.csv: {why}"
                        ),
                    },
                )?),
            };
        need(
            CAPACITIES.contains(&r.capacity),
            "run.capacity",
            r.capacity,
            "one of 256, 4096, 65536",
        )?;
        let grains = bed.columns as usize * (bed.fixed_per_column() + bed.rows as usize);
        need(
            grains <= r.capacity,
            "run.capacity",
            r.capacity,
            &format!(">= the bed's {grains} grains (a larger capacity or a smaller bed)"),
        )?;
        // The kernel's bound (`Sim::build_bed`): the highest fixed grain (2σ),
        // the lattice and one d_max.
        let bed_top = (2.0 * bed.fixed_spread + 1.0) * d + f64::from(bed.rows) * bed.pitch();
        need(
            flow.depth > bed_top,
            "flow.depth",
            flow.depth,
            &format!("> the bed's height {bed_top:e} m"),
        )?;
        let mut scenario = Scenario {
            material,
            rule,
            explicit_contact,
            tension: file.contact.tension.kernel(),
            substeps,
            bed,
            flow,
            slope: file.bed.slope_rad,
            skin: r.skin_d,
            seed: r.seeds[0],
        };
        let contact = scenario.contact().map_err(ConfigError::kernel)?;
        if t.substeps == Substeps::Auto {
            // The constants do not depend on the substeps; the flow's intervals do.
            substeps = t.substeps.resolve(
                &contact,
                &scenario.material,
                &scenario.bed,
                scenario.rule.constants_dt,
            );
            flow = flow_spec(&file, d, substeps)?;
            scenario.substeps = substeps;
            scenario.flow = flow;
        }
        stability(&scenario, &contact)?;
        coupled_flow_fits(&scenario, &file.flow.tau_star)?;
        for &tau_star in &file.flow.tau_star {
            scenario
                .flow(tau_star)
                .validate()
                .map_err(ConfigError::kernel)?;
        }
        // The simulation's own checks, as a backstop.
        scenario
            .sim_config()
            .and_then(|c| c.validate())
            .map_err(ConfigError::kernel)?;
        let step_dt = scenario.step_dt();
        let sample = u64::from(t.sample_steps);
        let block = steps_of(t.block, step_dt);
        need(
            sample <= block,
            "time.sample_steps",
            sample,
            &format!(
                "<= a block's {block} integration steps (time.block/step_dt = {} s/{step_dt:e} s): \
                 a longer sampling interval would stretch the block",
                t.block
            ),
        )?;
        need(
            t.window_min <= t.window,
            "time.window_min",
            t.window_min,
            &format!("<= time.window = {} s", t.window),
        )?;
        need(
            2.0 * t.block <= t.window_min * (1.0 + 1e-9),
            "time.block",
            t.block,
            &format!(
                "<= time.window_min/2 = {} s: the standard error of the window needs at least \
                 two blocks",
                t.window_min / 2.0
            ),
        )?;
        let block_samples = block / sample;
        let blocks = |seconds: f64| (seconds / t.block).round().max(2.0) as u64;
        let durations = Durations {
            settle_until: t.settle_until,
            settle: steps_of(t.settle, step_dt),
            spin_up: steps_of(t.spin_up, step_dt),
            sample,
            block_samples,
            min_blocks: blocks(t.window_min),
            max_blocks: blocks(t.window).max(blocks(t.window_min)),
        };
        let target = &file.target;
        for (key, value) in [
            ("target.stderr_relative", target.stderr_relative),
            ("target.stderr_absolute", target.stderr_absolute),
        ] {
            need(
                (0.0..=1.0).contains(&value),
                key,
                value,
                "in [0, 1] (0: the window always runs to time.window)",
            )?;
        }
        // At most 3000 s of steps of at least 1e-12 s: no overflow.
        let cell = durations.settle + durations.cell();
        need(
            cell <= MAX_CELL_STEPS,
            "time.settle + time.spin_up + time.window",
            format!(
                "{} + {} + {} s = {:e} integration steps",
                t.settle, t.spin_up, t.window, cell as f64
            ),
            &format!(
                "<= {MAX_CELL_STEPS:e} integration steps of step_dt = {step_dt:e} s per cell \
                 (at ~{GRAIN_STEPS_PER_S_PER_CORE:e} grain-steps/s per core, even 100 grains \
                 would take {:.0} days per cell): shorten the phases or raise step_dt",
                MAX_CELL_STEPS as f64 * 100.0 / GRAIN_STEPS_PER_S_PER_CORE / 86400.0
            ),
        )?;
        Ok(Config {
            tau_stars: file.flow.tau_star.clone(),
            seeds: r.seeds.clone(),
            durations,
            output: r.output.clone(),
            precision: r.precision,
            capacity: r.capacity,
            measured,
            file,
            scenario,
            contact,
        })
    }
}

/// The longest settling, spin-up or window (s of physical time).
pub const MAX_PHASE_S: f64 = 1000.0;

/// Why [`MAX_PHASE_S`].
const PHASE_REASON: &str = " of physical time: beds settle and q* converges within seconds, \
     a longer phase is a mistake (milliseconds meant?)";

/// The most integration steps of a cell (settling, spin-up and window).
pub const MAX_CELL_STEPS: u64 = 100_000_000_000;

/// The smallest constants' time step constants_dt (s).
pub const MIN_CONSTANTS_DT: f64 = 1e-8;

/// The smallest grain diameter (mm).
pub const MIN_DIAMETER_MM: f64 = 1e-3;

/// A rough speed of the step for wall-time estimates: the main job runs
/// 5–6e7 grain-steps per second on 2 cores (docs/performance.md).
pub const GRAIN_STEPS_PER_S_PER_CORE: f64 = 2.5e7;

/// Integration steps of step_dt in `seconds` (rounded).
fn steps_of(seconds: f64, step_dt: f64) -> u64 {
    (seconds / step_dt).round() as u64
}

/// `[grains]` and `[bed]` into the kernel's bed specification.
fn bed_spec(file: &ConfigFile) -> Result<BedSpec, ConfigError> {
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
fn material(file: &ConfigFile) -> Result<Material, ConfigError> {
    let s = file.grains.specific_gravity;
    need(
        s.is_finite() && s > 1.0 && s <= 20.0,
        "grains.specific_gravity",
        s,
        "in (1, 20]",
    )?;
    let (f, c) = (&file.flow, &file.contact);
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
fn time_rule(file: &ConfigFile, d: f64, material: &Material) -> Result<TimeStepRule, ConfigError> {
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
    let rule = TimeStepRule {
        alpha_m: c.alpha_m,
        alpha_cn: c.alpha_cn,
        beta: c.beta,
        constants_dt: file.time.constants_dt,
    };
    contact_constants(&rule, d, material).map_err(ConfigError::kernel)?;
    Ok(rule)
}

/// Explicit k_n and η_n, with k_s and η_s from (12), (13) (the kernel
/// checks them in [`Scenario::contact`]).
fn explicit_contact(c: &ContactSection, nu: f64) -> Result<Option<ContactConstants>, ConfigError> {
    match (c.k_n, c.eta_n) {
        (None, None) => Ok(None),
        (Some(k_n), Some(eta_n)) => {
            let two_one_plus_nu = 2.0 * (1.0 + nu);
            Ok(Some(ContactConstants {
                k_n,
                k_s: k_n / two_one_plus_nu,
                eta_n,
                eta_s: eta_n / two_one_plus_nu.sqrt(),
            }))
        }
        (Some(k), None) => need(false, "contact.k_n", k, "given with contact.eta_n").map(|()| None),
        (None, Some(e)) => need(false, "contact.eta_n", e, "given with contact.k_n").map(|()| None),
    }
}

/// The flow given as shear velocities or slopes (docs/model.md §6), into
/// `flow.tau_star` on the largest diameter d_max:
/// τ* = u*²/((s − 1) g d_max) from `flow.u_star_m_s`, and from `flow.slope`
/// the uniform flow's bed shear τ = ρ g h S, u*² = g h S, so
/// τ* = h S/((s − 1) d_max). Only the driving shear follows the slope:
/// gravity on the grains stays vertical (small slopes). `tau_star`, if
/// also given, must be those values (the saved configuration holds both).
///
/// ```
/// let c = mbs::Config::from_toml("[flow]\nu_star_m_s = [0.03]\n")?;
/// let tau = 0.03f64 * 0.03 / (1.65 * 9.81 * 0.5e-3);
/// assert!((c.tau_stars[0] - tau).abs() < 1e-15);
/// let c = mbs::Config::from_toml("[flow]\nslope = [0.001]\ndepth = 0.05\n")?;
/// assert!((c.tau_stars[0] - 0.05 * 0.001 / (1.65 * 0.5e-3)).abs() < 1e-15);
/// assert!(mbs::Config::from_toml("[flow]\nslope = [0.001]\nu_star_m_s = [0.03]\n").is_err());
/// # Ok::<(), mbs::ConfigError>(())
/// ```
pub fn flow_forms(file: &mut ConfigFile, s: f64, d: f64) -> Result<(), ConfigError> {
    let f = &file.flow;
    let h = f.depth;
    let (key, given, tau_of): (&str, &Vec<f64>, &dyn Fn(f64) -> f64) =
        match (&f.u_star_m_s, &f.slope) {
            (None, None) => return Ok(()),
            (Some(_), Some(slope)) => return need(
                false,
                "flow.slope",
                format!("{slope:?}"),
                "not given with flow.u_star_m_s: give the flow as one of tau_star, u_star_m_s or \
                 slope",
            ),
            (Some(u), None) => ("flow.u_star_m_s", u, &|u: f64| u * u / ((s - 1.0) * G * d)),
            (None, Some(slope)) => ("flow.slope", slope, &|sl: f64| h * sl / ((s - 1.0) * d)),
        };
    need(
        !given.is_empty() && given.len() <= 1000,
        key,
        format!("{given:?}"),
        "a list of 1 to 1000 values",
    )?;
    let mut taus = Vec::with_capacity(given.len());
    for (k, &v) in given.iter().enumerate() {
        let tau = tau_of(v);
        need(
            v.is_finite() && v > 0.0 && tau > 0.0 && tau <= 5.0,
            &format!("{key}[{k}]"),
            v,
            &format!(
                "> 0 and giving tau* in (0, 5] (here tau* = {tau:e}, on d_max = {d:e} m, s = {s})"
            ),
        )?;
        taus.push(tau);
    }
    need(
        f.tau_star == FlowSection::default().tau_star || f.tau_star == taus,
        "flow.tau_star",
        format!("{:?}", f.tau_star),
        &format!("not given with {key} (or equal to its values {taus:?})"),
    )?;
    file.flow.tau_star = taus;
    Ok(())
}

/// `[flow]` except τ* into the kernel's flow specification, its intervals
/// converted to integration steps (`substeps` per constants_dt); κ, ε0 and the
/// intervals are checked by the kernel with the flow at each τ*.
fn flow_spec(file: &ConfigFile, d: f64, substeps: u32) -> Result<FlowSpec, ConfigError> {
    let f = &file.flow;
    need(
        !f.tau_star.is_empty() && f.tau_star.len() <= 1000,
        "flow.tau_star",
        format!("{:?}", f.tau_star),
        "a list of 1 to 1000 values",
    )?;
    for (k, &t) in f.tau_star.iter().enumerate() {
        need(
            t.is_finite() && t > 0.0 && t <= 5.0,
            &format!("flow.tau_star[{k}]"),
            t,
            "in (0, 5]",
        )?;
    }
    let mut sorted = f.tau_star.clone();
    sorted.sort_by(f64::total_cmp);
    sorted.dedup();
    need(
        sorted.len() == f.tau_star.len(),
        "flow.tau_star",
        format!("{:?}", f.tau_star),
        "distinct values",
    )?;
    need(
        f.depth.is_finite() && f.depth > 0.0 && f.depth <= 100.0,
        "flow.depth",
        f.depth,
        "in (0, 100] m",
    )?;
    need(
        f.roughness_d.is_finite() && f.roughness_d > 0.0 && f.roughness_d <= 100.0,
        "flow.roughness_d",
        f.roughness_d,
        "in (0, 100]",
    )?;
    need(
        f.bed_level_window.is_finite() && (1.0..=1e6).contains(&f.bed_level_window),
        "flow.bed_level_window",
        f.bed_level_window,
        "in [1, 1e6] largest diameters",
    )?;
    Ok(FlowSpec {
        kappa: f.kappa,
        depth: f.depth,
        eps0: f.eps0,
        roughness: f.roughness_d * d,
        reference_diameter: d,
        turbulence: f.turbulence,
        hold_steps: f.hold_steps.saturating_mul(substeps),
        bed_level_interval: f.bed_level_interval.saturating_mul(substeps),
        bed_level_window: f.bed_level_window,
        model: f.model.kernel(),
        fluid: fluid_spec(&file.fluid, d, substeps)?,
    })
}

/// `[fluid]` into the kernel's [`FluidSpec`], its update interval converted
/// to integration steps; checked whatever the model, so that a bad value
/// is an error before it is used.
fn fluid_spec(f: &FluidSection, d: f64, substeps: u32) -> Result<FluidSpec, ConfigError> {
    need(
        f.cell_d.is_finite() && f.cell_d > 0.0 && f.cell_d <= 10.0,
        "fluid.cell_d",
        f.cell_d,
        "in (0, 10] largest diameters",
    )?;
    need(
        f.viscosity_m2_s.is_finite() && f.viscosity_m2_s > 0.0 && f.viscosity_m2_s <= 1.0,
        "fluid.viscosity_m2_s",
        f.viscosity_m2_s,
        "in (0, 1] m^2/s (water: 1.0e-6)",
    )?;
    need(
        f.phi_max.is_finite() && f.phi_max > 0.0 && f.phi_max < 1.0,
        "fluid.phi_max",
        f.phi_max,
        "in (0, 1)",
    )?;
    need(
        (1..=1_000_000).contains(&f.update_steps),
        "fluid.update_steps",
        f.update_steps,
        "in [1, 1000000] steps of constants_dt",
    )?;
    need(
        f.hindrance.is_finite() && (0.0..=10.0).contains(&f.hindrance),
        "fluid.hindrance",
        f.hindrance,
        "in [0, 10] (Richardson-Zaki: 3.1; 0: off)",
    )?;
    Ok(FluidSpec {
        cell_height: f.cell_d * d,
        viscosity: f.viscosity_m2_s,
        phi_max: f.phi_max,
        update_steps: f.update_steps.saturating_mul(substeps),
        hindrance: f.hindrance,
    })
}

/// The coupled flow of `scenario` at each τ* fits the host's column and is
/// driven forward: its cells at most [`FLUID_CELLS`], and the bed slope
/// alone not a stronger flow than τ* (docs/model.md §13: the driving
/// u*²/h − g sin θ ≥ 0).
fn coupled_flow_fits(scenario: &Scenario, tau_stars: &[f64]) -> Result<(), ConfigError> {
    if scenario.flow.model != FlowModel::Coupled {
        return Ok(());
    }
    for (k, &tau_star) in tau_stars.iter().enumerate() {
        let flow = scenario.flow(tau_star);
        let cells = flow.fluid.cells;
        need(
            cells <= FLUID_CELLS,
            "fluid.cell_d",
            scenario.flow.fluid.cell_height / scenario.bed.max_diameter(),
            &format!(
                "large enough for at most {FLUID_CELLS} cells over the column's {:e} m \
                 (here {cells} cells; or a smaller flow.depth)",
                flow.fluid.surface - flow.fluid.bottom
            ),
        )?;
        let s = scenario.material.s;
        let h = scenario.flow.depth;
        let least = h * scenario.slope.sin() / (s - 1.0) / scenario.bed.max_diameter();
        need(
            flow.fluid.driving >= 0.0,
            &format!("flow.tau_star[{k}]"),
            tau_star,
            &format!(
                ">= h sin(theta)/((s - 1) d_max) = {least:e}, the Shields number the bed slope \
                 bed.slope_rad = {} alone drives over flow.depth = {h} m (a uniform flow: \
                 flow.slope = [sin(theta)])",
                scenario.slope
            ),
        )?;
    }
    Ok(())
}

/// The classical stability bound docs/model.md (11) on the integration step
/// for the lightest grain: step_dt = constants_dt/substeps ≤ 2√(m/k_n).
fn stability(sc: &Scenario, c: &ContactConstants) -> Result<(), ConfigError> {
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

/// Explicit damping number above which q* was found to depend on the
/// integration step: a grain with four sticking contacts multiplies the
/// single-contact number by about four (docs/findings/explicit-damping-limit.md).
pub const DAMPING_NUMBER_CONVERGED: f64 = 0.5;

/// Slowest speed (m/s) a grain must reach to count as moving: an f32 bed on
/// which slower grains cannot move in x in one step gets a warning.
pub const F32_RESOLVED_SPEED: f64 = 1e-3;

/// The speed (m/s) below which an f32 grain near x = L does not move in x in
/// one integration step: half the spacing of f32 numbers at L, over step_dt.
pub fn f32_frozen_speed(width: f64, step_dt: f64) -> f64 {
    let spacing = width.log2().floor().exp2() * f64::from(f32::EPSILON);
    0.5 * spacing / step_dt
}

/// The warning for an f32 bed `width` wide integrated with `step_dt`, if
/// grains slower than [`F32_RESOLVED_SPEED`] cannot move in x.
pub fn f32_width_warning(width: f64, step_dt: f64) -> Option<String> {
    let frozen = f32_frozen_speed(width, step_dt);
    (frozen > F32_RESOLVED_SPEED).then(|| {
        format!(
            "precision f32 on a bed {width:.3} m wide: a grain slower than {frozen:.2e} m/s \
             does not move in x in one step, so the bed cannot settle or creep correctly; \
             use precision = \"f64\" or a narrower bed"
        )
    })
}

/// Width, in largest diameters, from which q* was measured not to depend on
/// the width at any τ* in [0.06, 0.5] (docs/findings/bed-width.md: 40 columns).
pub const CONVERGED_WIDTH_D: f64 = 40.0;

/// The warning for a bed too narrow for width-independent q*: narrower than
/// two bed-level windows the whole periodic bed moves collectively, and
/// narrower than [`CONVERGED_WIDTH_D`] its surface locks near the threshold.
pub fn narrow_bed_warning(bed: &BedSpec, flow: &FlowSpec) -> Option<String> {
    let d = bed.max_diameter();
    let needed = (2.0 * flow.bed_level_window).max(CONVERGED_WIDTH_D) * d;
    let width = bed.width();
    (width < needed).then(|| {
        let columns = (needed / bed.pitch()).ceil();
        format!(
            "bed {:.2} mm wide ({} columns) is narrower than {:.0} grain diameters: on narrower \
             periodic beds q* depends on the width (below two bed-level windows the whole bed \
             moves, near the threshold its surface locks); bed.columns = {columns} or more gives \
             width-independent q*",
            width * 1e3,
            bed.columns,
            needed / d,
        )
    })
}

/// Estimated wall time (s) above which `mbs run` warns.
pub const LONG_RUN_S: f64 = 86400.0;

/// The warning for a run of `config` on `cores` cores estimated to take
/// longer than [`LONG_RUN_S`]: its integration steps and grain-steps and the
/// wall time at [`GRAIN_STEPS_PER_S_PER_CORE`].
pub fn long_run_warning(config: &Config, cores: usize) -> Option<String> {
    let sc = &config.scenario;
    let grains = sc.bed.columns as f64 * (sc.bed.fixed_per_column() + sc.bed.rows as usize) as f64;
    let cells = config.tau_stars.len() * config.seeds.len();
    let steps = config.durations.cell() as f64;
    let settling = config.seeds.len() as f64 * config.durations.settle as f64;
    let grain_steps = (cells as f64 * steps + settling) * grains;
    let parallel = cores.clamp(1, cells.max(1)) as f64;
    let wall = grain_steps / (GRAIN_STEPS_PER_S_PER_CORE * parallel);
    (wall > LONG_RUN_S).then(|| {
        format!(
            "a long run: {} bed(s) settling for up to {:.3e} and {cells} cell(s) of {steps:.3e} \
             integration steps (step_dt = {:e} s) of up to {grains} grains, {grain_steps:.2e} \
             grain-steps: about {:.1} days on {parallel} core(s) at \
             ~{GRAIN_STEPS_PER_S_PER_CORE:e} grain-steps/s per core; check time.settle, \
             time.spin_up, time.window and time.constants_dt",
            config.seeds.len(),
            config.durations.settle as f64,
            sc.step_dt(),
            wall / 86400.0
        )
    })
}

/// Warnings about a valid but questionable configuration, for runs with
/// flow (`under_flow`) or without.
pub fn warnings(config: &Config, under_flow: bool) -> Vec<String> {
    let sc = &config.scenario;
    let mut out = Vec::new();
    if under_flow {
        out.extend(narrow_bed_warning(&sc.bed, &sc.flow));
    }
    if config.precision == Precision::F32 {
        out.extend(f32_width_warning(sc.bed.width(), sc.step_dt()));
    }
    for class in &sc.bed.classes {
        let n =
            explicit_damping_number(&config.contact, &sc.material, class.diameter, sc.step_dt());
        if n > DAMPING_NUMBER_CONVERGED {
            let advice = (f64::from(sc.substeps) * n / DAMPING_NUMBER_CONVERGED).ceil();
            out.push(format!(
                "explicit damping number {n:.2} > {DAMPING_NUMBER_CONVERGED} for d = {} mm: \
                 results depend on the integration step (beyond 2 beds never come to rest); \
                 time.substeps = {advice} or more gives converged results",
                class.diameter * 1e3,
            ));
        }
    }
    out
}

/// Fields that do not change a cell's result are fixed, so equal cells get
/// equal keys whatever the configuration file said about them.
pub fn canonical(config: &ConfigFile) -> ConfigFile {
    let mut c = config.clone();
    c.run.output = "-".into();
    // A validated configuration holds its flow as `tau_star` too.
    c.flow.u_star_m_s = None;
    c.flow.slope = None;
    // Only drawn: a cell store stays reusable with another measured profile.
    c.run.measured_profiles = None;
    c.run.measured_shift_d = 0.0;
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default scenario: the paper's case (docs/model.md §9) on
    /// [`DEFAULT_COLUMNS`].
    fn default_scenario() -> Scenario {
        let mut s = Scenario::paper();
        s.bed.columns = DEFAULT_COLUMNS;
        s
    }

    #[test]
    fn embedded_file_is_the_default() {
        let parsed: ConfigFile = toml::from_str(DEFAULT_TOML).unwrap();
        let mut expected = ConfigFile::default();
        expected.grains.diameter_mm = Some(0.5);
        assert_eq!(parsed, expected);
        let c = Config::load(None).unwrap();
        assert_eq!(c.scenario, default_scenario());
    }

    /// `contact.tension` picks the kernel's rule; the paper's is not written
    /// out, so the keys of its cells are those of before the option, and
    /// the other rule's cells have keys of their own.
    #[test]
    fn tension_is_the_paper_rule_unless_none() {
        let paper = Config::load(None).unwrap();
        assert_eq!(paper.scenario.tension, Tension::Dashpot);
        let text = toml::to_string(&paper.file).unwrap();
        assert!(!text.contains("tension"), "{text}");
        let none = Config::from_toml("[contact]\ntension = \"none\"\n").unwrap();
        assert_eq!(none.scenario.tension, Tension::None);
        assert_eq!(none.scenario.sim_config().unwrap().tension, Tension::None);
        assert!(toml::to_string(&none.file)
            .unwrap()
            .contains("tension = \"none\""));
        let bad = Config::from_toml("[contact]\ntension = \"glue\"\n").unwrap_err();
        assert!(bad.to_string().contains("dashpot"), "{bad}");
    }

    #[test]
    fn f32_on_a_wide_bed_is_warned_about() {
        let warned = |columns: u32, precision: &str| {
            let text = format!("[bed]\ncolumns = {columns}\n[run]\nprecision = \"{precision}\"\n");
            let config = Config::from_toml(&text).unwrap();
            warnings(&config, true)
                .iter()
                .any(|w| w.contains("precision f32"))
        };
        // 93 columns: 4.9 cm, f32 spacing 3.7e-9 m, frozen below 0.7 mm/s.
        assert!(!warned(93, "f32"));
        // 200 columns: 10.5 cm, frozen below 1.5 mm/s.
        assert!(warned(200, "f32"));
        assert!(!warned(200, "f64"));
        let frozen = f32_frozen_speed(0.105, 2.5e-6);
        assert!((frozen - 0.0625 * f64::from(f32::EPSILON) / 5e-6).abs() < 1e-12);
    }

    #[test]
    fn a_bed_narrower_than_two_bed_level_windows_is_warned_about() {
        let warned = |columns: u32, window: f64, under_flow: bool| {
            let text = format!("[bed]\ncolumns = {columns}\n[flow]\nbed_level_window = {window}\n");
            let config = Config::from_toml(&text).unwrap();
            warnings(&config, under_flow)
                .iter()
                .any(|w| w.contains("q* depends on the width"))
        };
        // Pitch 1.05 d: 38 columns are 39.9 d, 39 are 40.95 d.
        assert!(warned(5, 5.0, true));
        assert!(!warned(5, 5.0, false), "packing has no flow");
        assert!(warned(38, 5.0, true));
        assert!(!warned(39, 5.0, true));
        // Two windows of 25 d are 50 d: 48 columns (50.4 d) suffice.
        assert!(warned(47, 25.0, true));
        assert!(!warned(48, 25.0, true));
    }

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

    #[test]
    fn the_density_and_diameter_limits_keep_inverse_inertias_finite_in_f32() {
        let paper = Scenario::paper().material;
        for rho in [1e-3, 1e5] {
            for s in [1.0 + 1e-9, 20.0] {
                for d in [MIN_DIAMETER_MM * 1e-3, 0.1] {
                    let m = Material { rho, s, ..paper };
                    for x in [m.translational_mass(d), m.moment_of_inertia(d)] {
                        let inverse = (1.0 / x) as f32;
                        assert!(inverse.is_normal(), "rho {rho}, s {s}, d {d}: {x}");
                    }
                }
            }
        }
    }

    #[test]
    fn empty_file_is_the_paper_case_on_a_converged_width() {
        let c = Config::from_toml("").unwrap();
        assert_eq!(c.scenario_at(1), default_scenario());
        assert_eq!(default_scenario().bed.columns, 40);
        assert!(narrow_bed_warning(&default_scenario().bed, &default_scenario().flow).is_none());
    }

    #[test]
    fn the_flow_may_be_given_as_shear_velocities_or_slopes() {
        let (s, d) = (1.65, 0.5e-3);
        let by_u = Config::from_toml("[flow]\nu_star_m_s = [0.02, 0.04]\n").unwrap();
        let by_tau = Config::from_toml(&format!(
            "[flow]\ntau_star = [{}, {}]\n",
            0.02f64 * 0.02 / (s * G * d),
            0.04f64 * 0.04 / (s * G * d)
        ))
        .unwrap();
        assert_eq!(by_u.tau_stars, by_tau.tau_stars);
        // The same cells whichever form gave them.
        assert_eq!(canonical(&by_u.file), canonical(&by_tau.file));
        // τ = ρ g h S on a 5 cm deep flow.
        let by_slope = Config::from_toml("[flow]\ndepth = 0.05\nslope = [0.002]\n").unwrap();
        assert_eq!(by_slope.tau_stars, [0.05 * 0.002 / (s * d)]);
        // The saved configuration (both forms) loads back to the same run.
        for c in [&by_u, &by_slope] {
            let saved = toml::to_string(&c.file).unwrap();
            assert!(saved.contains("tau_star = ["), "{saved}");
            assert_eq!(Config::from_toml(&saved).unwrap().file, c.file);
        }
        for (text, message) in [
            (
                "[flow]\nu_star_m_s = [0.03]\nslope = [0.001]",
                "flow.slope = [0.001]: must be not given with flow.u_star_m_s",
            ),
            (
                "[flow]\nu_star_m_s = [0.03]\ntau_star = [0.2]",
                "flow.tau_star = [0.2]: must be not given with flow.u_star_m_s",
            ),
            (
                "[flow]\nu_star_m_s = [0.03, -0.01]",
                "flow.u_star_m_s[1] = -0.01: must be > 0 and giving tau* in (0, 5]",
            ),
            (
                "[flow]\nslope = [0.5]",
                "flow.slope[0] = 0.5: must be > 0 and giving tau* in (0, 5] (here tau* = 1.2121",
            ),
            (
                "[flow]\nu_star_m_s = []",
                "flow.u_star_m_s = []: must be a list of 1 to 1000",
            ),
        ] {
            let e = Config::from_toml(text).unwrap_err().to_string();
            assert!(e.contains(message), "{text}: {e}");
        }
    }

    #[test]
    fn errors_name_key_value_and_range() {
        let cases = [
            ("[grains]\ndiameter_mm = -0.5", "grains.diameter_mm = -0.5: must be > 0"),
            ("[bed]\ncolumns = 2", "bed.columns = 2: must be in [3, 100000]"),
            ("[time]\nsubsteps = 0", "time.substeps = 0: must be in [1, 10000] or \"auto\""),
            ("[flow]\ntau_star = [0.1, -1.0]", "flow.tau_star[1] = -1: must be in (0, 5]"),
            ("[run]\ncapacity = 100", "run.capacity = 100: must be one of"),
            ("[run]\ncapacity = 256\n[bed]\ncolumns = 30", "run.capacity = 256: must be >= the bed's 330 grains"),
            ("[contact]\nalpha_m = 2.0\nbeta = 1.0\n[time]\nsubsteps = 1", "step_dt = 2e-5 s: must be <= 1.8"),
            ("[contact]\nk_n = 1.0", "contact.k_n = 1: must be given with contact.eta_n"),
            ("[grains]\nclasses = [{ diameter_mm = 1.0, fraction = 0.6 }, { diameter_mm = 0.7, fraction = 0.6 }]", "grains.classes (sum of fractions) = 1.2: must be = 1"),
            ("[run]\nseeds = [1, 1]", "run.seeds = [1, 1]: must be distinct"),
            ("[flow]\ntau_star = [0.1, 0.1]", "flow.tau_star = [0.1, 0.1]: must be distinct values"),
        ];
        for (text, message) in cases {
            let e = Config::from_toml(text).unwrap_err().to_string();
            assert!(
                e.starts_with(message),
                "{text}\n  gave: {e}\n  want: {message}"
            );
        }
        let e = Config::from_toml("[time]\nsubsteps = \"fast\"")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("substeps = \"fast\"")
                && e.ends_with(
                    "invalid value: string \"fast\", expected an integer in [1, 10000] or \"auto\""
                ),
            "{e}"
        );
        // Checks the kernel makes are the kernel's: its error is kept as a value.
        let kernel_cases = [
            (
                "[flow]\nfluid_density = -1.0",
                "flow.fluid_density",
                "flow.fluid_density = -1: must be finite and > 0",
            ),
            (
                "[contact]\npoisson = 0.5",
                "contact.poisson",
                "contact.poisson = 0.5: must be in (-1, 0.5)",
            ),
            (
                "[bed]\nspacing = 3.0",
                "bed.spacing",
                "bed.spacing = 3: must be in (1, 2]",
            ),
            (
                "[flow]\neps0 = 2.0",
                "flow.eps0",
                "flow.eps0 = 2: must be in [0, 1]",
            ),
            (
                "[flow]\nhold_steps = 0",
                "flow.hold_steps",
                "flow.hold_steps = 0: must be >= 1",
            ),
            (
                "[contact]\nalpha_m = -1.0",
                "contact.alpha_m",
                "contact.alpha_m = -1: must be finite and > 0",
            ),
            (
                "[contact]\nk_n = -1.0\neta_n = 1e-4",
                "contact.k_n",
                "contact.k_n = -1: must be finite and > 0",
            ),
        ];
        for (text, want_key, message) in kernel_cases {
            let e = Config::from_toml(text).unwrap_err();
            assert!(
                matches!(e, ConfigError::Kernel { key, source: mbs_kernel::Error::InvalidParameter { .. } } if key == want_key),
                "{text}: {e:?}"
            );
            assert!(
                e.to_string().starts_with(message),
                "{text}\n  gave: {e}\n  want: {message}"
            );
        }
        let renamed = Config::from_toml("[time]\ndt = 2e-5")
            .unwrap_err()
            .to_string();
        assert!(
            renamed.contains("unknown field `dt`, expected one of `constants_dt`")
                && renamed.contains("time.dt is now time.constants_dt"),
            "{renamed}"
        );
        let unknown = Config::from_toml("[grains]\ndiameter = 0.5").unwrap_err();
        assert!(
            unknown.to_string().contains("unknown field `diameter`"),
            "{unknown}"
        );
    }
}
