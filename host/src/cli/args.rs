//! The command line: options every subcommand shares, and the subcommands,
//! each with its arguments in its own file.

use super::bench::BenchArgs;
use super::calibrate::CalibrateArgs;
pub use super::common::Shared;
use super::config::ConfigArgs;
use super::digest::DigestArgs;
use super::merge::MergeArgs;
use super::pack::PackArgs;
use super::run::RunArgs;
use super::snapshot::SnapshotArgs;
use clap::{Parser, Subcommand};

/// `mbs [SHARED] [COMMAND]`.
#[derive(Parser)]
#[command(
    name = "mbs",
    version,
    about = "DEM numerical movable bed: bed-load transport q* against the Shields number τ*",
    long_about = "DEM numerical movable bed (Gotoh, Harada & Sakai). Without a subcommand, \
                  runs the main job (`mbs run`) on the embedded paper's case."
)]
pub struct Cli {
    /// Before the subcommand, for every subcommand (the main job's without one).
    #[command(flatten)]
    pub shared: Shared,
    /// The subcommand; `run` without one.
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// The subcommands.
#[derive(Subcommand)]
pub enum Command {
    /// The main job: q* against τ* over seeds → transport.csv, transport.png/.svg, summary.json.
    Run(RunArgs),
    /// Merges the cell stores of shard output directories (`run` or
    /// `calibrate` with --shard) into one directory.
    #[command(mut_arg("threads", |a| a.hide(true)))]
    #[command(mut_arg("sets", |a| a.hide(true)))]
    Merge(MergeArgs),
    /// Prints the embedded default configuration (the paper's case), commented; with a
    /// file or --set, checks it as `run` would and prints it as a run echoes it (docs/guarantees.md).
    #[command(mut_arg("quiet", |a| a.hide(true)))]
    #[command(mut_arg("threads", |a| a.hide(true)))]
    Config(ConfigArgs),
    /// Packing test (docs/model.md §9 step 1): packing.csv and a plot of y_gc(t).
    #[command(mut_arg("threads", |a| a.hide(true)))]
    Pack(PackArgs),
    /// Pictures of the bed (PNG/SVG) and particle frames over time for ParaView (.pvd, .vtu) and meshio (.vtu).
    #[command(mut_arg("threads", |a| a.hide(true)))]
    Snapshot(SnapshotArgs),
    /// Prints the state digests after N settling and N flow steps (compare a board run).
    #[command(mut_arg("quiet", |a| a.hide(true)))]
    #[command(mut_arg("threads", |a| a.hide(true)))]
    Digest(DigestArgs),
    /// The paper's parameter optimisation, automated: α_m, α_cn, β, constants_dt(d, nvd), mixed sizes → report.md.
    #[command(args_conflicts_with_subcommands = true)]
    Calibrate(CalibrateArgs),
    /// Settles a bed of about N grains and prints ns per grain-step of the step loop alone.
    #[command(mut_arg("threads", |a| a.help(
        "One bed's step on N threads (the phased step, the same bits); default 1"
    )))]
    #[command(mut_arg("sets", |a| a.hide(true)))]
    Bench(BenchArgs),
}

impl Command {
    /// The subcommand's shared options, taken out of it.
    pub fn take_shared(&mut self) -> Shared {
        match self {
            Command::Calibrate(args) => args.take_shared(),
            Command::Run(RunArgs { shared, .. })
            | Command::Merge(MergeArgs { shared, .. })
            | Command::Config(ConfigArgs { shared, .. })
            | Command::Pack(PackArgs { shared, .. })
            | Command::Snapshot(SnapshotArgs { shared, .. })
            | Command::Digest(DigestArgs { shared, .. })
            | Command::Bench(BenchArgs { shared, .. }) => std::mem::take(shared),
        }
    }
}
