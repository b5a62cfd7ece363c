//! The figures a run leaves behind carry what a reader needs (issue 28):
//! every decade labelled, q* and τ* defined, τ*c of every relation, the
//! size classes of a mixed bed, and the snapshot's colour bar, bed level,
//! flow profile and periodic edges. (How they look is checked by eye.)

use crate::common::*;
use mbs::figures::{Q_STAR_AXIS, TAU_STAR_AXIS};
use mbs::science::references::Reference;
use std::path::Path;

/// The text of every `<text>` element of `dir/name`, after checking that
/// it and the PNG of the same name exist.
fn svg_texts(dir: &Path, stem: &str) -> Vec<String> {
    let png = std::fs::read(dir.join(format!("{stem}.png"))).unwrap();
    assert_eq!(&png[1..4], b"PNG", "{stem}.png");
    let svg = std::fs::read_to_string(dir.join(format!("{stem}.svg"))).unwrap();
    mbs::figures::svg_texts(&svg)
}

fn assert_has(texts: &[String], wanted: &[&str]) {
    for w in wanted {
        assert!(texts.iter().any(|t| t == w), "{w:?} not in {texts:?}");
    }
}

#[test]
fn the_transport_figure_labels_decades_thresholds_definitions_and_classes() {
    let dir = tempfile::tempdir().unwrap();
    let text = SMALL.replace(
        "[bed]",
        "[grains]\nclasses = [{ diameter_mm = 1.0, fraction = 0.5 }, { diameter_mm = 0.7, fraction = 0.5 }]\n[bed]",
    ) + "[contact]\nbeta = 4.0\n";
    let cfg = write(
        dir.path(),
        "mixed.toml",
        &text.replace("[time]", "[time]\nsubsteps = 8"),
    );
    let out = dir.path().join("out");
    run_into(&cfg, &out).assert().success();
    let texts = svg_texts(&out, "transport");
    // q*: every decade; τ* (0.1 and 0.3 and a quarter beyond): 0.08 to 0.3.
    assert_has(
        &texts,
        &["0.0001", "0.001", "0.01", "0.1", "1", "0.08", "0.2", "0.3"],
    );
    assert_has(&texts, &[Q_STAR_AXIS, TAU_STAR_AXIS]);
    for r in Reference::ALL {
        let label = r.label();
        assert!(
            label.contains(&format!("τ*c {}", r.tau_star_c())),
            "{label}"
        );
        assert_has(&texts, &[&label]);
    }
    assert_has(
        &texts,
        &[
            "mbs (mean, 95 % interval)",
            "mbs, class d = 1 mm",
            "mbs, class d = 0.7 mm",
        ],
    );
    let title = &texts[0];
    assert!(title.contains("d = 1, 0.7 mm"), "{title}");
}

#[test]
fn the_snapshot_has_a_colour_bar_the_bed_level_the_flow_and_the_periodic_edges() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    mbs()
        .arg("snapshot")
        .arg(&cfg)
        .args(["--frames", "1", "--every", "0.005", "--out"])
        .arg(dir.path())
        .assert()
        .success();
    let texts = svg_texts(dir.path(), "snapshot");
    assert_has(
        &texts,
        &[
            "grain speed |v| (m/s)",
            "mean flow U (m/s)",
            "U(y), (14)",
            "periodic edge x = 0",
            "x = L",
        ],
    );
    assert!(
        texts.iter().any(|t| t.starts_with("mean bed level ")),
        "{texts:?}"
    );
}

#[test]
fn measured_profiles_are_drawn_over_the_profiles_and_a_bad_file_is_a_configuration_error() {
    let dir = tempfile::tempdir().unwrap();
    // u_f given at one height only: its panel gets that one dot.
    write(
        dir.path(),
        "m.csv",
        "z_over_d,solid_fraction,particle_velocity_m_s,fluid_velocity_m_s\n\
         0.5,0.55,0.0,\n1.5,0.2,0.05,\n3.0,0.0,0.0,0.3\n",
    );
    let measured = dir.path().join("m.csv");
    let text = SMALL.replace("seeds = [1, 2]", "seeds = [1]").replace(
        "[run]",
        &format!(
            "[run]\nmeasured_profiles = {:?}\nmeasured_shift_d = 0.5",
            measured.display().to_string()
        ),
    );
    let cfg = write(dir.path(), "measured.toml", &text);
    let out = dir.path().join("out");
    run_into(&cfg, &out).assert().success();
    let texts = svg_texts(&out, "profiles");
    let legends = texts.iter().filter(|t| *t == "measured (m.csv)").count();
    assert_eq!(legends, 3, "{texts:?}");
    // The τ* legend once (the same colours in every panel) and the bed's
    // surface marked in each of the four panels.
    assert_eq!(
        texts.iter().filter(|t| *t == "τ* = 0.1").count(),
        1,
        "{texts:?}"
    );
    assert_eq!(
        texts
            .iter()
            .filter(|t| t.starts_with("bed surface"))
            .count(),
        4
    );
    // The shift and the file name are kept in the saved configuration.
    let saved = std::fs::read_to_string(out.join("config.toml")).unwrap();
    assert!(saved.contains("measured_shift_d = 0.5"), "{saved}");
    assert!(saved.contains("m.csv"), "{saved}");

    for (name, body) in [
        ("missing.csv", None),
        (
            "empty.csv",
            Some("z_over_d,solid_fraction,particle_velocity_m_s\n"),
        ),
        ("column.csv", Some("z_over_d,solid_fraction\n1.0,0.5\n")),
        (
            "nan.csv",
            Some("z_over_d,solid_fraction,particle_velocity_m_s\nNaN,0.5,0.1\n"),
        ),
    ] {
        if let Some(body) = body {
            write(dir.path(), name, body);
        }
        let path = dir.path().join(name);
        let bad = SMALL.replace(
            "[run]",
            &format!(
                "[run]\nmeasured_profiles = {:?}",
                path.display().to_string()
            ),
        );
        let cfg = write(dir.path(), "bad.toml", &bad);
        let output = run_into(&cfg, &dir.path().join("bad")).assert().failure();
        let stderr = String::from_utf8_lossy(&output.get_output().stderr).into_owned();
        assert!(stderr.contains("run.measured_profiles"), "{name}: {stderr}");
    }
}
