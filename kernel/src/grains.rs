//! Grain storage: a structure of arrays with a compile-time capacity `N`.
//!
//! All-zero bits are a valid, empty value of [`Grains`] (every field is a
//! number, a `bool` or an array of them), which is what lets a host allocate a
//! large simulation directly on the heap and a firmware place it in `.bss`.

use crate::real::Real;

/// Size classes the observables separate (docs/model.md §8, per size class q*).
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
    /// A fixed grain never moves and feels no drag (docs/model.md §4, §7).
    pub fixed: bool,
    /// Size class index, < [`MAX_CLASSES`].
    pub class: u8,
}

/// Bytes between two arrays of [`Grains`] on 64-bit hosts: one cache line.
/// Arrays of a power-of-two capacity would otherwise start at addresses
/// that share the same cache sets, and the step reads them all at one index.
const PAD_BYTES: usize = if cfg!(target_pointer_width = "64") {
    64
} else {
    0
};

/// Padding between the arrays of [`Grains`] (none on 32-bit boards, which
/// have no data cache).
pub(crate) type Pad = [u8; PAD_BYTES];

pub(crate) const PAD: Pad = [0; PAD_BYTES];

/// Structure-of-arrays storage of up to `N` grains, in declaration order
/// (`repr(C)`) with a [`Pad`] after each array.
#[derive(Debug, Clone)]
#[repr(C)]
pub struct Grains<R: Real, const N: usize> {
    /// Number of grains in use.
    pub(crate) len: usize,
    pub(crate) x: [R; N],
    _pad1: Pad,
    pub(crate) y: [R; N],
    _pad2: Pad,
    pub(crate) u: [R; N],
    _pad3: Pad,
    pub(crate) v: [R; N],
    _pad4: Pad,
    /// Spin ω, counter-clockwise.
    pub(crate) w: [R; N],
    _pad5: Pad,
    pub(crate) fx: [R; N],
    _pad6: Pad,
    pub(crate) fy: [R; N],
    _pad7: Pad,
    pub(crate) torque: [R; N],
    _pad8: Pad,
    /// Radius d/2.
    pub(crate) r: [R; N],
    _pad9: Pad,
    /// 1/(ρ(s + C_M)A3 d³); 0 for fixed grains.
    pub(crate) inv_mass: [R; N],
    _pad10: Pad,
    /// 1/(σπd⁵/60); 0 for fixed grains.
    pub(crate) inv_inertia: [R; N],
    _pad11: Pad,
    /// ½ρC_D A2 d² (docs/model.md (5) without ε and |w|).
    pub(crate) drag_coef: [R; N],
    _pad12: Pad,
    /// Held standard-normal fluctuation draws (docs/model.md (15)).
    pub(crate) z_u: [R; N],
    _pad13: Pad,
    pub(crate) z_v: [R; N],
    _pad14: Pad,
    pub(crate) fixed: [bool; N],
    _pad15: Pad,
    pub(crate) class: [u8; N],
    _pad16: Pad,
    /// Scratch of the bed-level search: connected to the fixed layer.
    pub(crate) in_bed: [bool; N],
    _pad17: Pad,
    /// Scratch of the bed-level search: highest bed-grain centre per bed-level span.
    pub(crate) span_top: [R; N],
}

impl<R: Real, const N: usize> Grains<R, N> {
    /// Empty storage (all zero bits).
    pub const fn new() -> Self {
        Grains {
            len: 0,
            x: [R::ZERO; N],
            _pad1: PAD,
            y: [R::ZERO; N],
            _pad2: PAD,
            u: [R::ZERO; N],
            _pad3: PAD,
            v: [R::ZERO; N],
            _pad4: PAD,
            w: [R::ZERO; N],
            _pad5: PAD,
            fx: [R::ZERO; N],
            _pad6: PAD,
            fy: [R::ZERO; N],
            _pad7: PAD,
            torque: [R::ZERO; N],
            _pad8: PAD,
            r: [R::ZERO; N],
            _pad9: PAD,
            inv_mass: [R::ZERO; N],
            _pad10: PAD,
            inv_inertia: [R::ZERO; N],
            _pad11: PAD,
            drag_coef: [R::ZERO; N],
            _pad12: PAD,
            z_u: [R::ZERO; N],
            _pad13: PAD,
            z_v: [R::ZERO; N],
            _pad14: PAD,
            fixed: [false; N],
            _pad15: PAD,
            class: [0; N],
            _pad16: PAD,
            in_bed: [false; N],
            _pad17: PAD,
            span_top: [R::ZERO; N],
        }
    }
}

impl<R: Real, const N: usize> Default for Grains<R, N> {
    fn default() -> Self {
        Self::new()
    }
}
