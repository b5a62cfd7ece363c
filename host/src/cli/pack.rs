//! `mbs pack`: the packing test (docs/model.md §9 step 1).

use super::common::logged;
use super::common::output_dir;
use super::common::print;
use super::common::report_warnings;
use super::common::seconds_arg;
use super::common::Common;
use super::common::Invocation;
use super::common::Shared;
use crate::config::Config;
use crate::error::HostError;
use crate::io::log::Log;
use crate::io::output::create_dir;
use crate::io::progress::Progress;
use crate::tools::pack::packing;
use crate::tools::pack::write_packing;
use crate::tools::pack::Packing;
use std::path::Path;

use clap::Args;
use std::path::PathBuf;

/// The arguments of `mbs pack`.
#[derive(Args)]
pub struct PackArgs {
    /// Shared options.
    #[command(flatten)]
    pub shared: Shared,
    /// Configuration file (TOML).
    pub config: Option<PathBuf>,
    /// Output directory.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Duration (s); default time.settle.
    #[arg(long, allow_negative_numbers = true)]
    pub duration: Option<f64>,
}

impl PackArgs {
    /// Checks the duration and runs the packing test.
    pub fn execute(self, how: &Invocation) -> Result<(), HostError> {
        if let Some(d) = self.duration {
            seconds_arg("--duration", d)?;
        }
        let config = how.load(self.config.as_deref())?;
        if let Some(d) = self.duration {
            crate::config::steps_arg("--duration", config.steps_of(d))?;
        }
        pack(&config, self.out.as_deref(), self.duration, how.common)
    }
}

/// `mbs pack`: the packing test → `packing.csv`, `packing.png`/`.svg`.
pub fn pack(
    config: &Config,
    out: Option<&Path>,
    duration: Option<f64>,
    common: Common,
) -> Result<(), HostError> {
    let dir = output_dir(config, out)?;
    create_dir(&dir)?;
    logged(config, &dir, "pack", false, |log, _| {
        pack_logged(config, &dir, duration, common, log)
    })
}

/// [`pack`] once its log is open.
fn pack_logged(
    config: &Config,
    dir: &Path,
    duration: Option<f64>,
    common: Common,
    log: &Log,
) -> Result<(), HostError> {
    report_warnings(config, log, false);
    let steps = duration.map_or(config.durations.settle, |d| config.steps_of(d));
    let seed = config.seeds[0];
    let every = u64::from(config.scenario.substeps) * 10;
    let progress = Progress::steps(steps, "packing", common.quiet);
    let samples = packing(Packing {
        config,
        seed,
        steps,
        every,
        progress: progress.bar(),
    })?;
    progress.finish();
    let sc = &config.scenario;
    let title = format!(
        "Packing: d = {} mm, {}×{}, α_m = {}, α_cn = {}, β = {}",
        sc.bed.max_diameter() * 1e3,
        sc.bed.columns,
        sc.bed.rows,
        sc.rule.alpha_m,
        sc.rule.alpha_cn,
        sc.rule.beta
    );
    write_packing(dir, &samples, &title)?;
    if let (Some(first), Some(last)) = (samples.first(), samples.last()) {
        log.event(&format!(
            "packed  y_gc {:.4} mm -> {:.4} mm over {:.3} s",
            first.y_gc * 1e3,
            last.y_gc * 1e3,
            last.time
        ));
    }
    if !common.quiet
        && let (Some(first), Some(last)) = (samples.first(), samples.last())
    {
        print(&format!(
                "y_gc {:.4} mm -> {:.4} mm over {:.3} s; kinetic energy at the end {:.3e} J; wrote {}/packing.csv, packing.png, packing.svg\n",
                first.y_gc * 1e3,
                last.y_gc * 1e3,
                last.time,
                last.kinetic_energy,
                dir.display()
            ))?;
    }
    Ok(())
}
