//! The five stages of the calibration. Each returns `Ok(None)` while cells
//! owned by other shards are missing, and saves its result as
//! `stageN.json` (for people and scripts; the stages themselves recompute
//! from the cell store) plus CSV and figures.

pub mod beta;
pub mod mixed;
pub mod settling;
pub mod timestep;

use crate::error::HostError;
use crate::io::output::write_json;
use serde::Serialize;
use std::path::Path;

/// Saves a stage's result as `dir/name.json`.
pub fn save_stage<T: Serialize>(dir: &Path, name: &str, value: &T) -> Result<(), HostError> {
    write_json(&dir.join(format!("{name}.json")), value)
}
