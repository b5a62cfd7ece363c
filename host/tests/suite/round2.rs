//! Issue 42, the second round of hostile input: inputs that ran forever
//! or grew without bound (class 2), values without a range and errors that
//! named the wrong thing (class 5), the tools' edge cases (class 6) and
//! the frictions a new user met (class 7). Classes 1 and 4 are in
//! `links.rs` and `run.rs`'s unit tests, class 3 in `trace.rs`.

use crate::common::{mbs, resume_in, run_into, write, SMALL};
use predicates::prelude::*;
use predicates::str::contains;

/// `mbs config --set …`: checked as `mbs run` checks it; stderr.
fn config_error(sets: &[&str]) -> String {
    let mut c = mbs();
    c.arg("config");
    for s in sets {
        c.args(["--set", s]);
    }
    let out = c.output().unwrap();
    assert_eq!(out.status.code(), Some(2), "{sets:?} was accepted");
    String::from_utf8(out.stderr).unwrap()
}

/// Class 2: measured profiles with values near ±1e308, a shift of 1.7e308,
/// `/dev/zero` as a profile, 1e9 frames: refused before anything runs.
#[test]
fn inputs_that_ran_forever_are_refused_before_running() {
    let dir = tempfile::tempdir().unwrap();
    let header = "z_over_d,solid_fraction,particle_velocity_m_s\n";
    for (rows, why) in [
        (
            "1e308,0.5,0.1\n2,0.4,0.2\n",
            "line 2: z_over_d = 1e308: must be in [-1000, 1000]",
        ),
        (
            "1,0.5,-1e308\n2,0.4,0.2\n",
            "line 2: particle_velocity_m_s = -1e308: must be in [-100, 100] m/s",
        ),
        (
            "1,5,0.1\n2,0.4,0.2\n",
            "line 2: solid_fraction = 5: must be in [0, 1]",
        ),
        (
            "1,0.5,0.1\n2,-3,0.2\n",
            "line 3: solid_fraction = -3: must be in [0, 1]",
        ),
    ] {
        let profile = write(dir.path(), "p.csv", &format!("{header}{rows}"));
        let set = format!("run.measured_profiles={:?}", profile.to_str().unwrap());
        let err = config_error(&[&set]);
        assert!(err.contains(why), "{rows}: {err}");
    }
    let err = config_error(&["run.measured_shift_d=1.7e308"]);
    assert!(
        err.contains("run.measured_shift_d = 1.7e308: must be in [-1000, 1000]"),
        "{err}"
    );
    let started = std::time::Instant::now();
    let err = config_error(&["run.measured_profiles=\"/dev/zero\""]);
    assert!(err.contains("refused unread"), "{err}");
    assert!(started.elapsed().as_secs() < 30, "read without a bound");
    mbs()
        .args(["snapshot", "--frames", "1000000000", "--out"])
        .arg(dir.path().join("snap"))
        .assert()
        .code(2)
        .stderr(contains("--frames = 1000000000: must be in [1, 10000]"));
    assert!(!dir.path().join("snap").exists(), "nothing written");
}

/// Class 5: every numeric key has a range; messages name the key as
/// given (a `--set`, a file's line), the value and why.
#[test]
fn every_key_has_a_range_and_errors_name_where_it_was_given() {
    for (set, why) in [
        (
            "flow.kappa=1e308",
            "flow.kappa = 1e308: must be in [0.1, 1] (von Karman",
        ),
        (
            "flow.drag_coefficient=1e308",
            "flow.drag_coefficient = 1e308: must be in [0, 100]",
        ),
        (
            "flow.added_mass=1e308",
            "flow.added_mass = 1e308: must be in [0, 10]",
        ),
        (
            "flow.roughness_d=1e-300",
            "flow.roughness_d = 1e-300: must be in [0.01, 100]",
        ),
        (
            "contact.alpha_m=1e-300",
            "contact.alpha_m = 1e-300: must be in [0.01, 10000]",
        ),
        (
            "contact.friction=1e308",
            "contact.friction = 1e308: must be in [0, 10]",
        ),
        (
            "run.skin_d=1e-300",
            "run.skin_d = 1e-300: must be in [0.01, 1]",
        ),
        (
            "flow.hold_steps=4294967295",
            "flow.hold_steps = 4294967295: must be >= 1",
        ),
    ] {
        let err = config_error(&[set]);
        assert!(err.contains(why), "{set}: {err}");
        assert!(
            err.contains(&format!("(given by --set {set})")),
            "{set}: {err}"
        );
    }
    for (set, why) in [
        (
            "fluid.cell_d=1e-300",
            "fluid.cell_d = 1e-300: must be in [0.01, 10]",
        ),
        (
            "fluid.phi_max=1e-300",
            "fluid.phi_max = 1e-300: must be in [0.1, 1)",
        ),
        (
            "bed.slope_rad=0.45",
            "bed.slope_rad = 0.45: must be <= 1.3750e-2 rad with flow.depth = 0.3 m",
        ),
    ] {
        let err = config_error(&[set, "flow.model=coupled", "flow.depth=0.3"]);
        assert!(err.contains(why), "{set}: {err}");
    }
    // One key a --set; a second key in it, or a bad value, is the --set's error.
    let err = config_error(&["bed.columns=6\nrows=99"]);
    assert!(
        err.contains("--set bed.columns=6\\nrows=99: holds a line break"),
        "{err}"
    );
    for (set, why) in [
        (
            "flow.tau_star=[0.1,",
            "--set flow.tau_star=[0.1,: [0.1, is not a TOML value",
        ),
        (
            "flow.eps0=1e400",
            "--set flow.eps0=1e400: 1e400 is not a TOML value",
        ),
        (
            "flow.kappa=abc",
            "--set flow.kappa=abc: invalid type: string \"abc\", expected f64",
        ),
    ] {
        let err = config_error(&[set]);
        assert!(
            err.contains(why) && !err.contains("line 29"),
            "{set}: {err}"
        );
    }
    // Long numbers are quoted short (docs/guarantees.md: 24 characters).
    let err = config_error(&["flow.hold_steps=1e-320"]);
    assert!(err.contains("`1e-320`") && err.len() < 200, "{err}");
    // A file's value is named with its line.
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(
        dir.path(),
        "case.toml",
        "# a case\n[flow]\nkappa = 0.4\n\n[run]\nskin_d = 7\n",
    );
    mbs()
        .arg("config")
        .arg(&cfg)
        .assert()
        .code(2)
        .stderr(contains(format!(
            "run.skin_d = 7: must be in [0.01, 1] largest diameters (a thinner skin rebuilds \
             the neighbour lists nearly every step) (given by {} line 6)",
            cfg.display()
        )));
}

/// Class 6: `merge --out FILE` and `validation/compare.py` on bad input
/// are named errors, exit 2.
#[test]
fn tool_edge_cases_are_named_errors() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "a-file", "x");
    mbs()
        .args(["merge"])
        .arg(dir.path())
        .arg("--out")
        .arg(&file)
        .assert()
        .code(2)
        .stderr(contains("--out = ").and(contains("must be a directory")));
    mbs()
        .args(["merge"])
        .arg(&file)
        .arg("--out")
        .arg(dir.path().join("merged"))
        .assert()
        .code(2)
        .stderr(contains("this is not a directory"));
    let python = std::process::Command::new("python3")
        .arg("--version")
        .output();
    if python.is_err() {
        // CI installs python3: there a missing one is a failure, not a skip.
        assert!(std::env::var_os("CI").is_none(), "python3 absent in CI");
        eprintln!("python3 absent: compare.py not tried");
        return;
    }
    let compare = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../validation/compare.py");
    let run = dir.path().join("run");
    std::fs::create_dir(&run).unwrap();
    let profile = "tau_star,y_over_d,solid_fraction,grain_velocity_m_s,fluid_velocity_m_s\n";
    write(
        &run,
        "profiles.csv",
        &format!("{profile}0.1,0.5,0.6,0,0\n0.1,1.5,0.6,0,0\n0.1,2.5,0,0,0.3\n"),
    );
    write(&run, "transport.csv", "q_star,q_star_stderr\n0.1,0.01\n");
    let measured = "z_over_d,solid_fraction,particle_velocity_m_s\n";
    for (name, text) in [
        ("empty.csv", String::new()),
        ("one-row.csv", format!("{measured}1,0.5,0.1\n")),
        ("flat.csv", format!("{measured}1,0.5,0.1\n1,0.4,0.2\n")),
        ("still.csv", format!("{measured}1,0.5,0\n2,0.4,0\n3,0,0\n")),
        ("garbage.csv", format!("{measured}1,x,0\n2,0.4,0\n")),
        ("phi.csv", format!("{measured}1,5,0.1\n2,0.4,0.2\n")),
        ("binary.csv", "\u{0}\u{1}\u{2}".into()),
    ] {
        let path = write(dir.path(), name, &text);
        let out = std::process::Command::new("python3")
            .arg(&compare)
            .arg(&path)
            .arg(&run)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name}: {err}");
        assert!(
            err.starts_with("error: ") && !err.contains("Traceback"),
            "{name}: {err}"
        );
    }
    // A good profile against a run of one τ* (one row in transport.csv, as
    // every shipped validation configuration writes) is compared.
    let good = write(
        dir.path(),
        "good.csv",
        &format!("{measured}0.5,0.6,0\n1.5,0.3,0.1\n2.5,0.01,0.2\n"),
    );
    let out = std::process::Command::new("python3")
        .arg(&compare)
        .arg(&good)
        .arg(&run)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("run transport.csv 0.100 +- 0.010"), "{text}");
}

/// Class 7: a `--set` of a section's alternative key replaces the
/// default's, a single τ* is a list of one, the lock file says what it
/// is, a resumed run claims only its own grain-steps, a τ* given as u* is
/// printed short.
#[test]
fn frictions_a_new_user_met() {
    mbs()
        .args([
            "config",
            "--set",
            "grains.classes=[{diameter_mm = 0.5, fraction = 1.0}]",
        ])
        .assert()
        .success()
        .stdout(contains("diameter_mm = 0.5"));
    mbs()
        .args(["config", "--set", "flow.tau_star=0.1"])
        .assert()
        .success()
        .stdout(contains("tau_star = [0.1]"));
    mbs()
        .args(["config", "--set", "flow.u_star_m_s=0.02"])
        .assert()
        .success();
    mbs()
        .args(["digest", "--set", "flow.tau_star=0.1", "--check", "t.json"])
        .assert()
        .code(2)
        .stderr(contains("must be absent with --check"));
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(
        dir.path(),
        "small.toml",
        &SMALL.replace("tau_star = [0.1, 0.3]", "u_star_m_s = [0.0213]"),
    );
    let whole = dir.path().join("whole");
    let printed = assert_cmd::Command::cargo_bin("mbs")
        .unwrap()
        .arg("run")
        .arg(&cfg)
        .arg("--out")
        .arg(&whole)
        .output()
        .unwrap();
    let stdout = String::from_utf8(printed.stdout).unwrap();
    // τ* of u* = 0.0213 m/s: u*²/((s − 1) g d) = 0.0213²/(1.65 × 9.81 × 5e-4).
    let tau = 0.0213f64.powi(2) / (1.65 * 9.81 * 5e-4);
    assert_eq!(format!("{tau:.5}"), "0.05606");
    assert!(stdout.contains("\n0.05606   "), "{stdout}");
    let lock = std::fs::read_to_string(whole.join(".mbs-lock")).unwrap();
    assert!(
        lock.contains("advisory lock") && lock.contains("delete it freely"),
        "{lock}"
    );
    let computed = |dir: &std::path::Path| -> f64 {
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap())
                .unwrap();
        s["grain_steps_computed"].as_f64().unwrap()
    };
    let stopped = dir.path().join("stopped");
    run_into(&cfg, &stopped)
        .args(["--stop-after-steps", "20000"])
        .assert()
        .code(130);
    resume_in(&stopped).assert().success();
    let (all, rest) = (computed(&whole), computed(&stopped));
    assert!(
        rest < 0.8 * all,
        "a resumed run claims {rest} of {all} grain-steps"
    );
}
