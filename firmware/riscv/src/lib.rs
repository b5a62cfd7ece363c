//! Shared by the RISC-V binaries: run a scenario from static storage with
//! [`golden::run`], count its instructions with `minstret` and measure its
//! peak stack use, print the report over semihosting.
//!
//! Cost: under `-icount shift=0` QEMU's `minstret` counts the instructions
//! executed, so the printed figure is instructions per grain-step,
//! repeatable run after run.
#![no_std]

use mbs_kernel::{Real, Scenario, Sim};
use riscv_semihosting::{debug, hprintln};

/// The working precision of the board binaries: f32, or f64 with
/// `--features f64`.
#[cfg(not(feature = "f64"))]
pub type Float = f32;
/// The working precision of the board binaries: f32, or f64 with
/// `--features f64`.
#[cfg(feature = "f64")]
pub type Float = f64;

/// `minstret`, the instructions retired.
struct Instret;

impl golden::Meter for Instret {
    fn now(&mut self) -> u64 {
        riscv::register::minstret::read64()
    }
}

extern "C" {
    /// The top of the stack (riscv-rt's link.x).
    static _stack_start: u32;
    /// The bottom of the stack room, the end of the statics (riscv-rt).
    static __estack: u32;
}

/// The stack's room: its bottom and its top.
fn stack_room() -> (usize, usize) {
    (
        core::ptr::addr_of!(__estack) as usize,
        core::ptr::addr_of!(_stack_start) as usize,
    )
}

/// Paints the stack below the stack pointer ([`golden::stack`]), less a
/// margin for the painting itself.
fn paint_stack() {
    let sp: usize;
    // SAFETY: reads the stack pointer.
    unsafe { core::arch::asm!("mv {}, sp", out(reg) sp, options(nomem, nostack)) };
    let (bottom, _) = stack_room();
    // SAFETY: no frame lives below the stack pointer less 256 bytes.
    unsafe { golden::stack::paint(bottom, (sp - 256) & !3) };
}

/// Runs `steps` settling and `steps` flow steps of `scenario` in `sim`
/// ([`golden::run`]), prints the report and the instructions per
/// grain-step; with `living`, then the living bed's trace
/// ([`golden::trace`]); then the peak stack use, and exits 0; exits 1 on
/// any kernel error.
pub fn run<R: Real, const N: usize, const K: usize, const C: usize>(
    sim: &mut Sim<R, N, K, C>,
    scenario: &Scenario,
    steps: u64,
    living: bool,
) -> ! {
    paint_stack();
    match golden::run(sim, scenario, steps, &mut Instret) {
        Ok(report) => {
            hprintln!("{}", report);
            hprintln!(
                "instructions per grain-step {}",
                (report.cost + report.grain_steps() / 2) / report.grain_steps().max(1)
            );
            if living {
                let trace = golden::trace(
                    sim,
                    golden::TRACE_STEPS,
                    golden::TRACE_EVERY,
                    &mut Instret,
                    |r| hprintln!("{}", r),
                );
                if let Err(e) = trace {
                    hprintln!("error: {}", e);
                    debug::exit(debug::EXIT_FAILURE);
                }
            }
            let (bottom, top) = stack_room();
            // SAFETY: painted by `paint_stack`.
            let used = unsafe { golden::stack::used(bottom, top) };
            hprintln!("stack {} B used of {} B", used, top - bottom);
            debug::exit(debug::EXIT_SUCCESS);
        }
        Err(e) => {
            hprintln!("error: {}", e);
            debug::exit(debug::EXIT_FAILURE);
        }
    }
    halt()
}

/// Exits 1 on any trap: an exception (riscv-rt's `ExceptionHandler`).
#[export_name = "ExceptionHandler"]
fn exception(_frame: &riscv_rt::TrapFrame) -> ! {
    debug::exit(debug::EXIT_FAILURE);
    halt()
}

/// Exits 1 on a panic, after printing it.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("{}", info);
    debug::exit(debug::EXIT_FAILURE);
    halt()
}

/// Waits for ever (after an exit that did not stop the machine).
fn halt() -> ! {
    loop {
        riscv::asm::wfi();
    }
}
