//! The batched step: the drag (docs/model.md (4)–(5), flow on; with the
//! coupled flow from its column, docs/model.md §13) on every grain, every
//! listed pair's contact force (docs/model.md §2 geometry, law (6)–(9)), then every
//! grain's force sum and motion (docs/model.md (1)–(3)), all in vector lanes, with
//! the bits of the scalar step ([`super::scalar`], which runs on every other
//! target).
//!
//! Pairs are independent until their forces are summed, and the sums fix
//! the bits. The pair pass finds a vector of pairs' forces, then adds each
//! pair's to its two grains' sums lane by lane, in pair order: one row
//! (f_x, f_y, torque) per grain, one vector add per side. Pairs are listed
//! by first grain, so grain i receives the pairs (m, i), m ascending, whose
//! second grain it is, then its own pairs (i, j) in slot order: exactly the
//! scalar step's order (the second grain's force negated: s + (−f) is s − f,
//! bit for bit; each torque adds its own −r f_s, the product the scalar
//! step forms). The grain pass then moves each grain. Every lane does the
//! operations of [`State::contact`](super::scalar),
//! [`crate::contact::ContactLaw::apply`] and the integrator in their
//! order; branches become selects. A pair that exerts no force adds +0 or
//! −0: neither changes a sum's bits (a sum starts at +0, or at a drag
//! force added to +0, so it is never −0, and s + 0 = s for every other s).
//!
//! The pairs come from the [pair index](super::index::PairIndex), which
//! lists them in this order and holds their history while it is ready.
//!
//! Lanes exist on x86-64 with AVX2 (`target-cpu=x86-64-v3` or newer, the
//! host default), for f64 (four per vector) and f32 (eight), with
//! capacities that are powers of two (every host capacity), so that masked
//! indices need no bounds checks. Elsewhere the scalar step runs. One macro
//! (`lanes!`) writes the step once for both precisions.

use super::index::{lanes, second_window, window_start, PairIndex, CHUNK, FAR, PAIRS};
use super::mover::Mover;
use crate::contact::ContactLaw;
use crate::error::Error;
use crate::events::Events;
use crate::flow::Profile;
use crate::fluid::{Cells, Coupling};
use crate::grains::Grains;
use crate::real::Real;
use core::any::Any;
use core::arch::x86_64::{
    __m128, __m256, __m256d, _mm256_castps256_ps128, _mm256_extractf128_ps, _mm256_permute2f128_pd,
    _mm256_set_m128, _mm256_shuffle_ps, _mm256_unpackhi_pd, _mm256_unpackhi_ps, _mm256_unpacklo_pd,
    _mm256_unpacklo_ps,
};

/// What the batched step reads besides the grains, the pair index and
/// the coupled flow: the periodic width, the contact law, the integrator,
/// and the flow.
#[derive(Clone, Copy)]
pub(crate) struct Params<R: Real> {
    pub(crate) width: R,
    pub(crate) law: ContactLaw<R>,
    pub(crate) mover: Mover<R>,
    pub(crate) flow: Flow<R>,
    /// Count the contacts made, broken and sliding ([`crate::Sim::count_events`]).
    pub(crate) count_events: bool,
}

/// The flow whose drag the batched step adds first.
#[derive(Clone, Copy)]
pub(crate) enum Flow<R: Real> {
    /// No flow: no drag.
    Off,
    /// The clear-water flow: its profile and the mean bed level.
    Clear(Profile<R>, R),
    /// The coupled flow, from its column (the `Coupling` passed along);
    /// the fluctuations (15) on or off (`Profile::turbulence`).
    Coupled { turbulence: bool },
}

/// Runs the batched step if the pair index is ready: the largest squared
/// speed, or the first grain's error in grain order (as the scalar step).
/// `None`: run the scalar step.
///
/// The vector code exists for `f64` and `f32`; [`Real`] knows nothing of
/// it. The precision is picked by downcasting the (`'static`) grains,
/// index and parameters to each precision's types ([`Any`]): a comparison
/// of two constant type ids, which each monomorphised copy folds away.
#[inline]
pub(crate) fn batched_step<R: Real, const N: usize, const K: usize, const C: usize>(
    grains: &mut Grains<R, N>,
    index: &mut PairIndex<R, N, K>,
    fluid: &mut Coupling<R, C>,
    params: &Params<R>,
    events: &mut Events,
) -> Option<Result<R, Error>> {
    // Cell indices of the coupled flow are exact in f32 lanes below 2^24.
    if !index.ready || C >= 1 << 24 {
        return None;
    }
    let (grains, index, fluid, params): (&mut dyn Any, &mut dyn Any, &mut dyn Any, &dyn Any) =
        (grains, index, fluid, params);
    if let (Some(g), Some(b), Some(f), Some(p)) = (
        grains.downcast_mut::<Grains<f64, N>>(),
        index.downcast_mut::<PairIndex<f64, N, K>>(),
        fluid.downcast_mut::<Coupling<f64, C>>(),
        params.downcast_ref::<Params<f64>>(),
    ) {
        if let Flow::Coupled { turbulence } = p.flow {
            f64x4::coupled_drag(g, b, f.cells(), turbulence);
        }
        let max_v2 = f64x4::batched_step(g, b, p, events);
        return Some(max_v2.map(R::from_f64));
    }
    if let (Some(g), Some(b), Some(f), Some(p)) = (
        grains.downcast_mut::<Grains<f32, N>>(),
        index.downcast_mut::<PairIndex<f32, N, K>>(),
        fluid.downcast_mut::<Coupling<f32, C>>(),
        params.downcast_ref::<Params<f32>>(),
    ) {
        if let Flow::Coupled { turbulence } = p.flow {
            f32x8::coupled_drag(g, b, f.cells(), turbulence);
        }
        let max_v2 = f32x8::batched_step(g, b, p, events);
        // Exact: every f32 is an f64.
        return Some(max_v2.map(|v| R::from_f64(f64::from(v))));
    }
    None
}

/// What the batched step of one precision reads and writes: the grains
/// (first `n`) and the pair index.
struct BatchStep<'a, R: Real, const N: usize, const K: usize> {
    n: usize,
    /// x, y, u, v, ω (moved; the radii are in the pair index).
    x: &'a mut [R; N],
    y: &'a mut [R; N],
    u: &'a mut [R; N],
    v: &'a mut [R; N],
    w: &'a mut [R; N],
    inv_mass: &'a [R; N],
    inv_inertia: &'a [R; N],
    width: R,
    law: ContactLaw<R>,
    mover: Mover<R>,
    batch: &'a mut PairIndex<R, N, K>,
    /// The clear-water flow's drag, added to the forces first, or None.
    drag: Option<Drag<'a, R, N>>,
    /// The contacts made, broken and sliding and the seam crossings.
    events: &'a mut Events,
}

impl<'a, R: Real, const N: usize, const K: usize> BatchStep<'a, R, N, K> {
    /// The grains `g`, the pair index `batch` and the parameters `p` of a step.
    /// The step's events are added to `events`.
    fn new(
        g: &'a mut Grains<R, N>,
        batch: &'a mut PairIndex<R, N, K>,
        p: &Params<R>,
        events: &'a mut Events,
    ) -> Self {
        BatchStep {
            n: g.len.min(N),
            x: &mut g.x,
            y: &mut g.y,
            u: &mut g.u,
            v: &mut g.v,
            w: &mut g.w,
            inv_mass: &g.inv_mass,
            inv_inertia: &g.inv_inertia,
            width: p.width,
            law: p.law,
            mover: p.mover,
            batch,
            drag: match p.flow {
                Flow::Clear(profile, bed_level) => Some(Drag {
                    profile,
                    bed_level,
                    coef: &g.drag_coef,
                    z_u: &g.z_u,
                    z_v: &g.z_v,
                }),
                _ => None,
            },
            events,
        }
    }
}

/// What the drag (4)–(5) of [`Profile::drag`] reads: the profile, the mean
/// bed level heights are measured from, and per grain ½ρC_D A2 d² and the
/// held fluctuation draws.
#[derive(Clone, Copy)]
struct Drag<'a, R: Real, const N: usize> {
    profile: Profile<R>,
    bed_level: R,
    coef: &'a [R; N],
    z_u: &'a [R; N],
    z_v: &'a [R; N],
}

/// The batched step in AVX2 lanes of one precision: module `$module`,
/// precision `$R` (raw bits `$bits`), vector `$V` of `$lanes` lanes, and
/// the precision's intrinsics; rows of a grain's four sums are `$Row`, and
/// `$to_rows` and `$from_rows` transpose four vectors to a row per lane and
/// back; `$to_mask` reads integer lanes as a lane mask; `$round` rounds
/// lanes (towards zero here) and `$to_index` truncates lanes to `i32`
/// indices. `unsafe` appears six times in the macro: the two calls of a
/// `#[target_feature]` function (the batched step's passes, the coupled
/// flow's drag),
/// sound because the build enables AVX2 (`cfg(target_feature = "avx2")`),
/// and the loads and stores of a vector from and to a `[$R; $lanes]` and
/// of a row from and to a `[$R; 4]`, sound because the array is exactly
/// the vector's or row's size and the unaligned loads and stores need no
/// alignment.
macro_rules! lanes {
    (
        $module:ident, $R:ty, $bits:ty, $V:ty, $lanes:literal,
        $loadu:ident, $storeu:ident, $setzero:ident, $set1:ident, $gather:expr, $permute:expr,
        $Row:ty, $row_loadu:ident, $row_storeu:ident, $row_add:ident, $second_row:expr,
        $to_rows:expr, $from_rows:expr, $to_mask:ident,
        $add:ident, $sub:ident, $mul:ident, $div:ident, $sqrt:ident,
        $and:ident, $andnot:ident, $xor:ident, $blendv:ident, $cmp:ident,
        $max:ident, $min:ident, $round:ident, $to_index:expr, $movemask:ident, $to_int:ident, $int_sub:ident
    ) => {
        #[allow(unsafe_code)]
        mod $module {
            use super::{BatchStep, Cells, Grains, PairIndex, Params, CHUNK, PAIRS};
            use crate::contact::Tension;
            use crate::error::Error;
            use crate::events::Events;
            use crate::real::Real;
            use core::arch::x86_64::*;

            /// Lanes per vector.
            const L: usize = $lanes;
            /// Groups of L grains whose cells the coupled flow's drag finds
            /// ahead ([`coupled_pass`]).
            const BLOCK: usize = 64 / L;
            /// Second grains from a window ([`super::second_window`]).
            const SECOND_WINDOW: bool = super::second_window(L) == 2 * L;
            const _: () = assert!(L == super::lanes::<$R>());

            /// The batched step ([`super::batched_step`]) of the grains `g`
            /// over the pair index `b`. Never inlined: its registers are
            /// allocated on their own, every array one offset from `g` or
            /// `b` (inlined into the step's dispatch, f64 spilled the
            /// grains' base: 7 % more instructions per grain-step).
            #[inline(never)]
            pub(super) fn batched_step<const N: usize, const K: usize>(
                g: &mut Grains<$R, N>,
                b: &mut PairIndex<$R, N, K>,
                p: &Params<$R>,
                events: &mut Events,
            ) -> Result<$R, Error> {
                let step = &mut BatchStep::new(g, b, p, events);
                // SAFETY: this module is compiled only with AVX2 enabled for the
                // whole build, so the CPU running it has AVX2.
                unsafe {
                    if let Some(drag) = step.drag {
                        drag_pass(step, &drag);
                    }
                    // One copy of the pair pass per (counting, tension
                    // rule): the paper's rule keeps its instructions.
                    let no_tension = p.law.tension == Tension::None;
                    match (p.count_events, no_tension) {
                        (true, false) => pair_pass::<N, K, true, false>(step),
                        (false, false) => pair_pass::<N, K, false, false>(step),
                        (true, true) => pair_pass::<N, K, true, true>(step),
                        (false, true) => pair_pass::<N, K, false, true>(step),
                    }
                    grain_pass(step)
                }
            }

            /// The coupled flow's drag on the grains `g` from its `cells`
            /// into the sums of the pair index `b`, before
            /// [`batched_step`] ([`coupled_pass`]; the fluctuations on if
            /// `turbulence`). Never inlined, and apart from the batched
            /// step: the clear-water step keeps its code.
            #[inline(never)]
            pub(super) fn coupled_drag<const N: usize, const K: usize>(
                g: &Grains<$R, N>,
                b: &mut PairIndex<$R, N, K>,
                mut cells: Cells<'_, $R>,
                turbulence: bool,
            ) {
                // SAFETY: this module is compiled only with AVX2 enabled for the
                // whole build, so the CPU running it has AVX2.
                unsafe { coupled_pass(g, b, &mut cells, turbulence) }
            }

            /// A vector from L values.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn load(values: &[$R; L]) -> $V {
                // SAFETY: `values` is L values (32 bytes); loadu needs no alignment.
                unsafe { $loadu(values.as_ptr()) }
            }

            /// Group `group` of L grains of an array (N is a whole number of groups).
            #[inline]
            fn group<const N: usize>(a: &[$R; N], group: usize) -> &[$R; L] {
                let (groups, _) = a.as_chunks::<L>();
                groups.get(group).unwrap_or(&[0.0; L])
            }

            /// Group `group` of L grains of an array, to write.
            #[inline]
            fn group_mut<const N: usize>(a: &mut [$R; N], group: usize) -> Option<&mut [$R; L]> {
                let (groups, _) = a.as_chunks_mut::<L>();
                groups.get_mut(group)
            }

            /// A vector from `a[at..at + L]`, zero if out of bounds.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn load_at(a: &[$R], at: usize) -> $V {
                match a.get(at..).and_then(|s| s.first_chunk::<L>()) {
                    Some(values) => load(values),
                    None => $setzero(),
                }
            }

            /// Stores a vector to `a[at..at + L]`, if in bounds.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn store(a: &mut [$R], at: usize, v: $V) {
                if let Some(values) = a.get_mut(at..).and_then(|s| s.first_chunk_mut::<L>()) {
                    put(values, v);
                }
            }

            /// Stores a vector to L values.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn put(values: &mut [$R; L], v: $V) {
                // SAFETY: `values` is L values (32 bytes); storeu needs no alignment.
                unsafe { $storeu(values.as_mut_ptr(), v) }
            }

            /// A grain's sums as a row.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn load_row(values: &[$R; 4]) -> $Row {
                // SAFETY: `values` is one row; loadu needs no alignment.
                unsafe { $row_loadu(values.as_ptr()) }
            }

            /// Adds a row to a grain's sums.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn add_row(values: &mut [$R; 4], row: $Row) {
                put_row(values, $row_add(load_row(values), row));
            }

            /// Stores a row.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn put_row(values: &mut [$R; 4], row: $Row) {
                // SAFETY: `values` is one row; storeu needs no alignment.
                unsafe { $row_storeu(values.as_mut_ptr(), row) }
            }

            /// The lanes of a vector.
            #[inline]
            #[target_feature(enable = "avx2")]
            fn lanes(v: $V) -> [$R; L] {
                let mut a = [0.0; L];
                put(&mut a, v);
                a
            }

            /// The values of `a` at indices `i` (in bounds: else zero).
            #[inline]
            #[target_feature(enable = "avx2")]
            fn gather(a: &[$R], i: &[usize; L]) -> $V {
                let v: [$R; L] = core::array::from_fn(|l| a.get(i[l]).copied().unwrap_or(0.0));
                $gather(v)
            }

            /// The values of `a` at grains `window + lane` (`lanes`: a permutation
            /// control of 32-bit lanes; zero if the window is out of bounds).
            #[inline]
            #[target_feature(enable = "avx2")]
            fn window(a: &[$R], window: usize, lanes: __m256i) -> $V {
                $permute(load_at(a, window), lanes)
            }

            /// `f` of the lanes of `v` selected by `mask`, zero elsewhere (one
            /// call per lane: the lanes hold the values the scalar step has).
            #[inline]
            #[target_feature(enable = "avx2")]
            fn map_where(v: $V, mask: $V, f: fn($R) -> $R) -> $V {
                if $movemask(mask) == 0 {
                    return $setzero();
                }
                let (values, selected) = (lanes(v), lanes(mask));
                // Built in registers: a vector load of scalar stores would stall.
                $gather(core::array::from_fn(|l| {
                    if selected[l].to_bits() != 0 {
                        f(values[l])
                    } else {
                        0.0
                    }
                }))
            }

            /// Adds the drag (4)–(5) to every mobile grain's force, L grains at a
            /// time, lane by lane as [`Profile::drag`](crate::flow::Profile::drag)
            /// (its scalar `ln` and `exp` only in the lanes that need them).
            #[target_feature(enable = "avx2")]
            fn drag_pass<const N: usize, const K: usize>(
                s: &mut BatchStep<'_, $R, N, K>,
                d: &super::Drag<'_, $R, N>,
            ) {
                let splat = $set1;
                let zero = $setzero();
                let (add, sub, mul) = ($add, $sub, $mul);
                let select = |no: $V, yes: $V, mask: $V| $blendv(no, yes, mask);
                let p = &d.profile;
                let one = splat(1.0);
                let (bed, shift, inv_ks) = (
                    splat(d.bed_level),
                    splat(p.zero_shift),
                    splat(p.inv_roughness),
                );
                let log_law = splat(<$R as Real>::from_f64(30.1));
                let (eps0, open) = (splat(p.eps0), splat(1.0 - p.eps0));
                let turbulence = splat(if p.turbulence {
                    <$R>::from_bits(<$bits>::MAX)
                } else {
                    0.0
                });
                let b = &mut *s.batch;
                let groups = s.n.min(N).div_ceil(L).min(N / L);
                for grp in 0..groups {
                    let mobile = load(group(&b.mobile, grp));
                    if $movemask(mobile) == 0 {
                        continue;
                    }
                    let at = |a: &[$R; N]| load(group(a, grp));
                    let y = sub(at(s.y), bed);
                    // (14) mean velocity.
                    let above = add(y, shift);
                    let arg = mul(mul(log_law, above), inv_ks);
                    let flows = $and($cmp(arg, one, _CMP_GT_OQ), mobile);
                    let mean = $and(
                        mul(
                            splat(p.u_star_over_kappa),
                            map_where(arg, flows, <$R as Real>::ln),
                        ),
                        flows,
                    );
                    // (15) fluctuations where U > 0.
                    let fluctuates = $and($cmp(mean, zero, _CMP_GT_OQ), turbulence);
                    let decay = map_where(
                        mul(y, splat(p.minus_inv_depth)),
                        fluctuates,
                        <$R as Real>::exp,
                    );
                    let fluct_u = $and(mul(at(d.z_u), mul(splat(p.rms_u0), decay)), fluctuates);
                    let fluct_v = $and(mul(at(d.z_v), mul(splat(p.rms_v0), decay)), fluctuates);
                    let wx = sub(add(mean, fluct_u), at(s.u));
                    let wy = sub(fluct_v, at(s.v));
                    // (16) sheltering.
                    let z = mul(above, inv_ks);
                    let exposed = $and($cmp(z, zero, _CMP_GT_OQ), mobile);
                    let hidden =
                        map_where($xor(mul(z, z), splat(-0.0)), exposed, <$R as Real>::exp);
                    let eps = select(eps0, add(eps0, mul(open, sub(one, hidden))), exposed);
                    // (4)–(5).
                    let xi = mul(mul(at(d.coef), eps), $sqrt(add(mul(wx, wx), mul(wy, wy))));
                    // The sums (+0) add the drag (+0 for fixed grains).
                    let [fx, fy] = [mul(xi, wx), mul(xi, wy)].map(|f| $and(f, mobile));
                    let rows = $to_rows([fx, fy, zero, zero]);
                    if let Some(sums) = b.sums.as_chunks_mut::<L>().0.get_mut(grp) {
                        for (sum, row) in sums.iter_mut().zip(rows) {
                            add_row(sum, row);
                        }
                    }
                }
            }

            /// Adds the coupled flow's drag to every mobile grain's force, L
            /// grains at a time, lane by lane as
            /// [`add_coupled_drag`](crate::step::scalar::add_coupled_drag):
            /// each grain's place between the cell centres
            /// ([`Coupling::place`]) in lanes, the two rows of its cell
            /// ([`Coupling::centres`], [`Coupling::slopes`]) loaded and
            /// transposed to lanes, the drag in lanes; then each grain's
            /// streamwise drag to the cells' sums ([`Coupling::deposit`]) in
            /// grain order. The cell indices are exact in f32: the caller
            /// takes fewer than 2^24 cells ([`super::batched_step`]).
            #[target_feature(enable = "avx2")]
            fn coupled_pass<const N: usize, const K: usize>(
                g: &Grains<$R, N>,
                b: &mut PairIndex<$R, N, K>,
                fluid: &mut Cells<'_, $R>,
                turbulence: bool,
            ) {
                let splat = $set1;
                let zero = $setzero();
                let (add, sub, mul) = ($add, $sub, $mul);
                let select = |no: $V, yes: $V, mask: $V| $blendv(no, yes, mask);
                let (bottom, inv_dy) = (splat(fluid.bottom), splat(fluid.inv_dy));
                let (half, one, two) = (splat(0.5), splat(1.0), splat(2.0));
                let last = fluid.count.saturating_sub(1);
                let last_cell = splat(last as $R);
                let rms_u = splat(<$R as Real>::from_f64(2.30));
                let rms_v = splat(<$R as Real>::from_f64(1.27));
                let turbulence = splat(if turbulence {
                    <$R>::from_bits(<$bits>::MAX)
                } else {
                    0.0
                });
                let no_row = [0.0; 4];
                // Coupling::position and Coupling::place of group `grp`: the
                // position, above the first centre, between two centres
                // (i = ⌊position⌋ and i + 1, 0 < position < last), the
                // fraction (0 beyond), the cell (i, else the end cell).
                let place = |grp: usize| {
                    let y = load(group(&g.y, grp));
                    let position = sub(mul(sub(y, bottom), inv_dy), half);
                    let above = $cmp(position, zero, _CMP_GT_OQ);
                    let inside = $and(above, $cmp(position, last_cell, _CMP_LT_OQ));
                    let floor = $round::<{ _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC }>(position);
                    let frac = $and(sub(position, floor), inside);
                    let cell = select($and(last_cell, above), floor, inside);
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
                            *c = $to_index(place(grp).4);
                        }
                    }
                    for (grp, cells) in block.zip(cells) {
                        let mobile = load(group(&b.mobile, grp));
                        if $movemask(mobile) == 0 {
                            continue;
                        }
                        let at = |a: &[$R; N]| load(group(a, grp));
                        let (position, above, inside, frac, _) = place(grp);
                        // Coupling::at: the value plus the slope times the
                        // fraction inside; beyond, the end cell's values, u_f
                        // falling to 0 at the wall below.
                        let row = |t: &[[$R; 4]], l: usize| {
                            load_row(t.get(cells[l] as usize).unwrap_or(&no_row))
                        };
                        let [u, scale, hindrance, _] =
                            $from_rows(core::array::from_fn(|l| row(fluid.centres, l)));
                        let [du, dscale, dhindrance, _] =
                            $from_rows(core::array::from_fn(|l| row(fluid.slopes, l)));
                        let lerp = |v: $V, dv: $V| select(v, add(v, mul(dv, frac)), inside);
                        let wall = $min(one, $max(zero, mul(add(position, half), two)));
                        let u_f = select(select(mul(u, wall), u, above), lerp(u, du), inside);
                        let (scale, hindrance) = (lerp(scale, dscale), lerp(hindrance, dhindrance));
                        // (15) with u*_loc, where u_f > 0; (4)–(5) with u_f and
                        // the hindrance (C7).
                        let fluctuates = $and($cmp(u_f, zero, _CMP_GT_OQ), turbulence);
                        let fluct_u = $and(mul(at(&g.z_u), mul(rms_u, scale)), fluctuates);
                        let fluct_v = $and(mul(at(&g.z_v), mul(rms_v, scale)), fluctuates);
                        let wx = sub(add(u_f, fluct_u), at(&g.u));
                        let wy = sub(fluct_v, at(&g.v));
                        let speed = $sqrt(add(mul(wx, wx), mul(wy, wy)));
                        let xi = mul(mul(at(&g.drag_coef), hindrance), speed);
                        // The sums (+0) add the drag (+0 for fixed grains).
                        let [fx, fy] = [mul(xi, wx), mul(xi, wy)].map(|f| $and(f, mobile));
                        let rows = $to_rows([fx, fy, zero, zero]);
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

            /// A batch's geometry and relative speeds: what its laws need of it
            /// (`State::contact`).
            #[derive(Clone, Copy)]
            struct Geometry {
                /// Unit normal, r_i + r_j − distance, radii.
                nx: $V,
                ny: $V,
                overlap: $V,
                ri: $V,
                rj: $V,
                /// Lane masks: in contact (not apart, not coincident); coincident
                /// (keeps its history).
                touching: $V,
                keeps: $V,
                /// Normal and tangential relative speeds.
                v_n: $V,
                v_s: $V,
            }

            /// Every listed pair's geometry and law, L pairs at a time, lane by
            /// lane as `State::contact` and `ContactLaw::apply`; each pair's force
            /// and torques added to its grains' sums in pair order. The
            /// events are counted if `COUNT`; `NO_TENSION`: the law (8')
            /// ([`Tension::None`]), else the paper's (8).
            #[target_feature(enable = "avx2")]
            fn pair_pass<
                const N: usize,
                const K: usize,
                const COUNT: bool,
                const NO_TENSION: bool,
            >(
                s: &mut BatchStep<'_, $R, N, K>,
            ) {
                let splat = $set1;
                let zero = $setzero();
                let sign = splat(-0.0);
                let all = splat(<$R>::from_bits(<$bits>::MAX));
                let neg = |a: $V| $xor(a, sign);
                let (add, sub, mul) = ($add, $sub, $mul);
                let select = |no: $V, yes: $V, mask: $V| $blendv(no, yes, mask);
                let (width, half_width) = (splat(s.width), splat(s.width * 0.5));
                let law = &s.law;
                let (dt, k_n, k_s) = (splat(law.step_dt), splat(law.k_n), splat(law.k_s));
                let (eta_n, eta_s, mu) = (splat(law.eta_n), splat(law.eta_s), splat(law.mu));
                let b = &mut *s.batch;
                let (x, y, u, v, w) = (&*s.x, &*s.y, &*s.u, &*s.v, &*s.w);
                let cap = N * PAIRS;
                // Pair q's grain in `a` (< N by construction; masked so that the
                // compiler sees it in bounds), and those of the batch from pair q.
                let index = |a: &[[u32; PAIRS]; N], q: usize| {
                    a.as_flattened()[q & (cap - 1)] as usize & (N - 1)
                };
                let at = |a: &[[u32; PAIRS]; N], q: usize| -> [usize; L] {
                    core::array::from_fn(|l| index(a, q + l))
                };
                let control =
                    |c: [u8; 8]| _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(i64::from_le_bytes(c)));
                // Batch t's first grains: its window and their lanes in it.
                let first_window = |t: usize| {
                    let lanes = control(b.window_lanes[t & (N - 1)]);
                    let first = b.pair_i.as_flattened()[(t * L) & (cap - 1)];
                    (super::window_start::<N>(first, L), lanes)
                };
                // Batch t's second grains' x, y, u, v, ω: from its second
                // window (from `start`), or gathered.
                let second_grains = |t: usize, start: usize| {
                    let grains = [x, y, u, v, w];
                    let c = b.second_lanes[t & (N - 1)];
                    if SECOND_WINDOW && c[0] != super::FAR {
                        let lanes = control(c);
                        let high = $to_mask(_mm256_slli_epi32::<28>(lanes));
                        grains.map(|a| {
                            let low = window(a, start, lanes);
                            select(low, window(a, start + L, lanes), high)
                        })
                    } else {
                        let j = at(&b.pair_j, t * L);
                        grains.map(|a| gather(a, &j))
                    }
                };

                // Chunks of batches: first their geometry (square root, division)
                // and relative speeds (the gathers), then their laws and sums, so
                // that the core overlaps many batches' square roots, divisions and
                // gathers instead of waiting for each.
                let batches = b.pairs.min(cap) / L;
                // The last first grain and its sums.
                let mut last = (usize::MAX, load_row(&[0.0; 4]));
                // One buffer for every chunk (zeroing it per chunk cost ~8
                // instructions per grain-step).
                // Per lane, the contacts made, broken and sliding if COUNT
                // (each mask lane, all ones, is −1 as an integer; counting
                // costs ~7 % more instructions per grain-step).
                let count = |n: __m256i, mask: $V| $int_sub(n, $to_int(mask));
                let (mut made_n, mut broken_n, mut sliding_n) = (
                    _mm256_setzero_si256(),
                    _mm256_setzero_si256(),
                    _mm256_setzero_si256(),
                );
                let mut geometry = [Geometry {
                    nx: zero,
                    ny: zero,
                    overlap: zero,
                    ri: zero,
                    rj: zero,
                    touching: zero,
                    keeps: zero,
                    v_n: zero,
                    v_s: zero,
                }; CHUNK];
                for chunk in (0..batches).step_by(CHUNK) {
                    let seam = b.seam[(chunk / CHUNK) & (N - 1)];
                    let chunk = chunk..batches.min(chunk + CHUNK);
                    // Geometry (State::contact).
                    for (t, g) in chunk.clone().zip(&mut geometry) {
                        let (start, lanes) = first_window(t);
                        let own = |a: &[$R; N]| window(a, start, lanes);
                        let [x_j, y_j, u_j, v_j, w_j] = second_grains(t, start);
                        // The periodic image: d itself (within half the width)
                        // away from the seam.
                        let d = sub(x_j, own(x));
                        let dx = if seam {
                            select(
                                select(d, add(d, width), $cmp(d, neg(half_width), _CMP_LT_OQ)),
                                sub(d, width),
                                $cmp(d, half_width, _CMP_GT_OQ),
                            )
                        } else {
                            d
                        };
                        let dy = sub(y_j, own(y));
                        let ri = load_at(b.r_i.as_flattened(), t * L);
                        let rj = load_at(b.r_j.as_flattened(), t * L);
                        let reach = add(ri, rj);
                        let dist2 = add(mul(dx, dx), mul(dy, dy));
                        let apart = $cmp(dist2, mul(reach, reach), _CMP_GE_OQ);
                        let dist = $sqrt(dist2);
                        let coincident = $cmp(dist, zero, _CMP_EQ_OQ);
                        let inv = $div(splat(1.0), dist);
                        let (nx, ny) = (mul(dx, inv), mul(dy, inv));
                        let (tx, ty) = (ny, neg(nx));
                        let du = sub(own(u), u_j);
                        let dv = sub(own(v), v_j);
                        let v_n = add(mul(du, nx), mul(dv, ny));
                        let spin = mul(ri, own(w));
                        let v_s = add(add(neg(add(mul(du, tx), mul(dv, ty))), spin), mul(rj, w_j));
                        *g = Geometry {
                            nx,
                            ny,
                            overlap: sub(reach, dist),
                            ri,
                            rj,
                            touching: $andnot(apart, $andnot(coincident, all)),
                            keeps: $andnot(apart, coincident),
                            v_n,
                            v_s,
                        };
                    }
                    for (t, g) in chunk.zip(&geometry) {
                        let q = t * L;
                        let Geometry {
                            nx,
                            ny,
                            overlap,
                            ri,
                            rj,
                            touching,
                            keeps,
                            v_n,
                            v_s,
                        } = *g;
                        let (tx, ty) = (ny, neg(nx));
                        let e_n0 = load_at(b.e_n.as_flattened(), q);
                        let e_s0 = load_at(b.e_s.as_flattened(), q);

                        // Law (ContactLaw::apply).
                        let first = $cmp(e_n0, zero, _CMP_EQ_OQ);
                        let e_n = add(e_n0, mul(k_n, select(mul(v_n, dt), overlap, first)));
                        let broken = $cmp(e_n, zero, _CMP_LT_OQ);
                        let f_n = add(e_n, mul(eta_n, v_n));
                        // (8'): f_n < 0 becomes +0 (−0 and NaN kept, as
                        // the scalar step), and the cap follows f_n.
                        let (f_n, normal) = if NO_TENSION {
                            let f_n = $andnot($cmp(f_n, zero, _CMP_LT_OQ), f_n);
                            (f_n, f_n)
                        } else {
                            (f_n, e_n)
                        };
                        let e_s = add(e_s0, mul(mul(k_s, v_s), dt));
                        let limit = mul(mu, normal);
                        let slides = $cmp($andnot(sign, e_s), limit, _CMP_GT_OQ);
                        let e_s_slid = select(neg(limit), limit, $cmp(e_s, zero, _CMP_GT_OQ));
                        let e_s_new = select(e_s, e_s_slid, slides);
                        let f_s = select(add(e_s, mul(eta_s, v_s)), e_s_new, slides);

                        // Outcomes: apart or broken drop the history; coincident keeps
                        // it; otherwise the new history and a force.
                        let acts = $andnot(broken, touching);
                        // Events: made (first and acts), broken (had history,
                        // neither acts nor keeps it), sliding (and acts).
                        if COUNT {
                            let held = $xor(acts, keeps);
                            made_n = count(made_n, $and(first, acts));
                            let dropped = $andnot(first, $andnot(held, all));
                            broken_n = count(broken_n, dropped);
                            sliding_n = count(sliding_n, $and(slides, acts));
                        }
                        // Padding pairs (w, w) are coincident: their history stays zero.
                        // The lanes that act and those that keep are disjoint, so
                        // one of each pair of terms is +0: a bitwise merge, which
                        // the optimiser does not turn into a masked store
                        // (`vmaskmovpd`, slow on AMD cores) as it did a select.
                        let e_n_out = $xor($and(e_n, acts), $and(e_n0, keeps));
                        let e_s_out = $xor($and(e_s_new, acts), $and(e_s0, keeps));
                        store(b.e_n.as_flattened_mut(), q, e_n_out);
                        store(b.e_s.as_flattened_mut(), q, e_s_out);
                        let fx = $and(add(mul(neg(f_n), nx), mul(f_s, tx)), acts);
                        let fy = $and(add(mul(neg(f_n), ny), mul(f_s, ty)), acts);
                        let f_s = $and(f_s, acts);
                        // Rows (f_x, f_y, −r_i f_s, −r_j f_s), added in pair order:
                        // the first three to the first grain, the force negated and
                        // the fourth to the second. A first grain's pairs are
                        // consecutive, and no other pair adds to its sums between
                        // them (its second-grain pairs all come earlier; a padding
                        // pair (w, w) adds zeros, to the stale copy in memory that
                        // the store overwrites), so its sums stay in a register
                        // from one to the next and are stored once, when the next
                        // first grain comes or the pass ends.
                        let rows = $to_rows([fx, fy, neg(mul(ri, f_s)), neg(mul(rj, f_s))]);
                        for (l, row) in rows.into_iter().enumerate() {
                            let (i, j) = (index(&b.pair_i, q + l), index(&b.pair_j, q + l));
                            let base = if i == last.0 {
                                last.1
                            } else {
                                if let Some(sums) = b.sums.get_mut(last.0) {
                                    put_row(sums, last.1);
                                }
                                load_row(&b.sums[i])
                            };
                            last = (i, $row_add(base, row));
                            add_row(&mut b.sums[j], $second_row(row));
                        }
                    }
                }
                if let Some(sums) = b.sums.get_mut(last.0) {
                    put_row(sums, last.1);
                }
                let total = |n: __m256i| {
                    lanes($to_mask(n))
                        .into_iter()
                        .map(|c| u64::from(c.to_bits()))
                        .sum::<u64>()
                };
                let e = &mut *s.events;
                e.contacts_made = e.contacts_made.wrapping_add(total(made_n));
                e.contacts_broken = e.contacts_broken.wrapping_add(total(broken_n));
                e.contacts_sliding = e.contacts_sliding.wrapping_add(total(sliding_n));
            }

            /// Every grain's motion (`Mover::advance`) from its sums, which it
            /// zeroes, L grains at a time: the largest squared speed, or the
            /// first failing grain's error (the sums then all zeroed).
            #[target_feature(enable = "avx2")]
            fn grain_pass<const N: usize, const K: usize>(
                s: &mut BatchStep<'_, $R, N, K>,
            ) -> Result<$R, Error> {
                let splat = $set1;
                let zero = $setzero();
                let (add, sub, mul) = ($add, $sub, $mul);
                let select = |no: $V, yes: $V, mask: $V| $blendv(no, yes, mask);
                let m = &s.mover;
                let (dt, width) = (splat(m.step_dt), splat(m.width));
                let (gx, gy) = (splat(m.gravity[0]), splat(m.gravity[1]));
                let (y_min, y_max) = (splat(m.y_min), splat(m.y_max));
                let largest = splat(<$R>::MAX);
                let abs = splat(<$R>::from_bits(<$bits>::MAX >> 1));
                let b = &mut *s.batch;
                let mut max_v2 = zero;
                let groups = s.n.min(N).div_ceil(L).min(N / L);
                for grp in 0..groups {
                    let g = grp * L;
                    let mobile = load(group(&b.mobile, grp));
                    let at = |a: &[$R; N]| load(group(a, grp));
                    let Some(sums) = b.sums.as_chunks_mut::<L>().0.get_mut(grp) else {
                        break;
                    };
                    let [fx, fy, torque, _] = $from_rows(sums.each_ref().map(|row| load_row(row)));
                    *sums = [[0.0; 4]; L];
                    if $movemask(mobile) == 0 {
                        continue;
                    }
                    // Mover::advance.
                    let im = at(s.inv_mass);
                    let (x0, y0, u0, v0, w0) = (at(s.x), at(s.y), at(s.u), at(s.v), at(s.w));
                    let u = add(u0, mul(add(mul(fx, im), gx), dt));
                    let v = add(v0, mul(add(mul(fy, im), gy), dt));
                    let w = add(w0, mul(mul(torque, at(s.inv_inertia)), dt));
                    let x = add(x0, mul(u, dt));
                    let y = add(y0, mul(v, dt));
                    let inside =
                        |x: $V| $and($cmp(x, zero, _CMP_GE_OQ), $cmp(x, width, _CMP_LT_OQ));
                    let mut in_x = inside(x);
                    // The periodic wrap, where a grain left [0, L) (x is
                    // its own wrap inside).
                    let x = if $movemask(in_x) == (1 << L) - 1 {
                        x
                    } else {
                        let over = $cmp(x, width, _CMP_GE_OQ);
                        let under = $cmp(x, zero, _CMP_LT_OQ);
                        let wrapped = add(x, width);
                        let wrapped = $andnot($cmp(wrapped, width, _CMP_GE_OQ), wrapped);
                        let x = select(select(x, wrapped, under), sub(x, width), over);
                        in_x = inside(x);
                        let crossed = $movemask($and($xor(over, under), mobile)).count_ones();
                        let e = &mut *s.events;
                        e.seam_crossings = e.seam_crossings.wrapping_add(u64::from(crossed));
                        x
                    };
                    let ok = $and(
                        $and($cmp($and(w, abs), largest, _CMP_LE_OQ), in_x),
                        $and($cmp(y, y_min, _CMP_GE_OQ), $cmp(y, y_max, _CMP_LE_OQ)),
                    );
                    if $movemask($andnot(ok, mobile)) != 0 {
                        // A grain fails: redo the group grain by grain, as the
                        // scalar step, up to the first failure.
                        let sums = [lanes(fx), lanes(fy), lanes(torque)];
                        let mobile = lanes(mobile);
                        for l in 0..L {
                            let i = (g + l) & (N - 1);
                            if mobile[l].to_bits() == 0 {
                                continue;
                            }
                            let moved = m.advance(
                                i,
                                [s.x[i], s.y[i], s.u[i], s.v[i], s.w[i]],
                                [
                                    sums[0][l] * s.inv_mass[i],
                                    sums[1][l] * s.inv_mass[i],
                                    sums[2][l] * s.inv_inertia[i],
                                ],
                            );
                            let (moved, _) = moved.inspect_err(|_| b.sums.fill([0.0; 4]))?;
                            [s.x[i], s.y[i], s.u[i], s.v[i], s.w[i]] = moved;
                            let v2 = moved[2] * moved[2] + moved[3] * moved[3];
                            max_v2 = $max(splat(v2), max_v2);
                        }
                        continue;
                    }
                    // Fixed grains keep their state (a whole group of mobile
                    // grains, the usual case, needs no blend).
                    let all_mobile = $movemask(mobile) == (1 << L) - 1;
                    for (a, old, new) in [
                        (&mut *s.x, x0, x),
                        (&mut *s.y, y0, y),
                        (&mut *s.u, u0, u),
                        (&mut *s.v, v0, v),
                        (&mut *s.w, w0, w),
                    ] {
                        if let Some(values) = group_mut(a, grp) {
                            put(
                                values,
                                if all_mobile {
                                    new
                                } else {
                                    select(old, new, mobile)
                                },
                            );
                        }
                    }
                    let v2 = $and(add(mul(u, u), mul(v, v)), mobile);
                    max_v2 = $max(v2, max_v2);
                }
                Ok(lanes(max_v2).into_iter().fold(0.0, <$R as Real>::max))
            }
        }
    };
}

lanes!(
    f64x4,
    f64,
    u64,
    __m256d,
    4,
    _mm256_loadu_pd,
    _mm256_storeu_pd,
    _mm256_setzero_pd,
    _mm256_set1_pd,
    |v: [f64; 4]| _mm256_setr_pd(v[0], v[1], v[2], v[3]),
    |v: __m256d, lanes: __m256i| _mm256_castps_pd(_mm256_permutevar8x32_ps(
        _mm256_castpd_ps(v),
        lanes
    )),
    __m256d,
    _mm256_loadu_pd,
    _mm256_storeu_pd,
    _mm256_add_pd,
    // (f_x, f_y, t_i, t_j) → (−f_x, −f_y, t_j, t_j)
    |row: __m256d| _mm256_xor_pd(
        _mm256_permute4x64_pd::<0b11_11_01_00>(row),
        _mm256_setr_pd(-0.0, -0.0, 0.0, 0.0)
    ),
    super::transpose_f64,
    super::transpose_f64,
    _mm256_castsi256_pd,
    _mm256_add_pd,
    _mm256_sub_pd,
    _mm256_mul_pd,
    _mm256_div_pd,
    _mm256_sqrt_pd,
    _mm256_and_pd,
    _mm256_andnot_pd,
    _mm256_xor_pd,
    _mm256_blendv_pd,
    _mm256_cmp_pd,
    _mm256_max_pd,
    _mm256_min_pd,
    _mm256_round_pd,
    |v: __m256d| {
        let i = _mm256_cvttpd_epi32(v);
        [
            _mm_extract_epi32::<0>(i),
            _mm_extract_epi32::<1>(i),
            _mm_extract_epi32::<2>(i),
            _mm_extract_epi32::<3>(i),
        ]
    },
    _mm256_movemask_pd,
    _mm256_castpd_si256,
    _mm256_sub_epi64
);

lanes!(
    f32x8,
    f32,
    u32,
    __m256,
    8,
    _mm256_loadu_ps,
    _mm256_storeu_ps,
    _mm256_setzero_ps,
    _mm256_set1_ps,
    |v: [f32; 8]| _mm256_setr_ps(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]),
    _mm256_permutevar8x32_ps,
    __m128,
    _mm_loadu_ps,
    _mm_storeu_ps,
    _mm_add_ps,
    // (f_x, f_y, t_i, t_j) → (−f_x, −f_y, t_j, t_j)
    |row: __m128| _mm_xor_ps(
        _mm_permute_ps::<0b11_11_01_00>(row),
        _mm_setr_ps(-0.0, -0.0, 0.0, 0.0)
    ),
    super::rows_f32,
    super::columns_f32,
    _mm256_castsi256_ps,
    _mm256_add_ps,
    _mm256_sub_ps,
    _mm256_mul_ps,
    _mm256_div_ps,
    _mm256_sqrt_ps,
    _mm256_and_ps,
    _mm256_andnot_ps,
    _mm256_xor_ps,
    _mm256_blendv_ps,
    _mm256_cmp_ps,
    _mm256_max_ps,
    _mm256_min_ps,
    _mm256_round_ps,
    |v: __m256| {
        let i = _mm256_cvttps_epi32(v);
        [
            _mm256_extract_epi32::<0>(i),
            _mm256_extract_epi32::<1>(i),
            _mm256_extract_epi32::<2>(i),
            _mm256_extract_epi32::<3>(i),
            _mm256_extract_epi32::<4>(i),
            _mm256_extract_epi32::<5>(i),
            _mm256_extract_epi32::<6>(i),
            _mm256_extract_epi32::<7>(i),
        ]
    },
    _mm256_movemask_ps,
    _mm256_castps_si256,
    _mm256_sub_epi32
);

/// Four vectors of four f64 lanes transposed: value l of vector c becomes
/// value c of vector l (per-lane values to rows, and back).
#[inline]
#[target_feature(enable = "avx2")]
fn transpose_f64([a, b, c, d]: [__m256d; 4]) -> [__m256d; 4] {
    let (ab_even, ab_odd) = (_mm256_unpacklo_pd(a, b), _mm256_unpackhi_pd(a, b));
    let (cd_even, cd_odd) = (_mm256_unpacklo_pd(c, d), _mm256_unpackhi_pd(c, d));
    [
        _mm256_permute2f128_pd::<0x20>(ab_even, cd_even),
        _mm256_permute2f128_pd::<0x20>(ab_odd, cd_odd),
        _mm256_permute2f128_pd::<0x31>(ab_even, cd_even),
        _mm256_permute2f128_pd::<0x31>(ab_odd, cd_odd),
    ]
}

/// Four vectors of eight f32 lanes transposed within each half: value l of
/// vector c becomes value c of vector l mod 4, half l / 4.
#[inline]
#[target_feature(enable = "avx2")]
fn transpose_halves_f32([a, b, c, d]: [__m256; 4]) -> [__m256; 4] {
    let (ab_low, ab_high) = (_mm256_unpacklo_ps(a, b), _mm256_unpackhi_ps(a, b));
    let (cd_low, cd_high) = (_mm256_unpacklo_ps(c, d), _mm256_unpackhi_ps(c, d));
    [
        _mm256_shuffle_ps::<0x44>(ab_low, cd_low),
        _mm256_shuffle_ps::<0xee>(ab_low, cd_low),
        _mm256_shuffle_ps::<0x44>(ab_high, cd_high),
        _mm256_shuffle_ps::<0xee>(ab_high, cd_high),
    ]
}

/// Four vectors of eight f32 lanes as eight rows of four: row l holds
/// value l of each vector.
#[inline]
#[target_feature(enable = "avx2")]
fn rows_f32(columns: [__m256; 4]) -> [__m128; 8] {
    let t = transpose_halves_f32(columns);
    let low = t.map(|v| _mm256_castps256_ps128(v));
    let high = t.map(|v| _mm256_extractf128_ps::<1>(v));
    [
        low[0], low[1], low[2], low[3], high[0], high[1], high[2], high[3],
    ]
}

/// Eight rows of four f32 as four vectors of eight lanes ([`rows_f32`]
/// undone).
#[inline]
#[target_feature(enable = "avx2")]
fn columns_f32(rows: [__m128; 8]) -> [__m256; 4] {
    let pairs: [__m256; 4] = core::array::from_fn(|l| _mm256_set_m128(rows[l + 4], rows[l]));
    transpose_halves_f32(pairs)
}
