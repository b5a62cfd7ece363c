//! The coupled flow's state inside a [`crate::Sim`] (docs/model.md §13): the
//! column, the slabs it is fed from, the per-cell sums of the exchange, and
//! the tables the grains read between two updates.

use super::column::Column;
use super::config::{DragLaw, Fluctuations, FluidConfig};
use super::slabs::Slabs;
use crate::real::Real;

/// The column of a coupled `Sim`, its scratch slabs, the drag sums and the
/// stabiliser's force of each cell, and per cell centre the tables of the
/// grains' drag. All-zero bits are the value [`Coupling::new`] (off), so
/// it can live in a zeroed `Sim`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Coupling<R: Real, const C: usize> {
    /// The coupled flow is on.
    pub(crate) on: bool,
    /// The fluid: u_f and φ of each cell (state).
    pub(crate) column: Column<R, C>,
    /// Scratch of an update: the grains' slab sums.
    pub(crate) slabs: Slabs<R, C>,
    /// What a grain reads at each cell centre j, a row [u_f, scale,
    /// hindrance, load]: u_f; u*_loc exp(−(y − y_bed)/h), the scale of the
    /// fluctuations (15) with the local shear velocity (C4); (1 − φ_j)^(−n),
    /// docs/model.md (C7), 1 without hindrance; the walls' load per r² of
    /// the overburden (C12), 0 without it. Derived ([`Coupling::refresh`]).
    pub(crate) centres: [[R; 4]; C],
    /// Each row of [`Coupling::centres`] less the one below: centre j + 1's
    /// values less centre j's (0 at the last centre), the slopes of the
    /// linear reads between them. Derived ([`Coupling::refresh`]).
    pub(crate) slopes: [[R; 4]; C],
    /// The stabiliser's force of each cell at the last update (N),
    /// returned to the fluid at the next (docs/model.md §13): state.
    pub(crate) carried: [R; C],
    /// The streamwise drag the grains received since the last update,
    /// summed per cell with the weights of the interpolation of u_f
    /// ([`Coupling::deposit`]), N: state.
    pub(crate) drag_sum: [R; C],
    /// Scratch of an update: the mobile grains' Σ w Ξ of each cell (kg/s).
    pub(crate) stabiliser: [R; C],
    /// Scratch of an update: u_f of each cell before it.
    pub(crate) previous: [R; C],
    /// The column's time step M step_dt (s).
    pub(crate) exchange_dt: R,
    /// 1/M, the average of the drag summed over M grain steps.
    pub(crate) inv_steps: R,
    /// The grains' drag law and fluctuations ([`Coupling::configure`]).
    pub(crate) closures: Closures<R>,
}

/// The slip speed (m/s) below which the grains' wall friction (C11) is
/// viscous, proportional to the speed: a grain at rest feels none.
pub(crate) const WALL_SLIP: f64 = 1e-3;

/// What the coupled flow's closures need in a step (docs/model.md (C8),
/// (C9)): the drag law's two terms, the fluctuations' model, the free
/// surface. Set from the configuration when the flow starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Closures<R: Real> {
    /// Dallavalle's drag (C8): Ξ = coef h (a |u_r| + b/r); else the
    /// paper's, coef h |u_r|.
    pub(crate) viscous: bool,
    /// a = 0.44/C_D.
    pub(crate) inertial: R,
    /// b = 24.4 ν/(2 C_D) (m²/s), over the radius r.
    pub(crate) viscous_term: R,
    /// HydroForceEngine's fluctuations (C9); else the paper's (15).
    pub(crate) hfe: bool,
    /// μ_w √(2/π) of the grains' friction on the side walls (C11); 0: none.
    pub(crate) grain_wall: R,
    /// 2 π K μ_w (ρ_p − ρ_f) g cos θ (N/m³) of (C12): the load per r² of
    /// the φ above; > 0: the walls also take it (the table's fourth
    /// column, times r²), 0 without it.
    pub(crate) load_weight: f64,
    /// The free surface: no drag on a grain whose centre is above it.
    pub(crate) surface: R,
}

impl<R: Real> Closures<R> {
    /// All zero: the paper's drag and fluctuations, a surface at 0.
    pub(crate) const ZERO: Self = Closures {
        viscous: false,
        inertial: R::ZERO,
        viscous_term: R::ZERO,
        hfe: false,
        grain_wall: R::ZERO,
        load_weight: 0.0,
        surface: R::ZERO,
    };

    /// The drag factor Ξ (kg/s) of a grain of radius `r` with
    /// `coef` = ½ρC_D A2 d², hindrance `hindrance` (C7), at relative speed
    /// `speed`: the paper's (5) coef h |u_r|, or Dallavalle's (C8)
    /// coef h (0.44 |u_r| + 24.4 ν/d)/C_D.
    #[inline]
    pub(crate) fn drag_factor(&self, coef: R, r: R, hindrance: R, speed: R) -> R {
        if self.viscous {
            coef * hindrance * (self.inertial * speed + self.viscous_term / r)
        } else {
            coef * hindrance * speed
        }
    }

    /// The grains' friction on the side walls (C11) of a grain of radius
    /// `r` moving at (`u`, `v`) with drag factor `xi` where the
    /// fluctuations' scale is `scale` and the overburden's load per r² is
    /// `load`: −μ_w N (u, v)/max(|v_p|, [`WALL_SLIP`]), N = Ξ √(2/π) scale
    /// the mean drag of the spanwise fluctuation that presses it on a wall,
    /// plus `load` r² with (C12); `None` without it.
    #[inline]
    pub(crate) fn wall_friction(
        &self,
        xi: R,
        scale: R,
        load: R,
        r: R,
        u: R,
        v: R,
    ) -> Option<(R, R)> {
        if self.grain_wall <= R::ZERO {
            return None;
        }
        let pressed = if self.load_weight > 0.0 {
            xi * self.grain_wall * scale + load * r * r
        } else {
            xi * self.grain_wall * scale
        };
        let speed = R::sqrt(u * u + v * v);
        let k = pressed / R::max(speed, R::from_f64(WALL_SLIP));
        Some((k * u, k * v))
    }

    /// The fluctuation (u', v') (m/s) of held standard-normal draws
    /// (z_u, z_v) where the fluctuations' scale is `scale` (docs/model.md
    /// §13): the paper's (15), (2.30 z_u, 1.27 z_v) scale, or
    /// HydroForceEngine's (C9), (z_u − z_v, z_v) scale.
    #[inline]
    pub(crate) fn fluctuation(&self, scale: R, z_u: R, z_v: R) -> (R, R) {
        if self.hfe {
            ((z_u - z_v) * scale, z_v * scale)
        } else {
            (
                z_u * (R::from_f64(2.30) * scale),
                z_v * (R::from_f64(1.27) * scale),
            )
        }
    }
}

/// Where a grain lies between the cell centres ([`Coupling::place`]):
/// between centres `cell` and `cell + 1` at `frac` of the way (`inside`),
/// or below the first or above the last centre, in `cell`'s tables with
/// `frac` = 0. Its drag goes to those centres by the same weights
/// ([`Coupling::deposit`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Place<R: Real> {
    /// The lower of the two centres, or the end cell.
    pub(crate) cell: usize,
    /// The weight of the upper centre, in [0, 1); 0 beyond the ends.
    pub(crate) frac: R,
    /// Between two centres.
    pub(crate) inside: bool,
}

/// What a grain at some height reads of the coupled flow: u_f, the scale of
/// its fluctuations and its hindrance, all linear between the two cell
/// centres around it ([`Coupling::at`]), and where its drag goes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Local<R: Real> {
    /// u_f (m/s).
    pub(crate) u: R,
    /// u*_loc exp(−(y − y_bed)/h) (m/s).
    pub(crate) scale: R,
    /// (1 − φ)^(−n).
    pub(crate) hindrance: R,
    /// The walls' load per r² of the overburden (C12), N/m².
    pub(crate) load: R,
    /// Where it was read.
    pub(crate) place: Place<R>,
}

/// The coupled flow's cells as a step reads and writes them, without the
/// capacity `C` (code over them is one copy for every `C`): the grid's
/// bottom and 1/Δy, the number of cells, the table of the cell centres
/// ([`Coupling::centres`], [`Coupling::slopes`]) and the drag sums. The
/// batched step reads the grid and the table; elsewhere only the sums are
/// used ([`Cells::deposit`]).
#[cfg_attr(
    not(all(target_arch = "x86_64", target_feature = "avx2")),
    allow(dead_code)
)]
pub(crate) struct Cells<'a, R: Real> {
    /// Height of face 0 (m).
    pub(crate) bottom: R,
    /// 1/Δy.
    pub(crate) inv_dy: R,
    /// The cells in use.
    pub(crate) count: usize,
    pub(crate) centres: &'a [[R; 4]],
    pub(crate) slopes: &'a [[R; 4]],
    /// The drag law, the fluctuations and the free surface.
    pub(crate) closures: Closures<R>,
    drag_sum: &'a mut [R],
}

impl<R: Real> Cells<'_, R> {
    /// Adds the streamwise drag `force` (N) a grain received at a place
    /// ([`Coupling::place`]: `cell`, `frac`) to the cells' sums with the
    /// weights of its interpolation: the two centres around it by their
    /// distances, all of it to one cell beyond the first or the last centre
    /// (the wall takes nothing), so the sums take the whole force, to
    /// round-off.
    #[inline]
    pub(crate) fn deposit(&mut self, cell: usize, frac: R, force: R) {
        let upper = force * frac;
        if let Some(sum) = self.drag_sum.get_mut(cell) {
            *sum += force - upper;
        }
        if let (true, Some(sum)) = (frac != R::ZERO, self.drag_sum.get_mut(cell + 1)) {
            *sum += upper;
        }
    }
}

impl<R: Real, const C: usize> Coupling<R, C> {
    /// Off, no cells.
    pub(crate) const fn new() -> Self {
        Coupling {
            on: false,
            column: Column::new(),
            slabs: Slabs::new(),
            centres: [[R::ZERO; 4]; C],
            slopes: [[R::ZERO; 4]; C],
            carried: [R::ZERO; C],
            drag_sum: [R::ZERO; C],
            stabiliser: [R::ZERO; C],
            previous: [R::ZERO; C],
            exchange_dt: R::ZERO,
            inv_steps: R::ZERO,
            closures: Closures::ZERO,
        }
    }

    /// Sets the closures of `config` (docs/model.md (C8)–(C12)) with the
    /// material's drag coefficient `c_d`, the grains' buoyant unit weight
    /// (ρ_p − ρ_f) g cos θ `unit_weight` (N/m³) and the free surface
    /// `surface`.
    pub(crate) fn configure(
        &mut self,
        config: &FluidConfig,
        c_d: f64,
        unit_weight: f64,
        surface: f64,
    ) {
        let viscous = config.spec.drag == DragLaw::Dallavalle;
        let walls = config.spec.channel_width > 0.0;
        let mu_w = config.spec.grain_wall_friction;
        self.closures = Closures {
            viscous,
            inertial: R::from_f64(if viscous { 0.44 / c_d } else { 0.0 }),
            viscous_term: R::from_f64(if viscous {
                24.4 * config.spec.viscosity / (2.0 * c_d)
            } else {
                0.0
            }),
            hfe: config.spec.fluctuations == Fluctuations::Hfe,
            grain_wall: R::from_f64(if walls {
                mu_w * core::f64::consts::FRAC_2_SQRT_PI * core::f64::consts::FRAC_1_SQRT_2
            } else {
                0.0
            }),
            load_weight: if walls {
                2.0 * core::f64::consts::PI * config.spec.lateral_ratio * mu_w * unit_weight
            } else {
                0.0
            },
            surface: R::from_f64(surface),
        };
    }

    /// The stabiliser's momentum in transit (N s): taken from the fluid at
    /// the last update, returned at the next.
    pub(crate) fn in_transit(&self) -> R {
        let mut sum = R::ZERO;
        for &f in &self.carried[..self.column.grid().cells().min(C)] {
            sum += f;
        }
        sum * self.exchange_dt
    }

    /// Height `y` in cells from the first centre: (y − bottom)/Δy − ½.
    #[inline]
    pub(crate) fn position(&self, y: R) -> R {
        let grid = self.column.grid();
        (y - grid.bottom) * grid.inv_dy - R::HALF
    }

    /// Where `position` ([`Coupling::position`]) lies between the cell
    /// centres: between two, or beyond the first or the last.
    #[inline]
    pub(crate) fn place(&self, position: R) -> Place<R> {
        let last = self.column.grid().cells().min(C).saturating_sub(1);
        let above = position > R::ZERO;
        // `as usize` saturates; position > 0 here.
        let i = if above { position.to_f64() as usize } else { 0 };
        if above && i < last {
            Place {
                cell: i,
                frac: position - R::from_f64(i as f64),
                inside: true,
            }
        } else {
            Place {
                cell: if above { last } else { 0 },
                frac: R::ZERO,
                inside: false,
            }
        }
    }

    /// The flow at height `y`, linear between the two cell centres around
    /// it (a value plus its slope times the fraction); below the first
    /// centre the bottom cell's values with u_f falling linearly to 0 at
    /// the no-slip bottom (as [`Column::velocity_at`]), above the last
    /// centre the top cell's.
    #[inline]
    pub(crate) fn at(&self, y: R) -> Local<R> {
        let s = self.position(y);
        let place = self.place(s);
        let zero = [R::ZERO; 4];
        let v = self.centres.get(place.cell).unwrap_or(&zero);
        if place.inside {
            let d = self.slopes.get(place.cell).unwrap_or(&zero);
            let lerp = |k: usize| v[k] + d[k] * place.frac;
            Local {
                u: lerp(0),
                scale: lerp(1),
                hindrance: lerp(2),
                load: lerp(3),
                place,
            }
        } else {
            // Below the first centre, falling to 0 at the wall (s = −½).
            let wall = R::min(R::max((s + R::HALF) * R::from_f64(2.0), R::ZERO), R::ONE);
            Local {
                u: if s > R::ZERO { v[0] } else { v[0] * wall },
                scale: v[1],
                hindrance: v[2],
                load: v[3],
                place,
            }
        }
    }

    /// The drag factor Ξ (kg/s) of a grain at height `y`, of radius `r`,
    /// ½ρC_D A2 d² `coef` and streamwise velocity `u`
    /// ([`Closures::drag_factor`] at |u_f − u|, without fluctuations): the
    /// stabiliser of a mobile grain, and at `u` = 0 the bed's resistance of
    /// a fixed grain or of a grain held at rest while a column starts; 0
    /// out of the water.
    #[inline]
    pub(crate) fn drag_factor_at(&self, coef: R, y: R, r: R, u: R) -> R {
        if y > self.closures.surface {
            return R::ZERO;
        }
        let at = self.at(y);
        self.closures
            .drag_factor(coef, r, at.hindrance, R::abs(at.u - u))
    }

    /// Adds the streamwise drag `force` (N) a grain received at a place
    /// ([`Coupling::place`]: `cell`, `frac`) to the cells' sums
    /// ([`Cells::deposit`]).
    #[inline]
    pub(crate) fn deposit(&mut self, cell: usize, frac: R, force: R) {
        self.cells().deposit(cell, frac, force);
    }

    /// The cells as a step reads and writes them ([`Cells`]).
    #[inline]
    pub(crate) fn cells(&mut self) -> Cells<'_, R> {
        let grid = self.column.grid();
        Cells {
            bottom: grid.bottom,
            inv_dy: grid.inv_dy,
            count: grid.cells().min(C),
            centres: &self.centres,
            slopes: &self.slopes,
            closures: self.closures,
            drag_sum: &mut self.drag_sum,
        }
    }

    /// Recomputes the table of each cell centre from the state
    /// ([`Coupling::centres`], [`Coupling::slopes`]): u_f, the scale of the
    /// fluctuations u*_loc exp(−(y − `bed_level`)/h) (`minus_inv_depth` =
    /// −1/h; HydroForceEngine's (C9): u*_loc at and above `bed_level`, 0
    /// below), the hindrance (1 − φ)^(−n) with exponent
    /// `config.spec.hindrance` (f64 `libm::pow`) and (C12)'s load, the
    /// weight of the φ above (in f64, summed from the top). After every
    /// update of the column or of the bed level, and after a restore.
    pub(crate) fn refresh(&mut self, config: &FluidConfig, minus_inv_depth: R, bed_level: R) {
        let n = config.spec.hindrance;
        let grid = self.column.grid();
        let velocities = self.column.velocities();
        let cells = self.column.solid_fractions().iter().zip(velocities);
        for (j, (&phi, &u)) in cells.enumerate().take(C) {
            let hindrance = if n == 0.0 {
                R::ONE
            } else {
                R::from_f64(libm::pow(1.0 - phi.to_f64(), -n))
            };
            let y = grid.centre(j);
            let scale = if !self.closures.hfe {
                let decay = R::exp((y - bed_level) * minus_inv_depth);
                self.column.shear_velocity_at(y) * decay
            } else if y >= bed_level {
                self.column.shear_velocity_at(y)
            } else {
                R::ZERO
            };
            self.centres[j] = [u, scale, hindrance, R::ZERO];
        }
        if self.closures.load_weight > 0.0 {
            // (C12): the weight of the φ above each centre, half its own
            // cell's, summed from the top.
            let (dy, w) = (grid.dy.to_f64(), self.closures.load_weight);
            let mut above = 0.0;
            let phis = self.column.solid_fractions();
            for j in (0..grid.cells().min(C)).rev() {
                let half = phis.get(j).map_or(0.0, |p| p.to_f64()) * dy * 0.5;
                if let Some(row) = self.centres.get_mut(j) {
                    row[3] = R::from_f64(w * (above + half));
                }
                above += 2.0 * half;
            }
        }
        let cells = grid.cells().min(C);
        for j in 0..cells {
            self.slopes[j] = match (self.centres.get(j), self.centres.get(j + 1)) {
                (Some(lo), Some(hi)) if j + 1 < cells => core::array::from_fn(|k| hi[k] - lo[k]),
                _ => [R::ZERO; 4],
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grain's drag reaction goes to the two cells around it by the
    /// interpolation's weights: 1 − frac to the lower cell, frac to the
    /// upper (nearer centre, larger share); all of it to the last cell at
    /// the top; nothing lost, nothing out of the sums.
    #[test]
    fn deposits_share_the_force_by_distance() {
        let mut sums = [0.0f64; 5];
        let mut cells = Cells {
            bottom: 0.0,
            inv_dy: 1.0,
            count: 5,
            centres: &[],
            slopes: &[],
            closures: Closures::ZERO,
            drag_sum: &mut sums,
        };
        cells.deposit(2, 0.25, 8.0);
        cells.deposit(4, 0.0, 1.0);
        cells.deposit(7, 0.5, 1.0);
        assert_eq!(sums, [0.0, 0.0, 6.0, 2.0, 1.0]);
    }
}
