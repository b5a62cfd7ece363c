//! The five stages of the calibration. Each returns `Ok(None)` while cells
//! owned by other shards are missing, and saves its result as
//! `stageN.json` (read by later stages and by the report) plus CSV and
//! figures.

pub mod beta;
pub mod mixed;
pub mod settling;
pub mod timestep;

use crate::error::HostError;
use crate::output::write_json;
use serde::{de::DeserializeOwned, Serialize};
use std::path::Path;

/// Saves a stage's result as `dir/name.json`.
pub fn save_stage<T: Serialize>(dir: &Path, name: &str, value: &T) -> Result<(), HostError> {
    write_json(&dir.join(format!("{name}.json")), value)
}

/// Loads a stage's saved result, if it has finished.
pub fn load_stage<T: DeserializeOwned>(dir: &Path, name: &str) -> Result<Option<T>, HostError> {
    let path = dir.join(format!("{name}.json"));
    match std::fs::read(&path) {
        Ok(bytes) => serde_json::from_slice(&bytes)
            .map(Some)
            .map_err(|e| HostError::Io {
                path,
                error: e.into(),
            }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(HostError::io(path)(e)),
    }
}

/// Cell numbering of a search: evaluation `e` of a stage whose evaluations
/// have `cells` cells each.
pub fn slot_of(e: usize, cells: usize) -> impl Fn(usize) -> usize + Sync {
    move |k| e * cells + k
}
