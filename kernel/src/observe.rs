//! The observables' record (docs/model.md §8): [`Observation`] (centre of
//! gravity y_gc, energies, overlaps, contacts, and the bed-load transport
//! rate q_B, in total and per size class) and q* ([`q_star`], on the
//! scale [`transport_scale`]). Computing them from a simulation
//! ([`crate::Sim::observe`]) is an `impl Sim` in `sim/observe.rs`; the
//! record and the formulas stay here, below the simulation, because they
//! need none (the host combines observations of many runs).

use crate::grains::MAX_CLASSES;

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

/// q* = q_B/√((s − 1)g d³) (docs/model.md §8), the scale by [`transport_scale`].
pub fn q_star(q_b: f64, d: f64, s: f64, g: f64) -> f64 {
    q_b / transport_scale(d, s, g)
}

/// The scale √((s − 1)g d³) (m²/s) of the transport rate (docs/model.md
/// §8): q_B = q* √((s − 1)g d³), the inverse of [`q_star`].
///
/// ```
/// use mbs_kernel::{q_star, transport_scale};
///
/// let (d, s, g) = (0.5e-3, 2.65, 9.81);
/// let scale = transport_scale(d, s, g);
/// assert!((q_star(0.1 * scale, d, s, g) - 0.1).abs() < 1e-15);
/// ```
pub fn transport_scale(d: f64, s: f64, g: f64) -> f64 {
    libm::sqrt((s - 1.0) * g * d * d * d)
}
