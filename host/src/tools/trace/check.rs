//! Checking a trace: re-running it (from the bed, or from its first
//! record's state) and comparing every record; at the first mismatch,
//! locating it: the differing field groups, grain values and contacts, and
//! the command that narrows the interval down.

use super::format::hex;
use super::{Nudge, Record, RunError, Trace, TraceRun, Verdict};
use crate::config::Precision;
use crate::io::text::shell_word;
use crate::sim::sims::{boxed_sim, check_restored, with_sim, HostSim, SimJob, NEIGHBOURS};
use base64::Engine;
use mbs_kernel::{FieldGroup, GrainField, Real};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// Grain values a mismatch report lists at most.
const LISTED: usize = 12;

impl Record {
    /// The same step, phase and digests (the state aside).
    fn same(&self, other: &Record) -> bool {
        (self.step, &self.phase, &self.digest, &self.groups)
            == (other.step, &other.phase, &other.digest, &other.groups)
    }
}

/// Re-runs `recorded` (as `run`, which it describes) with an optional
/// `nudge` and compares every record; at the first mismatch, locates it
/// (see `locate`). A trace that starts after step 0 with states starts
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
                .map_or(String::new(), |c| format!("{} ", shell_word(c)));
            for set in &run.spec.overrides {
                config.push_str(&format!("--set {} ", shell_word(set)));
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
