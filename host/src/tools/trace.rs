//! Digest traces (`mbs digest --trace FILE --every K`): the digest of the
//! digest run every K integration steps with separate digests of its
//! field groups, optionally the whole kernel state at each record, and the
//! metadata needed to compare two traces; and the check that re-runs a
//! trace and locates where this build parts from it. The format and the
//! locating procedure are in docs/determinism.md ("Traces").

use crate::config::Precision;
use crate::io::input::Bound;
use crate::sim::sims::{
    boxed_sim, check_restored, checkpoint_len, with_sim, HostSim, SimJob, NEIGHBOURS,
};
use base64::Engine;
use mbs_kernel::{FieldGroup, Fnv1a, GrainField, Real, Scenario};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The trace format's name and version (the `format` field).
pub const FORMAT: &str = "mbs-trace 2";

/// Grain values a mismatch report lists at most.
const LISTED: usize = 12;

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

/// The most records a trace holds (`mbs digest --trace` refuses an `--every`
/// that would give more): far more than a comparison needs.
pub const MAX_RECORDS: u64 = 100_000;

/// The most bytes one record takes in a trace file without its state
/// (test `a_record_fits_its_bound`).
const MAX_RECORD_BYTES: u64 = 1024;

/// The most bytes of a trace file's records: 100 MB, and so at most
/// [`MAX_RECORDS`] records without states; with states fewer, as many as
/// fit (`mbs digest --trace` refuses a trace that might not).
const MAX_TRACE_BYTES: u64 = MAX_RECORDS * MAX_RECORD_BYTES;

/// The longest trace file: [`MAX_TRACE_BYTES`] of records and 64 KiB for
/// the rest (the configuration's path included).
pub const TRACE_BOUND: Bound = Bound {
    bytes: MAX_TRACE_BYTES + (64 << 10),
    reason: "the largest trace (100000 records of at most 1 KiB, or fewer with states)",
};

/// What a trace records, as its file states it: the digest run of the
/// configuration (`settle_steps` without flow, then `flow_steps` at
/// `tau_star`), from step `from` to step `until`, every `every` steps and
/// at the phases' ends.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct TraceSpec {
    /// The configuration file, or `None` (null) for the golden run.
    pub config: Option<String>,
    /// `--set` overrides on top of it (empty: none).
    #[serde(default)]
    pub overrides: Vec<String>,
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
/// the kernel checkpoint ([`Sim::checkpoint`]) in base64.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct Record {
    /// Integration steps since the bed was built.
    pub step: u64,
    /// `settle` or `flow`.
    pub phase: String,
    /// [`Sim::digest`].
    pub digest: String,
    /// [`Sim::group_digest`] of each [`FieldGroup`], by its name.
    pub groups: BTreeMap<String, String>,
    /// The whole state, when the trace keeps states.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state: Option<String>,
}

impl Record {
    /// The same step, phase and digests (the state aside).
    fn same(&self, other: &Record) -> bool {
        (self.step, &self.phase, &self.digest, &self.groups)
            == (other.step, &other.phase, &other.digest, &other.groups)
    }
}

fn hex(x: u64) -> String {
    format!("{x:#018x}")
}

fn record<R: Real, const N: usize>(sim: &HostSim<R, N>, phase: &str, state: bool) -> Record {
    Record {
        step: sim.step_count(),
        phase: phase.into(),
        digest: hex(sim.digest()),
        groups: FieldGroup::ALL
            .iter()
            .map(|&g| (g.name().to_string(), hex(sim.group_digest(g))))
            .collect(),
        state: state.then(|| {
            let mut bytes = Vec::new();
            sim.checkpoint(|b| bytes.extend_from_slice(b));
            base64::engine::general_purpose::STANDARD.encode(bytes)
        }),
    }
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

impl TraceRun {
    /// At most the records this run writes: step `from`, then every
    /// `every` steps, and the end of each phase.
    pub fn max_records(&self) -> u64 {
        let span = self.end().saturating_sub(self.spec.from);
        3 + span.div_ceil(self.spec.every.max(1))
    }

    /// At most the bytes of this run's records: [`MAX_RECORD_BYTES`] each,
    /// and with states the base64 of the bed's largest kernel checkpoint
    /// (every grain with every neighbour slot a contact).
    pub fn max_bytes(&self) -> u64 {
        let bed = &self.scenario.bed;
        let grains = (bed.columns as usize)
            .saturating_mul(bed.fixed_per_column().saturating_add(bed.rows as usize));
        let state = if self.spec.states {
            let bytes = checkpoint_len(
                self.spec.precision,
                grains,
                grains.saturating_mul(NEIGHBOURS),
            );
            (bytes as u64).div_ceil(3) * 4
        } else {
            0
        };
        self.max_records()
            .saturating_mul(MAX_RECORD_BYTES.saturating_add(state))
    }

    /// Whether the trace fits [`TRACE_BOUND`]: else why not, for `--every`.
    pub fn fits(&self) -> Result<(), String> {
        if self.max_bytes() <= MAX_TRACE_BYTES {
            return Ok(());
        }
        let per_record = self.max_bytes() / self.max_records().max(1);
        let records = (MAX_TRACE_BYTES / per_record.max(1))
            .saturating_sub(3)
            .max(1);
        let span = self.end().saturating_sub(self.spec.from);
        Err(format!(
            ">= {}: a trace holds at most {} MB of records, here at most {records} records{}",
            span.div_ceil(records).max(1),
            MAX_TRACE_BYTES / 1_000_000,
            if self.spec.states { " with states" } else { "" }
        ))
    }

    /// The last step run.
    fn end(&self) -> u64 {
        self.spec
            .settle_steps
            .saturating_add(self.spec.flow_steps)
            .min(self.spec.until)
    }

    /// `settle` up to and including the settling phase's last step, then `flow`.
    fn phase(&self, step: u64) -> &'static str {
        if step <= self.spec.settle_steps {
            "settle"
        } else {
            "flow"
        }
    }

    fn is_record(&self, step: u64) -> bool {
        let every = self.spec.every.max(1);
        step >= self.spec.from
            && step <= self.end()
            && ((step - self.spec.from).is_multiple_of(every)
                || step == self.spec.settle_steps
                || step == self.end())
    }

    /// The step where the run must next stop after `step`: a record, the
    /// end of settling (the flow switches on), the nudge or the end.
    fn next_stop(&self, step: u64, nudge: Option<Nudge>) -> u64 {
        let every = self.spec.every.max(1);
        let record = if step < self.spec.from {
            self.spec.from
        } else {
            ((step - self.spec.from) / every + 1)
                .saturating_mul(every)
                .saturating_add(self.spec.from)
        };
        let mut next = record.min(self.end());
        if step < self.spec.settle_steps {
            next = next.min(self.spec.settle_steps);
        }
        if let Some(n) = nudge.filter(|n| n.step > step) {
            next = next.min(n.step);
        }
        next
    }

    /// Runs `sim` (built, or restored at a recorded step) to the end,
    /// applying `nudge` and handing each record to `visit`, which returns
    /// whether to go on.
    fn drive<R: Real, const N: usize>(
        &self,
        sim: &mut HostSim<R, N>,
        nudge: Option<Nudge>,
        mut visit: impl FnMut(&HostSim<R, N>, Record) -> bool,
    ) -> Result<(), RunError> {
        let flow = self.scenario.flow(self.spec.tau_star);
        loop {
            let step = sim.step_count();
            if let Some(n) = nudge.filter(|n| n.step == step) {
                sim.nudge(n.grain, n.field, n.ulps)
                    .map_err(|e| RunError::Nudge(n, e))?;
            }
            if self.is_record(step) && !visit(sim, record(sim, self.phase(step), self.spec.states))
            {
                return Ok(());
            }
            if step >= self.end() {
                return Ok(());
            }
            if step == self.spec.settle_steps && sim.flow().is_none() {
                sim.set_flow(Some(&flow))?;
            }
            sim.run(self.next_stop(step, nudge) - step)?;
        }
    }

    /// FNV-1a of the scenario, τ* and step counts (their `Debug` text:
    /// shortest round-trip floats, the same on every machine).
    pub fn scenario_hash(&self) -> u64 {
        let text = format!(
            "{:?} tau* {:?} settle {} flow {}",
            self.scenario, self.spec.tau_star, self.spec.settle_steps, self.spec.flow_steps
        );
        Fnv1a::of(text.as_bytes())
    }

    /// Runs the trace.
    pub fn run(&self) -> Result<Trace, RunError> {
        let records = with_sim(self.spec.precision, self.capacity, Recording(self))?;
        Ok(Trace {
            format: FORMAT.into(),
            program: BTreeMap::from([
                ("name".into(), Some("mbs".into())),
                ("version".into(), Some(env!("CARGO_PKG_VERSION").into())),
                (
                    "commit".into(),
                    option_env!("MBS_GIT_COMMIT").map(Into::into),
                ),
            ]),
            target: env!("MBS_TARGET").into(),
            step_path: step_path().into(),
            scenario_hash: hex(self.scenario_hash()),
            spec: TraceSpec {
                until: self.end(),
                ..self.spec.clone()
            },
            step_dt_s: self.scenario.step_dt(),
            records,
        })
    }
}

struct Recording<'a>(&'a TraceRun);

impl SimJob for Recording<'_> {
    type Output = Result<Vec<Record>, RunError>;

    fn run<R: Real, const N: usize>(self, sim: &mut HostSim<R, N>) -> Self::Output {
        self.0.scenario.build(sim)?;
        let mut records = Vec::new();
        self.0.drive(sim, None, |_, r| {
            records.push(r);
            true
        })?;
        Ok(records)
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

/// The step path this build runs.
pub fn step_path() -> &'static str {
    if cfg!(all(target_arch = "x86_64", target_feature = "avx2")) {
        "batched"
    } else {
        "scalar"
    }
}

fn crc(text: &str) -> String {
    format!("{:#010x}", crc32fast::hash(text.as_bytes()))
}

/// The trace file's text: `{"body": …, "checksum": "0x…"}`, the checksum
/// the CRC-32 of the body's compact JSON (keys sorted).
pub fn to_text(trace: &Trace) -> serde_json::Result<String> {
    let body = serde_json::to_value(trace)?;
    let checksum = crc(&serde_json::to_string(&body)?);
    let file = serde_json::json!({ "body": body, "checksum": checksum });
    let mut text = serde_json::to_string_pretty(&file)?;
    text.push('\n');
    Ok(text)
}

/// Reads a trace file's text: its body, if the text is a trace of this
/// format whose checksum matches; else why not (a damaged, edited,
/// truncated or foreign file).
pub fn parse(text: &str) -> Result<Trace, String> {
    let file: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| format!("not a JSON trace (damaged or truncated?): {e}"))?;
    let (Some(body), Some(checksum)) = (file.get("body"), file.get("checksum")) else {
        return Err("not an mbs trace: no \"body\" and \"checksum\"".into());
    };
    let format = body.get("format").and_then(|f| f.as_str());
    if format != Some(FORMAT) {
        return Err(format!(
            "trace format {}; this program reads {FORMAT:?}",
            format.map_or("missing".into(), |f| format!("{f:?}"))
        ));
    }
    let computed = crc(&serde_json::to_string(body).map_err(|e| e.to_string())?);
    if checksum.as_str() != Some(computed.as_str()) {
        return Err(format!(
            "checksum mismatch: the file says {checksum}, its body's CRC-32 is {computed} (edited or damaged)"
        ));
    }
    let recorded: Trace = serde_json::from_value(body.clone())
        .map_err(|e| format!("not an mbs trace of format {FORMAT:?}: {e}"))?;
    if recorded.spec.every == 0 || recorded.records.is_empty() {
        return Err("a trace with no records or every = 0".into());
    }
    if recorded.spec.states && recorded.records.iter().any(|r| r.state.is_none()) {
        return Err("a trace that keeps states has a record without one".into());
    }
    Ok(recorded)
}

/// What `mbs digest --check` found.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// Every record matches: their number and the last step.
    Matches(usize, u64),
    /// Where this run parts from the trace, and what differs.
    Mismatch(String),
}

/// Re-runs `recorded` (as `run`, which it describes) with an optional
/// `nudge` and compares every record; at the first mismatch, locates it
/// (see [`locate`]). A trace that starts after step 0 with states starts
/// from its first record's state instead of re-running from the bed.
pub fn check(run: &TraceRun, recorded: &Trace, nudge: Option<Nudge>) -> Result<Verdict, RunError> {
    with_sim(
        run.spec.precision,
        run.capacity,
        Checking {
            run,
            recorded,
            nudge,
        },
    )
}

struct Checking<'a> {
    run: &'a TraceRun,
    recorded: &'a Trace,
    nudge: Option<Nudge>,
}

fn decode<R: Real, const N: usize>(state: &str, sim: &mut HostSim<R, N>) -> Result<(), String> {
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(state)
        .map_err(|e| format!("not base64: {e}"))?;
    sim.restore(&bytes).map_err(|e| e.to_string())
}

impl SimJob for Checking<'_> {
    type Output = Result<Verdict, RunError>;

    fn run<R: Real, const N: usize>(self, sim: &mut HostSim<R, N>) -> Self::Output {
        let (run, records) = (self.run, &self.recorded.records);
        let first = &records[0];
        match &first.state {
            Some(state) if self.recorded.spec.from > 0 => {
                let refuse =
                    |why: String| RunError::State(format!("its first record's state: {why}"));
                decode(state, sim).map_err(refuse)?;
                let flow = run.scenario.flow(run.spec.tau_star);
                let flow = (first.step > run.spec.settle_steps).then_some(&flow);
                check_restored(sim, &run.scenario, flow, first.step)
                    .map_err(|why| refuse(format!("{why} (step {})", first.step)))?;
                if hex(sim.digest()) != first.digest {
                    return Err(refuse("it does not give the record's digest".into()));
                }
            }
            _ => {
                run.scenario.build(sim)?;
            }
        }
        let mut seen = 0;
        let mut verdict = None;
        run.drive(sim, self.nudge, |sim, now| {
            let Some(expected) = records.get(seen) else {
                verdict = Some(Verdict::Mismatch(format!(
                    "this run records step {} after the trace's last record",
                    now.step
                )));
                return false;
            };
            seen += 1;
            if expected.same(&now) {
                return true;
            }
            let before = seen.checked_sub(2).and_then(|k| records.get(k));
            verdict = Some(Verdict::Mismatch(locate(run, sim, expected, &now, before)));
            false
        })?;
        Ok(verdict.unwrap_or_else(|| {
            if seen < records.len() {
                Verdict::Mismatch(format!(
                    "the trace has {} records, this run {seen}",
                    records.len()
                ))
            } else {
                Verdict::Matches(seen, records[seen - 1].step)
            }
        }))
    }
}

/// The report of a mismatch between the trace's record `expected` and this
/// run's `now` (of `sim`'s state), `before` the last matching record: the
/// step and the differing groups; with the trace's state, every grain
/// field that differs with its size in ULPs; and whether this is the first
/// integration step that differs or, if not, the command that records the
/// interval densely on the reference build to find it.
fn locate<R: Real, const N: usize>(
    run: &TraceRun,
    sim: &HostSim<R, N>,
    expected: &Record,
    now: &Record,
    before: Option<&Record>,
) -> String {
    let mut out = String::new();
    if (expected.step, &expected.phase) != (now.step, &now.phase) {
        return format!(
            "record at step {} ({}) is at step {} ({}) in this run",
            expected.step, expected.phase, now.step, now.phase
        );
    }
    let groups: Vec<String> = FieldGroup::ALL
        .iter()
        .map(|g| g.name())
        .filter(|name| expected.groups.get(*name) != now.groups.get(*name))
        .map(|name| {
            format!(
                "{name} (trace {}, now {})",
                expected.groups.get(name).map_or("none", String::as_str),
                now.groups.get(name).map_or("none", String::as_str)
            )
        })
        .collect();
    let _ = write!(
        out,
        "first mismatch at integration step {} ({} phase): digest trace {}, now {}; differing groups: {}",
        expected.step,
        expected.phase,
        expected.digest,
        now.digest,
        if groups.is_empty() { "none (only the full digest)".into() } else { groups.join(", ") }
    );
    match before {
        Some(b) if b.step + 1 == expected.step => {
            let _ = write!(
                out,
                "\nthe runs part at integration step {}: the states after {} steps are equal, after {} they are not",
                expected.step, b.step, expected.step
            );
        }
        Some(b) => {
            let mut config = run
                .spec
                .config
                .as_deref()
                .map_or(String::new(), |c| format!("{c} "));
            for set in &run.spec.overrides {
                config.push_str(&format!("--set '{set}' "));
            }
            let precision = match run.spec.precision {
                Precision::F32 => "f32",
                Precision::F64 => "f64",
            };
            let _ = write!(
                out,
                "\nthe runs part between integration steps {} (equal) and {}; to find the first step that differs, record that interval on the reference build and check it here:\n  mbs digest {config}--steps {} --flow-steps {} --precision {precision} --tau {} --trace dense.json --every 1 --from {} --until {} --states\n  mbs digest --check dense.json",
                b.step, expected.step, run.spec.settle_steps, run.spec.flow_steps, run.spec.tau_star, b.step, expected.step
            );
        }
        None => {
            let _ = write!(
                out,
                "\nthe first record differs: the initial bed is not the trace's"
            );
        }
    }
    if let Some(state) = &expected.state {
        let mut reference = boxed_sim::<R, N, NEIGHBOURS>();
        match decode(state, &mut reference) {
            Ok(()) => out.push_str(&differences(&reference, sim)),
            Err(e) => {
                let _ = write!(out, "\nthe trace's state at this step cannot be read: {e}");
            }
        }
    }
    out
}

/// "1 grain" or "3 grains".
fn count(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// Every grain field of `now` that differs from `reference`, with the
/// size of the difference (in ULPs of the working precision and absolute),
/// the first [`LISTED`] in grain order; and the contacts that differ.
fn differences<R: Real, const N: usize>(reference: &HostSim<R, N>, now: &HostSim<R, N>) -> String {
    let mut out = String::new();
    if reference.len() != now.len() {
        let _ = write!(
            out,
            "\ngrains: trace {}, now {}",
            reference.len(),
            now.len()
        );
    }
    let mut differing = Vec::new();
    for i in 0..reference.len().min(now.len()) {
        for f in GrainField::ALL {
            let (Some(a), Some(b)) = (reference.field(i, f), now.field(i, f)) else {
                continue;
            };
            if R::canonical_bits(a) != R::canonical_bits(b) {
                differing.push((i, f, a, b));
            }
        }
    }
    let grains = {
        let mut g: Vec<usize> = differing.iter().map(|d| d.0).collect();
        g.dedup();
        g.len()
    };
    let _ = write!(
        out,
        "\n{} in {}{}",
        count(
            differing.len(),
            "grain value differs",
            "grain values differ"
        ),
        count(grains, "grain", "grains"),
        if differing.len() > LISTED {
            format!(" (the first {LISTED} listed)")
        } else {
            String::new()
        }
    );
    for &(i, f, a, b) in differing.iter().take(LISTED) {
        let _ = write!(
            out,
            "\n  grain {i} {}: trace {:e}, now {:e} ({:+} ULP, difference {:e})",
            f.name(),
            a.to_f64(),
            b.to_f64(),
            b.ordinal().wrapping_sub(a.ordinal()),
            b.to_f64() - a.to_f64()
        );
    }
    let springs = |sim: &HostSim<R, N>| -> BTreeMap<(usize, usize), (u64, u64)> {
        sim.contacts()
            .map(|(i, j, s)| ((i, j), (R::canonical_bits(s.e_n), R::canonical_bits(s.e_s))))
            .collect()
    };
    let (a, b) = (springs(reference), springs(now));
    let differ = a
        .keys()
        .chain(b.keys())
        .filter(|k| a.get(k) != b.get(k))
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    let _ = write!(
        out,
        "\ncontacts: trace {}, now {}; {differ} pairs differ (present in one only, or another spring)",
        a.len(),
        b.len()
    );
    if reference.bed_level().to_bits() != now.bed_level().to_bits() {
        let _ = write!(
            out,
            "\nbed level: trace {:e}, now {:e}",
            reference.bed_level(),
            now.bed_level()
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_fits_its_bound() {
        let widest = |state: Option<String>| Record {
            step: u64::MAX,
            phase: "settle".into(),
            digest: hex(u64::MAX),
            groups: FieldGroup::ALL
                .iter()
                .map(|g| (g.name().to_string(), hex(u64::MAX)))
                .collect(),
            state,
        };
        let trace = |n: usize, record: &Record| Trace {
            format: FORMAT.into(),
            program: BTreeMap::new(),
            target: String::new(),
            step_path: String::new(),
            scenario_hash: String::new(),
            spec: TraceSpec {
                config: None,
                overrides: Vec::new(),
                tau_star: 0.0,
                settle_steps: 0,
                flow_steps: 0,
                every: 1,
                from: u64::MAX,
                until: u64::MAX,
                states: record.state.is_some(),
                precision: Precision::F64,
            },
            step_dt_s: 0.0,
            records: vec![record.clone(); n],
        };
        let len = |n, record: &Record| to_text(&trace(n, record)).unwrap().len() as u64;
        let plain = widest(None);
        let record = len(2, &plain) - len(1, &plain);
        assert!(record <= MAX_RECORD_BYTES, "{record} bytes");
        assert!(len(1, &plain) - record < 2048);
        // With the largest state of the golden run's 55 grains.
        let bytes = checkpoint_len(Precision::F64, 55, 55 * NEIGHBOURS);
        let state = base64::engine::general_purpose::STANDARD.encode(vec![0xff; bytes]);
        let full = widest(Some(state));
        let record = len(2, &full) - len(1, &full);
        assert!(
            record <= MAX_RECORD_BYTES + (bytes as u64).div_ceil(3) * 4,
            "{record} bytes"
        );
    }
}
