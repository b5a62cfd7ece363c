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

/// A trace of the golden run, recorded in-process (100 + 100 steps, a
/// record every 50).
fn golden_trace() -> mbs::tools::trace::Trace {
    use mbs::tools::trace::{TraceRun, TraceSpec};
    let config = Config::golden().unwrap();
    let run = TraceRun {
        scenario: config.scenario_at(config.seeds[0]),
        capacity: config.capacity,
        spec: TraceSpec {
            config: None,
            overrides: Vec::new(),
            configuration: toml::to_string(&mbs::config::canonical(&config.file)).unwrap(),
            tau_star: 0.2,
            settle_steps: 100,
            flow_steps: 100,
            every: 50,
            from: 0,
            until: u64::MAX,
            states: false,
            precision: mbs::config::Precision::F64,
        },
    };
    run.run().unwrap()
}

/// `default` cases, or `PROPTEST_CASES` where set (longer fuzzing runs:
/// docs/guarantees.md, "Fuzzing").
fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(default)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(200), ..ProptestConfig::default() })]

    /// `--set SECTION.KEY=VALUE` with any key and value: a configuration
    /// whose plan holds, or a short named error of exit status 2.
    #[test]
    fn any_set_is_a_configuration_or_a_named_error(
        section in "(grains|bed|contact|time|flow|fluid|run|target|[a-z]{1,6})",
        key in "[a-z_]{1,16}",
        value in "\\PC{0,40}",
    ) {
        let set = format!("{section}.{key}={value}");
        match Config::load_with(None, &[set]) {
            Ok(c) => {
                prop_assert!(!c.tau_stars.is_empty() && c.scenario.step_dt() > 0.0);
            }
            Err(e) => {
                let text = e.to_string();
                prop_assert!(!text.trim().is_empty() && text.len() < 2000, "{}", text);
                prop_assert_eq!(mbs::HostError::from(e).exit_code(), 2);
            }
        }
    }

    /// A measured profile of any numbers is read with every value in its
    /// range, or refused with the line and the column.
    #[test]
    fn any_measured_profile_is_in_range_or_refused(
        rows in proptest::collection::vec(
            (
                prop_oneof![any::<f64>(), -2000.0..2000.0f64],
                prop_oneof![any::<f64>(), -1.0..2.0f64],
                prop_oneof![any::<f64>(), -200.0..200.0f64],
            ),
            0..6,
        ),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let mut text = String::from("z_over_d,solid_fraction,particle_velocity_m_s\n");
        for (z, phi, u) in &rows {
            text += &format!("{z},{phi},{u}\n");
        }
        let path = dir.path().join("p.csv");
        std::fs::write(&path, &text).unwrap();
        match mbs::science::measured::MeasuredProfile::read(&path, 0.0) {
            Ok(m) => {
                prop_assert!(m.y_over_d.iter().all(|z| z.abs() <= 1000.0));
                prop_assert!(m.solid_fraction.iter().all(|p| (0.0..=1.0).contains(p)));
                prop_assert!(m.grain_velocity.iter().all(|u| u.abs() <= 100.0));
            }
            Err(why) => prop_assert!(why.starts_with("line ") || why == "no line", "{}", why),
        }
    }

    /// A trace whose fields are edited (its checksum recomputed) is checked
    /// as strictly as the command that would record it: matched, refused
    /// with exit status 2, or a located mismatch (1); never a panic, never
    /// a run beyond the recording bounds.
    #[test]
    fn edited_traces_are_checked_like_the_command_line(
        field in 0usize..6,
        value in prop_oneof![any::<u64>(), 0u64..500],
        tau in prop_oneof![any::<f64>(), 0.0..6.0f64],
    ) {
        let mut trace = golden_trace();
        let s = &mut trace.spec;
        match field {
            0 => s.settle_steps = value,
            1 => s.flow_steps = value,
            2 => s.every = value,
            3 => s.from = value,
            4 => s.tau_star = tau,
            _ => s.configuration = s.configuration.replace("columns = 5", &format!("columns = {value}")),
        }
        let refused = trace.spec.validate().is_err();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.json");
        std::fs::write(&path, mbs::tools::trace::to_text(&trace).unwrap()).unwrap();
        // An edit of the phases changes the scenario's hash: refused before
        // any step, so no edit can make the check run long.
        match mbs::cli::check_trace(&path, None) {
            Ok(()) => prop_assert!(!refused),
            Err(e) if refused => prop_assert_eq!(e.exit_code(), 2, "{}", e),
            Err(e) => prop_assert!([1, 2].contains(&e.exit_code()), "{}", e),
        }
    }
}
