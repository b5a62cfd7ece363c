//! Grain storage: a structure of arrays with a compile-time capacity `N`.
//!
//! All-zero bits are a valid, empty value of [`Grains`] (every field is a
//! number, a `bool` or an array of them), which is what lets a host allocate a
//! large simulation directly on the heap and a firmware place it in `.bss`.

use crate::real::Real;

/// Size classes the observables separate (SPEC §8, per size class q*).
pub const MAX_CLASSES: usize = 4;

/// A grain in SI units (`f64`): what the caller adds with
/// [`crate::Sim::add_grain`] and reads back with [`crate::Sim::grain`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GrainSpec {
    /// Streamwise position x (m), in [0, L).
    pub x: f64,
    /// Height y (m).
    pub y: f64,
    /// Streamwise velocity u_p (m/s).
    pub u: f64,
    /// Vertical velocity v_p (m/s).
    pub v: f64,
    /// Spin ω (rad/s), counter-clockwise positive.
    pub spin: f64,
    /// Diameter d (m).
    pub diameter: f64,
    /// A fixed grain never moves and feels no drag (SPEC §4, §7).
    pub fixed: bool,
    /// Size class index, < [`MAX_CLASSES`].
    pub class: u8,
}

/// Structure-of-arrays storage of up to `N` grains.
#[derive(Debug, Clone)]
pub struct Grains<R: Real, const N: usize> {
    /// Number of grains in use.
    pub(crate) len: usize,
    pub(crate) x: [R; N],
    pub(crate) y: [R; N],
    pub(crate) u: [R; N],
    pub(crate) v: [R; N],
    /// Spin ω, counter-clockwise.
    pub(crate) w: [R; N],
    pub(crate) fx: [R; N],
    pub(crate) fy: [R; N],
    pub(crate) torque: [R; N],
    /// Radius d/2.
    pub(crate) r: [R; N],
    /// 1/(ρ(s + C_M)A3 d³); 0 for fixed grains.
    pub(crate) inv_mass: [R; N],
    /// 1/(σπd⁵/60); 0 for fixed grains.
    pub(crate) inv_inertia: [R; N],
    /// ½ρC_D A2 d² (SPEC (5) without ε and |w|).
    pub(crate) drag_coef: [R; N],
    /// Held standard-normal fluctuation draws (SPEC (15)).
    pub(crate) z_u: [R; N],
    pub(crate) z_v: [R; N],
    pub(crate) fixed: [bool; N],
    pub(crate) class: [u8; N],
    /// Scratch of the bed-level search: connected to the fixed layer.
    pub(crate) in_bed: [bool; N],
}

impl<R: Real, const N: usize> Grains<R, N> {
    /// Empty storage (all zero bits).
    pub const fn new() -> Self {
        Grains {
            len: 0,
            x: [R::ZERO; N],
            y: [R::ZERO; N],
            u: [R::ZERO; N],
            v: [R::ZERO; N],
            w: [R::ZERO; N],
            fx: [R::ZERO; N],
            fy: [R::ZERO; N],
            torque: [R::ZERO; N],
            r: [R::ZERO; N],
            inv_mass: [R::ZERO; N],
            inv_inertia: [R::ZERO; N],
            drag_coef: [R::ZERO; N],
            z_u: [R::ZERO; N],
            z_v: [R::ZERO; N],
            fixed: [false; N],
            class: [0; N],
            in_bed: [false; N],
        }
    }
}

impl<R: Real, const N: usize> Default for Grains<R, N> {
    fn default() -> Self {
        Self::new()
    }
}
