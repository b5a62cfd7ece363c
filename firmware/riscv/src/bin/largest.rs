//! The largest f32 bed that fits in the 64 KiB of RAM of memory.x: the
//! paper's grains, `COLUMNS` × `ROWS` over `COLUMNS` fixed grains, in
//! `.bss`, settling then flow (docs/board.md). Compare with
//! `mbs digest firmware/riscv/largest.toml --steps 1000 --precision f32`.
#![no_std]
#![no_main]

use mbs_kernel::Sim;

/// Columns of the bed.
const COLUMNS: u32 = 31;
/// Rows of the bed.
const ROWS: u32 = 12;
/// Grain capacity: the bed's grains.
const GRAINS: usize = (COLUMNS * (ROWS + 1)) as usize;
/// Neighbour slots per grain (6 suffice in a settled 2-D bed of equal grains).
const SLOTS: usize = 6;
/// Steps of each phase.
const STEPS: u64 = 1000;

/// The simulation, in `.bss` (all zero bits), never on the stack.
static mut SIM: Sim<f32, GRAINS, SLOTS> = Sim::new();

#[riscv_rt::entry]
fn main() -> ! {
    // SAFETY: the only reference to SIM, taken once.
    let sim = unsafe { &mut *core::ptr::addr_of_mut!(SIM) };
    firmware_riscv::run(sim, &golden::bed(COLUMNS, ROWS), STEPS, false)
}
