//! Vertical profiles of a cell's window (docs/model.md §13), on the cells of
//! the coupled flow's column ([`mbs_kernel::Scenario::column`]) whatever the
//! flow's model, continued down through the fixed grains ([`ProfileGrid`]):
//! per slab, the solid fraction φ (C2), the mean streamwise
//! grain velocity u_p (weighted by the grains' slice volumes, fixed grains
//! included at rest) and the mean fluid velocity u_f: the column's with the
//! coupled flow, the log law (14) above the mean bed level with clear
//! water. Sampled every [`PROFILE_SAMPLES`] q* samples;
//! [`crate::report::profiles`] writes them.

use crate::config::Config;
use crate::config::FLUID_CELLS;
use crate::sim::sims::HostSim;
use mbs_kernel::flow::LogLaw;
use mbs_kernel::fluid::{Grid, Slabs};
use mbs_kernel::Real;
use serde::{Deserialize, Serialize};

/// q* samples between two profile samples: with the default 10 integration
/// steps per q* sample, a profile every 100 steps (0.25 ms), a few per cent
/// of a step's cost.
pub const PROFILE_SAMPLES: u64 = 10;

/// The running sums of a cell's profiles (part of its checkpoint).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ProfileSums {
    /// Profiles sampled.
    pub samples: u64,
    /// Σ φ per cell.
    pub solid: Vec<f64>,
    /// Σ φ u_p per cell (m/s).
    pub momentum: Vec<f64>,
    /// Σ u_f per cell (m/s).
    pub fluid: Vec<f64>,
}

/// Fluid cells of the profiles at most: the column's [`FLUID_CELLS`] and as many
/// again below it.
const PROFILE_CELLS: usize = 2 * FLUID_CELLS;

/// The profiles' fluid cells: those of the coupled flow's column (for clear water
/// over fine grains, as many equal fluid cells over the same heights as fit
/// [`FLUID_CELLS`]; the coupled flow's column must fit them), continued
/// downwards to the lowest fixed grain's bottom, −(2 `fixed_spread` + ½)
/// d_max, where the column's water is at rest.
#[derive(Debug, Clone, Copy)]
pub struct ProfileGrid {
    /// The cells, bottom up.
    pub grid: Grid<f64>,
    /// Cells below the column's bottom.
    pub below: usize,
}

impl ProfileGrid {
    /// The profiles' fluid cells of `config`.
    pub fn of(config: &Config) -> ProfileGrid {
        let sc = &config.scenario;
        let mut column = sc.column();
        column.cells = column.cells.min(FLUID_CELLS);
        let dy = (column.surface - column.bottom) / column.cells as f64;
        let reach = (2.0 * sc.bed.fixed_spread + 0.5) * sc.bed.max_diameter();
        let below = ((reach / dy).ceil() as usize).min(PROFILE_CELLS - column.cells);
        column.bottom -= below as f64 * dy;
        column.cells += below;
        ProfileGrid {
            grid: column.grid(),
            below,
        }
    }
}

/// Slab sums of the grains on the profiles' fluid cells, reused between samples
/// (one allocation per cell, not per sample).
pub struct Sampler {
    cells: ProfileGrid,
    slabs: Box<Slabs<f64, PROFILE_CELLS>>,
}

impl Sampler {
    /// The sampler of `config`'s profiles.
    pub fn new(config: &Config) -> Sampler {
        Sampler {
            cells: ProfileGrid::of(config),
            slabs: Box::new(Slabs::new()),
        }
    }

    /// Adds the profiles of `sim` now to `sums`.
    pub fn sample<R: Real, const N: usize>(
        &mut self,
        sim: &HostSim<R, N>,
        sums: &mut ProfileSums,
    ) -> Result<(), mbs_kernel::Error> {
        let ProfileGrid { grid, below } = self.cells;
        let cells = grid.cells();
        self.slabs.clear(grid)?;
        for g in (0..sim.len()).filter_map(|i| sim.grain(i)) {
            self.slabs.add_grain(g.y, 0.5 * g.diameter, g.u, 0.0)?;
        }
        let column = sim.fluid_column();
        let clear = sim.flow().map(|f| (LogLaw::<f64>::new(f), sim.bed_level()));
        for j in 0..cells {
            let phi = self.slabs.solid_fraction(j);
            sums.solid[j] += phi;
            sums.momentum[j] += phi * self.slabs.grain_velocity(j);
            sums.fluid[j] += match (column, &clear) {
                // Below the column's no-slip bottom the water is at rest.
                (Some(c), _) => j
                    .checked_sub(below)
                    .and_then(|k| c.velocities().get(k))
                    .map_or(0.0, |u| u.to_f64()),
                (None, Some((law, level))) => law.mean_velocity(grid.centre(j) - level),
                (None, None) => 0.0,
            };
        }
        sums.samples += 1;
        Ok(())
    }
}

impl ProfileSums {
    /// Empty sums over `cells` cells.
    pub fn new(cells: usize) -> ProfileSums {
        ProfileSums {
            samples: 0,
            solid: vec![0.0; cells],
            momentum: vec![0.0; cells],
            fluid: vec![0.0; cells],
        }
    }

    /// The means (all zero without samples).
    pub fn means(&self) -> CellProfile {
        let n = self.samples.max(1) as f64;
        CellProfile {
            solid_fraction: self.solid.iter().map(|s| s / n).collect(),
            grain_velocity: (self.momentum.iter().zip(&self.solid))
                .map(|(m, s)| if *s > 0.0 { m / s } else { 0.0 })
                .collect(),
            fluid_velocity: self.fluid.iter().map(|u| u / n).collect(),
        }
    }
}

/// A cell's profiles over its window, per fluid cell of the column, bottom up.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CellProfile {
    /// φ.
    pub solid_fraction: Vec<f64>,
    /// u_p (m/s; 0 where no grain ever was).
    pub grain_velocity: Vec<f64>,
    /// u_f (m/s).
    pub fluid_velocity: Vec<f64>,
}
