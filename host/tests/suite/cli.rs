//! The `mbs` command end to end on small configurations: every subcommand,
//! its files, thread-count independence, and bad input (exit status 2, a
//! message naming key, value and range, nothing written).

use crate::common::*;
use predicates::prelude::*;
use std::path::Path;

#[test]
fn config_prints_the_embedded_default() {
    let out = mbs()
        .arg("config")
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    assert_eq!(
        mbs::Config::from_toml(&text).unwrap(),
        mbs::Config::load(None).unwrap()
    );
    assert!(text.contains("beta = 15.8") && text.contains("# "));
}

#[test]
fn every_shipped_configuration_loads_and_validates() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            if let Err(e) = mbs::Config::load(Some(&path)) {
                panic!("{}: {e}", path.display());
            }
            checked += 1;
        }
    }
    assert!(checked >= 2, "configs/ holds the example configurations");
}

/// The validation configurations (validation/*/*.toml) load as shipped,
/// their measured profiles read from the repository's root, where the
/// README runs them.
#[test]
fn every_validation_configuration_loads_and_validates() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut checked = 0;
    for case in std::fs::read_dir(root.join("validation")).unwrap() {
        let case = case.unwrap().path();
        if !case.is_dir() {
            continue;
        }
        for entry in std::fs::read_dir(&case).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                let text = std::fs::read_to_string(&path).unwrap();
                let from_root = format!("measured_profiles = \"{}/validation/", root.display());
                let text = text.replace("measured_profiles = \"validation/", &from_root);
                if let Err(e) = mbs::Config::from_toml(&text) {
                    panic!("{}: {e}", path.display());
                }
                checked += 1;
            }
        }
    }
    assert!(checked >= 4, "Frey's three experiments and r2d6s2");
}

#[test]
fn run_writes_table_plots_and_summary() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    run_into(&cfg, &out).assert().success();
    let csv = std::fs::read_to_string(out.join("transport.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(
        lines[0],
        "tau_star,q_star,q_star_stderr,q_star_ci95,seeds,mpm,wong_parker,u_star_m_s,q_b_m2_s,q_b_stderr_m2_s,window_s,discarded_s,unsteady,capped"
    );
    assert_eq!(lines.len(), 3);
    let row: Vec<f64> = lines[2].split(',').map(|v| v.parse().unwrap()).collect();
    assert_eq!(row[0], 0.3);
    assert!(row[1].is_finite() && row[2] >= 0.0 && row[3] >= row[2] && row[4] == 2.0);
    assert!((row[5] - 8.0 * (0.3f64 - 0.047).powf(1.5)).abs() < 1e-12);
    for f in ["transport.png", "transport.svg", "summary.json"] {
        assert!(out.join(f).metadata().unwrap().len() > 100, "{f}");
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(summary["config"]["bed"]["rows"], 4);
    assert!(summary["derived"]["k_n"].as_f64().unwrap() > 0.0);
    // SMALL gives no grain size: the echo leaves it out, the derived
    // values name the paper's.
    assert!(summary["config"]["grains"]["diameter_mm"].is_null());
    assert_eq!(summary["derived"]["diameter_mm"], 0.5);
    assert!(summary["grain_steps_per_s"].as_f64().unwrap() > 0.0);
    // The time series: SMALL's fixed windows of ten blocks, whose means
    // average to each cell's q*, drawn in a panel per τ*.
    let series = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
    let lines: Vec<Vec<&str>> = series
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert!(series.starts_with("tau_star,seed,block,t_s,q_star,bed_level_m,part\n"));
    assert_eq!(lines.len(), 4 * 10);
    for cell in summary["cells"].as_array().unwrap() {
        let (tau, seed) = (
            cell["tau_star"].as_f64().unwrap(),
            cell["seed"].as_u64().unwrap(),
        );
        let q: Vec<f64> = lines
            .iter()
            .filter(|l| l[0].parse::<f64>().unwrap() == tau && l[1].parse::<u64>().unwrap() == seed)
            .filter(|l| l[6] == "steady")
            .map(|l| l[4].parse().unwrap())
            .collect();
        // The steady blocks average to the cell's q*; the others are its
        // discarded transient.
        let discarded = cell["discarded"].as_u64().unwrap() as usize;
        assert_eq!(q.len(), 10 - discarded);
        let mean = q.iter().sum::<f64>() / q.len() as f64;
        let expected = cell["q_star"].as_f64().unwrap();
        assert!(
            (mean - expected).abs() <= 1e-12 * expected.abs().max(1e-9),
            "{mean} {expected}"
        );
    }
    // The last block ends 0.02 s (spin-up) + 10 × 0.005 s after the flow started.
    assert!(
        (lines[9][3].parse::<f64>().unwrap() - 0.07).abs() < 1e-12,
        "{:?}",
        lines[9]
    );
    let texts =
        mbs::figures::svg_texts(&std::fs::read_to_string(out.join("timeseries.svg")).unwrap());
    for title in [
        "τ* = 0.1: q* per 0.005 s block after a spin-up of 0.02 s",
        "τ* = 0.3: q* per 0.005 s block after a spin-up of 0.02 s",
    ] {
        assert!(texts.iter().any(|t| t == title), "{title} in {texts:?}");
    }
    let leftovers: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with(".mbs-tmp."))
        .collect();
    assert!(leftovers.is_empty(), "no temporary files left");
}

#[test]
fn transport_table_does_not_depend_on_threads() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let mut tables = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.path().join(format!("t{threads}"));
        run_on_threads(&cfg, &out, threads).assert().success();
        tables.push(std::fs::read(out.join("transport.csv")).unwrap());
    }
    assert_eq!(tables[0], tables[1]);
}

#[test]
fn mixed_beds_get_columns_per_size_class() {
    let dir = tempfile::tempdir().unwrap();
    let text = SMALL.replace(
        "[bed]",
        "[grains]\nclasses = [{ diameter_mm = 1.0, fraction = 0.5 }, { diameter_mm = 0.7, fraction = 0.5 }]\n[bed]",
    ) + "[contact]\nbeta = 4.0\n";
    let text = text.replace("[time]", "[time]\nsubsteps = 8");
    let cfg = write(dir.path(), "mixed.toml", &text);
    let out = dir.path().join("out");
    run_into(&cfg, &out).assert().success();
    let csv = std::fs::read_to_string(out.join("transport.csv")).unwrap();
    assert!(
        csv.starts_with("tau_star,q_star,q_star_stderr,q_star_ci95,seeds,mpm,wong_parker,u_star_m_s,q_b_m2_s,q_b_stderr_m2_s,window_s,discarded_s,unsteady,capped,q_star_1mm,q_star_1mm_stderr,q_star_0.7mm,q_star_0.7mm_stderr\n"),
        "{csv}"
    );
    // The classes are on the total's scale (d_max): they add up to q*.
    for line in csv.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let (total, classes) = (v[1], v[14] + v[16]);
        // Units on the largest diameter (1 mm, s = 2.65, g = 9.81):
        // u* = √(τ* (s − 1) g d), q_B = q* √((s − 1) g d³), its error alike.
        let (g_prime, d) = (1.65 * 9.81, 1e-3);
        assert!(
            (v[7] - (v[0] * g_prime * d).sqrt()).abs() < 1e-15,
            "u*: {line}"
        );
        let scale = (g_prime * d * d * d).sqrt();
        assert!(
            (v[8] - total * scale).abs() <= 1e-15 * scale.max(total.abs() * scale),
            "q_B: {line}"
        );
        assert!(
            (v[9] - v[2] * scale).abs() <= 1e-15 * scale,
            "q_B stderr: {line}"
        );
        assert!(
            (total - classes).abs() <= 1e-12 * total.abs().max(1e-9),
            "q* {total} is not the sum of its classes {classes}: {line}"
        );
    }
}

#[test]
fn pack_writes_the_settling_curve() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    mbs()
        .arg("pack")
        .arg(&cfg)
        .arg("--out")
        .arg(dir.path())
        .assert()
        .success();
    let csv = std::fs::read_to_string(dir.path().join("packing.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("time,y_gc,kinetic_energy,max_overlap,contacts,max_speed")
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    // 0.05 s sampled every 10 constants_dt (= 2e-4 s): 250 samples after t = 0.
    assert_eq!(rows.len(), 251);
    let (first, last) = (&rows[0], &rows[rows.len() - 1]);
    assert!(
        last[1] < first[1],
        "the bed packs down: y_gc {} -> {}",
        first[1],
        last[1]
    );
    assert!(last[4] > 0.0, "grains in contact");
    assert!(dir.path().join("packing.png").exists() && dir.path().join("packing.svg").exists());
}

#[test]
fn snapshot_writes_pictures_and_particle_frames() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    mbs()
        .arg("snapshot")
        .arg(&cfg)
        .args(["--frames", "3", "--every", "0.005", "--out"])
        .arg(dir.path())
        .assert()
        .success();
    let vtu = std::fs::read_to_string(dir.path().join("snapshot/bed_0003.vtu")).unwrap();
    assert!(vtu.starts_with("<?xml") && vtu.contains("<VTKFile type=\"UnstructuredGrid\""));
    assert!(vtu.contains("NumberOfPoints=\"25\"") && vtu.contains("Name=\"velocity\""));
    let series = std::fs::read_to_string(dir.path().join("snapshot/bed.pvd")).unwrap();
    assert_eq!(series.matches("bed_00").count(), 4);
    assert!(dir.path().join("snapshot.png").exists() && dir.path().join("snapshot.svg").exists());
}

#[test]
fn digest_matches_the_golden_file() {
    // The paper's run, and the coupled one (`Scenario::paper_coupled`) in
    // the host's column capacity of 2048 cells: the digest covers the used
    // cells only, as the golden test's and the boards' capacity of 100.
    for (file, sets) in [
        ("digests.txt", &[][..]),
        (
            "coupled.txt",
            &["--set", "flow.model=coupled", "--set", "fluid.cell_d=4"][..],
        ),
    ] {
        let golden = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../tests/golden")
                .join(file),
        )
        .unwrap();
        for p in ["f32", "f64"] {
            let out = mbs()
                .args(["digest", "--steps", "2000", "--precision", p])
                .args(sets)
                .assert()
                .success()
                .get_output()
                .stdout
                .clone();
            let text = String::from_utf8(out).unwrap();
            // The printed lines name the phases as the golden file does.
            let phases: Vec<&str> = text.lines().map(|l| l.split(' ').next().unwrap()).collect();
            assert_eq!(phases, ["settling", "flow"]);
            for line in text.lines() {
                let (phase, hex) = line.split_once(' ').unwrap();
                assert!(
                    golden.contains(&format!("{phase} {p} {hex}")),
                    "{file}: {line}"
                );
            }
        }
    }
}

#[test]
fn bench_runs_every_case_and_keeps_prepared_beds() {
    let beds = tempfile::tempdir().unwrap();
    for case in ["still", "flow", "rebuild", "rebuild-flow", "contacts"] {
        mbs()
            .args(["bench", "--grains", "64", "--steps", "50", "--case", case])
            .arg("--beds")
            .arg(beds.path())
            .assert()
            .success()
            .stdout(
                predicate::str::contains("ns per grain-step")
                    .and(predicate::str::contains("66 grains"))
                    .and(predicate::str::contains("(5 rounds: min "))
                    .and(predicate::str::contains(", median "))
                    .and(predicate::str::contains(format!(", {case}: "))),
            );
    }
    let kept = std::fs::read_dir(beds.path()).unwrap().count();
    assert_eq!(kept, 2, "one settled and one flowing bed, reused");
}

#[test]
fn bad_configurations_are_named_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("transport.csv"), "earlier results\n").unwrap();
    let cases = [
        ("[grains]\ndiameter = 0.5\n", "unknown field `diameter`"),
        (
            "[grains]\ndiameter_mm = -0.5\n",
            "grains.diameter_mm = -0.5: must be > 0",
        ),
        (
            "[contact]\nalpha_m = 2.0\nbeta = 1.0\n[time]\nsubsteps = 1\n",
            "step_dt = 2e-5 s: must be <= 1.8",
        ),
        (
            "[bed]\ncolumns = 40\n[run]\ncapacity = 256\n",
            "run.capacity = 256: must be >= the bed's 440 grains",
        ),
        (
            "[flow]\ntau_star = []\n",
            "flow.tau_star = []: must be a list of 1 to 1000 values",
        ),
        ("[run]\nprecision = \"f16\"\n", "unknown variant `f16`"),
    ];
    for (k, (text, message)) in cases.iter().enumerate() {
        let cfg = write(dir.path(), &format!("bad{k}.toml"), text);
        for cmd in ["run", "pack", "snapshot", "digest"] {
            let mut c = mbs();
            c.arg(cmd).arg(&cfg);
            if cmd != "digest" {
                c.arg("--out").arg(&out);
            }
            c.assert()
                .code(2)
                .stderr(predicate::str::contains(*message));
        }
    }
    let names: Vec<_> = std::fs::read_dir(&out).unwrap().collect();
    assert_eq!(names.len(), 1, "nothing written");
    assert_eq!(
        std::fs::read_to_string(out.join("transport.csv")).unwrap(),
        "earlier results\n"
    );
    mbs()
        .arg("run")
        .arg(dir.path().join("missing.toml"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("missing.toml"));
    mbs()
        .args(["snapshot", "--tau=-1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--tau = -1: must be in (0, 5]"));
}

#[test]
fn a_closed_stdout_is_not_a_crash() {
    let mut child = std::process::Command::new(assert_cmd::cargo::cargo_bin("mbs"))
        .arg("config")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
}

/// `--set SECTION.KEY=VALUE` overrides the configuration: the run uses it,
/// `DIR/config.toml` saves it, and a bad override is named like the same
/// line in a file would be (exit 2, nothing written).
#[test]
fn set_overrides_the_configuration_and_is_checked_like_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    run_into(&cfg, &out)
        .args(["--set", "flow.tau_star=[0.2]", "--set", "run.seeds = [3]"])
        .assert()
        .success();
    let csv = std::fs::read_to_string(out.join("transport.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 1, "{csv}");
    assert!(rows[0].starts_with("0.2,"), "{csv}");
    let saved = mbs::Config::load(Some(&out.join("config.toml"))).unwrap();
    assert_eq!((saved.tau_stars, saved.seeds), (vec![0.2], vec![3]));
    // Resuming keeps the configuration it started with.
    resume_in(&out)
        .args(["--set", "flow.tau_star=[0.3]"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("not with --resume"));
    for (set, why) in [
        ("bed.columns=2", "bed.columns = 2: must be in [3, 100000]"),
        ("flow.no_such_key=1", "unknown field `no_such_key`"),
        (
            "tau_star=0.2",
            "--set tau_star=0.2: must be SECTION.KEY=VALUE",
        ),
        ("run.precision=f16", "unknown variant `f16`"),
    ] {
        let bad = dir.path().join("bad");
        run_into(&cfg, &bad)
            .args(["--set", set])
            .assert()
            .code(2)
            .stderr(predicates::str::contains(why));
        assert!(!bad.exists(), "{set}: nothing written");
    }
}

/// A trace of a run with overrides keeps them, and its check applies them
/// again.
#[test]
fn a_trace_keeps_its_overrides() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("t.json");
    let digest = |extra: &[&str]| {
        let out = mbs()
            .args(["digest", "--steps", "100"])
            .args(extra)
            .output()
            .unwrap();
        assert!(out.status.success());
        String::from_utf8(out.stdout).unwrap()
    };
    let plain = digest(&[]);
    let lighter = digest(&[
        "--set",
        "grains.specific_gravity=2.5",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_ne!(plain, lighter, "the override changes the run");
    mbs()
        .args(["digest", "--check"])
        .arg(&trace)
        .assert()
        .success();
    mbs()
        .args(["digest", "--set", "grains.specific_gravity=2.4", "--check"])
        .arg(&trace)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("absent with --check"));
}

/// `mbs run --shard I/N` on N machines, `mbs merge`, and the same run into
/// the merged directory: `transport.csv` byte for byte as one unsharded run.
#[test]
fn a_sharded_run_merged_gives_the_same_table() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let whole = dir.path().join("whole");
    run_into(&cfg, &whole).assert().success();
    let mut shards = Vec::new();
    for i in 1..=3 {
        let out = dir.path().join(format!("shard{i}"));
        // --quiet (`run_into`): not even the shard's report.
        run_into(&cfg, &out)
            .args(["--shard", &format!("{i}/3")])
            .assert()
            .success()
            .stdout("");
        assert!(
            !out.join("transport.csv").exists(),
            "a shard writes no table"
        );
        shards.push(out);
    }
    let merged = dir.path().join("merged");
    mbs()
        .arg("merge")
        .args(&shards)
        .arg("--out")
        .arg(&merged)
        .assert()
        .success()
        .stdout("");
    // Every cell is stored: the run computes nothing (--stop-after-steps 0
    // would stop any cell that ran) and writes the table.
    run_into(&cfg, &merged)
        .args(["--stop-after-steps", "0"])
        .assert()
        .success();
    assert_eq!(
        std::fs::read(merged.join("transport.csv")).unwrap(),
        std::fs::read(whole.join("transport.csv")).unwrap()
    );
    mbs()
        .args(["run", "--shard", "4/3"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("must be I/N with 1 <= I <= N"));
}

#[test]
fn windows_stop_at_the_target_or_say_they_did_not_reach_it() {
    let dir = tempfile::tempdir().unwrap();
    let table = |name: &str, target: &str| {
        let text = SMALL
            .replace("window = 0.05", "window = 0.1")
            .replace("window_min = 0.05", "window_min = 0.02")
            + target;
        let cfg = write(dir.path(), &format!("{name}.toml"), &text);
        let out = dir.path().join(name);
        let run = run_into(&cfg, &out).assert().success();
        let stderr = String::from_utf8_lossy(&run.get_output().stderr).to_string();
        let csv = std::fs::read_to_string(out.join("transport.csv")).unwrap();
        let rows: Vec<Vec<f64>> = csv
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect();
        (rows, stderr)
    };
    // Any error is good enough: a window stops as soon as its steady part
    // holds window_min (4 blocks) and ten correlation times (10 blocks or
    // more), before time.window (20 blocks); τ* = 0.1 on this unsettled bed
    // is still falling (a seed finds no steady part) and runs to the cap.
    let (rows, stderr) = table(
        "loose",
        "[target]\nstderr_relative = 1.0\nstderr_absolute = 1.0\n",
    );
    // Columns window_s, unsteady and capped.
    assert_eq!((rows[0][10], rows[0][12], rows[0][13]), (0.1, 1.0, 2.0));
    assert!(rows[1][10] >= 0.05 && rows[1][10] < 0.1, "{:?}", rows[1]);
    assert_eq!((rows[1][12], rows[1][13]), (0.0, 0.0));
    assert!(
        stderr.contains("not-steady: tau* = 0.1: in 1 of 2 seed(s)"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("target-not-reached: tau* = 0.3"),
        "{stderr}"
    );
    // None is: every window runs to time.window and says so.
    let (rows, stderr) = table(
        "none",
        "[target]\nstderr_relative = 0.0\nstderr_absolute = 0.0\n",
    );
    for r in &rows {
        assert_eq!((r[10], r[13]), (0.1, 2.0), "{r:?}");
    }
    assert!(
        stderr.contains("warning: target-not-reached: tau* = 0.1: 2 of 2 seed(s) averaged for the whole time.window = 0.1 s"),
        "{stderr}"
    );
}

#[test]
fn negative_numbers_get_the_range_error() {
    for args in [
        &["snapshot", "--tau", "-1"][..],
        &["digest", "--tau", "-1"],
        &["pack", "--duration", "-1"],
    ] {
        let key = args[1];
        mbs()
            .args(args)
            .assert()
            .code(2)
            .stderr(predicate::str::contains(format!("{key} = -1: must be")));
    }
}

#[test]
fn an_output_path_that_is_not_a_directory_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "file", "");
    for out in [Path::new("/dev/null"), file.as_path()] {
        for command in ["run", "pack", "snapshot", "calibrate"] {
            mbs()
                .arg(command)
                .arg("--out")
                .arg(out)
                .assert()
                .code(2)
                .stderr(predicate::str::contains(format!(
                    "--out = {}: must be a directory (it exists and is not one)",
                    out.display()
                )));
        }
    }
}

#[test]
fn threads_above_the_maximum_are_refused() {
    // (A missing configuration and `config`: fast failures if the check breaks.)
    for args in [&["run", "missing.toml"][..], &["config"]] {
        mbs()
            .args(args)
            .args(["--threads", "1025"])
            .assert()
            .code(2)
            .stderr(predicate::str::contains(
                "--threads = 1025: must be 0 (one per core) to 1024",
            ));
    }
}

#[test]
fn subcommands_offer_only_the_options_they_use() {
    let help = |command: &str| {
        let out = mbs().args([command, "--help"]).assert().success();
        String::from_utf8(out.get_output().stdout.clone()).unwrap()
    };
    let offered = |text: &str| ["--quiet", "--threads", "--set"].map(|o| text.contains(o));
    assert_eq!(offered(&help("config")), [false, false, true]);
    assert_eq!(offered(&help("merge")), [true, false, false]);
    assert_eq!(offered(&help("bench")), [true, true, false]);
    assert_eq!(offered(&help("digest")), [false, false, true]);
    assert_eq!(offered(&help("pack")), [true, false, true]);
    assert_eq!(offered(&help("snapshot")), [true, false, true]);
    assert_eq!(offered(&help("run")), [true; 3]);
    assert_eq!(offered(&help("calibrate")), [true; 3]);
    // Still accepted wherever they were, before or after the subcommand.
    for args in [
        &["--quiet", "--threads", "1", "config"][..],
        &["config", "--quiet", "--threads", "1"],
        &["digest", "--steps", "10", "--quiet", "--threads", "2"],
    ] {
        assert_cmd::Command::cargo_bin("mbs")
            .unwrap()
            .args(args)
            .assert()
            .success();
    }
}
