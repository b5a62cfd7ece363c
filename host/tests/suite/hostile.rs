//! Hostile input, bounded fuzzing inside `cargo test`: the configuration
//! parser, the cell-checkpoint decoder and the kernel's checkpoint loader
//! never panic on arbitrary or mutated bytes; a refused kernel checkpoint
//! changes nothing. (Longer runs: the cargo-fuzz targets in `fuzz/`.)

use mbs::config::{Config, DEFAULT_TOML};
use mbs::work::cell::CellCheckpoint;
use mbs_kernel::{Scenario, Sim};
use proptest::prelude::*;

fn kernel_checkpoint() -> Vec<u8> {
    let mut sim = Box::new(Sim::<f64, 64, 8>::new());
    let sc = Scenario::paper();
    sc.build(&mut *sim).unwrap();
    sim.run(300).unwrap();
    sim.set_flow(Some(&sc.flow(Scenario::PAPER_TAU_STAR)))
        .unwrap();
    sim.run(300).unwrap();
    let mut out = Vec::new();
    sim.checkpoint(|b| out.extend_from_slice(b));
    out
}

/// Applies (position, byte) edits, positions taken modulo the length.
fn mutate(base: &[u8], edits: &[(usize, u8)], cut: Option<usize>) -> Vec<u8> {
    let mut out = base.to_vec();
    for &(at, b) in edits {
        if !out.is_empty() {
            let n = out.len();
            out[at % n] = b;
        }
    }
    if let Some(c) = cut {
        out.truncate(c % (base.len() + 1));
    }
    out
}

/// A text is a configuration whose plan holds (τ* and seeds to run, a
/// positive time step), or a named error of exit status 2.
fn check_outcome(text: &str) -> Result<(), TestCaseError> {
    match Config::from_toml(text) {
        Ok(c) => {
            prop_assert!(!c.tau_stars.is_empty() && !c.seeds.is_empty());
            prop_assert!(c.tau_stars.iter().all(|t| t.is_finite() && *t > 0.0));
            prop_assert!(c.scenario.step_dt() > 0.0);
        }
        Err(e) => {
            prop_assert!(!e.to_string().trim().is_empty());
            prop_assert_eq!(mbs::HostError::from(e).exit_code(), 2);
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn any_text_is_a_configuration_or_an_error(text in "\\PC{0,400}") {
        check_outcome(&text)?;
    }

    #[test]
    fn mutated_default_configurations_never_panic(
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..8),
        cut in proptest::option::of(any::<usize>()),
    ) {
        let bytes = mutate(DEFAULT_TOML.as_bytes(), &edits, cut);
        if let Ok(text) = std::str::from_utf8(&bytes) {
            check_outcome(text)?;
        }
    }

    #[test]
    fn arbitrary_bytes_are_refused_by_the_checkpoint_loaders(
        bytes in proptest::collection::vec(any::<u8>(), 0..600),
    ) {
        prop_assert!(CellCheckpoint::decode(&bytes, 7).is_err() || bytes.starts_with(b"MBSC"));
        let mut sim = Box::new(Sim::<f64, 64, 8>::new());
        let before = sim.digest();
        if sim.restore(&bytes).is_err() {
            prop_assert_eq!(sim.digest(), before);
        }
    }

    #[test]
    fn mutated_kernel_checkpoints_restore_or_change_nothing(
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..6),
        cut in proptest::option::of(any::<usize>()),
    ) {
        let good = kernel_checkpoint();
        let bytes = mutate(&good, &edits, cut);
        let mut sim = Box::new(Sim::<f64, 64, 8>::new());
        Scenario::paper().build(&mut *sim).unwrap();
        let before = sim.digest();
        match sim.restore(&bytes) {
            Ok(()) => { let _ = sim.run(20); }
            Err(_) => prop_assert_eq!(sim.digest(), before),
        }
    }
}
