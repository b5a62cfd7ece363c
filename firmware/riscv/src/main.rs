//! Runs `Scenario::paper()` (settling, then flow) in static storage and
//! prints the state digest after each phase over semihosting, then exits 0.
//! Any kernel error, panic or exception exits 1. Compare with
//! `mbs digest --steps 2000 --precision f32|f64` on the host.
#![no_std]
#![no_main]

use firmware_riscv::Float;
use mbs_kernel::{Scenario, Sim};

/// The simulation, in `.bss` (all zero bits), never on the stack.
static mut SIM: Sim<Float, 64, 8> = Sim::new();

#[riscv_rt::entry]
fn main() -> ! {
    // SAFETY: the only reference to SIM, taken once.
    let sim = unsafe { &mut *core::ptr::addr_of_mut!(SIM) };
    firmware_riscv::run(sim, &Scenario::paper(), golden::STEPS, true)
}
