//! The golden run, shared by every board and runner in `firmware/`: build
//! a scenario's bed, settle it, run it under the flow, and report the state
//! digest after each phase in the lines `mbs digest` prints (`settled 0x…`,
//! `flow 0x…`), so that a run on any target compares with the host's bit
//! for bit (docs/board.md).
#![no_std]

use core::fmt;
use mbs_kernel::{BedSpec, Error, Real, Scenario, Sim};

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

/// The report's lines; the `settled` and `flow` ones are those of
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
        writeln!(f, "settled {:#018x}", self.settled)?;
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
/// step.
pub fn run<R: Real, const N: usize, const K: usize>(
    sim: &mut Sim<R, N, K>,
    scenario: &Scenario,
    steps: u64,
    meter: &mut impl Meter,
) -> Result<Report, Error> {
    scenario.build(sim)?;
    let mut cost = 0;
    let mut phase = |sim: &mut Sim<R, N, K>| -> Result<u64, Error> {
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
