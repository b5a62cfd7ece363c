mod common;
use common::*;
use mbs_kernel::{contact_constants, Material, Sim, Tension, TimeStepRule};

fn run(alpha_m: f64, alpha_cn: f64, beta: f64, tension: Tension, launch: f64, gap: f64, sub: f64) {
    let mat = Material::default();
    let c = contact_constants(&TimeStepRule { alpha_m, alpha_cn, beta, constants_dt: 2e-5 }, D, &mat).unwrap();
    let dt = 2e-5 / sub;
    let mut cfg = config(dt, c.k_n, c.eta_n, mat.mu);
    cfg.contact = c;
    cfg.tension = tension;
    cfg.gravity = [0.0, -9.81];
    let m = mass();
    let g_red = 9.81 * 1.65 / 3.15;
    let weight = m * g_red;
    let mut s = Box::new(Sim::<f64, 256, 8>::new());
    s.reset(&cfg).unwrap();
    let mid = cfg.width / 2.0;
    s.add_grain(&fixed(mid, 0.0)).unwrap();
    // equilibrium overlap
    let eq = weight / c.k_n;
    let y0 = if launch > 0.0 { D - eq } else { D + gap };
    s.add_grain(&mobile(mid, y0, 0.0, launch)).unwrap();
    if launch > 0.0 {
        // put the spring at equilibrium: one step with zero velocity first? approximate: set via first-step overlap
    }
    let mut min_fn = f64::MAX;
    let mut ymax = y0;
    let mut v_prev = launch;
    let mut steps_contact = 0;
    for _ in 0..400_000 {
        s.step().unwrap();
        let g = s.grain(1).unwrap();
        let a = (g.v - v_prev) / dt;
        v_prev = g.v;
        if s.contact_history(0, 1).is_some() {
            steps_contact += 1;
            min_fn = min_fn.min(m * (a + g_red));
        }
        ymax = ymax.max(g.y);
    }
    let hb = launch * launch / (2.0 * g_red);
    println!("sub {sub} am {alpha_m} acn {alpha_cn} beta {beta} {tension:?} launch {launch} gap {gap}: zeta {:.2} max pull {:.1} x weight, rise {:.3} of ballistic, contact steps {steps_contact}",
        c.eta_n / (2.0 * (m * c.k_n).sqrt()), -min_fn / weight, if hb > 0.0 { (ymax - y0) / hb } else { 0.0 });
}

#[test]
fn explore() {
    for t in [Tension::Dashpot, Tension::None] {
        for (am, acn, b) in [(25.0, 1.0, 3.868), (20.0, 1.3, 15.8)] {
            for sub in [1.0, 8.0] {
            run(am, acn, b, t, 0.0, 0.0, sub);
            run(am, acn, b, t, 0.0, 0.05 * D, sub);
            run(am, acn, b, t, 0.01, 0.0, sub);
            run(am, acn, b, t, 0.2, 0.0, sub);
            }
        }
    }
}
