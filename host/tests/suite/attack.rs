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

/// A run of SMALL into `dir/name` stopped, then resumed and stopped again,
/// after each of `stops` steps of every bed and cell: the output directory,
/// holding a checkpoint per cell.
fn stopped_run(dir: &std::path::Path, name: &str, stops: &[u64]) -> std::path::PathBuf {
    let cfg = write(dir, "small.toml", SMALL);
    let out = dir.join(name);
    for (k, steps) in stops.iter().enumerate() {
        let mut c = if k == 0 {
            run_into(&cfg, &out)
        } else {
            resume_in(&out)
        };
        c.args(["--stop-after-steps", &steps.to_string()])
            .assert()
            .code(130);
    }
    out
}

/// Reads `cell`'s checkpoint in `out`, with the key the file holds.
fn read_checkpoint(out: &std::path::Path, cell: &str) -> mbs::work::cell::CellCheckpoint {
    let bytes = std::fs::read(out.join("checkpoints").join(cell)).unwrap();
    let key = u64::from_le_bytes(bytes[6..14].try_into().unwrap());
    mbs::work::cell::CellCheckpoint::decode(&bytes, key).unwrap()
}

/// Edits `cell`'s checkpoint with `edit` (its checksum recomputed), resumes,
/// and expects a refusal naming the checkpoint: exit 1, no table.
fn crafted_is_refused(
    steps: &[u64],
    cell: &str,
    edit: impl FnOnce(&mut mbs::work::cell::CellCheckpoint, &std::path::Path),
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

/// Stops of SMALL, whose beds settle for 20 000 steps and cells spin up
/// for 8 000 then average over 20 000, each job stopping at the first
/// multiple of 2 000 steps past the limit: the beds at 8 000 and 16 000,
/// then the cells at 6 000 (spin-up); the cells at 20 000 (window).
const IN_SPIN_UP: &[u64] = &[7_000, 7_000, 5_000];
const IN_WINDOW: &[u64] = &[20_000];

#[test]
fn crafted_window_samples_in_spin_up_are_refused_not_a_panic() {
    crafted_is_refused(IN_WINDOW, "tau0.3_seed1.ckpt", |ck, _| {
        ck.state.phase = mbs::work::cell::Phase::SpinUp;
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
fn crafted_sample_counts_that_wrap_are_refused() {
    // Steps = samples × sample_steps wraps to the steps done.
    crafted_is_refused(IN_WINDOW, "tau0.3_seed1.ckpt", |ck, _| {
        ck.state.samples += 1 << 63;
    });
}

#[test]
fn crafted_blocks_past_the_window_s_end_are_refused() {
    // Ten blocks end SMALL's window: a checkpoint cannot hold them.
    crafted_is_refused(IN_WINDOW, "tau0.3_seed1.ckpt", |ck, _| {
        let block = ck.state.blocks[0].clone();
        ck.state.blocks = vec![block; 10];
        ck.state.samples = 10 * 400;
        ck.state.done = 10 * 4000;
        ck.state.block_sum = 0.0;
        ck.state.class_sums = vec![0.0];
    });
}

#[test]
fn crafted_class_values_are_refused() {
    crafted_is_refused(IN_WINDOW, "tau0.3_seed1.ckpt", |ck, _| {
        ck.state.blocks[0].q_star_class = vec![];
    });
    crafted_is_refused(IN_WINDOW, "tau0.3_seed1.ckpt", |ck, _| {
        ck.state.blocks[0].q_star_class = vec![f64::NAN];
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

/// A sparse file of `len` bytes at `path` (nothing big is written).
fn sparse(path: &std::path::Path, len: u64) {
    std::fs::File::create(path).unwrap().set_len(len).unwrap();
}

/// Longer than every bound on what mbs reads but cheap to read whole for
/// an older mbs: 128 MiB.
const OVERSIZED: u64 = 128 << 20;

/// A limit on every run: a test that would run forever on an unchecked
/// value fails instead.
const PATIENCE: std::time::Duration = std::time::Duration::from_secs(60);

#[test]
fn an_oversized_configuration_is_refused_unread() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("big.toml");
    sparse(&cfg, OVERSIZED);
    run_into(&cfg, &dir.path().join("out"))
        .timeout(PATIENCE)
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "128 MiB, longer than the largest configuration mbs reads",
        ));
}

#[test]
fn an_oversized_cell_checkpoint_is_refused_unread() {
    let dir = tempfile::tempdir().unwrap();
    let out = stopped_run(dir.path(), "out", IN_SPIN_UP);
    let path = out.join("checkpoints").join("tau0.3_seed1.ckpt");
    sparse(&path, OVERSIZED);
    resume_in(&out)
        .timeout(PATIENCE)
        .assert()
        .code(1)
        .stderr(predicates::str::contains(
            "checkpoint refused: 128 MiB, longer than the largest cell checkpoint of this \
             configuration (256 grains, F64)",
        ));
    assert_eq!(std::fs::metadata(&path).unwrap().len(), OVERSIZED, "kept");
}

#[test]
fn an_overlong_line_of_the_cell_store_is_refused_unread() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    sparse(&out.join("cells.jsonl"), OVERSIZED);
    run_into(&cfg, &out)
        .timeout(PATIENCE)
        .assert()
        .code(1)
        .stderr(predicates::str::contains(
            "cells.jsonl: line 1 is longer than the longest line of a cell store",
        ));
    assert!(!out.join("transport.csv").exists());
}

#[test]
fn an_oversized_trace_is_refused_unread() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("trace.json");
    sparse(&trace, OVERSIZED);
    mbs()
        .args(["digest", "--check"])
        .arg(&trace)
        .timeout(PATIENCE)
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "trace refused: 128 MiB, longer than the largest trace",
        ));
}

#[test]
fn a_trace_of_too_many_records_is_refused_before_running() {
    let dir = tempfile::tempdir().unwrap();
    mbs()
        .args(["digest", "--steps", "200000", "--every", "1", "--trace"])
        .arg(dir.path().join("trace.json"))
        .timeout(std::time::Duration::from_secs(20))
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "--every = 1: must be >= 5: a trace holds at most 102 MB of records, here at most 99997 records",
        ));
}

/// Runs `mbs run` of SMALL with `[time]` edited by `edit` and expects exit 2
/// with `message`, without running a step.
fn refused_config(edit: (&str, &str), message: &str) {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "c.toml", &SMALL.replace(edit.0, edit.1));
    run_into(&cfg, &dir.path().join("out"))
        .timeout(PATIENCE)
        .assert()
        .code(2)
        .stderr(predicates::str::contains(message));
    assert!(!dir.path().join("out").exists());
}

#[test]
fn phases_and_time_steps_beyond_their_limits_are_refused_with_the_reason() {
    for (edit, message) in [
        (
            ("settle = 0.05", "settle = 1e308"),
            "time.settle = 1e308: must be in [0, 1000] s of physical time: beds settle and q* \
             converges within seconds",
        ),
        (
            ("spin_up = 0.02", "spin_up = 1e308"),
            "time.spin_up = 1e308: must be in [0, 1000] s",
        ),
        (
            ("window = 0.05", "window = 1e308"),
            "time.window = 1e308: must be in (0, 1000] s",
        ),
        (
            ("[time]", "[time]\nconstants_dt = 1e-12"),
            "time.constants_dt = 0.000000000001: must be in [1e-8, 1] s (below, every second of physical \
             time takes more than 1e8 integration steps)",
        ),
        (
            ("[time]", "[time]\nconstants_dt = 1e-8\nsubsteps = 10000"),
            "time.settle + time.spin_up + time.window = 0.05 + 0.02 + 0.05 s = 1.2e11 integration steps: must \
             be <= 1e11 integration steps",
        ),
    ] {
        refused_config(edit, message);
    }
}

#[test]
fn command_line_times_beyond_the_limit_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    mbs()
        .current_dir(dir.path())
        .args(["pack", "--duration", "1e308"])
        .timeout(PATIENCE)
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "--duration = 1e308: must be in (0, 1000] s",
        ));
    mbs()
        .current_dir(dir.path())
        .args(["snapshot", "--every", "1e308"])
        .timeout(PATIENCE)
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "--every = 1e308: must be in (0, 1000] s",
        ));
}

#[test]
fn sample_steps_longer_than_a_block_is_refused() {
    refused_config(
        ("[time]", "[time]\nsample_steps = 3000"),
        "time.sample_steps = 3000: must be <= a block's 2000 integration steps",
    );
}

#[test]
fn windows_and_blocks_that_do_not_fit_are_refused() {
    refused_config(
        ("window_min = 0.05", "window_min = 0.06"),
        "time.window_min = 0.06: must be <= time.window = 0.05 s",
    );
    refused_config(
        ("block = 0.005", "block = 0.03"),
        "time.block = 0.03: must be <= time.window_min/2 = 0.025 s",
    );
}

#[test]
fn a_fluid_density_that_leaves_the_float_range_is_named_not_the_time_step() {
    let dir = tempfile::tempdir().unwrap();
    let text = SMALL.replace("[flow]", "[flow]\nfluid_density = 1e-300");
    let cfg = write(dir.path(), "c.toml", &text);
    let out = run_into(&cfg, &dir.path().join("out"))
        .timeout(PATIENCE)
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "flow.fluid_density = 1e-300: must be in [0.001, 100000] kg/m^3",
        ))
        .get_output()
        .clone();
    assert!(!String::from_utf8_lossy(&out.stderr).contains("step_dt"));
}

#[test]
fn a_one_megabyte_key_gives_a_short_message() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!("[bed]\n{} = 1\n", "k".repeat(1_000_000));
    let cfg = write(dir.path(), "c.toml", &text);
    let out = run_into(&cfg, &dir.path().join("out"))
        .assert()
        .code(2)
        .stderr(predicates::str::contains("unknown field"))
        .get_output()
        .clone();
    assert!(
        out.stderr.len() < 2000,
        "{} bytes of stderr",
        out.stderr.len()
    );
}

#[test]
fn a_tiny_tau_star_names_its_checkpoint_in_exponent_form() {
    let dir = tempfile::tempdir().unwrap();
    let text = SMALL
        .replace("tau_star = [0.1, 0.3]", "tau_star = [1e-300]")
        .replace("seeds = [1, 2]", "seeds = [1]");
    let cfg = write(dir.path(), "c.toml", &text);
    let out = dir.path().join("out");
    run_into(&cfg, &out)
        .args(["--stop-after-steps", "24000"])
        .timeout(PATIENCE)
        .assert()
        .code(130);
    assert!(out.join("checkpoints/tau1e-300_seed1.ckpt").is_file());
    resume_in(&out).timeout(PATIENCE).assert().success();
}

#[test]
fn checkpoints_are_written_at_most_once_per_2000_steps() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    // Not quiet: the warning is the point.
    Command::new(assert_cmd::cargo::cargo_bin("mbs"))
        .args([
            "run".as_ref(),
            cfg.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ])
        .args(["--checkpoint-every", "1e-300"])
        .output()
        .map(|o| {
            assert!(o.status.success());
            let stderr = String::from_utf8_lossy(&o.stderr);
            assert!(
                stderr.contains(
                    "--checkpoint-every 1e-300 s: each cell writes a checkpoint at most once per \
                     2000 integration steps"
                ),
                "{stderr}"
            );
        })
        .unwrap();
}

#[test]
fn a_long_run_is_warned_about_with_its_steps_and_wall_time() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(
        dir.path(),
        "long.toml",
        "[time]\nsettle = 1000\nspin_up = 1000\nwindow = 1000\n",
    );
    let out = dir.path().join("out");
    let o = Command::new(assert_cmd::cargo::cargo_bin("mbs"))
        .args([
            "run".as_ref(),
            cfg.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ])
        .args(["--threads", "2", "--stop-after-steps", "1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(130));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains(
            "warning: a long run: 4 bed(s) settling for up to 4.000e8 and 20 cell(s) of \
             8.000e8 integration steps (step_dt = 2.5e-6 s) of up to 440 grains, 7.74e12 \
             grain-steps: about 1.8 days on 2 core(s)"
        ),
        "{stderr}"
    );
}

#[test]
fn resuming_a_directory_without_a_run_says_so_and_does_not_suggest_itself() {
    let dir = tempfile::tempdir().unwrap();
    let o = resume_in(dir.path()).assert().code(2).get_output().clone();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("nothing to resume here"), "{stderr}");
    assert!(!stderr.contains("--resume"), "{stderr}");
}

#[test]
fn a_configuration_cut_between_lines_runs_with_defaults_echoed_whole() {
    // Not detectable (every key is optional): the configuration used is
    // echoed whole in DIR/config.toml, the rest of the file's defaults included.
    let dir = tempfile::tempdir().unwrap();
    let cut = SMALL.split("window").next().unwrap();
    let cfg = write(dir.path(), "cut.toml", cut);
    let out = dir.path().join("out");
    run_into(&cfg, &out)
        .args(["--stop-after-steps", "1"])
        .assert()
        .code(130);
    let echoed = std::fs::read_to_string(out.join("config.toml")).unwrap();
    for line in [
        "window = 2.0",
        "tau_star = [0.03, 0.06, 0.1, 0.2, 0.4]",
        "seeds = [1, 2, 3, 4]",
    ] {
        assert!(echoed.contains(line), "{line} in\n{echoed}");
    }
}
