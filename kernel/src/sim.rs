//! The simulation: configuration, grains, the step (SPEC §2 equations of
//! motion (1)–(3) with symplectic Euler), and its error checks.

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
use crate::batch::{batched_step, BatchStep, Drag};
use crate::constants::{ContactConstants, Material, A2};
use crate::contact::{ContactLaw, Spring};
use crate::error::{check, finite, positive, Capacity, Error, Quantity};
use crate::flow::{fluctuation_draw, FlowConfig, Profile};
use crate::grains::{GrainSpec, Grains, MAX_CLASSES};
use crate::neighbours::Neighbours;
use crate::pairs::{Forces, State, Sums, Touching};
use crate::real::Real;

/// Whether the step finds each grain's contact geometry while the previous
/// grain is finished: on out-of-order cores its square roots and divisions,
/// the step's longest latencies, then overlap that work (x86-64: ~15 % less
/// time per grain-step for ~15 % more instructions). Not on
/// microcontrollers: in-order cores gain nothing, and the buffers would take
/// stack the largest bed does not have.
const GEOMETRY_AHEAD: bool = !cfg!(target_os = "none");

/// Everything a simulation needs besides its grains and its flow (SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SimConfig {
    /// The integration step (s): Δt/substeps of the constants' time step.
    pub step_dt: f64,
    /// Fluid and grain material.
    pub material: Material,
    /// Contact springs and dashpots, e.g. from [`crate::contact_constants`].
    pub contact: ContactConstants,
    /// Gravity (g_x, g_y) (m/s²); (0, −9.81) by default. Tilt it to incline the bed.
    pub gravity: [f64; 2],
    /// Periodic width L (m); grains live in 0 ≤ x < L.
    pub width: f64,
    /// Lowest allowed grain height (m): below it a grain has left the domain.
    pub y_min: f64,
    /// Highest allowed grain height (m).
    pub y_max: f64,
    /// Largest neighbour-list skin (m); each rebuild sizes the skin from the
    /// fastest grain, down to 0.3 of it. Results do not depend on it; speed does.
    pub skin: f64,
    /// Seed of every random draw (SPEC §7: all randomness from one seed).
    pub seed: u64,
}

impl SimConfig {
    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), Error> {
        positive("step_dt", self.step_dt)?;
        self.material.validate()?;
        self.contact.validate()?;
        finite("gravity.x", self.gravity[0])?;
        finite("gravity.y", self.gravity[1])?;
        positive("width", self.width)?;
        finite("y_min", self.y_min)?;
        check(
            self.y_max.is_finite() && self.y_max > self.y_min,
            "y_max",
            self.y_max,
            "finite and > y_min",
        )?;
        crate::error::non_negative("skin", self.skin)
    }
}

/// The checks of [`Sim::add_grain`] against a configuration: diameter > 0,
/// position inside the domain, finite velocities, a known size class and,
/// for a mobile grain, the stability bound (11).
pub(crate) fn check_grain(c: &SimConfig, spec: &GrainSpec) -> Result<(), Error> {
    positive("grain.diameter", spec.diameter)?;
    check(
        spec.x.is_finite() && spec.x >= 0.0 && spec.x < c.width,
        "grain.x",
        spec.x,
        "in [0, width)",
    )?;
    check(
        spec.y.is_finite() && spec.y >= c.y_min && spec.y <= c.y_max,
        "grain.y",
        spec.y,
        "in [y_min, y_max]",
    )?;
    finite("grain.u", spec.u)?;
    finite("grain.v", spec.v)?;
    finite("grain.spin", spec.spin)?;
    if usize::from(spec.class) >= MAX_CLASSES {
        return Err(Error::CapacityExceeded {
            what: Capacity::SizeClasses,
            capacity: MAX_CLASSES,
        });
    }
    if !spec.fixed {
        let limit = c
            .contact
            .stable_dt_limit(c.material.translational_mass(spec.diameter));
        check(
            c.step_dt <= limit,
            "step_dt",
            c.step_dt,
            "<= 2 sqrt(m/k_n) of every grain (SPEC (11))",
        )?;
    }
    Ok(())
}

/// A simulation of up to `N` grains with up to `K` neighbours (j > i) per grain,
/// in precision `R` (`f32` or `f64`).
///
/// All storage is inline; nothing is allocated. [`Sim::new`] is a `const fn`
/// that yields all-zero bits, so a firmware can place a simulation in a
/// `static` (`.bss`) and a host can allocate it zeroed on the heap
/// (`Box::new_zeroed`) without building it on the stack: **every field of
/// `Sim` is a number, a `bool`, or a struct or array of those, so the all-zero
/// bit pattern is a valid value equal to `Sim::new()`.** Keep it that way.
#[derive(Debug, Clone)]
pub struct Sim<R: Real, const N: usize, const K: usize> {
    pub(crate) grains: Grains<R, N>,
    pub(crate) nbrs: Neighbours<R, N, K>,
    pub(crate) config: SimConfig,
    pub(crate) configured: bool,
    pub(crate) law: ContactLaw<R>,
    pub(crate) dt: R,
    /// Reduced gravity g(s − 1)/(s + C_M): weight over inertia, SPEC (2).
    pub(crate) g_red: [R; 2],
    pub(crate) width: R,
    pub(crate) y_min: R,
    pub(crate) y_max: R,
    pub(crate) flow: FlowConfig,
    pub(crate) flow_on: bool,
    pub(crate) profile: Profile<R>,
    /// Step at which the flow was switched on: hold periods count from here.
    pub(crate) flow_epoch: u64,
    /// Mean bed level (SPEC §6), absolute height (m).
    pub(crate) bed_level: R,
    pub(crate) step: u64,
}

const ZERO_MATERIAL: Material = Material {
    rho: 0.0,
    s: 0.0,
    c_m: 0.0,
    c_d: 0.0,
    mu: 0.0,
    nu: 0.0,
};

const ZERO_FLOW: FlowConfig = FlowConfig {
    u_star: 0.0,
    kappa: 0.0,
    depth: 0.0,
    eps0: 0.0,
    roughness: 0.0,
    reference_diameter: 0.0,
    turbulence: false,
    hold_steps: 0,
    bed_level_interval: 0,
    bed_level_window: 0.0,
};

impl<R: Real, const N: usize, const K: usize> Default for Sim<R, N, K> {
    fn default() -> Self {
        Self::new()
    }
}

impl<R: Real, const N: usize, const K: usize> Sim<R, N, K> {
    /// An empty, unconfigured simulation (all-zero bits). Call [`Sim::reset`].
    pub const fn new() -> Self {
        Sim {
            grains: Grains::new(),
            nbrs: Neighbours::new(),
            config: SimConfig {
                step_dt: 0.0,
                material: ZERO_MATERIAL,
                contact: ContactConstants {
                    k_n: 0.0,
                    k_s: 0.0,
                    eta_n: 0.0,
                    eta_s: 0.0,
                },
                gravity: [0.0; 2],
                width: 0.0,
                y_min: 0.0,
                y_max: 0.0,
                skin: 0.0,
                seed: 0,
            },
            configured: false,
            law: ContactLaw::ZERO,
            dt: R::ZERO,
            g_red: [R::ZERO; 2],
            width: R::ZERO,
            y_min: R::ZERO,
            y_max: R::ZERO,
            flow: ZERO_FLOW,
            flow_on: false,
            profile: Profile::ZERO,
            flow_epoch: 0,
            bed_level: R::ZERO,
            step: 0,
        }
    }

    /// Removes all grains, contacts and flow, and applies `config`.
    /// On error nothing changes.
    pub fn reset(&mut self, config: &SimConfig) -> Result<(), Error> {
        config.validate()?;
        let m = &config.material;
        self.grains.len = 0;
        self.nbrs.clear();
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
            dt: R::from_f64(config.step_dt),
        };
        self.dt = R::from_f64(config.step_dt);
        let reduce = (m.s - 1.0) / (m.s + m.c_m);
        self.g_red = [
            R::from_f64(config.gravity[0] * reduce),
            R::from_f64(config.gravity[1] * reduce),
        ];
        self.width = R::from_f64(config.width);
        self.y_min = R::from_f64(config.y_min);
        self.y_max = R::from_f64(config.y_max);
        self.flow = ZERO_FLOW;
        self.flow_on = false;
        self.profile = Profile::ZERO;
        self.flow_epoch = 0;
        self.bed_level = R::ZERO;
        self.step = 0;
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
        g.x[i] = R::from_f64(spec.x);
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

    /// Switches the flow on (drag (4)–(5) with (14)–(16)) or off (`None`: no drag).
    /// Hold periods of the fluctuations and bed-level updates count from now.
    pub fn set_flow(&mut self, flow: Option<&FlowConfig>) -> Result<(), Error> {
        match flow {
            Some(f) => {
                f.validate()?;
                self.flow = *f;
                self.profile = Profile::new(f);
                self.flow_on = true;
                self.flow_epoch = self.step;
            }
            None => {
                self.flow = ZERO_FLOW;
                self.profile = Profile::ZERO;
                self.flow_on = false;
            }
        }
        Ok(())
    }

    /// Advances `steps` steps.
    pub fn run(&mut self, steps: u64) -> Result<(), Error> {
        for _ in 0..steps {
            self.step()?;
        }
        Ok(())
    }

    /// Advances one step Δt: neighbour refresh, flow bookkeeping, forces,
    /// symplectic Euler (velocities, then positions), checks.
    pub fn step(&mut self) -> Result<(), Error> {
        // No buffers at all in the straight loop (microcontroller stacks are small).
        if GEOMETRY_AHEAD {
            self.step_with::<K, true>()
        } else {
            self.step_with::<0, true>()
        }
    }

    /// [`Sim::step`] with the batched pass where it has lanes (`BATCHED`,
    /// [`Sim::batched_forces_and_motion`]), else the fused pass with buffers
    /// of `BUFFER` contacts to find the pair geometry one grain ahead, or
    /// none ([`Sim::forces_and_motion`]). All give the same bits.
    fn step_with<const BUFFER: usize, const BATCHED: bool>(&mut self) -> Result<(), Error> {
        check(self.configured, "sim", 0.0, "configured by reset() first")?;
        self.nbrs.refresh(&self.grains, self.width, self.y_min)?;
        if self.flow_on {
            let since = self.step.saturating_sub(self.flow_epoch);
            if since.is_multiple_of(u64::from(self.flow.bed_level_interval.max(1))) {
                self.update_bed_level();
            }
            let hold = u64::from(self.flow.hold_steps.max(1));
            if self.profile.turbulence && since.is_multiple_of(hold) {
                self.draw_fluctuations(since / hold);
            }
        }
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        let batched = if BATCHED {
            self.batched_forces_and_motion()
        } else {
            None
        };
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
        let batched = None;
        let moved = match batched {
            Some(moved) => moved,
            None => {
                if self.flow_on {
                    self.add_drag();
                }
                self.forces_and_motion::<BUFFER>()
            }
        };
        if moved.is_err() {
            self.clear_forces();
        }
        moved
    }

    /// Zeroes every force and torque. They are zero between steps: the
    /// motion pass zeroes each grain's once it is integrated, and a failed
    /// pass calls this.
    fn clear_forces(&mut self) {
        let n = self.grains.len;
        let g = &mut self.grains;
        g.fx[..n].fill(R::ZERO);
        g.fy[..n].fill(R::ZERO);
        g.torque[..n].fill(R::ZERO);
    }

    /// Redraws every grain's held fluctuation (SPEC (15)) for hold `period`.
    fn draw_fluctuations(&mut self, period: u64) {
        let seed = self.config.seed;
        let g = &mut self.grains;
        for i in 0..g.len {
            let (a, b) = fluctuation_draw(seed, period, i as u32);
            g.z_u[i] = R::from_f64(a);
            g.z_v[i] = R::from_f64(b);
        }
    }

    /// Drag (4)–(5) on every mobile grain, heights from the mean bed level.
    fn add_drag(&mut self) {
        let g = &mut self.grains;
        for i in 0..g.len {
            if g.fixed[i] {
                continue;
            }
            let (fx, fy) = self.profile.drag(
                g.drag_coef[i],
                g.y[i] - self.bed_level,
                g.u[i],
                g.v[i],
                g.z_u[i],
                g.z_v[i],
            );
            g.fx[i] += fx;
            g.fy[i] += fy;
        }
    }

    /// The parameters of [`Mover::advance`] for this step.
    fn mover(&self) -> Mover<R> {
        Mover {
            dt: self.dt,
            gravity: self.g_red,
            width: self.width,
            y_min: self.y_min,
            y_max: self.y_max,
            step: self.step,
        }
    }

    /// Ends a step whose grains moved at most `max_v2`^½ Δt.
    fn finish_step(&mut self, max_v2: R) {
        self.nbrs.add_travel(R::sqrt(max_v2) * self.dt);
        self.step += 1;
    }

    /// Contact forces (6)–(9) of every overlapping listed pair, then symplectic
    /// Euler (1)–(3), in one pass over the grains.
    ///
    /// Pairs are visited in the fixed order (i ascending, j ascending); the
    /// history of separated pairs is dropped. Grain i appears only in pairs
    /// (m ≤ i, ·), so its force is complete once its own pairs are added and
    /// it is integrated at once, while its data is in cache: the same
    /// operations in the same order as a contact pass followed by an
    /// integration pass, so the bits do not depend on the fusion.
    ///
    /// Each pair's geometry (distance, normal, relative velocities) depends
    /// only on the start-of-step state. With buffers (`BUFFER` > 0,
    /// [`GEOMETRY_AHEAD`]), grain i + 1's is found ([`Touching::find`])
    /// before grain i's laws and motion, so that an out-of-order core works
    /// on the next grain's square roots and divisions while it finishes
    /// grain i; without, just before grain i's laws. The laws and sums run
    /// in the fixed order either way.
    fn forces_and_motion<const BUFFER: usize>(&mut self) -> Result<(), Error> {
        // A buffer holds every slot of a grain, or there is none.
        const { assert!(BUFFER == 0 || BUFFER >= K) };
        let ahead = BUFFER > 0;
        let n = self.grains.len.min(N);
        let law = self.law;
        let width = self.width;
        let mover = self.mover();
        self.nbrs.history_to_slots();
        let (mut motion, mut forces, fixed) = split(&mut self.grains, n, mover);
        let r = forces.r;
        let nb = &mut self.nbrs;
        // Grain i + 1's contacts can be found before grain i's laws and
        // motion: they read only start-of-step state (grain i + 1 and grains
        // j > i + 1; grain i moves after). Two buffers, used in turn.
        let (mut a, mut b) = (Touching::<R, BUFFER>::new(), Touching::<R, BUFFER>::new());
        let (mut current, mut next) = (&mut a, &mut b);
        if ahead && n > 0 {
            let state = motion.state(r, width);
            let count = usize::from(nb.count[0]).min(K);
            next.find(&state, 0, &nb.other[0][..count], &mut nb.spring[0][..count]);
        }
        for i in 0..n {
            let ri = r[i];
            // Grain i's sums live in registers: no pair (i, j) has j = i.
            let mut sums = Sums {
                fx: forces.fx[i],
                fy: forces.fy[i],
                torque: forces.torque[i],
            };
            let state = motion.state(r, width);
            if ahead {
                core::mem::swap(&mut current, &mut next);
                if i + 1 < n {
                    let count = usize::from(nb.count[i + 1]).min(K);
                    let springs = &mut nb.spring[i + 1][..count];
                    next.find(&state, i + 1, &nb.other[i + 1][..count], springs);
                }
                let springs = &mut nb.spring[i];
                for (k, c) in current.iter() {
                    if let Some(spring) = springs.get_mut(k) {
                        forces.add(&law, spring, c, ri, &mut sums);
                    }
                }
            } else {
                let count = usize::from(nb.count[i]).min(K);
                let pairs = nb.other[i][..count].iter().zip(&mut nb.spring[i][..count]);
                if let Some(own) = state.own(i) {
                    for (&j, spring) in pairs {
                        if let Some(c) = state.contact(&own, j, spring) {
                            forces.add(&law, spring, &c, ri, &mut sums);
                        }
                    }
                }
            }
            (forces.fx[i], forces.fy[i], forces.torque[i]) = (R::ZERO, R::ZERO, R::ZERO);
            if !fixed[i] {
                motion.advance(i, &sums)?;
            }
        }
        let max_v2 = motion.max_v2;
        self.finish_step(max_v2);
        Ok(())
    }

    /// The batched step ([`crate::batch`]): the drag (flow on), every listed
    /// pair's force, then
    /// every grain's sums (in the order of [`Sim::forces_and_motion`]) and
    /// motion, in vector lanes. Same bits as the fused pass. `None` where
    /// this precision has no lanes on this target or the pairs do not fit
    /// its storage: the caller then runs the fused pass.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    fn batched_forces_and_motion(&mut self) -> Option<Result<(), Error>> {
        let mover = self.mover();
        let g = &mut self.grains;
        let nb = &mut self.nbrs;
        let mut step = BatchStep {
            n: g.len.min(N),
            x: &mut g.x,
            y: &mut g.y,
            u: &mut g.u,
            v: &mut g.v,
            w: &mut g.w,
            inv_mass: &g.inv_mass,
            inv_inertia: &g.inv_inertia,
            width: self.width,
            law: self.law,
            mover,
            batch: &mut nb.batch,
            drag: self.flow_on.then_some(Drag {
                profile: self.profile,
                bed_level: self.bed_level,
                coef: &g.drag_coef,
                z_u: &g.z_u,
                z_v: &g.z_v,
            }),
        };
        match batched_step(&mut step)? {
            Ok(max_v2) => {
                self.finish_step(max_v2);
                Some(Ok(()))
            }
            Err(e) => Some(Err(e)),
        }
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

    /// Rebuilds the neighbour lists now. Results never depend on when the
    /// lists are rebuilt; this is for benchmarks of the rebuild alone.
    pub fn rebuild_neighbours(&mut self) -> Result<(), Error> {
        check(self.configured, "sim", 0.0, "configured by reset() first")?;
        self.nbrs.rebuild(&self.grains, self.width, self.y_min)
    }

    /// Neighbour-list rebuilds since [`Sim::reset`] (a diagnostic of speed:
    /// results never depend on it).
    pub fn neighbour_rebuilds(&self) -> u64 {
        self.nbrs.rebuilds
    }

    /// The pairs (i, j), i < j, in contact with their spring history, in
    /// (i, j) order.
    pub fn contacts(&self) -> impl Iterator<Item = (usize, usize, Spring<R>)> + '_ {
        self.nbrs.contacts(self.grains.len)
    }

    /// The contact law (6)–(9) in force, in the working precision.
    pub fn contact_law(&self) -> ContactLaw<R> {
        self.law
    }

    /// Spring history (e_n, e_s) of the pair (i, j) if it is in contact.
    pub fn contact_history(&self, i: usize, j: usize) -> Option<(f64, f64)> {
        let h = self.nbrs.history(i, j)?;
        (h.e_n != R::ZERO || h.e_s != R::ZERO).then(|| (h.e_n.to_f64(), h.e_s.to_f64()))
    }

    /// The turbulent fluctuation (u, v) (m/s) grain `i` currently feels
    /// (SPEC (15)): its held draws times the rms at its height, zero where
    /// U = 0, for fixed grains, or without flow or turbulence.
    pub fn fluctuation(&self, i: usize) -> Option<(f64, f64)> {
        if i >= self.grains.len {
            return None;
        }
        let g = &self.grains;
        if !self.flow_on || g.fixed[i] {
            return Some((0.0, 0.0));
        }
        let y = g.y[i] - self.bed_level;
        let p = &self.profile;
        let (u, v) = p.fluctuation(p.mean_velocity(y), y, g.z_u[i], g.z_v[i]);
        Some((u.to_f64(), v.to_f64()))
    }

    /// Mean bed level y = 0 of the flow (SPEC §6), absolute (m): the mean
    /// centre height of the surface grains, found per window of
    /// `FlowConfig::bed_level_window` largest diameters so that it does not
    /// depend on the width of the periodic bed (README, "Bed width").
    pub fn bed_level(&self) -> f64 {
        self.bed_level.to_f64()
    }
}

/// Splits the first `n` grains into what a force-and-motion pass moves
/// ([`Motion`]), what its pair sums use ([`Forces`]), and which are fixed.
fn split<R: Real, const N: usize>(
    g: &mut Grains<R, N>,
    n: usize,
    mover: Mover<R>,
) -> (Motion<'_, R>, Forces<'_, R>, &[bool]) {
    let motion = Motion {
        x: &mut g.x[..n],
        y: &mut g.y[..n],
        u: &mut g.u[..n],
        v: &mut g.v[..n],
        w: &mut g.w[..n],
        inv_mass: &g.inv_mass[..n],
        inv_inertia: &g.inv_inertia[..n],
        mover,
        max_v2: R::ZERO,
    };
    let forces = Forces {
        fx: &mut g.fx[..n],
        fy: &mut g.fy[..n],
        torque: &mut g.torque[..n],
        r: &g.r[..n],
    };
    (motion, forces, &g.fixed[..n])
}

/// The grains' state during a force-and-motion pass, and the largest
/// squared speed reached.
struct Motion<'a, R: Real> {
    x: &'a mut [R],
    y: &'a mut [R],
    u: &'a mut [R],
    v: &'a mut [R],
    w: &'a mut [R],
    inv_mass: &'a [R],
    inv_inertia: &'a [R],
    mover: Mover<R>,
    max_v2: R,
}

impl<R: Real> Motion<'_, R> {
    /// The state as the pair geometry reads it (radii `r`, periodic `width`).
    #[inline(always)]
    fn state<'s>(&'s self, r: &'s [R], width: R) -> State<'s, R> {
        State::new([&*self.x, &*self.y, &*self.u, &*self.v, &*self.w, r], width)
    }

    /// Moves mobile grain i under its force and torque `sums` ([`Mover::advance`]).
    #[inline(always)]
    fn advance(&mut self, i: usize, sums: &Sums<R>) -> Result<(), Error> {
        // Read here, not kept from the top: fewer live registers in the
        // pair loops.
        let moved = self.mover.advance(
            i,
            [self.x[i], self.y[i], self.u[i], self.v[i], self.w[i]],
            [
                sums.fx * self.inv_mass[i],
                sums.fy * self.inv_mass[i],
                sums.torque * self.inv_inertia[i],
            ],
        )?;
        [self.x[i], self.y[i], self.u[i], self.v[i], self.w[i]] = moved;
        self.max_v2 = R::max(self.max_v2, moved[2] * moved[2] + moved[3] * moved[3]);
        Ok(())
    }
}

/// Symplectic Euler for one mobile grain (SPEC (1)–(3)) with the periodic
/// wrap in x and the non-finite and out-of-domain checks.
pub(crate) struct Mover<R: Real> {
    pub(crate) dt: R,
    /// Reduced gravity, SPEC (2).
    pub(crate) gravity: [R; 2],
    pub(crate) width: R,
    pub(crate) y_min: R,
    pub(crate) y_max: R,
    step: u64,
}

impl<R: Real> Mover<R> {
    /// The new (x, y, u, v, ω) of grain `i` from its state and its
    /// accelerations (F_x/m', F_y/m', T/I): velocities first, then positions
    /// from the new velocities.
    #[inline]
    pub(crate) fn advance(&self, i: usize, state: [R; 5], accel: [R; 3]) -> Result<[R; 5], Error> {
        let [x, y, u, v, w] = state;
        let dt = self.dt;
        let u = u + (accel[0] + self.gravity[0]) * dt;
        let v = v + (accel[1] + self.gravity[1]) * dt;
        let w = w + accel[2] * dt;
        let mut x = x + u * dt;
        let y = y + v * dt;
        if x >= self.width {
            x -= self.width;
        } else if x < R::ZERO {
            x += self.width;
            if x >= self.width {
                x = R::ZERO; // −tiny + L rounded up to L
            }
        }
        // One test on the common path: every value finite and inside the domain.
        // The domain test also rejects a non-finite u or v (x, y then become
        // ±∞ or NaN, Δt > 0) and a non-finite y; ω needs its own test.
        if R::is_finite(w) && x >= R::ZERO && x < self.width && y >= self.y_min && y <= self.y_max {
            Ok([x, y, u, v, w])
        } else {
            Err(self.fault(i, [x, y, u, v, w]))
        }
    }

    /// The error for a grain that failed [`Mover::advance`]'s test, in the
    /// order velocity, spin, position, domain.
    #[cold]
    fn fault(&self, i: usize, [x, y, u, v, w]: [R; 5]) -> Error {
        let (step, grain) = (self.step, i as u32);
        let quantity = if !(R::is_finite(u) && R::is_finite(v)) {
            Quantity::Velocity
        } else if !R::is_finite(w) {
            Quantity::Spin
        } else if !(R::is_finite(x) && R::is_finite(y)) {
            Quantity::Position
        } else {
            return Error::LeftDomain {
                step,
                grain,
                y: y.to_f64(),
            };
        };
        Error::NonFinite {
            step,
            grain,
            quantity,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scenario;

    /// The paper's scenario, settling then flow, stepped with the batched
    /// pass where it has lanes (`BATCHED`) or the fused pass with the pair
    /// geometry found ahead (`BUFFER` > 0) or not: (settled, flow) digests.
    fn digests<R: Real, const BUFFER: usize, const BATCHED: bool>() -> (u64, u64) {
        let mut sim = Sim::<R, 64, 8>::new();
        let sc = Scenario::paper();
        sc.build(&mut sim).unwrap();
        for _ in 0..1500 {
            sim.step_with::<BUFFER, BATCHED>().unwrap();
        }
        let settled = sim.digest();
        sim.set_flow(Some(&sc.flow())).unwrap();
        for _ in 0..1500 {
            sim.step_with::<BUFFER, BATCHED>().unwrap();
        }
        let flow = sim.digest();
        // Wherever the history lives, each contact's is found by its pair.
        let contacts = sim.contacts().collect::<heapless::Vec<_, 512>>();
        assert!(contacts.len() > 32, "{}", contacts.len());
        for &(i, j, h) in &contacts {
            let h = (h.e_n.to_f64(), h.e_s.to_f64());
            assert_eq!(sim.contact_history(j, i), Some(h));
        }
        // The batched pass runs (both precisions have lanes).
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        if BATCHED {
            assert!(sim.batched_forces_and_motion().is_some());
        }
        (settled, flow)
    }

    /// The host's loop shapes (batched pair pass in lanes; fused with the
    /// geometry one grain ahead) and the microcontroller's (fused, in
    /// order) give the same bits.
    #[test]
    fn batched_fused_ahead_or_not_give_the_same_bits() {
        let fused = digests::<f64, 0, false>();
        assert_eq!(digests::<f64, 8, false>(), fused);
        assert_eq!(digests::<f64, 8, true>(), fused);
        let fused = digests::<f32, 0, false>();
        assert_eq!(digests::<f32, 8, false>(), fused);
        assert_eq!(digests::<f32, 8, true>(), fused);
    }

    /// A grain in many pairs (a large grain ringed by 14 small ones, as
    /// first or as second grain of its pairs, so that one batch adds to its
    /// sums in many lanes): the batched step gives the fused pass's bits.
    #[test]
    fn a_grain_in_many_pairs_is_batched_with_the_fused_bits() {
        for big_first in [true, false] {
            let ring = |batched: bool| ring_digest::<f64>(big_first, batched);
            assert_eq!(ring(true), ring(false));
            let ring = |batched: bool| ring_digest::<f32>(big_first, batched);
            assert_eq!(ring(true), ring(false));
        }
    }

    /// A bed 24 columns wide drifting across the periodic seam at 1 m/s
    /// (grains of the last column wrap around between rebuilds), so that
    /// chunks of pairs away from the seam skip the periodic image and those
    /// near it do not: the batched step gives the one-pass bits step after
    /// step, in both precisions. It fails if the chunks near the seam are
    /// not marked.
    #[test]
    fn a_bed_drifting_across_the_seam_steps_batched_as_in_one_pass() {
        drifts_across_the_seam::<f64>();
        drifts_across_the_seam::<f32>();
    }

    fn drifts_across_the_seam<R: Real>() {
        let mut sc = Scenario::paper();
        sc.bed.columns = 24;
        let mut batched = std::boxed::Box::new(Sim::<R, 512, 8>::new());
        sc.build(&mut batched).unwrap();
        batched.run(8000).unwrap();
        for i in 0..batched.len() {
            if !batched.grains.fixed[i] {
                batched.grains.u[i] = R::from_f64(1.0);
            }
        }
        let mut one_pass = batched.clone();
        let mut wraps = 0;
        for _ in 0..400 {
            let xs = batched.grains.x;
            batched.step_with::<8, true>().unwrap();
            one_pass.step_with::<0, false>().unwrap();
            assert_eq!(batched.digest(), one_pass.digest());
            let half = 0.5 * batched.width.to_f64();
            wraps += (0..batched.len())
                .filter(|&i| (xs[i] - batched.grains.x[i]).to_f64() > half)
                .count();
        }
        assert!(wraps >= 10, "{wraps} grains wrapped around");
        assert!(
            batched.contacts().count() > batched.len(),
            "a bed in contact"
        );
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        {
            let (marked, chunks) = batched.nbrs.batch.chunks_near_the_seam();
            assert!(marked > 0 && marked < chunks, "{marked} of {chunks}");
        }
    }

    /// An empty 0.02 m wide box of the paper's constants, floor at −0.01 m,
    /// room for 64 grains of up to 16 neighbours.
    fn small_box<R: Real>() -> Sim<R, 64, 16> {
        let mut sim = Sim::new();
        let mut config = Scenario::paper().sim_config().unwrap();
        (config.width, config.y_min) = (0.02, -0.01);
        sim.reset(&config).unwrap();
        sim
    }

    /// One step of a [`small_box`], batched or one pass (no buffer).
    fn step_small_box<R: Real>(sim: &mut Sim<R, 64, 16>, batched: bool) -> Result<(), Error> {
        if batched {
            sim.step_with::<16, true>()
        } else {
            sim.step_with::<0, false>()
        }
    }

    fn ring_digest<R: Real>(big_first: bool, batched: bool) -> u64 {
        let mut sim = small_box::<R>();
        let big = GrainSpec {
            x: 0.01,
            y: 0.005,
            diameter: 2e-3,
            ..GrainSpec::default()
        };
        if big_first {
            sim.add_grain(&big).unwrap();
        }
        for k in 0..14 {
            let angle = core::f64::consts::TAU * f64::from(k) / 14.0;
            let reach = 1.249e-3;
            sim.add_grain(&GrainSpec {
                x: big.x + reach * libm::cos(angle),
                y: big.y + reach * libm::sin(angle),
                diameter: 0.5e-3,
                ..GrainSpec::default()
            })
            .unwrap();
        }
        if !big_first {
            sim.add_grain(&big).unwrap();
        }
        for _ in 0..20 {
            step_small_box(&mut sim, batched).unwrap();
        }
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        assert_eq!(sim.nbrs.batch.ready, batched);
        assert_eq!(sim.contacts().count(), 14);
        sim.digest()
    }

    /// A grain of a random cluster: x, y (m), u, v (m/s), spin (rad/s),
    /// size class (0.4, 0.5 or 0.7 mm) and whether it is fixed.
    type Loose = (f64, f64, f64, f64, f64, usize, bool);

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            cases: 48,
            ..proptest::prelude::ProptestConfig::default()
        })]
        /// Random clusters of mixed sizes, some fixed, some overlapping, with
        /// and without flow: the batched step gives the one-pass step's bits
        /// step after step, or the same error.
        #[test]
        fn random_clusters_step_batched_as_in_one_pass(
            grains in proptest::collection::vec(
                (
                    0.0..0.02f64,
                    0.0..0.0015f64,
                    -0.05..0.05f64,
                    -0.05..0.05f64,
                    -50.0..50.0f64,
                    0..3usize,
                    proptest::bool::weighted(0.15),
                ),
                1..60,
            ),
            flow: bool,
        ) {
            proptest::prop_assert_eq!(cluster::<f64>(&grains, flow, true), cluster::<f64>(&grains, flow, false));
            proptest::prop_assert_eq!(cluster::<f32>(&grains, flow, true), cluster::<f32>(&grains, flow, false));
        }
    }

    /// Steps a random cluster 40 times, batched or one pass: each step's
    /// outcome and digest, up to the first error.
    fn cluster<R: Real>(
        grains: &[Loose],
        flow: bool,
        batched: bool,
    ) -> std::vec::Vec<(Result<(), Error>, u64)> {
        let mut sim = small_box::<R>();
        for &(x, y, u, v, spin, class, fixed) in grains {
            let spec = GrainSpec {
                x,
                y,
                u,
                v,
                spin,
                diameter: [0.4e-3, 0.5e-3, 0.7e-3][class],
                fixed,
                ..GrainSpec::default()
            };
            sim.add_grain(&spec).unwrap();
        }
        if flow {
            sim.set_flow(Some(&Scenario::paper().flow())).unwrap();
        }
        let mut outcomes = std::vec::Vec::new();
        for _ in 0..40 {
            let outcome = step_small_box(&mut sim, batched);
            let failed = outcome.is_err();
            outcomes.push((outcome, sim.digest()));
            if failed {
                break;
            }
        }
        outcomes
    }

    /// Each build sizes the skin from the fastest grain's speed: the floor
    /// for a bed at rest, between floor and configured skin for a settling
    /// one, the configured skin once a grain is fast.
    #[test]
    fn the_skin_follows_the_fastest_grain() {
        let mut sim = Sim::<f64, 64, 8>::new();
        Scenario::paper().build(&mut sim).unwrap();
        sim.run(3000).unwrap();
        let largest = sim.config.skin;
        sim.rebuild_neighbours().unwrap();
        assert!(sim.nbrs.skin > 0.3 * largest && sim.nbrs.skin < largest);
        for a in [&mut sim.grains.u, &mut sim.grains.v, &mut sim.grains.w] {
            a.fill(0.0);
        }
        sim.step().unwrap();
        sim.rebuild_neighbours().unwrap();
        assert_eq!(sim.nbrs.skin, 0.3 * largest);
        let i = (0..sim.len()).rfind(|&i| !sim.grains.fixed[i]).unwrap();
        sim.grains.u[i] = 0.5;
        sim.step().unwrap();
        sim.rebuild_neighbours().unwrap();
        assert_eq!(sim.nbrs.skin, largest);
    }

    /// A grain thrown out of the domain fails the batched and the fused
    /// passes alike, in both precisions: the same error, the same state
    /// left behind.
    #[test]
    fn batched_and_fused_fail_alike() {
        fails_alike::<f64>();
        fails_alike::<f32>();
    }

    fn fails_alike<R: Real>() {
        let fail = |batched: bool| {
            let mut sim = Sim::<R, 64, 8>::new();
            Scenario::paper().build(&mut sim).unwrap();
            sim.run(100).unwrap();
            let i = (0..sim.len())
                .rev()
                .find(|&i| !sim.grains.fixed[i])
                .unwrap()
                - 2;
            sim.grains.v[i] = R::from_f64(1e9);
            let error = if batched {
                sim.step_with::<8, true>()
            } else {
                sim.step_with::<0, false>()
            };
            (error, sim.digest())
        };
        let (error, digest) = fail(false);
        assert!(matches!(error, Err(Error::LeftDomain { .. })), "{error:?}");
        assert_eq!(fail(true), (error, digest));
    }
}
