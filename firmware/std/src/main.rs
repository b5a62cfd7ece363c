//! `golden-std [f32|f64] [STEPS]`: runs `Scenario::paper()` ([`golden::run`],
//! `STEPS` settling then `STEPS` flow steps, 2000 by default) in `f64` (the
//! default) or `f32`, prints its report and the wall-clock time per
//! grain-step, then the living bed's trace ([`golden::trace`]), and exits 0; exits 1 on a kernel error, 2 on bad arguments.
//! Compare with `mbs digest --steps STEPS --precision f32|f64` on the host.
//!
//! The golden run on the targets with std that the host build does not
//! cover: x86-64 without AVX2 (the scalar step), aarch64 Linux and
//! wasm32-wasip1 (docs/board.md).

use mbs_kernel::{Real, Scenario, Sim};
use std::process::ExitCode;
use std::time::Instant;

/// Nanoseconds since the start.
struct Clock(Instant);

impl golden::Meter for Clock {
    fn now(&mut self) -> u64 {
        self.0.elapsed().as_nanos() as u64
    }
}

fn run<R: Real>(steps: u64) -> ExitCode {
    let mut sim = Sim::<R, 64, 8>::new();
    match golden::run(
        &mut sim,
        &Scenario::paper(),
        steps,
        &mut Clock(Instant::now()),
    ) {
        Ok(report) => {
            println!("{report}");
            println!(
                "ns per grain-step {:.1}",
                report.cost as f64 / report.grain_steps().max(1) as f64
            );
            let trace = golden::trace(
                &mut sim,
                golden::TRACE_STEPS,
                golden::TRACE_EVERY,
                &mut Clock(Instant::now()),
                |r| println!("{r}"),
            );
            if let Err(e) = trace {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let steps = match args.get(1).map(|s| s.parse::<u64>()) {
        None => Ok(golden::STEPS),
        Some(parsed) => parsed,
    };
    match (args.first().map(String::as_str), steps, args.len()) {
        (None | Some("f64"), Ok(steps), ..=2) => run::<f64>(steps),
        (Some("f32"), Ok(steps), ..=2) => run::<f32>(steps),
        _ => {
            eprintln!("usage: golden-std [f32|f64] [STEPS]");
            ExitCode::from(2)
        }
    }
}
