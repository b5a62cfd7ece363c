//! The main job's units of work: settled beds, resumable cells, their profiles, the store of finished cells, shards, and the experiment over them.

pub mod beds;
pub mod cell;
pub mod experiment;
pub mod job;
pub mod profiles;
pub mod session;
pub mod shard;
pub mod store;
