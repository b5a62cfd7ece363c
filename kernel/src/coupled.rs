//! `impl Sim`: the coupled flow (docs/model.md §13): starting its column,
//! and the update every M grain steps that exchanges momentum with the
//! grains. The grains' drag from the column is in the step
//! ([`crate::step`]).

use crate::error::Error;
use crate::real::Real;
use crate::sim::Sim;

impl<R: Real, const N: usize, const K: usize, const C: usize> Sim<R, N, K, C> {
    /// Starts the coupled flow of `self.flow` (validated, its cells fit `C`):
    /// the column at the solid fractions of the grains of now, its velocity
    /// the log law (14) of u* above the mean bed level of now; driven by
    /// `fluid.driving` plus g sin θ of the bed slope. The summed drag of
    /// every grain starts at 0.
    pub(crate) fn start_coupling(&mut self) -> Result<(), Error> {
        self.fluid.on = false;
        if self.nbrs.stale {
            self.rebuild()?;
        }
        self.update_bed_level();
        let mut config = self.flow.fluid;
        config.driving += self.config.slope_driving();
        let fluid = &mut self.fluid;
        fluid.column.reset(&config)?;
        fluid.slabs.clear(fluid.column.grid())?;
        let g = &mut self.grains;
        let n = g.len.min(N);
        for i in 0..n {
            fluid.slabs.add_grain(g.y[i], g.r[i], g.u[i], R::ZERO)?;
        }
        g.drag_sum[..n].fill(R::ZERO);
        let (profile, bed_level) = (&self.profile, self.bed_level);
        fluid
            .column
            .start(&fluid.slabs, |y| profile.mean_velocity(y - bed_level))?;
        fluid.refresh_hindrance(&self.flow.fluid);
        let steps = self.flow.fluid.update_steps.max(1);
        fluid.exchange_dt = R::from_f64(f64::from(steps) * self.config.step_dt);
        fluid.inv_steps = R::from_f64(1.0 / f64::from(steps));
        fluid.on = true;
        Ok(())
    }

    /// The update of the column after M grain steps (docs/model.md §13):
    /// the slabs from the grains of now (docs/model.md (C1)–(C2)), each
    /// mobile grain with the drag it received averaged over the M steps as
    /// an explicit sink (the fluid loses exactly what the grains gained),
    /// each fixed grain with its drag factor Ξ = ½ρC_D A2 d² |u_f| (its
    /// hindrance too) as an implicit sink; one implicit step of M step_dt
    /// (docs/model.md (C6)); the hindrance of the new φ; the sums emptied.
    /// On an error the column's velocities and the sums are unchanged.
    pub(crate) fn exchange(&mut self) -> Result<(), Error> {
        let fluid = &mut self.fluid;
        let g = &mut self.grains;
        let n = g.len.min(N);
        fluid.slabs.clear(fluid.column.grid())?;
        for i in 0..n {
            let (y, r) = (g.y[i], g.r[i]);
            if g.fixed[i] {
                let speed = R::abs(fluid.column.velocity_at(y));
                let xi = g.drag_coef[i] * fluid.hindrance_at(y) * speed;
                fluid.slabs.add_grain(y, r, R::ZERO, xi)?;
            } else {
                let force = g.drag_sum[i] * fluid.inv_steps;
                fluid.slabs.add_exchange(y, r, g.u[i], force)?;
            }
        }
        fluid.column.advance(&fluid.slabs, fluid.exchange_dt)?;
        fluid.refresh_hindrance(&self.flow.fluid);
        g.drag_sum[..n].fill(R::ZERO);
        Ok(())
    }
}
