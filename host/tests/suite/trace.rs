//! `mbs digest --trace FILE --every K`: the trace file (docs/determinism.md,
//! "Traces").

use crate::common::*;
use mbs_kernel::Fnv1a;

#[test]
fn digest_writes_a_trace_of_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("trace.json");
    let out = mbs()
        .args(["digest", "--steps", "200", "--every", "50", "--trace"])
        .arg(&file)
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let printed = String::from_utf8(out).unwrap();
    let text = std::fs::read_to_string(&file).unwrap();
    let file: serde_json::Value = serde_json::from_str(&text).unwrap();
    let body = &file["body"];
    // The checksum covers the body's compact JSON.
    let checksum = Fnv1a::of(serde_json::to_string(body).unwrap().as_bytes());
    assert_eq!(file["checksum"], format!("{checksum:#018x}"));
    assert_eq!(body["format"], "mbs-trace 1");
    assert_eq!(body["precision"], "f64");
    assert_eq!(body["settle_steps"], 200);
    assert_eq!(body["flow_steps"], 200);
    assert_eq!(body["every"], 50);
    assert_eq!(body["config"], serde_json::Value::Null);
    assert!(body["target"].as_str().unwrap().contains('-'));
    assert!(["batched", "scalar"].contains(&body["step_path"].as_str().unwrap()));
    assert!(body["step_dt_s"].as_f64().unwrap() > 0.0);
    // Step 0, then every 50 steps through both phases.
    let records = body["records"].as_array().unwrap();
    let steps: Vec<u64> = records
        .iter()
        .map(|r| r["step"].as_u64().unwrap())
        .collect();
    assert_eq!(steps, [0, 50, 100, 150, 200, 250, 300, 350, 400]);
    assert_eq!(records[4]["phase"], "settle");
    assert_eq!(records[5]["phase"], "flow");
    for r in records {
        let groups = r["groups"].as_object().unwrap();
        let names: Vec<&str> = groups.keys().map(String::as_str).collect();
        assert_eq!(
            names,
            ["flow", "positions", "spins", "springs", "velocities"]
        );
    }
    // The records at the phases' ends are the printed digests.
    let settled = records[4]["digest"].as_str().unwrap();
    let flow = records[8]["digest"].as_str().unwrap();
    assert_eq!(printed, format!("settled {settled}\nflow {flow}\n"));
}

#[test]
fn every_must_be_positive() {
    let dir = tempfile::tempdir().unwrap();
    mbs()
        .args(["digest", "--steps", "10", "--every", "0", "--trace"])
        .arg(dir.path().join("t.json"))
        .assert()
        .code(2);
}

/// Writes a trace of 200 + 200 steps every 50 into `dir`.
fn trace_in(dir: &std::path::Path) -> std::path::PathBuf {
    let file = dir.join("trace.json");
    mbs()
        .args(["digest", "--steps", "200", "--every", "50", "--trace"])
        .arg(&file)
        .assert()
        .success();
    file
}

/// Rewrites a trace's body with `edit` and a checksum that matches.
fn edit_with_checksum(file: &std::path::Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let mut trace: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
    edit(&mut trace["body"]);
    let checksum = Fnv1a::of(serde_json::to_string(&trace["body"]).unwrap().as_bytes());
    trace["checksum"] = format!("{checksum:#018x}").into();
    std::fs::write(file, serde_json::to_string_pretty(&trace).unwrap()).unwrap();
}

#[test]
fn check_passes_a_fresh_trace_and_names_the_first_mismatch() {
    let dir = tempfile::tempdir().unwrap();
    let file = trace_in(dir.path());
    mbs()
        .args(["digest", "--check"])
        .arg(&file)
        .assert()
        .code(0)
        .stdout(predicates::str::contains("trace matches: 9 records"));
    // A record whose spins group (and full digest) differ from step 250 on.
    edit_with_checksum(&file, |body| {
        for r in 6..9 {
            body["records"][r]["groups"]["spins"] = "0x0000000000000000".into();
        }
        body["records"][5]["groups"]["spins"] = "0x0000000000000001".into();
        body["records"][5]["digest"] = "0x0000000000000002".into();
    });
    mbs()
        .args(["digest", "--check"])
        .arg(&file)
        .assert()
        .code(1)
        .stderr(predicates::str::contains(
            "first mismatch at integration step 250 (flow phase)",
        ))
        .stderr(predicates::str::contains(
            "differing groups: spins (trace 0x0000000000000001",
        ));
}

#[test]
fn check_refuses_damaged_edited_truncated_and_foreign_traces() {
    let dir = tempfile::tempdir().unwrap();
    let file = trace_in(dir.path());
    let text = std::fs::read_to_string(&file).unwrap();
    let bad = |name: &str, text: &str, why: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        mbs()
            .args(["digest", "--check"])
            .arg(&path)
            .assert()
            .code(2)
            .stderr(predicates::str::contains(why));
    };
    bad(
        "truncated.json",
        &text[..text.len() / 2],
        "damaged or truncated",
    );
    bad(
        "edited.json",
        &text.replacen("\"step\": 250", "\"step\": 251", 1),
        "checksum mismatch",
    );
    bad("foreign.json", "{\"a\": 1}", "not an mbs trace");
    bad("empty.json", "", "damaged or truncated");
    // A valid checksum over another scenario (τ* changed).
    let other = dir.path().join("other.json");
    std::fs::write(&other, &text).unwrap();
    edit_with_checksum(&other, |body| body["tau_star"] = 0.3.into());
    mbs()
        .args(["digest", "--check"])
        .arg(&other)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("scenario hash"));
}
