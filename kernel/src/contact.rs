//! The contact law, docs/model.md (6)–(9): normal and tangential springs with
//! per-pair history, dashpots, no tension, Coulomb sliding; and what may
//! pull ([`Tension`]: the paper's rule (8), or no tension at all (8')).
//!
//! Geometry and signs (docs/model.md §2): n = (cos α, sin α) points from grain i to
//! grain j and t = (sin α, −cos α). The force on i is −f_n n + f_s t, on j its
//! negative; the counter-clockwise torque on each grain is −(d/2) f_s.
//! Relative displacements during a step:
//! Δξ_n = (v_i − v_j)·n Δt (approach > 0),
//! Δξ_s = [(v_j − v_i)·t + (d_i ω_i + d_j ω_j)/2] Δt (ω counter-clockwise).

use crate::real::Real;

/// Spring history of one contact: the elastic parts e_n, e_s of (6)–(7).
/// Both are zero for a pair that is not in contact.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Spring<R: Real> {
    /// Normal spring force e_n (N).
    pub e_n: R,
    /// Tangential spring force e_s (N).
    pub e_s: R,
}

impl<R: Real> Spring<R> {
    /// No history: a pair not in contact.
    pub const ZERO: Self = Spring {
        e_n: R::ZERO,
        e_s: R::ZERO,
    };
}

/// What part of the normal force may pull a separating pair (docs/model.md
/// (8), (8')). Fieldless, the paper's rule 0: an all-zero [`crate::Sim`]
/// stays valid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Tension {
    /// The paper's rule (8), the default: the contact breaks when its
    /// normal spring e_n would pull, but while the spring pushes the normal
    /// dashpot may pull, f_n = e_n + d_n < 0, and the Coulomb cap is μ e_n.
    #[default]
    Dashpot = 0,
    /// No tension (8'): the normal force never pulls, f_n = max(0, e_n + d_n),
    /// and the Coulomb cap is μ f_n (LIGGGHTS' `limitForce`). The contact
    /// still breaks when e_n turns negative.
    None = 1,
}

impl Tension {
    /// Its code in a checkpoint: 0 the paper's rule, 1 no tension.
    pub fn code(self) -> u8 {
        self as u8
    }

    /// The rule of checkpoint code `code`, if any.
    pub fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Tension::Dashpot),
            1 => Some(Tension::None),
            _ => None,
        }
    }
}

/// The constants of the contact law in the working precision.
///
/// ```
/// use mbs_kernel::contact::{ContactLaw, Spring, Tension};
///
/// let law = ContactLaw {
///     k_n: 100.0,
///     k_s: 40.0,
///     eta_n: 0.1,
///     eta_s: 0.05,
///     mu: 0.5,
///     step_dt: 1e-4,
///     tension: Tension::Dashpot,
/// };
/// let mut history = Spring::ZERO;
/// // A new contact overlapping by 10 µm, approaching at 0.2 m/s: the
/// // normal spring takes the overlap, the dashpot the speed (6).
/// let forces = law.apply(&mut history, 1e-5, 0.2, 0.0);
/// assert_eq!(forces, Some((100.0 * 1e-5 + 0.1 * 0.2, 0.0)));
/// // Pulled apart: tension breaks it (8), its history is dropped.
/// assert_eq!(law.apply(&mut history, 1e-6, -1.0, 0.0), None);
/// assert_eq!(history, Spring::ZERO);
/// // Separating: the spring still pushes (e_n = 0.1 mN) and the
/// // paper's dashpot pulls (f_n < 0); without tension f_n is 0.
/// let mut history = Spring { e_n: 1.1e-3, e_s: 0.0 };
/// let (f_n, _) = law.apply(&mut history, 1e-5, -0.1, 0.0).unwrap();
/// assert!(f_n < 0.0);
/// let mut history = Spring { e_n: 1.1e-3, e_s: 0.0 };
/// let law = ContactLaw { tension: Tension::None, ..law };
/// assert_eq!(law.apply(&mut history, 1e-5, -0.1, 0.0), Some((0.0, 0.0)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactLaw<R: Real> {
    /// Normal spring k_n (N/m).
    pub k_n: R,
    /// Tangential spring k_s (N/m), docs/model.md (7), (12).
    pub k_s: R,
    /// Normal dashpot η_n (N·s/m).
    pub eta_n: R,
    /// Tangential dashpot η_s (N·s/m), docs/model.md (7), (13).
    pub eta_s: R,
    /// μ.
    pub mu: R,
    /// The integration step (s), [`crate::SimConfig::step_dt`].
    pub step_dt: R,
    /// What may pull, [`crate::SimConfig::tension`].
    pub tension: Tension,
}

impl<R: Real> ContactLaw<R> {
    /// All-zero constants (an unconfigured simulation).
    pub const ZERO: Self = ContactLaw {
        k_n: R::ZERO,
        k_s: R::ZERO,
        eta_n: R::ZERO,
        eta_s: R::ZERO,
        mu: R::ZERO,
        step_dt: R::ZERO,
        tension: Tension::Dashpot,
    };

    /// Advances the history of one overlapping contact by one step and returns
    /// (f_n, f_s), or `None` when the contact breaks under tension (8), in
    /// which case the history is reset to zero.
    ///
    /// - (6) e_n += k_n Δξ_n, f_n = e_n + η_n v_n, with v_n = Δξ_n/Δt the
    ///   normal approach speed. **\[choice\]** On the first step of a contact
    ///   (history zero) Δξ_n is the overlap itself, the part of the step's
    ///   approach after touching, so e_n = k_n·overlap for a central impact.
    /// - (7) e_s += k_s Δξ_s, f_s = e_s + η_s v_s.
    /// - (8) e_n < 0: the contact breaks, f_n = f_s = 0, history dropped.
    /// - (8') with [`Tension::None`], f_n = max(0, e_n + η_n v_n), and the
    ///   Coulomb cap N of (9) is this f_n instead of e_n.
    /// - (9) |e_s| > μ N: e_s = μ N sign(e_s), f_s = e_s (no tangential
    ///   dashpot while sliding) **[choice, Cundall–Strack]**.
    #[inline]
    pub fn apply(&self, h: &mut Spring<R>, overlap: R, v_n: R, v_s: R) -> Option<(R, R)> {
        self.apply_sliding(h, overlap, v_n, v_s)
            .map(|(f_n, f_s, _)| (f_n, f_s))
    }

    /// [`ContactLaw::apply`], also telling whether the contact slides at
    /// the Coulomb limit (9).
    #[inline]
    pub(crate) fn apply_sliding(
        &self,
        h: &mut Spring<R>,
        overlap: R,
        v_n: R,
        v_s: R,
    ) -> Option<(R, R, bool)> {
        let dxi_n = if h.e_n == R::ZERO {
            overlap
        } else {
            v_n * self.step_dt
        };
        h.e_n += self.k_n * dxi_n;
        if h.e_n < R::ZERO {
            *h = Spring::ZERO;
            return None;
        }
        let mut f_n = h.e_n + self.eta_n * v_n;
        let mut normal = h.e_n;
        if self.tension == Tension::None {
            // (8'): a select in the batched step (−0 and NaN kept alike).
            if f_n < R::ZERO {
                f_n = R::ZERO;
            }
            normal = f_n;
        }
        h.e_s += self.k_s * v_s * self.step_dt;
        let limit = self.mu * normal;
        let slides = R::abs(h.e_s) > limit;
        let f_s = if slides {
            h.e_s = if h.e_s > R::ZERO { limit } else { -limit };
            h.e_s
        } else {
            h.e_s + self.eta_s * v_s
        };
        Some((f_n, f_s, slides))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn law() -> ContactLaw<f64> {
        ContactLaw {
            k_n: 100.0,
            k_s: 40.0,
            eta_n: 0.1,
            eta_s: 0.05,
            mu: 0.5,
            step_dt: 1e-4,
            tension: Tension::Dashpot,
        }
    }

    #[test]
    fn first_step_spring_equals_overlap_and_tension_breaks() {
        let l = law();
        let mut h = Spring::default();
        let (f_n, f_s) = l.apply(&mut h, 1e-5, 0.2, 0.0).unwrap();
        assert_eq!(h.e_n, 100.0 * 1e-5);
        assert_eq!(f_n, h.e_n + 0.1 * 0.2);
        assert_eq!(f_s, 0.0);
        // Separating faster than the spring can hold: e_n < 0, history dropped.
        assert!(l.apply(&mut h, 1e-6, -1.0, 0.3).is_none());
        assert_eq!(h, Spring::default());
    }

    /// (8'): without tension the normal force is clamped at zero and the
    /// Coulomb cap follows it; where the total pushes, both rules agree
    /// but for the cap (μ f_n instead of μ e_n).
    #[test]
    fn without_tension_the_dashpot_never_pulls_and_caps_friction() {
        let paper = law();
        let none = ContactLaw {
            tension: Tension::None,
            ..paper
        };
        let start = Spring {
            e_n: 2e-3,
            e_s: 5e-4,
        };
        // Separating at 0.05 m/s: e_n = 2e-3 − 100·5e-6 = 1.5e-3 N, the
        // dashpot −5e-3 N.
        let (mut a, mut b) = (start, start);
        let (f_paper, s_paper) = paper.apply(&mut a, 1e-5, -0.05, 0.0).unwrap();
        let (f_none, s_none) = none.apply(&mut b, 1e-5, -0.05, 0.0).unwrap();
        assert!((f_paper - (1.5e-3 - 5e-3)).abs() < 1e-15, "{f_paper}");
        assert_eq!(f_none, 0.0);
        // The paper caps e_s at μ e_n = 7.5e-4 N (not reached: it sticks);
        // without tension at μ·0: it slides with f_s = 0.
        assert_eq!(s_paper, 5e-4);
        assert_eq!((s_none, b.e_s), (0.0, 0.0));
        assert_eq!(a.e_n, b.e_n);
        // Approaching: the same normal force; the cap μ f_n = μ(e_n + d_n) is
        // larger than μ e_n, so a push that slides under (9) sticks under (8').
        let start = Spring {
            e_n: 2e-3,
            e_s: 1.2e-3,
        };
        let (mut a, mut b) = (start, start);
        let (f_paper, s_paper) = paper.apply(&mut a, 1e-5, 0.01, 0.0).unwrap();
        let (f_none, s_none) = none.apply(&mut b, 1e-5, 0.01, 0.0).unwrap();
        assert_eq!(f_paper, f_none);
        assert_eq!(s_paper, 0.5 * a.e_n);
        assert_eq!(s_none, 1.2e-3);
        assert_eq!(
            Tension::from_code(Tension::None.code()),
            Some(Tension::None)
        );
        assert_eq!(Tension::from_code(2), None);
    }

    /// docs/model.md §11 Coulomb check: a grain of mass m pressed by a normal spring
    /// force N and pushed tangentially by F sticks (comes to rest at
    /// ξ = F/k_s) while F < μN, and slides with f_s = μN once F > μN.
    #[test]
    fn sticks_below_mu_n_and_slides_at_mu_n() {
        let l = law();
        let normal = 0.02; // N
        let m = 1e-4;
        for (push, sticks) in [
            (0.5 * 0.5 * normal, true),
            (0.9 * 0.5 * normal, true),
            (1.1 * 0.5 * normal, false),
        ] {
            let mut h = Spring {
                e_n: normal,
                e_s: 0.0,
            };
            let mut v = 0.0; // sliding speed of the grain's surface over the other
            let mut last_fs = 0.0;
            for _ in 0..20_000 {
                // The contact resists the slip: slip increments Δξ_s = −v Δt on the pushed grain.
                let (_, f_s) = l.apply(&mut h, 0.0, 0.0, -v).unwrap();
                h.e_n = normal; // N held constant (gravity)
                v += (push + f_s) / m * l.step_dt;
                last_fs = f_s;
            }
            if sticks {
                assert!(v.abs() < 1e-9, "F = {push}: v = {v}");
                assert!((last_fs + push).abs() < 1e-9 * push.max(1.0));
                assert!(
                    (h.e_s + push).abs() < 1e-6 * push,
                    "spring carries the load"
                );
            } else {
                assert!(v > 0.1, "F = {push}: should slide, v = {v}");
                assert_eq!(last_fs, -0.5 * normal, "sliding friction is exactly mu N");
            }
        }
    }
}
