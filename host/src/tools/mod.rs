//! Commands beside the main job: the packing test, bed snapshots, the benchmark, digest traces.

pub mod bench;
pub mod pack;
pub mod snapshot;
pub mod trace;
