//! What a search's tests read and write: the grain it is at ([`At`],
//! with its scalar test of candidates) and the neighbours found for it
//! ([`Found`]); shared by the search ([`super::Search`]) and its tests in
//! lanes (`super::lanes`).

use crate::grains::Grains;
use crate::periodic::periodic;
use crate::real::Real;

/// The grain a search is at: what its tests of candidates read.
pub(super) struct At<R: Real> {
    pub(super) i: usize,
    pub(super) x: R,
    pub(super) y: R,
    pub(super) r: R,
    pub(super) skin: R,
    pub(super) width: R,
    pub(super) half_width: R,
}

impl<R: Real> At<R> {
    /// Whether a grain at (x, y) of radius r lies within reach: its
    /// separation (through the periodic image if `SEAM`) shorter than the
    /// radii and the skin.
    #[inline(always)]
    pub(super) fn near<const SEAM: bool>(&self, x: R, y: R, r: R) -> bool {
        let dx = x - self.x;
        let ddx = if SEAM {
            periodic(dx, self.width, self.half_width)
        } else {
            dx
        };
        let ddy = y - self.y;
        let reach = self.r + r + self.skin;
        ddx * ddx + ddy * ddy < reach * reach
    }

    /// Adds to `found` the grains j of `order` in `runs` within reach of
    /// grain i, j > i only (a run may hold grains already searched), no
    /// fixed–fixed pair. `SEAM`: the separation's periodic image is taken
    /// (else the separation itself); `FIXED`: grain i is fixed. Branch-free
    /// on the outcome of a test.
    #[inline(always)]
    pub(super) fn test<const N: usize, const SEAM: bool, const FIXED: bool>(
        &self,
        g: &Grains<R, N>,
        order: &[u32],
        runs: &[(u32, u32)],
        found: &mut Found,
    ) {
        for &(from, to) in runs {
            for &j in order.get(from as usize..to as usize).unwrap_or(&[]) {
                let j = j as usize;
                let (Some(&x), Some(&y), Some(&r)) = (g.x.get(j), g.y.get(j), g.r.get(j)) else {
                    continue;
                };
                let near = self.near::<SEAM>(x, y, r);
                let both_fixed = FIXED && g.fixed.get(j).is_some_and(|&f| f);
                found.push(j as u32, (j > self.i) & !both_fixed & near);
            }
        }
    }
}

/// Most neighbours a build may find for one grain: a grain with more
/// fails the build ([`crate::error::Capacity::NeighboursPerGrain`])
/// whatever `K`.
pub(super) const FOUND_MAX: usize = 64;

/// The neighbours found for one grain so far.
pub(super) struct Found {
    /// The grains found (and room for a vector's lanes past the most).
    pub(super) js: [u32; FOUND_MAX + 8],
    pub(super) len: usize,
}

impl Found {
    pub(super) fn new() -> Self {
        Found {
            js: [0; FOUND_MAX + 8],
            len: 0,
        }
    }

    /// Adds j if `keep`, without a branch on it: j is written in the next
    /// place either way (a later j overwrites it if not kept).
    #[inline]
    pub(super) fn push(&mut self, j: u32, keep: bool) {
        self.js[self.len.min(FOUND_MAX - 1)] = j;
        self.len += usize::from(keep);
    }

    /// The grains found, ascending (insertion sort: a few per grain), or
    /// `None` if more than `capacity` (or [`FOUND_MAX`] − 1) were found.
    pub(super) fn sorted(&mut self, capacity: usize) -> Option<&[u32]> {
        if self.len > capacity.min(FOUND_MAX - 1) {
            return None;
        }
        let len = self.len;
        let js = self.js.get_mut(..len)?;
        for k in 1..js.len() {
            let mut m = k;
            while m > 0 && js[m - 1] > js[m] {
                js.swap(m - 1, m);
                m -= 1;
            }
        }
        Some(js)
    }
}
