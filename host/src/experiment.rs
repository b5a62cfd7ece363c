//! The transport-rate experiment (SPEC §8, §9 step 3): for every (τ*, seed)
//! cell, build and settle the bed, switch the flow on, spin up, and average
//! q* over a window. Cells run in parallel (rayon); each is computed alone
//! from its own seed and the results are combined in a fixed order, so the
//! output does not depend on the number of threads.

use crate::config::Config;
use crate::error::HostError;
use crate::references::Reference;
use crate::sims::{with_sim, SimJob, NEIGHBOURS};
use indicatif::ProgressBar;
use mbs_kernel::{Real, Sim, G};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Batches of the window used for the standard error of a single seed.
pub const BATCHES: usize = 10;

/// Steps run between progress updates outside the window.
const CHUNK: u64 = 2000;

/// What one (τ*, seed) cell measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellResult {
    /// Shields number.
    pub tau_star: f64,
    /// Seed.
    pub seed: u64,
    /// Time-averaged q* over the window (all classes, d = d_max).
    pub q_star: f64,
    /// Time-averaged q* per size class (its own diameter).
    pub q_star_class: Vec<f64>,
    /// q* averaged over each of [`BATCHES`] consecutive parts of the window.
    pub batch_means: Vec<f64>,
    /// Mean bed level at the end (m, relative to the fixed grains' mean).
    pub bed_level: f64,
    /// Grain-steps computed.
    pub grain_steps: u64,
}

/// Integration steps of one cell (for progress bars).
pub fn cell_steps(config: &Config) -> u64 {
    let t = &config.file.time;
    config.steps(t.settle) + config.steps(t.spin_up) + window_samples(config) * sample_steps(config)
}

fn sample_steps(config: &Config) -> u64 {
    u64::from(config.file.time.sample_steps)
}

fn window_samples(config: &Config) -> u64 {
    (config.steps(config.file.time.window) / sample_steps(config)).max(1)
}

/// Runs `steps` steps in chunks, reporting progress.
pub fn run_steps<R: Real, const N: usize>(
    sim: &mut Sim<R, N, NEIGHBOURS>,
    steps: u64,
    progress: &ProgressBar,
) -> Result<(), mbs_kernel::Error> {
    let mut left = steps;
    while left > 0 {
        let n = left.min(CHUNK);
        sim.run(n)?;
        progress.inc(n);
        left -= n;
    }
    Ok(())
}

struct TransportJob<'a> {
    config: &'a Config,
    tau_star: f64,
    seed: u64,
    progress: &'a ProgressBar,
}

impl SimJob for TransportJob<'_> {
    type Output = Result<CellResult, HostError>;

    fn run<R: Real, const N: usize>(self, sim: &mut Sim<R, N, NEIGHBOURS>) -> Self::Output {
        let config = self.config;
        let sc = config.scenario_at(self.tau_star, self.seed);
        let fail = || HostError::kernel(format!("tau* = {}, seed {}", self.tau_star, self.seed));
        let t = &config.file.time;
        sc.build(sim).map_err(fail())?;
        run_steps(sim, config.steps(t.settle), self.progress).map_err(fail())?;
        sim.set_flow(Some(&sc.flow())).map_err(fail())?;
        run_steps(sim, config.steps(t.spin_up), self.progress).map_err(fail())?;
        let d_max = sc.bed.max_diameter();
        let s = sc.material.s;
        let classes = &sc.bed.classes;
        let samples = window_samples(config);
        let mut total = 0.0;
        let mut per_class = vec![0.0; classes.len()];
        let mut batch_sum = [0.0; BATCHES];
        let mut batch_n = [0u64; BATCHES];
        for k in 0..samples {
            sim.run(sample_steps(config)).map_err(fail())?;
            self.progress.inc(sample_steps(config));
            let o = sim.observe();
            let q = o.q_star(d_max, s, G);
            total += q;
            let b = (k as usize * BATCHES) / samples as usize;
            batch_sum[b] += q;
            batch_n[b] += 1;
            for (c, sum) in per_class.iter_mut().enumerate() {
                *sum += o.q_star_class(c, classes[c].diameter, s, G);
            }
        }
        let n = samples as f64;
        Ok(CellResult {
            tau_star: self.tau_star,
            seed: self.seed,
            q_star: total / n,
            q_star_class: per_class.iter().map(|q| q / n).collect(),
            batch_means: batch_sum
                .iter()
                .zip(batch_n)
                .filter(|(_, n)| *n > 0)
                .map(|(s, n)| s / n as f64)
                .collect(),
            bed_level: sim.bed_level(),
            grain_steps: sim.step_count() * sim.len() as u64,
        })
    }
}

/// Runs one cell.
pub fn run_cell(
    config: &Config,
    tau_star: f64,
    seed: u64,
    progress: &ProgressBar,
) -> Result<CellResult, HostError> {
    let job = TransportJob {
        config,
        tau_star,
        seed,
        progress,
    };
    with_sim(config.precision, config.capacity, job)
}

/// Runs every (τ*, seed) cell in parallel on the current rayon pool; results
/// in τ*-major, seed-minor order. The first failing cell in that order is
/// the error returned.
pub fn run_all(config: &Config, progress: &ProgressBar) -> Result<Vec<CellResult>, HostError> {
    let cells: Vec<(f64, u64)> = config
        .tau_stars
        .iter()
        .flat_map(|&t| config.seeds.iter().map(move |&s| (t, s)))
        .collect();
    let results: Vec<Result<CellResult, HostError>> = cells
        .par_iter()
        .map(|&(t, s)| run_cell(config, t, s, progress))
        .collect();
    results.into_iter().collect()
}

/// Mean and standard error of the mean (0 for fewer than two values).
pub fn mean_stderr(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    if values.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let mean = values.iter().sum::<f64>() / n;
    if values.len() < 2 {
        return (mean, 0.0);
    }
    let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// One row of `transport.csv`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransportRow {
    /// Shields number.
    pub tau_star: f64,
    /// Mean q* over the seeds.
    pub q_star: f64,
    /// Its standard error: between seeds, or between batch means of one seed.
    pub q_star_stderr: f64,
    /// Seeds averaged.
    pub seeds: usize,
    /// Meyer-Peter & Müller at τ*.
    pub mpm: f64,
    /// Wong & Parker at τ*.
    pub wong_parker: f64,
    /// (mean, stderr) of q* per size class (only for mixed beds).
    pub classes: Vec<(f64, f64)>,
}

/// Combines cell results into one row per τ*, in the configuration's order.
pub fn aggregate(config: &Config, results: &[CellResult]) -> Vec<TransportRow> {
    let n_classes = config.scenario.bed.classes.len();
    config
        .tau_stars
        .iter()
        .map(|&tau| {
            let cells: Vec<&CellResult> = results.iter().filter(|r| r.tau_star == tau).collect();
            let spread = |value: &dyn Fn(&CellResult) -> f64| -> (f64, f64) {
                let values: Vec<f64> = cells.iter().map(|c| value(c)).collect();
                match cells.as_slice() {
                    [one] => (values[0], mean_stderr(&one.batch_means).1),
                    _ => mean_stderr(&values),
                }
            };
            let (q_star, q_star_stderr) = spread(&|c| c.q_star);
            let classes = if n_classes > 1 {
                (0..n_classes)
                    .map(|k| {
                        let values: Vec<f64> = cells.iter().map(|c| c.q_star_class[k]).collect();
                        mean_stderr(&values)
                    })
                    .collect()
            } else {
                Vec::new()
            };
            TransportRow {
                tau_star: tau,
                q_star,
                q_star_stderr,
                seeds: cells.len(),
                mpm: Reference::MeyerPeterMuller.q_star(tau),
                wong_parker: Reference::WongParker.q_star(tau),
                classes,
            }
        })
        .collect()
}

/// Header and rows of `transport.csv`.
pub fn transport_table(config: &Config, rows: &[TransportRow]) -> (Vec<String>, Vec<Vec<String>>) {
    let mut header: Vec<String> = [
        "tau_star",
        "q_star",
        "q_star_stderr",
        "seeds",
        "mpm",
        "wong_parker",
    ]
    .map(String::from)
    .to_vec();
    if rows.first().is_some_and(|r| !r.classes.is_empty()) {
        for c in &config.scenario.bed.classes {
            let d = c.diameter * 1e3;
            header.push(format!("q_star_{d}mm"));
            header.push(format!("q_star_{d}mm_stderr"));
        }
    }
    let body = rows
        .iter()
        .map(|r| {
            let mut line = vec![
                r.tau_star.to_string(),
                r.q_star.to_string(),
                r.q_star_stderr.to_string(),
                r.seeds.to_string(),
                r.mpm.to_string(),
                r.wong_parker.to_string(),
            ];
            for (q, e) in &r.classes {
                line.push(q.to_string());
                line.push(e.to_string());
            }
            line
        })
        .collect();
    (header, body)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_standard_error() {
        let (m, e) = mean_stderr(&[1.0, 2.0, 3.0, 4.0]);
        assert_eq!(m, 2.5);
        assert!((e - (5.0f64 / 3.0 / 4.0).sqrt()).abs() < 1e-15);
        assert_eq!(mean_stderr(&[7.0]), (7.0, 0.0));
    }
}
