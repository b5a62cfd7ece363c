//! The simulation [`Sim`]: its state, its configuration ([`SimConfig`]),
//! adding grains, switching the flow, and reading the state back. The
//! other topics add their own `impl Sim` blocks, one file each:
//!
//! - `step`: [`Sim::step`], [`Sim::run`], the rebuild of the neighbour
//!   slots and the pair index, the flow's bookkeeping, and the dispatch to
//!   the two paths of [`crate::step`];
//! - `coupled`: the coupled flow's start and its update every M steps
//!   (docs/model.md §13);
//! - `bed`: the initial bed (§7), settling it ([`RestWatch`]), the mean
//!   bed level (§6);
//! - `observe`: the observables (§8);
//! - `checkpoint`: [`Sim::checkpoint`], [`Sim::restore`] (its format's
//!   version [`CHECKPOINT_VERSION`]);
//! - `digest`: [`Sim::digest`], [`Sim::group_digest`];
//! - `fields`: one grain's field by name, [`Sim::nudge`];
//! - `forces`: each contact's force, [`Sim::contact_forces`];
//! - `config`: [`SimConfig`], checked, and what it derives (the reduced
//!   and the whole gravity).
//!
//! What this folder holds is what needs a `Sim`. The types a topic reads
//! or returns that need none stay below it in their own modules, where
//! other layers and the host use them without one: `bed` ([`crate::BedSpec`],
//! [`crate::BedInfo`], [`crate::Rest`], [`crate::Settled`]), `observe`
//! ([`crate::Observation`], [`crate::q_star`]), `digest` ([`crate::Fnv1a`],
//! [`crate::FieldGroup`]) and `fields` ([`crate::GrainField`]). The
//! checkpoint's byte reader and writer serve only [`Sim::restore`] and
//! [`Sim::checkpoint`], and [`RestWatch`] reads a `Sim` at each check, so
//! they live here.

mod bed;
mod checkpoint;
mod config;
mod coupled;
mod digest;
mod fields;
mod forces;
mod observe;
mod phased;
mod step;

pub use bed::RestWatch;
pub use checkpoint::CHECKPOINT_VERSION;
pub(crate) use config::check_grain;
pub use config::SimConfig;
pub use forces::ContactForce;

use crate::constants::{ContactConstants, Material, A2};
use crate::contact::{ContactLaw, Spring, Tension};
use crate::error::{check, Capacity, Error};
use crate::events::Events;
use crate::flow::{FlowConfig, FlowModel, FlowSpec, LogLaw};
use crate::fluid::{Coupling, DragLaw, Fluctuations, FluidConfig, FluidSpec};
use crate::grains::{GrainSpec, Grains};
use crate::neighbours::Neighbours;
use crate::periodic::into_domain;
use crate::real::Real;
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
use crate::step::batch;
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
use crate::step::index::PairIndex;
use crate::step::mover::Mover;
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
use crate::step::no_lanes::PairIndex;
use crate::steps::IntegrationSteps;

/// A simulation of up to `N` grains with up to `K` neighbours (j > i) per grain,
/// in precision `R` (`f32` or `f64`), with a column of up to `C` fluid cells for
/// the coupled flow (docs/model.md §13).
///
/// `C` is a capacity as `N`: the column's arrays are inline, so the
/// coupled flow needs no allocator, and a `Sim` keeps the all-zero
/// property. It defaults to 0, no column: the clear-water simulations of
/// the host and the board keep their size and their code; a coupled flow
/// with more fluid cells than `C` is refused by [`Sim::set_flow`] with
/// [`Capacity::FluidCells`].
///
/// All storage is inline; nothing is allocated. [`Sim::new`] is a `const fn`
/// that yields all-zero bits, so a firmware can place a simulation in a
/// `static` (`.bss`) and a host can allocate it zeroed on the heap
/// (`Box::new_zeroed`) without building it on the stack: **every field of
/// `Sim` is a number, a `bool`, or a struct or array of those, so the all-zero
/// bit pattern is a valid value equal to `Sim::new()`.** Keep it that way.
///
/// ```
/// use mbs_kernel::{GrainSpec, Scenario, Sim};
///
/// // One grain in an empty box of the paper's constants: it falls.
/// let mut sim = Sim::<f64, 8, 4>::new();
/// sim.reset(&Scenario::paper().sim_config()?)?;
/// let grain = GrainSpec { x: 1e-3, y: 1e-3, diameter: 0.5e-3, ..GrainSpec::default() };
/// let i = sim.add_grain(&grain)?;
/// sim.run(100)?;
/// assert_eq!(sim.step_count(), 100);
/// assert!(sim.grain(i).is_some_and(|g| g.y < 1e-3 && g.v < 0.0));
/// # Ok::<(), mbs_kernel::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Sim<R: Real, const N: usize, const K: usize, const C: usize = 0> {
    pub(crate) grains: Grains<R, N>,
    pub(crate) nbrs: Neighbours<R, N, K>,
    /// The batched step's pair index (empty without vector lanes).
    pub(crate) index: PairIndex<R, N, K>,
    pub(crate) config: SimConfig,
    pub(crate) configured: bool,
    pub(crate) law: ContactLaw<R>,
    /// The integration step, [`SimConfig::step_dt`].
    pub(crate) step_dt: R,
    /// Reduced gravity g(s − 1)/(s + C_M): weight over inertia, docs/model.md (2).
    pub(crate) g_red: [R; 2],
    pub(crate) width: R,
    pub(crate) y_min: R,
    pub(crate) y_max: R,
    /// [`SimConfig::surface`].
    pub(crate) surface: R,
    /// [`SimConfig::air_gravity`].
    pub(crate) g_air: [R; 2],
    /// [`SimConfig::air_inertia_ratio`].
    pub(crate) air_ratio: R,
    pub(crate) flow: FlowConfig,
    pub(crate) flow_on: bool,
    pub(crate) log_law: LogLaw<R>,
    /// Step at which the flow was switched on: hold periods count from here.
    pub(crate) flow_epoch: u64,
    /// When HydroForceEngine's fluctuations are next redrawn
    /// ([`crate::Fluctuations::Hfe`]).
    pub(crate) redraw: Redraw,
    /// Mean bed level (docs/model.md §6), absolute height (m).
    pub(crate) bed_level: R,
    pub(crate) step: u64,
    /// Events of the successful steps (diagnostic, not in the digest nor
    /// in a checkpoint); the rebuilds are counted by the neighbour lists.
    pub(crate) events: Events,
    /// Whether the steps count contacts and seam crossings ([`Sim::count_events`]).
    pub(crate) count_events: bool,
    /// The coupled flow (docs/model.md §13), off with clear water.
    pub(crate) fluid: Coupling<R, C>,
}

/// The schedule of HydroForceEngine's fluctuations (docs/model.md (C9)):
/// the step of the next redraw and the period it draws (the key of its
/// draws). Set when a flow is switched on; state (in a checkpoint, and in
/// the digest with that model).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Redraw {
    /// The step at which every grain's fluctuation is redrawn next.
    pub(crate) next: u64,
    /// The period of that redraw, 0 for the first after the flow started.
    pub(crate) period: u64,
}

const ZERO_MATERIAL: Material = Material {
    rho: 0.0,
    s: 0.0,
    c_m: 0.0,
    c_d: 0.0,
    mu: 0.0,
    nu: 0.0,
};

/// All zero bits.
const ZERO_FLUID: FluidConfig = FluidConfig {
    spec: FluidSpec {
        viscosity: 0.0,
        phi_max: 0.0,
        update_steps: IntegrationSteps(0),
        hindrance: 0.0,
        channel_width: 0.0,
        wall_friction: 0.0,
        grain_wall_friction: 0.0,
        lateral_ratio: 0.0,
        drag: DragLaw::Paper,
        fluctuations: Fluctuations::Paper,
    },
    cells: 0,
    bottom: 0.0,
    surface: 0.0,
    cross_section: 0.0,
    density: 0.0,
    kappa: 0.0,
    driving: 0.0,
};

/// All zero bits.
const ZERO_FLOW: FlowConfig = FlowConfig {
    u_star: 0.0,
    spec: FlowSpec {
        kappa: 0.0,
        depth: 0.0,
        eps0: 0.0,
        roughness: 0.0,
        reference_diameter: 0.0,
        turbulence: false,
        hold_steps: IntegrationSteps(0),
        bed_level_interval: IntegrationSteps(0),
        bed_level_span: 0.0,
        model: FlowModel::ClearWater,
    },
    fluid: ZERO_FLUID,
};

impl<R: Real, const N: usize, const K: usize, const C: usize> Default for Sim<R, N, K, C> {
    fn default() -> Self {
        Self::new()
    }
}

impl<R: Real, const N: usize, const K: usize, const C: usize> Sim<R, N, K, C> {
    /// The integrator ([`Mover::advance`]) for this step.
    pub(super) fn mover(&self) -> Mover<R> {
        Mover {
            step_dt: self.step_dt,
            gravity: self.g_red,
            width: self.width,
            y_min: self.y_min,
            y_max: self.y_max,
            surface: self.surface,
            air_gravity: self.g_air,
            air_ratio: self.air_ratio,
            step: self.step,
        }
    }

    /// What the batched step and the phased step in lanes read besides
    /// the grains, the pair index and the coupled flow, with the integrator
    /// `mover`.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    pub(super) fn batch_params(&self, mover: Mover<R>) -> batch::Params<R> {
        let flow = match (self.flow_on, self.flow_on && self.fluid.on) {
            (false, _) => batch::Flow::Off,
            (true, false) => batch::Flow::Clear(self.log_law, self.bed_level),
            (true, true) => batch::Flow::Coupled {
                turbulence: self.log_law.turbulence,
            },
        };
        batch::Params {
            width: self.width,
            law: self.law,
            mover,
            flow,
            count_events: self.count_events,
        }
    }

    /// An empty, unconfigured simulation (all-zero bits). Call [`Sim::reset`].
    pub const fn new() -> Self {
        Sim {
            grains: Grains::new(),
            nbrs: Neighbours::new(),
            index: PairIndex::new(),
            config: SimConfig {
                step_dt: 0.0,
                material: ZERO_MATERIAL,
                contact: ContactConstants {
                    k_n: 0.0,
                    k_s: 0.0,
                    eta_n: 0.0,
                    eta_s: 0.0,
                },
                tension: Tension::Dashpot,
                gravity: [0.0; 2],
                width: 0.0,
                y_min: 0.0,
                y_max: 0.0,
                surface: 0.0,
                skin: 0.0,
                seed: 0,
                slope_angle: 0.0,
            },
            configured: false,
            law: ContactLaw::ZERO,
            step_dt: R::ZERO,
            g_red: [R::ZERO; 2],
            width: R::ZERO,
            y_min: R::ZERO,
            y_max: R::ZERO,
            surface: R::ZERO,
            g_air: [R::ZERO; 2],
            air_ratio: R::ZERO,
            flow: ZERO_FLOW,
            flow_on: false,
            log_law: LogLaw::ZERO,
            flow_epoch: 0,
            redraw: Redraw { next: 0, period: 0 },
            bed_level: R::ZERO,
            step: 0,
            events: Events::ZERO,
            count_events: false,
            fluid: Coupling::new(),
        }
    }

    /// Removes all grains, contacts and flow, and applies `config`.
    /// On error nothing changes.
    pub fn reset(&mut self, config: &SimConfig) -> Result<(), Error> {
        config.validate()?;
        let m = &config.material;
        self.grains.len = 0;
        self.nbrs.clear();
        self.index.clear();
        self.nbrs
            .set_skin(R::from_f64(config.skin), R::from_f64(config.step_dt));
        self.config = *config;
        self.configured = true;
        self.law = ContactLaw {
            k_n: R::from_f64(config.contact.k_n),
            k_s: R::from_f64(config.contact.k_s),
            eta_n: R::from_f64(config.contact.eta_n),
            eta_s: R::from_f64(config.contact.eta_s),
            mu: R::from_f64(m.mu),
            step_dt: R::from_f64(config.step_dt),
            tension: config.tension,
        };
        self.step_dt = R::from_f64(config.step_dt);
        self.g_red = config.reduced_gravity().map(R::from_f64);
        self.width = R::from_f64(config.width);
        self.y_min = R::from_f64(config.y_min);
        self.y_max = R::from_f64(config.y_max);
        self.surface = R::from_f64(config.surface);
        self.g_air = config.air_gravity().map(R::from_f64);
        self.air_ratio = R::from_f64(config.air_inertia_ratio());
        self.flow = ZERO_FLOW;
        self.flow_on = false;
        self.fluid.on = false;
        self.log_law = LogLaw::ZERO;
        self.flow_epoch = 0;
        self.redraw = Redraw::default();
        self.bed_level = R::ZERO;
        self.step = 0;
        self.events = Events::ZERO;
        Ok(())
    }

    /// Adds a grain and returns its index. Errors: capacity, or a field out of
    /// range (named). A mobile grain must satisfy the stability bound (11).
    pub fn add_grain(&mut self, spec: &GrainSpec) -> Result<usize, Error> {
        check(self.configured, "sim", 0.0, "configured by reset() first")?;
        check_grain(&self.config, spec)?;
        let c = &self.config;
        let mass = c.material.translational_mass(spec.diameter);
        let i = self.grains.len;
        if i >= N {
            return Err(Error::CapacityExceeded {
                what: Capacity::Grains,
                capacity: N,
            });
        }
        let g = &mut self.grains;
        let mobile = !spec.fixed;
        let d = spec.diameter;
        // x < width, but in a coarser precision it may round to the width:
        // then it is at the seam, x − width (exact: +0).
        g.x[i] = into_domain(R::from_f64(spec.x), self.width).0;
        g.y[i] = R::from_f64(spec.y);
        g.u[i] = if mobile { R::from_f64(spec.u) } else { R::ZERO };
        g.v[i] = if mobile { R::from_f64(spec.v) } else { R::ZERO };
        g.w[i] = if mobile {
            R::from_f64(spec.spin)
        } else {
            R::ZERO
        };
        g.r[i] = R::from_f64(0.5 * d);
        g.inv_mass[i] = if mobile {
            R::from_f64(1.0 / mass)
        } else {
            R::ZERO
        };
        g.inv_inertia[i] = if mobile {
            R::from_f64(1.0 / c.material.moment_of_inertia(d))
        } else {
            R::ZERO
        };
        g.drag_coef[i] = R::from_f64(0.5 * c.material.rho * c.material.c_d * A2 * d * d);
        g.z_u[i] = R::ZERO;
        g.z_v[i] = R::ZERO;
        (g.fx[i], g.fy[i], g.torque[i]) = (R::ZERO, R::ZERO, R::ZERO);
        g.fixed[i] = spec.fixed;
        g.class[i] = spec.class;
        g.len = i + 1;
        self.nbrs.count[i] = 0;
        self.nbrs.stale = true;
        Ok(i)
    }

    /// Switches the flow on (drag (4)–(5) with (14)–(16), or with the
    /// coupled flow of docs/model.md §13) or off (`None`: no drag).
    /// Hold periods of the fluctuations, bed-level updates and the coupled
    /// flow's updates count from now. A coupled flow starts from the log
    /// law (14) of `u_star` above the mean bed level of now, with the solid
    /// fractions of the grains of now; its fluid cells must fit the capacity `C`
    /// ([`Capacity::FluidCells`]). On an error nothing changes (the
    /// digest is the same), except when a coupled flow whose column refused
    /// the grains (a slab's solid fraction ≥ 1) replaces a coupled flow:
    /// the earlier column is overwritten, and the flow is left off.
    pub fn set_flow(&mut self, flow: Option<&FlowConfig>) -> Result<(), Error> {
        self.switch_flow(flow, true)
    }

    /// [`Sim::set_flow`]; a coupled column brought to its steady state only
    /// if `steady` (a restore replaces the column's state at once).
    pub(crate) fn switch_flow(
        &mut self,
        flow: Option<&FlowConfig>,
        steady: bool,
    ) -> Result<(), Error> {
        match flow {
            Some(f) => {
                f.validate()?;
                let coupled = f.spec.model == FlowModel::Coupled;
                if coupled {
                    f.fluid.validate(C)?;
                }
                let was_coupled = self.flow_on && self.fluid.on;
                let before = (
                    self.flow,
                    self.log_law,
                    self.flow_on,
                    (self.flow_epoch, self.redraw),
                    self.bed_level,
                );
                self.flow = *f;
                self.log_law = LogLaw::new(f);
                self.flow_on = true;
                self.flow_epoch = self.step;
                self.redraw = Redraw {
                    next: self.step,
                    period: 0,
                };
                self.fluid.on = false;
                if let Err(e) = if coupled {
                    self.start_coupling(steady)
                } else {
                    Ok(())
                } {
                    if was_coupled {
                        // The column the earlier flow ran on is overwritten.
                        self.switch_flow(None, steady)?;
                    } else {
                        (
                            self.flow,
                            self.log_law,
                            self.flow_on,
                            (self.flow_epoch, self.redraw),
                            self.bed_level,
                        ) = before;
                    }
                    return Err(e);
                }
            }
            None => {
                self.flow = ZERO_FLOW;
                self.log_law = LogLaw::ZERO;
                self.flow_on = false;
                self.fluid.on = false;
            }
        }
        Ok(())
    }

    /// The coupled flow's column (docs/model.md §13), if the coupled flow is on.
    pub fn fluid_column(&self) -> Option<&crate::fluid::Column<R, C>> {
        self.fluid.on.then_some(&self.fluid.column)
    }

    /// Number of grains.
    pub fn len(&self) -> usize {
        self.grains.len
    }

    /// No grains.
    pub fn is_empty(&self) -> bool {
        self.grains.len == 0
    }

    /// Steps taken since [`Sim::reset`].
    pub fn step_count(&self) -> u64 {
        self.step
    }

    /// Simulated time since [`Sim::reset`] (s).
    pub fn time(&self) -> f64 {
        self.step as f64 * self.config.step_dt
    }

    /// The configuration in force.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// The flow, if on.
    pub fn flow(&self) -> Option<&FlowConfig> {
        self.flow_on.then_some(&self.flow)
    }

    /// Grain `i`, if it exists.
    pub fn grain(&self, i: usize) -> Option<GrainSpec> {
        if i >= self.grains.len {
            return None;
        }
        let g = &self.grains;
        Some(GrainSpec {
            x: g.x[i].to_f64(),
            y: g.y[i].to_f64(),
            u: g.u[i].to_f64(),
            v: g.v[i].to_f64(),
            spin: g.w[i].to_f64(),
            diameter: 2.0 * g.r[i].to_f64(),
            fixed: g.fixed[i],
            class: g.class[i],
        })
    }

    /// Neighbour-list rebuilds since [`Sim::reset`] (a diagnostic of speed:
    /// results never depend on it).
    pub fn neighbour_rebuilds(&self) -> u64 {
        self.nbrs.rebuilds
    }

    /// Counts the contacts made, broken and sliding and the seam crossings
    /// from now on (`on`), or stops (the default). Counting costs the
    /// batched step ~7 % more instructions per grain-step; the other
    /// events are always counted. Results never depend on it.
    pub fn count_events(&mut self, on: bool) {
        self.count_events = on;
    }

    /// How often each event of the step happened since [`Sim::reset`] or
    /// [`Sim::restore`]: contacts made, broken and sliding and seam
    /// crossings (while [`Sim::count_events`] is on), neighbour-list
    /// rebuilds, turbulence redraws and bed-level updates. A diagnostic:
    /// not in the digest nor in a checkpoint; the batched and the scalar
    /// step count alike.
    ///
    /// ```
    /// use mbs_kernel::{Scenario, Sim};
    ///
    /// let mut sim = Sim::<f64, 64, 8>::new();
    /// Scenario::paper().build(&mut sim)?;
    /// sim.count_events(true);
    /// sim.run(3000)?;
    /// let events = sim.events();
    /// // The grains fell onto the bed and onto each other.
    /// assert!(events.contacts_made > 0);
    /// assert_eq!(events.neighbour_rebuilds, sim.neighbour_rebuilds());
    /// // No flow yet: no turbulence, no bed level.
    /// assert_eq!(events.turbulence_redraws, 0);
    /// # Ok::<(), mbs_kernel::Error>(())
    /// ```
    pub fn events(&self) -> Events {
        Events {
            neighbour_rebuilds: self.nbrs.rebuilds,
            ..self.events
        }
    }

    /// The pairs (i, j), i < j, in contact with their spring history, in
    /// (i, j) order.
    pub fn contacts(&self) -> impl Iterator<Item = (usize, usize, Spring<R>)> + '_ {
        let index = &self.index;
        self.nbrs
            .contacts(self.grains.len, move |i, k| index.spring_at(i, k))
    }

    /// The contact law (6)–(9) in force, in the working precision.
    pub fn contact_law(&self) -> ContactLaw<R> {
        self.law
    }

    /// Spring history (e_n, e_s) of the pair (i, j) if it is in contact.
    pub fn contact_history(&self, i: usize, j: usize) -> Option<(f64, f64)> {
        let h = self.nbrs.history(i, j, |i, k| self.index.spring_at(i, k))?;
        (h.e_n != R::ZERO || h.e_s != R::ZERO).then(|| (h.e_n.to_f64(), h.e_s.to_f64()))
    }

    /// The turbulent fluctuation (u, v) (m/s) grain `i` currently feels
    /// (docs/model.md (15)): its held draws times the rms at its height, zero where
    /// U = 0, for fixed grains, out of the water, or without flow or
    /// turbulence; with the coupled flow, the rms of the local shear
    /// velocity where u_f > 0, or HydroForceEngine's random walk (C9)
    /// (docs/model.md §13).
    pub fn fluctuation(&self, i: usize) -> Option<(f64, f64)> {
        if i >= self.grains.len {
            return None;
        }
        let g = &self.grains;
        if !self.flow_on || g.fixed[i] {
            return Some((0.0, 0.0));
        }
        if g.y[i] > self.surface {
            return Some((0.0, 0.0));
        }
        if self.fluid.on {
            // The coupled flow's (15) or (C9): u*_loc for u*, where u_f > 0.
            let at = self.fluid.at(g.y[i]);
            if !(self.log_law.turbulence && at.u > R::ZERO) {
                return Some((0.0, 0.0));
            }
            let (u, v) = self
                .fluid
                .closures
                .fluctuation(at.scale, g.z_u[i], g.z_v[i]);
            return Some((u.to_f64(), v.to_f64()));
        }
        let y = g.y[i] - self.bed_level;
        let p = &self.log_law;
        let (u, v) = p.fluctuation(p.mean_velocity(y), y, g.z_u[i], g.z_v[i]);
        Some((u.to_f64(), v.to_f64()))
    }

    /// Mean bed level y = 0 of the flow (docs/model.md §6), absolute (m): the mean
    /// centre height of the surface grains, found per span of
    /// `FlowSpec::bed_level_span` largest diameters so that it does not
    /// depend on the width of the periodic bed (docs/findings/bed-width.md).
    pub fn bed_level(&self) -> f64 {
        self.bed_level.to_f64()
    }
}
