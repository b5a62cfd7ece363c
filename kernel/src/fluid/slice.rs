//! A grain's share of a slab (docs/model.md (C1)).

use crate::real::Real;

/// π.
const PI: f64 = core::f64::consts::PI;

/// Volume (m³) of the part of a sphere of radius `r` between the planes at
/// heights `z_lo` < `z_hi` measured from its centre (clipped to [−r, r]):
/// π [r² (z_hi − z_lo) − (z_hi³ − z_lo³)/3], docs/model.md (C1). Zero if the
/// planes do not cut the sphere. The grains are spheres, as their masses
/// (docs/model.md §2), in a slice one diameter thick (docs/model.md §13).
///
/// ```
/// use mbs_kernel::fluid::slice_volume;
///
/// let r = 1.0f64;
/// let whole = 4.0 / 3.0 * core::f64::consts::PI;
/// assert!((slice_volume(r, -2.0, 2.0) - whole).abs() < 1e-15);
/// assert!((slice_volume(r, 0.0, 1.0) - whole / 2.0).abs() < 1e-15);
/// assert_eq!(slice_volume(r, 1.5, 2.0), 0.0);
/// ```
pub fn slice_volume<R: Real>(r: R, z_lo: R, z_hi: R) -> R {
    let a = R::max(z_lo, -r);
    let b = R::min(z_hi, r);
    if b > a {
        // Never negative: a thin slice's two terms cancel to round-off.
        let v = R::from_f64(PI) * (r * r * (b - a) - (b * b * b - a * a * a) / R::from_f64(3.0));
        R::max(v, R::ZERO)
    } else {
        R::ZERO
    }
}
