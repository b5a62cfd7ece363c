//! The initial bed's description (docs/model.md §7): [`BedSpec`] (the
//! lattice, the size classes, the fixed layer), what building it made
//! ([`BedInfo`]), when a settling bed is at rest ([`Rest`]) and what
//! settling did ([`Settled`]), and the fixed grains' height draw. Building
//! the bed in a simulation, settling it and the mean bed level (§6) are an
//! `impl Sim` in `sim/bed.rs`; these types stay here, below the
//! simulation, because they need none: a [`crate::Scenario`] and the host
//! build and validate them without a `Sim`.

use crate::error::{check, positive, Error};
use crate::grains::MAX_CLASSES;
use crate::random::Stream;

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

/// What [`crate::Sim::build_bed`] made.
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

/// The outcome of [`crate::Sim::settle`] and [`crate::Sim::settle_to_rest`].
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
    /// check's window (m; 0 for [`crate::Sim::settle`], which does not watch it).
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

    /// Grains of the bed, fixed ones included: columns × (fixed per column +
    /// rows) (saturating: never a panic).
    pub fn grains(&self) -> usize {
        (self.columns as usize)
            .saturating_mul(self.fixed_per_column().saturating_add(self.rows as usize))
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

    /// The lattice sites of the bed built with `seed` (docs/model.md §7
    /// step 2), column by column and bottom up, as
    /// [`Sim::build_bed`](crate::Sim::build_bed) fills them: each site's
    /// size class, `None` if it is left empty (probability `vacancy`).
    ///
    /// ```
    /// use mbs_kernel::BedSpec;
    ///
    /// let bed = BedSpec::uniform(5e-4, 4, 3);
    /// assert_eq!(bed.sites(1).count(), 12);
    /// assert!(bed.sites(1).all(|class| class == Some(0)));
    /// ```
    pub fn sites(&self, seed: u64) -> impl Iterator<Item = Option<usize>> + '_ {
        let mut draws = Stream::new(seed, crate::random::BED_STREAM, 1, 0);
        let sites = (self.columns as usize).saturating_mul(self.rows as usize);
        (0..sites).map(move |_| {
            let empty = draws.uniform() < self.vacancy;
            let pick = draws.uniform();
            if empty {
                return None;
            }
            let mut cumulative = 0.0;
            for (c, sc) in self.classes.iter().enumerate() {
                cumulative += sc.fraction;
                if pick < cumulative {
                    return Some(c);
                }
            }
            Some(self.classes.len().saturating_sub(1))
        })
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
pub(crate) fn fixed_height(rng: &mut Stream) -> f64 {
    for _ in 0..64 {
        let z = rng.gaussian_pair().0;
        if libm::fabs(z) <= 2.0 {
            return z;
        }
    }
    0.0
}
