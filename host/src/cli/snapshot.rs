//! `mbs snapshot`: pictures and particle frames of a bed under the flow.

use super::common::logged;
use super::common::output_dir;
use super::common::report_warnings;
use super::common::seconds_arg;
use super::common::tau_arg;
use super::common::Common;
use super::common::Invocation;
use super::common::Shared;
use super::common::{print, print_err};
use crate::config::{long_steps_warning, need, steps_arg, Config};
use crate::error::HostError;
use crate::io::output::create_dir;
use crate::io::progress::Progress;
use crate::tools::snapshot::snapshots;
use crate::tools::snapshot::write_picture;
use crate::tools::snapshot::Snapshots;
use std::path::Path;

use clap::Args;
use std::path::PathBuf;

/// The arguments of `mbs snapshot`.
#[derive(Args)]
pub struct SnapshotArgs {
    /// Shared options.
    #[command(flatten)]
    pub shared: Shared,
    /// Configuration file (TOML).
    pub config: Option<PathBuf>,
    /// Output directory.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Shields number of the flow.
    #[arg(long, default_value_t = 0.2, allow_negative_numbers = true)]
    pub tau: f64,
    /// Frames after the settled bed.
    #[arg(long, default_value_t = 20)]
    pub frames: u64,
    /// Time between frames (s).
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
    pub every: f64,
}

impl SnapshotArgs {
    /// Checks τ* and the interval, then takes the snapshots.
    pub fn execute(self, how: &Invocation) -> Result<(), HostError> {
        let tau = tau_arg(self.tau)?;
        seconds_arg("--every", self.every)?;
        need(
            (1..=MAX_FRAMES).contains(&self.frames),
            "--frames",
            self.frames,
            &format!(
                "in [1, {MAX_FRAMES}] (each frame is a file of every grain: more are a \
                 mistake or fill the disk; ParaView plays a few hundred)"
            ),
        )?;
        let config = how.load(self.config.as_deref())?;
        // At least one integration step between frames (shorter, every
        // frame was the same state).
        let step_dt = config.scenario.step_dt();
        need(
            self.every / step_dt >= 1.0 - 1e-9,
            "--every",
            crate::io::text::number(self.every),
            &format!(
                ">= one integration step (step_dt = constants_dt/substeps = {} s)",
                crate::io::text::number(step_dt)
            ),
        )?;
        let steps = config.steps_of(self.every).saturating_mul(self.frames);
        steps_arg("--frames x --every", steps)?;
        let grains = config.scenario.bed.grains();
        let total = steps.saturating_add(config.durations.settle);
        if let Some(w) = long_steps_warning("mbs snapshot", total, grains) {
            print_err(&format!("warning: {w}"));
        }
        snapshot(
            &config,
            self.out.as_deref(),
            tau,
            self.frames,
            self.every,
            how.common,
        )
    }
}

/// The most frames of `mbs snapshot --frames`.
pub const MAX_FRAMES: u64 = 10_000;

/// `mbs snapshot`: pictures and particle frames of the bed under the flow.
pub fn snapshot(
    config: &Config,
    out: Option<&Path>,
    tau_star: f64,
    frames: u64,
    every: f64,
    common: Common,
) -> Result<(), HostError> {
    let dir = output_dir(config, out)?;
    create_dir(&dir)?;
    logged(config, &dir, "snapshot", false, |log, _| {
        report_warnings(config, log, true);
        let every = config.steps_of(every);
        let progress = Progress::steps(
            config
                .durations
                .settle
                .saturating_add(frames.saturating_mul(every)),
            "snapshot",
            common.quiet,
        );
        let done = snapshots(Snapshots {
            config,
            tau_star,
            seed: config.seeds[0],
            frames,
            every,
            dir: &dir.join("snapshot"),
            progress: progress.bar(),
        })?;
        progress.finish();
        write_picture(&dir, &done.last, &format!("τ* = {tau_star}"))?;
        log.event(&format!("{} frames at tau* {tau_star}", done.frames));
        snapshot_report(&dir, done.frames, common)
    })
}

/// What `mbs snapshot` prints when done.
fn snapshot_report(dir: &Path, frames: usize, common: Common) -> Result<(), HostError> {
    if !common.quiet {
        print(&format!(
            "{frames} frames; wrote {dir}/snapshot/bed_NNNN.vtu (open bed.pvd in ParaView; meshio reads the .vtu files), {dir}/snapshot.png, snapshot.svg\n",
            dir = dir.display()
        ))?;
    }
    Ok(())
}
