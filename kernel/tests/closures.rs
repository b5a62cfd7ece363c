//! The free surface and HydroForceEngine's closures in a coupled `Sim`
//! (docs/model.md §2, (C8)–(C10)): a grain out of the water flies the
//! ballistic parabola, Dallavalle's drag is its formula, the discrete
//! random walk has its amplitudes and correlation and stops below the bed,
//! and restarts continue bit for bit, in f32 and f64.

pub mod common;

use common::{assert_resumes, config, mobile, D};
use mbs_kernel::fluid::FluidConfig;
use mbs_kernel::{
    DragLaw, FlowConfig, FlowModel, Fluctuations, GrainSpec, IntegrationSteps, Real, Scenario, Sim,
};

/// A coupled flow over `width` (m) of slice one `D` thick: a column of
/// `cells` from `bottom` to the free surface `surface`, driven by
/// u* = 3 cm/s over the depth, no hindrance.
fn flow(width: f64, bottom: f64, surface: f64, cells: usize) -> FlowConfig {
    let u_star = 0.03;
    let mut flow = FlowConfig::new(u_star, D);
    flow.spec.depth = surface;
    let mut fluid = FluidConfig::new(cells, bottom, surface, width * D);
    fluid.driving = FluidConfig::driving_for(u_star, surface - bottom);
    (flow.spec.model, flow.fluid) = (FlowModel::Coupled, fluid);
    flow
}

/// A grain thrown up through the free surface of a coupled flow (on a
/// slope θ): while its centre is above the surface it feels no drag, no
/// buoyancy and no added mass, so each step changes its velocity by
/// exactly (g sin θ, −g cos θ) step_dt and its heights follow the
/// symplectic Euler parabola y_k = y_0 + k v_0 dt − g cos θ dt² k(k+1)/2,
/// to rounding; it then falls back into the water.
fn ballistic<R: Real>(tol: f64) {
    let g = 9.81;
    for slope in [0.0, 0.1] {
        let mut c = config(1e-5, 1e3, 0.0, 0.5);
        (c.gravity, c.slope_angle, c.surface) = ([0.0, -g], slope, 50.0 * D);
        let mut sim = Box::new(Sim::<R, 8, 4, 128>::new());
        sim.reset(&c).unwrap();
        sim.add_grain(&mobile(10.0 * D, 49.5 * D, 0.1, 0.3))
            .unwrap();
        sim.set_flow(Some(&flow(40.0, 0.0, c.surface, 100)))
            .unwrap();
        let (ax, ay) = (g * libm::sin(slope), -g * libm::cos(slope));
        let dt = c.step_dt;
        let (mut aloft, mut back) = (0, false);
        let mut launch: Option<GrainSpec> = None;
        for _ in 0..20_000 {
            let before = sim.grain(0).unwrap();
            sim.step().unwrap();
            let after = sim.grain(0).unwrap();
            if before.y > c.surface {
                let top = *launch.get_or_insert(before);
                aloft += 1;
                let du = (after.u - before.u - ax * dt) / (g * dt);
                let dv = (after.v - before.v - ay * dt) / (g * dt);
                assert!(
                    du.abs() < tol && dv.abs() < tol,
                    "step {aloft}: {du:e} {dv:e}"
                );
                let k = aloft as f64;
                let parabola = top.y + k * top.v * dt + ay * dt * dt * k * (k + 1.0) / 2.0;
                let off = (after.y - parabola) / (top.y - c.y_min);
                assert!(off.abs() < tol, "step {aloft}: y off by {off:e}");
            } else if aloft > 0 {
                back = true;
                break;
            }
        }
        assert!(aloft > 1000, "{} steps out of the water", aloft);
        assert!(back, "fell back into the water");
    }
}

#[test]
fn a_grain_out_of_the_water_flies_a_parabola() {
    ballistic::<f64>(1e-9);
    ballistic::<f32>(2e-3);
}

/// A grain held at a fluid cell's centre, without gravity or fluctuations:
/// its first step's velocity is the drag over m' times step_dt, the drag
/// being ½ρ(π/4)d²(0.44|u_f| + 24.4ν/d) u_f with Dallavalle's law and
/// ½ρ C_D (π/4) d² |u_f| u_f with the paper's, u_f the column's at the
/// centre.
fn drag_laws<R: Real>(tol: f64) {
    for law in [DragLaw::Paper, DragLaw::Dallavalle] {
        let c = config(1e-5, 1e3, 0.0, 0.5);
        let mut sim = Box::new(Sim::<R, 8, 4, 128>::new());
        sim.reset(&c).unwrap();
        // Cells of D/2 from 0: centre 40 is at 20.25 D.
        sim.add_grain(&mobile(10.0 * D, 20.25 * D, 0.0, 0.0))
            .unwrap();
        let mut f = flow(40.0, 0.0, 50.0 * D, 100);
        (f.spec.turbulence, f.fluid.spec.drag) = (false, law);
        sim.set_flow(Some(&f)).unwrap();
        let u_f = sim.fluid_column().unwrap().velocities()[40].to_f64();
        sim.step().unwrap();
        let grain = sim.grain(0).unwrap();
        let force = grain.u * c.material.translational_mass(D) / c.step_dt;
        let (m, nu) = (&c.material, f.fluid.spec.viscosity);
        let area = std::f64::consts::FRAC_PI_4 * D * D;
        let expect = match law {
            DragLaw::Paper => 0.5 * m.rho * m.c_d * area * u_f.abs() * u_f,
            DragLaw::Dallavalle => 0.5 * m.rho * area * (0.44 * u_f.abs() + 24.4 * nu / D) * u_f,
        };
        assert!(u_f > 0.1, "u_f {u_f}");
        let error = (force - expect).abs() / expect;
        assert!(
            error < tol,
            "{law:?}: {force:e} N vs {expect:e} N ({error:e})"
        );
        assert_eq!(grain.v, 0.0);
    }
}

/// A grain at a fluid cell's centre moving downstream at `u` in a
/// channel, without gravity or draws, once without and once with the
/// grains' wall friction μ_w = 0.4 (C11), a step of `dt`: the difference
/// of their first steps is −μ_w √(2/π) Ξ u*_loc, Ξ Dallavalle's drag
/// factor (C8) and u*_loc the random walk's scale at the centre, within
/// `tol`; at rest a grain feels none. At 0.3 m/s and 1e-5 s the
/// difference is about 7e-11 m/s on 0.3 m/s (1e-6 in f64, far below f32's
/// resolution); the friction is the same above the slip speed
/// (`WALL_SLIP`, 1 mm/s), so a grain at 2 mm/s over 1e-2 s shows it in
/// f32 within 0.8 % (its velocity's last bits). A lone grain has no
/// contact: its k_n is only small enough for the step's stability bound.
fn grain_wall_friction<R: Real>(u: f64, dt: f64, tol: f64) {
    let step = |mu: f64, u: f64| {
        let c = config(dt, 1e-3, 0.0, 0.5);
        let mut sim = Box::new(Sim::<R, 8, 4, 128>::new());
        sim.reset(&c).unwrap();
        sim.add_grain(&mobile(10.0 * D, 20.25 * D, u, 0.0)).unwrap();
        let mut f = flow(40.0, 0.0, 50.0 * D, 100);
        f.spec.turbulence = false;
        let s = &mut f.fluid.spec;
        (s.drag, s.fluctuations, s.channel_width) = (DragLaw::Dallavalle, Fluctuations::Hfe, D);
        s.grain_wall_friction = mu;
        sim.set_flow(Some(&f)).unwrap();
        let column = sim.fluid_column().unwrap();
        let (u_f, grid) = (column.velocities()[40].to_f64(), column.grid());
        let scale = column.shear_velocity_at(grid.centre(40)).to_f64();
        sim.step().unwrap();
        let force = (sim.grain(0).unwrap().u - u) * c.material.translational_mass(D) / c.step_dt;
        (force, u_f, scale, f.fluid.spec.viscosity)
    };
    let (free, u_f, scale, nu) = step(0.0, u);
    let (held, ..) = step(0.4, u);
    let rho = 1000.0;
    let xi =
        0.5 * rho * std::f64::consts::FRAC_PI_4 * D * D * (0.44 * (u_f - u).abs() + 24.4 * nu / D);
    let expect = -0.4 * (2.0 / std::f64::consts::PI).sqrt() * xi * scale;
    assert!(scale > 0.0 && expect < 0.0);
    let error = (held - free - expect).abs() / expect.abs();
    assert!(error < tol, "{} N vs {expect} N ({error:e})", held - free);
    assert!(held <= free);
    let (at_rest, ..) = step(0.4, 0.0);
    let (drag_only, ..) = step(0.0, 0.0);
    assert_eq!(at_rest, drag_only, "no wall friction at rest");
}

#[test]
fn grains_rub_on_the_walls() {
    grain_wall_friction::<f64>(0.3, 1e-5, 1e-6);
    grain_wall_friction::<f64>(2e-3, 1e-2, 1e-6);
    grain_wall_friction::<f32>(2e-3, 1e-2, 2e-2);
}

/// As [`grain_wall_friction`] under gravity, with a row of grains 2 d
/// above the one moving at `u` (a step of `dt`), once with Janssen's
/// ratio K = 0.5 of the overburden's load (C12) and once without: the
/// difference of their first steps is −μ_w 2 K σ π r², σ = (ρ_p − ρ_f) g
/// Σ φ Δy over the cells above the grain's centre (half its own), from
/// the column's φ; within `tol`. K = 0 leaves the bits of (C11) alone.
fn overburden_friction<R: Real>(u: f64, dt: f64, tol: f64) {
    let g = 9.81;
    let step = |ratio: f64, u: f64| {
        let mut c = config(dt, 1e-3, 0.0, 0.5);
        c.gravity = [0.0, -g];
        let mut sim = Box::new(Sim::<R, 64, 4, 128>::new());
        sim.reset(&c).unwrap();
        sim.add_grain(&mobile(10.0 * D, 20.25 * D, u, 0.0)).unwrap();
        for k in 0..40 {
            let above = mobile((k as f64 + 0.5) * D, 22.25 * D, 0.0, 0.0);
            sim.add_grain(&above).unwrap();
        }
        let mut f = flow(40.0, 0.0, 50.0 * D, 100);
        f.spec.turbulence = false;
        let s = &mut f.fluid.spec;
        (s.drag, s.fluctuations, s.channel_width) = (DragLaw::Dallavalle, Fluctuations::Hfe, D);
        (s.grain_wall_friction, s.lateral_ratio) = (0.4, ratio);
        sim.set_flow(Some(&f)).unwrap();
        let column = sim.fluid_column().unwrap();
        let dy = column.grid().dy().to_f64();
        let phi: Vec<f64> = column
            .solid_fractions()
            .iter()
            .map(|p| p.to_f64())
            .collect();
        let above = phi[41..].iter().sum::<f64>() * dy + 0.5 * phi[40] * dy;
        sim.step().unwrap();
        let force = (sim.grain(0).unwrap().u - u) * c.material.translational_mass(D) / c.step_dt;
        let sigma = c.material.rho * (c.material.s - 1.0) * g * above;
        (force, sigma)
    };
    let (without, sigma) = step(0.0, u);
    let (with, _) = step(0.5, u);
    let expect = -0.4 * 2.0 * 0.5 * sigma * std::f64::consts::PI * D * D / 4.0;
    assert!(sigma > 0.0);
    let error = (with - without - expect).abs() / expect.abs();
    assert!(
        error < tol,
        "{} N vs {expect} N ({error:e})",
        with - without
    );
    assert!(with <= without);
    assert_eq!(step(0.5, 0.0).0, step(0.0, 0.0).0, "none at rest");
}

#[test]
fn grains_rub_on_the_walls_under_their_overburden() {
    overburden_friction::<f64>(0.3, 1e-5, 1e-6);
    overburden_friction::<f64>(2e-3, 1e-2, 1e-6);
    overburden_friction::<f32>(2e-3, 1e-2, 1e-3);
}

#[test]
fn dallavalle_drag_is_its_formula() {
    drag_laws::<f64>(1e-12);
    drag_laws::<f32>(1e-5);
}

/// The statistics of the discrete random walk (C9), from 2 048 grains held
/// at one cell centre 20 d above a row of fixed grains (the bed level)
/// over 12 redraws: rms u' = √2 u*_loc, rms v' = u*_loc and their
/// correlation −1/√2, each within 2 % (u*_loc the column's at the
/// centre); none on grains below the bed level; none out of the water.
/// With the paper's (15) the rms are (2.30, 1.27) u*_loc exp(−y/h), and
/// grains below the bed level fluctuate.
fn random_walk<R: Real>() {
    for model in [Fluctuations::Hfe, Fluctuations::Paper] {
        // Grains a billion times denser than water: the drag leaves them
        // where they are, at the heights whose u*_loc is known.
        let mut c = config(1e-4, 1e3, 0.0, 0.5);
        c.material.s = 1e9;
        let across = 2048;
        (c.width, c.y_min, c.y_max, c.surface) =
            (across as f64 * D, -20.0 * D, 200.0 * D, 50.0 * D);
        let mut sim = Box::new(Sim::<R, 4200, 4, 128>::new());
        sim.reset(&c).unwrap();
        for k in 0..across {
            let x = (k as f64 + 0.5) * D;
            let fixed = GrainSpec {
                fixed: true,
                ..mobile(x, 0.0, 0.0, 0.0)
            };
            sim.add_grain(&fixed).unwrap();
        }
        // Centre 60 of cells of D/2 from −10 D: 20.25 D; centre 15: −2.25 D.
        let (high, low) = (20.25 * D, -2.25 * D);
        for k in 0..across {
            sim.add_grain(&mobile((k as f64 + 0.5) * D, high, 0.0, 0.0))
                .unwrap();
        }
        let first_low = sim.len();
        for k in 0..64 {
            sim.add_grain(&mobile((32.0 * k as f64 + 0.2) * D, low, 0.0, 0.0))
                .unwrap();
        }
        let aloft = sim.len();
        sim.add_grain(&mobile(0.7 * D, 51.0 * D, 0.0, 0.0)).unwrap();
        let mut f = flow(across as f64, -10.0 * D, c.surface, 120);
        f.fluid.spec.fluctuations = model;
        f.spec.hold_steps = IntegrationSteps(400);
        sim.set_flow(Some(&f)).unwrap();
        assert!(
            sim.bed_level().abs() < 1e-12,
            "bed level {}",
            sim.bed_level()
        );
        let (mut uu, mut vv, mut uv, mut n) = (0.0, 0.0, 0.0, 0.0);
        let mut low_moves = false;
        let mut periods = 0;
        let mut redraws = sim.events().turbulence_redraws;
        while periods < 12 {
            sim.step().unwrap();
            if sim.events().turbulence_redraws == redraws {
                continue;
            }
            redraws = sim.events().turbulence_redraws;
            periods += 1;
            let column = sim.fluid_column().unwrap();
            let scale = column.shear_velocity_at(R::from_f64(high)).to_f64();
            let decay = match model {
                Fluctuations::Hfe => 1.0,
                Fluctuations::Paper => libm::exp(-(high - sim.bed_level()) / c.surface),
            };
            for i in across..first_low {
                let (u, v) = sim.fluctuation(i).unwrap();
                let s = scale * decay;
                (uu, vv, uv, n) = (
                    uu + u * u / (s * s),
                    vv + v * v / (s * s),
                    uv + u * v / (s * s),
                    n + 1.0,
                );
            }
            for i in first_low..aloft {
                low_moves |= sim.fluctuation(i).unwrap() != (0.0, 0.0);
            }
            assert_eq!(sim.fluctuation(aloft), Some((0.0, 0.0)), "out of the water");
        }
        let (rms_u, rms_v) = ((uu / n).sqrt(), (vv / n).sqrt());
        let correlation = uv / n / (rms_u * rms_v);
        std::println!(
            "{} {model:?}: {n} draws, rms u' {rms_u:.4}, rms v' {rms_v:.4}, correlation {correlation:.4}",
            R::NAME
        );
        let (target_u, target_v, target_r) = match model {
            Fluctuations::Hfe => (2f64.sqrt(), 1.0, -std::f64::consts::FRAC_1_SQRT_2),
            Fluctuations::Paper => (2.30, 1.27, 0.0),
        };
        assert!((rms_u / target_u - 1.0).abs() < 0.02, "rms u' {rms_u}");
        assert!((rms_v / target_v - 1.0).abs() < 0.02, "rms v' {rms_v}");
        assert!(
            (correlation - target_r).abs() < 0.02,
            "correlation {correlation}"
        );
        assert_eq!(low_moves, model == Fluctuations::Paper, "below the bed");
    }
}

#[test]
fn hfe_fluctuations_have_their_statistics() {
    random_walk::<f64>();
}

/// The fluctuation a step applies is the one `Sim::fluctuation` reports
/// (the statistics above read the latter): without gravity, contacts or
/// walls, a grain's velocity change over a step is its drag over its
/// mass, and the drag is a positive factor times the velocity relative to
/// the fluid, (u_f + u′ − u_p, v′ − v_p) (C7)–(C9): the change is parallel
/// to it, for either fluctuation model, on both step paths (8 slots:
/// batched where there are lanes; 6: scalar).
fn applied_fluctuation<R: Real, const K: usize>() {
    for model in [Fluctuations::Hfe, Fluctuations::Paper] {
        let mut c = config(1e-5, 1e3, 0.0, 0.5);
        let across = 64;
        (c.width, c.y_min, c.y_max, c.surface) =
            (across as f64 * 2.0 * D, -20.0 * D, 200.0 * D, 50.0 * D);
        let mut sim = Box::new(Sim::<R, 256, K, 128>::new());
        sim.reset(&c).unwrap();
        // Two diameters apart: no contacts.
        for k in 0..across {
            let y = (2.0 + 0.3 * (k % 50) as f64) * D;
            sim.add_grain(&mobile((2.0 * k as f64 + 0.5) * D, y, 0.0, 0.0))
                .unwrap();
        }
        let mut f = flow(2.0 * across as f64, -10.0 * D, c.surface, 120);
        f.fluid.spec.fluctuations = model;
        f.spec.hold_steps = IntegrationSteps(50);
        sim.set_flow(Some(&f)).unwrap();
        let mut checked = 0;
        let column = |sim: &Sim<R, 256, K, 128>| sim.fluid_column().unwrap().velocities().to_vec();
        for _ in 0..400 {
            let (redraws, before_column) = (sim.events().turbulence_redraws, column(&sim));
            let before: Vec<GrainSpec> = (0..across).map(|i| sim.grain(i).unwrap()).collect();
            let held: Vec<(f64, f64)> = (0..across).map(|i| sim.fluctuation(i).unwrap()).collect();
            sim.step().unwrap();
            // Steps that neither redraw nor update the column: the draws
            // and u_f read before the step are the ones it used.
            if sim.events().turbulence_redraws != redraws || column(&sim) != before_column {
                continue;
            }
            let fluid = sim.fluid_column().unwrap();
            for (i, (b, &(fu, fv))) in before.iter().zip(&held).enumerate() {
                let a = sim.grain(i).unwrap();
                let u_f = fluid.velocity_at(R::from_f64(b.y)).to_f64();
                let (wx, wy) = (u_f + fu - b.u, fv - b.v);
                let (du, dv) = (a.u - b.u, a.v - b.v);
                let cross = du * wy - dv * wx;
                let scale = (du * du + dv * dv).sqrt() * (wx * wx + wy * wy).sqrt();
                assert!(
                    cross.abs() <= 1e-3 * scale && du * wx + dv * wy > 0.0,
                    "{} {model:?} grain {i}: change ({du:e}, {dv:e}) against relative velocity ({wx:e}, {wy:e})",
                    R::NAME
                );
                checked += usize::from(fv != 0.0);
            }
        }
        assert!(
            checked > 1000,
            "{checked} grains with a fluctuation checked"
        );
    }
}

#[test]
fn the_step_applies_the_fluctuation_it_reports() {
    applied_fluctuation::<f64, 8>();
    applied_fluctuation::<f64, 6>();
    applied_fluctuation::<f32, 8>();
}

/// The paper's bed under 12 d of water at τ* = 0.6 with every
/// HydroForceEngine closure, grains leaving the water (the golden coupled
/// scenario with a shallow surface), settled `settle` steps and run `flow`.
fn shallow_run<R: Real, const K: usize, const C: usize>(
    settle: u64,
    flow: u64,
) -> Box<Sim<R, 64, K, C>> {
    let mut sc = Scenario::paper_coupled();
    let d = sc.bed.max_diameter();
    sc.flow.depth = 12.0 * d;
    sc.fluid_cell_height = 0.5 * d;
    sc.fluid.drag = DragLaw::Dallavalle;
    sc.fluid.fluctuations = Fluctuations::Hfe;
    sc.fluid.channel_width = 1.1 * d;
    sc.fluid.grain_wall_friction = 0.4;
    sc.fluid.lateral_ratio = 0.5;
    let mut sim = Box::new(Sim::<R, 64, K, C>::new());
    sc.build(&mut *sim).unwrap();
    sim.run(settle).unwrap();
    sim.set_flow(Some(&sc.flow(0.6))).unwrap();
    sim.run(flow).unwrap();
    sim
}

/// With every closure on, a run stopped anywhere (before and after
/// redraws of the random walk and updates of the column) and restored into
/// other capacities continues bit for bit; the side walls (with the
/// overburden's load, C12), the laws and the redraw schedule come back
/// from the checkpoint.
fn resume<R: Real>() {
    for flow in [0, 1, 77, 300, 1234] {
        let mut whole = shallow_run::<R, 8, 64>(1500, flow);
        let mut resumed = Box::new(Sim::<R, 128, 10, 900>::new());
        assert_resumes(&mut *whole, &mut resumed, 1500, flow);
    }
}

#[test]
fn closures_restart_bit_identical() {
    resume::<f64>();
    resume::<f32>();
}
