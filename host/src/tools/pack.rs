//! The packing test of docs/model.md §9 step 1: build the bed and let it
//! settle under gravity, recording y_gc(t), kinetic energy, largest overlap
//! and contact count.

use crate::config::Config;
use crate::error::HostError;
use crate::figures::{save, LinesFigure};
use crate::io::output::{decimal, write_csv};
use crate::sim::sims::{run_with_progress, with_sim, HostSim, SimJob};
use indicatif::ProgressBar;
use mbs_kernel::Real;
use serde::Serialize;
use std::path::Path;

/// One sample of a packing run: a line of `packing.csv`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PackSample {
    /// Time (s).
    #[serde(serialize_with = "decimal")]
    pub time: f64,
    /// Height of the mobile grains' centre of gravity (m).
    #[serde(serialize_with = "decimal")]
    pub y_gc: f64,
    /// Kinetic energy of the mobile grains (J).
    #[serde(serialize_with = "decimal")]
    pub kinetic_energy: f64,
    /// Largest overlap (m).
    #[serde(serialize_with = "decimal")]
    pub max_overlap: f64,
    /// Contacts.
    pub contacts: usize,
    /// Largest mobile-grain speed (m/s).
    #[serde(serialize_with = "decimal")]
    pub max_speed: f64,
}

/// What a packing run is asked to do.
pub struct Packing<'a> {
    /// Configuration.
    pub config: &'a Config,
    /// Seed of the bed.
    pub seed: u64,
    /// Integration steps.
    pub steps: u64,
    /// Integration steps between samples.
    pub every: u64,
    /// Progress (in steps).
    pub progress: &'a ProgressBar,
}

impl SimJob for Packing<'_> {
    type Output = Result<Vec<PackSample>, HostError>;

    fn run<R: Real, const N: usize>(self, sim: &mut HostSim<R, N>) -> Self::Output {
        let sc = self.config.scenario_at(self.seed);
        let fail = || HostError::kernel(format!("packing, seed {}", self.seed));
        sc.build(sim).map_err(fail())?;
        let every = self.every.max(1);
        let samples = self.steps / every;
        let sample = |sim: &HostSim<R, N>| {
            let o = sim.observe();
            PackSample {
                time: o.time,
                y_gc: o.y_gc,
                kinetic_energy: o.kinetic_energy,
                max_overlap: o.max_overlap,
                contacts: o.contacts,
                max_speed: o.max_speed,
            }
        };
        let mut out = vec![sample(sim)];
        for _ in 0..samples {
            run_with_progress(sim, every, self.progress).map_err(fail())?;
            out.push(sample(sim));
        }
        Ok(out)
    }
}

/// Runs the packing test.
pub fn packing(job: Packing<'_>) -> Result<Vec<PackSample>, HostError> {
    let (precision, capacity) = (job.config.precision, job.config.capacity);
    with_sim(precision, capacity, job)
}

/// Writes `packing.csv` and the y_gc(t) plot `packing.png`/`.svg` into `dir`.
pub fn write_packing(dir: &Path, samples: &[PackSample], title: &str) -> Result<(), HostError> {
    write_csv(&dir.join("packing.csv"), None, samples)?;
    let points: Vec<(f64, f64)> = samples.iter().map(|s| (s.time, s.y_gc * 1e3)).collect();
    let figure = settling_figure(vec![(String::new(), points)], title.to_string());
    save(&figure, dir, "packing")
}

/// y_gc(t) (mm against s) of labelled packing runs: the packing test's
/// figure and the settling stages' of the calibration.
pub fn settling_figure(series: Vec<(String, Vec<(f64, f64)>)>, title: String) -> LinesFigure {
    LinesFigure {
        series,
        title,
        x_label: "time t (s)".into(),
        y_label: "centre of gravity y_gc (mm)".into(),
        log_axes: false,
        markers: true,
        dots: Vec::new(),
        x_ticks: Vec::new(),
        marks: Vec::new(),
        ..LinesFigure::default()
    }
}
