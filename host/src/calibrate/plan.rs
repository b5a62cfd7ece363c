//! The calibration's plan: its grids, durations and seed caps (full or
//! quick), and to what error a curve's points are computed.

use serde::{Deserialize, Serialize};

/// To what error the points of a curve are computed (docs/calibration.md,
/// "Error-driven points"). A cell averages in blocks of `window_min`/10
/// until MSER finds a steady part of `window_min` or `window` is up
/// (`time.window_until = "steady"`: the point's error is its seeds'
/// spread, not each window's); a point starts with
/// `seeds` seeds (1, 2, …) and adds `seeds` more while the standard error
/// of their mean misses the same target, up to its cap, unless the point is
/// already beyond the fit's target factor by twice its error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Fidelity {
    /// Shortest averaging window of a cell (s).
    pub window_min: f64,
    /// Longest averaging window of a cell (s): the cap.
    pub window: f64,
    /// Seeds a point starts with, and adds at a time.
    pub seeds: usize,
    /// The most seeds of a point above `threshold_tau_star`.
    pub seeds_max: usize,
    /// The most seeds of a point at τ* ≤ `threshold_tau_star`, where q*
    /// comes from rare events.
    pub threshold_seeds_max: usize,
}

impl Fidelity {
    /// One seed and one fixed window: a cheap look.
    pub fn coarse(window: f64) -> Fidelity {
        Fidelity {
            window_min: window,
            window,
            seeds: 1,
            seeds_max: 1,
            threshold_seeds_max: 1,
        }
    }

    /// The block of a cell's window (s): a tenth of the shortest, so that
    /// MSER can judge a window of `window_min` (2 × [`MIN_TAIL`] blocks).
    ///
    /// [`MIN_TAIL`]: crate::science::truncation::MIN_TAIL
    pub fn block(&self) -> f64 {
        self.window_min / 10.0
    }
}

/// The grids, fidelities and durations of a calibration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// Quick mode.
    pub quick: bool,
    /// Stage 1: α_m values.
    pub alpha_m: Vec<f64>,
    /// Stage 2: α_cn values.
    pub alpha_cn: Vec<f64>,
    /// Stages 1–2: packing duration (s).
    pub pack_duration: f64,
    /// Stages 1–2: seeds.
    pub pack_seeds: Vec<u64>,
    /// Stages 1–2: lattice columns of the packing bed (docs/model.md §9
    /// step 1: nld = 5); the flow stages use the base bed's columns.
    pub pack_columns: u32,
    /// Stages 3–5: lattice columns instead of the base bed's (near the
    /// threshold q* depends on the width below 40; docs/findings/bed-width.md).
    pub flow_columns: Option<u32>,
    /// Stage 4: lattice columns instead of the flow stages' (its τ* ≥ 0.1
    /// converge by 20 columns; docs/findings/bed-width.md), so the 50-layer
    /// beds stay affordable.
    pub timestep_columns: Option<u32>,
    /// Stages 1–2: settled when |y_gc − final y_gc| stays below this (diameters).
    pub settle_tolerance_d: f64,
    /// Stages 1–2: at rest when the largest speed at the end is below this (m/s).
    pub rest_speed: f64,
    /// Stage 3: the coarse grid of β.
    pub beta_grid: Vec<f64>,
    /// Stage 3: the ratio between the first three fine β.
    pub beta_step: f64,
    /// Stage 3: the search ends when the parabola's vertex is within this
    /// ratio of a β already evaluated with a fine curve.
    pub beta_tolerance: f64,
    /// Stage 3: the largest number of fine curves.
    pub beta_evaluations: usize,
    /// The worst factor to the reference the fit aims at; a point beyond it
    /// by twice its error adds no seeds (its verdict is clear).
    pub target_factor: f64,
    /// Stages 3, 5: Shields numbers of the fit.
    pub tau_stars: Vec<f64>,
    /// The largest τ* that counts as near the threshold
    /// ([`Fidelity::threshold_seeds_max`]).
    pub threshold_tau_star: f64,
    /// Stage 3's coarse grid.
    pub coarse: Fidelity,
    /// Stage 3's fine search and stage 5.
    pub fine: Fidelity,
    /// Stage 4.
    pub timestep: Fidelity,
    /// Stage 4: grain diameters (mm), searched at the first of `layers`.
    pub sizes_mm: Vec<f64>,
    /// Stage 4: layer thicknesses nvd, searched at the study diameter.
    pub layers: Vec<u32>,
    /// Stage 4: the diameter of the layer study (mm).
    pub study_mm: f64,
    /// Stage 4: the first step of the secant search, as a ratio of constants_dt.
    pub constants_dt_step: f64,
    /// Stage 4: the most curves per (d, nvd) search.
    pub constants_dt_evaluations: usize,
    /// Stage 4: Shields numbers.
    pub timestep_tau_stars: Vec<f64>,
    /// Stage 5: size classes (mm, fraction).
    pub mixed: Vec<(f64, f64)>,
}

impl Plan {
    /// The full calibration.
    pub fn full() -> Plan {
        Plan {
            quick: false,
            alpha_m: vec![5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0],
            alpha_cn: vec![0.5, 0.7, 1.0, 1.3, 1.6, 2.0, 2.5, 3.0],
            pack_duration: 0.5,
            pack_seeds: vec![1, 2, 3, 4],
            pack_columns: 5,
            flow_columns: None,
            timestep_columns: Some(20),
            settle_tolerance_d: 0.01,
            rest_speed: 5e-3,
            beta_grid: vec![1.0, 1.6, 2.5, 4.0, 6.3, 10.0, 15.8, 25.0],
            beta_step: 1.3,
            beta_tolerance: 1.05,
            beta_evaluations: 8,
            target_factor: 1.5,
            tau_stars: vec![0.06, 0.08, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5],
            threshold_tau_star: 0.06,
            coarse: Fidelity::coarse(0.5),
            fine: Fidelity {
                window_min: 0.5,
                window: 2.0,
                seeds: 4,
                seeds_max: 4,
                threshold_seeds_max: 12,
            },
            timestep: Fidelity {
                window_min: 0.5,
                window: 1.0,
                seeds: 2,
                seeds_max: 2,
                threshold_seeds_max: 2,
            },
            sizes_mm: vec![0.1, 0.2, 0.5, 1.0, 2.0],
            layers: vec![10, 20, 30, 40, 50],
            study_mm: 0.5,
            constants_dt_step: 1.5,
            constants_dt_evaluations: 4,
            timestep_tau_stars: vec![0.1, 0.2, 0.4],
            mixed: vec![(0.7, 0.5), (0.5, 0.5)],
        }
    }

    /// Under 3 minutes on 2 cores: the same packing stages (seconds), a
    /// coarser β grid, fewer seeds, shorter windows, two grain sizes and two
    /// layer thicknesses; the fit leaves out τ* = 0.06, where q* needs a
    /// dozen seeds.
    pub fn quick() -> Plan {
        Plan {
            quick: true,
            beta_grid: vec![1.5, 3.0, 6.0, 12.0],
            tau_stars: vec![0.08, 0.1, 0.2, 0.4],
            threshold_tau_star: 0.08,
            fine: Fidelity {
                window_min: 0.5,
                window: 1.0,
                seeds: 2,
                seeds_max: 2,
                threshold_seeds_max: 4,
            },
            timestep: Fidelity::coarse(0.5),
            sizes_mm: vec![0.1, 0.5],
            layers: vec![10, 20],
            constants_dt_evaluations: 2,
            timestep_tau_stars: vec![0.1, 0.4],
            ..Plan::full()
        }
    }

    /// The most seeds of a point at `tau_star` under `fidelity`.
    pub fn seeds_max(&self, fidelity: &Fidelity, tau_star: f64) -> usize {
        if tau_star <= self.threshold_tau_star {
            fidelity.threshold_seeds_max.max(fidelity.seeds)
        } else {
            fidelity.seeds_max.max(fidelity.seeds)
        }
    }
}

/// How the cells of a request are numbered for sharding.
#[derive(Debug, Clone, Copy)]
pub enum Slots {
    /// One number per cell from this one on: cells spread over the shards.
    From(usize),
    /// This number for every cell: the whole request on one shard.
    All(usize),
}

#[cfg(test)]
mod tests {
    use super::Plan;

    #[test]
    fn threshold_points_get_their_own_seed_cap() {
        let plan = Plan::full();
        assert_eq!(plan.seeds_max(&plan.fine, 0.06), 12);
        assert_eq!(plan.seeds_max(&plan.fine, 0.08), 4);
        assert_eq!(plan.seeds_max(&plan.coarse, 0.06), 1);
    }
}
