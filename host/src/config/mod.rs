//! The TOML configuration: parsed with serde (`deny_unknown_fields`), every
//! missing key taken from the paper's case, then validated into typed
//! parameters. Every invalid value is reported as `key = value: must be …`.
//!
//! This file holds the run plan ([`Config`], [`Durations`], [`Setup`],
//! [`Precision`]) and its entry points ([`Config::load`],
//! [`Config::from_toml`], [`Config::validate`], …); the rest is one concern
//! a file, every public item re-exported here:
//!
//! | file | concern |
//! |---|---|
//! | `file.rs` | the file format: the sections as serde reads and writes them, [`canonical`] |
//! | `defaults.rs` | the defaults: [`DEFAULT_TOML`], each section's `Default` (the paper's case), [`DEFAULT_COLUMNS`] |
//! | `overrides.rs` | `--set SECTION.KEY=VALUE`: parsed one by one ([`Override`]), applied to the TOML text ([`apply_overrides`]), errors named by their `--set` |
//! | `load.rs` | loading: every file read (the configuration file, the files it names), then validation |
//! | `validate.rs` | validation, pure: a parsed file and the files it names, as read, into the run plan |
//! | `specs.rs` | kernel specifications of the grains, bed, material, contact; substeps and stability |
//! | `flow.rs` | kernel specifications of the flow and the coupled flow's column ([`flow_forms`]) |
//! | `limits.rs` | the bounds checked that are not the kernel's ([`CAPACITIES`] and the one list they come from, `grain_capacities!`; [`CONFIG_BOUND`], [`MAX_PHASE_S`], …) |
//! | `warnings.rs` | warnings about a valid but questionable configuration ([`warnings`]) |
//! | `errors.rs` | how the errors are made: out of range, a kernel error's key, toml's message |

mod defaults;
mod errors;
mod file;
mod flow;
mod limits;
mod load;
mod overrides;
mod specs;
mod validate;
mod warnings;

pub use crate::error::ConfigError;
pub use defaults::{DEFAULT_COLUMNS, DEFAULT_TOML};
pub(crate) use errors::need;
pub use file::{
    canonical, BedSection, ClassEntry, ConfigFile, ContactSection, FlowModelKey, FlowSection,
    FluidSection, FractionBasis, GrainsSection, RunSection, SettleUntil, Substeps, TargetSection,
    TensionRule, TimeSection, WindowUntil,
};
pub use flow::flow_forms;
pub(crate) use limits::grain_capacities;
pub use limits::{
    capacities_listed, steps_arg, tau_star_arg, CAPACITIES, CONFIG_BOUND, FLUID_CELLS,
    GRAIN_STEPS_PER_S_PER_CORE, MAX_CAPACITY, MAX_CELL_STEPS, MAX_PHASE_S, MAX_TAU_STAR,
    MAX_THREADS, MIN_CONSTANTS_DT, MIN_DIAMETER_MM, SUBSTEP_DAMPING_NUMBER,
};
pub use overrides::{apply_overrides, Override};
pub use specs::{number_fractions, volume_fractions};
pub use warnings::{
    f32_frozen_speed, f32_width_warning, long_run_warning, long_steps_warning, narrow_bed_warning,
    warnings, CONVERGED_WIDTH_D, DAMPING_NUMBER_CONVERGED, F32_RESOLVED_SPEED, LONG_RUN_S,
};

use crate::science::measured::MeasuredProfile;
use load::{load, Source};
use mbs_kernel::{ContactConstants, FlowConfig, Scenario};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Working precision of the kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Single precision (the board's native float).
    F32,
    /// Double precision.
    F64,
}

/// The run plan: a validated configuration, read by every command. Times
/// are integration steps, the flow is the kernel's [`FlowSpec`](mbs_kernel::FlowSpec) (intervals in
/// integration steps, u* per τ* from [`Config::setup`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// The file with every default filled in (serialised without the keys
    /// that leave the paper's model unchanged at their defaults, so that
    /// stored cells keep their keys): only echoed (`config.toml`,
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
    /// Warnings about renamed keys the file used (accepted for one release:
    /// [`DEPRECATED_KEYS`]), for [`warnings()`].
    pub renamed_keys: Vec<String>,
}

/// Keys renamed in this release, `(section, old, new)`: the old key is still
/// read (a serde alias) and warned about ([`Config::renamed_keys`]).
pub const DEPRECATED_KEYS: &[(&str, &str, &str)] =
    &[("flow", "bed_level_window", "bed_level_span")];

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
    /// When the window ends between them.
    pub window_until: WindowUntil,
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

impl Config {
    /// Parses and validates TOML text.
    pub fn from_toml(text: &str) -> Result<Config, ConfigError> {
        load(Source::Text(text), &[])
    }

    /// Reads and validates a file, or the embedded default when `path` is None.
    pub fn load(path: Option<&Path>) -> Result<Config, ConfigError> {
        Config::load_with(path, &[])
    }

    /// [`Config::load`] with `--set` overrides ([`apply_overrides`]).
    pub fn load_with(path: Option<&Path>, sets: &[String]) -> Result<Config, ConfigError> {
        match path {
            None => load(Source::Default, sets),
            Some(p) => load(Source::File(p), sets),
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
        load(Source::Parsed(Box::new(file)), sets)
    }

    /// Reads the files `file` names (`run.measured_profiles`), checks every
    /// value and builds the typed configuration.
    pub fn validate(file: ConfigFile) -> Result<Config, ConfigError> {
        load(Source::Parsed(Box::new(file)), &[])
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
        validate::steps_of(seconds, self.scenario.step_dt())
    }
}
