//! Checkpoints: the complete state of a [`Sim`] as bytes, and back.
//!
//! Little-endian whatever the machine, floats as their raw IEEE bits in the
//! working precision, so a checkpoint written on x86_64 restores on a
//! Cortex-M and continues bit for bit. Layout (version 6; version 5, read
//! too, has no lateral stress ratio of the grains' wall friction (C12);
//! version 4 no free surface below the domain's top, no side walls, the
//! paper's drag and fluctuations and no redraw schedule; version 3 no
//! slope, no flow model and no fluid: a horizontal bed and clear water;
//! version 2 not even the tension byte: the paper's rule):
//!
//! | field | bytes |
//! |---|---|
//! | magic `MBSK`, version u16, precision bytes u8 (4/8), 0 u8 | 8 |
//! | `SimConfig`: step_dt, ρ, s, C_M, C_D, μ, ν, k_n, k_s, η_n, η_s, g_x, g_y, L, y_min, y_max, skin (f64), seed (u64), tension (u8: 0 the paper's rule (8), 1 none (8')), slope angle θ, free surface (f64) | 161 |
//! | flow on (u8); `FlowConfig`: u*, and of its `FlowSpec` κ, h, ε0, k_sr, d (f64), turbulence (u8), hold, bed-level interval (u32, integration steps), bed-level span (f64), model (u8: 0 clear water, 1 coupled); `FluidConfig`: fluid cells (u32), bottom, surface, cross-section, ρ, ν, κ, φ_max, driving (f64), update steps (u32, integration steps), hindrance, channel width, wall friction factor, grains' wall friction, lateral stress ratio K (f64), drag law (u8: 0 paper, 1 Dallavalle), fluctuations (u8: 0 paper, 1 HydroForceEngine's) | 181 |
//! | flow epoch, step, next redraw step, redraw period (u64), bed level (R) | 32 + R |
//! | grains n (u32); per grain x, y, u, v, ω, d/2, z_u, z_v, 1/m, 1/I, drag factor (R), fixed, class (u8) | 4 + n (11R + 2) |
//! | contacts m (u32); per contact i, j (u32), e_n, e_s (R), in (i, j) order | 4 + m (8 + 2R) |
//! | coupled flow only: per fluid cell u_f, φ, the stabiliser's force carried, the grains' drag summed since the last update (R) | fluid cells 4R |
//!
//! The fluid section is checked as the rest: its configuration by
//! [`FlowConfig::validate`] and the capacity, every value finite, each φ
//! in [0, 1); a refused section leaves the
//! simulation unchanged.
//!
//! The inertias and drag factor are stored, not recomputed: they were derived
//! from the f64 diameter, which an f32 radius does not give back exactly.
//! Forces are not state (each step computes them afresh) and the neighbour
//! list is rebuilt on the next step from the restored contacts, which
//! changes no bit (results do not depend on when the list is rebuilt).
//! Restoring parses everything twice: a dry run that validates, then the
//! real one, so a refused checkpoint leaves the simulation unchanged.

use crate::constants::{ContactConstants, Material};
use crate::contact::{Spring, Tension};
use crate::error::{Capacity, CheckpointFault, Error};
use crate::flow::{FlowConfig, FlowModel, FlowSpec};
use crate::fluid::{DragLaw, Fluctuations, FluidConfig, FluidSpec};
use crate::grains::{GrainSpec, MAX_CLASSES};
use crate::real::Real;
use crate::sim::{check_grain, Redraw, Sim, SimConfig};
use crate::steps::IntegrationSteps;

/// Format version written by [`Sim::checkpoint`].
pub const CHECKPOINT_VERSION: u16 = 6;

const MAGIC: [u8; 4] = *b"MBSK";

/// Reads little-endian fields from a byte slice.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn fail(&self, fault: CheckpointFault) -> Error {
        Error::BadCheckpoint {
            fault,
            offset: self.at,
        }
    }

    fn take(&mut self, n: usize) -> Result<&[u8], Error> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(self.fail(CheckpointFault::Truncated));
        };
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }

    fn uint(&mut self, n: usize) -> Result<u64, Error> {
        let mut v = 0u64;
        for (k, b) in self.take(n)?.iter().enumerate() {
            v |= u64::from(*b) << (8 * k);
        }
        Ok(v)
    }

    fn u8(&mut self) -> Result<u8, Error> {
        Ok(self.uint(1)? as u8)
    }

    fn u32(&mut self) -> Result<u32, Error> {
        Ok(self.uint(4)? as u32)
    }

    fn u64(&mut self) -> Result<u64, Error> {
        self.uint(8)
    }

    fn flag(&mut self) -> Result<bool, Error> {
        match self.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(self.fail(CheckpointFault::Value)),
        }
    }

    fn f64(&mut self) -> Result<f64, Error> {
        let x = f64::from_bits(self.u64()?);
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.fail(CheckpointFault::Value))
        }
    }

    fn real<R: Real>(&mut self) -> Result<R, Error> {
        let x = R::from_raw(self.uint(R::BYTES)?);
        if R::is_finite(x) {
            Ok(x)
        } else {
            Err(self.fail(CheckpointFault::Value))
        }
    }
}

/// Writes little-endian fields to a byte sink.
struct Writer<'a, F: FnMut(&[u8])> {
    sink: &'a mut F,
}

impl<F: FnMut(&[u8])> Writer<'_, F> {
    fn uint(&mut self, v: u64, n: usize) {
        let bytes = v.to_le_bytes();
        (self.sink)(&bytes[..n]);
    }
    fn f64(&mut self, x: f64) {
        self.uint(x.to_bits(), 8);
    }
    fn real<R: Real>(&mut self, x: R) {
        self.uint(x.to_raw(), R::BYTES);
    }
}

/// The parsed header and configuration.
struct Head {
    config: SimConfig,
    flow: Option<FlowConfig>,
    flow_epoch: u64,
    step: u64,
    redraw: Redraw,
}

fn read_head<R: Real>(r: &mut Reader<'_>) -> Result<Head, Error> {
    if r.take(4)? != MAGIC {
        r.at = 0;
        return Err(r.fail(CheckpointFault::Magic));
    }
    let version = r.uint(2)?;
    if !(2..=u64::from(CHECKPOINT_VERSION)).contains(&version) {
        return Err(r.fail(CheckpointFault::Version));
    }
    if usize::from(r.u8()?) != R::BYTES {
        return Err(r.fail(CheckpointFault::Precision));
    }
    r.u8()?;
    let mut f = [0.0; 17];
    for x in f.iter_mut() {
        *x = r.f64()?;
    }
    let seed = r.u64()?;
    let at = r.at;
    let code = if version == 2 { 0 } else { r.u8()? };
    let tension = Tension::from_code(code).ok_or(Error::BadCheckpoint {
        fault: CheckpointFault::Value,
        offset: at,
    })?;
    let config = SimConfig {
        step_dt: f[0],
        material: Material {
            rho: f[1],
            s: f[2],
            c_m: f[3],
            c_d: f[4],
            mu: f[5],
            nu: f[6],
        },
        contact: ContactConstants {
            k_n: f[7],
            k_s: f[8],
            eta_n: f[9],
            eta_s: f[10],
        },
        tension,
        gravity: [f[11], f[12]],
        width: f[13],
        y_min: f[14],
        y_max: f[15],
        skin: f[16],
        seed,
        slope_angle: if version >= 4 { r.f64()? } else { 0.0 },
        // Before version 5 the domain ended at the free surface.
        surface: if version >= 5 { r.f64()? } else { f[15] },
    };
    let at = r.at;
    config.validate().map_err(|_| Error::BadCheckpoint {
        fault: CheckpointFault::Value,
        offset: at,
    })?;
    let flow_on = r.flag()?;
    let mut g = [0.0; 6];
    for x in g.iter_mut() {
        *x = r.f64()?;
    }
    let spec = FlowSpec {
        kappa: g[1],
        depth: g[2],
        eps0: g[3],
        roughness: g[4],
        reference_diameter: g[5],
        turbulence: r.flag()?,
        hold_steps: IntegrationSteps(r.u32()?),
        bed_level_interval: IntegrationSteps(r.u32()?),
        bed_level_span: r.f64()?,
        model: FlowModel::ClearWater,
    };
    let flow = spec.at(g[0]);
    let flow = if version >= 4 {
        let at = r.at;
        let model = FlowModel::from_code(r.u8()?).ok_or(Error::BadCheckpoint {
            fault: CheckpointFault::Value,
            offset: at,
        })?;
        let fluid_cells = r.u32()? as usize;
        let mut c = [0.0; 8];
        for x in c.iter_mut() {
            *x = r.f64()?;
        }
        let update_steps = IntegrationSteps(r.u32()?);
        let hindrance = r.f64()?;
        let (channel_width, wall_friction, grain_wall_friction, lateral_ratio, drag, fluctuations) =
            if version >= 5 {
                let width = r.f64()?;
                let friction = r.f64()?;
                let grains = r.f64()?;
                let ratio = if version >= 6 { r.f64()? } else { 0.0 };
                let at = r.at;
                let bad = || Error::BadCheckpoint {
                    fault: CheckpointFault::Value,
                    offset: at,
                };
                let drag = DragLaw::from_code(r.u8()?).ok_or_else(bad)?;
                let fluctuations = Fluctuations::from_code(r.u8()?).ok_or_else(bad)?;
                (width, friction, grains, ratio, drag, fluctuations)
            } else {
                (0.0, 1.0, 0.0, 0.0, DragLaw::Paper, Fluctuations::Paper)
            };
        let fluid = FluidConfig {
            spec: FluidSpec {
                viscosity: c[4],
                phi_max: c[6],
                update_steps,
                hindrance,
                channel_width,
                wall_friction,
                grain_wall_friction,
                lateral_ratio,
                drag,
                fluctuations,
            },
            cells: fluid_cells,
            bottom: c[0],
            surface: c[1],
            cross_section: c[2],
            density: c[3],
            kappa: c[5],
            driving: c[7],
        };
        FlowConfig {
            spec: FlowSpec { model, ..spec },
            fluid,
            ..flow
        }
    } else {
        flow
    };
    let at = r.at;
    if flow_on {
        flow.validate().map_err(|_| Error::BadCheckpoint {
            fault: CheckpointFault::Value,
            offset: at,
        })?;
    } else if flow.spec.model != FlowModel::ClearWater {
        return Err(Error::BadCheckpoint {
            fault: CheckpointFault::Value,
            offset: at,
        });
    }
    let (flow_epoch, step) = (r.u64()?, r.u64()?);
    let redraw = if version >= 5 {
        Redraw {
            next: r.u64()?,
            period: r.u64()?,
        }
    } else {
        Redraw::default()
    };
    Ok(Head {
        config,
        flow: flow_on.then_some(flow),
        flow_epoch,
        step,
        redraw,
    })
}

/// Bytes of a checkpoint before its grains: header 8, `SimConfig` 161 (with
/// the tension rule, the slope and the free surface), flow 181 (with the
/// fluid's configuration), flow epoch, step and redraw schedule 32 (the
/// bed level, `R`, follows).
const HEAD_LEN: usize = 8 + 161 + 181 + 32;

impl<R: Real, const N: usize, const K: usize, const C: usize> Sim<R, N, K, C> {
    /// The length of the largest checkpoint this simulation can write or
    /// restore: every grain slot used, every neighbour slot a contact. A
    /// longer file is no checkpoint of it, and can be refused unread.
    pub const MAX_CHECKPOINT_LEN: usize =
        Self::checkpoint_len(N, N * K).saturating_add(Self::fluid_len(C));

    /// The length of a checkpoint of `grains` grains and `contacts`
    /// contacts in this precision (saturating: never a panic).
    pub const fn checkpoint_len(grains: usize, contacts: usize) -> usize {
        let grain_bytes = grains.saturating_mul(11 * R::BYTES + 2);
        let contact_bytes = contacts.saturating_mul(8 + 2 * R::BYTES);
        (HEAD_LEN + R::BYTES + 8)
            .saturating_add(grain_bytes)
            .saturating_add(contact_bytes)
    }

    /// The length of the fluid section of a coupled checkpoint of `fluid_cells`
    /// fluid cells (saturating); a clear-water checkpoint has none.
    pub const fn fluid_len(fluid_cells: usize) -> usize {
        fluid_cells.saturating_mul(4 * R::BYTES)
    }

    /// Writes the complete state to `sink` in the format of this module.
    pub fn checkpoint(&self, mut sink: impl FnMut(&[u8])) {
        let mut w = Writer { sink: &mut sink };
        (w.sink)(&MAGIC);
        w.uint(u64::from(CHECKPOINT_VERSION), 2);
        w.uint(R::BYTES as u64, 1);
        w.uint(0, 1);
        let c = &self.config;
        let m = &c.material;
        let k = &c.contact;
        for x in [
            c.step_dt,
            m.rho,
            m.s,
            m.c_m,
            m.c_d,
            m.mu,
            m.nu,
            k.k_n,
            k.k_s,
            k.eta_n,
            k.eta_s,
            c.gravity[0],
            c.gravity[1],
            c.width,
            c.y_min,
            c.y_max,
            c.skin,
        ] {
            w.f64(x);
        }
        w.uint(c.seed, 8);
        w.uint(u64::from(c.tension.code()), 1);
        w.f64(c.slope_angle);
        w.f64(c.surface);
        let (u_star, f, fl) = (self.flow.u_star, &self.flow.spec, &self.flow.fluid);
        w.uint(u64::from(self.flow_on), 1);
        for x in [
            u_star,
            f.kappa,
            f.depth,
            f.eps0,
            f.roughness,
            f.reference_diameter,
        ] {
            w.f64(x);
        }
        w.uint(u64::from(f.turbulence), 1);
        w.uint(u64::from(f.hold_steps.0), 4);
        w.uint(u64::from(f.bed_level_interval.0), 4);
        w.f64(f.bed_level_span);
        w.uint(f.model as u64, 1);
        w.uint(fl.cells as u64, 4);
        for x in [
            fl.bottom,
            fl.surface,
            fl.cross_section,
            fl.density,
            fl.spec.viscosity,
            fl.kappa,
            fl.spec.phi_max,
            fl.driving,
        ] {
            w.f64(x);
        }
        w.uint(u64::from(fl.spec.update_steps.0), 4);
        w.f64(fl.spec.hindrance);
        w.f64(fl.spec.channel_width);
        w.f64(fl.spec.wall_friction);
        w.f64(fl.spec.grain_wall_friction);
        w.f64(fl.spec.lateral_ratio);
        w.uint(fl.spec.drag as u64, 1);
        w.uint(fl.spec.fluctuations as u64, 1);
        w.uint(self.flow_epoch, 8);
        w.uint(self.step, 8);
        w.uint(self.redraw.next, 8);
        w.uint(self.redraw.period, 8);
        w.real(self.bed_level);
        let g = &self.grains;
        w.uint(g.len as u64, 4);
        for i in 0..g.len {
            for x in [
                g.x[i],
                g.y[i],
                g.u[i],
                g.v[i],
                g.w[i],
                g.r[i],
                g.z_u[i],
                g.z_v[i],
                g.inv_mass[i],
                g.inv_inertia[i],
                g.drag_coef[i],
            ] {
                w.real(x);
            }
            w.uint(u64::from(g.fixed[i]), 1);
            w.uint(u64::from(g.class[i]), 1);
        }
        w.uint(self.contacts().count() as u64, 4);
        for (i, j, s) in self.contacts() {
            w.uint(i as u64, 4);
            w.uint(j as u64, 4);
            w.real(s.e_n);
            w.real(s.e_s);
        }
        if let Some(column) = self.fluid_column() {
            let f = &self.fluid;
            let fluid_cells = column.velocities().iter().zip(column.solid_fractions());
            for ((&u, &phi), (&carried, &drag)) in
                fluid_cells.zip(f.carried.iter().zip(&f.drag_sum))
            {
                w.real(u);
                w.real(phi);
                w.real(carried);
                w.real(drag);
            }
        }
    }

    /// Replaces the state with a checkpoint written by [`Sim::checkpoint`]
    /// (any machine, same precision). On error the simulation is unchanged.
    pub fn restore(&mut self, bytes: &[u8]) -> Result<(), Error> {
        self.read_state(bytes, false)?;
        self.read_state(bytes, true)
    }

    /// Parses a checkpoint; applies it only if `apply` (after a dry run
    /// without `apply` has succeeded).
    fn read_state(&mut self, bytes: &[u8], apply: bool) -> Result<(), Error> {
        let mut r = Reader { bytes, at: 0 };
        let head = read_head::<R>(&mut r)?;
        let bed_level = r.real::<R>()?;
        if apply {
            self.reset(&head.config)?;
            self.switch_flow(head.flow.as_ref(), false)?;
        }
        let n = r.u32()? as usize;
        if n > N {
            return Err(Error::CapacityExceeded {
                what: Capacity::Grains,
                capacity: N,
            });
        }
        if let Some(f) = head.flow.filter(|f| f.spec.model == FlowModel::Coupled) {
            f.fluid.validate(C)?;
        }
        for i in 0..n {
            let mut v = [R::ZERO; 11];
            for x in v.iter_mut() {
                *x = r.real::<R>()?;
            }
            let fixed = r.flag()?;
            let class = r.u8()?;
            let at = r.at;
            let bad = || Error::BadCheckpoint {
                fault: CheckpointFault::Value,
                offset: at,
            };
            if usize::from(class) >= MAX_CLASSES || v[8..].iter().any(|&x| x < R::ZERO) {
                return Err(bad());
            }
            let spec = GrainSpec {
                x: v[0].to_f64(),
                y: v[1].to_f64(),
                u: v[2].to_f64(),
                v: v[3].to_f64(),
                spin: v[4].to_f64(),
                diameter: 2.0 * v[5].to_f64(),
                fixed,
                class,
            };
            check_grain(&head.config, &spec).map_err(|_| bad())?;
            // In the checkpoint's precision too: x < width (the mover keeps
            // it so; a width rounded down could let x equal it).
            if v[0] >= R::from_f64(head.config.width) {
                return Err(bad());
            }
            if apply {
                self.add_grain(&spec).map_err(|_| bad())?;
                let g = &mut self.grains;
                (g.x[i], g.y[i], g.u[i], g.v[i], g.w[i]) = (v[0], v[1], v[2], v[3], v[4]);
                (g.r[i], g.z_u[i], g.z_v[i]) = (v[5], v[6], v[7]);
                (g.inv_mass[i], g.inv_inertia[i], g.drag_coef[i]) = (v[8], v[9], v[10]);
            }
        }
        let m = r.u32()? as usize;
        let mut last = (0usize, 0usize);
        let mut slots = 0usize;
        for c in 0..m {
            let (i, j) = (r.u32()? as usize, r.u32()? as usize);
            let spring = Spring {
                e_n: r.real::<R>()?,
                e_s: r.real::<R>()?,
            };
            if !((c == 0 || (i, j) > last) && i < j && j < n) {
                return Err(r.fail(CheckpointFault::Value));
            }
            slots = if c > 0 && i == last.0 { slots + 1 } else { 1 };
            if slots > K {
                return Err(Error::CapacityExceeded {
                    what: Capacity::NeighboursPerGrain,
                    capacity: K,
                });
            }
            last = (i, j);
            if apply {
                self.nbrs.push_history(i, j, spring);
            }
        }
        if let Some(flow) = head.flow.filter(|f| f.spec.model == FlowModel::Coupled) {
            self.read_fluid(&mut r, &flow, apply)?;
        }
        if r.at != bytes.len() {
            return Err(r.fail(CheckpointFault::Trailing));
        }
        if apply {
            self.nbrs.stale = true;
            self.flow_epoch = head.flow_epoch;
            self.step = head.step;
            self.redraw = head.redraw;
            self.bed_level = bed_level;
            if self.fluid.on {
                self.refresh_coupling();
            }
        }
        Ok(())
    }

    /// Reads the fluid section of a coupled checkpoint (`flow`, validated,
    /// fits `C`): each fluid cell's u_f, φ, carried force and summed drag;
    /// applies it (after the flow was started by `set_flow`) only if `apply`.
    fn read_fluid(
        &mut self,
        r: &mut Reader<'_>,
        flow: &FlowConfig,
        apply: bool,
    ) -> Result<(), Error> {
        let fluid_cells = flow.fluid.cells.min(C);
        let mut u = [R::ZERO; C];
        let mut phi = [R::ZERO; C];
        let mut carried = [R::ZERO; C];
        let mut drag = [R::ZERO; C];
        for j in 0..fluid_cells {
            u[j] = r.real::<R>()?;
            phi[j] = r.real::<R>()?;
            carried[j] = r.real::<R>()?;
            drag[j] = r.real::<R>()?;
            if !(phi[j] >= R::ZERO && phi[j] < R::ONE) {
                return Err(r.fail(CheckpointFault::Value));
            }
        }
        if apply {
            let fluid = &mut self.fluid;
            fluid
                .column
                .set_state(&u[..fluid_cells], &phi[..fluid_cells])?;
            (fluid.carried, fluid.drag_sum) = (carried, drag);
        }
        Ok(())
    }
}
