//! Never lose work: a run stopped at any step (within settling, spin-up or
//! the averaging window) or killed with SIGKILL at random moments, then
//! resumed, writes the same `transport.csv`, byte for byte, as a run never
//! stopped; damaged checkpoints are refused and change nothing.

use crate::common::*;
use predicates::prelude::*;
use std::path::{Path, PathBuf};

fn setup_with(text: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("small.toml");
    std::fs::write(&cfg, text).unwrap();
    (dir, cfg)
}

fn setup() -> (tempfile::TempDir, PathBuf) {
    setup_with(SMALL)
}

fn uninterrupted(cfg: &Path, out: &Path) -> Vec<u8> {
    run_into(cfg, out).assert().success();
    std::fs::read(out.join("transport.csv")).unwrap()
}

#[test]
fn stopped_anywhere_and_resumed_gives_the_same_table() {
    let (dir, cfg) = setup();
    let reference = uninterrupted(&cfg, &dir.path().join("reference"));
    // Every bed and cell stops after the given steps of its own (at the
    // next multiple of 2 000): beds settle for 20 000 steps, cells spin up
    // for 8 000 and average over 20 000. Stop points: in settling; twice in
    // settling, then in spin-up; twice in the window. The last run resumes
    // the 2 beds or the 4 cells.
    for (k, (stops, resumed)) in [
        (vec![5_000u64], "\"beds_resumed\": 2"),
        (vec![7_000, 7_000, 5_000], "\"cells_resumed\": 4"),
        (vec![20_000, 5_000], "\"cells_resumed\": 4"),
    ]
    .iter()
    .enumerate()
    {
        let out = dir.path().join(format!("stopped{k}"));
        let mut first = true;
        for &n in stops {
            let mut c = mbs();
            if first {
                c.arg("run").arg(&cfg).arg("--out").arg(&out);
            } else {
                c.arg("run").arg("--resume").arg(&out);
            }
            c.args(["--stop-after-steps", &n.to_string()])
                .assert()
                .code(130)
                .stderr(predicates::str::contains("resume with `mbs run --resume"));
            first = false;
            assert!(
                !out.join("transport.csv").exists(),
                "no table before the end"
            );
        }
        resume_in(&out).assert().success();
        assert_eq!(
            std::fs::read(out.join("transport.csv")).unwrap(),
            reference,
            "stops {stops:?}"
        );
        let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
        assert!(summary.contains(resumed), "{summary}");
    }
}

#[test]
fn killed_at_random_moments_and_resumed_gives_the_same_table() {
    // Forty times longer windows, and kills at 5–45 % of an uninterrupted
    // run's wall time: a run lasts long enough to be killed whatever the
    // build's speed.
    let (dir, cfg) = setup_with(&SMALL.replace(
        "window = 0.05\nwindow_min = 0.05",
        "window = 2.0\nwindow_min = 2.0",
    ));
    let (reference, wall) = timed(|| uninterrupted(&cfg, &dir.path().join("reference")));
    let out = dir.path().join("killed");
    let bin = assert_cmd::cargo::cargo_bin("mbs");
    let mut kills = 0;
    let delays = random_fractions(12345).map(|f| wall.mul_f64(0.05 + 0.4 * f));
    for (round, delay) in delays.take(6).enumerate() {
        let mut c = std::process::Command::new(&bin);
        c.arg("--quiet");
        if round == 0 {
            c.arg("run").arg(&cfg).arg("--out").arg(&out);
        } else {
            c.arg("run").arg("--resume").arg(&out);
        }
        c.args(["--checkpoint-every", "0.01"]);
        kills += usize::from(kill_after(&mut c, delay));
        // Whatever is on disk is whole: every checkpoint decodes or is absent,
        // no temporary files are left next to outputs that matter.
        for entry in std::fs::read_dir(out.join("checkpoints")).unwrap() {
            let path = entry.unwrap().path();
            if path
                .file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with(".mbs-tmp.")
            {
                continue; // killed while writing: removed by the next run
            }
            let bytes = std::fs::read(&path).unwrap();
            assert!(
                [b"MBSC", b"MBSB"].contains(&&bytes[..4].try_into().unwrap()),
                "{}",
                path.display()
            );
        }
    }
    resume_in(&out).assert().success();
    assert_eq!(std::fs::read(out.join("transport.csv")).unwrap(), reference);
    for d in [out.clone(), out.join("checkpoints")] {
        for entry in std::fs::read_dir(&d).unwrap() {
            let name = entry.unwrap().file_name().to_string_lossy().to_string();
            assert!(!name.starts_with(".mbs-tmp."), "leftover {name}");
        }
    }
    assert!(kills >= 2, "the test killed the run {kills} times");
}

#[test]
fn a_damaged_checkpoint_is_refused_and_kept() {
    let (dir, cfg) = setup();
    // A settling bed's checkpoint, damaged, is refused and kept.
    let settling = dir.path().join("settling");
    run_into(&cfg, &settling)
        .args(["--stop-after-steps", "3000"])
        .assert()
        .code(130);
    let bed = std::fs::read_dir(settling.join("checkpoints"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.file_name().unwrap().to_string_lossy().starts_with("bed_"))
        .unwrap();
    let mut bytes = std::fs::read(&bed).unwrap();
    bytes[40] ^= 0xff;
    std::fs::write(&bed, &bytes).unwrap();
    resume_in(&settling)
        .assert()
        .code(1)
        .stderr(predicates::str::contains("checksum mismatch"));
    assert_eq!(std::fs::read(&bed).unwrap(), bytes, "kept as it was");
    // A running cell's.
    let out = dir.path().join("damaged");
    run_into(&cfg, &out)
        .args(["--stop-after-steps", "20000"])
        .assert()
        .code(130);
    let path = out.join("checkpoints/tau0.1_seed1.ckpt");
    let mut bytes = std::fs::read(&path).unwrap();
    let n = bytes.len();
    bytes[n / 2] ^= 0xff;
    std::fs::write(&path, &bytes).unwrap();
    resume_in(&out)
        .assert()
        .code(1)
        .stderr(predicates::str::contains("checksum mismatch"));
    assert_eq!(
        std::fs::read(&path).unwrap(),
        bytes,
        "the damaged file is left as it was"
    );
    // Another configuration into the same directory is refused, nothing changed.
    let other = dir.path().join("other.toml");
    std::fs::write(&other, SMALL.replace("seeds = [1, 2]", "seeds = [1, 3]")).unwrap();
    let started = std::fs::read(out.join("config.toml")).unwrap();
    run_into(&other, &out)
        .assert()
        .code(1)
        .stderr(predicates::str::contains(
            "holds an interrupted run of another configuration",
        ));
    assert_eq!(std::fs::read(out.join("config.toml")).unwrap(), started);
    std::fs::write(&path, &bytes[..100]).unwrap();
    resume_in(&out)
        .assert()
        .code(1)
        .stderr(predicates::str::contains("checkpoint refused"));
}

#[test]
fn ctrl_c_checkpoints_and_says_how_to_resume() {
    let (dir, cfg) = setup_with(&SMALL.replace(
        "window = 0.05\nwindow_min = 0.05",
        "window = 2.0\nwindow_min = 2.0",
    ));
    let (reference, wall) = timed(|| uninterrupted(&cfg, &dir.path().join("reference")));
    let out = dir.path().join("interrupted");
    let child = std::process::Command::new(assert_cmd::cargo::cargo_bin("mbs"))
        .args(["--quiet", "run"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // A third of the way through: every cell is running.
    std::thread::sleep(wall / 3);
    let status = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("resume with `mbs run --resume"), "{stderr}");
    assert!(std::fs::read_dir(out.join("checkpoints")).unwrap().count() > 0);
    resume_in(&out).assert().success();
    assert_eq!(std::fs::read(out.join("transport.csv")).unwrap(), reference);
}

#[test]
fn grains_leaving_the_domain_are_a_named_error_not_nan() {
    // Unsoftened, elastic, frictionless contacts (β = 1, α_cn = 0, μ = 0)
    // at τ* = 5 throw a grain out of a 3.7 mm deep flow and beyond the
    // domain's top, as far above the surface as its bottom lies below.
    let text = SMALL
        .replace("tau_star = [0.1, 0.3]", "tau_star = [5.0]\ndepth = 0.0037")
        .replace(
            "[time]",
            "[contact]\nbeta = 1.0\nalpha_cn = 0.0\nfriction = 0.0\n[time]",
        );
    let (dir, cfg) = setup_with(&text);
    let out = dir.path().join("out");
    run_into(&cfg, &out).assert().code(1).stderr(
        predicates::str::contains("tau* = 5, seed 1: grain")
            .and(predicates::str::contains("left the domain at step")),
    );
    assert!(!out.join("transport.csv").exists(), "no table with NaN");
}

#[test]
fn an_unusable_output_directory_is_a_clear_error_and_earlier_results_stay() {
    let (dir, cfg) = setup();
    // A file where the output directory should be: nothing can be created in it.
    let blocked = dir.path().join("blocked");
    std::fs::write(&blocked, "earlier results\n").unwrap();
    // Refused before anything is written, as a bad argument (exit 2; was 1
    // with the operating system's "File exists").
    run_into(&cfg, &blocked)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("blocked: must be a directory"));
    assert_eq!(
        std::fs::read_to_string(&blocked).unwrap(),
        "earlier results\n"
    );
}

#[test]
fn a_full_disk_is_a_clear_error_and_earlier_results_stay() {
    let (dir, cfg) = setup();
    let out = dir.path().join("out");
    run_into(&cfg, &out).assert().success();
    let png = std::fs::read(out.join("transport.png")).unwrap();
    let store = std::fs::read(out.join("cells.jsonl")).unwrap();
    // A 16 KiB file-size limit with SIGXFSZ ignored: every write beyond it
    // fails with EFBIG, as a full disk fails with ENOSPC.
    let bin = assert_cmd::cargo::cargo_bin("mbs");
    let output = std::process::Command::new("bash")
        .arg("-c")
        .arg(r#"trap "" XFSZ; ulimit -f 16; exec "$0" --quiet run "$1" --out "$2""#)
        .arg(&bin)
        .arg(&cfg)
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("transport.png") && stderr.contains("too large"),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read(out.join("transport.png")).unwrap(),
        png,
        "earlier figure intact"
    );
    assert_eq!(
        std::fs::read(out.join("cells.jsonl")).unwrap(),
        store,
        "finished cells intact"
    );
}
