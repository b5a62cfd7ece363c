//! Settling the initial bed once per seed, until at rest (docs/model.md §7
//! step 3): every τ* of a seed starts from the same settled bed, a bed at
//! rest stops early at a whole window, a bed that is not at rest by
//! `time.settle` is a named warning kept in `summary.json`.

use crate::common::*;
use serde_json::Value;

fn summary(out: &std::path::Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn a_bed_not_at_rest_by_time_settle_is_a_named_warning_kept_in_the_summary() {
    // SMALL settles for 0.05 s: one window of the criterion, which needs four.
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    run_into(&cfg, &out)
        .assert()
        .success()
        .stderr(predicates::str::contains(
            "warning: bed-not-at-rest: the bed of seed 2 is not at rest after 0.050 s",
        ));
    let s = summary(&out);
    assert_eq!(s["beds_settled"], 2, "one bed per seed for 4 cells");
    let warnings: Vec<&str> = s["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    for seed in [1, 2] {
        let named = format!("bed-not-at-rest: the bed of seed {seed} ");
        assert!(
            warnings.iter().any(|w| w.starts_with(&named)),
            "{warnings:?}"
        );
    }
    for cell in s["cells"].as_array().unwrap() {
        assert_eq!(cell["bed"]["status"], "not_at_rest");
        assert_eq!(cell["bed"]["settle_s"], 0.05);
    }
}

#[test]
fn a_bed_at_rest_stops_early_and_every_tau_of_its_seed_starts_from_it() {
    let dir = tempfile::tempdir().unwrap();
    let text = SMALL.replace("settle = 0.05", "settle = 3.0");
    let cfg = write(dir.path(), "rest.toml", &text);
    let out = dir.path().join("out");
    run_into(&cfg, &out).assert().success();
    let s = summary(&out);
    let cells = s["cells"].as_array().unwrap();
    for seed in [1, 2] {
        let beds: Vec<&Value> = cells
            .iter()
            .filter(|c| c["seed"] == seed)
            .map(|c| &c["bed"])
            .collect();
        assert_eq!(beds.len(), 2);
        assert_eq!(beds[0], beds[1], "seed {seed}: one bed for both tau*");
        assert_eq!(beds[0]["status"], "at_rest");
        let t = beds[0]["settle_s"].as_f64().unwrap();
        // At rest after at least four windows of 0.05 s, before the cap,
        // at a window's end.
        assert!((0.2..3.0).contains(&t), "seed {seed}: {t} s");
        assert!(((t / 0.05) - (t / 0.05).round()).abs() < 1e-9, "{t}");
    }
    // Settling exactly 0.2 s instead: a different start, so other numbers.
    let fixed = write(
        dir.path(),
        "fixed.toml",
        &SMALL.replace("settle = 0.05", "settle_until = \"time\"\nsettle = 0.2"),
    );
    let out_fixed = dir.path().join("fixed");
    run_into(&fixed, &out_fixed).assert().success();
    for cell in summary(&out_fixed)["cells"].as_array().unwrap() {
        assert_eq!(cell["bed"]["settle_s"], 0.2);
    }
    assert_ne!(
        std::fs::read(out.join("transport.csv")).unwrap(),
        std::fs::read(out_fixed.join("transport.csv")).unwrap()
    );
}
