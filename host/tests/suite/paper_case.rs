//! Acceptance of the main job (issue: the `mbs` command) on the embedded
//! paper's case, and on the same case with β refitted for converged
//! integration (`configs/beta3.toml`). Deterministic: fixed seeds, so these
//! numbers change only when the model does.

use indicatif::ProgressBar;
use mbs::work::experiment::{aggregate, run_all, RunControl, TransportRow};
use mbs::Config;
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// The main job of `config` on its first two seeds (half the CI time of
/// four on the 40-column default bed).
fn transport(mut config: Config) -> Vec<TransportRow> {
    config.seeds.truncate(2);
    let dir = tempfile::tempdir().unwrap();
    let never = AtomicBool::new(false);
    let control = RunControl {
        dir: dir.path(),
        every: None,
        stop: &never,
        stop_after: None,
        shard: mbs::work::shard::Shard::ALL,
        log: &mbs::io::log::Log::discard(),
        dump_every: None,
    };
    let outcome = run_all(&config, &ProgressBar::hidden(), &control).expect("the case runs");
    aggregate(&config, &outcome.results)
}

fn q_at(rows: &[TransportRow], tau: f64) -> f64 {
    rows.iter()
        .find(|r| r.tau_star == tau)
        .expect("τ* in the list")
        .q_star
}

/// Above the threshold q* rises with τ*; below τ* ≈ 0.03 it is near zero
/// (under 0.01, i.e. below MPM at τ* = 0.06, and under a quarter of q* at τ* = 0.1).
fn assert_threshold_behaviour(rows: &[TransportRow]) {
    let taus: Vec<f64> = rows.iter().map(|r| r.tau_star).collect();
    assert_eq!(taus, [0.03, 0.06, 0.1, 0.2, 0.4]);
    for pair in rows[1..].windows(2) {
        assert!(
            pair[1].q_star > pair[0].q_star,
            "q* rises: {} at {} -> {} at {}",
            pair[0].q_star,
            pair[0].tau_star,
            pair[1].q_star,
            pair[1].tau_star
        );
    }
    let below = q_at(rows, 0.03);
    assert!(
        below.abs() < 0.01 && below.abs() < 0.25 * q_at(rows, 0.1),
        "near zero below the threshold: {below}"
    );
}

#[test]
fn paper_case_rises_above_the_threshold_and_vanishes_below() {
    let rows = transport(Config::load(None).unwrap());
    assert_threshold_behaviour(&rows);
}

#[test]
fn refitted_beta_is_within_a_factor_3_of_meyer_peter_muller() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/beta3.toml");
    let rows = transport(Config::load(Some(&path)).unwrap());
    assert_threshold_behaviour(&rows);
    for r in rows.iter().filter(|r| (0.1..=0.5).contains(&r.tau_star)) {
        let factor = (r.q_star / r.mpm).max(r.mpm / r.q_star);
        assert!(
            factor < 3.0,
            "τ* = {}: q* = {} vs MPM {}",
            r.tau_star,
            r.q_star,
            r.mpm
        );
    }
}
