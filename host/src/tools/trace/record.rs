//! Recording a trace: the digest run driven from record to record (with an
//! optional nudge), each record's digests and state, and the trace's
//! metadata.

use super::format::{hex, FORMAT};
use super::{Nudge, Record, RunError, Trace, TraceRun, TraceSpec};
use crate::sim::sims::{with_sim, HostSim, SimJob};
use base64::Engine;
use mbs_kernel::{FieldGroup, Fnv1a, Real};
use std::collections::BTreeMap;

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

impl TraceRun {
    /// The last step run.
    pub(super) fn end(&self) -> u64 {
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
    pub(super) fn drive<R: Real, const N: usize>(
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

/// The step path this build runs.
pub fn step_path() -> &'static str {
    if cfg!(all(target_arch = "x86_64", target_feature = "avx2")) {
        "batched"
    } else {
        "scalar"
    }
}
