//! # mbs-kernel
//!
//! The physics of the DEM numerical movable bed of Gotoh, Harada & Sakai
//! ("Optimization of parameters in DEM-based numerical movable bed
//! simulator"): sand grains in a vertical 2-D slice, spring–dashpot contacts
//! with friction, drag from a prescribed log-law flow with Monte Carlo
//! turbulence, a randomly packed bed over fixed grains, periodic in x.
//! `docs/model.md` lists the paper's equations, with the paper's numbers.
//!
//! - `#![no_std]`, no allocator: storage is inline with compile-time
//!   capacities (`N` grains, `K` neighbour slots per grain). No `unsafe`
//!   outside the x86-64 vector lanes (`batch`: three audited lines).
//! - Never panics: every failure is an [`Error`].
//! - Bit-reproducible: fixed iteration orders, `libm` for every
//!   transcendental, no fused multiply-add, keyed random streams, canonical
//!   bits in the [digest](Sim::digest). Generic over `f32` and `f64`.
//!
//! | docs/model.md | what | where |
//! |---|---|---|
//! | (1)–(3) | equations of motion, symplectic Euler | [`Sim::step`] |
//! | (4)–(5) | drag | [`flow::Profile::drag`] |
//! | (6)–(9) | contact law with history | [`contact::ContactLaw::apply`] |
//! | (10)–(13), (17), (18) | constants from Δt | [`contact_constants`] |
//! | (14)–(16) | log law, turbulence, sheltering | [`flow::Profile`] |
//! | §6 | mean bed level | [`Sim::bed_level`] |
//! | §7 | initial bed | [`Sim::build_bed`], [`Sim::settle`] |
//! | §8 | observables | [`Sim::observe`] |
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

#[cfg(test)]
extern crate std;

mod bed;
mod checkpoint;
mod constants;
pub mod contact;
mod digest;
mod error;
pub mod flow;
mod grains;
mod neighbours;
mod observe;
mod periodic;
pub mod random;
mod real;
mod scenario;
mod sim;
mod step;

pub use bed::{BedInfo, BedSpec, Settled, SizeClass};
pub use checkpoint::CHECKPOINT_VERSION;
pub use constants::{
    contact_constants, explicit_damping_number, ContactConstants, Material, TimeStepRule, A2, A3,
};
pub use digest::Fnv1a;
pub use error::{Capacity, CheckpointFault, Error, Quantity};
pub use flow::{shear_velocity, FlowConfig};
pub use grains::{GrainSpec, MAX_CLASSES};
pub use observe::{q_star, Observation};
pub use real::Real;
pub use scenario::{Scenario, G};
pub use sim::{Sim, SimConfig};
