//! Writes the settled bed of `mbs bench` as a LAMMPS data file and input,
//! so that LAMMPS steps the same grains with the same contact law, step and
//! skin (`benches/lammps.sh` runs both side by side, docs/performance.md).
//!
//! Run: `cargo run --release -p mbs --example lammps -- GRAINS DIR [BEDS]`
//! (BEDS: the directory of prepared beds that `mbs bench --beds` shares).
//!
//! The translation: LAMMPS's `gran/hooke/history` is the linear
//! spring–dashpot with a tangential spring and Coulomb's cap
//! (docs/model.md (6)–(9)); its dashpots are per unit of effective mass,
//! so γ = η/m_eff with m_eff = m/2 of two equal grains. The grains carry
//! their added mass (`Material::translational_mass`) and feel the
//! buoyant weight (`SimConfig::reduced_gravity`); the fixed grains are
//! frozen.

use mbs::sim::sims::boxed_sim;
use mbs::tools::bench::{prepare, BenchBed};
use std::fmt::Write as _;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (Some(grains), Some(dir)) = (args.get(1), args.get(2)) else {
        return Err("usage: lammps GRAINS DIR [BEDS]".into());
    };
    let grains: usize = grains.parse()?;
    let dir = PathBuf::from(dir);
    let beds = args.get(3).map(PathBuf::from);
    const N: usize = 65_536;
    let mut sim = boxed_sim::<f64, N, 8>();
    let bed = BenchBed { grains, beta: 15.8 };
    prepare(&mut *sim, &bed, false, beds.as_deref())?;
    let c = *sim.config();
    let m = c.material;
    let specs: Vec<_> = (0..sim.len()).filter_map(|i| sim.grain(i)).collect();
    let d = specs.iter().map(|g| g.diameter).fold(0.0, f64::max);
    // LAMMPS's sphere mass is density · (4/3)π r³ in 2-D too: the
    // kernel's mass (added mass included) per unit of that volume.
    let density = m.rho * (m.s + m.c_m);
    let m_eff = m.translational_mass(d) / 2.0;
    let [g_x, g_y] = c.reduced_gravity();
    if g_x != 0.0 {
        return Err("the bench bed is horizontal; a slope is not translated".into());
    }
    let g = -g_y;
    let (y_lo, y_hi) = (c.y_min, c.y_max);

    let mut data = String::new();
    writeln!(data, "mbs bench bed, {} grains", specs.len())?;
    writeln!(data, "\n{} atoms\n2 atom types\n", specs.len())?;
    writeln!(data, "0 {:e} xlo xhi", c.width)?;
    writeln!(data, "{y_lo:e} {y_hi:e} ylo yhi")?;
    writeln!(data, "{:e} {:e} zlo zhi", -d, d)?;
    writeln!(data, "\nAtoms # sphere\n")?;
    for (i, s) in specs.iter().enumerate() {
        let kind = if s.fixed { 2 } else { 1 };
        let (x, y, dd) = (s.x, s.y, s.diameter);
        writeln!(data, "{} {kind} {dd:e} {density:e} {x:e} {y:e} 0", i + 1)?;
    }
    writeln!(data, "\nVelocities\n")?;
    for (i, s) in specs.iter().enumerate() {
        writeln!(data, "{} {:e} {:e} 0 0 0 {:e}", i + 1, s.u, s.v, s.spin)?;
    }

    let k = c.contact;
    let input = format!(
        "# mbs bench bed ({n} grains): the same grains, law, step and skin.
units si
dimension 2
boundary p f p
atom_style sphere
atom_modify map array
comm_modify vel yes
newton off
read_data bed.data
group mobile type 1
group fixed type 2
pair_style gran/hooke/history {kn:e} {ks:e} {gn:e} {gs:e} {mu} 1
pair_coeff * *
neighbor {skin:e} bin
neigh_modify delay 0 every 1 check yes
fix move mobile nve/sphere
fix weight mobile gravity {g:e} vector 0 -1 0
fix frozen fixed freeze
fix plane all enforce2d
timestep {dt:e}
compute touching all contact/atom
compute contacts all reduce sum c_touching
variable per_grain equal c_contacts/2/atoms
thermo_style custom step ke v_per_grain
thermo ${{steps}}
run ${{steps}}
",
        n = specs.len(),
        kn = k.k_n,
        ks = k.k_s,
        gn = k.eta_n / m_eff,
        gs = k.eta_s / m_eff,
        mu = m.mu,
        skin = c.skin,
        dt = c.step_dt,
    );
    std::fs::create_dir_all(&dir)?;
    std::fs::write(dir.join("bed.data"), data)?;
    std::fs::write(dir.join("in.bed"), input)?;
    println!(
        "{}: {} grains, step {:e} s",
        dir.display(),
        specs.len(),
        c.step_dt
    );
    Ok(())
}
