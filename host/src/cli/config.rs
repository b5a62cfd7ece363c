//! `mbs config`: prints the embedded default configuration, or checks a
//! configuration (a file, `--set` overrides) and prints it as a run would
//! use it.

use super::common::print;
use super::common::{config_text, Invocation, Shared};
use crate::config::DEFAULT_TOML;
use crate::error::HostError;
use clap::Args;
use std::path::PathBuf;

/// The arguments of `mbs config`.
#[derive(Args)]
pub struct ConfigArgs {
    /// A configuration to check and print as a run echoes it in
    /// `DIR/config.toml` (docs/guarantees.md); without it and without --set, the
    /// embedded default with its comments.
    pub config: Option<PathBuf>,
    /// Shared options (`--set` applies).
    #[command(flatten)]
    pub shared: Shared,
}

impl ConfigArgs {
    /// `mbs config [CONFIG] [--set …]`: the embedded default as shipped, or
    /// the configuration checked exactly as `mbs run` checks it (exit 2
    /// naming the key, the value, the range and where it was given) and
    /// printed as the run would echo it.
    pub fn execute(self, how: &Invocation) -> Result<(), HostError> {
        if self.config.is_none() && how.sets.is_empty() {
            return print(DEFAULT_TOML);
        }
        let config = how.load(self.config.as_deref())?;
        print(&config_text(
            &config,
            std::path::Path::new(super::RUN_CONFIG),
        )?)
    }
}
