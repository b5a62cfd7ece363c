//! `impl Sim`: the coupled flow (docs/model.md §13): starting its column,
//! and the update every M grain steps that exchanges momentum with the
//! grains. The grains' drag from the column is in the step
//! ([`crate::step`]).

use crate::error::Error;
use crate::real::Real;
use crate::sim::Sim;

/// Implicit steps at most that bring a starting column to its steady state
/// over the grains at rest ([`Sim::steady_column`]).
const STEADY_STEPS: u32 = 2000;

/// Their time step, in units of the column's slowest time scale
/// H/(κ u*) (H its height): large steps of the implicit scheme.
const STEADY_DT: f64 = 0.1;

/// The steady state is reached when no velocity changes in a step by more
/// than this fraction of the largest: in f64; in f32, [`STEADY_TOLERANCE_F32`].
const STEADY_TOLERANCE: f64 = 1e-7;

/// [`STEADY_TOLERANCE`] in f32, about 80 units of its last place: the
/// differences of neighbouring fluid cells' velocities in the eddy viscosity (C4)
/// leave the f32 column's steady state defined to about 1e-3.
const STEADY_TOLERANCE_F32: f64 = 1e-5;

impl<R: Real, const N: usize, const K: usize, const C: usize> Sim<R, N, K, C> {
    /// Starts the coupled flow of `self.flow` (validated, its fluid cells fit `C`):
    /// the column at the solid fractions of the grains of now, its velocity
    /// the log law (14) of u* above the mean bed level of now, brought to
    /// its steady state over the grains held at rest if `steady`
    /// ([`Sim::steady_column`]); driven by `fluid.driving` plus g sin θ of
    /// the bed slope. The summed drag and the carried force start at 0.
    pub(crate) fn start_coupling(&mut self, steady: bool) -> Result<(), Error> {
        self.fluid.on = false;
        self.update_bed_level();
        let mut config = self.flow.fluid;
        config.driving += self.config.slope_driving();
        let fluid = &mut self.fluid;
        fluid.column.reset(&config)?;
        let (m, surface) = (&self.config.material, self.config.surface);
        // (ρ_p − ρ_f) g cos θ of the overburden (C12).
        let unit_weight =
            m.rho * (m.s - 1.0) * -self.config.gravity[1] * libm::cos(self.config.slope_angle);
        fluid.configure(&config, m.c_d, unit_weight, surface);
        fluid.slabs.clear(fluid.column.grid())?;
        let g = &mut self.grains;
        let n = g.len.min(N);
        for i in 0..n {
            fluid.slabs.add_grain(g.y[i], g.r[i], g.u[i], R::ZERO)?;
        }
        fluid.drag_sum.fill(R::ZERO);
        fluid.carried.fill(R::ZERO);
        let (log_law, bed_level) = (&self.log_law, self.bed_level);
        fluid
            .column
            .start(&fluid.slabs, |y| log_law.mean_velocity(y - bed_level))?;
        self.refresh_coupling();
        if steady {
            self.steady_column()?;
        }
        let fluid = &mut self.fluid;
        let steps = self.flow.fluid.spec.update_steps.0.max(1);
        fluid.exchange_dt = R::from_f64(f64::from(steps) * self.config.step_dt);
        fluid.inv_steps = R::from_f64(1.0 / f64::from(steps));
        fluid.on = true;
        Ok(())
    }

    /// Brings the starting column to its steady state over the grains held
    /// at rest (docs/model.md §13): implicit steps of [`STEADY_DT`] H/(κ u*)
    /// (the column's slowest time scale; its viscous time H²/ν if u* = 0),
    /// each grain a sink Ξ = ½ρC_D A2 d² (1 − φ)^(−n) |u_f| at rest like
    /// the fixed grains of [`Sim::exchange`], until no velocity changes by
    /// more than [`STEADY_TOLERANCE`] of the largest, or
    /// [`STEADY_STEPS`] steps. The outer flow would otherwise take that
    /// time scale, seconds to tens of seconds, to forget the log law (14).
    fn steady_column(&mut self) -> Result<(), Error> {
        let config = &self.flow.fluid;
        let height = config.surface - config.bottom;
        let rate = self.flow.spec.kappa * self.flow.u_star / height;
        let rate = if rate > 0.0 {
            rate
        } else {
            config.spec.viscosity / (height * height)
        };
        let dt = R::from_f64(STEADY_DT / rate);
        let tolerance = R::from_f64(if R::BYTES == 4 {
            STEADY_TOLERANCE_F32
        } else {
            STEADY_TOLERANCE
        });
        let n = self.grains.len.min(N);
        for _ in 0..STEADY_STEPS {
            let fluid = &mut self.fluid;
            let g = &self.grains;
            fluid.slabs.clear(fluid.column.grid())?;
            for i in 0..n {
                let xi = fluid.drag_factor_at(g.drag_coef[i], g.y[i], g.r[i], R::ZERO);
                fluid.slabs.add_grain(g.y[i], g.r[i], R::ZERO, xi)?;
            }
            let fluid_cells = fluid.column.grid().cells().min(C);
            fluid.previous[..fluid_cells].copy_from_slice(fluid.column.velocities());
            fluid.column.advance(&fluid.slabs, dt)?;
            let (mut change, mut largest) = (R::ZERO, R::ZERO);
            for (&u, &before) in fluid.column.velocities().iter().zip(&fluid.previous) {
                change = R::max(change, R::abs(u - before));
                largest = R::max(largest, R::abs(u));
            }
            self.refresh_coupling();
            if change <= tolerance * largest {
                break;
            }
        }
        let fluid = &mut self.fluid;
        fluid.previous.fill(R::ZERO);
        fluid.slabs.clear(fluid.column.grid())?;
        let g = &self.grains;
        for i in 0..n {
            fluid.slabs.add_grain(g.y[i], g.r[i], g.u[i], R::ZERO)?;
        }
        Ok(())
    }

    /// The update of the column after M grain steps (docs/model.md §13):
    ///
    /// 1. the drag the grains received over the M steps, summed per fluid cell
    ///    (`Coupling::deposit`) and averaged, as an explicit sink: the
    ///    fluid loses exactly what the grains gained; the slabs from the
    ///    grains of now (docs/model.md (C1)–(C2)) and, to keep the step
    ///    stable where the grains hold the fluid tightly, each mobile
    ///    grain's drag factor of now
    ///    Ξ = ½ρC_D A2 d² (1 − φ)^(−n) |u_f − u_p| (or Dallavalle's (C8);
    ///    0 out of the water) as an implicit
    ///    stabiliser: the sink k (u_f − u_f⁰), balanced so that it takes
    ///    no momentum at u_f = u_f⁰ (u_f⁰ the velocity before the step);
    /// 2. the stabiliser's force of the previous update, k (u_f − u_f⁰),
    ///    returned as a source, so that over a run the fluid's sink is
    ///    the grains' drag exactly, but for the last update's, in transit;
    /// 3. each fixed grain with its drag factor Ξ = ½ρC_D A2 d² (1 − φ)^(−n)
    ///    |u_f| as an implicit sink (the bed's resistance, as in
    ///    kernel/tests/fluid.rs);
    /// 4. one implicit step of M step_dt (docs/model.md (C6)), the
    ///    hindrance of the new φ, the stabiliser's force kept, the sums
    ///    emptied.
    ///
    /// On an error the column's velocities and the sums are unchanged.
    pub(crate) fn exchange(&mut self) -> Result<(), Error> {
        let fluid = &mut self.fluid;
        let g = &mut self.grains;
        let n = g.len.min(N);
        let fluid_cells = fluid.column.grid().cells().min(C);
        fluid.slabs.clear(fluid.column.grid())?;
        for i in 0..n {
            let (y, r, u) = (g.y[i], g.r[i], g.u[i]);
            if !g.fixed[i] {
                let xi = fluid.drag_factor_at(g.drag_coef[i], y, r, u);
                fluid.slabs.add_exchange(y, r, u, xi)?;
            }
        }
        let velocities = fluid.column.velocities();
        for j in 0..fluid_cells {
            let k = fluid.slabs.drag_factor(j);
            let u = velocities.get(j).copied().unwrap_or(R::ZERO);
            (fluid.stabiliser[j], fluid.previous[j]) = (k, u);
            let drag = fluid.drag_sum[j] * fluid.inv_steps;
            fluid.slabs.add_source(j, k * u + fluid.carried[j] - drag);
        }
        for i in 0..n {
            let (y, r) = (g.y[i], g.r[i]);
            if g.fixed[i] {
                let xi = fluid.drag_factor_at(g.drag_coef[i], y, r, R::ZERO);
                fluid.slabs.add_grain(y, r, R::ZERO, xi)?;
            }
        }
        fluid.column.advance(&fluid.slabs, fluid.exchange_dt)?;
        for (j, &u) in fluid
            .column
            .velocities()
            .iter()
            .enumerate()
            .take(fluid_cells)
        {
            fluid.carried[j] = fluid.stabiliser[j] * (u - fluid.previous[j]);
        }
        fluid.drag_sum.fill(R::ZERO);
        Ok(())
    }

    /// One eddy turnover of the water above the bed, in integration steps
    /// (docs/model.md (C9)): (h − y_bed)/⟨u_f⟩, the mean over the fluid
    /// cells whose centre lies at or above the mean bed level y_bed,
    /// rounded up; `FlowSpec::hold_steps` where that water does not flow
    /// downstream or the bed lies above the surface.
    pub(crate) fn eddy_turnover_steps(&self) -> u64 {
        let column = &self.fluid.column;
        let grid = column.grid();
        let bed = self.bed_level;
        let (mut sum, mut count) = (0.0, 0u32);
        for (j, &u) in column.velocities().iter().enumerate() {
            if grid.centre(j) >= bed {
                sum += u.to_f64();
                count += 1;
            }
        }
        let fallback = u64::from(self.flow.spec.hold_steps.0.max(1));
        if count == 0 || sum.is_nan() || sum <= 0.0 {
            return fallback;
        }
        let depth = self.flow.fluid.surface - bed.to_f64();
        let steps = libm::ceil(depth / (sum / f64::from(count)) / self.config.step_dt);
        if (1.0..1e15).contains(&steps) {
            steps as u64
        } else {
            fallback
        }
    }

    /// Recomputes the coupled flow's tables from its state and the mean
    /// bed level (`Coupling::refresh`): after an update of either, and
    /// after a restore.
    pub(crate) fn refresh_coupling(&mut self) {
        let minus_inv_depth = self.log_law.minus_inv_depth;
        self.fluid
            .refresh(&self.flow.fluid, minus_inv_depth, self.bed_level);
    }

    /// The momentum of the coupled flow's stabiliser in transit (N s per
    /// slice; 0 without the coupled flow): taken from the fluid at the
    /// last update and returned at the next (docs/model.md §13). Over a
    /// run, the fluid's momentum change plus the grains' momentum change
    /// from the drag equals the driving impulse less the bed's (the
    /// no-slip bottom's stress and the fixed grains' drag), less this.
    pub fn fluid_in_transit(&self) -> f64 {
        if self.fluid.on {
            self.fluid.in_transit().to_f64()
        } else {
            0.0
        }
    }
}
