//! Digest traces (`mbs digest --trace FILE --every K`): the digest of the
//! digest run every K integration steps with separate digests of its
//! field groups, optionally the whole kernel state at each record, and the
//! metadata needed to compare two traces; and the check that re-runs a
//! trace and locates where this build parts from it. The format and the
//! locating procedure are in docs/determinism.md ("Traces").
//!
//! The files:
//!
//! - `mod.rs`: the types ([`Nudge`], [`TraceSpec`], [`TraceRun`],
//!   [`Record`], [`Trace`], [`RunError`], [`Verdict`]);
//! - `format.rs`: the file format ([`FORMAT`], [`to_text`], [`parse`]) and
//!   its bounds ([`MAX_RECORDS`], [`TRACE_BOUND`]);
//! - `record.rs`: recording a trace while running ([`TraceRun::run`]);
//! - `check.rs`: re-running a trace and comparing ([`check`]), and locating
//!   where the runs part.

mod check;
mod format;
mod record;

pub use check::check;
pub use format::{parse, to_text, FORMAT, MAX_RECORDS, TRACE_BOUND};
pub use record::step_path;

use crate::config::{need, steps_arg, tau_star_arg, ConfigError, Precision};
use mbs_kernel::{GrainField, Scenario};
use serde::Serialize;
use std::collections::BTreeMap;

/// A deliberate change of one grain's field by `ulps` units in the last
/// place after `step` integration steps (`--nudge STEP:GRAIN:FIELD[:ULPS]`):
/// what `mbs digest --check` should then locate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nudge {
    /// Integration steps taken when the field is changed.
    pub step: u64,
    /// Grain index.
    pub grain: usize,
    /// The field.
    pub field: GrainField,
    /// Units in the last place (≠ 0).
    pub ulps: i64,
}

impl std::fmt::Display for Nudge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let Nudge {
            step,
            grain,
            field,
            ulps,
        } = self;
        write!(f, "{step}:{grain}:{}:{ulps}", field.name())
    }
}

impl std::str::FromStr for Nudge {
    type Err = String;

    /// `STEP:GRAIN:FIELD[:ULPS]`, ULPS 1 when omitted.
    ///
    /// ```
    /// use mbs::tools::trace::Nudge;
    /// use mbs_kernel::GrainField;
    ///
    /// let n: Nudge = "120:7:y".parse().unwrap();
    /// assert_eq!((n.step, n.grain, n.field, n.ulps), (120, 7, GrainField::Y, 1));
    /// assert!("120:7:mass".parse::<Nudge>().is_err());
    /// ```
    fn from_str(text: &str) -> Result<Nudge, String> {
        let parts: Vec<&str> = text.split(':').collect();
        let (step, grain, field, ulps) = match parts[..] {
            [a, b, c] => (a, b, c, "1"),
            [a, b, c, d] => (a, b, c, d),
            _ => return Err("STEP:GRAIN:FIELD or STEP:GRAIN:FIELD:ULPS".into()),
        };
        let number = |what: &str, s: &str| format!("{what} {s:?} is not a whole number");
        let field = GrainField::from_name(field)
            .ok_or_else(|| format!("field {field:?}: one of x, y, u, v, spin, draw_u, draw_v"))?;
        let ulps: i64 = ulps.parse().map_err(|_| number("ULPS", ulps))?;
        if ulps == 0 {
            return Err("ULPS 0 changes nothing".into());
        }
        Ok(Nudge {
            step: step.parse().map_err(|_| number("STEP", step))?,
            grain: grain.parse().map_err(|_| number("GRAIN", grain))?,
            field,
            ulps,
        })
    }
}

/// What a trace records, as its file states it: the digest run of the
/// configuration (`settle_steps` without flow, then `flow_steps` at
/// `tau_star`), from step `from` to step `until`, every `every` steps and
/// at the phases' ends.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct TraceSpec {
    /// The configuration file's name as given when recording, or `None`
    /// (null) for the golden run: a label, never opened.
    pub config: Option<String>,
    /// `--set` overrides given on top of it (empty: none), as a record.
    #[serde(default)]
    pub overrides: Vec<String>,
    /// The configuration as run, overrides applied: its TOML as a run
    /// echoes it ([`canonical`](crate::config::canonical): no
    /// output directory, no measured profile). `--check` runs this text,
    /// checked like any configuration: a trace is data, not a pointer to
    /// files.
    pub configuration: String,
    /// Shields number of the flow phase.
    pub tau_star: f64,
    /// Steps without flow.
    pub settle_steps: u64,
    /// Steps under the flow.
    pub flow_steps: u64,
    /// Steps between records (> 0).
    pub every: u64,
    /// The first recorded step.
    pub from: u64,
    /// The last step run (at most `settle_steps + flow_steps`).
    pub until: u64,
    /// Each record carries the whole kernel state.
    pub states: bool,
    /// Working precision.
    pub precision: Precision,
}

impl TraceSpec {
    /// Checks what the command line checks when such a trace is recorded:
    /// τ* in (0, 5], each phase at most [`steps_arg`]'s limit, `every` > 0,
    /// `from` at most the last step. A trace read from a file is checked
    /// again, as strictly as the command that would have written it.
    pub fn validate(&self) -> Result<(), ConfigError> {
        tau_star_arg("--tau", self.tau_star)?;
        steps_arg("--steps", self.settle_steps)?;
        steps_arg("--flow-steps", self.flow_steps)?;
        need(self.every >= 1, "--every", self.every, "> 0")?;
        let last = (self.settle_steps + self.flow_steps).min(self.until);
        need(
            self.from <= last,
            "--from",
            self.from,
            &format!("<= the run's last step, {last} (--steps, --flow-steps, --until)"),
        )
    }
}

/// A trace to run: its [`TraceSpec`] on the scenario the configuration
/// gives, in a simulation of `capacity` grains.
#[derive(Debug, Clone)]
pub struct TraceRun {
    /// The scenario (configuration and seed).
    pub scenario: Scenario,
    /// Grain capacity (as [`crate::Config::capacity`]).
    pub capacity: usize,
    /// What to record.
    pub spec: TraceSpec,
}

/// One record: the integration step, the phase, the full digest and each
/// field group's (hexadecimal, `0x` and 16 digits), and with `--states`
/// the kernel checkpoint ([`Sim::checkpoint`](mbs_kernel::Sim::checkpoint)) in base64.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct Record {
    /// Integration steps since the bed was built.
    pub step: u64,
    /// `settle` or `flow`.
    pub phase: String,
    /// [`Sim::digest`](mbs_kernel::Sim::digest).
    pub digest: String,
    /// [`Sim::group_digest`](mbs_kernel::Sim::group_digest) of each [`FieldGroup`](mbs_kernel::FieldGroup), by its name.
    pub groups: BTreeMap<String, String>,
    /// The whole state, when the trace keeps states.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state: Option<String>,
}

/// Why a trace run stopped early.
#[derive(Debug)]
pub enum RunError {
    /// The kernel failed.
    Kernel(mbs_kernel::Error),
    /// The nudge could not be applied (no such grain, or out of range).
    Nudge(Nudge, mbs_kernel::Error),
    /// The trace's first state cannot start this run (crafted or foreign).
    State(String),
}

impl From<mbs_kernel::Error> for RunError {
    fn from(e: mbs_kernel::Error) -> Self {
        RunError::Kernel(e)
    }
}

/// The metadata and records of a trace (its body, which the checksum
/// covers), as written and as read back.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct Trace {
    /// [`FORMAT`].
    pub format: String,
    /// Program name, version and git commit (null when unknown).
    pub program: BTreeMap<String, Option<String>>,
    /// The target triple the program was built for.
    pub target: String,
    /// `batched` (x86-64 AVX2 lanes) or `scalar`.
    pub step_path: String,
    /// FNV-1a of the scenario's description (configuration, seed, τ*,
    /// steps), hexadecimal.
    pub scenario_hash: String,
    /// What was recorded.
    #[serde(flatten)]
    pub spec: TraceSpec,
    /// The integration step (s).
    pub step_dt_s: f64,
    /// The records, in step order.
    pub records: Vec<Record>,
}

impl Trace {
    /// The step of its last record.
    pub fn last_step(&self) -> u64 {
        self.records.last().map_or(0, |r| r.step)
    }

    /// The program that recorded it: name, version and commit as known.
    pub fn program_name(&self) -> String {
        let field = |k: &str| self.program.get(k).cloned().flatten();
        [field("name"), field("version"), field("commit")]
            .into_iter()
            .flatten()
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// What `mbs digest --check` found.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// Every record matches: their number and the last step.
    Matches(usize, u64),
    /// Where this run parts from the trace, and what differs.
    Mismatch(String),
}
