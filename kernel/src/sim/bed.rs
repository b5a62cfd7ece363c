//! `impl Sim`: the initial bed (docs/model.md §7) of a [`BedSpec`],
//! settling it ([`Rest`], [`RestWatch`]), and the mean bed level
//! (docs/model.md §6).

use crate::bed::{fixed_height, BedInfo, BedSpec, Rest, Settled};
use crate::error::{check, Capacity, Error};
use crate::grains::GrainSpec;
use crate::random::{Stream, BED_STREAM};
use crate::real::Real;
use crate::sim::{Sim, SimConfig};

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
        let needed = spec.grains();
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
        let mut sites = spec.sites(config.seed);
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
                let Some(Some(class)) = sites.next() else {
                    continue;
                };
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
    /// definition applied in spans of the paper's width, so that the level
    /// does not depend on the width of the periodic bed.
    /// - The grains of the bed are those connected to a fixed grain through
    ///   contacts (saltating grains are not).
    /// - The width L is cut into `floor(L / (w d_max))` spans (at least
    ///   one, at most `N`), w = `bed_level_span` (default 5: the paper's
    ///   bed of nld = 5 columns is one span).
    /// - The surface grains of a span are its bed grains whose centre lies
    ///   within d_max below the span's highest bed-grain centre.
    /// - The level is the mean centre height of all surface grains.
    ///
    /// Over the whole width (docs/model.md §6 as written) the highest bed grain is an
    /// extreme value that rises with the number of columns and lifted the
    /// zero of the log law above the surface of wide beds: q* fell 1.7× per
    /// doubling of the width. Per span it converges (docs/findings/bed-width.md).
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
        let span = self.flow.spec.bed_level_span * d_max.to_f64();
        let spans = span_count(self.width.to_f64(), span, N);
        let per_metre = R::from_f64(spans as f64) / self.width;
        let span_of = |x: R| ((x * per_metre).to_f64() as usize).min(spans - 1);
        let Some(top) = g.span_top.get_mut(..spans) else {
            return;
        };
        top.fill(self.y_min - R::ONE);
        for i in 0..n {
            let k = span_of(g.x[i]);
            if g.in_bed[i] && g.y[i] > top[k] {
                top[k] = g.y[i];
            }
        }
        let (mut sum, mut count) = (R::ZERO, R::ZERO);
        for i in 0..n {
            if g.in_bed[i] && g.y[i] >= top[span_of(g.x[i])] - d_max {
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

/// Number of bed-level spans over a width `width`: as many as fit at
/// least `span` wide, at least one, at most `capacity` (a bed with fewer
/// grain slots than spans has no continuous surface; its spans are then
/// wider).
fn span_count(width: f64, span: f64, capacity: usize) -> usize {
    let fit = if span > 0.0 { width / span } else { 1.0 };
    (fit as usize).min(capacity).max(1)
}
