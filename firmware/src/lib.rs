//! Shared by the Cortex-M binaries (M4F and M0): run a scenario from static
//! storage with [`golden::run`], measure its cost with SysTick and its peak
//! stack use, print the report over semihosting.
//!
//! Cost: SysTick counts the core clock in QEMU's virtual time. Under
//! `-icount shift=0` QEMU advances virtual time by a fixed amount per guest
//! instruction, so ticks are proportional to instructions executed. The
//! ratio is measured on the spot with a loop of known length
//! ([`calibration_ticks`]), so the printed figure is instructions per
//! grain-step, repeatable run after run.
#![no_std]

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_semihosting::{debug, hprintln};
use mbs_kernel::{Real, Scenario, Sim};

/// The working precision of the board binaries: f32, or f64 with
/// `--features f64`.
#[cfg(not(feature = "f64"))]
pub type Float = f32;
/// The working precision of the board binaries: f32, or f64 with
/// `--features f64`.
#[cfg(feature = "f64")]
pub type Float = f64;

/// SysTick, a free-running 24-bit down-counter, extended to a count that
/// only grows: it must be read at least once every 2^24 ticks (every step
/// of a bed is, by orders of magnitude).
pub struct Ticks {
    _syst: SYST,
    last: u32,
    total: u64,
}

impl Ticks {
    /// Starts SysTick on the core clock with the largest reload.
    pub fn start(mut syst: SYST) -> Self {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(0x00ff_ffff);
        syst.clear_current();
        syst.enable_counter();
        Ticks {
            _syst: syst,
            last: SYST::get_current(),
            total: 0,
        }
    }
}

impl golden::Meter for Ticks {
    fn now(&mut self) -> u64 {
        let current = SYST::get_current();
        self.total += u64::from(self.last.wrapping_sub(current) & 0x00ff_ffff);
        self.last = current;
        self.total
    }
}

/// Instructions of [`calibration_ticks`].
const CALIBRATION: u64 = 2_000_000;

/// SysTick ticks of a loop of [`CALIBRATION`] instructions (`subs` + `bne`
/// per iteration).
pub fn calibration_ticks(ticks: &mut Ticks) -> u64 {
    use golden::Meter;
    const ITERATIONS: u32 = (CALIBRATION / 2) as u32;
    let start = ticks.now();
    let mut n = ITERATIONS;
    // SAFETY: a register-only countdown loop; no memory is touched.
    unsafe {
        core::arch::asm!("1:", "subs {0}, {0}, #1", "bne 1b", inout(reg) n, options(nomem, nostack));
    }
    let _ = n;
    (ticks.now() - start).max(1)
}

/// `a / b` rounded to the nearest integer.
fn div_round(a: u64, b: u64) -> u64 {
    (a + b / 2) / b.max(1)
}

/// Peak stack use and the stack's room, in bytes ([`golden::stack`]):
/// cortex-m-rt paints the stack, from `_stack_end` (the end of the statics)
/// up to `_stack_start` (the top of RAM), at reset (`paint-stack`).
pub fn stack_use() -> (usize, usize) {
    const _: () = assert!(golden::stack::PAINT == cortex_m_rt::STACK_PAINT_VALUE);
    extern "C" {
        static _stack_start: u32;
        static _stack_end: u32;
    }
    let top = core::ptr::addr_of!(_stack_start) as usize;
    let end = core::ptr::addr_of!(_stack_end) as usize;
    // SAFETY: the RAM from `_stack_end` to `_stack_start` is the stack,
    // painted at reset.
    (unsafe { golden::stack::used(end, top) }, top - end)
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
    syst: SYST,
) -> ! {
    let mut ticks = Ticks::start(syst);
    let calibration = calibration_ticks(&mut ticks);
    match golden::run(sim, scenario, steps, &mut ticks) {
        Ok(report) => {
            hprintln!("{}", report);
            // Integer arithmetic: float formatting takes up to 1 KiB of stack.
            let tenths_per_tick = div_round(10 * CALIBRATION, calibration);
            hprintln!(
                "instructions per grain-step {} ({}.{} instructions per SysTick tick)",
                div_round(
                    report.cost * CALIBRATION,
                    calibration * report.grain_steps()
                ),
                tenths_per_tick / 10,
                tenths_per_tick % 10
            );
            if living {
                let trace = golden::trace(
                    sim,
                    golden::TRACE_STEPS,
                    golden::TRACE_EVERY,
                    &mut ticks,
                    |r| hprintln!("{}", r),
                );
                if let Err(e) = trace {
                    hprintln!("error: {}", e);
                    debug::exit(debug::EXIT_FAILURE);
                }
            }
            let (used, room) = stack_use();
            hprintln!("stack {} B used of {} B", used, room);
            debug::exit(debug::EXIT_SUCCESS);
        }
        Err(e) => {
            hprintln!("error: {}", e);
            debug::exit(debug::EXIT_FAILURE);
        }
    }
    loop {
        cortex_m::asm::wfi();
    }
}
