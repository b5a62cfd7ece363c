//! `mbs calibrate` end to end in its quick mode: every stage and the report,
//! resuming after an interruption, shards merged to the serial result, and
//! results independent of the thread count.

use crate::common::*;
use std::path::Path;

fn calibrate(dir: &Path, extra: &[&str]) {
    mbs()
        .args(["calibrate", "--quick", "--out"])
        .arg(dir)
        .args(extra)
        .assert()
        .success();
}

fn read(dir: &Path, name: &str) -> String {
    std::fs::read_to_string(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn json(dir: &Path, name: &str) -> serde_json::Value {
    serde_json::from_str(&read(dir, name)).unwrap()
}

#[test]
fn quick_calibration_writes_every_stage_and_the_report() {
    let dir = tempfile::tempdir().unwrap();
    calibrate(dir.path(), &[]);
    for f in [
        "report.md",
        "plan.json",
        "stage1.png",
        "stage2.svg",
        "stage3.png",
        "stage3.csv",
        "stage4.csv",
        "stage4_dt.png",
        "stage4_sizes.png",
        "stage4_layers.png",
        "stage5.png",
    ] {
        assert!(dir.path().join(f).metadata().unwrap().len() > 0, "{f}");
    }
    // The log and the summary (docs/guarantees.md).
    let log = read(dir.path(), "mbs.log");
    let events: Vec<&str> = log.lines().map(|l| l.split_once("  ").unwrap().1).collect();
    assert_eq!(events[0], "=== mbs calibrate started");
    assert!(events.contains(&"stage 3 (β)"));
    assert!(events.iter().any(|e| e.starts_with("cell end  tau* ")));
    assert_eq!(events.last(), Some(&"done (exit 0)"));
    let summary = json(dir.path(), "summary.json");
    assert_eq!(summary["stages_done"], 5);
    assert!(summary["warnings"].is_array());
    let report = read(dir.path(), "report.md");
    let s1 = json(dir.path(), "stage1.json");
    let s3 = json(dir.path(), "stage3.json");
    let s4 = json(dir.path(), "stage4.json");
    // β's uncertainty: the evaluated β within the noise of the minimum,
    // the fitted one among them, stated in the report.
    let beta = s3["beta"].as_f64().unwrap();
    let (lo, hi) = (
        s3["beta_range"][0].as_f64().unwrap(),
        s3["beta_range"][1].as_f64().unwrap(),
    );
    assert!(lo <= beta && beta <= hi, "{lo} {beta} {hi}");
    assert!(
        report.contains(&format!("spans **[{lo:.3}, {hi:.3}]**: β's uncertainty")),
        "{report}"
    );
    // The summary table states our values next to the paper's, from the stage results.
    let alpha_m = s1["chosen"].as_f64().unwrap();
    assert!(
        report.contains(&format!("| α_m | {alpha_m} | 20 |")),
        "{report}"
    );
    let beta = s3["beta"].as_f64().unwrap();
    assert!(report.contains(&format!("| β | {beta:.3} | 15.8 |")));
    // The figures: the chosen β marked, q*_k/f_k named, narrow axes labelled.
    let misfit = read(dir.path(), "stage3_misfit.svg");
    assert!(misfit.contains(&format!("chosen β = {beta:.3}")));
    assert!(read(dir.path(), "stage5.svg").contains("fractional transport q*_k / f_k"));
    for f in ["stage4_dt.svg", "stage4_dt_layers.svg"] {
        let svg = read(dir.path(), f);
        let dt_labels = svg
            .split("</text>")
            .filter_map(|t| t.rsplit('>').next()?.trim().parse::<f64>().ok())
            .filter(|v| *v > 0.0 && *v < 1e-3)
            .count();
        assert!(dt_labels >= 2, "{f}: y tick labels");
    }
    assert!(beta > 1.0 && beta < 30.0);
    let dt01 = s4["rows"][0]["constants_dt"].as_f64().unwrap();
    assert_eq!(s4["rows"][0]["diameter_mm"], 0.1);
    assert!(report.contains(&format!("| {dt01:.2e} s | 9.0e-6 s |")));
    let worst = s3["worst_factor"].as_f64().unwrap();
    assert!(report.contains(&format!("**{worst:.2}** (target 1.5)")));
    // Stage 3 fitted: better than the unsoftened contacts.
    let before: Vec<f64> = s3["before"]["q_star"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap_or(f64::NAN))
        .collect();
    let after: Vec<f64> = s3["after"]["q_star"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(before.len(), after.len());
    assert!(s3["misfit"].as_f64().unwrap() < s3["coarse"][0][1].as_f64().unwrap());
    // Error-driven points: every point of the fitted curve reached its
    // target (or a clear verdict) or used the most seeds of the plan.
    let plan = json(dir.path(), "plan.json");
    let fine = &plan["fine"];
    let threshold = plan["threshold_tau_star"].as_f64().unwrap();
    for (k, t) in s3["after"]["tau_stars"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
    {
        let seeds = s3["after"]["seeds"][k].as_u64().unwrap();
        let cap = if t.as_f64().unwrap() <= threshold {
            fine["threshold_seeds_max"].as_u64().unwrap()
        } else {
            fine["seeds_max"].as_u64().unwrap()
        };
        assert!(
            seeds >= fine["seeds"].as_u64().unwrap() && seeds <= cap,
            "{t}: {seeds}"
        );
        let reached = s3["after"]["reached"][k].as_bool().unwrap();
        assert!(reached || seeds == cap, "{t}");
        // A capped point is named in the log and the report.
        let named = log.contains(&format!("capped  tau* {t} beta {beta}:"));
        assert_eq!(named, !reached, "{t}: {log}");
        if !reached {
            assert!(report.contains("**Capped:**"), "{report}");
        }
    }
    // Two fidelities in the search, the precise ones around the result.
    let csv = read(dir.path(), "stage3.csv");
    assert!(
        csv.lines().any(|l| l.starts_with("coarse,"))
            && csv.lines().any(|l| l.starts_with("fine,"))
    );
    assert!(s3["fine"]
        .as_array()
        .unwrap()
        .iter()
        .any(|e| e[0].as_f64() == Some(beta)));
    // calibrated.toml: what `mbs run` reads as it is, with the fitted constants.
    let calibrated = mbs::Config::load(Some(&dir.path().join("calibrated.toml")))
        .expect("mbs run accepts calibrated.toml");
    let rule = calibrated.scenario.rule;
    assert_eq!(
        (rule.alpha_m, rule.alpha_cn, rule.beta),
        (
            alpha_m,
            json(dir.path(), "stage2.json")["chosen"].as_f64().unwrap(),
            beta
        )
    );
    // Run again (every cell stored): it ends by printing the values.
    let out = assert_cmd::Command::cargo_bin("mbs")
        .unwrap()
        .args(["calibrate", "--quick", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    let printed = String::from_utf8(out.stdout).unwrap();
    assert!(
        printed.contains(&format!("calibrated: alpha_m = {alpha_m}, "))
            && printed.contains(&format!("beta = {beta} "))
            && printed.contains("calibrated.toml"),
        "{printed}"
    );
}

#[test]
fn an_interrupted_calibration_resumes_and_loses_no_finished_cell() {
    let dir = tempfile::tempdir().unwrap();
    calibrate(dir.path(), &["--stage", "2"]);
    let cells = read(dir.path(), "cells.jsonl");
    let stage2 = read(dir.path(), "stage2.json");
    // Nothing to do the second time.
    calibrate(dir.path(), &["--stage", "2"]);
    assert_eq!(read(dir.path(), "cells.jsonl"), cells);
    // A crash while the last cell was being written: that cell is computed again.
    let torn = &cells[..cells.len() - 40];
    std::fs::write(dir.path().join("cells.jsonl"), torn).unwrap();
    std::fs::remove_file(dir.path().join("stage2.json")).unwrap();
    calibrate(dir.path(), &["--stage", "2"]);
    assert_eq!(read(dir.path(), "stage2.json"), stage2);
    let lines = read(dir.path(), "cells.jsonl").lines().count();
    assert_eq!(
        lines,
        cells.lines().count() + 1,
        "one torn line + one recomputed cell"
    );
}

#[test]
fn shards_merge_to_the_serial_result_and_threads_change_nothing() {
    let root = tempfile::tempdir().unwrap();
    let serial = root.path().join("serial");
    mbs()
        .args([
            "--threads",
            "1",
            "calibrate",
            "--quick",
            "--stage",
            "2",
            "--out",
        ])
        .arg(&serial)
        .assert()
        .success();
    let parallel = root.path().join("parallel");
    mbs()
        .args([
            "--threads",
            "2",
            "calibrate",
            "--quick",
            "--stage",
            "2",
            "--out",
        ])
        .arg(&parallel)
        .assert()
        .success();
    for f in ["stage1.json", "stage2.json", "stage1.csv"] {
        assert_eq!(read(&serial, f), read(&parallel, f), "{f}");
    }
    let shards: Vec<_> = (1..=3)
        .map(|i| root.path().join(format!("shard{i}")))
        .collect();
    for (i, dir) in shards.iter().enumerate() {
        mbs()
            .args([
                "calibrate",
                "--quick",
                "--stage",
                "1",
                "--shard",
                &format!("{}/3", i + 1),
                "--out",
            ])
            .arg(dir)
            .assert()
            .success();
        assert!(
            !dir.join("stage1.json").exists(),
            "a shard alone cannot finish stage 1"
        );
    }
    let merged = root.path().join("merged");
    mbs()
        .args(["calibrate", "merge"])
        .args(&shards)
        .arg("--out")
        .arg(&merged)
        .assert()
        .success();
    let before = read(&merged, "cells.jsonl").lines().count();
    calibrate(&merged, &["--stage", "1"]);
    assert_eq!(
        read(&merged, "cells.jsonl").lines().count(),
        before,
        "no cell recomputed"
    );
    assert_eq!(read(&merged, "stage1.json"), read(&serial, "stage1.json"));
    mbs().args(["calibrate", "--shard", "4/3"]).assert().code(2);
    mbs()
        .args(["calibrate", "merge"])
        .arg(root.path().join("no-such-shard"))
        .arg("--out")
        .arg(root.path().join("m2"))
        .assert()
        .code(1)
        .stderr(predicates::str::contains("no cell store here"));
}

#[test]
fn a_calibration_killed_at_random_moments_finishes_with_the_same_results() {
    let root = tempfile::tempdir().unwrap();
    let reference = root.path().join("reference");
    // Kills at 5–65 % of an uninterrupted calibration's wall time, whatever
    // the build's speed.
    let ((), wall) = timed(|| calibrate(&reference, &["--stage", "2"]));
    let out = root.path().join("killed");
    let bin = assert_cmd::cargo::cargo_bin("mbs");
    let mut kills = 0;
    let delays = random_fractions(99).map(|f| wall.mul_f64(0.05 + 0.6 * f));
    for delay in delays.take(5) {
        let mut c = std::process::Command::new(&bin);
        c.args(["--quiet", "calibrate", "--quick", "--stage", "2", "--out"])
            .arg(&out);
        kills += usize::from(kill_after(&mut c, delay));
    }
    calibrate(&out, &["--stage", "2"]);
    for f in ["stage1.json", "stage2.json", "stage2.csv"] {
        assert_eq!(read(&out, f), read(&reference, f), "{f}");
    }
    assert!(kills >= 1, "killed {kills} times");
}
