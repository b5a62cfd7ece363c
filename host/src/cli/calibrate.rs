//! `mbs calibrate`: the paper's parameter optimisation ([`crate::calibrate`]),
//! and `mbs calibrate merge`.

use super::common::directory;
use super::common::logged;
use super::common::on_pool;
use super::common::print;
use super::common::report_warnings;
use super::common::threads_warning;
use super::common::Invocation;
use super::common::Shared;
use crate::config::Config;
use crate::error::HostError;
use crate::io::output::create_dir;
use crate::io::output::write_json;
use crate::work::shard::Shard;
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

use super::merge::MergeArgs;
use crate::calibrate::{Options, Reached};
use crate::science::references::Reference;
use clap::Args;
use clap::Subcommand;
use std::path::PathBuf;

/// The arguments of `mbs calibrate`.
#[derive(Args)]
pub struct CalibrateArgs {
    /// Shared options.
    #[command(flatten)]
    pub shared: Shared,
    /// `merge`, or none to calibrate.
    #[command(subcommand)]
    pub action: Option<CalibrateAction>,
    /// Base configuration (TOML); the embedded paper's case when omitted.
    pub config: Option<PathBuf>,
    /// Output directory (cells, stage results, figures, report.md); resumed if it exists.
    #[arg(long, default_value = "mbs-calibration")]
    pub out: PathBuf,
    /// Fewer points and seeds: a few minutes on 2 cores.
    #[arg(long)]
    pub quick: bool,
    /// Stop after this stage (1-5).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u8).range(1..=5))]
    pub stage: u8,
    /// Run only slice I of N of each stage's cells (I = 1..N), e.g. a Slurm array task.
    #[arg(long, value_name = "I/N", value_parser = clap::value_parser!(Shard))]
    pub shard: Option<Shard>,
    /// Reference relation fitted in stages 3-5.
    #[arg(long, value_enum, default_value_t = Reference::MeyerPeterMuller)]
    pub reference: Reference,
}

/// The subcommands of `mbs calibrate`.
#[derive(Subcommand)]
pub enum CalibrateAction {
    /// Merges the cell stores of shard output directories into one directory.
    #[command(mut_arg("threads", |a| a.hide(true)))]
    #[command(mut_arg("sets", |a| a.hide(true)))]
    Merge(MergeArgs),
}

impl CalibrateArgs {
    /// The shared options given before `merge` and after it, taken out.
    pub fn take_shared(&mut self) -> Shared {
        let outer = std::mem::take(&mut self.shared);
        match &mut self.action {
            Some(CalibrateAction::Merge(m)) => outer.and(std::mem::take(&mut m.shared)),
            None => outer,
        }
    }

    /// Merges shard directories, or calibrates and says what it got to.
    pub fn execute(self, how: &Invocation) -> Result<(), HostError> {
        if let Some(CalibrateAction::Merge(m)) = self.action {
            let finish = format!("`mbs calibrate [CONFIG] --out {}`", m.out.display());
            return m.merge(&finish, how.common.quiet);
        }
        let base = how.load(self.config.as_deref())?;
        let options = Options {
            quick: self.quick,
            last_stage: usize::from(self.stage),
            shard: self.shard.unwrap_or(Shard::ALL),
            reference: self.reference,
            quiet: how.common.quiet,
        };
        let out = &self.out;
        let message = match calibrate(base, out, options, how.common.threads)? {
            Reached::Done { stages, calibrated } => {
                let done = if stages == 5 {
                    format!("calibration done: {}/report.md\n", out.display())
                } else {
                    format!("stages 1-{stages} done in {}\n", out.display())
                };
                match calibrated {
                    Some(c) => format!("{done}{c}\n"),
                    None => done,
                }
            }
            Reached::Waiting { stage } => format!(
                "stage {stage}: this shard's cells are done; merge the shards \
                 (`mbs calibrate merge DIRS --out DIR`) and run again\n"
            ),
        };
        if how.common.quiet {
            Ok(())
        } else {
            print(&message)
        }
    }
}

/// `mbs calibrate`: the calibration into `dir` ([`crate::calibrate`]),
/// logged in `dir/mbs.log`, with `dir/summary.json` (its warnings and
/// wall time); returns what it got to.
pub fn calibrate(
    base: Config,
    dir: &Path,
    options: crate::calibrate::Options,
    threads: usize,
) -> Result<crate::calibrate::Reached, HostError> {
    let dir = directory("--out", dir)?;
    // A finished run's directory: its summary would be overwritten
    // (refused before the log is opened: nothing written).
    crate::io::output::not_holding(&dir, crate::report::TRANSPORT, "mbs run")?;
    create_dir(&dir)?;
    let mut reached = None;
    let logged_config = base.clone();
    logged(&logged_config, &dir, "calibrate", false, |log, _| {
        let start = Instant::now();
        report_warnings(&base, log, true);
        let pool = on_pool(threads, rayon::current_num_threads)?;
        if let Some(w) = threads_warning(pool) {
            log.warn(&w);
        }
        let progress = on_pool(threads, || {
            crate::calibrate::calibrate(base, &dir, options, log)
        })??;
        let stages = match &progress {
            crate::calibrate::Reached::Done { stages, .. } => *stages,
            crate::calibrate::Reached::Waiting { stage } => stage - 1,
        };
        log.event(&format!("stages 1-{stages} done"));
        write_json(
            &dir.join("summary.json"),
            &CalibrationSummary {
                program: "mbs",
                version: env!("CARGO_PKG_VERSION"),
                command: "calibrate",
                stages_done: stages,
                wall_time_s: start.elapsed().as_secs_f64(),
                warnings: log.warnings(),
            },
        )?;
        reached = Some(progress);
        Ok(())
    })?;
    reached.ok_or_else(|| HostError::io(&dir)(std::io::Error::other("no calibration result")))
}

/// `summary.json` of `mbs calibrate`.
#[derive(Serialize)]
struct CalibrationSummary {
    program: &'static str,
    version: &'static str,
    command: &'static str,
    /// Stages finished (all of them, or those before the one waiting for
    /// other shards).
    stages_done: usize,
    /// Wall time of this invocation.
    wall_time_s: f64,
    /// The warnings (also on standard error and in `mbs.log`).
    warnings: Vec<String>,
}
