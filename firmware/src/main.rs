//! Runs `Scenario::paper()` (settling, then flow) in static storage by the
//! phased step cut into ranges ([`golden::run_phased`]) and by the step,
//! prints the state digests after each phase over semihosting, then the
//! living bed's trace ([`golden::trace`]), then exits 0.
//! Any kernel error, panic or hard fault exits 1. Compare with
//! `mbs digest --steps 2000 --precision f32|f64` on the host.
#![no_std]
#![no_main]

use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::debug;
#[cfg(phased)]
use cortex_m_semihosting::hprintln;
use firmware::Float;
#[cfg(phased)]
use mbs_kernel::Phases;
use mbs_kernel::{Scenario, Sim};
use panic_semihosting as _;

#[entry]
fn main() -> ! {
    // A `static mut` of the entry function: cortex-m-rt hands it out once
    // as `&'static mut`, and its const initialiser (all zero bits) puts it
    // in .bss. (`cortex_m::singleton!` built the value on the stack first,
    // which overlaps .bss when the simulation is larger than the stack.)
    static mut SIM: Sim<Float, 64, 8> = Sim::new();
    let sim: &'static mut Sim<Float, 64, 8> = SIM;
    let peripherals = cortex_m::Peripherals::take().expect("first and only call");
    // The phased step first, cut into ranges on this core: the same
    // digests as the step (`.ci/firmware` compares both with the host's).
    // Not on the Cortex-M0: its buffers do not fit beside the simulation.
    #[cfg(phased)]
    {
        static mut PHASES: Phases<Float, 64, 8> = Phases::new();
        // SAFETY: the only reference to PHASES, made once, in the entry
        // function that runs once.
        let phases = unsafe { &mut *core::ptr::addr_of_mut!(PHASES) };
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
