//! The attack cases of issue 32 as regression tests: closed output streams,
//! crafted checkpoints, two runs in one directory, oversized files, cosmetic
//! edits of a resumed configuration, and values that cannot finish.

use crate::common::*;
use std::process::{Command, Stdio};

/// Runs `mbs ARGS` with standard error (and, if `close_stdout`, standard
/// output) a pipe whose reading end is closed before `mbs` writes: returns the
/// exit status, None if killed by a signal.
fn with_closed_streams(args: &[&std::ffi::OsStr], close_stdout: bool) -> Option<i32> {
    let closed = || {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        Stdio::from(writer)
    };
    Command::new(assert_cmd::cargo::cargo_bin("mbs"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(if close_stdout {
            closed()
        } else {
            Stdio::null()
        })
        .stderr(closed())
        .status()
        .unwrap()
        .code()
}

/// `mbs run` of the configuration `text` into `dir/out` with both output
/// streams closed: the exit status and the output directory.
fn run_with_closed_streams(dir: &std::path::Path, text: &str) -> (Option<i32>, std::path::PathBuf) {
    let cfg = write(dir, "c.toml", text);
    let out = dir.join("out");
    let args = [
        "run".as_ref(),
        cfg.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ];
    (with_closed_streams(&args, true), out)
}

#[test]
fn a_closed_stderr_keeps_the_exit_status_of_a_bad_configuration() {
    let dir = tempfile::tempdir().unwrap();
    let (code, _) = run_with_closed_streams(dir.path(), "[bed]\ncolumns = 0\n");
    assert_eq!(code, Some(2));
}

#[test]
fn a_closed_stderr_keeps_the_exit_status_of_a_good_run() {
    let dir = tempfile::tempdir().unwrap();
    // A warning (the f32 width) goes to stderr before the work.
    let (code, out) = run_with_closed_streams(dir.path(), SMALL);
    assert_eq!(code, Some(0));
    assert!(out.join("transport.csv").is_file());
}

#[test]
fn a_closed_stdout_keeps_the_exit_status_of_config() {
    assert_eq!(with_closed_streams(&["config".as_ref()], true), Some(0));
}

/// A run of SMALL into `dir/name` stopped after `steps` steps of every cell:
/// the output directory, holding a checkpoint per cell.
fn stopped_run(dir: &std::path::Path, name: &str, steps: u64) -> std::path::PathBuf {
    let cfg = write(dir, "small.toml", SMALL);
    let out = dir.join(name);
    run_into(&cfg, &out)
        .args(["--stop-after-steps", &steps.to_string()])
        .assert()
        .code(130);
    out
}

/// Reads `cell`'s checkpoint in `out`, with the key the file holds.
fn read_checkpoint(out: &std::path::Path, cell: &str) -> mbs::cell::CellCheckpoint {
    let bytes = std::fs::read(out.join("checkpoints").join(cell)).unwrap();
    let key = u64::from_le_bytes(bytes[6..14].try_into().unwrap());
    mbs::cell::CellCheckpoint::decode(&bytes, key).unwrap()
}

/// Edits `cell`'s checkpoint with `edit` (its checksum recomputed), resumes,
/// and expects a refusal naming the checkpoint: exit 1, no table.
fn crafted_is_refused(
    steps: u64,
    cell: &str,
    edit: impl FnOnce(&mut mbs::cell::CellCheckpoint, &std::path::Path),
) {
    let dir = tempfile::tempdir().unwrap();
    let out = stopped_run(dir.path(), "out", steps);
    let mut ck = read_checkpoint(&out, cell);
    edit(&mut ck, &out);
    std::fs::write(out.join("checkpoints").join(cell), ck.encode()).unwrap();
    resume_in(&out)
        .assert()
        .code(1)
        .stderr(predicates::str::contains("checkpoint refused"));
    assert!(!out.join("transport.csv").exists());
}

/// Steps of SMALL: 20 000 settling, 8 000 spin-up, then the window.
const IN_SPIN_UP: u64 = 24_000;
const IN_WINDOW: u64 = 34_000;

#[test]
fn crafted_window_samples_in_spin_up_are_refused_not_a_panic() {
    crafted_is_refused(IN_WINDOW, "tau0.3_seed1.ckpt", |ck, _| {
        ck.state.phase = mbs::cell::Phase::SpinUp;
        ck.state.done = 0;
    });
}

#[test]
fn crafted_done_beyond_the_spin_up_is_refused() {
    crafted_is_refused(IN_SPIN_UP, "tau0.3_seed1.ckpt", |ck, _| {
        ck.state.done = u64::MAX;
    });
}

#[test]
fn crafted_batch_counts_that_wrap_are_refused() {
    crafted_is_refused(IN_WINDOW, "tau0.3_seed1.ckpt", |ck, _| {
        let n = ck.state.samples;
        ck.state.batch_n = [0; mbs::cell::BATCHES];
        ck.state.batch_n[0] = 1 << 63;
        ck.state.batch_n[1] = (1 << 63) + n;
    });
}

#[test]
fn a_crafted_total_is_refused() {
    crafted_is_refused(IN_WINDOW, "tau0.3_seed1.ckpt", |ck, _| {
        ck.state.total = 2.0 * ck.state.total + 1.0;
    });
}

#[test]
fn another_cells_kernel_state_is_refused() {
    crafted_is_refused(IN_WINDOW, "tau0.1_seed1.ckpt", |ck, out| {
        ck.sim = read_checkpoint(out, "tau0.3_seed1.ckpt").sim;
    });
}

#[test]
fn another_seeds_kernel_state_is_refused() {
    crafted_is_refused(IN_SPIN_UP, "tau0.3_seed1.ckpt", |ck, out| {
        ck.sim = read_checkpoint(out, "tau0.3_seed2.ckpt").sim;
    });
}

/// Holds the advisory lock of `dir/.mbs-lock` as a live `mbs` would, with
/// this process's id in it.
fn hold_lock(dir: &std::path::Path) -> std::fs::File {
    std::fs::create_dir_all(dir).unwrap();
    let file = std::fs::File::create(dir.join(".mbs-lock")).unwrap();
    file.try_lock().unwrap();
    std::fs::write(dir.join(".mbs-lock"), format!("{}\n", std::process::id())).unwrap();
    file
}

#[test]
fn a_second_run_into_a_locked_directory_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    let lock = hold_lock(&out);
    run_into(&cfg, &out)
        .assert()
        .code(1)
        .stderr(predicates::str::contains(format!(
            "in use by another mbs (process {})",
            std::process::id()
        )));
    assert!(!out.join("transport.csv").exists() && !out.join("config.toml").exists());
    drop(lock);
    run_into(&cfg, &out).assert().success();
}

#[test]
fn a_second_calibration_into_a_locked_directory_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cal");
    let _lock = hold_lock(&out);
    mbs()
        .args(["calibrate", "--quick", "--stage", "1", "--out"])
        .arg(&out)
        .assert()
        .code(1)
        .stderr(predicates::str::contains("in use by another mbs"));
    assert!(!out.join("plan.json").exists());
}

#[test]
fn a_stale_lock_of_a_killed_process_is_taken_over() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    // The file a killed holder leaves: its id, no lock (released at death).
    std::fs::write(out.join(".mbs-lock"), "4194303\n").unwrap();
    run_into(&cfg, &out).assert().success();
}

#[test]
fn resume_after_a_cosmetic_edit_of_the_configuration() {
    let dir = tempfile::tempdir().unwrap();
    let out = stopped_run(dir.path(), "out", IN_SPIN_UP);
    let path = out.join("config.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let edited = format!("# a comment\n{}", text.trim_end());
    std::fs::write(&path, edited).unwrap();
    resume_in(&out).assert().success();
    assert!(out.join("transport.csv").is_file());
}
