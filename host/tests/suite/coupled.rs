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

/// [`coupled`] with every HydroForceEngine closure (docs/model.md
/// (C8)–(C12)) under 4 mm of water: Dallavalle's drag, the random walk,
/// side walls 0.55 mm apart, the grains' friction on them under the
/// spanwise push and the overburden.
fn closures() -> String {
    coupled().replace("[flow]", "[flow]\ndepth = 0.004")
        + "[fluid]\ndrag = \"dallavalle\"\nfluctuations = \"hfe\"\n[channel]\nwidth_m = 0.00055\nwall_friction = 0.6\ngrain_friction = 0.4\nlateral_ratio = 0.5\n"
}

/// The rows of `profiles.csv` as (τ*, y/d, φ, u_p, u_f), u_p `None` where
/// no grain ever was.
fn profiles(out: &std::path::Path) -> Vec<(f64, f64, f64, Option<f64>, f64)> {
    let text = std::fs::read_to_string(out.join("profiles.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("tau_star,y_over_d,solid_fraction,grain_velocity_m_s,fluid_velocity_m_s,contact_stress_pa,kinetic_stress_pa,viscous_stress_pa,reynolds_stress_pa")
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
/// the same transport table and profiles, byte for byte; with the paper's
/// closures and with HydroForceEngine's.
#[test]
fn coupled_runs_repeat_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let mut firsts = Vec::new();
    for (name, text) in [("coupled", coupled()), ("closures", closures())] {
        let cfg = write(dir.path(), &format!("{name}.toml"), &text);
        let mut outputs = Vec::new();
        for threads in ["1", "2"] {
            let out = dir.path().join(format!("{name}-t{threads}"));
            run_on_threads(&cfg, &out, threads).assert().success();
            outputs.push(out);
        }
        let stopped = dir.path().join(format!("{name}-stopped"));
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
                assert_eq!(
                    std::fs::read(out.join(file)).unwrap(),
                    first,
                    "{name}: {file}"
                );
            }
        }
        firsts.push(std::fs::read(outputs[0].join("profiles.csv")).unwrap());
    }
    assert_ne!(firsts[0], firsts[1], "the closures are other closures");
    let clear = dir.path().join("clear");
    run_into(&write(dir.path(), "clear.toml", SMALL), &clear)
        .assert()
        .success();
    assert_ne!(
        std::fs::read(clear.join("profiles.csv")).unwrap(),
        firsts[0],
        "the coupled flow is another flow"
    );
}

/// Bad coupled-flow and slope keys are errors that name the key, its value
/// and the allowed range, with exit status 2.
#[test]
fn bad_coupled_keys_are_named() {
    let dir = tempfile::tempdir().unwrap();
    for (set, message) in [
        (
            "fluid.phi_max=1.0",
            "fluid.phi_max = 1: must be in [0.1, 1)",
        ),
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
            "fluid.viscosity_m2_s = 0: must be in [1e-8, 1]",
        ),
        (
            "bed.slope_rad=0.5",
            "bed.slope_rad = 0.5: must be in [0, 0.5) rad",
        ),
        (
            "bed.slope_rad=0.01",
            "flow.tau_star[0] = 0.1: must be >= h sin(theta)/((s - 1) d_max)",
        ),
        (
            "bed.slope_rad=0.1",
            "bed.slope_rad = 0.1: must be <= 2.0626e-2 rad with flow.depth = 0.2 m",
        ),
        ("flow.model=\"laminar\"", "unknown variant `laminar`"),
        ("fluid.drag=\"stokes\"", "unknown variant `stokes`"),
        (
            "channel.width_m=0",
            "channel.width_m = 0: must be in (0, 100] m",
        ),
        (
            "channel.width_m=0.0065 channel.wall_friction=-1",
            "channel.wall_friction = -1: must be in [0, 10]",
        ),
        (
            "channel.width_m=0.0065 channel.grain_friction=11",
            "channel.grain_friction = 11: must be in [0, 10]",
        ),
        (
            "channel.width_m=0.0065 channel.lateral_ratio=-0.5",
            "channel.lateral_ratio = -0.5: must be in [0, 10]",
        ),
    ] {
        let cfg = write(dir.path(), "c.toml", &coupled());
        mbs()
            .arg("run")
            .arg(&cfg)
            .args(set.split(' ').flat_map(|s| ["--set", s]))
            .arg("--out")
            .arg(dir.path().join("out"))
            .assert()
            .code(2)
            .stderr(predicate::str::contains(message));
    }
}

/// The closures and the walls act on the coupled flow only: with clear
/// water each is an error naming it, not a setting silently ignored.
#[test]
fn closures_without_the_coupled_flow_are_named() {
    let dir = tempfile::tempdir().unwrap();
    for (set, key) in [
        ("channel.width_m=0.0065", "channel.width_m = 0.0065"),
        ("fluid.drag=\"dallavalle\"", "fluid.drag = dallavalle"),
        ("fluid.fluctuations=\"hfe\"", "fluid.fluctuations = hfe"),
    ] {
        let cfg = write(dir.path(), "c.toml", SMALL);
        mbs()
            .arg("run")
            .arg(&cfg)
            .args(["--set", set])
            .arg("--out")
            .arg(dir.path().join("out"))
            .assert()
            .code(2)
            .stderr(predicate::str::contains(format!(
                "{key}: must be absent with flow.model = \"clear-water\""
            )));
    }
}

/// The shear stresses of `profiles.csv` (docs/model.md §8): in the settled
/// bed of a horizontal bed the grains' contacts carry one shear stress at
/// every depth (the drag they received above, within 2 %); above the
/// grains they carry none and the fluid's viscous and Reynolds stresses
/// carry the driving of the water above, ρ g S ∫ (1 − φ) dy, within 1 %
/// where the column is steady (from 60 d up).
#[test]
fn stress_profiles_carry_the_shear() {
    let dir = tempfile::tempdir().unwrap();
    let text = coupled()
        .replace("tau_star = [0.1, 0.3]", "tau_star = [0.3]")
        .replace("window = 0.05", "window = 0.3")
        .replace("window_min = 0.05", "window_min = 0.3");
    let cfg = write(dir.path(), "stress.toml", &text);
    let out = dir.path().join("out");
    run_into(&cfg, &out).assert().success();
    let csv = std::fs::read_to_string(out.join("profiles.csv")).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap_or(0.0)).collect())
        .collect();
    let (d, h) = (0.5e-3, 0.2);
    let g_s = 0.3 * 1.65 * 9.81 * d / h;
    let dy = (rows[1][1] - rows[0][1]) * d;
    let bed: Vec<f64> = (rows.iter())
        .filter(|r| (1.0..=2.5).contains(&r[1]))
        .map(|r| r[5])
        .collect();
    let mean = bed.iter().sum::<f64>() / bed.len() as f64;
    assert!(
        mean > 0.0 && bed.iter().all(|c| (c / mean - 1.0).abs() < 0.02),
        "{bed:?}"
    );
    for (j, r) in rows.iter().enumerate() {
        if r[1] < 8.0 {
            continue;
        }
        assert_eq!((r[5], r[6]), (0.0, 0.0), "no grains at {} d", r[1]);
        if r[1] >= 60.0 {
            let open: f64 =
                rows[j + 1..].iter().map(|s| 1.0 - s[2]).sum::<f64>() + 0.5 * (1.0 - r[2]);
            let expected = 1000.0 * g_s * open * dy;
            let fluid = r[7] + r[8];
            assert!(
                (fluid / expected - 1.0).abs() < 0.01,
                "{} d: {fluid} against {expected}",
                r[1]
            );
        }
    }
}
