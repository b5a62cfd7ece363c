//! The step's two paths (docs/model.md §2: equations of motion (1)–(3),
//! symplectic Euler), which give the same bits. They work on what they are
//! handed (the grains, the neighbour slots or the pair index, the flow's
//! log law or the coupled flow's fluid cells, the contact law, the integrator)
//! and know nothing of [`crate::Sim`]; its `step` (`sim/step.rs`) does the
//! bookkeeping and picks the path:
//!
//! - the **batched step** (`batch`, x86-64 with AVX2): the drag, every
//!   listed pair's force and every grain's motion in vector lanes, over
//!   the pairs of its pair index (`index`, a field of the `Sim`);
//! - the **scalar step** ([`scalar`], every target, and wherever the pairs
//!   do not fit the index): one grain at a time.
//!
//! Both move grains with the same integrator ([`mover`]). Without vector
//! lanes, `no_lanes` stands in for the pair index. The **phased step**
//! ([`phased`]) runs the scalar step's operations in two phases over ranges
//! of grains, for several cores, with its bits; where the batched step has
//! lanes, it runs the batched step's passes in such phases.
//!
//! With the coupled flow (docs/model.md §13) each path finds the drag of
//! every mobile grain from the column as it finds the clear-water drag,
//! the batched step in lanes, the scalar step one grain at a time
//! ([`scalar::add_coupled_drag`]), and adds each grain's streamwise drag to
//! the fluid cells' sums in grain order.

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub(crate) mod batch;
pub(crate) mod buffers;
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub(crate) mod index;
pub(crate) mod mover;
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
pub(crate) mod no_lanes;
pub(crate) mod phased;
pub(crate) mod scalar;

/// Whether the scalar step finds each grain's contact geometry while the
/// previous grain is finished: on out-of-order cores its square roots and
/// divisions, the step's longest latencies, then overlap that work
/// (x86-64: ~15 % less time per grain-step for ~15 % more instructions).
/// Not on microcontrollers: in-order cores gain nothing, and the buffers
/// would take stack the largest bed does not have.
pub(crate) const GEOMETRY_AHEAD: bool = !cfg!(target_os = "none");
