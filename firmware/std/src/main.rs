//! `golden-std [coupled] [f32|f64] [STEPS]`: runs `Scenario::paper()`
//! ([`golden::run`], `STEPS` settling then `STEPS` flow steps, 2000 by
//! default) in `f64` (the default) or `f32`, prints its report and the
//! wall-clock time per grain-step, then the living bed's trace
//! ([`golden::trace`]), and exits 0; exits 1 on a kernel error, 2 on bad
//! arguments. Compare with `mbs digest --steps STEPS --precision f32|f64`
//! on the host. With `coupled`, the coupled golden run instead,
//! `Scenario::paper_coupled()`, without the trace: compare with
//! `mbs digest --steps STEPS --precision f32|f64 --set flow.model=coupled --set fluid.cell_d=4`.
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

fn run<R: Real>(steps: u64, coupled: bool) -> ExitCode {
    let mut sim = Sim::<R, 64, 8, { Scenario::PAPER_COUPLED_CELLS }>::new();
    let scenario = if coupled {
        Scenario::paper_coupled()
    } else {
        Scenario::paper()
    };
    match golden::run(&mut sim, &scenario, steps, &mut Clock(Instant::now())) {
        Ok(report) => {
            println!("{report}");
            println!(
                "ns per grain-step {:.1}",
                report.cost as f64 / report.grain_steps().max(1) as f64
            );
            if coupled {
                return ExitCode::SUCCESS;
            }
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
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let coupled = args.first().is_some_and(|a| a == "coupled");
    if coupled {
        args.remove(0);
    }
    let steps = match args.get(1).map(|s| s.parse::<u64>()) {
        None => Ok(golden::STEPS),
        Some(parsed) => parsed,
    };
    match (args.first().map(String::as_str), steps, args.len()) {
        (None | Some("f64"), Ok(steps), ..=2) => run::<f64>(steps, coupled),
        (Some("f32"), Ok(steps), ..=2) => run::<f32>(steps, coupled),
        _ => {
            eprintln!("usage: golden-std [coupled] [f32|f64] [STEPS]");
            ExitCode::from(2)
        }
    }
}
