//! `summary.json`: the configuration, the derived constants, what the run
//! did and its results, in one file.

use crate::config::{Config, ConfigFile};
use crate::error::HostError;
use crate::io::output::write_json;
use crate::report::RunFacts;
use crate::work::cell::CellResult;
use crate::work::experiment::RunOutcome;
use crate::work::experiment::TransportRow;
use mbs_kernel::explicit_damping_number;
use serde::Serialize;
use std::path::Path;

/// Contact constants and time steps derived from the configuration.
#[derive(Debug, Clone, Serialize)]
pub struct Derived {
    /// Normal spring k_n (N/m).
    pub k_n: f64,
    /// Tangential spring k_s (N/m), docs/model.md (12).
    pub k_s: f64,
    /// Normal dashpot η_n (N s/m).
    pub eta_n: f64,
    /// Tangential dashpot η_s (N s/m), docs/model.md (13).
    pub eta_s: f64,
    /// The constants' time step constants_dt (s).
    pub constants_dt_s: f64,
    /// The integration step step_dt = constants_dt/substeps (s).
    pub step_dt_s: f64,
    /// Explicit damping number of the largest grains (stable below 2).
    pub explicit_damping_number: f64,
    /// The largest grain diameter d (mm), on which τ*, q* and every
    /// length in diameters are taken (the echoed configuration leaves
    /// `grains.diameter_mm` out where the file gave no size).
    pub diameter_mm: f64,
    /// Periodic width L (m).
    pub width: f64,
    /// Largest number of grains in the bed (fixed + lattice sites).
    pub max_grains: usize,
}

impl Derived {
    /// From a validated configuration.
    pub fn of(config: &Config) -> Derived {
        let sc = &config.scenario;
        let c = config.contact;
        Derived {
            k_n: c.k_n,
            k_s: c.k_s,
            eta_n: c.eta_n,
            eta_s: c.eta_s,
            constants_dt_s: sc.rule.constants_dt,
            step_dt_s: sc.step_dt(),
            explicit_damping_number: explicit_damping_number(
                &c,
                &sc.material,
                sc.bed.max_diameter(),
                sc.step_dt(),
            ),
            diameter_mm: sc.bed.max_diameter() * 1e3,
            width: sc.bed.width(),
            max_grains: sc.bed.grains(),
        }
    }
}

/// The content of `summary.json`.
#[derive(Serialize)]
struct Summary<'a> {
    program: &'static str,
    version: &'static str,
    command: &'static str,
    config: &'a ConfigFile,
    derived: Derived,
    threads: usize,
    /// Cells computed by this invocation (resumed ones included).
    cells_computed: usize,
    /// Cells taken from `cells.jsonl` as they were.
    cells_reused: usize,
    cells_resumed: usize,
    beds_settled: usize,
    beds_resumed: usize,
    /// Wall time of this invocation.
    wall_time_s: f64,
    /// Grain-steps of every cell.
    grain_steps: u64,
    /// Grain-steps of the cells computed by this invocation (a resumed
    /// cell counts whole).
    grain_steps_computed: u64,
    /// `grain_steps_computed / wall_time_s`; `null` when every cell was reused.
    grain_steps_per_s: Option<f64>,
    /// The warnings of the run (also on standard error and in `mbs.log`).
    warnings: Vec<String>,
    transport: &'a [TransportRow],
    cells: &'a [CellResult],
}

/// Writes `summary.json` of a run: `rows` aggregated from `outcome`'s
/// results, `facts` about this invocation. The profiles are left out
/// (they are in `profiles.csv`).
pub fn write_summary(
    path: &Path,
    config: &Config,
    outcome: &RunOutcome,
    rows: &[TransportRow],
    facts: &RunFacts,
) -> Result<(), HostError> {
    let results = &outcome.results;
    write_json(
        path,
        &Summary {
            program: "mbs",
            version: env!("CARGO_PKG_VERSION"),
            command: "run",
            config: &config.file,
            derived: Derived::of(config),
            threads: facts.threads,
            cells_computed: facts.computed(outcome),
            cells_reused: outcome.reused,
            cells_resumed: outcome.resumed,
            beds_settled: outcome.beds_settled,
            beds_resumed: outcome.beds_resumed,
            wall_time_s: facts.wall_time_s,
            grain_steps: results.iter().map(|r| r.grain_steps).sum::<u64>()
                + outcome.bed_grain_steps,
            grain_steps_computed: outcome.computed_grain_steps + outcome.bed_grain_steps,
            grain_steps_per_s: facts.rate(outcome),
            warnings: facts.warnings.clone(),
            transport: rows,
            cells: &results
                .iter()
                .map(|r| CellResult {
                    profile: None,
                    ..r.clone()
                })
                .collect::<Vec<_>>(),
        },
    )
}
