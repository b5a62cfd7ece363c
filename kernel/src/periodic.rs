//! The periodic x direction: the domain repeats every width L, so the
//! separation of two grains is the shortest of their periodic images. A
//! leaf: the neighbour search, the steps and the observables all use it.

use crate::real::Real;

/// Minimum-image separation in the periodic x direction: `dx` moved by
/// ±`width` into [−`half_width`, `half_width`].
#[inline]
pub(crate) fn periodic<R: Real>(dx: R, width: R, half_width: R) -> R {
    if dx > half_width {
        dx - width
    } else if dx < -half_width {
        dx + width
    } else {
        dx
    }
}
