//! `mbs`: the DEM numerical movable bed (Gotoh, Harada & Sakai).

use clap::{Args, Parser, Subcommand};
use mbs::calibrate::{merge, Options, Progress};
use mbs::cli::{self, Common};
use mbs::science::references::Reference;
use mbs::tools::bench::{Bench, BenchBed, Case};
use mbs::work::shard::Shard;
use mbs::{Config, HostError, Precision};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    version,
    about = "DEM numerical movable bed: bed-load transport q* against the Shields number τ*",
    long_about = "DEM numerical movable bed (Gotoh, Harada & Sakai). Without a subcommand, \
                  runs the main job (`mbs run`) on the embedded paper's case."
)]
struct Cli {
    /// Before the subcommand, for every subcommand (the main job's without one).
    #[command(flatten)]
    shared: Shared,
    #[command(subcommand)]
    command: Option<Command>,
}

/// Options a subcommand offers where they apply (each subcommand hides
/// the others, still accepted as before).
#[derive(Args, Clone, Default)]
struct Shared {
    /// No progress and no report on standard output (warnings are still printed).
    #[arg(long, short)]
    quiet: bool,
    /// Worker threads (0: one per core; at most 1024). Results do not depend on it.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Override one configuration key, e.g. --set flow.tau_star=[0.1,0.2]
    /// (repeatable; checked like the file, saved in DIR/config.toml).
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    sets: Vec<String>,
}

impl Shared {
    /// These options given before the subcommand together with `sub`, given after it.
    fn and(self, sub: Shared) -> Shared {
        Shared {
            quiet: self.quiet || sub.quiet,
            threads: if sub.threads != 0 {
                sub.threads
            } else {
                self.threads
            },
            sets: [self.sets, sub.sets].concat(),
        }
    }
}

#[derive(Subcommand)]
enum Command {
    /// The main job: q* against τ* over seeds → transport.csv, transport.png/.svg, summary.json.
    Run {
        #[command(flatten)]
        shared: Shared,
        /// Configuration file (TOML); the embedded paper's case when omitted.
        #[arg(conflicts_with = "resume")]
        config: Option<PathBuf>,
        /// Output directory (default: run.output of the configuration).
        #[arg(long, conflicts_with = "resume")]
        out: Option<PathBuf>,
        /// Continue an interrupted run in DIR with the configuration it started with.
        #[arg(long, value_name = "DIR")]
        resume: Option<PathBuf>,
        /// Checkpoint every running cell every SECONDS of wall time, and at most once per
        /// 2000 integration steps of a cell (Ctrl-C always checkpoints).
        #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
        checkpoint_every: Option<f64>,
        /// Stop every cell after N steps as if interrupted (for tests of resuming).
        #[arg(long, hide = true)]
        stop_after_steps: Option<u64>,
        /// Compute only slice I of N of the cells (I = 1..N), e.g. a Slurm array
        /// task; `mbs merge` joins the slices.
        #[arg(long, value_name = "I/N")]
        shard: Option<Shard>,
        /// Write particle frames (XML VTK, for ParaView and meshio) of each computed
        /// cell every SECONDS of simulated time under the flow, from the flow's start
        /// (time 0), to DIR/frames/tau<τ*>_seed<seed>/frames.pvd; at least one
        /// integration step, at most time.window. Cells reused from cells.jsonl
        /// write none; a resumed cell continues its frames.
        #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
        dump_every: Option<f64>,
    },
    /// Merges the cell stores of shard output directories (`run` or
    /// `calibrate` with --shard) into one directory.
    #[command(mut_arg("quiet", |a| a.hide(true)))]
    #[command(mut_arg("threads", |a| a.hide(true)))]
    #[command(mut_arg("sets", |a| a.hide(true)))]
    Merge(MergeArgs),
    /// Prints the embedded default configuration (the paper's case), commented.
    #[command(mut_arg("quiet", |a| a.hide(true)))]
    #[command(mut_arg("threads", |a| a.hide(true)))]
    #[command(mut_arg("sets", |a| a.hide(true)))]
    Config {
        #[command(flatten)]
        shared: Shared,
    },
    /// Packing test (docs/model.md §9 step 1): packing.csv and a plot of y_gc(t).
    #[command(mut_arg("threads", |a| a.hide(true)))]
    Pack {
        #[command(flatten)]
        shared: Shared,
        /// Configuration file (TOML).
        config: Option<PathBuf>,
        /// Output directory.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Duration (s); default time.settle.
        #[arg(long, allow_negative_numbers = true)]
        duration: Option<f64>,
    },
    /// Pictures of the bed (PNG/SVG) and particle frames over time for ParaView and meshio (.vtu, .pvd).
    #[command(mut_arg("threads", |a| a.hide(true)))]
    Snapshot {
        #[command(flatten)]
        shared: Shared,
        /// Configuration file (TOML).
        config: Option<PathBuf>,
        /// Output directory.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Shields number of the flow.
        #[arg(long, default_value_t = 0.2, allow_negative_numbers = true)]
        tau: f64,
        /// Frames after the settled bed.
        #[arg(long, default_value_t = 20)]
        frames: u64,
        /// Time between frames (s).
        #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
        every: f64,
    },
    /// Prints the state digests after N settling and N flow steps (compare a board run).
    #[command(mut_arg("quiet", |a| a.hide(true)))]
    #[command(mut_arg("threads", |a| a.hide(true)))]
    Digest {
        #[command(flatten)]
        shared: Shared,
        /// Configuration file (TOML); without one, the golden-digest run: the
        /// paper's case on its 5 columns, as the firmware runs it.
        config: Option<PathBuf>,
        /// Steps of each phase (of settling only, with --flow-steps).
        #[arg(long, default_value_t = 2000)]
        steps: u64,
        /// Steps of the flow phase (default: --steps).
        #[arg(long)]
        flow_steps: Option<u64>,
        /// Working precision.
        #[arg(long, value_enum, default_value_t = Precision::F64)]
        precision: Precision,
        /// Shields number of the flow phase.
        #[arg(long, default_value_t = 0.2, allow_negative_numbers = true)]
        tau: f64,
        /// Also write a trace of the run (JSON, docs/determinism.md "Traces").
        #[arg(long, value_name = "FILE")]
        trace: Option<PathBuf>,
        /// Integration steps between the trace's records.
        #[arg(long, default_value_t = 1000, requires = "trace")]
        every: u64,
        /// The trace's first recorded step (the run starts at 0 regardless).
        #[arg(long, default_value_t = 0, requires = "trace")]
        from: u64,
        /// The trace's last step (default: the end of the flow phase).
        #[arg(long, requires = "trace")]
        until: Option<u64>,
        /// Each record of the trace keeps the whole kernel state (base64), so
        /// that a check can name the grains and fields that differ.
        #[arg(long, requires = "trace")]
        states: bool,
        /// Re-run a trace's scenario and compare: exit 0 if every record
        /// matches, 1 locating the first mismatch, 2 for a damaged or foreign trace.
        #[arg(long, value_name = "TRACE", conflicts_with_all = ["config", "trace"])]
        check: Option<PathBuf>,
        /// With --check: change one grain's field by ULPS units in the last
        /// place after STEP integration steps (ULPS 1 if omitted; fields x, y,
        /// u, v, spin, draw_u, draw_v), to see how the check locates a difference.
        #[arg(long, value_name = "STEP:GRAIN:FIELD[:ULPS]", requires = "check")]
        nudge: Option<mbs::tools::trace::Nudge>,
    },
    /// The paper's parameter optimisation, automated: α_m, α_cn, β, constants_dt(d, nvd), mixed sizes → report.md.
    #[command(args_conflicts_with_subcommands = true)]
    Calibrate {
        #[command(flatten)]
        shared: Shared,
        #[command(subcommand)]
        action: Option<CalibrateAction>,
        /// Base configuration (TOML); the embedded paper's case when omitted.
        config: Option<PathBuf>,
        /// Output directory (cells, stage results, figures, report.md); resumed if it exists.
        #[arg(long, default_value = "mbs-calibration")]
        out: PathBuf,
        /// Fewer points and seeds: a few minutes on 2 cores.
        #[arg(long)]
        quick: bool,
        /// Stop after this stage (1-5).
        #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u8).range(1..=5))]
        stage: u8,
        /// Run only slice I of N of each stage's cells (I = 1..N), e.g. a Slurm array task.
        #[arg(long, value_name = "I/N", value_parser = clap::value_parser!(Shard))]
        shard: Option<Shard>,
        /// Reference relation fitted in stages 3-5.
        #[arg(long, value_enum, default_value_t = Reference::MeyerPeterMuller)]
        reference: Reference,
    },
    /// Settles a bed of about N grains and prints ns per grain-step of the step loop alone.
    #[command(mut_arg("threads", |a| a.hide(true)))]
    #[command(mut_arg("sets", |a| a.hide(true)))]
    Bench {
        #[command(flatten)]
        shared: Shared,
        /// Grains (fixed included), 33 to 65536.
        #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(33..=65536))]
        grains: u32,
        /// Repetitions timed: steps, rebuilds or passes over the contacts.
        #[arg(long, default_value_t = 2000)]
        steps: u64,
        /// Working precision.
        #[arg(long, value_enum, default_value_t = Precision::F64)]
        precision: Precision,
        /// What is timed.
        #[arg(long, value_enum, default_value_t = Case::Still)]
        case: Case,
        /// Shorthand for `--case flow`.
        #[arg(long, conflicts_with = "case")]
        flow: bool,
        /// β of the paper's contact constants.
        #[arg(long, default_value_t = 15.8, allow_negative_numbers = true)]
        beta: f64,
        /// Keep prepared beds in this directory and reuse them.
        #[arg(long)]
        beds: Option<PathBuf>,
    },
}

/// The arguments of `mbs merge` and `mbs calibrate merge`.
#[derive(clap::Args)]
struct MergeArgs {
    #[command(flatten)]
    shared: Shared,
    /// Shard output directories.
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// The directory to merge into (then rerun the command without --shard
    /// and with --out DIR to finish).
    #[arg(long)]
    out: PathBuf,
}

#[derive(Subcommand)]
enum CalibrateAction {
    /// Merges the cell stores of shard output directories into one directory.
    #[command(mut_arg("quiet", |a| a.hide(true)))]
    #[command(mut_arg("threads", |a| a.hide(true)))]
    #[command(mut_arg("sets", |a| a.hide(true)))]
    Merge(MergeArgs),
}

/// Checks a Shields number given on the command line.
fn tau_arg(tau: f64) -> Result<f64, HostError> {
    if tau.is_finite() && tau > 0.0 && tau <= 5.0 {
        Ok(tau)
    } else {
        Err(mbs::ConfigError::Invalid {
            key: "--tau".into(),
            value: tau.to_string(),
            allowed: "in (0, 5]".into(),
        }
        .into())
    }
}

/// Checks a physical time given on the command line: in (0, 1000] s, the
/// limit of the configuration's phases ([`mbs::config::MAX_PHASE_S`]).
fn seconds_arg(key: &str, seconds: f64) -> Result<(), HostError> {
    let max = mbs::config::MAX_PHASE_S;
    if seconds > 0.0 && seconds <= max {
        Ok(())
    } else {
        Err(mbs::ConfigError::Invalid {
            key: key.into(),
            value: mbs::io::text::number(seconds),
            allowed: format!("in (0, {max}] s of physical time"),
        }
        .into())
    }
}

impl Command {
    /// The subcommand's shared options, taken out of it.
    fn take_shared(&mut self) -> Shared {
        match self {
            Command::Calibrate {
                shared,
                action: Some(CalibrateAction::Merge(MergeArgs { shared: inner, .. })),
                ..
            } => std::mem::take(shared).and(std::mem::take(inner)),
            Command::Run { shared, .. }
            | Command::Merge(MergeArgs { shared, .. })
            | Command::Config { shared }
            | Command::Pack { shared, .. }
            | Command::Snapshot { shared, .. }
            | Command::Digest { shared, .. }
            | Command::Calibrate { shared, .. }
            | Command::Bench { shared, .. } => std::mem::take(shared),
        }
    }
}

fn execute(cli: Cli) -> Result<(), HostError> {
    let mut command = cli.command.unwrap_or(Command::Run {
        shared: Shared::default(),
        config: None,
        out: None,
        resume: None,
        checkpoint_every: None,
        stop_after_steps: None,
        shard: None,
        dump_every: None,
    });
    let shared = cli.shared.and(command.take_shared());
    cli::check_threads(shared.threads)?;
    let common = Common {
        quiet: shared.quiet,
        threads: shared.threads,
    };
    let sets = shared.sets;
    let load =
        |path: &Option<PathBuf>| Config::load_with(path.as_deref(), &sets).map_err(HostError::from);
    match command {
        Command::Run {
            config,
            out,
            resume,
            checkpoint_every,
            stop_after_steps,
            shard,
            dump_every,
            ..
        } => {
            if let Some(s) = checkpoint_every
                .filter(|s| !(*s > 0.0 && std::time::Duration::try_from_secs_f64(*s).is_ok()))
            {
                return Err(mbs::ConfigError::Invalid {
                    key: "--checkpoint-every".into(),
                    value: s.to_string(),
                    allowed: "> 0 seconds".into(),
                }
                .into());
            }
            let options = cli::RunOptions {
                checkpoint_every,
                stop_after_steps,
                resuming: resume.is_some(),
                shard: shard.unwrap_or(Shard::ALL),
                dump_every,
            };
            let (config, out) = match resume {
                Some(_) if !sets.is_empty() => return Err(mbs::ConfigError::Invalid {
                    key: "--set".into(),
                    value: sets.join(" "),
                    allowed:
                        "not with --resume: a resumed run keeps the configuration it started with"
                            .into(),
                }
                .into()),
                Some(dir) => (cli::resumed_config(&dir)?, Some(dir)),
                None => (load(&config)?, out),
            };
            cli::run(&config, out.as_deref(), options, common)
        }
        Command::Config { .. } => cli::config(),
        Command::Merge(MergeArgs { shards, out, .. }) => {
            let added = merge(&shards, &out)?;
            cli::print(&format!(
                "merged {added} new cells into {}; finish with the same command without --shard and with --out {}\n",
                out.display(),
                out.display()
            ))
        }
        Command::Pack {
            config,
            out,
            duration,
            ..
        } => {
            if let Some(d) = duration {
                seconds_arg("--duration", d)?;
            }
            cli::pack(&load(&config)?, out.as_deref(), duration, common)
        }
        Command::Snapshot {
            config,
            out,
            tau,
            frames,
            every,
            ..
        } => {
            let tau = tau_arg(tau)?;
            seconds_arg("--every", every)?;
            cli::snapshot(&load(&config)?, out.as_deref(), tau, frames, every, common)
        }
        Command::Digest {
            config,
            steps,
            flow_steps,
            precision,
            tau,
            trace,
            every,
            from,
            until,
            states,
            check,
            nudge,
            ..
        } => {
            if let Some(file) = check {
                if !sets.is_empty() {
                    return Err(mbs::ConfigError::Invalid {
                        key: "--set".into(),
                        value: sets.join(" "),
                        allowed: "not with --check: a check runs with the trace's own overrides"
                            .into(),
                    }
                    .into());
                }
                return cli::check_trace(&file, nudge);
            }
            if every == 0 {
                return Err(mbs::ConfigError::Invalid {
                    key: "--every".into(),
                    value: every.to_string(),
                    allowed: "> 0".into(),
                }
                .into());
            }
            let name = config.as_ref().map(|p| p.display().to_string());
            let config = match config {
                Some(_) => load(&config)?,
                None => mbs::Config::golden_with(&sets)?,
            };
            let trace = trace.as_deref().map(|path| cli::TraceArgs {
                path,
                config: name,
                overrides: sets.clone(),
                every,
                from,
                until,
                states,
            });
            let steps = (steps, flow_steps.unwrap_or(steps));
            cli::digest(&config, steps, precision, tau_arg(tau)?, trace)
        }
        Command::Calibrate {
            action: Some(CalibrateAction::Merge(MergeArgs { shards, out, .. })),
            ..
        } => {
            let added = merge(&shards, &out)?;
            cli::print(&format!(
                "merged {added} new cells into {}; finish with `mbs calibrate [CONFIG] --out {}`\n",
                out.display(),
                out.display()
            ))
        }
        Command::Calibrate {
            action: None,
            config,
            out,
            quick,
            stage,
            shard,
            reference,
            ..
        } => {
            let base = load(&config)?;
            let options = Options {
                quick,
                last_stage: usize::from(stage),
                shard: shard.unwrap_or(Shard::ALL),
                reference,
                quiet: common.quiet,
            };
            let message = match cli::calibrate(base, &out, options, common.threads)? {
                Progress::Done { stages, calibrated } => {
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
                Progress::Waiting { stage } => format!(
                    "stage {stage}: this shard's cells are done; merge the shards \
                     (`mbs calibrate merge DIRS --out DIR`) and run again\n"
                ),
            };
            if common.quiet {
                Ok(())
            } else {
                cli::print(&message)
            }
        }
        Command::Bench {
            grains,
            steps,
            precision,
            case,
            flow,
            beta,
            beds,
            ..
        } => {
            let job = Bench {
                bed: BenchBed {
                    grains: grains as usize,
                    beta,
                },
                case: if flow { Case::Flow } else { case },
                repetitions: steps,
                beds: beds.as_deref(),
            };
            cli::bench_command(precision, job, common)
        }
    }
}

fn main() -> ExitCode {
    match execute(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            cli::print_err(&format!("error: {e}"));
            ExitCode::from(e.exit_code())
        }
    }
}
