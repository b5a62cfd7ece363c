//! `mbs config`: prints the embedded default configuration.

use super::common::print;
use super::common::Shared;
use crate::config::DEFAULT_TOML;
use crate::error::HostError;
use clap::Args;

/// The arguments of `mbs config` (none of its own).
#[derive(Args)]
pub struct ConfigArgs {
    /// Shared options (accepted, unused).
    #[command(flatten)]
    pub shared: Shared,
}

/// `mbs config`: the embedded default configuration.
pub fn config() -> Result<(), HostError> {
    print(DEFAULT_TOML)
}
