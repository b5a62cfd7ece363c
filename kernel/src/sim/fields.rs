//! `impl Sim`: one grain's state field ([`GrainField`]) read in the working
//! precision, and moved by a number of units in the last place (ULPs) —
//! how a test or a user shows where two runs part (docs/determinism.md,
//! "Locating a divergence").

use crate::error::Error;
use crate::fields::GrainField;
use crate::real::Real;
use crate::sim::Sim;

impl<R: Real, const N: usize, const K: usize, const C: usize> Sim<R, N, K, C> {
    fn slot(&mut self, i: usize, field: GrainField) -> Option<&mut R> {
        let g = &mut self.grains;
        if i >= g.len {
            return None;
        }
        Some(match field {
            GrainField::X => &mut g.x[i],
            GrainField::Y => &mut g.y[i],
            GrainField::U => &mut g.u[i],
            GrainField::V => &mut g.v[i],
            GrainField::Spin => &mut g.w[i],
            GrainField::DrawU => &mut g.z_u[i],
            GrainField::DrawV => &mut g.z_v[i],
        })
    }

    /// Grain `i`'s `field` in the working precision, if the grain exists.
    pub fn field(&self, i: usize, field: GrainField) -> Option<R> {
        let g = &self.grains;
        (i < g.len).then(|| match field {
            GrainField::X => g.x[i],
            GrainField::Y => g.y[i],
            GrainField::U => g.u[i],
            GrainField::V => g.v[i],
            GrainField::Spin => g.w[i],
            GrainField::DrawU => g.z_u[i],
            GrainField::DrawV => g.z_v[i],
        })
    }

    /// Moves grain `i`'s `field` by `ulps` units in the last place of the
    /// working precision (a deliberate, smallest possible perturbation).
    /// Refused, changing nothing, for a grain that does not exist or a
    /// value that would leave its range (non-finite, x outside [0, L),
    /// y outside the domain).
    ///
    /// ```
    /// use mbs_kernel::{GrainField, Real, Scenario, Sim};
    ///
    /// let mut a = Sim::<f32, 64, 8>::new();
    /// Scenario::paper().build(&mut a)?;
    /// let mut b = a.clone();
    /// b.nudge(3, GrainField::Y, 1)?;
    /// let (ya, yb) = (a.field(3, GrainField::Y).unwrap(), b.field(3, GrainField::Y).unwrap());
    /// assert_eq!(yb.ordinal() - ya.ordinal(), 1);
    /// assert_ne!(a.digest(), b.digest());
    /// assert!(b.nudge(1000, GrainField::Y, 1).is_err());
    /// # Ok::<(), mbs_kernel::Error>(())
    /// ```
    pub fn nudge(&mut self, i: usize, field: GrainField, ulps: i64) -> Result<(), Error> {
        let (width, y_min, y_max) = (self.config.width, self.config.y_min, self.config.y_max);
        let Some(slot) = self.slot(i, field) else {
            return Err(Error::InvalidParameter {
                name: "nudge grain",
                value: i as f64,
                allowed: "an index below the number of grains",
            });
        };
        let moved = R::from_ordinal(slot.ordinal().saturating_add(ulps));
        let x = moved.to_f64();
        let ok = R::is_finite(moved)
            && match field {
                GrainField::X => (0.0..width).contains(&x),
                GrainField::Y => (y_min..=y_max).contains(&x),
                _ => true,
            };
        if !ok {
            return Err(Error::InvalidParameter {
                name: field.name(),
                value: x,
                allowed: "finite and inside the domain",
            });
        }
        *slot = moved;
        Ok(())
    }
}
