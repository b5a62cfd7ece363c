//! The third round of hostile input (2026-11-29): stored results, files
//! that are not regular files, values that pass their own range but not
//! the bed's, and environment variables that bypass the command line.

use crate::common::{run_into, write};
use predicates::prelude::*;
use predicates::str::contains;

/// A bed of 4 columns × 1 row in two size classes, phases of a few steps.
const TINY_MIXED: &str = r#"
[grains]
classes = [{ diameter_mm = 0.5, fraction = 0.5 }, { diameter_mm = 0.4, fraction = 0.5 }]
[bed]
columns = 4
rows = 1
[time]
settle_until = "time"
settle = 0.001
spin_up = 0.001
window = 0.002
window_min = 0.002
block = 0.001
[flow]
tau_star = [0.2]
[run]
seeds = [1]
capacity = 256
"#;

/// TINY_MIXED written in `dir` and run into `dir/out`: the configuration
/// and the output directory.
fn tiny_run(dir: &std::path::Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let cfg = write(dir, "tiny.toml", TINY_MIXED);
    let out = dir.join("out");
    run_into(&cfg, &out).assert().success();
    (cfg, out)
}

/// The settled bed's file of the run in `out` (one seed: one bed).
fn settled_bed(out: &std::path::Path) -> std::path::PathBuf {
    std::fs::read_dir(out.join("beds"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "bed"))
        .unwrap()
}

/// Rewrites the result of the only line of the cell store in `dir` by
/// `edit` and signs it again (CRC-32 of key, a zero byte and the value's
/// compact JSON), as someone who read `store.rs` could.
fn resign(dir: &std::path::Path, edit: impl Fn(&mut serde_json::Value)) {
    let path = dir.join("cells.jsonl");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut line: serde_json::Value = serde_json::from_str(text.trim()).unwrap();
    edit(&mut line["value"]["Ok"]);
    let key = line["key"].as_str().unwrap().to_string();
    let mut h = crc32fast::Hasher::new();
    h.update(key.as_bytes());
    h.update(&[0]);
    h.update(line["value"].to_string().as_bytes());
    line["crc32"] = h.finalize().into();
    std::fs::write(&path, format!("{line}\n")).unwrap();
}

/// A stored line whose checksum is right but whose result does not fit its
/// cell (too few class values: was a panic; another τ*: a NaN row; q* not
/// the mean of its blocks; profiles off the column) is refused with a
/// warning naming the field, and the cell computed again: the table is
/// the one the genuine line gave.
#[test]
fn stored_results_that_do_not_fit_their_cell_are_computed_again() {
    let dir = tempfile::tempdir().unwrap();
    let (cfg, out) = tiny_run(dir.path());
    let table = std::fs::read(out.join("transport.csv")).unwrap();
    let profiles = std::fs::read(out.join("profiles.csv")).unwrap();
    type Edit = fn(&mut serde_json::Value);
    let edits: [(&str, Edit); 5] = [
        ("q_star_class", |v| {
            v["q_star_class"] = serde_json::json!([])
        }),
        ("tau_star and seed", |v| v["tau_star"] = 0.3.into()),
        ("q_star", |v| v["q_star"] = 1e308.into()),
        ("blocks", |v| {
            v["blocks"][0]["q_star_class"] = serde_json::json!([0.0])
        }),
        ("profile", |v| {
            v["profile"]["solid_fraction"] = serde_json::json!([0.5]);
        }),
    ];
    for (field, edit) in edits {
        resign(&out, edit);
        run_into(&cfg, &out)
            .assert()
            .success()
            .stderr(contains(format!(
                "is refused (its {field} does not fit the cell)"
            )));
        assert_eq!(
            std::fs::read(out.join("transport.csv")).unwrap(),
            table,
            "{field}"
        );
        assert_eq!(
            std::fs::read(out.join("profiles.csv")).unwrap(),
            profiles,
            "{field}"
        );
        // The cell computed again is the line read from then on.
        std::fs::write(
            out.join("cells.jsonl"),
            std::fs::read_to_string(out.join("cells.jsonl"))
                .unwrap()
                .lines()
                .last()
                .unwrap()
                .to_string()
                + "\n",
        )
        .unwrap();
        run_into(&cfg, &out)
            .arg("--stop-after-steps")
            .arg("0")
            .assert()
            .success();
    }
}

/// A FIFO planted where mbs keeps a file of its own (the store, the log,
/// the lock, a cell's checkpoint, a settled bed) blocked the open forever
/// (and, once the Ctrl-C handler was installed, SIGTERM no longer ended
/// it): now refused at once, naming the file, exit 1.
#[cfg(unix)]
#[test]
fn a_fifo_where_mbs_keeps_its_own_file_is_refused_not_waited_on() {
    let dir = tempfile::tempdir().unwrap();
    let (cfg, good) = tiny_run(dir.path());
    let bed = settled_bed(&good);
    let bed = format!("beds/{}", bed.file_name().unwrap().to_string_lossy());
    for own in [
        "cells.jsonl",
        "mbs.log",
        ".mbs-lock",
        "checkpoints/tau0.2_seed1.ckpt",
        &bed,
    ] {
        let out = dir.path().join(format!("fifo-{}", own.replace('/', "-")));
        std::fs::create_dir_all(out.join("beds")).unwrap();
        std::fs::create_dir_all(out.join("checkpoints")).unwrap();
        let status = std::process::Command::new("mkfifo")
            .arg(out.join(own))
            .status()
            .unwrap();
        assert!(status.success());
        run_into(&cfg, &out)
            .timeout(std::time::Duration::from_secs(60))
            .assert()
            .code(1)
            .stderr(contains(own).and(contains("not a regular file")));
    }
}

/// Values inside their own ranges that the bed cannot take were accepted
/// by `mbs config` and failed every command at run time (exit 1, after
/// writing `config.toml` over a finished run's): a periodic width under
/// three neighbour bins (3 columns), a channel narrower than a grain (a
/// solid fraction above 1), a bench bed of 3 columns. Now exit 2 naming
/// the key and what it needs, before anything is written.
#[test]
fn values_the_bed_cannot_take_are_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let (cfg, out) = tiny_run(dir.path());
    let echoed = std::fs::read(out.join("config.toml")).unwrap();
    let refused = |sets: &[&str], message: &str| {
        let mut run = run_into(&cfg, &out);
        for s in sets {
            run.args(["--set", s]);
        }
        run.assert().code(2).stderr(contains(message));
        assert_eq!(std::fs::read(out.join("config.toml")).unwrap(), echoed);
    };
    refused(
        &["bed.columns=3"],
        "bed.columns = 3: must be >= 4 for bed.spacing = 1.05 and run.skin_d = 0.1",
    );
    refused(
        &["bed.columns=4", "run.skin_d=0.5"],
        "bed.columns = 4: must be >= 5",
    );
    refused(
        &["flow.model=\"coupled\"", "channel.width_m=0.0001"],
        "channel.width_m = 0.0001: must be >= the largest grain diameter, 5e-4 m",
    );
    crate::common::mbs()
        .args(["bench", "--grains", "38"])
        .assert()
        .code(2)
        .stderr(contains("38 is not in 39..=65536"));
}

/// `RAYON_NUM_THREADS` is what rayon uses without `--threads`: it passed
/// by the 1024-thread limit and the warning (2000 threads for a tiny run,
/// `summary.json` saying 2000). Now checked as `--threads` is.
#[test]
fn rayon_num_threads_is_checked_as_threads_is() {
    crate::common::mbs()
        .env("RAYON_NUM_THREADS", "2000")
        .arg("config")
        .assert()
        .code(2)
        .stderr(contains(
            "RAYON_NUM_THREADS = 2000: must be 0 (one per core) to 1024",
        ));
    crate::common::mbs()
        .env("RAYON_RS_NUM_CPUS", "5000")
        .arg("config")
        .assert()
        .code(2)
        .stderr(contains("RAYON_RS_NUM_CPUS = 5000"));
    // Read as rayon reads it: " 2000" is no number, ignored.
    crate::common::mbs()
        .env("RAYON_NUM_THREADS", " 2000")
        .arg("config")
        .assert()
        .success();
    // --threads given: the environment is not read.
    crate::common::mbs()
        .env("RAYON_NUM_THREADS", "2000")
        .args(["--threads", "1", "config"])
        .assert()
        .success();
}

/// Command-line times: `--checkpoint-every` beyond what a duration holds
/// was refused as "must be > 0 seconds" and quoted in 301 digits;
/// `snapshot --every` under one integration step wrote identical frames.
#[test]
fn command_line_intervals_have_true_ranges() {
    crate::common::mbs()
        .args(["run", "--checkpoint-every", "1e300"])
        .assert()
        .code(2)
        .stderr(contains(
            "--checkpoint-every = 1e300: must be in (0, 1e9] seconds of wall time",
        ));
    let dir = tempfile::tempdir().unwrap();
    crate::common::mbs()
        .args(["snapshot", "--every", "1e-6", "--frames", "2", "--out"])
        .arg(dir.path().join("snap"))
        .assert()
        .code(2)
        .stderr(contains(
            "--every = 0.000001: must be >= one integration step (step_dt = \
             constants_dt/substeps = 0.0000025 s)",
        ));
    assert!(!dir.path().join("snap").exists());
}

/// `--set` errors at a section's header of the reformatted text (a new
/// section, a table for a list) quoted a line of a file the user never
/// saw; they name the `--set` as every other one does.
#[test]
fn set_errors_at_a_section_name_the_set() {
    for (set, why) in [
        ("x.y=1", "unknown field `x`"),
        (
            "grains.classes={}",
            "invalid type: map, expected a sequence",
        ),
        ("flow.tau_star=[{a=1}]", "invalid type: map, expected f64"),
        ("flow.tau_star={a=1}", "invalid type: map, expected f64"),
    ] {
        crate::common::mbs()
            .args(["config", "--set", set])
            .assert()
            .code(2)
            .stderr(contains(format!("--set {set}: {why}")))
            .stderr(contains("TOML parse error").not());
    }
}

/// A settled bed's file, signed again, was trusted whatever it held: a
/// kernel state with other grains than the bed builds (an extra grain; an
/// empty bed gave q* = 0), or more settling steps than `time.settle`
/// allows (u64::MAX: 4.6e13 s of settling in `summary.json`). Refused,
/// naming the file, exit 1; the table stays.
#[test]
fn a_settled_bed_that_its_configuration_does_not_build_is_refused() {
    use mbs::work::beds::BedState;
    let dir = tempfile::tempdir().unwrap();
    let (cfg, out) = tiny_run(dir.path());
    let table = std::fs::read(out.join("transport.csv")).unwrap();
    let path = settled_bed(&out);
    let key = u64::from_str_radix(path.file_stem().unwrap().to_str().unwrap(), 16).unwrap();
    let genuine = std::fs::read(&path).unwrap();
    type Craft = fn(&mut BedState);
    let crafts: [(&str, Craft); 2] = [
        ("more than time.settle", |bed| bed.steps = u64::MAX),
        ("other grains than its bed builds", |bed| {
            let mut sim = mbs::sim::sims::boxed_sim::<f64, 256, { mbs::sim::sims::NEIGHBOURS }>();
            sim.restore(&bed.sim).unwrap();
            let mut extra = sim.grain(sim.len() - 1).unwrap();
            extra.y += 4.0 * extra.diameter;
            sim.add_grain(&extra).unwrap();
            bed.sim.clear();
            sim.checkpoint(|b| bed.sim.extend_from_slice(b));
        }),
    ];
    for (why, craft) in crafts {
        let mut bed = BedState::decode(&genuine, key).unwrap();
        craft(&mut bed);
        std::fs::write(&path, bed.encode()).unwrap();
        // The cell is computed again from the bed (not from the store).
        std::fs::remove_file(out.join("cells.jsonl")).unwrap();
        run_into(&cfg, &out).assert().code(1).stderr(contains(why));
        assert_eq!(
            std::fs::read(out.join("transport.csv")).unwrap(),
            table,
            "{why}"
        );
        std::fs::write(&path, &genuine).unwrap();
        run_into(&cfg, &out).assert().success();
    }
}

/// `bench --beds DIR` used whatever checkpoint had a prepared bed's name
/// (another bed timed as this one; an empty one gave NaN contacts per
/// grain and inf ns): now a file that is not this bed is prepared again.
#[test]
fn a_bench_bed_that_is_not_the_bed_is_prepared_again() {
    let dir = tempfile::tempdir().unwrap();
    let beds = dir.path().join("beds");
    let bench = |grains: &str| {
        let out = crate::common::mbs()
            .args(["bench", "--grains", grains, "--steps", "10", "--beds"])
            .arg(&beds)
            .assert()
            .success();
        String::from_utf8(out.get_output().stdout.clone()).unwrap()
    };
    assert!(bench("44").starts_with("44 grains"));
    let file = |columns: &str| {
        std::fs::read_dir(&beds)
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| p.to_string_lossy().contains(&format!("_{columns}c_")))
            .unwrap()
    };
    let four = file("4");
    assert!(bench("55").starts_with("55 grains"));
    std::fs::copy(file("5"), &four).unwrap();
    assert!(bench("44").starts_with("44 grains"));
}

/// `mbs run` and `mbs calibrate` write files of the same names
/// (`summary.json`, `cells.jsonl`, `mbs.log`): either, given the other's
/// directory, overwrote its summary. Refused, exit 2, nothing written.
#[test]
fn run_and_calibrate_keep_to_directories_of_their_own() {
    let dir = tempfile::tempdir().unwrap();
    let (cfg, out) = tiny_run(dir.path());
    let summary = std::fs::read(out.join("summary.json")).unwrap();
    let log = std::fs::read(out.join("mbs.log")).unwrap();
    crate::common::mbs()
        .args(["calibrate", "--quick", "--out"])
        .arg(&out)
        .assert()
        .code(2)
        .stderr(contains("holds the results of `mbs run` (transport.csv)"));
    assert_eq!(std::fs::read(out.join("summary.json")).unwrap(), summary);
    assert_eq!(std::fs::read(out.join("mbs.log")).unwrap(), log);
    let calibration = dir.path().join("calibration");
    std::fs::create_dir(&calibration).unwrap();
    std::fs::write(calibration.join("plan.json"), "{}").unwrap();
    run_into(&cfg, &calibration)
        .assert()
        .code(2)
        .stderr(contains("holds the results of `mbs calibrate` (plan.json)"));
    assert!(!calibration.join("summary.json").exists());
}
