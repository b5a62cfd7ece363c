//! Digest traces (`mbs digest --trace FILE --every K`): the digest of the
//! digest run every K integration steps with separate digests of its
//! field groups, and the metadata needed to compare two traces. The format
//! is in docs/determinism.md ("Traces").

use crate::config::Precision;
use crate::input::Bound;
use crate::sims::{with_sim, SimJob, NEIGHBOURS};
use mbs_kernel::{FieldGroup, Fnv1a, Real, Scenario, Sim};
use serde::Serialize;
use std::collections::BTreeMap;

/// The trace format's name and version (the `format` field).
pub const FORMAT: &str = "mbs-trace 1";

/// The most records a trace holds (`mbs digest --trace` refuses an `--every`
/// that would give more): far more than a comparison needs.
pub const MAX_RECORDS: u64 = 100_000;

/// The most bytes one record takes in a trace file (test
/// `a_record_fits_its_bound`).
const MAX_RECORD_BYTES: u64 = 1024;

/// The longest trace file: [`MAX_RECORDS`] records and 64 KiB for the rest
/// (the configuration's path included).
pub const TRACE_BOUND: Bound = Bound {
    bytes: MAX_RECORDS * MAX_RECORD_BYTES + (64 << 10),
    reason: "the largest trace (100000 records of at most 1 KiB)",
};

/// What a trace records: the digest run of `scenario` (`settle_steps`
/// without flow, then `flow_steps` at `tau_star`), every `every` steps.
#[derive(Debug, Clone)]
pub struct TraceRun {
    /// The scenario (configuration and seed).
    pub scenario: Scenario,
    /// The configuration file, or `None` for the golden run.
    pub config: Option<String>,
    /// Shields number of the flow phase.
    pub tau_star: f64,
    /// Steps without flow.
    pub settle_steps: u64,
    /// Steps under the flow.
    pub flow_steps: u64,
    /// Steps between records (> 0).
    pub every: u64,
    /// Working precision.
    pub precision: Precision,
    /// Grain capacity (as [`crate::Config::capacity`]).
    pub capacity: usize,
}

/// One record: the integration step, the phase, the full digest and each
/// field group's (hexadecimal, `0x` and 16 digits).
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
}

fn hex(x: u64) -> String {
    format!("{x:#018x}")
}

fn record<R: Real, const N: usize>(sim: &Sim<R, N, NEIGHBOURS>, phase: &str) -> Record {
    Record {
        step: sim.step_count(),
        phase: phase.into(),
        digest: hex(sim.digest()),
        groups: FieldGroup::ALL
            .iter()
            .map(|&g| (g.name().to_string(), hex(sim.group_digest(g))))
            .collect(),
    }
}

impl SimJob for &TraceRun {
    type Output = Result<Vec<Record>, mbs_kernel::Error>;

    fn run<R: Real, const N: usize>(self, sim: &mut Sim<R, N, NEIGHBOURS>) -> Self::Output {
        self.scenario.build(sim)?;
        let mut records = vec![record(sim, "settle")];
        let every = self.every.max(1);
        let flow = self.scenario.flow(self.tau_star);
        for (phase, steps) in [("settle", self.settle_steps), ("flow", self.flow_steps)] {
            if phase == "flow" {
                sim.set_flow(Some(&flow))?;
            }
            let end = sim.step_count().saturating_add(steps);
            while sim.step_count() < end {
                let next = (sim.step_count() / every + 1).saturating_mul(every);
                sim.run(next.min(end) - sim.step_count())?;
                records.push(record(sim, phase));
            }
        }
        Ok(records)
    }
}

/// The metadata and records of a trace (its body, which the checksum covers).
#[derive(Debug, Clone, Serialize)]
pub struct Trace {
    /// [`FORMAT`].
    pub format: &'static str,
    /// Program name, version and git commit (null when unknown).
    pub program: BTreeMap<&'static str, Option<String>>,
    /// The target triple the program was built for.
    pub target: &'static str,
    /// `f32` or `f64`.
    pub precision: Precision,
    /// `batched` (x86-64 AVX2 lanes) or `scalar`.
    pub step_path: &'static str,
    /// FNV-1a of the scenario's description (configuration, seed, τ*,
    /// steps), hexadecimal.
    pub scenario_hash: String,
    /// The configuration file, or null for the golden run.
    pub config: Option<String>,
    /// Shields number of the flow phase.
    pub tau_star: f64,
    /// Steps without flow.
    pub settle_steps: u64,
    /// Steps under the flow.
    pub flow_steps: u64,
    /// Steps between records.
    pub every: u64,
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

impl TraceRun {
    /// At most the records this run writes: step 0, then every `every` steps
    /// and at the end of each phase.
    pub fn max_records(&self) -> u64 {
        let every = self.every.max(1);
        2 + self.settle_steps.div_ceil(every) + self.flow_steps.div_ceil(every)
    }

    /// FNV-1a of the scenario, τ* and step counts (their `Debug` text:
    /// shortest round-trip floats, the same on every machine).
    pub fn scenario_hash(&self) -> u64 {
        let text = format!(
            "{:?} tau* {:?} settle {} flow {}",
            self.scenario, self.tau_star, self.settle_steps, self.flow_steps
        );
        Fnv1a::of(text.as_bytes())
    }

    /// Runs the trace.
    pub fn run(&self) -> Result<Trace, mbs_kernel::Error> {
        let records = with_sim(self.precision, self.capacity, self)?;
        Ok(Trace {
            format: FORMAT,
            program: BTreeMap::from([
                ("name", Some("mbs".into())),
                ("version", Some(env!("CARGO_PKG_VERSION").into())),
                ("commit", option_env!("MBS_GIT_COMMIT").map(Into::into)),
            ]),
            target: env!("MBS_TARGET"),
            precision: self.precision,
            step_path: step_path(),
            scenario_hash: hex(self.scenario_hash()),
            config: self.config.clone(),
            tau_star: self.tau_star,
            settle_steps: self.settle_steps,
            flow_steps: self.flow_steps,
            every: self.every,
            step_dt_s: self.scenario.step_dt(),
            records,
        })
    }
}

/// The trace file's text: `{"body": …, "checksum": "0x…"}`, the checksum
/// FNV-1a of the body's compact JSON (keys sorted).
pub fn to_text(trace: &Trace) -> serde_json::Result<String> {
    let body = serde_json::to_value(trace)?;
    let checksum = Fnv1a::of(serde_json::to_string(&body)?.as_bytes());
    let file = serde_json::json!({ "body": body, "checksum": hex(checksum) });
    let mut text = serde_json::to_string_pretty(&file)?;
    text.push('\n');
    Ok(text)
}

/// A trace file read back: what to re-run and the records to compare.
#[derive(Debug, Clone, serde::Deserialize)]
pub struct Recorded {
    /// [`Trace::format`].
    pub format: String,
    /// [`Trace::scenario_hash`].
    pub scenario_hash: String,
    /// [`Trace::config`].
    pub config: Option<String>,
    /// [`Trace::precision`].
    pub precision: Precision,
    /// [`Trace::tau_star`].
    pub tau_star: f64,
    /// [`Trace::settle_steps`].
    pub settle_steps: u64,
    /// [`Trace::flow_steps`].
    pub flow_steps: u64,
    /// [`Trace::every`].
    pub every: u64,
    /// [`Trace::records`].
    pub records: Vec<Record>,
}

/// Reads a trace file's text: its body, if the text is a trace of this
/// format whose checksum matches; else why not (a damaged, edited,
/// truncated or foreign file).
pub fn parse(text: &str) -> Result<Recorded, String> {
    let file: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| format!("not a JSON trace (damaged or truncated?): {e}"))?;
    let (Some(body), Some(checksum)) = (file.get("body"), file.get("checksum")) else {
        return Err("not an mbs trace: no \"body\" and \"checksum\"".into());
    };
    let compact = serde_json::to_string(body).map_err(|e| e.to_string())?;
    let computed = hex(Fnv1a::of(compact.as_bytes()));
    if checksum.as_str() != Some(computed.as_str()) {
        return Err(format!(
            "checksum mismatch: the file says {checksum}, its body hashes to {computed} (edited or damaged)"
        ));
    }
    let recorded: Recorded = serde_json::from_value(body.clone())
        .map_err(|e| format!("not an mbs trace of format {FORMAT:?}: {e}"))?;
    if recorded.format != FORMAT {
        return Err(format!(
            "trace format {:?}; this program reads {FORMAT:?}",
            recorded.format
        ));
    }
    if recorded.every == 0 || recorded.records.is_empty() {
        return Err("a trace with no records or every = 0".into());
    }
    Ok(recorded)
}

/// The first record of `recorded` that `now` does not reproduce: its step,
/// phase and the groups that differ (or a note that the runs have different
/// records). `None` when every record matches.
pub fn first_mismatch(recorded: &[Record], now: &[Record]) -> Option<String> {
    for (a, b) in recorded.iter().zip(now) {
        if a == b {
            continue;
        }
        if (a.step, &a.phase) != (b.step, &b.phase) {
            return Some(format!(
                "record at step {} ({}) is at step {} ({}) in this run",
                a.step, a.phase, b.step, b.phase
            ));
        }
        let groups: Vec<String> = FieldGroup::ALL
            .iter()
            .map(|g| g.name())
            .filter(|name| a.groups.get(*name) != b.groups.get(*name))
            .map(|name| {
                format!(
                    "{name} (trace {}, now {})",
                    a.groups.get(name).map_or("none", String::as_str),
                    b.groups.get(name).map_or("none", String::as_str)
                )
            })
            .collect();
        return Some(format!(
            "first mismatch at integration step {} ({} phase): digest trace {}, now {}; differing groups: {}",
            a.step,
            a.phase,
            a.digest,
            b.digest,
            if groups.is_empty() { "none (only the full digest)".into() } else { groups.join(", ") }
        ));
    }
    (recorded.len() != now.len()).then(|| {
        format!(
            "the trace has {} records, this run {}",
            recorded.len(),
            now.len()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_fits_its_bound() {
        let widest = Record {
            step: u64::MAX,
            phase: "settle".into(),
            digest: hex(u64::MAX),
            groups: FieldGroup::ALL
                .iter()
                .map(|g| (g.name().to_string(), hex(u64::MAX)))
                .collect(),
        };
        let trace = |n: usize| Trace {
            format: FORMAT,
            program: BTreeMap::new(),
            target: "",
            precision: Precision::F64,
            step_path: "",
            scenario_hash: String::new(),
            config: None,
            tau_star: 0.0,
            settle_steps: 0,
            flow_steps: 0,
            every: 1,
            step_dt_s: 0.0,
            records: vec![widest.clone(); n],
        };
        let len = |n| to_text(&trace(n)).unwrap().len() as u64;
        let record = len(2) - len(1);
        assert!(record <= MAX_RECORD_BYTES, "{record} bytes");
        assert!(len(1) - record < 2048);
    }
}
