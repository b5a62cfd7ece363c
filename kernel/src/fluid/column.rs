//! The fluid column (docs/model.md (C4)–(C6)): the velocity u_f of each cell,
//! advanced by implicit Euler steps of the volume-averaged momentum equation,
//! and the queries the grains will need (velocity, stress, shear velocity).

use super::config::FluidConfig;
use super::grid::Grid;
use super::mixing::mixing_lengths;
use super::slabs::Slabs;
use super::tridiagonal::Tridiagonal;
use crate::error::{check, positive, Error};
use crate::real::Real;

/// A 1-D vertical column of `C` cells at most (a compile-time capacity, as
/// the grains' `N`: storage is inline, the all-zero value is [`Column::new`],
/// an empty column, so it can live in a zeroed `Sim` later).
///
/// Its state is the velocity u_f and the solid fraction φ of each cell
/// ([`Column::velocities`], [`Column::solid_fractions`],
/// [`Column::set_state`]); everything else is derived from them or scratch.
///
/// ```
/// use mbs_kernel::fluid::{Column, FluidConfig, Slabs};
///
/// // Clear water 4 cm deep over a no-slip bottom, u* = 1 cm/s.
/// let mut config = FluidConfig::new(40, 0.0, 0.04, 1e-6);
/// let g_s = FluidConfig::driving_for(0.01, 0.04);
/// config.driving = g_s;
/// let mut column = Column::<f64, 64>::new();
/// column.reset(&config)?;
/// let mut slabs = Slabs::<f64, 64>::new();
/// slabs.clear(column.grid())?; // no grains
/// for _ in 0..10 {
///     column.advance(&slabs, 0.01)?;
/// }
/// // From rest, away from the bottom the water accelerates freely, g S t…
/// assert!((column.velocity_at(0.03) - g_s * 0.1).abs() < 1e-9 * g_s);
/// // …and a boundary layer grows at the no-slip bottom.
/// assert!(column.velocity_at(0.0005) < column.velocity_at(0.03));
/// assert_eq!(column.velocity_at(0.0), 0.0);
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Column<R: Real, const C: usize> {
    /// The cells.
    grid: Grid<R>,
    /// ρ (kg/m³).
    density: R,
    /// ν (m²/s).
    viscosity: R,
    /// κ.
    kappa: R,
    /// φ_max.
    phi_max: R,
    /// g S (m/s²).
    driving: R,
    /// The channel's width W (m), 0 without side walls (C10).
    channel_width: R,
    /// c_f 2/W (1/m), c_f the factor on f (`FluidSpec::wall_friction`);
    /// 0 without side walls.
    walls: R,
    /// The stress the side walls took in the last step, per unit area of
    /// the bed (Pa).
    side_stress: R,
    /// u_f at each cell's centre (m/s): state.
    u: [R; C],
    /// φ of each cell at the last step: state.
    phi: [R; C],
    /// The mixing length at each face j (the bottom of cell j), from `phi`.
    mixing: [R; C],
    /// Scratch of the implicit step.
    system: Tridiagonal<R, C>,
}

impl<R: Real, const C: usize> Default for Column<R, C> {
    fn default() -> Self {
        Self::new()
    }
}

impl<R: Real, const C: usize> Column<R, C> {
    /// An empty column (no cells); [`Column::reset`] configures it.
    pub const fn new() -> Self {
        Column {
            grid: Grid::EMPTY,
            density: R::ZERO,
            viscosity: R::ZERO,
            kappa: R::ZERO,
            phi_max: R::ZERO,
            driving: R::ZERO,
            channel_width: R::ZERO,
            walls: R::ZERO,
            side_stress: R::ZERO,
            u: [R::ZERO; C],
            phi: [R::ZERO; C],
            mixing: [R::ZERO; C],
            system: Tridiagonal::new(),
        }
    }

    /// Validates `config` and configures the column, fluid at rest and no
    /// grains; on an error the column is unchanged.
    pub fn reset(&mut self, config: &FluidConfig) -> Result<(), Error> {
        config.validate(C)?;
        self.u.fill(R::ZERO);
        self.phi.fill(R::ZERO);
        self.grid = config.grid();
        self.density = R::from_f64(config.density);
        self.viscosity = R::from_f64(config.spec.viscosity);
        self.kappa = R::from_f64(config.kappa);
        self.phi_max = R::from_f64(config.spec.phi_max);
        self.driving = R::from_f64(config.driving);
        let width = config.spec.channel_width;
        self.channel_width = R::from_f64(width);
        let walls = config.spec.wall_friction * 2.0 / width;
        self.walls = R::from_f64(if width > 0.0 { walls } else { 0.0 });
        self.side_stress = R::ZERO;
        self.refresh_mixing();
        Ok(())
    }

    /// The cells, for [`Slabs::clear`].
    pub fn grid(&self) -> Grid<R> {
        self.grid
    }

    /// One implicit Euler step of `dt` seconds of docs/model.md (C5) as (C6),
    /// with the grains of `slabs`: their solid fraction and drag at the end of
    /// the step, the eddy viscosity (C4) from the velocities at its start (lagged),
    /// the drag sink implicit in u_f, the side walls' friction (C10) half
    /// implicit, half explicit, its factor from the velocities at the
    /// start (as HydroForceEngine). On an error the velocities are
    /// unchanged (the solid fractions may be those of `slabs`).
    pub fn advance(&mut self, slabs: &Slabs<R, C>, dt: R) -> Result<(), Error> {
        positive("fluid.dt", dt.to_f64())?;
        let n = self.grid.cells;
        check(n >= 2, "fluid.cells", n as f64, ">= 2 (Column::reset)")?;
        self.check_grid(slabs)?;
        for j in 0..n {
            let phi = slabs.solid_fraction(j);
            check_fraction(phi)?;
            let (k, m) = slabs.drag_coefficients(j);
            check(
                R::is_finite(k) && R::is_finite(m),
                "fluid.drag",
                k.to_f64(),
                "finite",
            )?;
        }
        for j in 0..n {
            self.phi[j] = slabs.solid_fraction(j);
        }
        self.refresh_mixing();
        let inv_dt = R::ONE / dt;
        let inv_density = R::ONE / self.density;
        for j in 0..n {
            let (open, nu, _) = self.face(j);
            let spacing = if j == 0 {
                R::HALF * self.grid.dy
            } else {
                self.grid.dy
            };
            self.system.lower[j] = -(open * nu / (spacing * self.grid.dy));
        }
        for j in 0..n {
            let below = -self.system.lower[j];
            let above = if j + 1 < n {
                -self.system.lower[j + 1]
            } else {
                R::ZERO
            };
            let open = R::ONE - self.phi[j];
            let (k, m) = slabs.drag_coefficients(j);
            self.system.diag[j] = open * inv_dt + below + above + k * inv_density;
            self.system.upper[j] = -above;
            self.system.rhs[j] = open * inv_dt * self.u[j] + open * self.driving + m * inv_density;
            if self.walls > R::ZERO {
                let half = R::HALF * open * self.wall_rate(self.u[j]);
                self.system.diag[j] += half;
                self.system.rhs[j] -= half * self.u[j];
            }
        }
        let solution = self.system.solve(n)?;
        for &x in solution {
            check(R::is_finite(x), "fluid.velocity", x.to_f64(), "finite")?;
        }
        let mut side = R::ZERO;
        if self.walls > R::ZERO {
            let walls = (self.walls, self.channel_width, self.viscosity);
            for (j, &new) in solution.iter().enumerate() {
                let (old, open) = (self.u[j], R::ONE - self.phi[j]);
                side += open * wall_rate(walls, old) * R::HALF * (old + new);
            }
        }
        self.side_stress = self.density * self.grid.dy * side;
        self.u[..n].copy_from_slice(solution);
        Ok(())
    }

    /// The side walls' friction rate (2/W)(c_f f/8)|u| (1/s) at velocity
    /// `u` (docs/model.md (C10)), with Blasius's f = 0.3164 Re^(−1/4),
    /// Re = max(|u| W/ν, 1e-10), as HydroForceEngine's default
    /// (`wallFrictionModel = 0`), and its factor c_f
    /// (`FluidSpec::wall_friction`, its `fluidFrictionCoef`); 0 without
    /// walls.
    pub fn wall_rate(&self, u: R) -> R {
        wall_rate((self.walls, self.channel_width, self.viscosity), u)
    }

    /// The stress the side walls took in the last [`Column::advance`], per
    /// unit area of the bed (Pa): Σ_j ρ (1 − φ_j) Δy (2/W)(f/8)|u_j⁰| times
    /// the mean of u_j⁰ and u_j, the term of (C10) as the step applied it,
    /// so that the momentum of the step balances exactly; 0 without walls
    /// or before the first step.
    pub fn side_wall_stress(&self) -> R {
        self.side_stress
    }

    /// Starts the column from the solid fractions of `slabs` and the
    /// velocity `velocity(y)` at each cell's centre y (e.g. the log law
    /// (14)); on an error the column is unchanged.
    pub fn start(&mut self, slabs: &Slabs<R, C>, velocity: impl Fn(R) -> R) -> Result<(), Error> {
        let n = self.grid.cells;
        self.check_grid(slabs)?;
        for j in 0..n {
            let (u, phi) = (velocity(self.grid.centre(j)), slabs.solid_fraction(j));
            check(R::is_finite(u), "fluid.velocity", u.to_f64(), "finite")?;
            check_fraction(phi)?;
        }
        for j in 0..n {
            self.u[j] = velocity(self.grid.centre(j));
            self.phi[j] = slabs.solid_fraction(j);
        }
        self.refresh_mixing();
        Ok(())
    }

    /// Checks that `slabs` was filled for this column's grid.
    fn check_grid(&self, slabs: &Slabs<R, C>) -> Result<(), Error> {
        check(
            slabs.grid == self.grid,
            "fluid.slabs",
            slabs.grid.cells as f64,
            "filled for this column's grid (Slabs::clear)",
        )
    }

    /// The stress the no-slip bottom took in the last [`Column::advance`]
    /// (Pa): ρ (1 − φ_0)(ν + ν_t) 2u_0/Δy with the step's lagged ν_t, the
    /// bottom's term of docs/model.md (C6), so that the momentum of the
    /// step balances exactly; 0 before the first step.
    pub fn wall_stress(&self) -> R {
        if self.grid.cells == 0 {
            return R::ZERO;
        }
        -(self.density * self.grid.dy * self.system.lower[0] * self.u[0])
    }

    /// u_f at each cell's centre (m/s), bottom first: state.
    pub fn velocities(&self) -> &[R] {
        &self.u[..self.grid.cells]
    }

    /// φ of each cell at the last step, bottom first: state.
    pub fn solid_fractions(&self) -> &[R] {
        &self.phi[..self.grid.cells]
    }

    /// Restores the state (one value per cell each, as read from
    /// [`Column::velocities`] and [`Column::solid_fractions`]); on an error
    /// the column is unchanged.
    pub fn set_state(&mut self, velocities: &[R], solid_fractions: &[R]) -> Result<(), Error> {
        let n = self.grid.cells;
        check(
            velocities.len() == n && solid_fractions.len() == n,
            "fluid.state",
            velocities.len() as f64,
            "one value per cell",
        )?;
        for (&u, &phi) in velocities.iter().zip(solid_fractions) {
            check(R::is_finite(u), "fluid.velocity", u.to_f64(), "finite")?;
            check_fraction(phi)?;
        }
        self.u[..n].copy_from_slice(velocities);
        self.phi[..n].copy_from_slice(solid_fractions);
        self.refresh_mixing();
        Ok(())
    }

    /// u_f at height `y` (m/s): linear between cell centres, between 0 at
    /// the bottom (no slip) and the first centre, the top cell's value above
    /// its centre (zero gradient); 0 below the bottom or for a NaN.
    pub fn velocity_at(&self, y: R) -> R {
        let n = self.grid.cells;
        let s = (y - self.grid.bottom) * self.grid.inv_dy;
        let inside = s > R::ZERO && n > 0;
        if !inside {
            return R::ZERO;
        }
        let s = s - R::HALF;
        if s < R::ZERO {
            return self.u[0] * (s + R::HALF) * R::from_f64(2.0);
        }
        // `as usize` saturates; n ≥ 1 here.
        let i = s.to_f64() as usize;
        if i >= n - 1 {
            return self.u[n - 1];
        }
        let frac = s - R::from_f64(i as f64);
        self.u[i] + (self.u[i + 1] - self.u[i]) * frac
    }

    /// The fluid's shear stress at face `j` (Pa): ρ (1 − φ)(ν + ν_t) du/dy,
    /// docs/model.md (C4); face 0 is the bottom, face `cells` and above the
    /// free surface (0).
    pub fn shear_stress(&self, j: usize) -> R {
        if j < self.grid.cells {
            let (open, nu, grad) = self.face(j);
            self.density * open * nu * grad
        } else {
            R::ZERO
        }
    }

    /// The Reynolds stress at face `j` (Pa): ρ (1 − φ) ν_t du/dy, docs/model.md (C4).
    pub fn reynolds_stress(&self, j: usize) -> R {
        if j < self.grid.cells {
            let (open, nu, grad) = self.face(j);
            self.density * open * (nu - self.viscosity) * grad
        } else {
            R::ZERO
        }
    }

    /// The local shear velocity at height `y` (m/s), √(τ_t/ρ) of the
    /// Reynolds stress τ_t (docs/model.md (C4)), linear between faces; 0
    /// outside the column.
    pub fn shear_velocity_at(&self, y: R) -> R {
        let s = (y - self.grid.bottom) * self.grid.inv_dy;
        let inside = s > R::ZERO && s < R::from_f64(self.grid.cells as f64);
        if !inside {
            return R::ZERO;
        }
        let i = s.to_f64() as usize;
        let frac = s - R::from_f64(i as f64);
        let (lo, hi) = (self.reynolds_stress(i), self.reynolds_stress(i + 1));
        let stress = lo + (hi - lo) * frac;
        R::sqrt(R::max(stress, R::ZERO) / self.density)
    }

    /// The driving stress ρ g S Σ (1 − φ_j) Δy (Pa): at steady state the
    /// stress at the bottom plus the grains' drag per unit area
    /// (docs/model.md (C5)).
    pub fn driving_stress(&self) -> R {
        let mut open = R::ZERO;
        for &phi in self.solid_fractions() {
            open += R::ONE - phi;
        }
        self.density * self.driving * open * self.grid.dy
    }

    /// (1 − φ), ν + ν_t and du/dy at face `j` < cells, from the state
    /// (docs/model.md (C4)):
    /// φ the mean of the two cells (the bottom cell's at face 0), du/dy
    /// from the two centres (from the wall's u_f = 0 at face 0).
    fn face(&self, j: usize) -> (R, R, R) {
        let (phi, grad) = if j == 0 {
            (self.phi[0], self.u[0] * R::from_f64(2.0) * self.grid.inv_dy)
        } else {
            (
                R::HALF * (self.phi[j - 1] + self.phi[j]),
                (self.u[j] - self.u[j - 1]) * self.grid.inv_dy,
            )
        };
        let l = self.mixing[j];
        (R::ONE - phi, self.viscosity + l * l * R::abs(grad), grad)
    }

    /// The mixing lengths (docs/model.md (C3)) from the solid fractions.
    fn refresh_mixing(&mut self) {
        let n = self.grid.cells;
        mixing_lengths(
            &self.phi[..n],
            self.phi_max,
            self.kappa,
            self.grid.dy,
            &mut self.mixing[..n],
        );
    }
}

/// [`Column::wall_rate`] of `(2/W, W, ν)`.
fn wall_rate<R: Real>((walls, width, viscosity): (R, R, R), u: R) -> R {
    if walls <= R::ZERO {
        return R::ZERO;
    }
    let speed = R::abs(u);
    let re = R::max(speed * width / viscosity, R::from_f64(1e-10));
    let f = R::from_f64(0.3164) / R::sqrt(R::sqrt(re));
    walls * f * R::from_f64(0.125) * speed
}

/// Checks a cell's solid fraction: in [0, 1).
fn check_fraction<R: Real>(phi: R) -> Result<(), Error> {
    check(
        phi >= R::ZERO && phi < R::ONE,
        "fluid.solid_fraction",
        phi.to_f64(),
        "in [0, 1)",
    )
}
