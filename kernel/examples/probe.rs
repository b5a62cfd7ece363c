use mbs_kernel::{Scenario, Sim};
fn main() {
    let mut sc = Scenario::paper();
    let args: Vec<String> = std::env::args().collect();
    sc.rule.beta = args.get(1).map_or(1.0, |a| a.parse().unwrap());
    sc.rule.alpha_cn = args.get(2).map_or(1.0, |a| a.parse().unwrap());
    sc.material.mu = args.get(3).map_or(0.577, |a| a.parse().unwrap());
    sc.material.c_d = 0.4;
    let mut sim = Box::new(Sim::<f64, 512, 8>::new());
    let mut cfg = sc.sim_config().unwrap();
    cfg.dt *= args.get(4).map_or(1.0, |a| a.parse().unwrap());
    sim.build_bed(&cfg, &sc.bed).unwrap();
    for k in 0..40 {
        if let Err(e) = sim.run(5000) {
            println!("{e}");
            break;
        }
        let o = sim.observe();
        let (mut imax, mut vmax) = (0, 0.0);
        for i in 0..sim.len() {
            let g = sim.grain(i).unwrap();
            let s = (g.u * g.u + g.v * g.v).sqrt();
            if s > vmax {
                vmax = s;
                imax = i;
            }
        }
        let g = sim.grain(imax).unwrap();
        println!("{k:3} t={:.3} ygc={:.4e} ke={:.3e} ov={:.3e} c={} vmax={:.3e} grain {imax} at ({:.3e},{:.3e}) v=({:.2e},{:.2e}) w={:.2e}", o.time, o.y_gc, o.kinetic_energy, o.max_overlap, o.contacts, o.max_speed, g.x, g.y, g.u, g.v, g.spin);
    }
}
