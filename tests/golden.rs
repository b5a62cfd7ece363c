//! Golden digests: the paper's scenario (settling bed, then the bed under
//! flow at τ* = 0.2) must reproduce the committed digests bit for bit, in f32
//! and f64, on every machine. Re-record on purpose, in a commit that says why:
//!
//!     MBS_BLESS=1 cargo test --test golden

use mbs_kernel::{Real, Scenario, Sim};
use std::path::PathBuf;

/// Steps of each phase of the golden run.
const SETTLE_STEPS: u64 = 2000;
const FLOW_STEPS: u64 = 2000;

fn path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/digests.txt")
}

fn run<R: Real>() -> (u64, u64) {
    let mut sim = Box::new(Sim::<R, 64, 8>::new());
    Scenario::paper()
        .digests(
            &mut *sim,
            Scenario::PAPER_TAU_STAR,
            SETTLE_STEPS,
            FLOW_STEPS,
        )
        .expect("golden scenario runs")
}

fn lines() -> Vec<String> {
    let (a, b) = (run::<f32>(), run::<f64>());
    vec![
        format!("settling f32 {:#018x}", a.0),
        format!("flow f32 {:#018x}", a.1),
        format!("settling f64 {:#018x}", b.0),
        format!("flow f64 {:#018x}", b.1),
    ]
}

#[test]
fn golden_digests_match() {
    let now = lines();
    if std::env::var_os("MBS_BLESS").is_some() {
        let text = format!(
            "# Digests of Scenario::paper() after {SETTLE_STEPS} settling steps and {FLOW_STEPS} flow steps.\n# Re-record: MBS_BLESS=1 cargo test --test golden\n{}\n",
            now.join("\n")
        );
        std::fs::write(path(), text).expect("write golden file");
        return;
    }
    let text = std::fs::read_to_string(path()).expect("tests/golden/digests.txt exists");
    let recorded: Vec<&str> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .collect();
    assert_eq!(
        recorded, now,
        "state digests changed; if on purpose, re-record (see file header)"
    );
}

#[test]
fn digests_distinguish_phases_and_precisions() {
    let now = lines();
    for (i, a) in now.iter().enumerate() {
        for b in &now[i + 1..] {
            assert_ne!(a.split(' ').nth(2), b.split(' ').nth(2));
        }
    }
}
