//! The cell store: an append-only file of finished cells (of `mbs run` and
//! `mbs calibrate`), one JSON line each, written and synced as each cell
//! completes. A run that is interrupted (even by SIGKILL) loses only the
//! cells still being computed (one per worker thread; `mbs run` checkpoints
//! those): a torn last line fails its checksum and is ignored on loading,
//! and its cell is simply computed again.

use crate::error::HostError;
use crate::io::input::{read_line_bounded, Bound};
use crate::io::output::open_own;
use serde::{de::DeserializeOwned, Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{BufReader, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Name of the store file in an output directory.
pub const STORE: &str = "cells.jsonl";

/// The longest line of a store: a cell's specification is a configuration
/// with one τ* and one seed (a few kB); the longest result, a calibration's
/// packing curve (0.5 s sampled every 50 constants_dt ≥ 1e-8 s: at most
/// 1e6 samples of two numbers), takes under 50 MB. A longer line is no
/// line mbs wrote: the store is refused (a torn line is shorter, and only
/// recomputed).
pub const LINE_BOUND: Bound = Bound {
    bytes: 64 << 20,
    reason: "the longest line of a cell store (a calibration's packing curve of \
             at most 1e6 samples, under 50 MB)",
};

/// One stored line.
#[derive(Serialize, Deserialize)]
struct Line {
    /// The cell's specification, canonical JSON.
    key: String,
    /// Its result, JSON.
    value: serde_json::Value,
    /// CRC-32 (IEEE) of `key`, a zero byte and the result's JSON text. (Lines
    /// of the earlier format, `check` with FNV-1a, do not parse: their cells
    /// are computed again.)
    crc32: u32,
}

fn checksum(key: &str, value: &str) -> u32 {
    let mut h = crc32fast::Hasher::new();
    h.update(key.as_bytes());
    h.update(&[0]);
    h.update(value.as_bytes());
    h.finalize()
}

/// Finished cells keyed by their specification.
pub struct Store {
    path: PathBuf,
    cells: Mutex<(BTreeMap<String, serde_json::Value>, Option<File>)>,
}

impl Store {
    /// Opens (or creates) the store file at `path`, loading every intact line.
    pub fn open(path: &Path) -> Result<Store, HostError> {
        let map = load(path)?;
        Ok(Store {
            path: path.to_path_buf(),
            cells: Mutex::new((map, None)),
        })
    }

    /// Number of stored cells.
    pub fn len(&self) -> usize {
        self.cells.lock().map(|c| c.0.len()).unwrap_or(0)
    }

    /// Whether the store is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The stored result of `spec`, if any.
    pub fn get<S: Serialize, T: DeserializeOwned>(&self, spec: &S) -> Option<T> {
        let key = serde_json::to_string(spec).ok()?;
        let cells = self.cells.lock().ok()?;
        cells
            .0
            .get(&key)
            .and_then(|v| serde_json::from_value(v.clone()).ok())
    }

    /// Stores the result of `spec`: appended and synced before returning.
    pub fn put<S: Serialize, T: Serialize>(&self, spec: &S, result: &T) -> Result<(), HostError> {
        let io = |e: serde_json::Error| HostError::Io {
            path: self.path.clone(),
            error: e.into(),
        };
        let key = serde_json::to_string(spec).map_err(io)?;
        let value = serde_json::to_value(result).map_err(io)?;
        self.put_raw(key, value)
    }

    /// Stores `value` under the canonical `key` as written by [`Store::put`].
    fn put_raw(&self, key: String, value: serde_json::Value) -> Result<(), HostError> {
        let io = |e: std::io::Error| HostError::Io {
            path: self.path.clone(),
            error: e,
        };
        let text = value.to_string();
        let line = Line {
            crc32: checksum(&key, &text),
            key: key.clone(),
            value: value.clone(),
        };
        let mut bytes = serde_json::to_vec(&line).map_err(|e| io(e.into()))?;
        bytes.push(b'\n');
        let mut cells = self
            .cells
            .lock()
            .map_err(|_| io(std::io::Error::other("store lock poisoned")))?;
        if cells.1.is_none() {
            let mut file = open_own(&self.path, OpenOptions::new().create(true).append(true))?;
            // After a crash mid-line, start on a fresh line so the torn
            // fragment does not swallow the next cell.
            if !ends_with_newline(&self.path).map_err(io)? {
                file.write_all(b"\n").map_err(io)?;
            }
            cells.1 = Some(file);
        }
        if let Some(file) = cells.1.as_mut() {
            let written = file.write_all(&bytes).and_then(|()| file.sync_data());
            if let Err(e) = written {
                // Reopen next time, so the next line starts on a fresh line.
                cells.1 = None;
                return Err(io(e));
            }
        }
        cells.0.insert(key, value);
        Ok(())
    }

    /// Every stored (key, value), in key order.
    pub fn entries(&self) -> Vec<(String, serde_json::Value)> {
        self.cells
            .lock()
            .map(|c| c.0.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
            .unwrap_or_default()
    }

    /// Adds the cells of other stores (merging shard outputs); returns how
    /// many were new.
    pub fn merge_from(&self, other: &Path) -> Result<usize, HostError> {
        let mut added = 0;
        for (key, value) in load(other)? {
            let known = self
                .cells
                .lock()
                .map(|c| c.0.contains_key(&key))
                .unwrap_or(false);
            if !known {
                self.put_raw(key, value)?;
                added += 1;
            }
        }
        Ok(added)
    }
}

/// Whether the file is empty or ends with a newline.
fn ends_with_newline(path: &Path) -> std::io::Result<bool> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = crate::io::input::open_own_file(path)?;
    let len = f.metadata()?.len();
    if len == 0 {
        return Ok(true);
    }
    f.seek(SeekFrom::End(-1))?;
    let mut last = [0u8];
    f.read_exact(&mut last)?;
    Ok(last[0] == b'\n')
}

/// The (key, value) of a store line (without its newline), if it is one
/// whose checksum matches; else None (a torn or damaged line).
pub fn parse_line(line: &[u8]) -> Option<(String, serde_json::Value)> {
    let parsed = serde_json::from_slice::<Line>(line).ok()?;
    (checksum(&parsed.key, &parsed.value.to_string()) == parsed.crc32)
        .then_some((parsed.key, parsed.value))
}

/// Loads every intact line of a store file (a missing file is empty).
fn load(path: &Path) -> Result<BTreeMap<String, serde_json::Value>, HostError> {
    let mut map = BTreeMap::new();
    let file = match crate::io::input::open_own_file(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(map),
        Err(e) => return Err(HostError::io(path)(e)),
    };
    let mut reader = BufReader::new(file);
    let mut line = Vec::new();
    let mut number = 1;
    while read_line_bounded(&mut reader, &mut line, number, LINE_BOUND)
        .map_err(HostError::io(path))?
    {
        number += 1;
        if let Some((key, value)) = parse_line(&line) {
            map.insert(key, value);
        }
    }
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_survive_reopening_and_a_torn_last_line_is_ignored() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cells.jsonl");
        let store = Store::open(&path).unwrap();
        // Floats must come back bit for bit (serde_json's float_roundtrip).
        let awkward = [
            0.0006000000000000001,
            3.3065954920759474e-8,
            0.0027262901272944477,
        ];
        store.put(&("a", 1.5), &[1.0, 2.0]).unwrap();
        store.put(&("e", 0.1), &awkward).unwrap();
        store.put(&("b", 2.5), &0.25).unwrap();
        drop(store);
        // A crash in the middle of a line, and a line edited by hand.
        let mut text = std::fs::read_to_string(&path).unwrap();
        text = text.replace("0.25", "0.35");
        text.push_str("{\"key\":\"[\\\"c\\\",3.5]\",\"val");
        std::fs::write(&path, text).unwrap();
        let store = Store::open(&path).unwrap();
        assert_eq!(store.get::<_, Vec<f64>>(&("a", 1.5)), Some(vec![1.0, 2.0]));
        assert_eq!(
            store.get::<_, Vec<f64>>(&("e", 0.1)),
            Some(awkward.to_vec())
        );
        assert_eq!(store.get::<_, f64>(&("b", 2.5)), None, "checksum fails");
        assert_eq!(store.len(), 2);
        store.put(&("b", 2.5), &0.25).unwrap();
        let other = dir.path().join("other.jsonl");
        let second = Store::open(&other).unwrap();
        second.put(&("d", 4.5), &7u32).unwrap();
        assert_eq!(store.merge_from(&other).unwrap(), 1);
        assert_eq!(Store::open(&path).unwrap().len(), 4);
    }
}
