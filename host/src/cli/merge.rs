//! `mbs merge` and `mbs calibrate merge`: the cell stores of shard output
//! directories into one directory.

use super::common::print;
use super::common::Shared;
use crate::calibrate::merge;
use crate::error::HostError;
use clap::Args;
use std::path::PathBuf;

/// The arguments of `mbs merge` and `mbs calibrate merge`.
#[derive(Args)]
pub struct MergeArgs {
    /// Shared options (`--quiet`: no report; the others accepted, unused).
    #[command(flatten)]
    pub shared: Shared,
    /// Shard output directories.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// The directory to merge into (then rerun the command without --shard
    /// and with --out DIR to finish).
    #[arg(long)]
    pub out: PathBuf,
}

impl MergeArgs {
    /// Merges, then says (unless `quiet`) how to finish with `finish`, the
    /// command to run on the merged directory (e.g. `the same command
    /// without --shard`).
    pub fn merge(self, finish: &str, quiet: bool) -> Result<(), HostError> {
        super::common::directory("--out", &self.out)?;
        for shard in &self.shards {
            if shard.exists() && !shard.is_dir() {
                return Err(crate::ConfigError::Invalid {
                    key: "SHARDS".into(),
                    value: shard.display().to_string(),
                    allowed: "output directories of runs with --shard (this is not a directory)"
                        .into(),
                }
                .into());
            }
        }
        let added = merge(&self.shards, &self.out)?;
        if quiet {
            return Ok(());
        }
        print(&format!(
            "merged {added} new cells into {}; finish with {finish}\n",
            self.out.display()
        ))
    }

    /// `mbs merge`.
    pub fn execute(self, quiet: bool) -> Result<(), HostError> {
        let finish = format!(
            "the same command without --shard and with --out {}",
            self.out.display()
        );
        self.merge(&finish, quiet)
    }
}
