//! Checkpoints: a run stopped anywhere and restored (into a simulation of
//! another capacity) continues bit for bit; every damaged checkpoint is
//! refused with a named fault and leaves the simulation unchanged.

use mbs_kernel::{
    Capacity, CheckpointFault, Error, Real, Scenario, Sim, SimConfig, Tension, CHECKPOINT_VERSION,
};

type Big<R> = Sim<R, 256, 8>;
type Other<R> = Sim<R, 64, 10>;

fn bytes<R: Real, const N: usize, const K: usize>(sim: &Sim<R, N, K>) -> Vec<u8> {
    let mut out = Vec::new();
    sim.checkpoint(|b| out.extend_from_slice(b));
    out
}

/// Runs the paper's scenario: `settle` steps, flow on, `flow` steps.
fn run<R: Real, const N: usize, const K: usize>(sim: &mut Sim<R, N, K>, settle: u64, flow: u64) {
    let sc = Scenario::paper();
    sc.build(sim).unwrap();
    sim.run(settle).unwrap();
    sim.set_flow(Some(&sc.flow(Scenario::PAPER_TAU_STAR)))
        .unwrap();
    sim.run(flow).unwrap();
}

fn resume_is_bit_identical<R: Real>() {
    // Stops before the flow, right after it starts, inside a hold period
    // (800 steps at 8 substeps), on a bed-level update and after several.
    for (settle, flow) in [(700, 0), (1500, 1), (1500, 333), (1500, 800), (1500, 1999)] {
        let mut uninterrupted = Box::new(Big::<R>::new());
        run(&mut *uninterrupted, settle, flow);
        let saved = bytes(&*uninterrupted);
        let mut resumed = Box::new(Other::<R>::new());
        resumed.restore(&saved).unwrap();
        assert_eq!(
            resumed.digest(),
            uninterrupted.digest(),
            "restored state ({settle}, {flow})"
        );
        assert_eq!(bytes(&*resumed), saved, "checkpoint of the restored state");
        if flow == 0 {
            let sc = Scenario::paper();
            uninterrupted.run(300).unwrap();
            resumed.run(300).unwrap();
            uninterrupted
                .set_flow(Some(&sc.flow(Scenario::PAPER_TAU_STAR)))
                .unwrap();
            resumed
                .set_flow(Some(&sc.flow(Scenario::PAPER_TAU_STAR)))
                .unwrap();
        }
        uninterrupted.run(1200).unwrap();
        resumed.run(1200).unwrap();
        assert_eq!(
            resumed.digest(),
            uninterrupted.digest(),
            "continued ({settle}, {flow})"
        );
        assert_eq!(resumed.step_count(), uninterrupted.step_count());
    }
}

#[test]
fn resume_is_bit_identical_f32() {
    resume_is_bit_identical::<f32>();
}

#[test]
fn resume_is_bit_identical_f64() {
    resume_is_bit_identical::<f64>();
}

fn refused(sim: &mut Big<f64>, damaged: &[u8]) -> Error {
    let before = (sim.digest(), bytes(sim));
    let err = sim.restore(damaged).unwrap_err();
    assert_eq!(
        (sim.digest(), bytes(sim)),
        before,
        "unchanged after {err:?}"
    );
    err
}

fn fault(e: Error) -> CheckpointFault {
    match e {
        Error::BadCheckpoint { fault, .. } => fault,
        other => panic!("not a checkpoint fault: {other:?}"),
    }
}

#[test]
fn damaged_checkpoints_are_refused_and_change_nothing() {
    let mut source = Box::new(Big::<f64>::new());
    run(&mut *source, 1000, 500);
    let good = bytes(&*source);
    assert_eq!(&good[..4], b"MBSK");
    assert_eq!(u16::from_le_bytes([good[4], good[5]]), CHECKPOINT_VERSION);
    let mut sim = Box::new(Big::<f64>::new());
    run(&mut *sim, 10, 0);
    // Every truncation.
    for len in 0..good.len() {
        assert_eq!(
            fault(refused(&mut sim, &good[..len])),
            CheckpointFault::Truncated,
            "length {len}"
        );
    }
    let mut bad = good.clone();
    bad[0] = b'X';
    assert_eq!(fault(refused(&mut sim, &bad)), CheckpointFault::Magic);
    let mut bad = good.clone();
    bad[4] = 99;
    assert_eq!(fault(refused(&mut sim, &bad)), CheckpointFault::Version);
    let mut f32_sim = Box::new(Big::<f32>::new());
    assert!(matches!(
        f32_sim.restore(&good),
        Err(Error::BadCheckpoint {
            fault: CheckpointFault::Precision,
            offset: 7
        })
    ));
    let mut bad = good.clone();
    bad.push(0);
    assert_eq!(fault(refused(&mut sim, &bad)), CheckpointFault::Trailing);
    // A tension rule that does not exist, after the header (8) and the
    // configuration's numbers (144).
    let mut bad = good.clone();
    bad[8 + 144] = 2;
    assert_eq!(fault(refused(&mut sim, &bad)), CheckpointFault::Value);
    // A NaN where the first grain's x is: after the header (8 + 161 + 181
    // (flow) + 32 + 8 (bed level) + 4 (grain count)) bytes.
    let mut bad = good.clone();
    let x0 = 8 + 161 + 181 + 32 + 8 + 4;
    bad[x0..x0 + 8].copy_from_slice(&f64::NAN.to_bits().to_le_bytes());
    assert_eq!(fault(refused(&mut sim, &bad)), CheckpointFault::Value);
    // Every single flipped byte is refused or restores to a valid state:
    // never a panic, never a half-applied state.
    for k in (0..good.len()).step_by(7) {
        let mut flipped = good.clone();
        flipped[k] ^= 0x5a;
        let mut target = Box::new(Big::<f64>::new());
        run(&mut *target, 10, 0);
        let before = target.digest();
        match target.restore(&flipped) {
            Ok(()) => {
                let _ = target.run(10);
            }
            Err(_) => assert_eq!(target.digest(), before, "byte {k}"),
        }
    }
    // Too many grains for the capacity.
    let mut tiny = Box::new(Sim::<f64, 32, 8>::new());
    assert!(matches!(
        tiny.restore(&good),
        Err(Error::CapacityExceeded {
            what: Capacity::Grains,
            capacity: 32
        })
    ));
}

/// The offset of the flow epoch and step count (two u64 after the flow) in
/// a checkpoint of the paper's bed run `settle` steps, flow on, `flow` steps.
fn counters_at(saved: &[u8], settle: u64, flow: u64) -> usize {
    let mut needle = settle.to_le_bytes().to_vec();
    needle.extend_from_slice(&(settle + flow).to_le_bytes());
    saved
        .windows(16)
        .position(|w| w == needle)
        .expect("the counters in the checkpoint")
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 24, ..Default::default() })]

    /// A restored state with extreme but well-formed counters (flow epoch and
    /// step count up to u64::MAX) steps without an overflow panic, in any
    /// build (overflow checks on in `cargo test` without `--release`).
    #[test]
    fn extreme_restored_counters_step_without_overflow(
        epoch in proptest::prop_oneof![
            proptest::strategy::Just(0u64),
            proptest::strategy::Just(u64::MAX),
            proptest::strategy::Just(u64::MAX - 1),
            proptest::prelude::any::<u64>()
        ],
        to_max in 0u64..4,
    ) {
        let (settle, flow) = (200, 50);
        let mut sim = Box::new(Big::<f64>::new());
        run(&mut *sim, settle, flow);
        let mut saved = bytes(&*sim);
        let at = counters_at(&saved, settle, flow);
        saved[at..at + 8].copy_from_slice(&epoch.to_le_bytes());
        saved[at + 8..at + 16].copy_from_slice(&(u64::MAX - to_max).to_le_bytes());
        let mut resumed = Box::new(Big::<f64>::new());
        resumed.restore(&saved).unwrap();
        for _ in 0..6 {
            let _ = resumed.step();
        }
        proptest::prop_assert!(resumed.time().is_finite());
    }
}

/// The contact's tension rule is part of the checkpoint (docs/model.md
/// (8')): a run without tension restores without tension and continues bit
/// for bit; a version-2 checkpoint (no tension byte) restores with the
/// paper's rule, the only one it knew.
#[test]
fn the_tension_rule_is_restored() {
    let mut sc = Scenario::paper();
    sc.tension = Tension::None;
    let mut uninterrupted = Box::new(Big::<f64>::new());
    sc.build(&mut *uninterrupted).unwrap();
    uninterrupted.run(1500).unwrap();
    let saved = bytes(&*uninterrupted);
    assert_eq!(saved[8 + 144], 1);
    let mut resumed = Box::new(Other::<f64>::new());
    resumed.restore(&saved).unwrap();
    assert_eq!(resumed.config().tension, Tension::None);
    uninterrupted.run(1500).unwrap();
    resumed.run(1500).unwrap();
    assert_eq!(resumed.digest(), uninterrupted.digest());

    let mut paper = Box::new(Big::<f64>::new());
    run(&mut *paper, 1500, 0);
    for version in [5, 4, 3, 2] {
        let old = downgrade(&bytes(&*paper), version);
        let mut restored = Box::new(Other::<f64>::new());
        restored.restore(&old).unwrap();
        // Before version 5 the free surface was the domain's top.
        let expected = SimConfig {
            surface: if version >= 5 {
                paper.config().surface
            } else {
                paper.config().y_max
            },
            ..*paper.config()
        };
        assert_eq!(*restored.config(), expected);
        assert_eq!(restored.digest(), paper.digest());
    }
}

/// A clear-water checkpoint of the current version as version 5 (no
/// lateral stress ratio), 4 (no free
/// surface, no side walls, drag law, fluctuation model or redraw
/// schedule), 3 (no slope, no flow model, no fluid configuration either)
/// or 2 (no tension byte either).
fn downgrade(bytes: &[u8], version: u16) -> Vec<u8> {
    let mut old = bytes.to_vec();
    // Version 6's addition: the lateral stress ratio after the grains'
    // wall friction.
    let flow_end = 8 + 161 + 66;
    old.drain(flow_end + 105..flow_end + 113);
    if version == 5 {
        old[4..6].copy_from_slice(&version.to_le_bytes());
        return old;
    }
    // Version 5's additions: the redraw schedule after the flow epoch and
    // the step, the side walls, drag law and fluctuations after the
    // fluid's configuration, the free surface after the slope.
    let redraw = flow_end + 107 + 16;
    old.drain(redraw..redraw + 16);
    old.drain(flow_end + 81..flow_end + 107);
    old.drain(8 + 153..8 + 161);
    let flow_end = 8 + 153 + 66;
    if version <= 3 {
        // The flow model and the fluid's configuration after the 66 bytes of
        // the flow, then the slope after the tension byte.
        assert_eq!(old[flow_end], 0, "clear water");
        old.drain(flow_end..flow_end + 81);
        let slope = f64::from_le_bytes(old[8 + 145..8 + 153].try_into().unwrap());
        assert_eq!(slope, 0.0);
        old.drain(8 + 145..8 + 153);
    }
    if version == 2 {
        assert_eq!(old.remove(8 + 144), 0);
    }
    old[4..6].copy_from_slice(&version.to_le_bytes());
    old
}

/// `Sim::MAX_CHECKPOINT_LEN` is the length of an empty simulation's
/// checkpoint plus full grain and contact slots, and bounds a real one.
#[test]
fn the_largest_checkpoint_bounds_every_checkpoint() {
    fn check<R: Real>() {
        let mut sim = Box::new(Big::<R>::new());
        sim.reset(&Scenario::paper().sim_config().unwrap()).unwrap();
        let empty = bytes(&*sim).len();
        let grain = 11 * R::BYTES + 2;
        let contact = 8 + 2 * R::BYTES;
        assert_eq!(
            Big::<R>::MAX_CHECKPOINT_LEN,
            empty + 256 * grain + 256 * 8 * contact
        );
        run(&mut *sim, 300, 100);
        assert!(bytes(&*sim).len() <= Big::<R>::MAX_CHECKPOINT_LEN);
    }
    check::<f32>();
    check::<f64>();
}
