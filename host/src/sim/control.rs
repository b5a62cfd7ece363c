//! Stopping and checkpointing a resumable job (a cell, a settling bed):
//! a stop requested by Ctrl-C or after a number of steps, and timed
//! checkpoints, each written atomically to the job's file.

use crate::error::HostError;
use crate::io::output::write_atomic;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The fewest integration steps between two timed checkpoints of a job
/// (`--checkpoint-every`): a shorter interval would write checkpoints more
/// often than the job steps (each is a file synced to disk).
pub const MIN_CHECKPOINT_STEPS: u64 = 2000;

/// When a job stops early and where it checkpoints.
pub struct Control<'a> {
    /// Checkpoint file of this job.
    pub path: Option<PathBuf>,
    /// Wall-clock interval between checkpoints (and at least
    /// [`MIN_CHECKPOINT_STEPS`] steps).
    pub every: Option<Duration>,
    /// Set asynchronously (Ctrl-C): checkpoint and stop at the next chunk.
    pub stop: &'a AtomicBool,
    /// Stop (with a checkpoint) after this many steps of this invocation (tests).
    pub stop_after: Option<u64>,
}

impl Control<'_> {
    /// A job that never stops and never checkpoints.
    pub fn never(stop: &AtomicBool) -> Control<'_> {
        Control {
            path: None,
            every: None,
            stop,
            stop_after: None,
        }
    }
}

/// When to write a checkpoint and whether to stop, for a job that has
/// stepped `stepped` integration steps in this invocation.
pub struct Checkpoints<'a> {
    control: &'a Control<'a>,
    last: Instant,
    stepped_at_last: u64,
}

impl<'a> Checkpoints<'a> {
    /// Starts timing.
    pub fn new(control: &'a Control<'a>) -> Self {
        Checkpoints {
            control,
            last: Instant::now(),
            stepped_at_last: 0,
        }
    }

    /// Writes `encode()` to the job's file when a stop is requested or a
    /// timed checkpoint is due; true if the job must stop now.
    pub fn due(
        &mut self,
        stepped: u64,
        encode: impl FnOnce() -> Vec<u8>,
    ) -> Result<bool, HostError> {
        let c = self.control;
        let stop_now = c.stop.load(Ordering::Relaxed) || c.stop_after.is_some_and(|n| stepped >= n);
        let due = c.every.is_some_and(|every| {
            self.last.elapsed() >= every && stepped - self.stepped_at_last >= MIN_CHECKPOINT_STEPS
        });
        if stop_now || due {
            if let Some(path) = &c.path {
                write_atomic(path, &encode())?;
            }
            self.last = Instant::now();
            self.stepped_at_last = stepped;
        }
        Ok(stop_now)
    }
}
