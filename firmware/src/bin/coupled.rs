//! The coupled golden run on the Cortex-M4F: `Scenario::paper_coupled()`
//! (the paper's bed, the coupled flow in a column of 100 cells), 2 000
//! settling and 2 000 flow steps in `.bss`, in f32 (`--features f64` for
//! f64), then exits 0 (docs/board.md). Built with `--features coupled` (the
//! Cortex-M0's 16 KiB hold no column). Host side:
//! `mbs digest --steps 2000 --precision f32 --set flow.model=coupled --set fluid.cell_d=4`.
#![no_std]
#![no_main]

use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::debug;
use firmware::Float;
use mbs_kernel::{Scenario, Sim};
use panic_semihosting as _;

/// The simulation: the paper's 55 grains and the column's cells.
type CoupledSim = Sim<Float, 64, 8, { Scenario::PAPER_COUPLED_CELLS }>;

#[entry]
fn main() -> ! {
    // In .bss, never on the stack (src/main.rs).
    static mut SIM: CoupledSim = Sim::new();
    let sim: &'static mut CoupledSim = SIM;
    let peripherals = cortex_m::Peripherals::take().expect("first and only call");
    firmware::run(
        sim,
        &Scenario::paper_coupled(),
        golden::STEPS,
        false,
        peripherals.SYST,
    )
}

#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
