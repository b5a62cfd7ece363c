//! The coupled flow and the bed slope from the command (docs/model.md §13):
//! the profiles every run writes conserve the grains' volume exactly, a
//! coupled run gives the same bits on any thread count and after a stop,
//! and bad coupled or slope keys are named errors.

use crate::common::*;
use predicates::prelude::*;

/// [`SMALL`] under the coupled flow.
fn coupled() -> String {
    SMALL.replace("[flow]", "[flow]\nmodel = \"coupled\"")
}

/// The rows of `profiles.csv` as (τ*, y/d, φ, u_p, u_f), u_p `None` where
/// no grain ever was.
fn profiles(out: &std::path::Path) -> Vec<(f64, f64, f64, Option<f64>, f64)> {
    let text = std::fs::read_to_string(out.join("profiles.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("tau_star,y_over_d,solid_fraction,grain_velocity_m_s,fluid_velocity_m_s")
    );
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let n = |k: usize| f[k].parse::<f64>().unwrap();
            (n(0), n(1), n(2), f[3].parse().ok(), n(4))
        })
        .collect()
}

/// The slices of every grain add up to its volume (docs/model.md (C1)), so
/// the profile's Σ φ A Δy is the bed's solid volume in every sample, and so
/// in the mean: 25 spheres (5 fixed, 20 mobile) of 0.5 mm in slabs of
/// 5 × 1.05 d × d, to 1e-9. Clear water and the coupled flow alike; the
/// coupled fluid is at rest inside the bed and flows above it.
#[test]
fn profiles_hold_the_grains_volume_exactly() {
    let d = 0.5e-3;
    let sphere = std::f64::consts::PI / 6.0 * d * d * d;
    let area = 5.0 * 1.05 * d * d;
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in [("clear", SMALL.to_string()), ("coupled", coupled())] {
        let cfg = write(dir.path(), &format!("{name}.toml"), &text);
        let out = dir.path().join(name);
        run_into(&cfg, &out).assert().success();
        let rows = profiles(&out);
        for tau in [0.1, 0.3] {
            let rows: Vec<_> = rows.iter().filter(|r| r.0 == tau).collect();
            // 0.2 m in cells of d/2, and 3 more down to the fixed grains (7/6 d).
            assert_eq!(rows.len(), 803, "{name}");
            let dy = (rows[1].1 - rows[0].1) * d;
            let volume: f64 = rows.iter().map(|r| r.2 * area * dy).sum();
            assert!(
                (volume - 25.0 * sphere).abs() <= 1e-9 * volume,
                "{name}, tau* {tau}: {volume} against {}",
                25.0 * sphere
            );
            let top = rows.iter().rposition(|r| r.2 > 0.0).unwrap();
            let above = rows[top + 10].4;
            assert!(above > 0.0 && rows[0].4.abs() < above, "{name}: {above}");
            assert!(rows[..=top].iter().any(|r| r.3.is_some()));
        }
    }
}

/// A coupled run stopped and resumed, or run on one or two threads, writes
/// the same transport table and profiles, byte for byte.
#[test]
fn coupled_runs_repeat_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "coupled.toml", &coupled());
    let mut outputs = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.path().join(format!("t{threads}"));
        run_on_threads(&cfg, &out, threads).assert().success();
        outputs.push(out);
    }
    let stopped = dir.path().join("stopped");
    mbs()
        .arg("run")
        .arg(&cfg)
        .arg("--out")
        .arg(&stopped)
        .args(["--stop-after-steps", "25000"])
        .assert()
        .code(130);
    resume_in(&stopped).assert().success();
    outputs.push(stopped);
    for file in ["transport.csv", "profiles.csv"] {
        let first = std::fs::read(outputs[0].join(file)).unwrap();
        for out in &outputs[1..] {
            assert_eq!(std::fs::read(out.join(file)).unwrap(), first, "{file}");
        }
    }
    let clear = dir.path().join("clear");
    run_into(&write(dir.path(), "clear.toml", SMALL), &clear)
        .assert()
        .success();
    assert_ne!(
        std::fs::read(clear.join("profiles.csv")).unwrap(),
        std::fs::read(outputs[0].join("profiles.csv")).unwrap(),
        "the coupled flow is another flow"
    );
}

/// Bad coupled-flow and slope keys are errors that name the key, its value
/// and the allowed range, with exit status 2.
#[test]
fn bad_coupled_keys_are_named() {
    let dir = tempfile::tempdir().unwrap();
    for (set, message) in [
        ("fluid.phi_max=1.0", "fluid.phi_max = 1: must be in (0, 1)"),
        (
            "fluid.cell_d=0.01",
            "fluid.cell_d = 0.01: must be large enough for at most 2048 cells",
        ),
        (
            "fluid.hindrance=-1",
            "fluid.hindrance = -1: must be in [0, 10]",
        ),
        (
            "fluid.update_steps=0",
            "fluid.update_steps = 0: must be in [1, 1000000]",
        ),
        (
            "fluid.viscosity_m2_s=0",
            "fluid.viscosity_m2_s = 0: must be in (0, 1]",
        ),
        (
            "bed.slope_rad=0.5",
            "bed.slope_rad = 0.5: must be in [0, 0.5) rad",
        ),
        (
            "bed.slope_rad=0.1",
            "flow.tau_star[0] = 0.1: must be >= h sin(theta)/((s - 1) d_max)",
        ),
        ("flow.model=\"laminar\"", "unknown variant `laminar`"),
    ] {
        let cfg = write(dir.path(), "c.toml", &coupled());
        mbs()
            .arg("run")
            .arg(&cfg)
            .args(["--set", set])
            .arg("--out")
            .arg(dir.path().join("out"))
            .assert()
            .code(2)
            .stderr(predicate::str::contains(message));
    }
}
