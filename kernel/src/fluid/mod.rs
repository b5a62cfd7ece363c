//! The coupled flow (docs/model.md §13, option of issue 31): a volume-averaged,
//! one-dimensional vertical column for the streamwise fluid velocity u_f(y),
//! from the bottom of the fixed layer to the free surface, that feels the
//! grains through their solid fraction and their drag.
//!
//! A [`crate::Sim`] with the coupled flow ([`crate::FlowModel::Coupled`])
//! holds a column in its `Coupling` and updates it every
//! [`FluidSpec::update_steps`] integration steps; a caller can also drive a
//! [`Column`] alone: fill [`Slabs`] and call [`Column::advance`]. One concept per file:
//!
//! | file | what | docs/model.md |
//! |---|---|---|
//! | `config` | [`FluidSpec`], the parameters a user chooses, and [`FluidConfig`], those with what the bed gives, validated | §13 |
//! | `grid` | [`Grid`]: the uniform cells (slabs) of the column | §13 |
//! | `slice` | [`slice_volume`]: a sphere's volume between two planes | docs/model.md (C1) |
//! | `slabs` | [`Slabs`]: solid fraction, grain velocity and drag per slab | docs/model.md (C2) |
//! | `mixing` | the mixing length (Li & Sawamoto 1995, free-surface factor) | docs/model.md (C3) |
//! | `tridiagonal` | [`Tridiagonal`]: the Thomas solve in fixed-size arrays | docs/model.md (C6) |
//! | `column` | [`Column`]: the state u_f, one implicit step, the queries | docs/model.md (C4)–(C6) |
//! | `coupling` | `Coupling`: the column inside a `Sim`, its slabs, the table the grains read per cell centre (u_f, the fluctuations' scale, the hindrance, their slopes), the grains' place between the centres | docs/model.md §13, (C7) |
//!
//! Like the rest of the kernel: no allocation (arrays of the capacity `C`,
//! a const generic), never panics (every failure is an [`crate::Error`]),
//! bit-reproducible (fixed loop orders, `sqrt` the only function called, no
//! fused multiply-add), generic over `f32` and `f64`.

mod column;
mod config;
mod coupling;
mod grid;
mod mixing;
mod slabs;
mod slice;
mod tridiagonal;

pub use column::Column;
pub use config::{DragLaw, Fluctuations, FluidConfig, FluidSpec};
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub(crate) use coupling::Cells;
pub(crate) use coupling::Coupling;
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub(crate) use coupling::WALL_SLIP;
pub use grid::Grid;
pub use slabs::Slabs;
pub use slice::slice_volume;
pub use tridiagonal::Tridiagonal;
