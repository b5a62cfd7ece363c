//! # mbs-kernel
//!
//! The physics of the DEM numerical movable bed of Gotoh, Harada & Sakai
//! ("Optimization of parameters in DEM-based numerical movable bed
//! simulator"): sand grains in a vertical 2-D slice, spring–dashpot contacts
//! with friction, drag from a prescribed log-law flow with Monte Carlo
//! turbulence, a randomly packed bed over fixed grains, periodic in x.
//! `docs/model.md` lists the paper's equations, with the paper's numbers.
//!
//! ```
//! use mbs_kernel::{Scenario, Sim};
//!
//! // The paper's case, on a lattice of 5 columns of 2 grains (the paper
//! // has 10 rows) over 5 fixed grains.
//! let mut scenario = Scenario::paper();
//! scenario.bed.rows = 2;
//! // Room for 16 grains of up to 8 neighbours each, in f64.
//! let mut sim = Sim::<f64, 16, 8>::new();
//! let bed = scenario.build(&mut sim)?;
//! assert_eq!((bed.fixed, bed.mobile), (5, 10));
//! // The lattice falls onto the fixed grains (10 000 steps, 25 ms).
//! sim.run(10_000)?;
//! assert!(sim.observe().contacts >= 10);
//! // Switch the flow on (τ* = 0.2) and step on.
//! sim.set_flow(Some(&scenario.flow(0.2)))?;
//! sim.run(400)?;
//! // The digest of the whole state: a copy restored from a checkpoint
//! // has the same bits.
//! let mut bytes = Vec::new();
//! sim.checkpoint(|chunk| bytes.extend_from_slice(chunk));
//! let mut copy = Sim::<f64, 16, 8>::new();
//! copy.restore(&bytes)?;
//! assert_eq!(copy.digest(), sim.digest());
//! # Ok::<(), mbs_kernel::Error>(())
//! ```
//!
//! - `#![no_std]`, no allocator: storage is inline with compile-time
//!   capacities (`N` grains, `K` neighbour slots per grain), and an all-zero
//!   [`Sim`] is a valid empty one ([`Sim::new`]). No `unsafe` outside the
//!   x86-64 vector lanes: eight audited `unsafe` blocks, two in
//!   `lanes.rs` (`read` and `write`: a vector or row from and to
//!   an array of exactly its size), and six calls of
//!   `#[target_feature(enable = "avx2")]` functions, compiled only where the
//!   build enables AVX2: two in the `lanes!` macro of `step/batch/mod.rs`
//!   (the batched step's entry points), three in `step/batch/phases.rs`
//!   (each phase's pass) and one in `neighbours/lanes.rs` (the search's
//!   tests).
//! - Never panics: every failure is an [`Error`].
//! - Bit-reproducible: fixed iteration orders, `libm` for every
//!   transcendental, no fused multiply-add, keyed random streams, canonical
//!   bits in the [digest](Sim::digest). Generic over `f32` and `f64`
//!   ([`Real`]).
//!
//! | docs/model.md | what | where |
//! |---|---|---|
//! | (1)–(3) | equations of motion, symplectic Euler | [`Sim::step`] |
//! | (4)–(5) | drag | [`flow::LogLaw::drag`] |
//! | (6)–(9), (8') | contact law with history; what may pull, [`Tension`] | [`contact::ContactLaw::apply`] |
//! | (10)–(13), (17), (18) | constants from Δt | [`contact_constants`] |
//! | (12)–(13) | tangential constants from normal ones | [`ContactConstants::from_normal`] |
//! | (11) | stability bound of the integration step | [`ContactConstants::stable_dt_limit`] |
//! | (14)–(16) | log law, turbulence, sheltering | [`flow::LogLaw`] |
//! | §6 | mean bed level | [`Sim::bed_level`] |
//! | §6 | the Shields relation, both ways | [`shear_velocity`], [`shields_number`] |
//! | §7 | initial bed | [`Sim::build_bed`], [`Sim::settle`] |
//! | §8 | observables | [`Sim::observe`] |
//! | (C1)–(C7), §13 | the coupled flow: its column, updated every M steps; the grains' drag from it in the step | [`fluid::Column`], [`FlowModel::Coupled`] |
//!
//! ## Layers
//!
//! Each module uses only modules of the layers above it, leaves of its own
//! layer and files of its own folder: there is no import loop
//! (`.ci/cycles.py`). docs/architecture.md lists each file's imports.
//!
//! 1. **Numbers** (leaves): `real` ([`Real`]: `f32` or `f64`, numbers
//!    only), `error` ([`Error`]), `events` ([`Events`]: event counters),
//!    [`random`] (keyed random streams), `periodic` (the minimum image
//!    across the periodic boundary), `digest` ([`Fnv1a`], the digest's
//!    hash, and [`FieldGroup`]), `steps` ([`IntegrationSteps`]: the
//!    kernel's intervals, counts of integration steps Δt/substeps).
//! 2. **Model laws**: `constants` (material, and the contact constants from
//!    Δt: [`contact_constants`]), [`contact`] (the contact law (6)–(9) and
//!    its spring history), [`flow`] (the log law (14)–(16), the drag
//!    (4)–(5), and the choice of clear water or the coupled flow,
//!    [`FlowModel`]), [`fluid`] (the coupled flow's 1-D column, §13:
//!    (C1)–(C7)).
//! 3. **Storage and records**: `grains` (the grains, a structure of
//!    arrays), `neighbours` (each grain's neighbour slots with their spring
//!    history, and the binned search that fills them), and the records
//!    a simulation takes or gives that need no [`Sim`]: `bed` ([`BedSpec`]
//!    and what building and settling a bed made, §7), `observe`
//!    ([`Observation`], [`q_star`], §8), `fields` ([`GrainField`]).
//! 4. **Step** (`step`): the two paths, on the data they are handed; they
//!    know nothing of [`Sim`]. `step::mover` (symplectic Euler (1)–(3)
//!    with the domain checks, shared by both paths), `step::scalar` (the
//!    **scalar step**: portable, one grain at a time), `step::batch` (the
//!    **batched step** in x86-64 AVX2 vector lanes: `lanes`, the lane types
//!    of both precisions and their operations; its passes `drag` (4)–(5)
//!    and §13, `pairs` (6)–(9) and `grains` (1)–(3); `params`, what they
//!    read) and `step::index` (its pair index; `step::no_lanes` stands in
//!    for it elsewhere), and `step::phased` (the **phased step**: the
//!    scalar step's operations in two phases over ranges of grains, run by
//!    the caller's [`Executor`] on one core or many, with [`Phases`], its
//!    buffers, in `step::buffers`). All paths give the same bits.
//! 5. **Sim** (`sim`): [`Sim`], its state and configuration ([`SimConfig`]),
//!    adding grains, switching the flow, reading the state, and the
//!    `impl Sim` blocks of its topics, one file each: `sim::step`
//!    ([`Sim::step`], [`Sim::run`]: the neighbour refresh, the flow's
//!    bookkeeping, the dispatch to the paths), `sim::phased`
//!    ([`Sim::step_phased`]: the same step in phases over ranges of grains), `sim::coupled` (the
//!    coupled flow's start and its update every M steps), `sim::bed` (the
//!    initial bed, settling, [`RestWatch`], the mean bed level),
//!    `sim::observe` ([`Sim::observe`]), `sim::checkpoint`
//!    ([`Sim::checkpoint`], [`Sim::restore`]), `sim::digest`
//!    ([`Sim::digest`]) and `sim::fields` (one grain's field read or moved
//!    by ULPs, [`Sim::nudge`]).
//! 6. **Scenario** (`scenario`): [`Scenario`], a complete run set-up (the
//!    paper's by default) from which the host, the golden tests and the
//!    firmware all build their simulations.
//!
//! The pair index of the batched step is a field of [`Sim`], not of the
//! neighbour storage: while it is ready it holds the spring history, and
//! the slots get it back before the scalar step or a rebuild reads them.
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

#[cfg(test)]
extern crate std;

mod bed;
mod constants;
pub mod contact;
mod digest;
mod error;
mod events;
mod executor;
mod fields;
pub mod flow;
pub mod fluid;
mod grains;
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
mod lanes;
mod neighbours;
mod observe;
mod periodic;
pub mod random;
mod real;
mod scenario;
mod sim;
mod step;
mod steps;

pub use bed::{BedInfo, BedSpec, Rest, Settled, SizeClass};
pub use constants::{
    contact_constants, explicit_damping_number, ContactConstants, Material, TimeStepRule, A2, A3,
};
pub use contact::Tension;
pub use digest::{FieldGroup, Fnv1a};
pub use error::{Capacity, CheckpointFault, Error, Quantity};
pub use events::Events;
pub use executor::{cut_ranges, Executor, Phase, Ranges, Serial};
pub use fields::GrainField;
pub use flow::{
    shear_velocity, shields_number, uniform_flow_shields_number, FlowConfig, FlowModel, FlowSpec,
};
pub use fluid::{DragLaw, Fluctuations, FluidSpec};
pub use grains::{GrainSpec, MAX_CLASSES};
pub use observe::{q_star, transport_scale, Observation};
pub use real::Real;
pub use scenario::{Scenario, G};
pub use sim::{ContactForce, RestWatch, Sim, SimConfig, CHECKPOINT_VERSION};
pub use step::buffers::Phases;
pub use steps::IntegrationSteps;
