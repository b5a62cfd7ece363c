//! `impl Sim`: the observables of docs/model.md §8 ([`Observation`]):
//! centre of gravity y_gc, energies, overlaps, contacts, and the bed-load
//! transport rate q_B, in total and per size class.

use crate::constants::A3;
use crate::observe::Observation;
use crate::periodic::periodic;
use crate::real::Real;
use crate::sim::Sim;

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
