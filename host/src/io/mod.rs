//! Files and terminals: bounded reads, atomic writes, checkpoint framing, the log, progress, short text.

pub mod framing;
pub mod input;
pub mod log;
pub mod output;
pub mod progress;
pub mod text;
