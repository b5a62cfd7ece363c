//! The phased step: the scalar step's operations ([`super::scalar`])
//! regrouped into two phases over ranges of grains, so that the ranges can
//! run on different cores and any cut gives the bits of the whole.
//!
//! 1. **Pairs** ([`PairPhase`]): every listed pair (i, slot) of the range's
//!    first grains i: its geometry from the start-of-step state, its law
//!    (6)–(9), which advances its spring history (held in grain i's slot:
//!    no two ranges share one), and its force on i and tangential force,
//!    written to the pair's place in [`Phases`].
//! 2. **Moves** ([`MovePhase`]): every grain k of the range gathers its
//!    sums in the scalar step's order — its drag (clear water (4)–(5); the
//!    coupled flow's is added before the phases), the pairs (i < k, ·) that
//!    name it, i ascending ([`Phases`] lists them when the neighbour lists
//!    change), then its own pairs in slot order — and moves (1)–(3).
//!
//! The scalar step adds to grain k the same terms in the same order (a
//! pair (i, k) adds to k's force array when grain i is visited, before
//! grain k's own pairs), so each sum has its bits. A pair out of contact
//! adds +0 where the scalar step adds nothing: a sum starts at +0 (or a
//! drag added to +0) and is never −0, so s + 0 = s − 0 = s. Counts add up
//! in any order; the largest speed is a maximum; the error of a failed
//! move is the first grain's in grain order, as in the scalar step (the
//! grains of the other ranges may have moved by then: a failed step leaves
//! the simulation for [`crate::Sim::restore`] or a reset).
//!
//! Where the batched step has lanes and its pair index is ready, the same
//! phases run in lanes (`step::batch::phases`, with the same bits).
//!
//! Who runs the ranges is the caller's [`Executor`]: [`Serial`] runs each
//! phase whole, [`Ranges`] cuts it into ranges run one after the other (on
//! one core, as a board does), and a host cuts it among threads (the `mbs`
//! host: rayon). The kernel holds no thread and allocates nothing.

use super::buffers::Phases;
use super::mover::Mover;
use super::scalar::{pair_force, split_grains, Counts, Motion, State, Sums};
use crate::contact::{ContactLaw, Spring};
use crate::error::Error;
use crate::executor::Phase;
use crate::flow::LogLaw;
use crate::grains::Grains;
use crate::neighbours::Neighbours;
use crate::real::Real;

/// Cuts the phase `$this` at grain `$mid`: each listed field, a slice over
/// the range's grains (`mut`: mutable), at `$mid`, and each `own` field by
/// its own `split_at`; the other fields (shared, copied) as they are; the
/// second part's first grain `first + $mid`.
macro_rules! cut_at {
    ($this:ident, $mid:expr; mut $($m:ident),*; ref $($r:ident),* $(; own $($o:ident),*)?) => {{
        let mid = $mid;
        $(let $m = core::mem::take(&mut $this.$m);
          let $m = $m.split_at_mut(mid.min($m.len()));)*
        $(let $r = $this.$r.split_at(mid.min($this.$r.len()));)*
        $($(let $o = $this.$o.split_at(mid);)*)?
        let second = Self {
            first: $this.first + mid,
            $($m: $m.1,)*
            $($r: $r.1,)*
            $($($o: $o.1,)*)?
            ..$this
        };
        let first = Self {
            $($m: $m.0,)*
            $($r: $r.0,)*
            $($($o: $o.0,)*)?
            ..$this
        };
        (first, second)
    }};
}

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub(crate) use cut_at;

/// The pair phase over a range of first grains (module docs, phase 1).
pub(crate) struct PairPhase<'a, R: Real, const K: usize> {
    /// Index of the range's first grain.
    first: usize,
    /// The start-of-step state of every grain.
    state: State<'a, R>,
    count: &'a [u8],
    other: &'a [[u32; K]],
    spring: &'a mut [[Spring<R>; K]],
    fx: &'a mut [[R; K]],
    fy: &'a mut [[R; K]],
    fs: &'a mut [[R; K]],
    law: ContactLaw<R>,
}

impl<'a, R: Real, const K: usize> PairPhase<'a, R, K> {
    /// The pair phase of the first `n` grains of `g` over the lists `nb`,
    /// writing to `out`; periodic `width`.
    pub(crate) fn new<const N: usize>(
        g: &'a Grains<R, N>,
        nb: &'a mut Neighbours<R, N, K>,
        out: &'a mut Phases<R, N, K>,
        n: usize,
        law: ContactLaw<R>,
        width: R,
    ) -> Self {
        let n = n.min(N);
        PairPhase {
            first: 0,
            state: State::new(
                [
                    &g.x[..n],
                    &g.y[..n],
                    &g.u[..n],
                    &g.v[..n],
                    &g.w[..n],
                    &g.r[..n],
                ],
                width,
            ),
            count: &nb.count[..n],
            other: &nb.other[..n],
            spring: &mut nb.spring[..n],
            fx: &mut out.fx[..n],
            fy: &mut out.fy[..n],
            fs: &mut out.fs[..n],
            law,
        }
    }
}

impl<R: Real, const K: usize> Phase for PairPhase<'_, R, K> {
    type Output = Counts;

    fn grains(&self) -> usize {
        self.count.len()
    }

    fn split_at(mut self, mid: usize) -> (Self, Self) {
        let mid = mid.min(self.count.len());
        cut_at!(self, mid; mut spring, fx, fy, fs; ref count, other)
    }

    fn run(self) -> Counts {
        let mut counts = Counts::default();
        let rows = self
            .count
            .iter()
            .zip(self.other)
            .zip(self.spring.iter_mut());
        let out = self
            .fx
            .iter_mut()
            .zip(self.fy.iter_mut())
            .zip(self.fs.iter_mut());
        for (offset, (((&count, other), springs), ((fx, fy), fs))) in rows.zip(out).enumerate() {
            let count = usize::from(count).min(K);
            fx[..count].fill(R::ZERO);
            fy[..count].fill(R::ZERO);
            fs[..count].fill(R::ZERO);
            let Some(own) = self.state.own(self.first + offset) else {
                continue;
            };
            for (k, (&j, spring)) in other[..count].iter().zip(springs).enumerate() {
                let broken = &mut counts.broken;
                if let Some(c) = self.state.contact(&own, j, spring, broken)
                    && let Some((x, y, s)) = pair_force(&self.law, spring, &c, &mut counts)
                {
                    (fx[k], fy[k], fs[k]) = (x, y, s);
                }
            }
        }
        counts
    }

    fn merge(first: Counts, second: Counts) -> Counts {
        first.merge(second)
    }
}

impl<R: Real> Motion<'_, R> {
    /// The first `mid` grains of the range and the rest (`mid` clamped),
    /// each counting its own speeds and crossings from none.
    fn split_at(mut self, mid: usize) -> (Self, Self) {
        self.max_v2 = R::ZERO;
        self.crossings = 0;
        let mid = mid.min(self.x.len());
        cut_at!(self, mid; mut x, y, u, v, w; ref inv_mass, inv_inertia)
    }
}

/// What the move phase gives: the largest squared speed and the seam
/// crossings, or the first failing grain's error.
pub(crate) type Moved<R> = Result<(R, u64), Error>;

/// What two adjacent ranges of a move phase give together: the larger
/// squared speed, the crossings added, or the first range's error.
pub(crate) fn merge_moved<R: Real>(first: Moved<R>, second: Moved<R>) -> Moved<R> {
    let (v_a, c_a) = first?;
    let (v_b, c_b) = second?;
    Ok((R::max(v_a, v_b), c_a.wrapping_add(c_b)))
}

/// The clear-water drag (4)–(5) a move phase adds first: the log law, the
/// mean bed level and the free surface (docs/model.md §2, §6).
#[derive(Clone, Copy)]
pub(crate) struct ClearDrag<R: Real> {
    pub(crate) log_law: LogLaw<R>,
    pub(crate) bed_level: R,
    pub(crate) surface: R,
}

/// The move phase over a range of grains (module docs, phase 2).
pub(crate) struct MovePhase<'a, R: Real, const K: usize> {
    /// Index of the range's first grain.
    first: usize,
    /// The range's state and its integration, as the scalar step's.
    motion: Motion<'a, R>,
    fx: &'a mut [R],
    fy: &'a mut [R],
    torque: &'a mut [R],
    r: &'a [R],
    fixed: &'a [bool],
    drag_coef: &'a [R],
    z_u: &'a [R],
    z_v: &'a [R],
    count: &'a [u8],
    start: &'a [u32],
    end: &'a [u32],
    /// Every grain's pairs (shared).
    pair_fx: &'a [R],
    pair_fy: &'a [R],
    pair_fs: &'a [R],
    incoming: &'a [u32],
    drag: Option<ClearDrag<R>>,
}

impl<'a, R: Real, const K: usize> MovePhase<'a, R, K> {
    /// The move phase of the first `n` grains of `g` with the pairs in
    /// `pairs` (indexed for these lists), the clear-water `drag` if the flow
    /// is clear water, and the integrator `mover`.
    pub(crate) fn new<const N: usize>(
        g: &'a mut Grains<R, N>,
        nb: &'a Neighbours<R, N, K>,
        pairs: &'a Phases<R, N, K>,
        n: usize,
        drag: Option<ClearDrag<R>>,
        mover: Mover<R>,
    ) -> Self {
        let n = n.min(N);
        let (motion, rest) = split_grains(g, n, mover);
        MovePhase {
            first: 0,
            motion,
            fx: rest.fx,
            fy: rest.fy,
            torque: rest.torque,
            r: rest.r,
            fixed: rest.fixed,
            drag_coef: rest.drag_coef,
            z_u: rest.z_u,
            z_v: rest.z_v,
            count: &nb.count[..n],
            start: &pairs.start[..n],
            end: &pairs.end[..n],
            pair_fx: pairs.fx.as_flattened(),
            pair_fy: pairs.fy.as_flattened(),
            pair_fs: pairs.fs.as_flattened(),
            incoming: pairs.incoming.as_flattened(),
            drag,
        }
    }
}

impl<R: Real, const K: usize> Phase for MovePhase<'_, R, K> {
    type Output = Moved<R>;

    fn grains(&self) -> usize {
        self.fx.len()
    }

    fn split_at(mut self, mid: usize) -> (Self, Self) {
        let mid = mid.min(self.fx.len());
        cut_at!(self, mid;
            mut fx, fy, torque;
            ref r, fixed, drag_coef, z_u, z_v, count, start, end;
            own motion)
    }

    fn run(mut self) -> Moved<R> {
        for k in 0..self.fx.len() {
            let (Some(&r), Some(&fixed)) = (self.r.get(k), self.fixed.get(k)) else {
                break;
            };
            let (mut sx, mut sy, mut st) = (self.fx[k], self.fy[k], self.torque[k]);
            if let Some(d) = &self.drag {
                // As `scalar::add_drag`, on the start-of-step state.
                if !fixed && self.motion.y[k] <= d.surface {
                    let (fx, fy) = d.log_law.drag(
                        self.drag_coef.get(k).copied().unwrap_or(R::ZERO),
                        self.motion.y[k] - d.bed_level,
                        self.motion.u[k],
                        self.motion.v[k],
                        self.z_u.get(k).copied().unwrap_or(R::ZERO),
                        self.z_v.get(k).copied().unwrap_or(R::ZERO),
                    );
                    sx += fx;
                    sy += fy;
                }
            }
            // The pairs (i < k, ·) that name k, i ascending: −f, −r_k f_s.
            let (from, to) = (self.start.get(k), self.end.get(k));
            let incoming = match (from, to) {
                (Some(&a), Some(&b)) => self.incoming.get(a as usize..b as usize).unwrap_or(&[]),
                _ => &[],
            };
            for &p in incoming {
                let p = p as usize;
                if let (Some(&x), Some(&y), Some(&s)) = (
                    self.pair_fx.get(p),
                    self.pair_fy.get(p),
                    self.pair_fs.get(p),
                ) {
                    sx -= x;
                    sy -= y;
                    st -= r * s;
                }
            }
            // Its own pairs, slot order: +f, −r_k f_s.
            let own = (self.first + k) * K;
            let count = usize::from(self.count.get(k).copied().unwrap_or(0)).min(K);
            for p in own..own + count {
                if let (Some(&x), Some(&y), Some(&s)) = (
                    self.pair_fx.get(p),
                    self.pair_fy.get(p),
                    self.pair_fs.get(p),
                ) {
                    sx += x;
                    sy += y;
                    st -= r * s;
                }
            }
            (self.fx[k], self.fy[k], self.torque[k]) = (R::ZERO, R::ZERO, R::ZERO);
            if fixed {
                continue;
            }
            let sums = Sums {
                fx: sx,
                fy: sy,
                torque: st,
            };
            self.motion.advance(k, &sums)?;
        }
        Ok((self.motion.max_v2, self.motion.crossings))
    }

    fn merge(first: Moved<R>, second: Moved<R>) -> Moved<R> {
        merge_moved(first, second)
    }
}
