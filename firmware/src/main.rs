//! Runs `Scenario::paper()` (settling, then flow) in static storage by the
//! phased step cut into ranges ([`golden::run_phased`]) and by the step,
//! prints the state digests after each phase over semihosting, then the
//! living bed's trace ([`golden::trace`]), then exits 0.
//! Any kernel error, panic or hard fault exits 1. Compare with
//! `mbs digest --steps 2000 --precision f32|f64` on the host.
#![no_std]
#![no_main]

use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hprintln};
use firmware::Float;
use mbs_kernel::{Phases, Scenario, Sim};
use panic_semihosting as _;

#[entry]
fn main() -> ! {
    // A `static mut` of the entry function: cortex-m-rt hands it out once
    // as `&'static mut`, and its const initialiser (all zero bits) puts it
    // in .bss. (`cortex_m::singleton!` built the value on the stack first,
    // which overlaps .bss when the simulation is larger than the stack.)
    static mut SIM: Sim<Float, 64, 8> = Sim::new();
    static mut PHASES: Phases<Float, 64, 8> = Phases::new();
    let sim: &'static mut Sim<Float, 64, 8> = SIM;
    let phases: &'static mut Phases<Float, 64, 8> = PHASES;
    let peripherals = cortex_m::Peripherals::take().expect("first and only call");
    // The phased step first, cut into ranges on this core: the same
    // digests as the step (`.ci/firmware` compares both with the host's).
    match golden::run_phased(sim, phases, &Scenario::paper(), golden::STEPS) {
        Ok((settled, flow)) => {
            hprintln!("phased settling {:#018x}", settled);
            hprintln!("phased flow {:#018x}", flow);
        }
        Err(e) => {
            hprintln!("error: {}", e);
            debug::exit(debug::EXIT_FAILURE);
        }
    }
    firmware::run(
        sim,
        &Scenario::paper(),
        golden::STEPS,
        true,
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
