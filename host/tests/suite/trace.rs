//! `mbs digest --trace FILE --every K`: the trace file, and `mbs digest
//! --check`, which compares a run with it and locates where they part
//! (docs/determinism.md, "Traces").

use crate::common::*;
use std::path::{Path, PathBuf};

/// The trace checksum: CRC-32 of the body's compact JSON.
fn checksum(body: &serde_json::Value) -> String {
    format!(
        "{:#010x}",
        crc32fast::hash(serde_json::to_string(body).unwrap().as_bytes())
    )
}

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
    assert_eq!(file["checksum"], checksum(body));
    assert_eq!(body["format"], "mbs-trace 3");
    assert_eq!(body["from"], 0);
    assert_eq!(body["until"], 400);
    assert_eq!(body["states"], false);
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
        assert!(r.get("state").is_none(), "no states unless asked");
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
    assert_eq!(printed, format!("settling {settled}\nflow {flow}\n"));
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
fn trace_in(dir: &Path) -> PathBuf {
    let file = dir.join("trace.json");
    mbs()
        .args(["digest", "--steps", "200", "--every", "50", "--trace"])
        .arg(&file)
        .assert()
        .success();
    file
}

/// Rewrites a trace's body with `edit` and a checksum that matches.
fn edit_with_checksum(file: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let mut trace: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
    edit(&mut trace["body"]);
    trace["checksum"] = checksum(&trace["body"]).into();
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

/// `mbs digest --check TRACE [--nudge N]`: its exit status and standard error.
fn check(trace: &Path, nudge: Option<&str>) -> (Option<i32>, String) {
    let mut c = mbs();
    c.args(["digest", "--check"]).arg(trace);
    if let Some(n) = nudge {
        c.args(["--nudge", n]);
    }
    let out = c.output().unwrap();
    (out.status.code(), String::from_utf8(out.stderr).unwrap())
}

/// Records `mbs digest ARGS --trace FILE` in `dir`.
fn record(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let file = dir.join(name);
    mbs()
        .arg("digest")
        .args(args)
        .arg("--trace")
        .arg(&file)
        .assert()
        .success();
    file
}

/// The locator, tested honestly: a run changed by one ULP of one grain's
/// field at a known step (`--nudge`, through the kernel's `Sim::nudge`) is
/// located to that integration step, that grain and that field, with the
/// size of the change, in both precisions and for three fields.
#[test]
fn a_one_ulp_change_is_located_to_its_step_grain_and_field() {
    let dir = tempfile::tempdir().unwrap();
    for (precision, from, until, nudge, grain_line) in [
        ("f64", "270", "300", "290:7:y", "grain 7 y: "),
        ("f32", "340", "360", "350:12:spin:-2", "grain 12 spin: "),
        ("f64", "390", "400", "395:20:draw_u", "grain 20 draw_u: "),
    ] {
        let trace = record(
            dir.path(),
            &format!("dense-{precision}-{from}.json"),
            &[
                "--steps",
                "200",
                "--precision",
                precision,
                "--every",
                "1",
                "--from",
                from,
                "--until",
                until,
                "--states",
            ],
        );
        assert_eq!(
            check(&trace, None).0,
            Some(0),
            "{precision}: unchanged, it matches"
        );
        let (code, err) = check(&trace, Some(nudge));
        assert_eq!(code, Some(1), "{err}");
        let step = nudge.split(':').next().unwrap();
        for expected in [
            format!("first mismatch at integration step {step}"),
            format!("the runs part at integration step {step}"),
            "1 grain value differs in 1 grain\n".to_string(),
            grain_line.to_string(),
        ] {
            assert!(
                err.contains(&expected),
                "{precision} {nudge}: no {expected:?} in\n{err}"
            );
        }
        let ulps = nudge.split(':').nth(3).unwrap_or("+1");
        let ulps = if ulps.starts_with('-') {
            ulps.to_string()
        } else {
            format!("+{}", ulps.trim_start_matches('+'))
        };
        assert!(err.contains(&format!("({ulps} ULP, difference ")), "{err}");
    }
}

/// A coarse trace says between which records the runs part and prints the
/// two commands that narrow it down; run as printed, they locate the step.
#[test]
fn a_coarse_mismatch_prints_the_commands_that_locate_it() {
    let dir = tempfile::tempdir().unwrap();
    let coarse = record(
        dir.path(),
        "coarse.json",
        &["--steps", "300", "--every", "100"],
    );
    let (code, err) = check(&coarse, Some("290:7:y"));
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("first mismatch at integration step 300 (settle phase)"),
        "{err}"
    );
    assert!(err.contains("differing groups: positions"), "{err}");
    assert!(
        err.contains("between integration steps 200 (equal) and 300"),
        "{err}"
    );
    // The printed recording command, run as printed (in `dir`).
    let command = err
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with("mbs digest ") && l.contains("--trace dense.json"))
        .unwrap_or_else(|| panic!("no command in\n{err}"));
    assert!(
        command.contains("--every 1 --from 200 --until 300 --states"),
        "{command}"
    );
    let args: Vec<&str> = command.split_whitespace().skip(1).collect();
    mbs().current_dir(dir.path()).args(&args).assert().success();
    let (code, err) = check(&dir.path().join("dense.json"), Some("290:7:y"));
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("the runs part at integration step 290"),
        "{err}"
    );
    assert!(err.contains("grain 7 y: "), "{err}");
}

/// The printed command quotes a trace's labels as shell words: an
/// apostrophe in a recorded `--set` stays one word, and a crafted label
/// (a `;`, a newline, a terminal escape) is shown quoted and escaped,
/// never written raw.
#[test]
fn the_printed_command_quotes_the_traces_labels() {
    let dir = tempfile::tempdir().unwrap();
    let coarse = record(
        dir.path(),
        "coarse.json",
        &["--steps", "300", "--every", "100"],
    );
    edit_with_checksum(&coarse, |body| {
        body["config"] = "x.toml; touch PWNED #\n\u{1b}[31m".into();
        body["overrides"] = serde_json::json!(["run.output=\"it's\""]);
    });
    let (code, err) = check(&coarse, Some("290:7:y"));
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains(
            r#"mbs digest 'x.toml; touch PWNED #\n\u{1b}[31m' --set 'run.output="it'\''s"' --steps"#
        ),
        "{err}"
    );
    assert!(!err.contains('\u{1b}'), "{err}");
}

#[test]
fn a_nudge_that_cannot_apply_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let trace = record(dir.path(), "t.json", &["--steps", "20", "--every", "10"]);
    for (nudge, why) in [
        ("5:100000:x", "nudge grain = 100000"),
        ("5:1:mass", "field \"mass\""),
        ("5:1:x:0", "ULPS 0 changes nothing"),
    ] {
        let (code, err) = check(&trace, Some(nudge));
        assert_eq!(code, Some(2), "{nudge}: {err}");
        assert!(err.contains(why), "{nudge}: {err}");
    }
}

/// A trace's states are state from outside: a state moved to another
/// record (checksum recomputed) is refused, not trusted.
#[test]
fn a_trace_with_a_foreign_first_state_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let trace = record(
        dir.path(),
        "dense.json",
        &[
            "--steps", "100", "--every", "1", "--from", "150", "--until", "155", "--states",
        ],
    );
    edit_with_checksum(&trace, |body| {
        body["records"][0]["state"] = body["records"][1]["state"].clone();
    });
    let (code, err) = check(&trace, None);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("first record's state"), "{err}");
    edit_with_checksum(&trace, |body| {
        body["records"][0]["state"] = "not base64!".into()
    });
    let (code, err) = check(&trace, None);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("not base64"), "{err}");
}

/// Issue 42, class 3: a trace carries its configuration as text and
/// `--check` runs that text: the file it was recorded from may change or
/// vanish, an edited configuration names no file that would be read, and
/// every bound the recording command enforces is enforced again.
#[test]
fn a_trace_is_data_not_a_pointer() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = crate::common::write(dir.path(), "case.toml", "[bed]\ncolumns = 5\n");
    let file = dir.path().join("t.json");
    mbs()
        .args(["digest", "--steps", "100", "--every", "50", "--trace"])
        .arg(&file)
        .arg(&cfg)
        .assert()
        .success();
    // The file it was recorded from: edited, then gone.
    std::fs::write(&cfg, "[grains]\nspecific_gravity = 2.0\n").unwrap();
    assert_eq!(check(&file, None).0, Some(0));
    std::fs::remove_file(&cfg).unwrap();
    assert_eq!(check(&file, None).0, Some(0));
    // A configuration naming a file to read (checksum recomputed): the
    // file is never opened, its text never printed.
    let secret = crate::common::write(dir.path(), "secret.txt", "TOP-SECRET\n");
    let pointed = dir.path().join("pointed.json");
    std::fs::copy(&file, &pointed).unwrap();
    edit_with_checksum(&pointed, |body| {
        body["config"] = secret.to_str().unwrap().into();
        let text = body["configuration"].as_str().unwrap().to_string();
        let line = format!(
            "[run]\nmeasured_profiles = {:?}\n",
            secret.to_str().unwrap()
        );
        assert!(text.contains("[run]\n"), "{text}");
        body["configuration"] = text.replace("[run]\n", &line).into();
    });
    let (code, err) = check(&pointed, None);
    assert!(!err.contains("TOP-SECRET"), "{err}");
    assert_eq!(code, Some(0), "only drawn, never read: {err}");
    // Bounds of the recording command, enforced again.
    for (field, value, why) in [
        (
            "flow_steps",
            serde_json::json!(1_000_000_000_000u64),
            "--flow-steps",
        ),
        ("settle_steps", serde_json::json!(u64::MAX), "--steps"),
        ("tau_star", serde_json::json!(9.0), "--tau"),
        ("from", serde_json::json!(10_000), "--from"),
        ("every", serde_json::json!(0), "every = 0"),
    ] {
        let edited = dir.path().join(format!("{field}.json"));
        std::fs::copy(&file, &edited).unwrap();
        edit_with_checksum(&edited, |body| body[field] = value.clone());
        let (code, err) = check(&edited, None);
        assert_eq!(code, Some(2), "{field}: {err}");
        assert!(err.contains(why), "{field}: {err}");
    }
    // A configuration out of range inside the trace is named as such.
    let bad = dir.path().join("bad.json");
    std::fs::copy(&file, &bad).unwrap();
    edit_with_checksum(&bad, |body| {
        let text = body["configuration"].as_str().unwrap().to_string();
        body["configuration"] = text.replace("kappa = 0.4", "kappa = 1e308").into();
    });
    let (code, err) = check(&bad, None);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("its configuration: flow.kappa = 1e308"),
        "{err}"
    );
}

/// Issue 42, class 6: a nudge after the trace's last record, a trace
/// starting past the run's end, are named errors (exit 2).
#[test]
fn nudges_and_starts_past_the_end_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let file = trace_in(dir.path());
    let (code, err) = check(&file, Some("401:3:x"));
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains(
            "--nudge = 401:3:x:1: must be a STEP at most the trace's last record, step 400"
        ),
        "{err}"
    );
    assert_eq!(
        check(&file, Some("400:3:x")).0,
        Some(1),
        "the last record still counts"
    );
    let past = dir.path().join("past.json");
    mbs()
        .args([
            "digest", "--steps", "100", "--every", "10", "--from", "500", "--trace",
        ])
        .arg(&past)
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "--from = 500: must be <= the run's last step, 200",
        ));
    assert!(!past.exists());
    mbs()
        .args(["digest", "--steps", "1000000000000"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "--steps = 1000000000000: must be <= 1e11",
        ));
    mbs()
        .args([
            "digest",
            "--steps",
            "10",
            "--flow-steps",
            "18446744073709551615",
            "--trace",
        ])
        .arg(dir.path().join("huge.json"))
        .assert()
        .code(2)
        .stderr(predicates::str::contains("--flow-steps"));
}
