//! Heap simulations of a run-time precision and capacity, and what touches one: stopping and checkpointing, particle frames.

pub mod control;
pub mod frames;
pub mod sims;
pub mod team;
pub mod threads;
