//! The integrator both step paths share: symplectic Euler for one mobile
//! grain (docs/model.md (1)–(3)), velocities first, then positions from the new
//! velocities, with the periodic wrap in x and the checks that every value
//! is finite and inside the domain.

use crate::error::{Error, Quantity};
use crate::periodic::into_domain;
use crate::real::Real;

/// Symplectic Euler for one mobile grain (docs/model.md (1)–(3)) with the periodic
/// wrap in x and the non-finite and out-of-domain checks.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Mover<R: Real> {
    /// The integration step.
    pub(crate) step_dt: R,
    /// Reduced gravity, docs/model.md (2).
    pub(crate) gravity: [R; 2],
    pub(crate) width: R,
    pub(crate) y_min: R,
    pub(crate) y_max: R,
    /// The free surface: above it, `air_gravity` and forces times `air_ratio`.
    pub(crate) surface: R,
    /// The whole weight's acceleration, out of the water.
    pub(crate) air_gravity: [R; 2],
    /// m'/m_s: an acceleration of a force out of the water over in it.
    pub(crate) air_ratio: R,
    /// The step count, for the errors.
    pub(crate) step: u64,
}

impl<R: Real> Mover<R> {
    /// The new (x, y, u, v, ω) of grain `i` from its state and its
    /// accelerations (F_x/m', F_y/m', T/I): velocities first, then positions
    /// from the new velocities; and whether it wrapped across the seam. A
    /// grain whose centre lies above the free surface is out of the water:
    /// its forces accelerate its own mass m_s = m' / `air_ratio` and it
    /// feels its whole weight (docs/model.md §2).
    #[inline]
    pub(crate) fn advance(
        &self,
        i: usize,
        state: [R; 5],
        accel: [R; 3],
    ) -> Result<([R; 5], bool), Error> {
        let [x, y, u, v, w] = state;
        let dt = self.step_dt;
        let spin = accel[2];
        let (accel, gravity) = if y > self.surface {
            let ratio = self.air_ratio;
            ([accel[0] * ratio, accel[1] * ratio], self.air_gravity)
        } else {
            ([accel[0], accel[1]], self.gravity)
        };
        let u = u + (accel[0] + gravity[0]) * dt;
        let v = v + (accel[1] + gravity[1]) * dt;
        let w = w + spin * dt;
        let (x, wrapped) = into_domain(x + u * dt, self.width);
        let y = y + v * dt;
        // One test on the common path: every value finite and inside the domain.
        // The domain test also rejects a non-finite u or v (x, y then become
        // ±∞ or NaN, step_dt > 0) and a non-finite y; ω needs its own test.
        if R::is_finite(w) && x >= R::ZERO && x < self.width && y >= self.y_min && y <= self.y_max {
            Ok(([x, y, u, v, w], wrapped))
        } else {
            Err(self.fault(i, [x, y, u, v, w]))
        }
    }

    /// The error for a grain that failed [`Mover::advance`]'s test, in the
    /// order velocity, spin, position, domain.
    #[cold]
    fn fault(&self, i: usize, [x, y, u, v, w]: [R; 5]) -> Error {
        let (step, grain) = (self.step, i as u32);
        let quantity = if !(R::is_finite(u) && R::is_finite(v)) {
            Quantity::Velocity
        } else if !R::is_finite(w) {
            Quantity::Spin
        } else if !(R::is_finite(x) && R::is_finite(y)) {
            Quantity::Position
        } else {
            return Error::LeftDomain {
                step,
                grain,
                y: y.to_f64(),
            };
        };
        Error::NonFinite {
            step,
            grain,
            quantity,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Out of the water a force accelerates the grain's own mass, m'/m_s =
    /// `air_ratio` times more than in it, and the whole weight acts.
    #[test]
    fn out_of_the_water_a_grain_has_its_own_mass_and_weight() {
        let mover = Mover {
            step_dt: 0.5,
            gravity: [0.25, -0.5],
            width: 10.0,
            y_min: -10.0,
            y_max: 10.0,
            surface: 1.0,
            air_gravity: [1.0, -4.0],
            air_ratio: 1.5,
            step: 0,
        };
        let water = mover.advance(0, [0.0, 1.0, 0.0, 0.0, 0.0], [2.0, 2.0, 2.0]);
        assert_eq!(water.unwrap().0, [0.5625, 1.375, 1.125, 0.75, 1.0]);
        let air = mover.advance(0, [0.0, 1.5, 0.0, 0.0, 0.0], [2.0, 2.0, 2.0]);
        // u = (2 × 1.5 + 1) × 0.5, v = (2 × 1.5 − 4) × 0.5, the spin as in water.
        assert_eq!(air.unwrap().0, [1.0, 1.25, 2.0, -0.5, 1.0]);
    }
}
