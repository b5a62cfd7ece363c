//! The largest f32 bed that fits in the 128 KiB of RAM of `memory.x`:
//! `Sim<f32, 832, 6>` (148 B per grain) in `.bss`, a 64-column × 12-row bed
//! of the paper's grains over 64 fixed grains (832 grains), settling then
//! flow. Compare with `mbs digest largest.toml --steps 1000 --precision f32`.
#![no_std]
#![no_main]

use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::debug;
use mbs_kernel::{BedSpec, Scenario, Sim};
use panic_semihosting as _;

/// Grain capacity: (128 KiB − stack and statics) / 148 B.
const GRAINS: usize = 832;
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
    let scenario = Scenario {
        bed: BedSpec::uniform(0.5e-3, 64, 12),
        ..Scenario::paper()
    };
    firmware::run(sim, &scenario, STEPS, peripherals.SYST)
}

#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
