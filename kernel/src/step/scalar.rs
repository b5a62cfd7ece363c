//! The scalar step: portable, one grain at a time. The contact forces
//! (6)–(9) of every overlapping listed pair, then symplectic Euler
//! (1)–(3), grain after grain ([`step`]); the drag (4)–(5) before it, flow
//! on ([`add_drag`]).
//!
//! A pair's geometry (distance, normal, relative velocities) depends only on
//! the start-of-step state (docs/model.md §2), so it may be computed ahead of the
//! laws, which must run in the fixed order (their sums are order-dependent
//! in floating point). [`Touching`] holds one grain's contacts found ahead.

use super::mover::Mover;
use crate::contact::{ContactLaw, Spring};
use crate::error::Error;
use crate::events::Events;
use crate::flow::LogLaw;
use crate::fluid::Coupling;
use crate::grains::Grains;
use crate::neighbours::Neighbours;
use crate::periodic::periodic;
use crate::real::Real;

/// The scalar step: contact forces (6)–(9) of every overlapping listed
/// pair, then symplectic Euler (1)–(3), grain after grain; the largest
/// squared speed reached, or the first failing grain's error. The
/// contacts made, broken and sliding and the seam crossings are added to
/// `events`.
///
/// Pairs are visited in the fixed order (i ascending, j ascending); the
/// history of separated pairs is dropped. Grain i appears only in pairs
/// (m ≤ i, ·), so its force is complete once its own pairs are added and
/// it is integrated at once, while its data is in cache: the same
/// operations in the same order as a contact pass over all pairs followed
/// by an integration pass over all grains, so the bits are theirs.
///
/// Each pair's geometry (distance, normal, relative velocities) depends
/// only on the start-of-step state. With buffers (`BUFFER` > 0,
/// [`super::GEOMETRY_AHEAD`]), grain i + 1's is found ([`Touching::find`])
/// before grain i's laws and motion, so that an out-of-order core works
/// on the next grain's square roots and divisions while it finishes
/// grain i; without, just before grain i's laws. The laws and sums run
/// in the fixed order either way.
pub(crate) fn step<R: Real, const N: usize, const K: usize, const BUFFER: usize>(
    grains: &mut Grains<R, N>,
    nb: &mut Neighbours<R, N, K>,
    law: ContactLaw<R>,
    width: R,
    mover: Mover<R>,
    events: &mut Events,
) -> Result<R, Error> {
    // A buffer holds every slot of a grain, or there is none.
    const { assert!(BUFFER == 0 || BUFFER >= K) };
    let ahead = BUFFER > 0;
    let n = grains.len.min(N);
    let (mut motion, mut forces, fixed) = split(grains, n, mover);
    let r = forces.r;
    // Grain i + 1's contacts can be found before grain i's laws and
    // motion: they read only start-of-step state (grain i + 1 and grains
    // j > i + 1; grain i moves after). Two buffers, used in turn.
    let (mut a, mut b) = (Touching::<R, BUFFER>::new(), Touching::<R, BUFFER>::new());
    let (mut current, mut next) = (&mut a, &mut b);
    if ahead && n > 0 {
        let state = motion.state(r, width);
        let count = usize::from(nb.count[0]).min(K);
        let springs = &mut nb.spring[0][..count];
        next.find(
            &state,
            0,
            &nb.other[0][..count],
            springs,
            &mut forces.counts.broken,
        );
    }
    for i in 0..n {
        let ri = r[i];
        // Grain i's sums live in registers: no pair (i, j) has j = i.
        let mut sums = Sums {
            fx: forces.fx[i],
            fy: forces.fy[i],
            torque: forces.torque[i],
        };
        let state = motion.state(r, width);
        if ahead {
            core::mem::swap(&mut current, &mut next);
            if i + 1 < n {
                let count = usize::from(nb.count[i + 1]).min(K);
                let springs = &mut nb.spring[i + 1][..count];
                let broken = &mut forces.counts.broken;
                next.find(&state, i + 1, &nb.other[i + 1][..count], springs, broken);
            }
            let springs = &mut nb.spring[i];
            for (k, c) in current.iter() {
                if let Some(spring) = springs.get_mut(k) {
                    forces.add(&law, spring, c, ri, &mut sums);
                }
            }
        } else {
            let count = usize::from(nb.count[i]).min(K);
            let pairs = nb.other[i][..count].iter().zip(&mut nb.spring[i][..count]);
            if let Some(own) = state.own(i) {
                for (&j, spring) in pairs {
                    if let Some(c) = state.contact(&own, j, spring, &mut forces.counts.broken) {
                        forces.add(&law, spring, &c, ri, &mut sums);
                    }
                }
            }
        }
        (forces.fx[i], forces.fy[i], forces.torque[i]) = (R::ZERO, R::ZERO, R::ZERO);
        if !fixed[i] {
            motion.advance(i, &sums)?;
        }
    }
    forces.counts.add_to(events);
    events.seam_crossings = events.seam_crossings.wrapping_add(motion.crossings);
    Ok(motion.max_v2)
}

/// Drag (4)–(5) on every mobile grain of `g` in the water (its centre at
/// or below `surface`, docs/model.md §2), heights from the mean bed level
/// `bed_level` (docs/model.md §6).
pub(crate) fn add_drag<R: Real, const N: usize>(
    g: &mut Grains<R, N>,
    log_law: &LogLaw<R>,
    bed_level: R,
    surface: R,
) {
    for i in 0..g.len.min(N) {
        if g.fixed[i] || g.y[i] > surface {
            continue;
        }
        let (fx, fy) = log_law.drag(
            g.drag_coef[i],
            g.y[i] - bed_level,
            g.u[i],
            g.v[i],
            g.z_u[i],
            g.z_v[i],
        );
        g.fx[i] += fx;
        g.fy[i] += fy;
    }
}

/// The coupled flow's drag on every mobile grain of `g` in the water (its
/// centre at or below the free surface, docs/model.md §2, §13): (4)–(5),
/// or Dallavalle's (C8), with u_f of the column at the grain's centre for
/// U, times the hindrance (C7), without sheltering (16) (the column's
/// velocity already falls inside the bed); the fluctuations (15), or
/// HydroForceEngine's (C9), of the held draws with the local shear
/// velocity of the column's Reynolds stress (C4) for u*, where u_f > 0 and
/// the `log_law`'s turbulence is on; each read linear between
/// the fluid cells' centres ([`Coupling::at`]). The streamwise drag is also summed
/// per fluid cell for the column's next update ([`Coupling::deposit`]), in grain
/// order. The batched step does the same in lanes (`batch::coupled_pass`).
pub(crate) fn add_coupled_drag<R: Real, const N: usize, const C: usize>(
    g: &mut Grains<R, N>,
    fluid: &mut Coupling<R, C>,
    log_law: &LogLaw<R>,
) {
    let closures = fluid.closures;
    for i in 0..g.len.min(N) {
        if g.fixed[i] || g.y[i] > closures.surface {
            continue;
        }
        let at = fluid.at(g.y[i]);
        let (fluct_u, fluct_v) = if log_law.turbulence && at.u > R::ZERO {
            closures.fluctuation(at.scale, g.z_u[i], g.z_v[i])
        } else {
            (R::ZERO, R::ZERO)
        };
        let wx = at.u + fluct_u - g.u[i];
        let wy = fluct_v - g.v[i];
        let speed = R::sqrt(wx * wx + wy * wy);
        let xi = closures.drag_factor(g.drag_coef[i], g.r[i], at.hindrance, speed);
        let (fx, fy) = (xi * wx, xi * wy);
        match closures.wall_friction(xi, at.scale, at.load, g.r[i], g.u[i], g.v[i]) {
            // The walls take it, not the fluid (C11).
            Some((wall_x, wall_y)) => {
                g.fx[i] += fx - wall_x;
                g.fy[i] += fy - wall_y;
            }
            None => {
                g.fx[i] += fx;
                g.fy[i] += fy;
            }
        }
        fluid.deposit(at.place.cell, at.place.frac, fx);
    }
}

/// Splits the first `n` grains into what the scalar step moves
/// ([`Motion`]), what its pair sums use ([`Forces`]), and which are fixed.
fn split<R: Real, const N: usize>(
    g: &mut Grains<R, N>,
    n: usize,
    mover: Mover<R>,
) -> (Motion<'_, R>, Forces<'_, R>, &[bool]) {
    let (motion, rest) = split_grains(g, n, mover);
    let forces = Forces {
        fx: rest.fx,
        fy: rest.fy,
        torque: rest.torque,
        r: rest.r,
        counts: Counts::default(),
    };
    (motion, forces, rest.fixed)
}

/// The first `n` grains' arrays besides their [`Motion`].
pub(crate) struct Rest<'a, R: Real> {
    pub(crate) fx: &'a mut [R],
    pub(crate) fy: &'a mut [R],
    pub(crate) torque: &'a mut [R],
    pub(crate) r: &'a [R],
    pub(crate) fixed: &'a [bool],
    pub(crate) drag_coef: &'a [R],
    pub(crate) z_u: &'a [R],
    pub(crate) z_v: &'a [R],
}

/// The first `n` grains of `g` as what moves by `mover` ([`Motion`], from
/// grain 0) and the rest of their arrays: both steps start from this.
pub(crate) fn split_grains<R: Real, const N: usize>(
    g: &mut Grains<R, N>,
    n: usize,
    mover: Mover<R>,
) -> (Motion<'_, R>, Rest<'_, R>) {
    let n = n.min(N);
    let motion = Motion {
        first: 0,
        x: &mut g.x[..n],
        y: &mut g.y[..n],
        u: &mut g.u[..n],
        v: &mut g.v[..n],
        w: &mut g.w[..n],
        inv_mass: &g.inv_mass[..n],
        inv_inertia: &g.inv_inertia[..n],
        mover,
        max_v2: R::ZERO,
        crossings: 0,
    };
    let rest = Rest {
        fx: &mut g.fx[..n],
        fy: &mut g.fy[..n],
        torque: &mut g.torque[..n],
        r: &g.r[..n],
        fixed: &g.fixed[..n],
        drag_coef: &g.drag_coef[..n],
        z_u: &g.z_u[..n],
        z_v: &g.z_v[..n],
    };
    (motion, rest)
}

/// The state of a range of grains (from grain `first`; the scalar step's:
/// all, from 0) while they move, the largest squared speed reached and the
/// seam crossings. The phased step moves its ranges with it too.
pub(crate) struct Motion<'a, R: Real> {
    pub(crate) first: usize,
    pub(crate) x: &'a mut [R],
    pub(crate) y: &'a mut [R],
    pub(crate) u: &'a mut [R],
    pub(crate) v: &'a mut [R],
    pub(crate) w: &'a mut [R],
    pub(crate) inv_mass: &'a [R],
    pub(crate) inv_inertia: &'a [R],
    pub(crate) mover: Mover<R>,
    pub(crate) max_v2: R,
    pub(crate) crossings: u64,
}

impl<R: Real> Motion<'_, R> {
    /// The state as the pair geometry reads it (radii `r`, periodic `width`).
    #[inline(always)]
    fn state<'s>(&'s self, r: &'s [R], width: R) -> State<'s, R> {
        State::new([&*self.x, &*self.y, &*self.u, &*self.v, &*self.w, r], width)
    }

    /// Moves mobile grain `first + i` under its force and torque `sums`
    /// ([`Mover::advance`]).
    #[inline(always)]
    pub(crate) fn advance(&mut self, i: usize, sums: &Sums<R>) -> Result<(), Error> {
        // Read here, not kept from the top: fewer live registers in the
        // pair loops.
        let (moved, wrapped) = self.mover.advance(
            self.first + i,
            [self.x[i], self.y[i], self.u[i], self.v[i], self.w[i]],
            [
                sums.fx * self.inv_mass[i],
                sums.fy * self.inv_mass[i],
                sums.torque * self.inv_inertia[i],
            ],
        )?;
        [self.x[i], self.y[i], self.u[i], self.v[i], self.w[i]] = moved;
        self.crossings = self.crossings.wrapping_add(u64::from(wrapped));
        self.max_v2 = R::max(self.max_v2, moved[2] * moved[2] + moved[3] * moved[3]);
        Ok(())
    }
}

/// The start-of-step state the geometry reads: positions, velocities,
/// spins and radii of the grains, and the periodic width.
#[derive(Clone, Copy)]
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
    /// in contact. Drops the history (`spring`) of a pair that is apart,
    /// counting it in `broken` if it was a contact; `None` also for j out
    /// of range and coincident centres.
    #[inline(always)]
    pub(crate) fn contact(
        &self,
        own: &Own<R>,
        j: u32,
        spring: &mut Spring<R>,
        broken: &mut u64,
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
            *broken = broken.wrapping_add(u64::from(spring.e_n != R::ZERO));
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
    /// Tangential slip speed (docs/model.md §2).
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
/// grain's force arrays (for j), with the radii for the torques; and the
/// contacts made, broken and sliding so far.
struct Forces<'a, R: Real> {
    fx: &'a mut [R],
    fy: &'a mut [R],
    torque: &'a mut [R],
    r: &'a [R],
    counts: Counts,
}

impl<R: Real> Forces<'_, R> {
    /// Advances the contact's history by the law (6)–(9) and adds its force
    /// −f_n n + f_s t to grain i (radius `ri`, sums `own`) and the opposite
    /// to grain j, with the torques −r f_s.
    #[inline(always)]
    fn add(
        &mut self,
        law: &ContactLaw<R>,
        spring: &mut Spring<R>,
        c: &Contact<R>,
        ri: R,
        own: &mut Sums<R>,
    ) {
        let Some((fx_pair, fy_pair, f_s)) = pair_force(law, spring, c, &mut self.counts) else {
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
        own.fx += fx_pair;
        own.fy += fy_pair;
        *fxj -= fx_pair;
        *fyj -= fy_pair;
        own.torque -= ri * f_s;
        *tj -= rj * f_s;
    }
}

/// Contacts made, broken and sliding (docs/model.md (6)–(9)), counted as
/// the step meets them.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Counts {
    pub(crate) made: u64,
    pub(crate) broken: u64,
    pub(crate) sliding: u64,
}

impl Counts {
    /// The counts of two ranges together.
    pub(crate) fn merge(self, other: Counts) -> Counts {
        Counts {
            made: self.made.wrapping_add(other.made),
            broken: self.broken.wrapping_add(other.broken),
            sliding: self.sliding.wrapping_add(other.sliding),
        }
    }

    /// Adds the counts to `events`.
    pub(crate) fn add_to(&self, events: &mut Events) {
        events.contacts_made = events.contacts_made.wrapping_add(self.made);
        events.contacts_broken = events.contacts_broken.wrapping_add(self.broken);
        events.contacts_sliding = events.contacts_sliding.wrapping_add(self.sliding);
    }
}

/// Advances a contact's history by the law (6)–(9) and gives its force
/// −f_n n + f_s t on grain i and its tangential force f_s (the torques are
/// −r f_s on each grain), counting it in `counts`; `None` if the law
/// breaks it. Both the scalar and the phased step call this.
#[inline(always)]
pub(crate) fn pair_force<R: Real>(
    law: &ContactLaw<R>,
    spring: &mut Spring<R>,
    c: &Contact<R>,
    counts: &mut Counts,
) -> Option<(R, R, R)> {
    let first = spring.e_n == R::ZERO;
    let Some((f_n, f_s, slides)) = law.apply_sliding(spring, c.overlap, c.v_n, c.v_s) else {
        counts.broken = counts.broken.wrapping_add(u64::from(!first));
        return None;
    };
    counts.made = counts.made.wrapping_add(u64::from(first));
    counts.sliding = counts.sliding.wrapping_add(u64::from(slides));
    // t = (sin α, −cos α) = (n_y, −n_x)
    let (tx, ty) = (c.ny, -c.nx);
    Some((-f_n * c.nx + f_s * tx, -f_n * c.ny + f_s * ty, f_s))
}

/// The contacts of one grain found ahead of its laws: slot and geometry.
struct Touching<R: Real, const K: usize> {
    len: usize,
    slot: [u8; K],
    contact: [Contact<R>; K],
}

impl<R: Real, const K: usize> Touching<R, K> {
    /// Empty.
    fn new() -> Self {
        Touching {
            len: 0,
            slot: [0; K],
            contact: [Contact::ZERO; K],
        }
    }

    /// Replaces the contents by grain i's contacts in slot order (`slots`:
    /// each slot's j, `springs`: its history), [`State::contact`], which
    /// counts the contacts it drops in `broken`.
    #[inline(always)]
    fn find(
        &mut self,
        s: &State<'_, R>,
        i: usize,
        slots: &[u32],
        springs: &mut [Spring<R>],
        broken: &mut u64,
    ) {
        self.len = 0;
        let Some(own) = s.own(i) else {
            return;
        };
        let mut len = 0;
        for (k, (&j, spring)) in slots.iter().zip(springs).enumerate() {
            if let (Some(c), true) = (s.contact(&own, j, spring, broken), len < K) {
                (self.slot[len], self.contact[len]) = (k as u8, c);
                len += 1;
            }
        }
        self.len = len;
    }

    /// The contacts found: (slot, geometry), in slot order.
    #[inline(always)]
    fn iter(&self) -> impl Iterator<Item = (usize, &Contact<R>)> {
        let len = self.len.min(K);
        let slots = self.slot[..len].iter().map(|&k| usize::from(k));
        slots.zip(&self.contact[..len])
    }
}
