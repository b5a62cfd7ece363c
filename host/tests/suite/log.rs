//! What a run leaves for its user besides the results: `DIR/mbs.log`
//! (appended to by a resumed run), plain progress lines when standard
//! error is not a terminal, and warnings that `--quiet` does not silence
//! and `summary.json` keeps.

use crate::common::*;
use std::path::Path;

/// The events of `dir/mbs.log`, each line's timestamp checked and removed.
fn events(dir: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join("mbs.log")).unwrap();
    text.lines()
        .map(|line| {
            let (time, event) = line.split_once("  ").unwrap();
            // RFC 3339, UTC, milliseconds: 2026-11-25T19:32:41.123Z
            assert_eq!(time.len(), 24, "{line}");
            assert!(time.ends_with('Z') && time.as_bytes()[10] == b'T', "{line}");
            event.to_string()
        })
        .collect()
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn a_run_logs_its_cells_and_a_resume_and_a_rerun_append() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    // The beds settle (20 000 steps), the cells stop after 20 000 of theirs.
    run_into(&cfg, &out)
        .args(["--stop-after-steps", "20000"])
        .assert()
        .code(130);
    let first = events(&out);
    assert_eq!(first[0], "=== mbs run started");
    assert!(first[1].starts_with("command ") && first[1].contains(" run "));
    assert!(first[2].starts_with(&format!("version mbs {}", env!("CARGO_PKG_VERSION"))));
    assert!(first[3].starts_with("config fnv1a 0x"));
    assert!(first.contains(&"cell start  tau* 0.1 seed 1".to_string()));
    assert!(first
        .iter()
        .any(|e| e.starts_with("cell stopped  tau* 0.3 seed 2")));
    assert!(first.last().unwrap().starts_with("error (exit 130) "));

    resume_in(&out).assert().success();
    let second = events(&out);
    assert_eq!(second[..first.len()], first[..], "appended, not rewritten");
    let resumed = &second[first.len()..];
    assert_eq!(resumed[0], "=== mbs run resumed");
    assert_eq!(resumed[3], first[3], "the same configuration hash");
    assert!(resumed.contains(&"cell start  tau* 0.1 seed 1 (from its checkpoint)".to_string()));
    let ends: Vec<&String> = resumed
        .iter()
        .filter(|e| e.starts_with("cell end  "))
        .collect();
    assert_eq!(ends.len(), 4, "{resumed:?}");
    assert!(ends
        .iter()
        .all(|e| e.contains("  q* ") && e.ends_with(" s")));
    assert_eq!(resumed.last().unwrap(), "done (exit 0)");
    let computed = summary(&out);
    assert_eq!(computed["cells_computed"], 4);
    assert!(computed["grain_steps_per_s"].as_f64().unwrap() > 0.0);

    // Rerun on the finished directory: every cell reused, no rate claimed.
    run_into(&cfg, &out).assert().success();
    let third = events(&out);
    let rerun = &third[second.len()..];
    assert_eq!(rerun[0], "=== mbs run started");
    assert_eq!(
        rerun
            .iter()
            .filter(|e| e.starts_with("cell reused  "))
            .count(),
        4
    );
    let reused = summary(&out);
    assert_eq!(reused["cells_reused"], 4);
    assert_eq!(reused["cells_computed"], 0);
    assert_eq!(reused["grain_steps_computed"], 0);
    assert!(reused["grain_steps_per_s"].is_null(), "{reused}");
    assert_eq!(reused["grain_steps"], computed["grain_steps"]);
}

#[test]
fn quiet_keeps_the_warnings_on_stderr_in_the_log_and_in_the_summary() {
    let dir = tempfile::tempdir().unwrap();
    // 5 columns: narrower than 40 grain diameters, a physics warning.
    let cfg = write(
        dir.path(),
        "small.toml",
        &SMALL.replace("tau_star = [0.1, 0.3]", "tau_star = [0.3]"),
    );
    let out = dir.path().join("out");
    let cores = std::thread::available_parallelism().unwrap().get();
    let threads = (cores + 1).to_string();
    let run = run_into(&cfg, &out)
        .args(["--threads", &threads])
        .assert()
        .success();
    let stderr = String::from_utf8_lossy(&run.get_output().stderr).to_string();
    assert!(stderr.contains("warning: bed "), "{stderr}");
    assert!(stderr.contains("(5 columns) is narrower"), "{stderr}");
    assert!(stderr.contains(&format!("warning: {threads} threads on {cores} core(s)")));
    assert!(
        !stderr.contains("progress"),
        "--quiet silences progress: {stderr}"
    );
    let warnings = summary(&out)["warnings"].clone();
    let warnings: Vec<&str> = warnings
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    // The configuration's warnings first, then the physics of the run
    // (SMALL's beds are not at rest after 0.05 s).
    assert!(warnings.len() > 2, "{warnings:?}");
    assert!(
        warnings[0].starts_with("bed ")
            && warnings[1].starts_with(&format!("{threads} threads on"))
    );
    assert!(warnings[2].starts_with("bed-not-at-rest: "), "{warnings:?}");
    let log = events(&out);
    for w in warnings {
        assert!(log.contains(&format!("warning {w}")), "{log:?}");
    }
}

#[test]
fn off_a_terminal_progress_is_plain_lines() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    // Not quiet; the test harness pipes standard error: not a terminal.
    let run = assert_cmd::Command::cargo_bin("mbs")
        .unwrap()
        .arg("run")
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let stderr = String::from_utf8_lossy(&run.get_output().stderr).to_string();
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("progress"))
        .collect();
    assert!(lines.len() >= 2, "{stderr}");
    assert!(
        lines[0].starts_with("progress   0 %  cells 0/4  elapsed 0:0"),
        "{stderr}"
    );
    let last = lines.last().unwrap();
    assert!(
        last.starts_with("progress 100 %  cells 4/4  elapsed "),
        "{stderr}"
    );
    assert!(last.contains("  eta 0:00"), "{stderr}");
    assert!(!stderr.contains('\r'), "no bar drawn: {stderr:?}");
}

#[test]
fn pack_and_snapshot_log_too() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    for (command, extra) in [
        ("pack", ["--duration", "0.01"]),
        ("snapshot", ["--frames", "1"]),
    ] {
        let out = dir.path().join(command);
        mbs()
            .arg(command)
            .arg(&cfg)
            .arg("--out")
            .arg(&out)
            .args(extra)
            .assert()
            .success();
        let log = events(&out);
        assert_eq!(log[0], format!("=== mbs {command} started"));
        assert!(log.iter().any(|e| e.starts_with("warning ")) == (command == "snapshot"));
        assert_eq!(log.last().unwrap(), "done (exit 0)");
    }
}

/// `flow.bed_level_window`, the old name of `flow.bed_level_span`, is read
/// for one release: the same run, and a warning that names the new key on
/// standard error, in `mbs.log` and in `summary.json`; `DIR/config.toml`
/// holds the new key only.
#[test]
fn the_old_bed_level_key_gives_the_same_run_and_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let small = SMALL.replace("tau_star = [0.1, 0.3]", "tau_star = [0.3]");
    let run = |key: &str| {
        let text = small.replace("[flow]\n", &format!("[flow]\n{key} = 4.0\n"));
        let cfg = write(dir.path(), &format!("{key}.toml"), &text);
        let out = dir.path().join(key);
        let done = run_into(&cfg, &out).assert().success();
        let stderr = String::from_utf8_lossy(&done.get_output().stderr).to_string();
        (out, stderr)
    };
    let (new, new_err) = run("bed_level_span");
    let (old, old_err) = run("bed_level_window");
    let read = |dir: &Path, name: &str| std::fs::read_to_string(dir.join(name)).unwrap();
    assert_eq!(read(&old, "transport.csv"), read(&new, "transport.csv"));
    assert_eq!(read(&old, "config.toml"), read(&new, "config.toml"));
    assert!(read(&new, "config.toml").contains("bed_level_span = 4.0"));
    assert!(!read(&old, "config.toml").contains("bed_level_window"));
    let warning = "flow.bed_level_window is now flow.bed_level_span;";
    assert!(!new_err.contains(warning), "{new_err}");
    assert!(
        old_err.contains(&format!("warning: {warning}")),
        "{old_err}"
    );
    let warnings = summary(&old)["warnings"].to_string();
    assert!(warnings.contains(warning), "{warnings}");
    assert!(!summary(&new)["warnings"].to_string().contains(warning));
    let log = events(&old);
    assert!(
        log.iter()
            .any(|e| e.starts_with(&format!("warning {warning}"))),
        "{log:?}"
    );
}
