//! Vertical profiles of a cell's window (docs/model.md §13), on the cells of
//! the coupled flow's column ([`mbs_kernel::Scenario::column`]) whatever the
//! flow's model, continued down through the fixed grains ([`ProfileGrid`]):
//! per slab, the solid fraction φ (C2), the mean streamwise
//! grain velocity u_p (weighted by the grains' slice volumes, fixed grains
//! included at rest) and the mean fluid velocity u_f: the column's with the
//! coupled flow, the log law (14) above the mean bed level with clear
//! water. Sampled every [`PROFILE_SAMPLES`] q* samples; `profiles.csv` and
//! `profiles.png`/`.svg` hold the mean over the seeds of each τ*.

use crate::cell::CellResult;
use crate::config::Config;
use crate::error::HostError;
use crate::output::{decimal, write_csv};
use crate::plot::{LinesFigure, Panels};
use crate::sims::{HostSim, FLUID_CELLS};
use crate::text::number;
use mbs_kernel::flow::Profile as LogLaw;
use mbs_kernel::fluid::{Grid, Slabs};
use mbs_kernel::Real;
use serde::{Deserialize, Serialize};
use std::path::Path;

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

/// Cells of the profiles at most: the column's [`FLUID_CELLS`] and as many
/// again below it.
const PROFILE_CELLS: usize = 2 * FLUID_CELLS;

/// The profiles' cells: those of the coupled flow's column (for clear water
/// over fine grains, as many equal cells over the same heights as fit
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
    /// The profiles' cells of `config`.
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

/// Slab sums of the grains on the profiles' cells, reused between samples
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

/// A cell's profiles over its window, per cell of the column, bottom up.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CellProfile {
    /// φ.
    pub solid_fraction: Vec<f64>,
    /// u_p (m/s; 0 where no grain ever was).
    pub grain_velocity: Vec<f64>,
    /// u_f (m/s).
    pub fluid_velocity: Vec<f64>,
}

/// A line of `profiles.csv`.
#[derive(Serialize)]
struct Line {
    #[serde(serialize_with = "decimal")]
    tau_star: f64,
    #[serde(serialize_with = "decimal")]
    y_over_d: f64,
    #[serde(serialize_with = "decimal")]
    solid_fraction: f64,
    /// Empty where no grain ever was.
    grain_velocity_m_s: Option<String>,
    #[serde(serialize_with = "decimal")]
    fluid_velocity_m_s: f64,
}

/// The profiles of τ* `tau_star`: the mean of its seeds' (φ and u_f plain
/// means, u_p weighted by φ), or `None` if no seed has one.
fn mean_profile(results: &[CellResult], tau_star: f64) -> Option<CellProfile> {
    let cells: Vec<&CellProfile> = results
        .iter()
        .filter(|r| r.tau_star == tau_star)
        .filter_map(|r| r.profile.as_ref())
        .collect();
    let n = cells.first()?.solid_fraction.len();
    if cells.iter().any(|c| c.solid_fraction.len() != n) {
        return None;
    }
    let k = cells.len() as f64;
    let sum = |f: &dyn Fn(&CellProfile, usize) -> f64| -> Vec<f64> {
        (0..n)
            .map(|j| cells.iter().map(|c| f(c, j)).sum())
            .collect()
    };
    let solid = sum(&|c, j| c.solid_fraction[j]);
    let momentum = sum(&|c, j| c.solid_fraction[j] * c.grain_velocity[j]);
    Some(CellProfile {
        solid_fraction: solid.iter().map(|s| s / k).collect(),
        grain_velocity: (momentum.iter().zip(&solid))
            .map(|(m, s)| if *s > 0.0 { m / s } else { 0.0 })
            .collect(),
        fluid_velocity: sum(&|c, j| c.fluid_velocity[j])
            .iter()
            .map(|u| u / k)
            .collect(),
    })
}

/// Heights of the cell centres over the largest diameter (y = 0: the fixed
/// grains' mean centre height).
fn heights(config: &Config) -> Vec<f64> {
    let grid = ProfileGrid::of(config).grid;
    let d = config.scenario.bed.max_diameter();
    (0..grid.cells()).map(|j| grid.centre(j) / d).collect()
}

/// Writes `profiles.csv`: per τ* and cell of the column, bottom up, the
/// height y/d of its centre, φ, u_p and u_f, each the mean over the seeds.
pub fn write_profiles(
    path: &Path,
    config: &Config,
    results: &[CellResult],
) -> Result<(), HostError> {
    let y = heights(config);
    let mut lines = Vec::new();
    for &tau_star in &config.tau_stars {
        let Some(p) = mean_profile(results, tau_star) else {
            continue;
        };
        for (j, &y_over_d) in y.iter().enumerate().take(p.solid_fraction.len()) {
            let phi = p.solid_fraction[j];
            lines.push(Line {
                tau_star,
                y_over_d,
                solid_fraction: phi,
                grain_velocity_m_s: (phi > 0.0).then(|| p.grain_velocity[j].to_string()),
                fluid_velocity_m_s: p.fluid_velocity[j],
            });
        }
    }
    write_csv(path, None, &lines)
}

/// Heights drawn above the highest slab that ever held a grain, in d.
const ABOVE_BED_D: f64 = 15.0;

/// φ, u_p and u_f against y/d, side by side, a line per τ*: from the
/// column's bottom to [`ABOVE_BED_D`] above the highest grain; the measured
/// profile of `run.measured_profiles` as dots.
pub fn profiles_figure(config: &Config, results: &[CellResult]) -> Panels {
    let y = heights(config);
    let profiles: Vec<(f64, CellProfile)> = config
        .tau_stars
        .iter()
        .filter_map(|&t| mean_profile(results, t).map(|p| (t, p)))
        .collect();
    let top = profiles
        .iter()
        .filter_map(|(_, p)| p.solid_fraction.iter().rposition(|&s| s > 0.0))
        .max()
        .and_then(|j| y.get(j))
        .map_or(ABOVE_BED_D, |&t| t + ABOVE_BED_D);
    let shown = |values: &dyn Fn(&CellProfile) -> &Vec<f64>, grains_only: bool| {
        profiles
            .iter()
            .map(|(t, p)| {
                let points = (y.iter().zip(values(p)).zip(&p.solid_fraction))
                    .filter(|((yj, _), phi)| **yj <= top && (!grains_only || **phi > 0.0))
                    .map(|((&yj, &v), _)| (v, yj))
                    .collect();
                // Four significant digits: a τ* from a slope is long.
                let tau = number(*t);
                let tau = if tau.len() <= 6 {
                    tau
                } else {
                    format!("{t:.4}")
                };
                (format!("τ* = {tau}"), points)
            })
            .collect::<Vec<_>>()
    };
    let model = match config.file.flow.model {
        crate::config::FlowModelKey::ClearWater => "clear water",
        crate::config::FlowModelKey::Coupled => "coupled flow",
    };
    // `run.measured_profiles` as dots on each panel (u_f where it has it).
    let measured = config
        .measured
        .as_ref()
        .map(|m| (m.label.clone(), m.points()));
    let dots = |k: usize| match &measured {
        Some((label, points)) if !points[k].is_empty() => {
            vec![(label.clone(), points[k].clone())]
        }
        _ => Vec::new(),
    };
    let panel = |series, k: usize, title: &str, x_label: &str| LinesFigure {
        series,
        dots: dots(k),
        title: title.into(),
        x_label: x_label.into(),
        y_label: "y/d".into(),
        log_axes: false,
        markers: false,
        x_ticks: Vec::new(),
        marks: Vec::new(),
    };
    Panels {
        panels: vec![
            panel(
                shown(&|p| &p.solid_fraction, false),
                0,
                &format!("solid fraction ({model})"),
                "φ",
            ),
            panel(
                shown(&|p| &p.grain_velocity, true),
                1,
                "grain velocity",
                "u_p (m/s)",
            ),
            panel(
                shown(&|p| &p.fluid_velocity, false),
                2,
                "fluid velocity",
                "u_f (m/s)",
            ),
        ],
        side_by_side: true,
    }
}
