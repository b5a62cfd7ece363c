//! The file format: the sections of a configuration file as serde reads
//! and writes them (`deny_unknown_fields`, every key optional), and the
//! fields [`canonical`] fixes so that equal cells get equal keys. Their
//! defaults are in `defaults.rs`.

use super::Precision;
use mbs_kernel::{DragLaw, FlowModel, Fluctuations, Tension};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::PathBuf;

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

fn is_one(value: &u32) -> bool {
    *value == 1
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

/// `fluid.drag`: the grains' drag law in the coupled flow, the kernel's
/// [`DragLaw`] (docs/model.md (C8)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DragKey {
    /// The paper's (4)–(5), C_D constant.
    #[default]
    Paper,
    /// Dallavalle's, as HydroForceEngine: C_D = 0.44 + 24.4/Re_p.
    Dallavalle,
}

impl DragKey {
    /// The kernel's law.
    pub fn kernel(self) -> DragLaw {
        match self {
            DragKey::Paper => DragLaw::Paper,
            DragKey::Dallavalle => DragLaw::Dallavalle,
        }
    }

    /// Not written out at the paper's: the keys of cells stay as they were.
    fn is_paper(&self) -> bool {
        *self == DragKey::Paper
    }
}

/// `fluid.fluctuations`: the turbulent fluctuations in the coupled flow,
/// the kernel's [`Fluctuations`] (docs/model.md (C9)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FluctuationsKey {
    /// The paper's (15) with the local shear velocity.
    #[default]
    Paper,
    /// HydroForceEngine's discrete random walk.
    Hfe,
}

impl FluctuationsKey {
    /// The kernel's model.
    pub fn kernel(self) -> Fluctuations {
        match self {
            FluctuationsKey::Paper => Fluctuations::Paper,
            FluctuationsKey::Hfe => Fluctuations::Hfe,
        }
    }

    /// Not written out at the paper's: the keys of cells stay as they were.
    fn is_paper(&self) -> bool {
        *self == FluctuationsKey::Paper
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

/// `time.window_until`: when a cell's averaging window ends
/// (docs/model.md §8, (E1)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WindowUntil {
    /// When its steady part spans `time.window_min` and its own error
    /// reaches `[target]` ([`crate::work::cell::WindowRule`]), or at
    /// `time.window`.
    #[default]
    Target,
    /// When its steady part spans `time.window_min`, or at `time.window`:
    /// the error comes from the seeds, as independent replicates (the
    /// calibration's points).
    Steady,
}

impl WindowUntil {
    /// The default (left out of a cell's key, which stays as it was).
    pub fn is_target(&self) -> bool {
        *self == WindowUntil::Target
    }
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
    /// When the window ends between `window_min` and `window`.
    #[serde(skip_serializing_if = "WindowUntil::is_target")]
    pub window_until: WindowUntil,
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

/// `time.substeps`: a count, or `"auto"`: the fewest that keep the
/// explicit damping number of every size class at or below
/// [`SUBSTEP_DAMPING_NUMBER`](super::SUBSTEP_DAMPING_NUMBER) ([`Substeps::resolve`]).
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

/// `[flow]` (docs/model.md §6).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FlowSection {
    /// Shields numbers (the key `flow.tau_star`).
    #[serde(rename = "tau_star")]
    pub tau_stars: Vec<f64>,
    /// Shear velocities u* (m/s), instead of `tau_star` ([`flow_forms`](super::flow_forms)).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u_star_m_s: Option<Vec<f64>>,
    /// Slopes S of a uniform flow of depth h, instead of `tau_star`
    /// ([`flow_forms`](super::flow_forms)).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slope: Option<Vec<f64>>,
    /// κ.
    pub kappa: f64,
    /// h (m).
    pub depth: f64,
    /// ε0.
    pub eps0: f64,
    /// Roughness height of the log law k_sr / d (docs/model.md (14)).
    pub roughness_d: f64,
    /// Monte Carlo turbulence on.
    pub turbulence: bool,
    /// Hold of a fluctuation (steps of constants_dt).
    pub hold_steps: u32,
    /// Bed-level interval (steps of constants_dt).
    pub bed_level_interval: u32,
    /// Width of the bed-level spans, in largest diameters (read under its
    /// old name `bed_level_window` too, for one release, with a warning:
    /// [`DEPRECATED_KEYS`](super::DEPRECATED_KEYS)).
    #[serde(alias = "bed_level_window")]
    pub bed_level_span: f64,
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
    /// Largest fluid cell height (largest diameters).
    pub cell_d: f64,
    /// Kinematic viscosity ν (m²/s).
    pub viscosity_m2_s: f64,
    /// φ_max of the mixing length (C3).
    pub phi_max: f64,
    /// Steps of constants_dt between two updates of the column.
    pub update_steps: u32,
    /// Exponent n of the hindrance (C7).
    pub hindrance: f64,
    /// The grains' drag law (C8).
    #[serde(skip_serializing_if = "DragKey::is_paper")]
    pub drag: DragKey,
    /// The turbulent fluctuations (C9).
    #[serde(skip_serializing_if = "FluctuationsKey::is_paper")]
    pub fluctuations: FluctuationsKey,
}

/// `[channel]`: side walls that hold the coupled flow's water back
/// (docs/model.md (C10)); absent: an unbounded slice.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelSection {
    /// The channel's width W between its side walls (m).
    pub width_m: f64,
    /// A factor on the walls' friction factor (HydroForceEngine's
    /// `fluidFrictionCoef`); 1: Blasius's smooth wall.
    #[serde(default = "one")]
    pub wall_friction: f64,
    /// The grains' friction coefficient on the walls μ_w (0: none).
    #[serde(default)]
    pub grain_friction: f64,
    /// Janssen's ratio K of the lateral to the vertical granular stress:
    /// the weight of the grains above also presses a grain on the walls
    /// (C12), besides the spanwise fluctuation's drag (C11); 0: not.
    #[serde(default)]
    pub lateral_ratio: f64,
}

fn one() -> f64 {
    1.0
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
    /// A measured profile drawn over `profiles.png` ([`MeasuredProfile`](crate::science::measured::MeasuredProfile)).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured_profiles: Option<PathBuf>,
    /// Its heights are drawn at z/d minus this (largest diameters).
    #[serde(skip_serializing_if = "is_zero")]
    pub measured_shift_d: f64,
    /// Its legend label (absent: "measured (FILE)"), e.g. a simulation's name.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured_label: Option<String>,
    /// Threads inside each cell's bed (the phased step: the same bits on
    /// any number); 0: automatic, the cores left over when every cell has
    /// one, shared among the cells.
    #[serde(skip_serializing_if = "is_one")]
    pub threads_per_cell: u32,
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
    /// `[channel]`, with the coupled flow only; absent: no side walls.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub channel: Option<ChannelSection>,
    /// `[target]`.
    pub target: TargetSection,
    /// `[run]`.
    pub run: RunSection,
}

impl FluidSection {
    fn is_default(&self) -> bool {
        *self == FluidSection::default()
    }
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
    c.run.measured_label = None;
    // How many threads a cell runs on changes none of its bits.
    c.run.threads_per_cell = 1;
    c
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

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
}
