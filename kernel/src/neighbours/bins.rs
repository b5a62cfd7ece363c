//! The bins of a build: square, at least the largest cut-off wide,
//! periodic in x and hashed into buckets ([`Bins`]), and a grain's bin and
//! bucket.

use crate::grains::Grains;
use crate::real::Real;

/// The bins of a build ([`super::Neighbours::sort`]): square, at least the
/// largest cut-off wide, `nx` across the periodic width and hashed into
/// `buckets` buckets from `y_min` up; what a search reads besides the
/// sorted grains.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Bins<R: Real> {
    pub(super) nx: u32,
    pub(super) inv_bin: R,
    pub(super) y_min: R,
    pub(super) buckets: usize,
    pub(super) may_repeat: bool,
    pub(super) width: R,
    pub(super) skin: R,
}

impl<R: Real> Bins<R> {
    /// Grain i's bin (bx, by) and its bucket.
    #[inline]
    pub(super) fn bucket_of<const N: usize>(
        &self,
        g: &Grains<R, N>,
        i: usize,
    ) -> (u32, u32, usize) {
        let bx = ((g.x[i] * self.inv_bin).to_f64() as u32).min(self.nx - 1);
        let by = (((g.y[i] - self.y_min) * self.inv_bin).to_f64() as u32).min(1 << 30);
        (bx, by, bucket(bx, by, self.nx, self.buckets))
    }
}

/// Buckets for `n` grains with capacity `capacity`: the smallest power of
/// two ≥ n, or the largest that fits the capacity (none if it is 0).
pub(super) fn bucket_count(n: usize, capacity: usize) -> usize {
    let fits = capacity.checked_ilog2().map_or(0, |log| 1 << log);
    n.max(1)
        .checked_next_power_of_two()
        .unwrap_or(fits)
        .min(fits)
}

/// Bucket of bin (bx, by) among `buckets` (a power of two).
#[inline]
pub(super) fn bucket(bx: u32, by: u32, nx: u32, buckets: usize) -> usize {
    ((by as u64 * nx as u64 + bx as u64) & (buckets as u64 - 1)) as usize
}
