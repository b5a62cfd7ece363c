//! The periodic x direction: the domain repeats every width L, so the
//! separation of two grains is the shortest of their periodic images, and
//! a grain's x stays in [0, L). A leaf: the neighbour search, the steps,
//! the placement of grains and the observables all use it.

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

/// `x` brought into [0, `width`) across the seam, as every grain is kept:
/// x − width at or past the width, x + width below 0 (+0 where that sum
/// rounds up to the width); and whether it crossed. Exact for x within a
/// width of the domain.
#[inline]
pub(crate) fn into_domain<R: Real>(x: R, width: R) -> (R, bool) {
    if x >= width {
        (x - width, true)
    } else if x < R::ZERO {
        let x = x + width;
        // −tiny + L rounded up to L.
        (if x >= width { R::ZERO } else { x }, true)
    } else {
        (x, false)
    }
}
