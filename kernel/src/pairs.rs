//! The pair work of a step: the geometry of each listed pair from the
//! start-of-step state (SPEC §2), and its contact force (6)–(9) added to
//! both grains.
//!
//! A pair's geometry (distance, normal, relative velocities) depends only on
//! the start-of-step state, so it may be computed ahead of the laws, which
//! must run in the fixed order (their sums are order-dependent in floating
//! point). [`Touching`] holds one grain's contacts found ahead.

use crate::contact::{ContactLaw, Spring};
use crate::neighbours::periodic;
use crate::real::Real;

/// The start-of-step state the geometry reads: positions, velocities,
/// spins and radii of the grains, and the periodic width.
pub(crate) struct State<'a, R: Real> {
    x: &'a [R],
    y: &'a [R],
    u: &'a [R],
    v: &'a [R],
    w: &'a [R],
    r: &'a [R],
    width: R,
    /// width / 2.
    half_width: R,
}

/// Grain i's part of its pairs' geometry.
pub(crate) struct Own<R: Real> {
    x: R,
    y: R,
    u: R,
    v: R,
    /// r ω.
    spin: R,
    r: R,
}

impl<'a, R: Real> State<'a, R> {
    /// The state of arrays x, y, u, v, ω, r (m, m/s, rad/s) in a periodic
    /// width (m).
    #[inline(always)]
    pub(crate) fn new([x, y, u, v, w, r]: [&'a [R]; 6], width: R) -> Self {
        State {
            x,
            y,
            u,
            v,
            w,
            r,
            width,
            half_width: width * R::HALF,
        }
    }

    /// Grain i's state, if it exists.
    #[inline(always)]
    pub(crate) fn own(&self, i: usize) -> Option<Own<R>> {
        let (&x, &y, &u) = (self.x.get(i)?, self.y.get(i)?, self.u.get(i)?);
        let (&v, &w, &r) = (self.v.get(i)?, self.w.get(i)?, self.r.get(i)?);
        Some(Own {
            x,
            y,
            u,
            v,
            spin: r * w,
            r,
        })
    }

    /// The geometry of listed pair (i, j) of grain i (`own`) if the two are
    /// in contact. Drops the history (`spring`) of a pair that is apart;
    /// `None` also for j out of range and coincident centres.
    #[inline(always)]
    pub(crate) fn contact(
        &self,
        own: &Own<R>,
        j: u32,
        spring: &mut Spring<R>,
    ) -> Option<Contact<R>> {
        let j = j as usize;
        // Grain j's values are read where the equations need them: fewer
        // live registers on small cores.
        let (&xj, &yj, &rj) = (self.x.get(j)?, self.y.get(j)?, self.r.get(j)?);
        let dx = periodic(xj - own.x, self.width, self.half_width);
        let dy = yj - own.y;
        let reach = own.r + rj;
        let dist2 = dx * dx + dy * dy;
        if dist2 >= reach * reach {
            *spring = Spring::ZERO;
            return None;
        }
        let dist = R::sqrt(dist2);
        if dist == R::ZERO {
            // Coincident centres: no direction to push along.
            return None;
        }
        let inv = R::ONE / dist;
        let (nx, ny) = (dx * inv, dy * inv);
        // t = (sin α, −cos α) = (n_y, −n_x)
        let (tx, ty) = (ny, -nx);
        let du = own.u - *self.u.get(j)?;
        let dv = own.v - *self.v.get(j)?;
        let v_n = du * nx + dv * ny;
        let v_s = -(du * tx + dv * ty) + own.spin + rj * *self.w.get(j)?;
        Some(Contact {
            j: j as u32,
            nx,
            ny,
            overlap: reach - dist,
            v_n,
            v_s,
        })
    }
}

/// The geometry of a pair (i, j) in contact: what the law (6)–(9) needs.
#[derive(Clone, Copy)]
pub(crate) struct Contact<R: Real> {
    j: u32,
    /// Unit normal from i to j.
    nx: R,
    ny: R,
    /// r_i + r_j − distance (> 0).
    overlap: R,
    /// Normal approach speed (v_i − v_j)·n.
    v_n: R,
    /// Tangential slip speed (SPEC §2).
    v_s: R,
}

impl<R: Real> Contact<R> {
    const ZERO: Self = Contact {
        j: 0,
        nx: R::ZERO,
        ny: R::ZERO,
        overlap: R::ZERO,
        v_n: R::ZERO,
        v_s: R::ZERO,
    };
}

/// The force and torque sums of one grain.
pub(crate) struct Sums<R: Real> {
    pub(crate) fx: R,
    pub(crate) fy: R,
    pub(crate) torque: R,
}

/// Where a contact's force goes: grain i's sums (in registers) and every
/// grain's force arrays (for j), with the radii for the torques.
pub(crate) struct Forces<'a, R: Real> {
    pub(crate) fx: &'a mut [R],
    pub(crate) fy: &'a mut [R],
    pub(crate) torque: &'a mut [R],
    pub(crate) r: &'a [R],
}

impl<R: Real> Forces<'_, R> {
    /// Advances the contact's history by the law (6)–(9) and adds its force
    /// −f_n n + f_s t to grain i (radius `ri`, sums `own`) and the opposite
    /// to grain j, with the torques −r f_s.
    #[inline(always)]
    pub(crate) fn add(
        &mut self,
        law: &ContactLaw<R>,
        spring: &mut Spring<R>,
        c: &Contact<R>,
        ri: R,
        own: &mut Sums<R>,
    ) {
        let Some((f_n, f_s)) = law.apply(spring, c.overlap, c.v_n, c.v_s) else {
            return;
        };
        let j = c.j as usize;
        let (Some(fxj), Some(fyj), Some(tj), Some(&rj)) = (
            self.fx.get_mut(j),
            self.fy.get_mut(j),
            self.torque.get_mut(j),
            self.r.get(j),
        ) else {
            return;
        };
        // t = (sin α, −cos α) = (n_y, −n_x)
        let (tx, ty) = (c.ny, -c.nx);
        let fx_pair = -f_n * c.nx + f_s * tx;
        let fy_pair = -f_n * c.ny + f_s * ty;
        own.fx += fx_pair;
        own.fy += fy_pair;
        *fxj -= fx_pair;
        *fyj -= fy_pair;
        own.torque -= ri * f_s;
        *tj -= rj * f_s;
    }
}

/// The contacts of one grain found ahead of its laws: slot and geometry.
pub(crate) struct Touching<R: Real, const K: usize> {
    len: usize,
    slot: [u8; K],
    contact: [Contact<R>; K],
}

impl<R: Real, const K: usize> Touching<R, K> {
    /// Empty.
    pub(crate) fn new() -> Self {
        Touching {
            len: 0,
            slot: [0; K],
            contact: [Contact::ZERO; K],
        }
    }

    /// Replaces the contents by grain i's contacts in slot order (`slots`:
    /// each slot's j, `springs`: its history), [`State::contact`].
    #[inline(always)]
    pub(crate) fn find(
        &mut self,
        s: &State<'_, R>,
        i: usize,
        slots: &[u32],
        springs: &mut [Spring<R>],
    ) {
        self.len = 0;
        let Some(own) = s.own(i) else {
            return;
        };
        let mut len = 0;
        for (k, (&j, spring)) in slots.iter().zip(springs).enumerate() {
            if let (Some(c), true) = (s.contact(&own, j, spring), len < K) {
                (self.slot[len], self.contact[len]) = (k as u8, c);
                len += 1;
            }
        }
        self.len = len;
    }

    /// The contacts found: (slot, geometry), in slot order.
    #[inline(always)]
    pub(crate) fn iter(&self) -> impl Iterator<Item = (usize, &Contact<R>)> {
        let len = self.len.min(K);
        let slots = self.slot[..len].iter().map(|&k| usize::from(k));
        slots.zip(&self.contact[..len])
    }
}
