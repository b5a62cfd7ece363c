//! Host side of mbs: configuration, the transport-rate experiment, output
//! files and figures, on top of the `no_std` kernel `mbs-kernel`. The
//! command line ([`cli`]) is a thin layer over this library, which is what
//! a Python package wraps.
//!
//! ## Layers
//!
//! Each folder is a layer; a module imports only from its own folder and
//! from folders of the same or a lower layer, never from a higher one, and
//! no files import each other in a loop (`.ci/cycles.py` checks both in CI).
//!
//! | layer | folder | what |
//! |---|---|---|
//! | 0 | [`error`] | every way mbs fails ([`HostError`], [`ConfigError`]) and its exit status |
//! | 0 | [`io`] | files and terminals: bounded reads, atomic writes, checkpoint framing, the log, progress, short text |
//! | 1 | [`science`] | bed-load relations, hiding in mixtures, measured profiles, means and their errors |
//! | 2 | [`config`] | the TOML configuration: format, defaults, overrides, validation into the run plan |
//! | 2 | [`figures`] | figures (PNG + SVG) from plain series |
//! | 3 | [`sim`] | heap simulations of a run-time precision and capacity; stopping and checkpointing; particle frames |
//! | 4 | [`work`] | settled beds, resumable (τ*, seed) cells, their profiles, the store of finished cells, shards, the experiment |
//! | 5 | [`report`] | what a run writes, as a function of its outcome |
//! | 6 | [`tools`] | beside the main job: the packing test, snapshots, the benchmark, digest traces |
//! | 7 | [`calibrate`] | the paper's parameter optimisation, automated |
//! | 8 | [`cli`] | the command line: one file per subcommand |
//!
//! docs/architecture.md lists every module with its imports.

pub mod calibrate;
pub mod cli;
pub mod config;
pub mod error;
pub mod figures;
pub mod io;
pub mod report;
pub mod science;
pub mod sim;
pub mod tools;
pub mod work;

pub use config::{Config, ConfigError, Precision};
pub use error::HostError;
/// The progress bars' crate, for a library user who takes the run's bar
/// (`cli::RunOptions::progress_to`).
pub use indicatif;
pub use sim::sims::boxed_sim;
