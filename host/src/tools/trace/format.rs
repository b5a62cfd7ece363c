//! The trace file format: its name and version, the bounds on a trace's
//! size, and the text of a trace file (written with a checksum, parsed and
//! verified).

use super::{Trace, TraceRun};
use crate::io::input::Bound;
use crate::sim::sims::{checkpoint_len, NEIGHBOURS};

/// The trace format's name and version (the `format` field).
pub const FORMAT: &str = "mbs-trace 3";

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

/// The longest trace file: `MAX_TRACE_BYTES` of records and 64 KiB for
/// the rest (the configuration's path included).
pub const TRACE_BOUND: Bound = Bound {
    bytes: MAX_TRACE_BYTES + (64 << 10),
    reason: "the largest trace (100000 records of at most 1 KiB, or fewer with states)",
};

pub(super) fn hex(x: u64) -> String {
    format!("{x:#018x}")
}

impl TraceRun {
    /// At most the records this run writes: step `from`, then every
    /// `every` steps, and the end of each phase.
    pub fn max_records(&self) -> u64 {
        let span = self.end().saturating_sub(self.spec.from);
        3 + span.div_ceil(self.spec.every.max(1))
    }

    /// At most the bytes of this run's records: `MAX_RECORD_BYTES` each,
    /// and with states the base64 of the bed's largest kernel checkpoint
    /// (every grain with every neighbour slot a contact).
    pub fn max_bytes(&self) -> u64 {
        let bed = &self.scenario.bed;
        let grains = bed.grains();
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

#[cfg(test)]
mod tests {
    use super::super::{Record, TraceSpec};
    use super::*;
    use crate::config::Precision;
    use base64::Engine;
    use mbs_kernel::FieldGroup;
    use std::collections::BTreeMap;

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
                configuration: String::new(),
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
