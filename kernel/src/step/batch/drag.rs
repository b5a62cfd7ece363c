//! The drag in lanes, the batched step's first pass: L mobile grains at a
//! time, lane by lane the operations of the scalar step's drag.
//!
//! - Clear water (`drag_pass`): the drag (4)–(5) of the log law
//!   (14) with the held fluctuations (15) and the sheltering (16), as
//!   [`LogLaw::drag`](crate::flow::LogLaw::drag), its scalar `ln` and
//!   `exp` only in the lanes that need them.
//! - The coupled flow (`coupled_pass`, docs/model.md §13): each grain's
//!   place between the column's fluid cell centres, the column's u_f, scale of
//!   the fluctuations (15) and hindrance (C7) interpolated there, the drag
//!   (4)–(5) from them, as
//!   [`add_coupled_drag`](crate::step::scalar::add_coupled_drag); each
//!   grain's streamwise drag then goes to the fluid cells' sums in grain order.
//!
//! Each grain's drag is added to its sums (+0 for fixed grains). Written
//! once for both precisions: `drag!` writes the module `drag` into each
//! precision's module of the batched step (`lanes!` in [`super`]).

/// Writes the module `drag` (the passes `drag_pass` and `coupled_pass`)
/// in the lanes of `lanes::$lanes` ([`crate::lanes`]).
macro_rules! drag {
    ($lanes:ident) => {
        /// The drag passes in these lanes (`step/batch/drag.rs`).
        pub(super) mod drag {
            use crate::fluid::Cells;
            use crate::grains::Grains;
            use crate::lanes::$lanes::*;
            use crate::real::Real;
            use crate::step::batch::params::Moving;
            use crate::step::index::PairIndex;
            use crate::step::phased::ClearDrag;

            /// Groups of L grains whose fluid cells the coupled flow's drag finds
            /// ahead ([`coupled_pass`]).
            const BLOCK: usize = 64 / L;

            /// Adds the drag (4)–(5) to every mobile grain's force in the
            /// range `s` ([`drag_group`] on each group).
            #[target_feature(enable = "avx2")]
            pub(crate) fn drag_pass(s: &mut Moving<'_, R>, d: &ClearDrag<R>) {
                for grp in 0..s.len() / L {
                    drag_group(s, d, grp);
                }
            }

            /// Adds the drag (4)–(5) to the force of each mobile grain of
            /// group `grp` of the range `s`, lane by lane as
            /// [`LogLaw::drag`](crate::flow::LogLaw::drag) (its scalar `ln`
            /// and `exp` only in the lanes that need them).
            #[inline]
            #[target_feature(enable = "avx2")]
            pub(crate) fn drag_group(s: &mut Moving<'_, R>, d: &ClearDrag<R>, grp: usize) {
                let zero = zero();
                let p = &d.log_law;
                let one = splat(1.0);
                let (bed, shift, inv_ks) = (
                    splat(d.bed_level),
                    splat(p.zero_shift),
                    splat(p.inv_roughness),
                );
                let log_law = splat(<R as Real>::from_f64(30.1));
                let (eps0, open) = (splat(p.eps0), splat(1.0 - p.eps0));
                let turbulence = splat(if p.turbulence { TRUE } else { 0.0 });
                let surface = splat(d.surface);
                let at = |a: &[R]| load(group(a, grp));
                // Mobile grains in the water.
                let mobile = and(at(s.mobile), le(at(s.y), surface));
                if movemask(mobile) == 0 {
                    return;
                }
                let y = sub(at(s.y), bed);
                // (14) mean velocity.
                let above = add(y, shift);
                let arg = mul(mul(log_law, above), inv_ks);
                let flows = and(gt(arg, one), mobile);
                let mean = and(
                    mul(
                        splat(p.u_star_over_kappa),
                        map_where(arg, flows, <R as Real>::ln),
                    ),
                    flows,
                );
                // (15) fluctuations where U > 0.
                let fluctuates = and(gt(mean, zero), turbulence);
                let decay = map_where(
                    mul(y, splat(p.minus_inv_depth)),
                    fluctuates,
                    <R as Real>::exp,
                );
                let fluct_u = and(mul(at(s.z_u), mul(splat(p.rms_u0), decay)), fluctuates);
                let fluct_v = and(mul(at(s.z_v), mul(splat(p.rms_v0), decay)), fluctuates);
                let wx = sub(add(mean, fluct_u), at(s.u));
                let wy = sub(fluct_v, at(s.v));
                // (16) sheltering.
                let z = mul(above, inv_ks);
                let exposed = and(gt(z, zero), mobile);
                let hidden = map_where(xor(mul(z, z), splat(-0.0)), exposed, <R as Real>::exp);
                let eps = select(eps0, add(eps0, mul(open, sub(one, hidden))), exposed);
                // (4)–(5).
                let xi = mul(mul(at(s.coef), eps), sqrt(add(mul(wx, wx), mul(wy, wy))));
                // The sums (+0) add the drag (+0 for fixed grains).
                let [fx, fy] = [mul(xi, wx), mul(xi, wy)].map(|f| and(f, mobile));
                let rows = to_rows([fx, fy, zero, zero]);
                if let Some(sums) = s.sums.as_chunks_mut::<L>().0.get_mut(grp) {
                    for (sum, row) in sums.iter_mut().zip(rows) {
                        add_row(sum, row);
                    }
                }
            }

            /// Adds the coupled flow's drag to every mobile grain's force, L
            /// grains at a time, lane by lane as
            /// [`add_coupled_drag`](crate::step::scalar::add_coupled_drag):
            /// each grain's place between the fluid cells' centres
            /// ([`Coupling::place`](crate::fluid::Coupling::place)) in lanes,
            /// the two rows of its fluid cell
            /// ([`Coupling::centres`](crate::fluid::Coupling::centres),
            /// [`Coupling::slopes`](crate::fluid::Coupling::slopes)) loaded
            /// and transposed to lanes, the drag in lanes; then each grain's
            /// streamwise drag to the fluid cells' sums
            /// ([`Coupling::deposit`](crate::fluid::Coupling::deposit)) in
            /// grain order. The fluid cell indices are exact in f32: the caller
            /// takes fewer than 2^24 cells
            /// ([`batched_step`](crate::step::batch::batched_step)).
            #[target_feature(enable = "avx2")]
            pub(super) fn coupled_pass<const N: usize, const K: usize>(
                g: &Grains<R, N>,
                b: &mut PairIndex<R, N, K>,
                fluid: &mut Cells<'_, R>,
                turbulence: bool,
            ) {
                let zero = zero();
                let (bottom, inv_dy) = (splat(fluid.bottom), splat(fluid.inv_dy));
                let (half, one, two) = (splat(0.5), splat(1.0), splat(2.0));
                let last = fluid.count.saturating_sub(1);
                let last_cell = splat(last as R);
                let rms_u = splat(<R as Real>::from_f64(2.30));
                let rms_v = splat(<R as Real>::from_f64(1.27));
                let turbulence = splat(if turbulence { TRUE } else { 0.0 });
                let closures = fluid.closures;
                let surface = splat(closures.surface);
                let (inertial, viscous) = (splat(closures.inertial), splat(closures.viscous_term));
                let grain_wall = closures.grain_wall;
                let slip = splat(<R as Real>::from_f64(crate::fluid::WALL_SLIP));
                let no_row = [0.0; 4];
                // Coupling::position and Coupling::place of group `grp`: the
                // position, above the first centre, between two centres
                // (i = ⌊position⌋ and i + 1, 0 < position < last), the
                // fraction (0 beyond), the cell (i, else the end cell).
                let place = |grp: usize| {
                    let y = load(group(&g.y, grp));
                    let position = sub(mul(sub(y, bottom), inv_dy), half);
                    let above = gt(position, zero);
                    let inside = and(above, lt(position, last_cell));
                    let floor = trunc(position);
                    let frac = and(sub(position, floor), inside);
                    let cell = select(and(last_cell, above), floor, inside);
                    (position, above, inside, frac, cell)
                };
                let groups = g.len.min(N).div_ceil(L).min(N / L);
                // Blocks of groups: first every cell of the block, so that
                // the rows' loads do not wait on their addresses.
                for first in (0..groups).step_by(BLOCK) {
                    let block = first..(first + BLOCK).min(groups);
                    let mut cells = [[0; L]; BLOCK];
                    for (k, grp) in block.clone().enumerate() {
                        if let Some(c) = cells.get_mut(k) {
                            *c = to_index(place(grp).4);
                        }
                    }
                    for (grp, cells) in block.zip(cells) {
                        let at = |a: &[R; N]| load(group(a, grp));
                        // Mobile grains in the water.
                        let mobile = and(load(group(&b.mobile, grp)), le(at(&g.y), surface));
                        if movemask(mobile) == 0 {
                            continue;
                        }
                        let (position, above, inside, frac, _) = place(grp);
                        // Coupling::at: the value plus the slope times the
                        // fraction inside; beyond, the end cell's values, u_f
                        // falling to 0 at the wall below.
                        let row = |t: &[[R; 4]], l: usize| {
                            load_row(t.get(cells[l] as usize).unwrap_or(&no_row))
                        };
                        let [u, scale, hindrance, load] =
                            from_rows(core::array::from_fn(|l| row(fluid.centres, l)));
                        let [du, dscale, dhindrance, dload] =
                            from_rows(core::array::from_fn(|l| row(fluid.slopes, l)));
                        let lerp = |v: V, dv: V| select(v, add(v, mul(dv, frac)), inside);
                        let wall = min(one, max(zero, mul(add(position, half), two)));
                        let u_f = select(select(mul(u, wall), u, above), lerp(u, du), inside);
                        let (scale, hindrance) = (lerp(scale, dscale), lerp(hindrance, dhindrance));
                        // (15) or (C9) with u*_loc, where u_f > 0; (4)–(5) or
                        // (C8) with u_f and the hindrance (C7)
                        // (Closures::fluctuation, Closures::drag_factor).
                        let fluctuates = and(gt(u_f, zero), turbulence);
                        let (z_u, z_v) = (at(&g.z_u), at(&g.z_v));
                        let (fluct_u, fluct_v) = if closures.hfe {
                            (mul(sub(z_u, z_v), scale), mul(z_v, scale))
                        } else {
                            (mul(z_u, mul(rms_u, scale)), mul(z_v, mul(rms_v, scale)))
                        };
                        let (fluct_u, fluct_v) =
                            (and(fluct_u, fluctuates), and(fluct_v, fluctuates));
                        let wx = sub(add(u_f, fluct_u), at(&g.u));
                        let wy = sub(fluct_v, at(&g.v));
                        let speed = sqrt(add(mul(wx, wx), mul(wy, wy)));
                        let coef = mul(at(&g.drag_coef), hindrance);
                        let xi = if closures.viscous {
                            mul(coef, add(mul(inertial, speed), div(viscous, at(&g.r))))
                        } else {
                            mul(coef, speed)
                        };
                        // The sums (+0) add the drag (+0 for fixed grains),
                        // less the walls' friction (C11, Closures::wall_friction).
                        let [fx, fy] = [mul(xi, wx), mul(xi, wy)].map(|f| and(f, mobile));
                        let (sum_x, sum_y) = if grain_wall > 0.0 {
                            let (u, v) = (at(&g.u), at(&g.v));
                            let spanwise = mul(mul(xi, splat(grain_wall)), scale);
                            let pressed = if closures.load_weight > 0.0 {
                                let r = at(&g.r);
                                add(spanwise, mul(mul(lerp(load, dload), r), r))
                            } else {
                                spanwise
                            };
                            let speed = sqrt(add(mul(u, u), mul(v, v)));
                            let k = div(pressed, max(speed, slip));
                            let [wall_x, wall_y] = [mul(k, u), mul(k, v)].map(|f| and(f, mobile));
                            (sub(fx, wall_x), sub(fy, wall_y))
                        } else {
                            (fx, fy)
                        };
                        let rows = to_rows([sum_x, sum_y, zero, zero]);
                        if let Some(sums) = b.sums.as_chunks_mut::<L>().0.get_mut(grp) {
                            for (sum, row) in sums.iter_mut().zip(rows) {
                                add_row(sum, row);
                            }
                        }
                        let (forces, fracs, moves) = (lanes(fx), lanes(frac), lanes(mobile));
                        for l in 0..L {
                            if moves[l].to_bits() != 0 {
                                fluid.deposit(cells[l] as usize, fracs[l], forces[l]);
                            }
                        }
                    }
                }
            }
        }
    };
}
pub(super) use drag;
