//! Observables (docs/model.md §8): centre of gravity y_gc, energies, overlaps,
//! contacts, and the bed-load transport rate q_B, in total and per size class.

use crate::constants::A3;
use crate::grains::MAX_CLASSES;
use crate::periodic::periodic;
use crate::real::Real;
use crate::sim::Sim;

/// A snapshot of the observables, accumulated in `f64` in grain order.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Observation {
    /// Simulated time (s).
    pub time: f64,
    /// Mobile grains.
    pub mobile: usize,
    /// Height of the centre of gravity of the mobile grains, y_gc (m).
    pub y_gc: f64,
    /// Kinetic energy ½m(u² + v²) + ½Iω² of the mobile grains, with the
    /// translational inertia m = ρ(s + C_M)A3 d³ of the equations of motion (J).
    pub kinetic_energy: f64,
    /// Potential energy of the submerged weight, −m g_red·r (J).
    pub potential_energy: f64,
    /// Energy stored in contact springs, Σ e_n²/2k_n + e_s²/2k_s (J).
    pub spring_energy: f64,
    /// Largest overlap (d_i + d_j)/2 − |r_ij| among touching pairs (m).
    pub max_overlap: f64,
    /// Pairs in contact (non-zero spring history).
    pub contacts: usize,
    /// Largest mobile-grain speed (m/s).
    pub max_speed: f64,
    /// Σ V_i u_p,i / L per size class (m²/s): q_B of a class is this over its
    /// diameter (docs/model.md §8, \[choice\]: the slice is one grain thick).
    pub volume_flux: [f64; MAX_CLASSES],
}

impl Observation {
    /// q_B = Σ V_i u_p,i / (L d) over all classes, for reference diameter `d`.
    pub fn q_b(&self, d: f64) -> f64 {
        self.volume_flux.iter().sum::<f64>() / d
    }

    /// Dimensionless q* = q_B/√((s − 1)g d³) over all classes.
    pub fn q_star(&self, d: f64, s: f64, g: f64) -> f64 {
        q_star(self.q_b(d), d, s, g)
    }

    /// q* of size class `class` on the scale `d`: its flux over the slice
    /// thickness `d`, made dimensionless with `d` (docs/model.md §8). With
    /// the `d` given to [`Observation::q_star`] (the largest diameter), the
    /// classes add up to the total; a class's own-scale q* is this times
    /// (d/d_k)^(3/2).
    pub fn q_star_class(&self, class: usize, d: f64, s: f64, g: f64) -> f64 {
        let flux = self.volume_flux.get(class).copied().unwrap_or(0.0);
        q_star(flux / d, d, s, g)
    }
}

/// q* = q_B/√((s − 1)g d³) (docs/model.md §8).
pub fn q_star(q_b: f64, d: f64, s: f64, g: f64) -> f64 {
    q_b / libm::sqrt((s - 1.0) * g * d * d * d)
}

impl<R: Real, const N: usize, const K: usize, const C: usize> Sim<R, N, K, C> {
    /// Largest speed of a mobile grain (m/s).
    pub fn max_speed(&self) -> f64 {
        let g = &self.grains;
        let mut v2 = R::ZERO;
        for i in 0..g.len {
            if !g.fixed[i] {
                v2 = R::max(v2, g.u[i] * g.u[i] + g.v[i] * g.v[i]);
            }
        }
        libm::sqrt(v2.to_f64())
    }

    /// Computes every observable of docs/model.md §8 at the current state.
    pub fn observe(&self) -> Observation {
        let g = &self.grains;
        let m = &self.config.material;
        let mut o = Observation {
            time: self.time(),
            ..Observation::default()
        };
        let [gx, gy] = [self.g_red[0].to_f64(), self.g_red[1].to_f64()];
        let (mut mass_sum, mut moment) = (0.0, 0.0);
        let width = self.config.width;
        for i in 0..g.len {
            if g.fixed[i] {
                continue;
            }
            let d = 2.0 * g.r[i].to_f64();
            let (x, y, u, v, w) = (
                g.x[i].to_f64(),
                g.y[i].to_f64(),
                g.u[i].to_f64(),
                g.v[i].to_f64(),
                g.w[i].to_f64(),
            );
            let mass = m.translational_mass(d);
            let volume = A3 * d * d * d;
            o.mobile += 1;
            mass_sum += volume;
            moment += volume * y;
            o.kinetic_energy += 0.5 * mass * (u * u + v * v) + 0.5 * m.moment_of_inertia(d) * w * w;
            o.potential_energy -= mass * (gx * x + gy * y);
            if let Some(flux) = o.volume_flux.get_mut(usize::from(g.class[i])) {
                *flux += volume * u / width;
            }
        }
        o.y_gc = if mass_sum > 0.0 {
            moment / mass_sum
        } else {
            0.0
        };
        o.max_speed = self.max_speed();
        let c = &self.config.contact;
        let half_width = self.width * R::HALF;
        for (i, j, h) in self.contacts() {
            o.contacts += 1;
            let (e_n, e_s) = (h.e_n.to_f64(), h.e_s.to_f64());
            o.spring_energy += e_n * e_n / (2.0 * c.k_n) + e_s * e_s / (2.0 * c.k_s);
            let dx = periodic(g.x[j] - g.x[i], self.width, half_width).to_f64();
            let dy = (g.y[j] - g.y[i]).to_f64();
            let overlap = (g.r[i] + g.r[j]).to_f64() - libm::sqrt(dx * dx + dy * dy);
            o.max_overlap = o.max_overlap.max(overlap);
        }
        o
    }
}
