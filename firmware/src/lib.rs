//! Shared by the firmware binaries: run a scenario from static storage,
//! measure its cost with SysTick, print the digests over semihosting.
//!
//! Cost: SysTick counts the core clock in QEMU's virtual time. Under
//! `-icount shift=0` QEMU advances virtual time by a fixed amount per guest
//! instruction, so ticks are proportional to instructions executed. The
//! ratio is measured on the spot with a loop of known length
//! ([`instructions_per_tick`]), so the printed figure is instructions per
//! grain-step, repeatable run after run.
#![no_std]

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_semihosting::{debug, hprintln};
use mbs_kernel::{Error, Real, Scenario, Sim};

/// A free-running 24-bit SysTick down-counter.
pub struct Ticks {
    syst: SYST,
    total: u64,
}

impl Ticks {
    /// Starts SysTick on the core clock with the largest reload.
    pub fn start(mut syst: SYST) -> Self {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(0x00ff_ffff);
        syst.clear_current();
        syst.enable_counter();
        Ticks { syst, total: 0 }
    }

    /// Runs `f`, adding its ticks to the total; `f` must take fewer than
    /// 2^24 ticks (one step of a bed does, by orders of magnitude).
    pub fn time<T>(&mut self, f: impl FnOnce() -> T) -> (T, u32) {
        let start = SYST::get_current();
        let out = f();
        let end = SYST::get_current();
        let _ = &self.syst;
        let ticks = start.wrapping_sub(end) & 0x00ff_ffff;
        self.total += u64::from(ticks);
        (out, ticks)
    }

    /// Ticks accumulated by [`Ticks::time`].
    pub fn total(&self) -> u64 {
        self.total
    }
}

/// Instructions per SysTick tick, from a loop of `2 × 1_000_000` instructions
/// (`subs` + `bne` per iteration).
pub fn instructions_per_tick(ticks: &mut Ticks) -> f64 {
    const ITERATIONS: u32 = 1_000_000;
    let ((), t) = ticks.time(|| {
        let mut n = ITERATIONS;
        // SAFETY: a register-only countdown loop; no memory is touched.
        unsafe {
            core::arch::asm!("1:", "subs {0}, {0}, #1", "bne 1b", inout(reg) n, options(nomem, nostack));
        }
        let _ = n;
    });
    ticks.total = 0;
    (2 * ITERATIONS) as f64 / f64::from(t.max(1))
}

/// Builds the scenario's bed in `sim`, runs `steps` settling and `steps` flow
/// steps (each timed), prints precision, grains, steps, digests and the
/// instructions per grain-step, and exits 0; exits 1 on any kernel error.
pub fn run<R: Real, const N: usize, const K: usize>(
    sim: &mut Sim<R, N, K>,
    scenario: &Scenario,
    steps: u64,
    syst: SYST,
) -> ! {
    let mut ticks = Ticks::start(syst);
    let per_tick = instructions_per_tick(&mut ticks);
    match phases(sim, scenario, steps, &mut ticks) {
        Ok((settled, flow)) => {
            let grain_steps = (sim.len() as u64 * sim.step_count()) as f64;
            hprintln!("precision {}", R::NAME);
            hprintln!(
                "grains {} (capacity {}, neighbour slots {})",
                sim.len(),
                N,
                K
            );
            hprintln!("steps {}", sim.step_count());
            hprintln!("settled {:#018x}", settled);
            hprintln!("flow {:#018x}", flow);
            hprintln!(
                "instructions per grain-step {:.0} ({:.1} instructions per SysTick tick)",
                ticks.total() as f64 * per_tick / grain_steps,
                per_tick
            );
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

fn phases<R: Real, const N: usize, const K: usize>(
    sim: &mut Sim<R, N, K>,
    scenario: &Scenario,
    steps: u64,
    ticks: &mut Ticks,
) -> Result<(u64, u64), Error> {
    scenario.build(sim)?;
    for _ in 0..steps {
        ticks.time(|| sim.step()).0?;
    }
    let settled = sim.digest();
    sim.set_flow(Some(&scenario.flow()))?;
    for _ in 0..steps {
        ticks.time(|| sim.step()).0?;
    }
    Ok((settled, sim.digest()))
}
