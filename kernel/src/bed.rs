//! The initial bed (docs/model.md §7) and the mean bed level (docs/model.md §6).

use crate::error::{check, positive, Capacity, Error};
use crate::grains::{GrainSpec, MAX_CLASSES};
use crate::random::{Stream, BED_STREAM};
use crate::real::Real;
use crate::sim::{Sim, SimConfig};

/// One grain size of a (possibly mixed) bed.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SizeClass {
    /// Diameter d (m).
    pub diameter: f64,
    /// Fraction of the lattice sites that get this size (fractions sum to 1).
    pub fraction: f64,
}

/// How to build the initial bed (docs/model.md §7).
///
/// ```
/// use mbs_kernel::BedSpec;
///
/// let bed = BedSpec::uniform(0.5e-3, 40, 10);
/// bed.validate()?;
/// assert_eq!(bed.fixed_per_column(), 1);
/// assert!((bed.width() - 40.0 * 1.05 * 0.5e-3).abs() < 1e-15);
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct BedSpec {
    /// Lattice columns nld ≥ 3.
    pub columns: u32,
    /// Lattice rows nvd ≥ 1.
    pub rows: u32,
    /// Lattice spacing in units of the largest diameter (docs/model.md §7: 1.05–1.10).
    pub spacing: f64,
    /// Probability that a lattice site is left empty, in [0, 1).
    pub vacancy: f64,
    /// Standard deviation of the fixed grains' heights in units of the
    /// largest diameter (docs/model.md §7: 1/3).
    pub fixed_spread: f64,
    /// Size classes of the mobile grains (1 to [`MAX_CLASSES`]).
    pub classes: heapless::Vec<SizeClass, MAX_CLASSES>,
}

/// What [`Sim::build_bed`] made.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BedInfo {
    /// Fixed grains.
    pub fixed: usize,
    /// Mobile grains. Grains are stored column by column, each column's
    /// fixed grains first, then its lattice sites bottom-up.
    pub mobile: usize,
    /// Periodic width L (m).
    pub width: f64,
    /// Lowest allowed height y_min chosen for the domain (m).
    pub y_min: f64,
}

/// The outcome of [`Sim::settle`] and [`Sim::settle_to_rest`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Settled {
    /// Steps taken.
    pub steps: u64,
    /// Whether the criterion was met within the step budget.
    pub at_rest: bool,
    /// The largest mobile-grain speed at the last check (m/s).
    pub speed: f64,
    /// How far the mobile grains' centre of gravity moved over the last
    /// check's window (m; 0 for [`Sim::settle`], which does not watch it).
    pub drift: f64,
}

/// When a settling bed is at rest (docs/model.md §7 step 3): checked every
/// `window` integration steps, for `checks` checks in a row every mobile
/// grain slower than `speed` and the mobile grains' centre of gravity y_gc
/// moved by less than `drift` over the window.
///
/// ```
/// use mbs_kernel::{Rest, Scenario, G};
///
/// let sc = Scenario::paper();
/// let rest = Rest::for_bed(sc.bed.max_diameter(), sc.material.s, G, sc.step_dt());
/// // 1 % of √((s − 1) g d), d/1000 per 0.05 s.
/// assert!((rest.speed - 0.01 * (1.65f64 * 9.81 * 0.5e-3).sqrt()).abs() < 1e-15);
/// assert!((rest.drift - 0.5e-6).abs() < 1e-18);
/// assert_eq!((rest.window, rest.checks), (20_000, 4));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Rest {
    /// Every mobile grain slower than this (m/s).
    pub speed: f64,
    /// y_gc moved by less than this over a window (m).
    pub drift: f64,
    /// Integration steps between checks (> 0).
    pub window: u64,
    /// Checks in a row that must pass (≥ 1).
    pub checks: u32,
}

impl Rest {
    /// Speed of a check as a fraction of √((s − 1) g d_max).
    pub const SPEED: f64 = 0.01;
    /// Drift per window as a fraction of d_max.
    pub const DRIFT: f64 = 1e-3;
    /// The window's length (s).
    pub const WINDOW: f64 = 0.05;
    /// Checks in a row: the bed stays still for 0.2 s.
    pub const CHECKS: u32 = 4;

    /// The default criterion for a bed of largest diameter `d_max` (m) and
    /// specific gravity `s` under gravity `g` (m/s²), integrated with steps
    /// of `step_dt` (s): grains
    /// slower than 1 % of √((s − 1) g d_max), y_gc drifting less than d_max/1000
    /// per 0.05 s (0.02 d/s), four windows in a row (0.2 s): the creep of a
    /// bed still compacting at 0.05 d/s is not rest, nor a pause before a
    /// collapse.
    pub fn for_bed(d_max: f64, s: f64, g: f64, step_dt: f64) -> Rest {
        let window = libm::round(Self::WINDOW / step_dt);
        Rest {
            speed: Self::SPEED * libm::sqrt((s - 1.0) * g * d_max),
            drift: Self::DRIFT * d_max,
            window: if window >= 1.0 { window as u64 } else { 1 },
            checks: Self::CHECKS,
        }
    }
}

/// The state of the rest criterion between checks: what
/// [`Sim::settle_to_rest`] keeps from one window to the next, so that a
/// host can settle in chunks of its own, write it into a checkpoint and
/// resume the criterion exactly where it stopped.
///
/// ```
/// use mbs_kernel::{Rest, RestWatch, Scenario, Sim, G};
///
/// let sc = Scenario::paper();
/// let mut sim: Box<Sim<f64, 256, 8>> = Box::default();
/// sc.build(&mut *sim).unwrap();
/// let rest = Rest::for_bed(sc.bed.max_diameter(), sc.material.s, G, sc.step_dt());
/// let mut watch = RestWatch::start(&*sim);
/// sim.run(rest.window).unwrap();
/// let check = watch.check(&*sim, &rest);
/// // Just built: the grains are falling.
/// assert!(!check.at_rest && check.speed > rest.speed && watch.passed == 0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestWatch {
    /// The mobile grains' centre of gravity y_gc at the last check (m).
    pub y_gc: f64,
    /// Checks passed in a row.
    pub passed: u32,
}

impl RestWatch {
    /// The watch before the first check of `sim`'s bed.
    pub fn start<R: Real, const N: usize, const K: usize, const C: usize>(
        sim: &Sim<R, N, K, C>,
    ) -> RestWatch {
        RestWatch {
            y_gc: sim.observe().y_gc,
            passed: 0,
        }
    }

    /// One check of [`Rest`] after a window of steps: the largest mobile
    /// speed, the drift of y_gc since the last check, and whether `rest`
    /// has now held for `rest.checks` checks in a row (`steps` left 0 for
    /// the caller to fill).
    pub fn check<R: Real, const N: usize, const K: usize, const C: usize>(
        &mut self,
        sim: &Sim<R, N, K, C>,
        rest: &Rest,
    ) -> Settled {
        let now = sim.observe().y_gc;
        let speed = sim.max_speed();
        let drift = libm::fabs(now - self.y_gc);
        self.y_gc = now;
        self.passed = if speed < rest.speed && drift < rest.drift {
            self.passed.saturating_add(1)
        } else {
            0
        };
        Settled {
            steps: 0,
            at_rest: self.passed >= rest.checks.max(1),
            speed,
            drift,
        }
    }
}

impl BedSpec {
    /// A single-size bed of diameter `d` with the spacing 1.05 of docs/model.md §7, no
    /// vacancies and fixed-height spread d/3.
    pub fn uniform(d: f64, columns: u32, rows: u32) -> Self {
        let mut classes = heapless::Vec::<SizeClass, MAX_CLASSES>::new();
        // Capacity MAX_CLASSES ≥ 1, so one push always fits.
        let _ = classes.push(SizeClass {
            diameter: d,
            fraction: 1.0,
        });
        BedSpec {
            columns,
            rows,
            spacing: 1.05,
            vacancy: 0.0,
            fixed_spread: 1.0 / 3.0,
            classes,
        }
    }

    /// The largest diameter (m); 0 without classes.
    pub fn max_diameter(&self) -> f64 {
        self.classes
            .iter()
            .fold(0.0, |m, c| if c.diameter > m { c.diameter } else { m })
    }

    /// Lattice pitch (m).
    pub fn pitch(&self) -> f64 {
        self.spacing * self.max_diameter()
    }

    /// Fixed grains per lattice column: ⌈d_max/d_min⌉ **\[choice\]**, so that
    /// the fixed layer of a mixed bed is as tight for the finest grains as a
    /// single-size layer is for its grains (1 for a single size).
    pub fn fixed_per_column(&self) -> usize {
        let d_min = self
            .classes
            .iter()
            .fold(f64::INFINITY, |m, c| m.min(c.diameter));
        let ratio = self.max_diameter() / d_min;
        if ratio.is_finite() && ratio >= 1.0 {
            libm::ceil(ratio - 1e-9).min(16.0) as usize
        } else {
            1
        }
    }

    /// Periodic width L = columns × pitch (m).
    pub fn width(&self) -> f64 {
        self.columns as f64 * self.pitch()
    }

    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), Error> {
        check(
            self.columns >= 3,
            "bed.columns",
            self.columns as f64,
            ">= 3",
        )?;
        check(self.rows >= 1, "bed.rows", self.rows as f64, ">= 1")?;
        check(
            self.spacing.is_finite() && self.spacing > 1.0 && self.spacing <= 2.0,
            "bed.spacing",
            self.spacing,
            "in (1, 2] (docs/model.md §7: 1.05-1.10)",
        )?;
        check(
            self.vacancy.is_finite() && (0.0..1.0).contains(&self.vacancy),
            "bed.vacancy",
            self.vacancy,
            "in [0, 1)",
        )?;
        check(
            self.fixed_spread.is_finite() && (0.0..=1.0).contains(&self.fixed_spread),
            "bed.fixed_spread",
            self.fixed_spread,
            "in [0, 1]",
        )?;
        check(
            !self.classes.is_empty(),
            "grains.classes",
            0.0,
            "at least one class",
        )?;
        let mut total = 0.0;
        for c in &self.classes {
            positive("grains.diameter", c.diameter)?;
            positive("grains.fraction", c.fraction)?;
            total += c.fraction;
        }
        check(
            libm::fabs(total - 1.0) < 1e-9,
            "grains.fraction (sum)",
            total,
            "= 1",
        )
    }
}

/// A standard normal deviate truncated to ±2 by redrawing **\[choice\]**: an
/// untruncated tail opens gaps in the fixed layer wide enough for a grain to
/// fall through it in wide beds.
fn fixed_height(rng: &mut Stream) -> f64 {
    for _ in 0..64 {
        let z = rng.gaussian_pair().0;
        if libm::fabs(z) <= 2.0 {
            return z;
        }
    }
    0.0
}

impl<R: Real, const N: usize, const K: usize, const C: usize> Sim<R, N, K, C> {
    /// Resets the simulation with `config` and builds the initial bed of docs/model.md §7
    /// from `config.seed`:
    /// 1. fixed grains of the largest diameter evenly spaced across L,
    ///    [`BedSpec::fixed_per_column`] per column, heights Gaussian with mean 0
    ///    and standard deviation `fixed_spread`·d_max, truncated at ±2σ;
    /// 2. a `columns` × `rows` square lattice of mobile grains at
    ///    x = (c + ½)·pitch, starting one pitch above the highest fixed grain,
    ///    each site empty with probability `vacancy`, else of a size class
    ///    drawn by the fractions.
    ///
    /// `config.width` and `config.y_min` are replaced by the bed's: L =
    /// columns·pitch and y_min = lowest fixed grain − 2 d_max. Settle it
    /// afterwards with [`Sim::settle`] (step 3 of §7).
    pub fn build_bed(&mut self, config: &SimConfig, spec: &BedSpec) -> Result<BedInfo, Error> {
        spec.validate()?;
        let d_max = spec.max_diameter();
        let pitch = spec.pitch();
        let columns = spec.columns as usize;
        let needed = columns * (spec.fixed_per_column() + spec.rows as usize);
        if needed > N {
            return Err(Error::CapacityExceeded {
                what: Capacity::Grains,
                capacity: N,
            });
        }
        // Fixed heights are drawn twice from the same stream: once for the
        // domain extent, once to place them (no scratch array of size N).
        let spread = spec.fixed_spread * d_max;
        let fixed_count = columns * spec.fixed_per_column();
        let fixed_pitch = spec.width() / fixed_count as f64;
        let mut rng = Stream::new(config.seed, BED_STREAM, 0, 0);
        let (mut lowest, mut highest) = (f64::INFINITY, f64::NEG_INFINITY);
        for _ in 0..fixed_count {
            let y = fixed_height(&mut rng) * spread;
            lowest = lowest.min(y);
            highest = highest.max(y);
        }
        let top = highest + pitch * spec.rows as f64;
        let mut cfg = *config;
        cfg.width = spec.width();
        cfg.y_min = lowest - 2.0 * d_max;
        check(
            config.y_max > top + d_max,
            "y_max",
            config.y_max,
            "above the initial lattice (rows x pitch + 1 d)",
        )?;
        self.reset(&cfg)?;
        // Grains are added column by column (fixed grains, then the lattice
        // sites bottom-up), so neighbours are near each other in memory: the
        // step's cost per grain does not grow with the width of the bed.
        let mut heights = Stream::new(config.seed, BED_STREAM, 0, 0);
        let mut sites = Stream::new(config.seed, BED_STREAM, 1, 0);
        let per_column = spec.fixed_per_column();
        let mut mobile = 0;
        for col in 0..columns {
            for k in col * per_column..(col + 1) * per_column {
                self.add_grain(&GrainSpec {
                    x: k as f64 * fixed_pitch,
                    y: fixed_height(&mut heights) * spread,
                    diameter: d_max,
                    fixed: true,
                    ..GrainSpec::default()
                })?;
            }
            for row in 0..spec.rows as usize {
                let empty = sites.uniform() < spec.vacancy;
                let pick = sites.uniform();
                if empty {
                    continue;
                }
                let mut class = spec.classes.len() - 1;
                let mut cumulative = 0.0;
                for (c, sc) in spec.classes.iter().enumerate() {
                    cumulative += sc.fraction;
                    if pick < cumulative {
                        class = c;
                        break;
                    }
                }
                let diameter = spec.classes.get(class).map_or(d_max, |c| c.diameter);
                self.add_grain(&GrainSpec {
                    x: (col as f64 + 0.5) * pitch,
                    y: highest + pitch * (row + 1) as f64,
                    diameter,
                    class: class as u8,
                    ..GrainSpec::default()
                })?;
                mobile += 1;
            }
        }
        Ok(BedInfo {
            fixed: fixed_count,
            mobile,
            width: cfg.width,
            y_min: cfg.y_min,
        })
    }

    /// Steps until every mobile grain moves slower than `speed_tol` (m/s),
    /// checked every 100 steps, or until `max_steps` (docs/model.md §7 step
    /// 3): [`Sim::settle_to_rest`] without the centre-of-gravity condition.
    pub fn settle(&mut self, max_steps: u64, speed_tol: f64) -> Result<Settled, Error> {
        let rest = Rest {
            speed: speed_tol,
            drift: f64::INFINITY,
            window: 100,
            checks: 1,
        };
        self.settle_to_rest(max_steps, &rest)
    }

    /// Steps until the bed is at `rest` or `max_steps` have been taken
    /// (docs/model.md §7 step 3), checking every `rest.window` steps; the
    /// outcome says which, with the speed and drift of the last check.
    pub fn settle_to_rest(&mut self, max_steps: u64, rest: &Rest) -> Result<Settled, Error> {
        let start = self.step;
        let window = rest.window.max(1);
        let mut watch = RestWatch::start(self);
        let mut last = Settled {
            steps: 0,
            at_rest: false,
            speed: self.max_speed(),
            drift: 0.0,
        };
        while self.step - start < max_steps {
            let chunk = (max_steps - (self.step - start)).min(window);
            self.run(chunk)?;
            last = watch.check(self, rest);
            last.steps = self.step - start;
            if last.at_rest {
                return Ok(last);
            }
        }
        Ok(last)
    }

    /// Recomputes the mean bed level (docs/model.md §6, \[choice\]): the paper's
    /// definition applied in windows of the paper's width, so that the level
    /// does not depend on the width of the periodic bed.
    /// - The grains of the bed are those connected to a fixed grain through
    ///   contacts (saltating grains are not).
    /// - The width L is cut into `floor(L / (w d_max))` windows (at least
    ///   one, at most `N`), w = `bed_level_window` (default 5: the paper's
    ///   bed of nld = 5 columns is one window).
    /// - The surface grains of a window are its bed grains whose centre lies
    ///   within d_max below the window's highest bed-grain centre.
    /// - The level is the mean centre height of all surface grains.
    ///
    /// Over the whole width (docs/model.md §6 as written) the highest bed grain is an
    /// extreme value that rises with the number of columns and lifted the
    /// zero of the log law above the surface of wide beds: q* fell 1.7× per
    /// doubling of the width. Per window it converges (docs/findings/bed-width.md).
    /// Without fixed grains the level is y = 0.
    pub(crate) fn update_bed_level(&mut self) {
        if !self.label_bed_grains() {
            self.bed_level = R::ZERO;
            return;
        }
        let n = self.grains.len;
        let g = &mut self.grains;
        let mut d_max = R::ZERO;
        for i in 0..n {
            d_max = R::max(d_max, g.r[i] + g.r[i]);
        }
        let window = self.flow.bed_level_window * d_max.to_f64();
        let windows = window_count(self.width.to_f64(), window, N);
        let per_metre = R::from_f64(windows as f64) / self.width;
        let window_of = |x: R| ((x * per_metre).to_f64() as usize).min(windows - 1);
        let Some(top) = g.window_top.get_mut(..windows) else {
            return;
        };
        top.fill(self.y_min - R::ONE);
        for i in 0..n {
            let k = window_of(g.x[i]);
            if g.in_bed[i] && g.y[i] > top[k] {
                top[k] = g.y[i];
            }
        }
        let (mut sum, mut count) = (R::ZERO, R::ZERO);
        for i in 0..n {
            if g.in_bed[i] && g.y[i] >= top[window_of(g.x[i])] - d_max {
                sum += g.y[i];
                count += R::ONE;
            }
        }
        self.bed_level = sum / count;
    }

    /// Marks in `in_bed` the grains connected to a fixed grain through
    /// contacts with a compressed spring; false if there is no fixed grain.
    fn label_bed_grains(&mut self) -> bool {
        let n = self.grains.len;
        let (g, nbrs, index) = (&mut self.grains, &self.nbrs, &self.index);
        let mut any = false;
        for i in 0..n {
            g.in_bed[i] = g.fixed[i];
            any |= g.fixed[i];
        }
        // Label propagation along contacts in (i, j) order until nothing
        // changes: at most n sweeps, a few for a bed built bottom-up.
        for _ in 0..n {
            let mut changed = false;
            // The contacts of Sim::contacts (borrowed field by field).
            for (i, j, h) in nbrs.contacts(n, |i, k| index.spring_at(i, k)) {
                if h.e_n > R::ZERO && g.in_bed[i] != g.in_bed[j] {
                    g.in_bed[i] = true;
                    g.in_bed[j] = true;
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        any
    }
}

/// Number of bed-level windows over a width `width`: as many as fit at
/// least `window` wide, at least one, at most `capacity` (a bed with fewer
/// grain slots than windows has no continuous surface; its windows are then
/// wider).
fn window_count(width: f64, window: f64, capacity: usize) -> usize {
    let fit = if window > 0.0 { width / window } else { 1.0 };
    (fit as usize).min(capacity).max(1)
}
