//! The coupled golden run on RV32IMAC: `Scenario::paper_coupled()` (the
//! paper's bed, the coupled flow in a column of 100 cells), 2 000 settling
//! and 2 000 flow steps in `.bss`, in f32 (`--features f64` for f64), then
//! exits 0 (docs/board.md). Compare with
//! `mbs digest --steps 2000 --precision f32 --set flow.model=coupled --set fluid.cell_d=4`.
#![no_std]
#![no_main]

use firmware_riscv::Float;
use mbs_kernel::{Scenario, Sim};

/// The simulation, in `.bss` (all zero bits), never on the stack: the
/// paper's 55 grains and the column's cells.
static mut SIM: Sim<Float, 64, 8, { Scenario::PAPER_COUPLED_CELLS }> = Sim::new();

#[riscv_rt::entry]
fn main() -> ! {
    // SAFETY: the only reference to SIM, taken once.
    let sim = unsafe { &mut *core::ptr::addr_of_mut!(SIM) };
    firmware_riscv::run(sim, &Scenario::paper_coupled(), golden::STEPS, false)
}
