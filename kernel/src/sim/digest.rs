//! `impl Sim`: a 64-bit digest of the complete simulation state over
//! canonical bits (−0.0 as +0.0, one NaN pattern), little-endian, FNV-1a
//! ([`Fnv1a`]). Equal digests on two machines mean the same bits in every
//! grain, contact and counter. [`FieldGroup`]: one group of fields alone.

use crate::digest::{FieldGroup, Fnv1a};
use crate::real::Real;
use crate::sim::Sim;

impl<R: Real, const N: usize, const K: usize, const C: usize> Sim<R, N, K, C> {
    /// Digest of the state: step count, grains (position, velocity, spin,
    /// diameter, fixed, class, held fluctuation draws), the contacts in
    /// (i, j) order with their spring history, the generator state (seed and
    /// flow epoch; draws are keyed by these), the bed level and, with the
    /// coupled flow, its state (per fluid cell: u_f, φ, the carried force, the
    /// grains' drag summed since the last update).
    ///
    /// ```
    /// use mbs_kernel::{Scenario, Sim};
    ///
    /// let mut a = Sim::<f64, 64, 8>::new();
    /// Scenario::paper().build(&mut a)?;
    /// let mut b = a.clone();
    /// assert_eq!(a.digest(), b.digest());
    /// b.step()?;
    /// assert_ne!(a.digest(), b.digest());
    /// # Ok::<(), mbs_kernel::Error>(())
    /// ```
    pub fn digest(&self) -> u64 {
        let mut h = Fnv1a::default();
        let g = &self.grains;
        h.word(self.step);
        h.word(g.len as u64);
        for i in 0..g.len {
            for x in [
                g.x[i], g.y[i], g.u[i], g.v[i], g.w[i], g.r[i], g.z_u[i], g.z_v[i],
            ] {
                h.real(x);
            }
            h.word(u64::from(g.fixed[i]) | u64::from(g.class[i]) << 8);
        }
        for (i, j, s) in self.contacts() {
            h.word(i as u64);
            h.word(j as u64);
            h.real(s.e_n);
            h.real(s.e_s);
        }
        self.flow_state_digest(&mut h);
        h.finish()
    }

    /// Adds the seed and the flow's state to `h`: the flow's epoch, whether
    /// it is on, the mean bed level, HydroForceEngine's redraw schedule
    /// (only with those fluctuations) and the coupled flow's column
    /// ([`Sim::digest`] and the flow group of [`Sim::group_digest`] end
    /// with it).
    fn flow_state_digest(&self, h: &mut Fnv1a) {
        h.word(self.config.seed);
        h.word(self.flow_epoch);
        h.word(u64::from(self.flow_on));
        h.real(self.bed_level);
        if self.fluid.on && self.fluid.closures.hfe {
            h.word(self.redraw.next);
            h.word(self.redraw.period);
        }
        self.fluid_digest(h);
    }

    /// Adds the coupled flow's state to `h`: each fluid cell's u_f, φ, the
    /// stabiliser's force carried to the next update and the grains' drag
    /// summed since the last; nothing with clear water (its digests are
    /// those of before the coupled flow).
    fn fluid_digest(&self, h: &mut Fnv1a) {
        if let Some(column) = self.fluid_column() {
            let f = &self.fluid;
            let fluid_cells = column.velocities().iter().zip(column.solid_fractions());
            for ((&u, &phi), (&carried, &drag)) in
                fluid_cells.zip(f.carried.iter().zip(&f.drag_sum))
            {
                h.real(u);
                h.real(phi);
                h.real(carried);
                h.real(drag);
            }
        }
    }
}

impl<R: Real, const N: usize, const K: usize, const C: usize> Sim<R, N, K, C> {
    /// Digest (FNV-1a over canonical bits, as [`Sim::digest`]) of one
    /// group of fields alone: equal full digests imply nothing about the
    /// groups' and the reverse, but a full digest that differs has at least
    /// one group that differs (every group's fields are in the full digest).
    ///
    /// ```
    /// use mbs_kernel::{FieldGroup, Scenario, Sim};
    ///
    /// let mut a = Sim::<f64, 64, 8>::new();
    /// Scenario::paper().build(&mut a)?;
    /// let b = a.clone();
    /// a.run(10)?;
    /// // Falling grains: positions and velocities change, spins stay zero.
    /// assert_ne!(a.group_digest(FieldGroup::Positions), b.group_digest(FieldGroup::Positions));
    /// assert_ne!(a.group_digest(FieldGroup::Velocities), b.group_digest(FieldGroup::Velocities));
    /// assert_eq!(a.group_digest(FieldGroup::Spins), b.group_digest(FieldGroup::Spins));
    /// # Ok::<(), mbs_kernel::Error>(())
    /// ```
    pub fn group_digest(&self, group: FieldGroup) -> u64 {
        let mut h = Fnv1a::default();
        let g = &self.grains;
        let n = g.len;
        match group {
            FieldGroup::Positions => (0..n).for_each(|i| {
                h.real(g.x[i]);
                h.real(g.y[i]);
            }),
            FieldGroup::Velocities => (0..n).for_each(|i| {
                h.real(g.u[i]);
                h.real(g.v[i]);
            }),
            FieldGroup::Spins => (0..n).for_each(|i| h.real(g.w[i])),
            FieldGroup::Springs => {
                for (i, j, s) in self.contacts() {
                    h.word(i as u64);
                    h.word(j as u64);
                    h.real(s.e_n);
                    h.real(s.e_s);
                }
            }
            FieldGroup::Flow => {
                h.word(self.step);
                (0..n).for_each(|i| {
                    h.real(g.z_u[i]);
                    h.real(g.z_v[i]);
                });
                self.flow_state_digest(&mut h);
            }
        }
        h.finish()
    }
}
