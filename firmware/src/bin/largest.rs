//! The largest f32 bed that fits in the board's RAM: the paper's grains,
//! `COLUMNS` × `ROWS` over `COLUMNS` fixed grains, in `.bss`, settling then
//! flow (docs/board.md):
//! - Cortex-M4F, 128 KiB (top-level memory.x): 64 × 12, 832 grains,
//!   `Sim<f32, 832, 6>`. Host side:
//!   `mbs digest firmware/largest.toml --steps 1000 --precision f32`.
//! - Cortex-M0, 16 KiB (memory-thumbv6m.x): 7 × 10, 77 grains,
//!   `Sim<f32, 77, 6>`. Host side:
//!   `mbs digest firmware/largest-thumbv6m.toml --steps 1000 --precision f32`.
#![no_std]
#![no_main]

use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::debug;
use mbs_kernel::Sim;
use panic_semihosting as _;

/// Columns of the bed (the M4F is the board with the FPU, `eabihf`).
const COLUMNS: u32 = if cfg!(target_abi = "eabihf") { 64 } else { 7 };
/// Rows of the bed.
const ROWS: u32 = if cfg!(target_abi = "eabihf") { 12 } else { 10 };
/// Grain capacity: the bed's grains.
const GRAINS: usize = (COLUMNS * (ROWS + 1)) as usize;
/// Neighbour slots per grain (6 suffice in a settled 2-D bed of equal grains).
const SLOTS: usize = 6;
/// Steps of each phase.
const STEPS: u64 = 1000;

#[entry]
fn main() -> ! {
    // A `static mut` of the entry function: cortex-m-rt hands it out once
    // as `&'static mut`, and its const initialiser (all zero bits) puts it
    // in .bss. (`cortex_m::singleton!` built the value on the stack first,
    // which overlaps .bss when the simulation is larger than the stack.)
    static mut SIM: Sim<f32, GRAINS, SLOTS> = Sim::new();
    let sim: &'static mut Sim<f32, GRAINS, SLOTS> = SIM;
    let peripherals = cortex_m::Peripherals::take().expect("first and only call");
    firmware::run(
        sim,
        &golden::bed(COLUMNS, ROWS),
        STEPS,
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
