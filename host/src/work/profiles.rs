//! Vertical profiles of a cell's window (docs/model.md §13), on the cells of
//! the coupled flow's column ([`mbs_kernel::Scenario::column`]) whatever the
//! flow's model, continued down through the fixed grains ([`ProfileGrid`]):
//! per slab, the solid fraction φ (C2), the mean streamwise
//! grain velocity u_p (weighted by the grains' slice volumes, fixed grains
//! included at rest) and the mean fluid velocity u_f: the column's with the
//! coupled flow, the log law (14) above the mean bed level with clear
//! water; and the shear stresses (docs/model.md §8): the grains' by
//! contacts and by their velocity fluctuations, the fluid's viscous and
//! Reynolds stresses (the coupled flow's column; 0 with clear water).
//! Sampled every [`PROFILE_SAMPLES`] q* samples; [`crate::report::profiles`]
//! writes them.

use crate::config::Config;
use crate::config::FLUID_CELLS;
use crate::sim::sims::HostSim;
use mbs_kernel::flow::LogLaw;
use mbs_kernel::fluid::{slice_volume, Grid, Slabs};
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
    /// Σ of each shear stress per cell (Pa), [`Stresses`].
    pub stresses: Stresses,
}

/// The shear stresses τ_xy of a profile per cell (Pa; a sum of samples in
/// [`ProfileSums`], their mean in [`CellProfile`]), positive when the
/// layer above drags the one below downstream (docs/model.md §8).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Stresses {
    /// The grains' contacts: (1/V) Σ f_x l_y, f the force on grain i from
    /// grain j and l the branch from i to j, each contact's share in
    /// proportion to the height of its branch in the slab (V the slab's
    /// volume).
    #[serde(default)]
    pub contact: Vec<f64>,
    /// The grains' velocity fluctuations: −(1/V) Σ w m u' v' about the
    /// slab's mass-weighted mean velocity (w the grain's share of the slab).
    #[serde(default)]
    pub kinetic: Vec<f64>,
    /// The fluid's viscous stress ρ (1 − φ) ν du_f/dy (C4).
    #[serde(default)]
    pub viscous: Vec<f64>,
    /// The fluid's Reynolds stress ρ (1 − φ) ν_t du_f/dy (C4).
    #[serde(default)]
    pub reynolds: Vec<f64>,
}

impl Stresses {
    /// Zeros over `cells` cells.
    fn new(cells: usize) -> Stresses {
        Stresses {
            contact: vec![0.0; cells],
            kinetic: vec![0.0; cells],
            viscous: vec![0.0; cells],
            reynolds: vec![0.0; cells],
        }
    }

    /// The four columns, in the order of a checkpoint and of `profiles.csv`.
    pub fn columns(&self) -> [&Vec<f64>; 4] {
        [&self.contact, &self.kinetic, &self.viscous, &self.reynolds]
    }

    /// The four columns, mutable.
    pub fn columns_mut(&mut self) -> [&mut Vec<f64>; 4] {
        [
            &mut self.contact,
            &mut self.kinetic,
            &mut self.viscous,
            &mut self.reynolds,
        ]
    }

    /// From the four columns in [`Stresses::columns`]'s order.
    pub fn from_columns([contact, kinetic, viscous, reynolds]: [Vec<f64>; 4]) -> Stresses {
        Stresses {
            contact,
            kinetic,
            viscous,
            reynolds,
        }
    }
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

    /// Heights of the cells' centres over the largest diameter (y = 0: the
    /// fixed grains' mean centre height), bottom up.
    pub fn heights_d(config: &Config) -> Vec<f64> {
        let grid = ProfileGrid::of(config).grid;
        let d = config.scenario.bed.max_diameter();
        (0..grid.cells()).map(|j| grid.centre(j) / d).collect()
    }
}

/// Slab sums of the grains on the profiles' fluid cells, reused between samples
/// (one allocation per cell, not per sample).
pub struct Sampler {
    cells: ProfileGrid,
    slabs: Box<Slabs<f64, PROFILE_CELLS>>,
    /// The grains' density ρ s (kg/m³).
    grain_density: f64,
    /// Scratch of a sample per cell: Σ w m, Σ w m u, Σ w m v, Σ w m u v.
    moments: Vec<[f64; 4]>,
}

impl Sampler {
    /// The sampler of `config`'s profiles.
    pub fn new(config: &Config) -> Sampler {
        let cells = ProfileGrid::of(config);
        let m = &config.scenario.material;
        Sampler {
            moments: vec![[0.0; 4]; cells.grid.cells()],
            cells,
            slabs: Box::new(Slabs::new()),
            grain_density: m.rho * m.s,
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
        self.add_stresses(sim, &mut sums.stresses);
        sums.samples += 1;
        Ok(())
    }

    /// Adds the shear stresses of `sim` now to `sums` ([`Stresses`]).
    fn add_stresses<R: Real, const N: usize>(&mut self, sim: &HostSim<R, N>, sums: &mut Stresses) {
        let ProfileGrid { grid, below } = self.cells;
        let cells = grid.cells();
        let dy = grid.dy();
        let bottom = grid.centre(0) - 0.5 * dy;
        let volume = grid.slab_volume();
        // Cell of height y (may lie outside [0, cells)).
        let cell = |y: f64| ((y - bottom) / dy).floor();
        // Contacts: f_x l_y spread along the branch in proportion to its
        // height in each slab (all in one slab for a level branch).
        let contact = &mut sums.contact;
        sim.contact_forces(|c| {
            let Some(y0) = sim.grain(c.i).map(|g| g.y) else {
                return;
            };
            let value = c.force[0] * c.branch[1] / volume;
            let (lo, hi) = (y0.min(y0 + c.branch[1]), y0.max(y0 + c.branch[1]));
            if hi <= lo {
                let k = cell(y0);
                if k >= 0.0 && k < cells as f64 {
                    contact[k as usize] += value;
                }
                return;
            }
            let (first, last) = (cell(lo).max(0.0), cell(hi).min(cells as f64 - 1.0));
            if first > last {
                return;
            }
            let slabs = contact.iter_mut().enumerate();
            for (k, sum) in slabs.skip(first as usize).take((last - first) as usize + 1) {
                let (a, b) = (bottom + k as f64 * dy, bottom + (k + 1) as f64 * dy);
                let part = (b.min(hi) - a.max(lo)).max(0.0) / (hi - lo);
                *sum += value * part;
            }
        });
        // Velocity fluctuations of the mobile grains about each slab's mean.
        self.moments.iter_mut().for_each(|m| *m = [0.0; 4]);
        for g in (0..sim.len()).filter_map(|i| sim.grain(i)) {
            if g.fixed {
                continue;
            }
            let r = 0.5 * g.diameter;
            let whole = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
            let mass = self.grain_density * whole;
            let (first, last) = (
                cell(g.y - r).max(0.0),
                cell(g.y + r).min(cells as f64 - 1.0),
            );
            if first > last {
                continue;
            }
            for k in first as usize..=last as usize {
                let a = bottom + k as f64 * dy - g.y;
                let w = slice_volume(r, a, a + dy) / whole * mass;
                let m = &mut self.moments[k];
                *m = [
                    m[0] + w,
                    m[1] + w * g.u,
                    m[2] + w * g.v,
                    m[3] + w * g.u * g.v,
                ];
            }
        }
        for (k, m) in self.moments.iter().enumerate() {
            if m[0] > 0.0 {
                sums.kinetic[k] -= (m[3] - m[1] * m[2] / m[0]) / volume;
            }
        }
        // The fluid's: the mean of each cell's two faces (0 at the surface).
        if let Some(column) = sim.fluid_column() {
            let n = column.velocities().len();
            for j in below..cells.min(below + n) {
                let k = j - below;
                let face = |f: usize| {
                    let total = column.shear_stress(f).to_f64();
                    let reynolds = column.reynolds_stress(f).to_f64();
                    (total - reynolds, reynolds)
                };
                let ((v0, r0), (v1, r1)) = (face(k), face(k + 1));
                sums.viscous[j] += 0.5 * (v0 + v1);
                sums.reynolds[j] += 0.5 * (r0 + r1);
            }
        }
    }
}

impl ProfileSums {
    /// Columns per cell: Σφ, Σφ u_p, Σu_f and the four stresses.
    pub const COLUMNS: usize = 7;

    /// Every column, in the order of a checkpoint: Σφ, Σφ u_p, Σu_f, then
    /// [`Stresses::columns`].
    pub fn columns(&self) -> [&Vec<f64>; Self::COLUMNS] {
        let [a, b, c, d] = self.stresses.columns();
        [&self.solid, &self.momentum, &self.fluid, a, b, c, d]
    }

    /// Empty sums over `cells` cells.
    pub fn new(cells: usize) -> ProfileSums {
        ProfileSums {
            samples: 0,
            solid: vec![0.0; cells],
            momentum: vec![0.0; cells],
            fluid: vec![0.0; cells],
            stresses: Stresses::new(cells),
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
            stresses: Stresses::from_columns(
                self.stresses
                    .columns()
                    .map(|c| c.iter().map(|s| s / n).collect()),
            ),
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
    /// The shear stresses (Pa); empty in a cell store written before them.
    #[serde(default)]
    pub stresses: Stresses,
}
