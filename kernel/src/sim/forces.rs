//! `impl Sim`: each contact's force as the next step will apply it
//! ([`ContactForce`], docs/model.md (6)–(9)), for the granular stress of
//! a coarse-graining (docs/model.md §8) and the frames' per-grain forces.

use crate::periodic::periodic;
use crate::real::Real;
use crate::sim::Sim;

/// One contact between grains `i` < `j`: the branch from i's centre to
/// j's (its periodic image nearest to i) and the force on i from j (N);
/// j feels the opposite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactForce {
    /// The first grain.
    pub i: usize,
    /// The second grain.
    pub j: usize,
    /// x_j − x_i (minimum image) and y_j − y_i (m).
    pub branch: [f64; 2],
    /// The force on i from j (N): −f_n n + f_s t of docs/model.md §2.
    pub force: [f64; 2],
}

impl<R: Real, const N: usize, const K: usize, const C: usize> Sim<R, N, K, C> {
    /// Calls `visit` with every contact's force as the next step will apply
    /// it: the contact law (6)–(9) ([`crate::contact::ContactLaw::apply`]) on a copy
    /// of the spring history, with the overlap and relative velocities of
    /// now; nothing changes. Contacts in (i, j) order; a contact whose
    /// spring the next step would break (8) is left out.
    ///
    /// ```
    /// use mbs_kernel::{Scenario, Sim};
    ///
    /// let mut sim = Sim::<f64, 64, 8>::new();
    /// Scenario::paper().build(&mut sim)?;
    /// sim.run(20_000)?; // the lattice falls onto the fixed grains
    /// // The contacts carry the grains' weight: compression, each grain
    /// // pushed away from the other along their branch.
    /// let (mut contacts, mut virial) = (0, 0.0);
    /// sim.contact_forces(|c| {
    ///     assert!(c.i < c.j);
    ///     contacts += 1;
    ///     virial += c.force[0] * c.branch[0] + c.force[1] * c.branch[1];
    /// });
    /// assert!(contacts > 0 && virial < 0.0);
    /// # Ok::<(), mbs_kernel::Error>(())
    /// ```
    pub fn contact_forces(&self, mut visit: impl FnMut(ContactForce)) {
        let g = &self.grains;
        let (width, law) = (self.width, self.law);
        let half = width * R::HALF;
        for (i, j, spring) in self.contacts() {
            if i >= g.len || j >= g.len {
                continue;
            }
            let dx = periodic(g.x[j] - g.x[i], width, half);
            let dy = g.y[j] - g.y[i];
            let dist = R::sqrt(dx * dx + dy * dy);
            let overlap = g.r[i] + g.r[j] - dist;
            if overlap <= R::ZERO || dist == R::ZERO {
                continue;
            }
            // The scalar step's geometry: n from i to j, t = (n_y, −n_x).
            let (nx, ny) = (dx / dist, dy / dist);
            let (tx, ty) = (ny, -nx);
            let (du, dv) = (g.u[i] - g.u[j], g.v[i] - g.v[j]);
            let v_n = du * nx + dv * ny;
            let v_s = -(du * tx + dv * ty) + g.r[i] * g.w[i] + g.r[j] * g.w[j];
            let mut history = spring;
            let Some((f_n, f_s)) = law.apply(&mut history, overlap, v_n, v_s) else {
                continue;
            };
            visit(ContactForce {
                i,
                j,
                branch: [dx.to_f64(), dy.to_f64()],
                force: [
                    (-f_n * nx + f_s * tx).to_f64(),
                    (-f_n * ny + f_s * ty).to_f64(),
                ],
            });
        }
    }
}
