//! Crash-safe output: every file is written to a temporary name in its
//! directory and renamed over the target, so an interrupted run never leaves
//! a half-written file and never damages an earlier one.

use crate::error::HostError;
use crate::io::input::{read_own_text_bounded, Bound};
use std::io::Write;
use std::path::Path;

/// Prefix of every temporary file, followed by the writer's process id;
/// [`remove_temporaries`] deletes those of processes that no longer run.
pub const TEMPORARY: &str = ".mbs-tmp.";

/// Deletes temporary files left in `dir` by killed processes: names
/// `.mbs-tmp.<pid>.*` whose process is gone (checked in `/proc`; where there
/// is no `/proc`, nothing is deleted). Another live `mbs` writing into the
/// same directory keeps its files.
pub fn remove_temporaries(dir: &Path) -> Result<(), HostError> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(HostError::io(dir)(e)),
    };
    let proc_fs = Path::new("/proc/self").exists();
    for entry in entries {
        let entry = entry.map_err(HostError::io(dir))?;
        let name = entry.file_name().to_string_lossy().to_string();
        let Some(rest) = name.strip_prefix(TEMPORARY) else {
            continue;
        };
        let pid = rest.split('.').next().unwrap_or("");
        let gone = proc_fs && !Path::new("/proc").join(pid).exists();
        if gone && pid.parse::<u32>().is_ok_and(|p| p != std::process::id()) {
            std::fs::remove_file(entry.path()).map_err(HostError::io(entry.path()))?;
        }
    }
    Ok(())
}

/// Name of the lock file of an output directory.
pub const LOCK: &str = ".mbs-lock";

/// A lock file holds a process id and what the file is ([`LOCK_NOTE`]).
const LOCK_BOUND: Bound = Bound {
    bytes: 256,
    reason: "a lock file (a process id and a note)",
};

/// What a lock file says after the holder's id: it stays in a finished
/// directory, and why that is harmless.
pub const LOCK_NOTE: &str =
    "is or was the process of mbs working in this directory (an advisory lock: \
     it stays when mbs ends and binds nothing then; delete it freely)";

/// An exclusive advisory lock on an output directory, held while the value
/// lives; the operating system releases it when the process ends, however
/// it ends, so a killed holder's lock is simply taken over.
#[derive(Debug)]
pub struct DirLock(#[allow(dead_code)] std::fs::File);

/// Locks `dir` (created if missing) for this process: `DIR/.mbs-lock`,
/// locked with the OS's advisory lock and holding this process's id. Another
/// live process holding it is [`HostError::Busy`], naming its id.
pub fn lock_dir(dir: &Path) -> Result<DirLock, HostError> {
    create_dir(dir)?;
    let path = dir.join(LOCK);
    let mut file = open_own(
        &path,
        std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false),
    )?;
    match file.try_lock() {
        Ok(()) => {
            for own in OWN_DIRS {
                refuse_link(&dir.join(own))?;
            }
            file.set_len(0)
                .and_then(|()| writeln!(file, "{} {LOCK_NOTE}", std::process::id()))
                .map_err(HostError::io(&path))?;
            Ok(DirLock(file))
        }
        Err(std::fs::TryLockError::WouldBlock) => Err(HostError::Busy {
            dir: dir.to_path_buf(),
            holder: read_own_text_bounded(&path, LOCK_BOUND)
                .ok()
                .and_then(|t| t.split_whitespace().next()?.parse().ok()),
        }),
        Err(std::fs::TryLockError::Error(e)) => Err(HostError::io(&path)(e)),
    }
}

/// Opens a file of mbs's own in an output directory (the lock, the store,
/// the log) with `options`, never through a symbolic link: a link planted
/// where mbs expects its own file would make it write outside the
/// directory. A link there is refused (exit 2), naming the file; nothing is
/// written. (Files written whole are renamed into place, which replaces a
/// link instead of following it: [`write_atomic`].)
pub fn open_own(
    path: &Path,
    options: &mut std::fs::OpenOptions,
) -> Result<std::fs::File, HostError> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // Without blocking: a FIFO planted there would block the open.
        options.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK);
    }
    // Elsewhere, look first (a narrow race; unix has none).
    if !cfg!(unix) {
        refuse_link(path)?;
    }
    // On unix a link makes the open fail (ELOOP), a FIFO without a reader
    // opened for writing too (ENXIO): say why.
    let file = options.open(path).map_err(|e| {
        let other = std::fs::symlink_metadata(path).is_ok_and(|m| !m.is_file());
        refuse_link(path).err().unwrap_or_else(|| {
            HostError::io(path)(if other {
                crate::io::input::not_regular()
            } else {
                e
            })
        })
    })?;
    // Only a regular file (a FIFO opened for writing without a reader
    // fails above; with one, or a device, here).
    crate::io::input::regular(&file).map_err(HostError::io(path))?;
    Ok(file)
}

/// The configuration a run directory was started with (`mbs run --resume`).
pub const RUN_CONFIG: &str = "config.toml";

/// Refuses the output directory `dir` of one command if it holds the
/// results of `other` (its file `mark`, which only that command writes):
/// `mbs run` and `mbs calibrate` write files of the same names
/// (`summary.json`, `cells.jsonl`, `mbs.log`), so either would overwrite
/// the other's (exit 2, nothing written).
pub fn not_holding(dir: &Path, mark: &str, other: &str) -> Result<(), HostError> {
    if std::fs::symlink_metadata(dir.join(mark)).is_err() {
        return Ok(());
    }
    Err(crate::error::ConfigError::Invalid {
        key: "--out".into(),
        value: dir.display().to_string(),
        allowed: format!(
            "a directory of its own: this one holds the results of `{other}` ({mark}), whose \
             files would be overwritten"
        ),
    }
    .into())
}

/// The folders mbs writes its own files into inside an output directory;
/// each must be a folder of its own, not a link to one elsewhere.
pub const OWN_DIRS: [&str; 3] = ["checkpoints", "beds", "frames"];

/// Refuses `path` if it is a symbolic link (exit 2, naming it): a folder or
/// file of mbs's own inside an output directory.
pub fn refuse_link(path: &Path) -> Result<(), HostError> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => Err(link_refused(path)),
        _ => Ok(()),
    }
}

/// The error for a symbolic link where mbs writes its own file.
fn link_refused(path: &Path) -> HostError {
    crate::error::ConfigError::Invalid {
        key: "--out".into(),
        value: path.display().to_string(),
        allowed: "a directory whose mbs files are not symbolic links (mbs writes only inside \
                  its output directory; remove the link)"
            .into(),
    }
    .into()
}

/// Creates `dir` (and parents) if missing.
pub fn create_dir(dir: &Path) -> Result<(), HostError> {
    std::fs::create_dir_all(dir).map_err(HostError::io(dir))
}

/// Writes `bytes` to `path` atomically (temporary file, fsync, rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), HostError> {
    write_atomic_with(path, |tmp| {
        std::fs::write(tmp, bytes).map_err(HostError::io(tmp))
    })
}

/// Lets `write` fill a temporary file beside `path` (same extension, so
/// format-by-extension encoders work), then renames it over `path`.
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), HostError>,
) -> Result<(), HostError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let suffix = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let prefix = format!("{TEMPORARY}{}.{name}.", std::process::id());
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(&suffix);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // An ordinary output file (tempfile would make it private, 0600).
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let tmp = builder.tempfile_in(dir).map_err(HostError::io(dir))?;
    write(tmp.path())?;
    tmp.as_file()
        .sync_all()
        .map_err(HostError::io(tmp.path()))?;
    tmp.persist(path)
        .map_err(|e| HostError::Io {
            path: path.to_path_buf(),
            error: e.error,
        })
        .map(|_| ())
}

/// Writes lines of text atomically.
pub fn write_text(path: &Path, text: &str) -> Result<(), HostError> {
    write_atomic(path, text.as_bytes())
}

/// Serialises `value` as pretty JSON, atomically.
pub fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<(), HostError> {
    let mut bytes = serde_json::to_vec_pretty(value).map_err(|e| HostError::Io {
        path: path.to_path_buf(),
        error: e.into(),
    })?;
    bytes.write_all(b"\n").map_err(HostError::io(path))?;
    write_atomic(path, &bytes)
}

/// Writes a CSV table atomically: a header, then a line per row (a
/// serde-derived struct; a sequence field gives several columns). Without
/// `header` the header is the row type's field names. Write every number
/// with [`decimal`] or [`decimals`].
pub fn write_csv<R: serde::Serialize>(
    path: &Path,
    header: Option<&[String]>,
    rows: &[R],
) -> Result<(), HostError> {
    let io = |error| HostError::Io {
        path: path.to_path_buf(),
        error,
    };
    let mut w = csv::WriterBuilder::new()
        .has_headers(header.is_none())
        .from_writer(Vec::new());
    let csv_err = |e: csv::Error| io(std::io::Error::other(e));
    if let Some(header) = header {
        w.write_record(header).map_err(csv_err)?;
    }
    for r in rows {
        w.serialize(r).map_err(csv_err)?;
    }
    let bytes = w.into_inner().map_err(|e| io(e.into_error()))?;
    write_atomic(path, &bytes)
}

/// Serialises a number of a table as Rust's `Display` writes it (`0.00001`,
/// `1`, `NaN`), as every table of mbs always has: csv's own serde support
/// writes ryu's shortest form (`1e-5`, `1.0`). For `#[serde(serialize_with)]`.
pub fn decimal<S: serde::Serializer>(value: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(value)
}

/// [`decimal`] for each number of a sequence field (one column each).
pub fn decimals<S: serde::Serializer>(values: &[f64], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(values.iter().map(|v| Decimal(*v)))
}

/// A number serialised with [`decimal`].
struct Decimal(f64);

impl serde::Serialize for Decimal {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        decimal(&self.0, s)
    }
}

/// Deletes `path` if it exists.
pub fn remove_if_present(path: &Path) -> Result<(), HostError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(HostError::io(path)(e)),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_write_numbers_as_display_writes_them() {
        #[derive(serde::Serialize)]
        struct Line {
            #[serde(serialize_with = "decimal")]
            x: f64,
            n: usize,
            #[serde(serialize_with = "decimals")]
            more: Vec<f64>,
        }
        #[derive(serde::Serialize)]
        struct Named {
            #[serde(serialize_with = "decimal")]
            small: f64,
            note: &'static str,
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        let header = ["x", "n", "a", "b"].map(String::from);
        let line = Line {
            x: 1.0,
            n: 2,
            more: vec![1e-5, f64::NAN],
        };
        write_csv(&path, Some(&header), &[line]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text, "x,n,a,b\n1,2,0.00001,NaN\n");
        let named = Named {
            small: 2.5e-7,
            note: "a, b",
        };
        write_csv(&path, None, &[named]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text, "small,note\n0.00000025,\"a, b\"\n");
    }

    #[test]
    fn failed_write_keeps_the_old_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.csv");
        write_text(&path, "old\n").unwrap();
        let err = write_atomic_with(&path, |tmp| {
            std::fs::write(tmp, "half").unwrap();
            Err(HostError::Plot {
                path: tmp.to_path_buf(),
                message: "interrupted".into(),
            })
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old\n");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "temporary removed");
        write_text(&path, "new\n").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new\n");
    }
}
