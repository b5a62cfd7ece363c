//! Host side of mbs: configuration, the transport-rate experiment, output
//! files and figures, on top of the `no_std` kernel `mbs-kernel`.
//!
//! | module | concept |
//! |---|---|
//! | [`config`] | TOML configuration, defaults, validation into the run plan |
//! | [`sims`] | heap simulations of a run-time precision and capacity, run with progress |
//! | [`control`] | stopping and checkpointing a resumable job |
//! | [`framing`] | checkpoint files' framing: magic, version, fields, CRC |
//! | [`beds`] | the settled bed of a (configuration, seed), settled once to rest |
//! | [`cell`] | one resumable (τ*, seed) run: its result and its checkpoint file |
//! | [`experiment`] | q*(τ*) over seeds, in parallel, thread-count independent |
//! | [`stats`] | mean and standard error, the precision target, steadiness |
//! | [`store`] | append-only file of finished cells |
//! | [`shard`] | a slice of the cells (`--shard I/N`) and the merge of slices |
//! | [`references`] | bed-load relations of docs/model.md §10 |
//! | [`mixture`] | fractional transport of a mixture with hiding (Wilcock & Crowe 2003) |
//! | [`pack`] | packing test (docs/model.md §9 step 1) |
//! | [`frames`] | particle frames for ParaView and meshio (`.vtu`, `.pvd`) |
//! | [`snapshot`] | bed pictures and particle frames of a bed under the flow |
//! | [`bench`] | hot-loop benchmark shared with criterion |
//! | [`plot`] | figures (PNG + SVG) |
//! | [`output`] | atomic file writes |
//! | [`log`] | `DIR/mbs.log` and the warnings of a command |
//! | [`progress`] | progress: a bar on a terminal, plain lines elsewhere |
//! | [`input`] | bounded reads: files refused unread beyond the largest valid one |
//! | [`text`] | excerpts of long lines for messages, numbers that stay short (file names) |
//! | [`timeseries`] | q*(t) and bed level per cell, per-τ* figure, steadiness and target warnings |
//! | [`trace`] | digest traces: the digest run's field-group digests over time |
//! | [`commands`] | the subcommands of `mbs` |

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
pub use sim::sims::boxed_sim;
