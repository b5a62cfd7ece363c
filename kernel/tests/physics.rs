//! The exact checks of docs/model.md §11, each for f32 and f64 (the argument of each
//! body is a precision-appropriate relative tolerance for exact identities).

pub mod common;

use common::*;
use mbs_kernel::{FlowConfig, Real, Sim};
use std::f64::consts::PI;

/// One head-on impact of two equal free grains (m_eff = m/2), g = 0.
/// Returns (restitution, contact time, max overlap).
fn impact<R: Real>(zeta: f64, dt: f64) -> (f64, f64, f64) {
    let k_n = 1.0;
    let m_eff = mass() / 2.0;
    let eta_n = zeta * 2.0 * (m_eff * k_n).sqrt();
    let cfg = config(dt, k_n, eta_n, 0.577);
    let mut s = small::<R>(&cfg);
    let v0 = 0.1; // approach speed
    let mid = cfg.width / 2.0;
    let gap = 2.5 * v0 * dt; // touch during the third step
    s.add_grain(&mobile(mid - 0.5 * D - gap / 2.0, 0.0, 0.5 * v0, 0.0))
        .unwrap();
    s.add_grain(&mobile(mid + 0.5 * D + gap / 2.0, 0.0, -0.5 * v0, 0.0))
        .unwrap();
    let (mut steps_in_contact, mut max_overlap, mut touched) = (0u32, 0.0f64, false);
    for _ in 0..100_000 {
        s.step().unwrap();
        if s.contact_history(0, 1).is_some() {
            touched = true;
            steps_in_contact += 1;
            max_overlap = max_overlap.max(s.observe().max_overlap);
        } else if touched {
            break;
        }
    }
    let (a, b) = (s.grain(0).unwrap(), s.grain(1).unwrap());
    ((b.u - a.u) / v0, steps_in_contact as f64 * dt, max_overlap)
}

fn restitution_and_contact_time<R: Real>(_tol: f64) {
    let k_n = 1.0f64;
    let m_eff = mass() / 2.0;
    let omega0 = (k_n / m_eff).sqrt();
    let t_free = PI / omega0;
    let mut err_coarse = 0.0;
    let mut err_fine = 0.0;
    for zeta in [0.0, 0.1, 0.3, 0.6] {
        let e_exact = (-PI * zeta / (1.0 - zeta * zeta).sqrt()).exp();
        let t_exact = t_free / (1.0 - zeta * zeta).sqrt();
        let mut errs = [0.0; 2];
        for (slot, per_contact) in [(0, 20.0), (1, 160.0)] {
            let dt = t_free / per_contact;
            let (e, t, _) = impact::<R>(zeta, dt);
            errs[slot] = (e - e_exact).abs() + ((t - t_exact) / t_exact).abs();
            if slot == 1 {
                assert!(
                    (e - e_exact).abs() < 0.01,
                    "zeta {zeta}: e = {e}, exact {e_exact}"
                );
                assert!(
                    ((t - t_exact) / t_exact).abs() < 0.02,
                    "zeta {zeta}: t_c = {t}, exact {t_exact}"
                );
            }
        }
        err_coarse += errs[0];
        err_fine += errs[1];
    }
    assert!(
        err_fine < 0.5 * err_coarse,
        "error must shrink with dt: {err_coarse} -> {err_fine}"
    );
}
both_precisions!(restitution, restitution_and_contact_time);

fn max_overlap_undamped<R: Real>(_tol: f64) {
    let m_eff = mass() / 2.0;
    let omega0 = (1.0 / m_eff).sqrt();
    let (e, _, overlap) = impact::<R>(0.0, PI / omega0 / 200.0);
    let exact = 0.1 / omega0;
    assert!(
        (overlap - exact).abs() < 0.01 * exact,
        "overlap {overlap}, exact {exact}"
    );
    assert!((e - 1.0).abs() < 0.01);
}
both_precisions!(max_overlap, max_overlap_undamped);

/// Total momentum of a free, damped, frictional collision is conserved.
fn momentum_in_free_collision<R: Real>(tol: f64) {
    let cfg = config(2e-5, 1.0, 2e-4, 0.577);
    let mut s = small::<R>(&cfg);
    let mid = cfg.width / 2.0;
    s.add_grain(&mobile(mid - 0.6 * D, 0.0, 0.08, 0.01))
        .unwrap();
    s.add_grain(&mobile(mid + 0.6 * D, 0.3 * D, -0.05, -0.02))
        .unwrap();
    s.add_grain(&mobile(mid, 1.4 * D, 0.0, -0.05)).unwrap();
    let p = |s: &Small<R>| {
        (0..3).fold((0.0, 0.0), |(px, py), i| {
            let g = s.grain(i).unwrap();
            (px + g.u, py + g.v) // equal masses
        })
    };
    let before = p(&s);
    let mut contacts = 0;
    for _ in 0..3000 {
        s.step().unwrap();
        contacts = contacts.max(s.observe().contacts);
    }
    let after = p(&s);
    assert!(contacts >= 1, "grains must collide");
    let scale = 0.1;
    assert!(
        (after.0 - before.0).abs() < 10.0 * tol * scale,
        "{before:?} -> {after:?}"
    );
    assert!(
        (after.1 - before.1).abs() < 10.0 * tol * scale,
        "{before:?} -> {after:?}"
    );
}
both_precisions!(momentum, momentum_in_free_collision);

/// Undamped, frictionless grains bouncing on a fixed row under gravity:
/// kinetic + potential + spring energy stays bounded over many impacts.
fn energy_bounded_without_damping<R: Real, const K: usize>(_tol: f64) {
    let k_n = 1.0;
    let dt = PI * (mass() / k_n).sqrt() / 100.0;
    let mut cfg = config(dt, k_n, 0.0, 0.0);
    cfg.gravity = [0.0, -9.81];
    cfg.width = 12.0 * 1.05 * D;
    let mut s = sim::<R, K>(&cfg);
    for k in 0..12 {
        s.add_grain(&fixed(k as f64 * 1.05 * D, 0.0)).unwrap();
    }
    for k in 0..12 {
        let x = (k as f64 + 0.5) * 1.05 * D;
        s.add_grain(&mobile(
            x,
            (1.5 + 0.3 * (k % 3) as f64) * D,
            0.01 * (k as f64 - 5.5),
            0.0,
        ))
        .unwrap();
    }
    let energy = |s: &Sim<R, 256, K>| {
        let o = s.observe();
        o.kinetic_energy + o.potential_energy + o.spring_energy
    };
    let e0 = energy(&s);
    let scale = s.observe().kinetic_energy.max(mass() * 9.81 * D);
    let mut worst: f64 = 0.0;
    let mut impacts = 0;
    let mut was_touching = false;
    for _ in 0..40_000 {
        s.step().unwrap();
        let o = s.observe();
        worst = worst.max((energy(&s) - e0).abs());
        let touching = o.contacts > 0;
        impacts += (touching && !was_touching) as u32;
        was_touching = touching;
    }
    assert!(impacts >= 10, "only {impacts} impacts");
    assert!(
        worst < 0.05 * 12.0 * scale,
        "energy drift {worst:e} vs scale {scale:e}"
    );
}
both_paths!(energy, energy_bounded_without_damping);

/// Single grain settling in still water: w(t) = w_t tanh(t/τ_s).
fn settling_velocity<R: Real, const K: usize>(_tol: f64) {
    let mut cfg = config(1e-5, 1.0, 0.0, 0.577);
    cfg.gravity = [0.0, -9.81];
    cfg.y_min = -1.0;
    cfg.y_max = 0.1;
    let mut s = sim::<R, K>(&cfg);
    s.add_grain(&mobile(cfg.width / 2.0, 0.0, 0.0, 0.0))
        .unwrap();
    let mut still = FlowConfig::new(0.0, D);
    still.spec.eps0 = 1.0;
    still.spec.turbulence = false;
    s.set_flow(Some(&still)).unwrap();
    let (sg, cd, cm, g) = (2.65, 0.4, 0.5, 9.81);
    let w_t = (4.0 * (sg - 1.0) * g * D / (3.0 * cd)).sqrt();
    let tau = w_t * (sg + cm) / ((sg - 1.0) * g);
    assert!((w_t - 0.1642).abs() < 1e-3 && (tau - 0.0320).abs() < 1e-3);
    for t_ms in [5.0, 20.0, 32.0, 60.0, 120.0] {
        let target = (t_ms * 1e-3 / cfg.step_dt).round() as u64;
        let done = s.step_count();
        s.run(target - done).unwrap();
        let w = -s.grain(0).unwrap().v;
        let exact = w_t * (s.time() / tau).tanh();
        assert!(
            (w - exact).abs() < 2e-3 * w_t,
            "t = {t_ms} ms: w = {w}, exact {exact}"
        );
    }
}
both_paths!(settling, settling_velocity);

/// A grain in the pocket of two touching fixed grains of its size, gravity
/// tilted by `theta_deg`, for at most 0.5 s: whether it rolled out (more
/// than 0.75 d sideways), and where it is. Stiff springs: the paper's
/// rule with β = 1 (k_n = 25 N/m, the pocket grain's overlap 5e-5 d, which
/// moves the pivot by ~3e-3°), integrated at Δt/8. The pocket lies near
/// x = 0 (coordinates ~d): in f32 a grain 20 d from the origin would not
/// move at the speeds it starts to roll with (a step's travel below half a
/// unit in the last place of x).
fn pocket_run<R: Real, const K: usize>(theta_deg: f64) -> (bool, mbs_kernel::GrainSpec, f64) {
    let mat = mbs_kernel::Material::default();
    let c = mbs_kernel::contact_constants(
        &mbs_kernel::TimeStepRule {
            alpha_m: 20.0,
            alpha_cn: 1.3,
            beta: 1.0,
            constants_dt: 2e-5,
        },
        D,
        &mat,
    )
    .unwrap();
    let mut cfg = config(2e-5 / 8.0, c.k_n, c.eta_n, mat.mu);
    cfg.contact = c;
    let th = theta_deg.to_radians();
    cfg.gravity = [9.81 * th.sin(), -9.81 * th.cos()];
    let mut s = sim::<R, K>(&cfg);
    let mid = D;
    s.add_grain(&fixed(mid - 0.5 * D, 0.0)).unwrap();
    s.add_grain(&fixed(mid + 0.5 * D, 0.0)).unwrap();
    s.add_grain(&mobile(mid, D * 3f64.sqrt() / 2.0, 0.0, 0.0))
        .unwrap();
    for _ in 0..(0.5 / cfg.step_dt) as u64 {
        s.step().unwrap();
        if (s.grain(2).unwrap().x - mid).abs() > 0.75 * D {
            return (true, s.grain(2).unwrap(), mid);
        }
    }
    (false, s.grain(2).unwrap(), mid)
}

/// A grain in the pocket of two touching fixed grains, gravity tilted by θ,
/// stays for θ below the 30° pivot angle (where gravity passes through the
/// downhill support) and rolls out above it: it stays at 25°, rolls out at
/// 35°, and bisection between them, five halvings, finds the pivot within
/// ±0.5° of 30° (the final bracket is 0.31° wide).
fn pocket_pivot<R: Real, const K: usize>(_tol: f64) {
    let (escaped, g, mid) = pocket_run::<R, K>(25.0);
    assert!(
        !escaped && (g.x - mid).abs() < 0.05 * D,
        "θ = 25°: moved to {}",
        g.x - mid
    );
    assert!(
        g.u.abs() < 1e-4 && g.v.abs() < 1e-4,
        "θ = 25°: still moving"
    );
    let (escaped, g, mid) = pocket_run::<R, K>(35.0);
    assert!(escaped, "θ = 35°: should roll out, at {}", g.x - mid);
    let (mut stays, mut rolls) = (25.0, 35.0);
    for _ in 0..5 {
        let theta = 0.5 * (stays + rolls);
        if pocket_run::<R, K>(theta).0 {
            rolls = theta;
        } else {
            stays = theta;
        }
    }
    assert!(
        stays >= 29.5 && rolls <= 30.5,
        "pivot between {stays}° and {rolls}°, not within ±0.5° of 30°"
    );
}
both_paths!(pocket, pocket_pivot);

/// A grain crossing x = L keeps its contact and history; contacts across
/// the seam are found; the collision equals the same one away from the seam;
/// on both step paths (the scalar one wraps by `periodic::periodic`).
fn periodic_seam<R: Real, const K: usize>(_tol: f64) {
    let cfg = config(1e-5, 1.0, 1e-4, 0.577);
    let run = |centre: f64| {
        let mut s = sim::<R, K>(&cfg);
        let wrap = |x: f64| x.rem_euclid(cfg.width);
        // An oblique collision (tangential history builds) drifting at +0.3 m/s,
        // the pair's normal along (0.6, 0.8), touching within a step.
        let drift = 0.3;
        let (hx, hy) = (0.3 * D * 1.0005, 0.4 * D * 1.0005);
        s.add_grain(&mobile(wrap(centre - hx), -hy, drift + 0.02, 0.05))
            .unwrap();
        s.add_grain(&mobile(wrap(centre + hx), hy, drift - 0.02, -0.05))
            .unwrap();
        let mut wrapped_in_contact = false;
        let mut last_x = s.grain(0).unwrap().x;
        let mut history_steps = 0;
        for _ in 0..600 {
            let before = s.contact_history(0, 1);
            s.step().unwrap();
            let x = s.grain(0).unwrap().x;
            if x < last_x {
                // grain 0 crossed the seam during this step
                if let (Some(a), Some(b)) = (before, s.contact_history(0, 1)) {
                    wrapped_in_contact = true;
                    assert!(
                        a.1 != 0.0 && b.1 != 0.0,
                        "tangential history carried: {a:?} -> {b:?}"
                    );
                }
            }
            history_steps += s.contact_history(0, 1).is_some() as u32;
            last_x = x;
        }
        let (a, b) = (s.grain(0).unwrap(), s.grain(1).unwrap());
        (
            a.u,
            a.v,
            a.spin,
            b.u,
            b.v,
            b.spin,
            wrapped_in_contact,
            history_steps,
        )
    };
    // Centred on the seam: grain 0 starts 0.3 d left of it and crosses it
    // about halfway through the ~1 ms contact.
    let at_seam = run(cfg.width);
    let away = run(cfg.width / 2.0);
    assert!(at_seam.7 > 20, "contact lasted {} steps", at_seam.7);
    assert!(
        at_seam.7.abs_diff(away.7) <= 1,
        "same contact duration: {} vs {}",
        at_seam.7,
        away.7
    );
    assert!(at_seam.6, "grain 0 must cross the seam while in contact");
    let pairs = [
        (at_seam.0, away.0),
        (at_seam.1, away.1),
        (at_seam.3, away.3),
        (at_seam.4, away.4),
    ];
    for (p, q) in pairs {
        assert!((p - q).abs() < 1e-3 * 0.05, "seam {p} vs away {q}");
    }
    assert!(
        at_seam.2 != 0.0 && (at_seam.2 - away.2).abs() < 1e-3 * away.2.abs(),
        "spin {} vs {}",
        at_seam.2,
        away.2
    );

    // A static overlap straddling the seam is found on the first step.
    let mut s = sim::<R, K>(&cfg);
    s.add_grain(&mobile(0.2 * D, 0.0, 0.0, 0.0)).unwrap();
    s.add_grain(&mobile(cfg.width - 0.75 * D, 0.0, 0.0, 0.0))
        .unwrap();
    s.step().unwrap();
    assert!(s.contact_history(0, 1).is_some(), "contact across the seam");
    assert!(
        s.grain(0).unwrap().u > 0.0 && s.grain(1).unwrap().u < 0.0,
        "pushed apart across the seam"
    );
}
both_paths!(seam, periodic_seam);

/// Sample mean and rms of the fluctuations (15) within statistical bounds,
/// held for `hold_steps` and redrawn after.
fn turbulence_statistics<R: Real, const K: usize>(_tol: f64) {
    let mut cfg = config(2e-5, 1.0, 1e-4, 0.577);
    cfg.width = 250.0 * D;
    let mut s = sim::<R, K>(&cfg);
    let heights = [2.0 * D, 20.0 * D];
    for k in 0..250 {
        let y = heights[k % 2];
        s.add_grain(&mobile((k as f64 + 0.5) * D, y, 0.0, 0.0))
            .unwrap();
    }
    let u_star = 0.03;
    let flow = FlowConfig::new(u_star, D);
    s.set_flow(Some(&flow)).unwrap();
    let mut sums = [[0.0f64; 4]; 2];
    let mut n = [0.0f64; 2];
    for period in 0..16 {
        s.step().unwrap();
        let first: Vec<_> = (0..250).map(|i| s.fluctuation(i).unwrap()).collect();
        s.run(u64::from(flow.spec.hold_steps) - 1).unwrap();
        for (i, &(u0, _)) in first.iter().enumerate() {
            let g = s.grain(i).unwrap();
            let (u, v) = s.fluctuation(i).unwrap();
            // Held: the draws are unchanged, only the height-dependent rms moves.
            assert!(
                u0 == 0.0 || (u / u0 - 1.0).abs() < 0.05,
                "held within the period {period}"
            );
            let decay = (-(g.y - s.bed_level()) / flow.spec.depth).exp();
            let c = i % 2;
            let (zu, zv) = (u / (2.30 * u_star * decay), v / (1.27 * u_star * decay));
            sums[c][0] += zu;
            sums[c][1] += zu * zu;
            sums[c][2] += zv;
            sums[c][3] += zv * zv;
            n[c] += 1.0;
        }
    }
    for c in 0..2 {
        let m = n[c];
        for (mean, sq) in [
            (sums[c][0] / m, sums[c][1] / m),
            (sums[c][2] / m, sums[c][3] / m),
        ] {
            assert!(mean.abs() < 5.0 / m.sqrt(), "mean {mean} over {m}");
            assert!(
                (sq.sqrt() - 1.0).abs() < 5.0 / (2.0 * m).sqrt(),
                "rms/expected {}",
                sq.sqrt()
            );
        }
    }
    // A new period brings new draws.
    let a = s.fluctuation(0).unwrap();
    s.run(u64::from(flow.spec.hold_steps)).unwrap();
    assert_ne!(a, s.fluctuation(0).unwrap());
}
both_paths!(turbulence, turbulence_statistics);

/// A grain at rest on a fixed grain, and one on it, carry their weights on
/// their contacts ([`Sim::contact_forces`]): the lower contact the two
/// grains' submerged weights, the upper one the top grain's, along the
/// branch, to 1e-6 in f64.
fn resting_column<R: Real>(tol: f64) {
    let mut c = config(1e-5, 1e3, 2e-3, 0.5);
    c.gravity = [0.0, -9.81];
    let mut sim = Box::new(Sim::<R, 8, 4>::new());
    sim.reset(&c).unwrap();
    let fixed = mbs_kernel::GrainSpec {
        fixed: true,
        ..mobile(10.0 * D, 0.0, 0.0, 0.0)
    };
    sim.add_grain(&fixed).unwrap();
    sim.add_grain(&mobile(10.0 * D, 0.99 * D, 0.0, 0.0))
        .unwrap();
    sim.add_grain(&mobile(10.0 * D, 1.98 * D, 0.0, 0.0))
        .unwrap();
    sim.run(200_000).unwrap();
    let m = &c.material;
    let weight = m.rho * (m.s - 1.0) * PI / 6.0 * D * D * D * 9.81;
    let mut forces = Vec::new();
    sim.contact_forces(|f| forces.push(f));
    assert_eq!(forces.len(), 2, "{forces:?}");
    for (f, (i, j, load)) in forces.iter().zip([(0, 1, 2.0), (1, 2, 1.0)]) {
        assert_eq!((f.i, f.j), (i, j));
        assert!(f.branch[0].abs() < 1e-12 && f.branch[1] > 0.9 * D, "{f:?}");
        // The lower grain is pushed down by the one above.
        let off = (f.force[1] + load * weight).abs() / weight;
        assert!(
            off < tol && f.force[0].abs() < tol * weight,
            "{f:?}: {off:e}"
        );
    }
}

#[test]
fn contacts_carry_the_weight_of_a_resting_column() {
    resting_column::<f64>(1e-6);
    resting_column::<f32>(1e-3);
}
