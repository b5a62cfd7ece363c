//! The grains' motion in lanes, the batched step's last pass: every
//! mobile grain, L at a time, moved by symplectic Euler (docs/model.md
//! (1)–(3)) from its sums (drag and contact forces, torque), which it
//! zeroes, lane by lane the operations of
//! [`Mover::advance`](crate::step::mover::Mover::advance): velocities
//! first, then positions from the new velocities, the periodic wrap in x,
//! the checks that every value is finite and inside the domain. A group
//! with a failing grain is redone grain by grain by `Mover::advance`
//! itself, so the error is the scalar step's.
//!
//! Written once for both precisions: `grains!` writes the module `grains`
//! into each precision's module of the batched step (`lanes!` in
//! [`super`]).

/// Writes the module `grains` (the pass `grain_pass`) in the lanes of
/// `lanes::$lanes` ([`crate::lanes`]).
macro_rules! grains {
    ($lanes:ident) => {
        /// The grain pass in these lanes (`step/batch/grains.rs`).
        pub(super) mod grains {
            use crate::error::Error;
            use crate::lanes::$lanes::*;
            use crate::real::Real;
            use crate::step::batch::params::Moving;
            use crate::step::mover::Mover;

            /// Every grain's motion (`Mover::advance`) of the range `s` by
            /// `m` from its sums, which it zeroes, L grains at a time, each
            /// group of mobile grains after `before` (given the group and its
            /// sums) has added to its sums: the largest squared speed and
            /// the seam crossings, or the first failing grain's error (the
            /// range's sums then all zeroed).
            #[target_feature(enable = "avx2")]
            pub(crate) fn grain_pass<F: FnMut(usize, &mut [[R; 4]; L])>(
                s: &mut Moving<'_, R>,
                m: &Mover<R>,
                mut before: F,
            ) -> Result<(R, u64), Error> {
                let zero = zero();
                let (dt, width) = (splat(m.step_dt), splat(m.width));
                let (g_x, g_y) = (splat(m.gravity[0]), splat(m.gravity[1]));
                let (y_min, y_max) = (splat(m.y_min), splat(m.y_max));
                let surface = splat(m.surface);
                let largest = splat(R::MAX);
                let abs = splat(ABS);
                let mut crossings = 0u64;
                let mut max_v2 = zero;
                // Every array as groups of L, zipped (no index to check).
                let (xs, ys) = (s.x.as_chunks_mut::<L>().0, s.y.as_chunks_mut::<L>().0);
                let (us, vs) = (s.u.as_chunks_mut::<L>().0, s.v.as_chunks_mut::<L>().0);
                let ws = s.w.as_chunks_mut::<L>().0;
                let inv_mass = s.inv_mass.as_chunks::<L>().0;
                let inv_inertia = s.inv_inertia.as_chunks::<L>().0;
                let mobiles = s.mobile.as_chunks::<L>().0;
                let all_sums = s.sums.as_chunks_mut::<L>().0;
                let mut failed = None;
                let state = xs
                    .iter_mut()
                    .zip(ys.iter_mut())
                    .zip(us.iter_mut())
                    .zip(vs.iter_mut());
                let state = state.zip(ws.iter_mut()).zip(inv_mass).zip(inv_inertia);
                let groups = state.zip(mobiles).zip(all_sums.iter_mut()).enumerate();
                // gx … gw: the group's x, y, u, v, ω; im, ii: its inverse
                // masses and inertias.
                for (grp, ((((((((gx, gy), gu), gv), gw), im), ii), mobile), sums)) in groups {
                    let g = s.first + grp * L;
                    let mobile = load(mobile);
                    if movemask(mobile) == 0 {
                        *sums = [[0.0; 4]; L];
                        continue;
                    }
                    before(grp, sums);
                    let [fx, fy, torque, _] = from_rows(sums.each_ref().map(|row| load_row(row)));
                    *sums = [[0.0; 4]; L];
                    // Mover::advance.
                    let im_v = load(im);
                    let (x0, y0, u0, v0, w0) = (load(gx), load(gy), load(gu), load(gv), load(gw));
                    let u = add(u0, mul(add(mul(fx, im_v), g_x), dt));
                    let v = add(v0, mul(add(mul(fy, im_v), g_y), dt));
                    let w = add(w0, mul(mul(torque, load(ii)), dt));
                    let x = add(x0, mul(u, dt));
                    let y = add(y0, mul(v, dt));
                    let inside = |x: V| and(ge(x, zero), lt(x, width));
                    let mut in_x = inside(x);
                    // The periodic wrap, where a grain left [0, L) (x is
                    // its own wrap inside).
                    let x = if movemask(in_x) == (1 << L) - 1 {
                        x
                    } else {
                        let over = ge(x, width);
                        let under = lt(x, zero);
                        let wrapped = add(x, width);
                        let wrapped = andnot(ge(wrapped, width), wrapped);
                        let x = select(select(x, wrapped, under), sub(x, width), over);
                        in_x = inside(x);
                        let crossed = movemask(and(xor(over, under), mobile)).count_ones();
                        crossings = crossings.wrapping_add(u64::from(crossed));
                        x
                    };
                    let ok = and(
                        and(le(and(w, abs), largest), in_x),
                        and(ge(y, y_min), le(y, y_max)),
                    );
                    // Out of the water, a grain moves by other accelerations.
                    let ok = and(ok, le(y0, surface));
                    if movemask(andnot(ok, mobile)) != 0 {
                        // A grain fails, or is out of the water: redo the
                        // group grain by grain, as the scalar step, up to
                        // the first failure.
                        let sums = [lanes(fx), lanes(fy), lanes(torque)];
                        let mobile = lanes(mobile);
                        for l in 0..L {
                            if mobile[l].to_bits() == 0 {
                                continue;
                            }
                            let moved = m.advance(
                                g + l,
                                [gx[l], gy[l], gu[l], gv[l], gw[l]],
                                [sums[0][l] * im[l], sums[1][l] * im[l], sums[2][l] * ii[l]],
                            );
                            let (moved, _) = match moved {
                                Ok(moved) => moved,
                                Err(e) => {
                                    failed = Some(e);
                                    break;
                                }
                            };
                            [gx[l], gy[l], gu[l], gv[l], gw[l]] = moved;
                            let v2 = moved[2] * moved[2] + moved[3] * moved[3];
                            max_v2 = max(splat(v2), max_v2);
                        }
                        if failed.is_some() {
                            break;
                        }
                        continue;
                    }
                    // Fixed grains keep their state (a whole group of mobile
                    // grains, the usual case, needs no blend).
                    let all_mobile = movemask(mobile) == (1 << L) - 1;
                    for (values, old, new) in [
                        (gx, x0, x),
                        (gy, y0, y),
                        (gu, u0, u),
                        (gv, v0, v),
                        (gw, w0, w),
                    ] {
                        put(
                            values,
                            if all_mobile {
                                new
                            } else {
                                select(old, new, mobile)
                            },
                        );
                    }
                    let v2 = and(add(mul(u, u), mul(v, v)), mobile);
                    max_v2 = max(v2, max_v2);
                }
                if let Some(e) = failed {
                    s.sums.fill([0.0; 4]);
                    return Err(e);
                }
                let max_v2 = lanes(max_v2).into_iter().fold(0.0, <R as Real>::max);
                Ok((max_v2, crossings))
            }
        }
    };
}
pub(super) use grains;
