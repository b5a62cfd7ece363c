//! The command line of `mbs`: one file per subcommand, each holding its
//! arguments (clap) and the function from them to files and a short report
//! on standard output; [`args`] holds the options they share, this module
//! the dispatch ([`main`]) and what every subcommand uses (the output
//! directory, the log, the thread pool, standard output).
//!
//! | file | subcommand |
//! |---|---|
//! | [`run`](mod@run) | `mbs run`: the main job, q* against τ* |
//! | [`merge`](mod@merge) | `mbs merge`: shard directories into one |
//! | [`config`](mod@config) | `mbs config`: the embedded default configuration, or a configuration checked |
//! | [`pack`](mod@pack) | `mbs pack`: the packing test |
//! | [`snapshot`](mod@snapshot) | `mbs snapshot`: pictures and frames of a bed |
//! | [`digest`](mod@digest) | `mbs digest`: state digests and traces |
//! | [`calibrate`](mod@calibrate) | `mbs calibrate`: the parameter optimisation |
//! | [`bench`](mod@bench) | `mbs bench`: ns per grain-step |

pub mod args;
pub mod bench;
pub mod calibrate;
pub mod common;
pub mod config;
pub mod digest;
pub mod merge;
pub mod pack;
pub mod run;
pub mod snapshot;

pub use bench::bench_command;
pub use calibrate::calibrate;
pub use digest::{check_trace, digest, TraceArgs};
pub use pack::pack;
pub use run::{dump_steps, resumed_config, run, RunOptions};
pub use snapshot::snapshot;

use crate::error::HostError;
pub use common::{
    check_threads, directory, on_pool, print, print_err, Common, Invocation, MAX_THREADS,
    RUN_CONFIG,
};

/// Runs the parsed command line.
pub fn execute(cli: args::Cli) -> Result<(), HostError> {
    let mut command = cli
        .command
        .unwrap_or_else(|| args::Command::Run(run::RunArgs::default()));
    let shared = cli.shared.and(command.take_shared());
    check_threads(shared.threads)?;
    let how = Invocation {
        common: Common {
            quiet: shared.quiet,
            threads: shared.threads,
        },
        sets: shared.sets,
    };
    match command {
        args::Command::Run(a) => a.execute(&how),
        args::Command::Config(a) => a.execute(&how),
        args::Command::Merge(a) => a.execute(how.common.quiet),
        args::Command::Pack(a) => a.execute(&how),
        args::Command::Snapshot(a) => a.execute(&how),
        args::Command::Digest(a) => a.execute(&how),
        args::Command::Calibrate(a) => a.execute(&how),
        args::Command::Bench(a) => a.execute(&how),
    }
}

/// `mbs` with the process's arguments: the exit status of
/// [`HostError::exit_code`], the error on standard error.
pub fn main() -> std::process::ExitCode {
    use clap::Parser;
    match execute(args::Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            print_err(&format!("error: {e}"));
            std::process::ExitCode::from(e.exit_code())
        }
    }
}
