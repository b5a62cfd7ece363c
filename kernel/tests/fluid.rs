//! The coupled flow's column (docs/model.md §13): exact slice volumes, the
//! tridiagonal solve, the rough-wall log law, the momentum balance with a
//! drag sink, bit-reproducibility and errors, in f32 and f64.

use mbs_kernel::fluid::{slice_volume, Column, FluidConfig, Slabs, Tridiagonal};
use mbs_kernel::{Capacity, Error, Fnv1a, Real};
use std::f64::consts::PI;

/// Grain diameter (m).
const D: f64 = 0.5e-3;
/// Capacity of the test columns.
const CAP: usize = 512;
/// Grains across the periodic width: slabs of (20 D) × D.
const ACROSS: usize = 20;
/// Water density (kg/m³) and the drag coefficient C_D of docs/model.md §1.
const RHO: f64 = 1000.0;
const C_D: f64 = 0.4;

type Col<R> = Column<R, CAP>;

/// A column from 0 (the bottom of a row of fixed grains of diameter D) to a
/// depth `h` of water above their centres (the mean bed level, D/2), in
/// cells of D/2, driven by u* over h.
fn rough_config(h: f64, u_star: f64) -> FluidConfig {
    let cells = ((h + 0.5 * D) / (0.5 * D)).round() as usize;
    let mut c = FluidConfig::new(cells, 0.0, 0.5 * D + h, ACROSS as f64 * D * D);
    c.driving = FluidConfig::driving_for(u_star, h);
    c
}

/// One step of `dt` of the column over the fixed rough bed of [`run_rough`].
fn rough_step<R: Real>(column: &mut Col<R>, slabs: &mut Slabs<R, CAP>, dt: f64) {
    let coef = 0.5 * RHO * C_D * PI / 4.0 * D * D;
    slabs.clear(column.grid()).unwrap();
    let y = R::from_f64(0.5 * D);
    let xi = R::from_f64(coef) * R::abs(column.velocity_at(y));
    for _ in 0..ACROSS {
        slabs
            .add_grain(y, R::from_f64(0.5 * D), R::ZERO, xi)
            .unwrap();
    }
    column.advance(slabs, R::from_f64(dt)).unwrap();
}

/// Runs `steps` steps of `dt` of the column over the fixed rough bed: one row
/// of ACROSS touching grains centred at D/2, at rest, each with the drag
/// factor ½ ρ C_D (π/4) D² |u_f| of the flow at its centre (docs/model.md (5)
/// without sheltering), recomputed before each step. Returns the column and
/// the largest change of a velocity in the last step (m/s).
fn run_rough<R: Real>(config: &FluidConfig, steps: usize, dt: f64) -> (Box<Col<R>>, f64) {
    let mut column = Box::new(Col::<R>::new());
    column.reset(config).unwrap();
    let mut slabs = Box::new(Slabs::<R, CAP>::new());
    let mut change = 0.0f64;
    for _ in 0..steps {
        let before: Vec<R> = column.velocities().to_vec();
        rough_step(&mut column, &mut slabs, dt);
        change = before
            .iter()
            .zip(column.velocities())
            .map(|(a, b)| (b.to_f64() - a.to_f64()).abs())
            .fold(0.0, f64::max);
    }
    (column, change)
}

/// The largest relative error of u_f against docs/model.md (14) with
/// roughness `k_sr`, over the cells in the outer 80 % of the depth h above
/// the bed level D/2.
fn log_law_error<R: Real>(column: &Col<R>, h: f64, u_star: f64, k_sr: f64) -> f64 {
    let grid = column.grid();
    let mut worst = 0.0f64;
    for (j, &u) in column.velocities().iter().enumerate() {
        let y = grid.centre(j).to_f64() - 0.5 * D;
        if y >= 0.2 * h {
            let log = u_star / 0.4 * (30.1 * (y + 0.25 * D) / k_sr).ln();
            worst = worst.max((u.to_f64() - log).abs() / log);
        }
    }
    worst
}

/// The roughness k_sr of (14) that fits the profile over the outer 80 % in
/// the mean of ln(30.1 (y + D/4)) − κ u/u*.
fn fitted_roughness<R: Real>(column: &Col<R>, h: f64, u_star: f64) -> f64 {
    let grid = column.grid();
    let (mut sum, mut count) = (0.0, 0.0);
    for (j, &u) in column.velocities().iter().enumerate() {
        let y = grid.centre(j).to_f64() - 0.5 * D;
        if y >= 0.2 * h {
            sum += (30.1 * (y + 0.25 * D)).ln() - 0.4 * u.to_f64() / u_star;
            count += 1.0;
        }
    }
    (sum / count).exp()
}

/// With no mobile grains the steady profile at shear velocity `u_star` is
/// the log law (14) over the outer 80 % of the depth: within 2 % with the
/// roughness that fits it best, a roughness of the order of d (the wall is
/// hydraulically transitional, k_sr u*/ν = 6–40, so it varies with u*), and
/// at u* = 3 cm/s within 2 % of (14) with the paper's k_sr = d too.
/// `steady` bounds the last step's relative change (the f32 solve of a
/// nearly steady diffusion has round-off noise of about 1e-4).
fn log_law_over_a_fixed_rough_bed<R: Real>(u_star: f64, steady: f64) {
    let h = 0.1;
    let config = rough_config(h, u_star);
    let (column, change) = run_rough::<R>(&config, 6000, 0.5);
    let k_sr = fitted_roughness(&column, h, u_star);
    let fitted = log_law_error(&column, h, u_star, k_sr);
    let paper = log_law_error(&column, h, u_star, D);
    std::println!(
        "{}, u* = {u_star} m/s: log law over the outer 80 %: max error {:.3} % with the fitted k_sr = {:.3} d, {:.3} % with k_sr = d; last change {change:.1e} m/s",
        R::NAME,
        fitted * 100.0,
        k_sr / D,
        paper * 100.0
    );
    let top = column.velocities().last().unwrap().to_f64();
    assert!(change < steady * top, "not steady: {change:e}");
    assert!(fitted < 0.02, "log law, fitted k_sr: {fitted}");
    assert!((0.5 * D..2.5 * D).contains(&k_sr), "k_sr = {k_sr}");
    if u_star == 0.03 {
        assert!(paper < 0.02, "log law, k_sr = d: {paper}");
    }
    // The local shear velocity of the Reynolds stress (C4): the driving of
    // the water above, ρ u*² (y_s − y)/h, less the viscous stress of the log
    // law, ρ ν u*/(κ y).
    let grid = column.grid();
    for frac in [0.1, 0.5, 0.9] {
        let y = 0.5 * D + frac * h;
        let viscous = config.spec.viscosity * u_star / (0.4 * frac * h);
        let expect = (u_star * u_star * (1.0 - frac) - viscous).sqrt();
        let got = column.shear_velocity_at(R::from_f64(y)).to_f64();
        assert!(
            (got - expect).abs() < 0.002 * u_star,
            "u*_loc at {frac} h: {got} vs {expect}"
        );
    }
    // u_f at a centre is the cell's, half way between two centres their mean.
    let u = column.velocities();
    let (j, dy) = (100, grid.dy());
    assert_eq!(column.velocity_at(grid.centre(j)), u[j]);
    let mid = column.velocity_at(grid.centre(j) + R::HALF * dy).to_f64();
    let mean = 0.5 * (u[j].to_f64() + u[j + 1].to_f64());
    assert!((mid - mean).abs() < 1e-6 * mean, "{mid} vs {mean}");
}

#[test]
fn log_law() {
    // τ* = 0.02, 0.11 and 0.79 on 0.5 mm sand.
    for u_star in [0.0127, 0.03, 0.08] {
        log_law_over_a_fixed_rough_bed::<f64>(u_star, 1e-9);
    }
    log_law_over_a_fixed_rough_bed::<f32>(0.03, 2e-4);
}

/// Grains at prescribed velocities with a constant drag factor in the
/// bottom slabs: at steady state the fluid's stress at the bottom plus the
/// drag it gives the grains equals the driving stress (C5), and above the
/// grains the stress is the driving of the water above. `dt` and `steps`
/// reach the steady state to within `tol` (f32 takes shorter steps: its
/// round-off noise grows with the weight of diffusion over the time term).
fn momentum_balance_with_a_drag_sink<R: Real>(dt: f64, steps: usize, tol: f64) {
    let (h, u_star) = (0.1, 0.03);
    let config = rough_config(h, u_star);
    balance::<R>(&config, dt, steps, tol);
}

/// [`momentum_balance_with_a_drag_sink`] for the column of `config`; with
/// side walls (C10) their stress joins the bottom's and the drag, and it
/// is Blasius's (2/W)(f/8) u² summed over the cells.
fn balance<R: Real>(config: &FluidConfig, dt: f64, steps: usize, tol: f64) {
    let config = *config;
    let mut column = Box::new(Col::<R>::new());
    column.reset(&config).unwrap();
    let mut slabs = Box::new(Slabs::<R, CAP>::new());
    slabs.clear(column.grid()).unwrap();
    // Three rows, each 20 grains across, moving at 0, 5 and 20 cm/s.
    let xi = R::from_f64(2e-5);
    for (row, u_p) in [(0.5, 0.0), (1.5, 0.05), (2.5, 0.2)] {
        for _ in 0..ACROSS {
            let (y, r) = (R::from_f64(row * D), R::from_f64(0.5 * D));
            slabs.add_grain(y, r, R::from_f64(u_p), xi).unwrap();
        }
    }
    for _ in 0..steps {
        column.advance(&slabs, R::from_f64(dt)).unwrap();
    }
    let grid = column.grid();
    let dy = grid.dy().to_f64();
    // The drag the fluid gives the grains, per unit bed area: Σ (k u − m) Δy.
    let mut drag = 0.0;
    for (j, &u) in column.velocities().iter().enumerate() {
        let (k, m) = slabs.drag_coefficients(j);
        drag += (k.to_f64() * u.to_f64() - m.to_f64()) * dy;
    }
    let bed = column.shear_stress(0).to_f64();
    let driving = column.driving_stress().to_f64();
    let depth = config.surface - config.bottom;
    let nominal = RHO * config.driving * depth;
    let walls = column.side_wall_stress().to_f64();
    let width = config.spec.channel_width;
    let mut blasius = 0.0;
    if width > 0.0 {
        for (&u, &phi) in column.velocities().iter().zip(column.solid_fractions()) {
            let u = u.to_f64();
            let re = (u.abs() * width / config.spec.viscosity).max(1e-10);
            let f = 0.3164 * re.powf(-0.25);
            let f = config.spec.wall_friction * f;
            blasius += RHO * (1.0 - phi.to_f64()) * dy * (2.0 / width) * (f / 8.0) * u * u;
        }
    }
    let exact = (bed + drag + walls - driving).abs() / driving;
    let brief = (bed + drag + walls - nominal).abs() / nominal;
    std::println!(
        "{}: bed stress {bed:.5} Pa + drag {drag:.5} Pa + side walls {walls:.5} Pa = {:.5} Pa; driving ρ g S Σ(1 − φ)Δy {driving:.5} Pa (error {:.1e}), ρ g S h {nominal:.5} Pa (error {:.2} %)",
        R::NAME,
        bed + drag + walls,
        exact,
        brief * 100.0
    );
    assert!(
        drag.abs() > 0.01 * driving,
        "the drag sink is not exercised"
    );
    assert!(exact < tol, "momentum balance: {exact:e}");
    if width > 0.0 {
        assert!(
            walls > 0.2 * driving,
            "the walls are not exercised: {walls}"
        );
        let off = (walls - blasius).abs() / blasius;
        assert!(
            off < tol.max(1e-12),
            "side walls {walls} vs Blasius {blasius}"
        );
        return;
    }
    assert_eq!(walls, 0.0);
    assert!(drag > 0.1 * driving, "the grains hold the water back");
    assert!(brief < 0.01, "against ρ g h S: {brief}");
    // Above the grains (from face 7, 3.5 d up): the stress carries the
    // driving of the water above, ρ g S (surface − y).
    for j in [7, 50, 200, 390] {
        let above = RHO * config.driving * (config.surface - grid.face(j).to_f64());
        let stress = column.shear_stress(j).to_f64();
        assert!(
            (stress - above).abs() < tol * nominal,
            "face {j}: {stress} vs {above}"
        );
    }
}

#[test]
fn momentum_balance() {
    momentum_balance_with_a_drag_sink::<f64>(0.5, 6000, 1e-9);
    momentum_balance_with_a_drag_sink::<f32>(0.02, 60_000, 2e-3);
}

/// In a channel 6.5 mm wide (Frey 2014), at steady state, the driving
/// equals the bottom's stress plus the drag plus the side walls' stress
/// (C10), which is Blasius's friction (times the factor c_f: 1 and ½)
/// summed over the cells.
#[test]
fn side_walls_take_their_share() {
    for wall_friction in [1.0, 0.5] {
        let mut config = rough_config(0.02, 0.03);
        config.spec.channel_width = 0.0065;
        config.spec.wall_friction = wall_friction;
        balance::<f64>(&config, 0.05, 20_000, 1e-9);
        balance::<f32>(&config, 0.01, 60_000, 2e-3);
    }
}

/// Slice volumes (C1): a grain inside one slab, a grain cut in two, caps,
/// and shares that add up to the grain's volume.
fn slice_volumes<R: Real>(tol: f64) {
    let r = 0.25e-3;
    let whole = 4.0 / 3.0 * PI * r * r * r;
    let v =
        |lo: f64, hi: f64| slice_volume(R::from_f64(r), R::from_f64(lo), R::from_f64(hi)).to_f64();
    assert!((v(-r, r) - whole).abs() < tol * whole);
    assert!((v(-2.0 * r, 3.0 * r) - whole).abs() < tol * whole);
    // Cut at its centre: two halves.
    assert!((v(-r, 0.0) - whole / 2.0).abs() < tol * whole);
    assert!((v(0.0, r) - whole / 2.0).abs() < tol * whole);
    // A cap of height c: π c² (3r − c)/3.
    let c = 0.3 * r;
    let cap = PI * c * c * (3.0 * r - c) / 3.0;
    assert!((v(r - c, r) - cap).abs() < tol * whole);
    assert!((v(-r, -r + c) - cap).abs() < tol * whole);
    assert_eq!(v(r, 2.0 * r), 0.0);
    assert_eq!(v(0.1 * r, 0.1 * r), 0.0);

    // Through the slabs of a column of cells D/2 = 2r, 10 d² across.
    let mut column = Box::new(Column::<R, 8>::new());
    column
        .reset(&FluidConfig::new(8, 0.0, 8.0 * 2.0 * r, 10.0 * D * D))
        .unwrap();
    let mut slabs = Box::new(Slabs::<R, 8>::new());
    let volume = column.grid().slab_volume().to_f64();
    let solid = |slabs: &Slabs<R, 8>| -> Vec<f64> {
        (0..8)
            .map(|j| slabs.solid_fraction(j).to_f64() * volume)
            .collect()
    };
    // Wholly inside slab 2 (spanning [4r, 6r]).
    slabs.clear(column.grid()).unwrap();
    let small = 0.9 * r;
    slabs
        .add_grain(R::from_f64(5.0 * r), R::from_f64(small), R::ZERO, R::ZERO)
        .unwrap();
    let s = solid(&slabs);
    let inside = 4.0 / 3.0 * PI * small * small * small;
    assert!((s[2] - inside).abs() < tol * inside, "{s:?}");
    assert_eq!(s.iter().filter(|&&x| x != 0.0).count(), 1);
    // Cut in two by face 3 (at 6r): equal halves in slabs 2 and 3.
    slabs.clear(column.grid()).unwrap();
    slabs
        .add_grain(R::from_f64(6.0 * r), R::from_f64(r), R::ZERO, R::ZERO)
        .unwrap();
    let s = solid(&slabs);
    assert!(
        (s[2] - whole / 2.0).abs() < tol * whole && (s[3] - whole / 2.0).abs() < tol * whole,
        "{s:?}"
    );
    // A grain of radius 3r across four slabs: the parts add up.
    slabs.clear(column.grid()).unwrap();
    let big = 3.0 * r;
    slabs
        .add_grain(
            R::from_f64(7.3 * r),
            R::from_f64(big),
            R::from_f64(0.1),
            R::ONE,
        )
        .unwrap();
    let total: f64 = solid(&slabs).iter().sum();
    let expect = 4.0 / 3.0 * PI * big * big * big;
    assert!((total - expect).abs() < tol * expect, "{total} vs {expect}");
    // Its drag shares add up to Ξ, its velocity is that of every slab.
    let shares: f64 = (0..8)
        .map(|j| slabs.drag_coefficients(j).0.to_f64() * volume)
        .sum();
    assert!((shares - 1.0).abs() < tol, "{shares}");
    for j in 2..6 {
        assert!(
            (slabs.grain_velocity(j).to_f64() - 0.1).abs() < tol,
            "slab {j}"
        );
    }
    assert_eq!(slabs.grain_velocity(0), R::ZERO);
}

#[test]
fn exact_slice_volumes() {
    slice_volumes::<f64>(1e-13);
    slice_volumes::<f32>(2e-6);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 256, ..Default::default() })]

    /// A grain anywhere inside the column, of any size up to the column's
    /// height: its slab volumes add up to its volume to round-off.
    #[test]
    fn slice_volumes_add_up(y in 0.3f64..0.7, r in 0.001f64..0.3) {
        let mut column = Box::new(Column::<f64, 64>::new());
        column.reset(&FluidConfig::new(64, 0.0, 1.0, 1.0)).unwrap();
        let mut slabs = Box::new(Slabs::<f64, 64>::new());
        slabs.clear(column.grid()).unwrap();
        slabs.add_grain(y, r, 0.0, 1.0).unwrap();
        let volume = column.grid().slab_volume();
        let total: f64 = (0..64).map(|j| slabs.solid_fraction(j) * volume).sum();
        let expect = 4.0 / 3.0 * PI * r * r * r;
        proptest::prop_assert!((total - expect).abs() < 1e-13 * expect.max(1e-6), "{} vs {}", total, expect);
    }
}

/// The Thomas solve against a known system of four unknowns:
/// [4 1 0 0; 1 4 1 0; 0 1 4 1; 0 0 1 4] x = b with x = (1, −2, 3, 0.5).
fn thomas<R: Real>(tol: f64) {
    let mut t = Tridiagonal::<R, 6>::new();
    let x = [1.0, -2.0, 3.0, 0.5];
    for i in 0..4 {
        t.diag[i] = R::from_f64(4.0);
        t.lower[i] = R::from_f64(1.0);
        t.upper[i] = R::from_f64(1.0);
        let below = if i > 0 { x[i - 1] } else { 0.0 };
        let above = if i < 3 { x[i + 1] } else { 0.0 };
        t.rhs[i] = R::from_f64(below + 4.0 * x[i] + above);
    }
    // Entries beyond the system are not read.
    t.lower[0] = R::from_f64(f64::NAN);
    t.upper[3] = R::from_f64(f64::NAN);
    let got = t.solve(4).unwrap();
    for (g, e) in got.iter().zip(x) {
        assert!((g.to_f64() - e).abs() < tol, "{got:?}");
    }
    // Singular: a zero pivot is an error, not a division by zero.
    let mut t = Tridiagonal::<R, 6>::new();
    assert!(matches!(
        t.solve(3),
        Err(Error::InvalidParameter {
            name: "fluid.pivot",
            ..
        })
    ));
    assert!(matches!(
        t.solve(7),
        Err(Error::CapacityExceeded {
            what: Capacity::FluidCells,
            capacity: 6
        })
    ));
}

#[test]
fn tridiagonal_solve() {
    thomas::<f64>(1e-15);
    thomas::<f32>(1e-6);
}

/// The FNV-1a digest of the velocities' f64 bits.
fn profile_digest<R: Real>(column: &Col<R>) -> u64 {
    let mut h = Fnv1a::default();
    for &u in column.velocities() {
        h.word(u.to_f64().to_bits());
    }
    h.finish()
}

/// The same calls give the same bits; a column restored from the state at
/// the half way continues to the same bits; the digest after 400 steps of a
/// 5 cm column over the rough bed is pinned (f64 and f32).
fn bits<R: Real>(golden: u64) {
    let config = rough_config(0.05, 0.03);
    let (a, _) = run_rough::<R>(&config, 400, 0.01);
    let (b, _) = run_rough::<R>(&config, 400, 0.01);
    assert_eq!(profile_digest(&a), profile_digest(&b));
    // Half way, then a restored copy and the original go on alike.
    let (mut first, _) = run_rough::<R>(&config, 200, 0.01);
    let mut copy = Box::new(Col::<R>::new());
    copy.reset(&config).unwrap();
    copy.set_state(first.velocities(), first.solid_fractions())
        .unwrap();
    let mut slabs = Box::new(Slabs::<R, CAP>::new());
    for column in [&mut first, &mut copy] {
        for _ in 0..200 {
            rough_step(column, &mut slabs, 0.01);
        }
    }
    assert_eq!(profile_digest(&first), profile_digest(&a));
    assert_eq!(profile_digest(&copy), profile_digest(&a));
    let digest = profile_digest(&a);
    std::println!("{}: profile digest {digest:#018x}", R::NAME);
    assert_eq!(digest, golden, "{}: {digest:#018x}", R::NAME);
}

#[test]
fn bit_reproducible() {
    bits::<f64>(0xb1c53c7681f85b81);
    bits::<f32>(0x1f38c88594719626);
}

/// Bad parameters and inputs are `Error` values naming what is wrong.
#[test]
fn bad_inputs_are_errors() {
    let name = |r: Result<(), Error>| match r {
        Err(Error::InvalidParameter { name, .. }) => name,
        other => panic!("{other:?}"),
    };
    let good = rough_config(0.05, 0.03);
    let mut column = Box::new(Col::<f64>::new());
    for (field, value) in [
        ("fluid.cells", 1.0),
        ("fluid.bottom", f64::NAN),
        ("fluid.surface", -1.0),
        ("fluid.cross_section", 0.0),
        ("fluid.density", -1.0),
        ("fluid.viscosity", f64::NAN),
        ("fluid.kappa", 0.0),
        ("fluid.phi_max", 1.0),
        ("fluid.driving", f64::INFINITY),
    ] {
        let mut c = good;
        match field {
            "fluid.cells" => c.cells = value as usize,
            "fluid.bottom" => c.bottom = value,
            "fluid.surface" => c.surface = value,
            "fluid.cross_section" => c.cross_section = value,
            "fluid.density" => c.density = value,
            "fluid.viscosity" => c.spec.viscosity = value,
            "fluid.kappa" => c.kappa = value,
            "fluid.phi_max" => c.spec.phi_max = value,
            _ => c.driving = value,
        }
        assert_eq!(name(column.reset(&c)), field);
    }
    let mut c = good;
    c.cells = CAP + 1;
    assert_eq!(
        column.reset(&c),
        Err(Error::CapacityExceeded {
            what: Capacity::FluidCells,
            capacity: CAP
        })
    );
    // An empty column cannot step.
    let mut slabs = Box::new(Slabs::<f64, CAP>::new());
    assert_eq!(name(column.advance(&slabs, 0.01)), "fluid.cells");
    column.reset(&good).unwrap();
    // Slabs of another grid.
    assert_eq!(name(column.advance(&slabs, 0.01)), "fluid.slabs");
    slabs.clear(column.grid()).unwrap();
    for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(name(column.advance(&slabs, dt)), "fluid.dt");
    }
    // A step so short that 1/dt overflows is refused, the state kept.
    assert!(column.advance(&slabs, 1e-320).is_err());
    assert!(column.velocities().iter().all(|&u| u == 0.0));
    // Grains.
    assert_eq!(
        name(slabs.add_grain(f64::NAN, D, 0.0, 0.0)),
        "fluid.grain_height"
    );
    assert_eq!(
        name(slabs.add_grain(D, 0.0, 0.0, 0.0)),
        "fluid.grain_radius"
    );
    assert_eq!(name(slabs.add_grain(D, -D, 0.0, 0.0)), "fluid.grain_radius");
    assert_eq!(
        name(slabs.add_grain(D, D, f64::INFINITY, 0.0)),
        "fluid.grain_velocity"
    );
    assert_eq!(name(slabs.add_grain(D, D, 0.0, -1.0)), "fluid.grain_drag");
    // Grains outside the column count for nothing.
    slabs.add_grain(-1.0, D, 0.0, 1.0).unwrap();
    slabs.add_grain(1.0, D, 0.0, 1.0).unwrap();
    assert!((0..CAP).all(|j| slabs.solid_volume(j) == 0.0));
    // Overlapping grains that fill a slab: φ ≥ 1 is refused.
    for _ in 0..100 {
        slabs.add_grain(0.5 * D, 0.5 * D, 0.0, 0.0).unwrap();
    }
    assert_eq!(name(column.advance(&slabs, 0.01)), "fluid.solid_fraction");
    // Slabs of a smaller capacity than the grid.
    let mut tiny = Slabs::<f64, 4>::new();
    assert!(matches!(
        tiny.clear(column.grid()),
        Err(Error::CapacityExceeded { capacity: 4, .. })
    ));
    // State of the wrong length or not finite.
    let n = good.cells;
    let (u, phi) = (vec![0.0; n], vec![0.0; n]);
    assert_eq!(name(column.set_state(&u[1..], &phi)), "fluid.state");
    let mut bad = u.clone();
    bad[3] = f64::NAN;
    assert_eq!(name(column.set_state(&bad, &phi)), "fluid.velocity");
    let mut bad = phi.clone();
    bad[3] = 1.0;
    assert_eq!(name(column.set_state(&u, &bad)), "fluid.solid_fraction");
    // Queries outside the column or of NaN heights are zero.
    assert_eq!(column.velocity_at(f64::NAN), 0.0);
    assert_eq!(column.velocity_at(-1.0), 0.0);
    assert_eq!(column.shear_velocity_at(f64::NAN), 0.0);
    assert_eq!(column.shear_velocity_at(2.0), 0.0);
    assert_eq!(column.shear_stress(CAP + 10), 0.0);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 64, ..Default::default() })]

    /// Any configuration, grains and step: an error or finite velocities,
    /// never a panic.
    #[test]
    fn never_panics(
        cells in 0usize..600,
        bottom in proptest::num::f64::ANY,
        height in proptest::num::f64::ANY,
        driving in proptest::num::f64::ANY,
        phi_max in -0.5f64..1.5,
        grains in proptest::collection::vec(
            (proptest::num::f64::ANY, proptest::num::f64::ANY, proptest::num::f64::ANY, proptest::num::f64::ANY),
            0..20,
        ),
        dt in proptest::num::f64::ANY,
        y in proptest::num::f64::ANY,
    ) {
        let mut c = FluidConfig::new(cells, bottom, bottom + height, D * D);
        c.driving = driving;
        c.spec.phi_max = phi_max;
        let mut column = Box::new(Col::<f64>::new());
        let _ = column.reset(&c);
        let mut slabs = Box::new(Slabs::<f64, CAP>::new());
        let _ = slabs.clear(column.grid());
        for &(gy, r, u, xi) in &grains {
            let _ = slabs.add_grain(gy, r, u, xi);
        }
        for _ in 0..3 {
            if column.advance(&slabs, dt).is_ok() {
                proptest::prop_assert!(column.velocities().iter().all(|u| u.is_finite()));
            }
        }
        let _ = (column.velocity_at(y), column.shear_velocity_at(y), column.driving_stress());
        for j in 0..=cells.min(CAP + 1) {
            let _ = (column.shear_stress(j), column.reynolds_stress(j));
        }
    }
}
