//! `mbs bench`: ns per grain-step of the step loop alone on a prepared bed.

use super::common::print;
use super::common::print_err;
use super::common::Common;
use super::common::Invocation;
use super::common::Shared;
use crate::config::{Precision, MAX_CAPACITY};
use crate::error::HostError;
use indicatif::ProgressBar;

use crate::tools::bench::{bench, Bench, BenchBed, Case};
use clap::Args;
use std::path::PathBuf;

/// The arguments of `mbs bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// Shared options.
    #[command(flatten)]
    pub shared: Shared,
    /// Grains (fixed included), 39 (4 columns) to the largest capacity
    /// ([`MAX_CAPACITY`]).
    #[arg(
        long,
        default_value_t = 1024,
        value_parser = clap::value_parser!(u32).range(39..=MAX_CAPACITY as i64),
        help = format!("Grains (fixed included), 39 (4 columns) to {MAX_CAPACITY}")
    )]
    pub grains: u32,
    /// Repetitions timed: steps, rebuilds or passes over the contacts.
    #[arg(long, default_value_t = 2000)]
    pub steps: u64,
    /// Working precision.
    #[arg(long, value_enum, default_value_t = Precision::F64)]
    pub precision: Precision,
    /// What is timed.
    #[arg(long, value_enum, default_value_t = Case::Still)]
    pub case: Case,
    /// Shorthand for `--case flow`.
    #[arg(long, conflicts_with = "case")]
    pub flow: bool,
    /// β of the paper's contact constants.
    #[arg(long, default_value_t = 15.8, allow_negative_numbers = true)]
    pub beta: f64,
    /// Keep prepared beds in this directory and reuse them.
    #[arg(long)]
    pub beds: Option<PathBuf>,
}

impl BenchArgs {
    /// Prepares the bed and times the case.
    pub fn execute(self, how: &Invocation) -> Result<(), HostError> {
        crate::config::steps_arg("--steps", self.steps)?;
        crate::config::need(
            self.beta.is_finite() && (0.01..=1e4).contains(&self.beta),
            "--beta",
            self.beta,
            "in [0.01, 10000], as contact.beta",
        )?;
        let job = Bench {
            bed: BenchBed {
                grains: self.grains as usize,
                beta: self.beta,
            },
            case: if self.flow { Case::Flow } else { self.case },
            repetitions: self.steps,
            beds: self.beds.as_deref(),
            // `--threads N`: one bed's step (the phased step) or its
            // rebuild's search on N threads, the same bits; by default on one.
            threads: how.common.threads.max(1),
        };
        bench_command(self.precision, job, how.common)
    }
}

/// `mbs bench`: ns per grain-step of one case on a prepared bed.
pub fn bench_command(
    precision: Precision,
    job: crate::tools::bench::Bench<'_>,
    common: Common,
) -> Result<(), HostError> {
    let spinner = if common.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new_spinner()
    };
    spinner.set_message("preparing the bed, then timing");
    spinner.enable_steady_tick(std::time::Duration::from_millis(200));
    let (case, beta) = (job.case, job.bed.beta);
    let sc = job.bed.scenario(job.bed.columns());
    // A physics warning: printed even when quiet.
    if precision == Precision::F32
        && let Some(w) = crate::config::f32_width_warning(sc.bed.width(), sc.step_dt())
    {
        print_err(&format!("warning: {w}"));
    }
    let r = bench(precision, job);
    spinner.finish_and_clear();
    let r = r?;
    print(&format!(
        "{} grains, {:?}, beta {}, {}: {:.1} ns per grain-step over {} repetitions ({} rounds: min {:.1}, median {:.1}, max {:.1}), {:.2} contacts per grain, {} neighbour rebuilds ({:.0} % of the time in the steps that rebuilt)\n",
        r.grains,
        precision,
        beta,
        case.name(),
        r.ns_per_grain_step,
        r.repetitions,
        r.rounds,
        r.ns_spread.0,
        r.ns_spread.1,
        r.ns_spread.2,
        r.contacts_per_grain,
        r.rebuilds,
        100.0 * r.rebuild_share
    ))
}
