//! Every failure is a returned, named error; no input makes the kernel panic.

pub mod common;

use common::*;
use mbs_kernel::{
    BedSpec, Capacity, Error, FlowConfig, GrainSpec, IntegrationSteps, Quantity, Scenario, Sim,
    SimConfig,
};
use proptest::prelude::*;

#[test]
fn grain_capacity_overflow_is_an_error() {
    let cfg = config(1e-5, 1.0, 1e-4, 0.5);
    let mut s = Box::new(Sim::<f64, 4, 8>::new());
    s.reset(&cfg).unwrap();
    for k in 0..4 {
        s.add_grain(&mobile((k as f64 + 0.5) * 2.0 * D, 0.0, 0.0, 0.0))
            .unwrap();
    }
    let err = s.add_grain(&mobile(20.0 * D, 0.0, 0.0, 0.0)).unwrap_err();
    assert_eq!(
        err,
        Error::CapacityExceeded {
            what: Capacity::Grains,
            capacity: 4
        }
    );
    assert_eq!(s.len(), 4, "nothing dropped, nothing added");
    // A bed that does not fit is refused before anything is built.
    let mut small = Box::new(Sim::<f64, 40, 8>::new());
    let err = Scenario::paper().build(&mut *small).unwrap_err();
    assert!(matches!(
        err,
        Error::CapacityExceeded {
            what: Capacity::Grains,
            capacity: 40
        }
    ));
}

#[test]
fn neighbour_capacity_overflow_is_an_error_not_a_dropped_contact() {
    let sc = Scenario::paper();
    let mut s = Box::new(Sim::<f64, 128, 1>::new());
    sc.build(&mut *s).unwrap();
    // Up to the first build that lists two neighbours of a grain (the
    // grains start apart and settle into contact).
    let err = s.run(3000).unwrap_err();
    assert_eq!(
        err,
        Error::CapacityExceeded {
            what: Capacity::NeighboursPerGrain,
            capacity: 1
        }
    );
}

#[test]
fn non_finite_and_out_of_range_inputs_are_named() {
    let cfg = config(1e-5, 1.0, 1e-4, 0.5);
    let mut s = small::<f64>(&cfg);
    let cases: [(GrainSpec, &str); 5] = [
        (mobile(f64::NAN, 0.0, 0.0, 0.0), "grain.x"),
        (mobile(cfg.width, 0.0, 0.0, 0.0), "grain.x"),
        (mobile(0.0, f64::INFINITY, 0.0, 0.0), "grain.y"),
        (mobile(0.0, 0.0, f64::NAN, 0.0), "grain.u"),
        (
            GrainSpec {
                diameter: -1.0,
                ..mobile(0.0, 0.0, 0.0, 0.0)
            },
            "grain.diameter",
        ),
    ];
    for (spec, field) in cases {
        match s.add_grain(&spec) {
            Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, field),
            other => panic!("{field}: {other:?}"),
        }
    }
    let bad = SimConfig {
        step_dt: f64::NAN,
        ..cfg
    };
    assert!(matches!(
        s.reset(&bad),
        Err(Error::InvalidParameter {
            name: "step_dt",
            ..
        })
    ));
    let msg = s
        .reset(&SimConfig { y_max: -1.0, ..cfg })
        .unwrap_err()
        .to_string();
    assert!(msg.contains("y_max") && msg.contains("must be"), "{msg}");
}

#[test]
fn time_step_beyond_the_stability_bound_is_refused() {
    let k_n = 1.0;
    let limit = 2.0 * (mass() / k_n).sqrt(); // docs/model.md (11)
    let mut s = small::<f64>(&config(1.01 * limit, k_n, 0.0, 0.5));
    let err = s.add_grain(&mobile(0.0, 0.0, 0.0, 0.0)).unwrap_err();
    assert!(
        matches!(
            err,
            Error::InvalidParameter {
                name: "step_dt",
                ..
            }
        ),
        "{err:?}"
    );
    let mut s = small::<f64>(&config(0.99 * limit, k_n, 0.0, 0.5));
    s.add_grain(&mobile(0.0, 0.0, 0.0, 0.0)).unwrap();
}

#[test]
fn overflowing_state_is_reported_with_step_and_grain() {
    let cfg = config(1e-5, 1.0, 1e-4, 0.5);
    let mut s = small::<f64>(&cfg);
    s.add_grain(&mobile(D, 0.0, 0.0, 0.0)).unwrap();
    s.add_grain(&mobile(5.0 * D, 0.0, 1e200, 0.0)).unwrap();
    let mut flow = FlowConfig::new(0.0, D);
    flow.spec.turbulence = false;
    s.set_flow(Some(&flow)).unwrap();
    // Drag ∝ |w|² overflows to infinity.
    let err = s.step().unwrap_err();
    assert_eq!(
        err,
        Error::NonFinite {
            step: 0,
            grain: 1,
            quantity: Quantity::Velocity
        }
    );
}

#[test]
fn leaving_the_domain_is_reported() {
    let cfg = config(1e-5, 1.0, 1e-4, 0.5);
    let mut s = small::<f32>(&cfg);
    s.add_grain(&mobile(D, cfg.y_max - 0.1 * D, 0.0, 100.0))
        .unwrap();
    match s.step() {
        Err(Error::LeftDomain {
            step: 0,
            grain: 0,
            y,
        }) => assert!(y > cfg.y_max),
        other => panic!("{other:?}"),
    }
}

#[test]
fn stepping_an_unconfigured_simulation_is_an_error() {
    let mut s = Box::new(Small::<f64>::new());
    assert!(matches!(
        s.step(),
        Err(Error::InvalidParameter { name: "sim", .. })
    ));
    assert!(s.add_grain(&mobile(0.0, 0.0, 0.0, 0.0)).is_err());
    assert_eq!(s.grain(0), None);
    assert_eq!(s.contact_history(7, 300), None);
    assert_eq!(s.fluctuation(1000), None);
}

#[test]
fn bad_bed_specs_are_named() {
    let sc = Scenario::paper();
    let cfg = sc.sim_config().unwrap();
    let mut s = Box::new(Small::<f64>::new());
    for (bed, name) in [
        (
            BedSpec {
                columns: 2,
                ..sc.bed.clone()
            },
            "bed.columns",
        ),
        (
            BedSpec {
                spacing: 0.9,
                ..sc.bed.clone()
            },
            "bed.spacing",
        ),
        (
            BedSpec {
                vacancy: 1.0,
                ..sc.bed.clone()
            },
            "bed.vacancy",
        ),
    ] {
        match s.build_bed(&cfg, &bed) {
            Err(Error::InvalidParameter { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{name}: {other:?}"),
        }
    }
}

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(-0.0),
        Just(0.0),
        Just(f64::MAX),
        -1.0..1.0f64,
        -1e-3..1e-2f64,
        any::<f64>(),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Arbitrary configurations, grains and flows never panic: each call
    /// returns Ok or a named error; a refused flow changes nothing, a
    /// failed step keeps the step count and a good one adds one.
    #[test]
    fn no_input_panics(
        dt in any_f64(), k_n in any_f64(), eta in any_f64(), mu in any_f64(), width in any_f64(),
        skin in any_f64(), gx in any_f64(),
        grains in proptest::collection::vec((any_f64(), any_f64(), any_f64(), any_f64(), any_f64(), any::<bool>(), any::<u8>()), 0..12),
        u_star in any_f64(), eps0 in any_f64(), hold in any::<u32>(), steps in 0u64..40,
    ) {
        let mut cfg = config(dt, k_n, eta, mu);
        cfg.width = width;
        cfg.skin = skin;
        cfg.gravity = [gx, -9.81];
        let mut s = Box::new(Sim::<f32, 16, 4>::new());
        let _ = s.reset(&cfg);
        for (x, y, u, v, d, fixed, class) in grains {
            let _ = s.add_grain(&GrainSpec { x, y, u, v, spin: 0.0, diameter: d, fixed, class });
        }
        let mut flow = FlowConfig::new(u_star, D);
        flow.spec.eps0 = eps0;
        flow.spec.hold_steps = IntegrationSteps(hold);
        let before = s.digest();
        if s.set_flow(Some(&flow)).is_err() {
            prop_assert_eq!(s.digest(), before, "a refused flow changes nothing");
        }
        for _ in 0..steps {
            let n = s.step_count();
            if s.step().is_err() {
                prop_assert_eq!(s.step_count(), n, "a failed step keeps the step count");
                break;
            }
            prop_assert_eq!(s.step_count(), n + 1);
        }
        let _ = (s.observe(), s.max_speed());
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    /// Valid configurations with arbitrary (possibly overlapping, fast,
    /// coincident) grains step without panicking, in both precisions.
    #[test]
    fn arbitrary_grains_step_without_panic(
        grains in proptest::collection::vec((0.0..1.0f64, 0.0..1.0f64, -1e3..1e3f64, -1e3..1e3f64, 0.1..2.0f64, any::<bool>()), 1..40),
        flow_on in any::<bool>(), steps in 1u64..200,
    ) {
        let cfg = config(1e-5, 1.0, 1e-4, 0.5);
        let mut a = Box::new(Sim::<f64, 64, 6>::new());
        let mut b = Box::new(Sim::<f32, 64, 6>::new());
        a.reset(&cfg).unwrap();
        b.reset(&cfg).unwrap();
        for &(x, y, u, v, d, fixed) in &grains {
            let spec = GrainSpec {
                x: x * cfg.width,
                y: cfg.y_min + y * (cfg.y_max - cfg.y_min),
                u, v, spin: u, diameter: d * D, fixed, class: 0,
            };
            let _ = a.add_grain(&spec);
            let _ = b.add_grain(&spec);
        }
        if flow_on {
            let flow = FlowConfig::new(0.05, D);
            a.set_flow(Some(&flow)).unwrap();
            b.set_flow(Some(&flow)).unwrap();
        }
        for _ in 0..steps {
            if a.step().is_err() { break; }
        }
        for _ in 0..steps {
            if b.step().is_err() { break; }
        }
        let o = a.observe();
        prop_assert!(o.contacts <= 64 * 6);
    }
}

/// Grains placed overlapping (up to 99.9 % of a diameter, stiff undamped
/// springs at half the stability bound) are pushed apart at once (the first
/// step's spring is k_n × overlap) and the state stays finite for thousands
/// of steps; a failure would be a named error, not NaN.
#[test]
fn grains_placed_overlapping_are_pushed_apart() {
    let k_n = 1.0e4;
    let dt = 0.5 * 2.0 * (mass() / k_n).sqrt();
    let cfg = config(dt, k_n, 0.0, 0.5);
    for overlap in [0.1, 0.5, 0.9, 0.999] {
        let mut s = small::<f64>(&cfg);
        let gap = (1.0 - overlap) * D;
        s.add_grain(&mobile(10.0 * D, 0.0, 0.0, 0.0)).unwrap();
        s.add_grain(&mobile(10.0 * D + gap, 0.0, 0.0, 0.0)).unwrap();
        s.step().unwrap();
        let (a, b) = (s.grain(0).unwrap(), s.grain(1).unwrap());
        assert!(
            b.x - a.x > gap && a.u < 0.0 && b.u > 0.0,
            "overlap {overlap}: {a:?} {b:?}"
        );
        if let Err(e) = s.run(5000) {
            panic!("overlap {overlap}: {e}");
        }
        for i in 0..2 {
            let g = s.grain(i).unwrap();
            assert!(g.x.is_finite() && g.y.is_finite() && g.u.is_finite() && g.v.is_finite());
        }
    }
}

/// Every grain lies in [0, width) in the simulation's own precision, as the
/// neighbour search and the mover assume: a position just below the width
/// that rounds to it in f32 is placed at the seam, and a checkpoint whose
/// grain stands at the width (in its precision) is refused.
#[test]
fn a_position_that_rounds_to_the_width_is_inside_the_domain() {
    let cfg = config(1e-5, 1.0, 1e-4, 0.5);
    let width = cfg.width as f32;
    assert!(f64::from(width) < cfg.width, "a width that f32 rounds down");
    let mut s = Box::new(Sim::<f32, 256, 8>::new());
    s.reset(&cfg).unwrap();
    let i = s
        .add_grain(&mobile(f64::from(width), 0.0, 0.0, 0.0))
        .unwrap();
    let x = s.grain(i).unwrap().x;
    assert!((0.0..f64::from(width)).contains(&x), "x = {x}");
    let marked = (10.5 * D) as f32;
    s.add_grain(&mobile(f64::from(marked), 0.0, 0.0, 0.0))
        .unwrap();
    let mut saved = Vec::new();
    s.checkpoint(|b| saved.extend_from_slice(b));
    let mut restored = Box::new(Sim::<f32, 256, 8>::new());
    restored.restore(&saved).unwrap();
    let bits = marked.to_le_bytes();
    let at = saved.windows(4).position(|w| w == bits).unwrap();
    saved[at..at + 4].copy_from_slice(&width.to_le_bytes());
    assert!(matches!(
        restored.restore(&saved),
        Err(Error::BadCheckpoint { .. })
    ));
}
