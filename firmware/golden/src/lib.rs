//! The golden run, shared by every board and runner in `firmware/`: build
//! a scenario's bed, settle it, run it under the flow, and report the state
//! digest after each phase in the lines `mbs digest` prints (`settling 0x…`,
//! `flow 0x…`); then the living bed's trace ([`trace`]): so that a run on
//! any target compares with the host's bit for bit (docs/board.md).
#![no_std]

use core::fmt;
use mbs_kernel::{BedSpec, Error, FieldGroup, Phases, Ranges, Real, Scenario, Sim};

/// Steps of each phase of the paper's run (`mbs digest`'s default).
pub const STEPS: u64 = 2000;

/// The paper's case on a bed of `columns` × `rows` grains over `columns`
/// fixed grains (`columns × (rows + 1)` grains): what `[bed] columns` and
/// `rows` give `mbs digest`. A board's largest bed is one of these.
pub fn bed(columns: u32, rows: u32) -> Scenario {
    Scenario {
        bed: BedSpec::uniform(0.5e-3, columns, rows),
        ..Scenario::paper()
    }
}

/// A target's cost counter: a count that only grows (instructions, clock
/// ticks or nanoseconds, as the target can).
pub trait Meter {
    /// The count now.
    fn now(&mut self) -> u64;
}

/// What a golden run reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Report {
    /// `f32` or `f64`.
    pub precision: &'static str,
    /// Grains in the bed.
    pub grains: usize,
    /// Grain capacity N of the simulation.
    pub capacity: usize,
    /// Neighbour slots K per grain.
    pub slots: usize,
    /// Steps run, both phases.
    pub steps: u64,
    /// State digest after settling.
    pub settled: u64,
    /// State digest after the flow phase.
    pub flow: u64,
    /// The meter's count over the steps alone.
    pub cost: u64,
}

impl Report {
    /// Grain-steps run: grains × steps.
    pub fn grain_steps(&self) -> u64 {
        self.grains as u64 * self.steps
    }
}

/// The report's lines; the `settling` and `flow` ones are those of
/// `mbs digest`.
impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "precision {}", self.precision)?;
        writeln!(
            f,
            "grains {} (capacity {}, neighbour slots {})",
            self.grains, self.capacity, self.slots
        )?;
        writeln!(f, "steps {}", self.steps)?;
        writeln!(f, "settling {:#018x}", self.settled)?;
        write!(f, "flow {:#018x}", self.flow)
    }
}

/// Peak stack use, measured by painting: the stack is filled with
/// [`stack::PAINT`] before the run (at reset, or by [`stack::paint`]), and
/// the lowest word no longer holding it is the deepest the stack reached.
pub mod stack {
    /// The paint, cortex-m-rt's `STACK_PAINT_VALUE`.
    pub const PAINT: u32 = 0xcccc_cccc;

    /// Fills the words from `bottom` up to `top` with [`PAINT`].
    ///
    /// # Safety
    /// `bottom..top` is word-aligned RAM that nothing uses: the stack below
    /// the stack pointer, less a margin for this function's own frame.
    pub unsafe fn paint(bottom: usize, top: usize) {
        let mut word = bottom;
        while word < top {
            // SAFETY: the caller's promise.
            unsafe { core::ptr::write_volatile(word as *mut u32, PAINT) };
            word += 4;
        }
    }

    /// Bytes of stack used: from `top` (the stack's start, its highest
    /// address) down to the lowest word above `bottom` that no longer
    /// holds [`PAINT`].
    ///
    /// # Safety
    /// `bottom..top` is the word-aligned RAM of a stack painted from
    /// `bottom`.
    pub unsafe fn used(bottom: usize, top: usize) -> usize {
        let mut deepest = bottom;
        // SAFETY: the caller's promise; reads only.
        while deepest < top && unsafe { core::ptr::read_volatile(deepest as *const u32) } == PAINT {
            deepest += 4;
        }
        top - deepest
    }
}

/// Builds `scenario`'s bed in `sim`, runs `steps` settling steps, switches
/// the flow on at the paper's τ* and runs `steps` flow steps, metering each
/// step. A coupled scenario ([`Scenario::paper_coupled`]) needs a fluid
/// capacity `C` of at least its column's cells.
pub fn run<R: Real, const N: usize, const K: usize, const C: usize>(
    sim: &mut Sim<R, N, K, C>,
    scenario: &Scenario,
    steps: u64,
    meter: &mut impl Meter,
) -> Result<Report, Error> {
    scenario.build(sim)?;
    let mut cost = 0;
    let mut phase = |sim: &mut Sim<R, N, K, C>| -> Result<u64, Error> {
        for _ in 0..steps {
            let start = meter.now();
            sim.step()?;
            cost += meter.now().wrapping_sub(start);
        }
        Ok(sim.digest())
    };
    let settled = phase(sim)?;
    sim.set_flow(Some(&scenario.flow(Scenario::PAPER_TAU_STAR)))?;
    let flow = phase(sim)?;
    Ok(Report {
        precision: R::NAME,
        grains: sim.len(),
        capacity: N,
        slots: K,
        steps: sim.step_count(),
        settled,
        flow,
        cost,
    })
}

/// Ranges a phase of the phased step is cut into by [`run_phased`]: what
/// three host threads would each run, here one after the other.
pub const PHASED_RANGES: usize = 3;

/// [`run`] without the meter, stepping by the phased step
/// ([`Sim::step_phased`]) cut into [`PHASED_RANGES`] ranges on this one
/// core: the digests after settling and after the flow, which equal
/// [`run`]'s and the host's on any number of threads. Printed as
/// `phased settling 0x…` and `phased flow 0x…`.
pub fn run_phased<R: Real, const N: usize, const K: usize, const C: usize>(
    sim: &mut Sim<R, N, K, C>,
    phases: &mut Phases<R, N, K>,
    scenario: &Scenario,
    steps: u64,
) -> Result<(u64, u64), Error> {
    scenario.build(sim)?;
    let ranges = Ranges(PHASED_RANGES);
    let mut phase = |sim: &mut Sim<R, N, K, C>| -> Result<u64, Error> {
        for _ in 0..steps {
            sim.step_phased(phases, &ranges)?;
        }
        Ok(sim.digest())
    };
    let settled = phase(sim)?;
    sim.set_flow(Some(&scenario.flow(Scenario::PAPER_TAU_STAR)))?;
    Ok((settled, phase(sim)?))
}

/// Settling steps of the living bed (tests/golden.rs): its committed
/// settled states are taken after them.
pub const LIVING_SETTLE_STEPS: u64 = 80_000;

/// Shields number of the living bed's flow, where grains saltate.
pub const LIVING_TAU_STAR: f64 = 0.5;

/// Steps between the trace's records.
pub const TRACE_EVERY: u64 = 500;

/// Flow steps of the trace: 2 000 (what CI runs on every target), or
/// `MBS_TRACE_STEPS` at build time (e.g. 400 000, the living bed's whole
/// flow phase). A multiple of [`TRACE_EVERY`] keeps the records the host's.
pub const TRACE_STEPS: u64 = match option_env!("MBS_TRACE_STEPS") {
    Some(text) => parse(text),
    None => 2000,
};

/// A decimal number (a build-time constant: a bad one fails the build).
const fn parse(text: &str) -> u64 {
    let bytes = text.as_bytes();
    let mut i = 0;
    let mut n: u64 = 0;
    while i < bytes.len() {
        assert!(bytes[i].is_ascii_digit(), "MBS_TRACE_STEPS: digits only");
        n = n * 10 + (bytes[i] - b'0') as u64;
        i += 1;
    }
    n
}

/// The paper's bed after [`LIVING_SETTLE_STEPS`] settling steps, as kernel
/// checkpoints (tests/golden/living-settled-f32.ckpt, …-f64.ckpt; the
/// golden test proves them equal to a fresh settle on the host).
const SETTLED_F32: &[u8] = include_bytes!("../../../tests/golden/living-settled-f32.ckpt");
const SETTLED_F64: &[u8] = include_bytes!("../../../tests/golden/living-settled-f64.ckpt");

/// One record of the trace: the line `trace STEP PHASE DIGEST` and the
/// digests of the field groups in [`FieldGroup::ALL`] order, as
/// `.ci/trace-lines.py` writes the records of the host's trace file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Record {
    /// Integration steps since the bed was built.
    pub step: u64,
    /// `settle` (the settled bed) or `flow`.
    pub phase: &'static str,
    /// The state digest.
    pub digest: u64,
    /// The field groups' digests.
    pub groups: [u64; 5],
}

impl fmt::Display for Record {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "trace {} {} {:#018x}",
            self.step, self.phase, self.digest
        )?;
        for g in self.groups {
            write!(f, " {g:#018x}")?;
        }
        Ok(())
    }
}

fn record<R: Real, const N: usize, const K: usize, const C: usize>(
    sim: &Sim<R, N, K, C>,
    phase: &'static str,
) -> Record {
    let mut groups = [0; 5];
    for (g, group) in groups.iter_mut().zip(FieldGroup::ALL) {
        *g = sim.group_digest(group);
    }
    Record {
        step: sim.step_count(),
        phase,
        digest: sim.digest(),
        groups,
    }
}

/// The living bed's trace: restores the committed settled bed, records it,
/// switches the flow on at [`LIVING_TAU_STAR`] and runs `steps` steps,
/// recording every `every` and at the end; hands each record to `out` and
/// returns the meter's count over the steps. The host's
/// `mbs digest --steps 80000 --flow-steps STEPS --tau 0.5 --every EVERY
/// --from 80000 --trace FILE` records the same.
pub fn trace<R: Real, const N: usize, const K: usize, const C: usize>(
    sim: &mut Sim<R, N, K, C>,
    steps: u64,
    every: u64,
    meter: &mut impl Meter,
    mut out: impl FnMut(&Record),
) -> Result<u64, Error> {
    sim.restore(if R::BYTES == 4 {
        SETTLED_F32
    } else {
        SETTLED_F64
    })?;
    out(&record(sim, "settle"));
    sim.set_flow(Some(&Scenario::paper().flow(LIVING_TAU_STAR)))?;
    let end = sim.step_count().saturating_add(steps);
    let mut cost = 0;
    while sim.step_count() < end {
        for _ in 0..every.max(1).min(end - sim.step_count()) {
            let start = meter.now();
            sim.step()?;
            cost += meter.now().wrapping_sub(start);
        }
        out(&record(sim, "flow"));
    }
    Ok(cost)
}
