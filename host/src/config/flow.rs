//! Kernel specifications of the flow: `[flow]` and `[fluid]` into the
//! kernel's [`FlowSpec`] and [`FluidSpec`] (the flow given as shear
//! velocities or slopes turned into τ* first, [`flow_forms`], by the
//! kernel's [`shields_number`] and [`uniform_flow_shields_number`]), and
//! the coupled flow's column checked against the host's at each τ*.
//!
//! The file counts the flow's intervals (`flow.hold_steps`,
//! `flow.bed_level_interval`, `fluid.update_steps`) in steps of the
//! constants' time step; they are checked here as written, and only then
//! converted to the kernel's [`IntegrationSteps`]
//! ([`IntegrationSteps::from_constants_steps`], the one conversion), so an
//! error quotes the key and the value of the file.

use super::errors::need;
use super::file::{
    ChannelSection, ConfigFile, DragKey, FlowModelKey, FlowSection, FluctuationsKey, FluidSection,
};
use super::limits::{tau_star_arg, FLUID_CELLS, MAX_TAU_STAR};
use crate::error::ConfigError;
use mbs_kernel::{
    shields_number, uniform_flow_shields_number, FlowModel, FlowSpec, FluidSpec, IntegrationSteps,
    Scenario, G,
};

/// The flow given as shear velocities or slopes (docs/model.md §6), into
/// `flow.tau_star` on the largest diameter d_max:
/// τ* = u*²/((s − 1) g d_max) from `flow.u_star_m_s`, and from `flow.slope`
/// the uniform flow's bed shear τ = ρ g h S, u*² = g h S, so
/// τ* = h S/((s − 1) d_max). Only the driving shear follows the slope:
/// gravity on the grains stays vertical (small slopes). `tau_star`, if
/// also given, must be those values (the saved configuration holds both).
///
/// ```
/// let c = mbs::Config::from_toml("[flow]\nu_star_m_s = [0.03]\n")?;
/// let tau = 0.03f64 * 0.03 / (1.65 * 9.81 * 0.5e-3);
/// assert!((c.tau_stars[0] - tau).abs() < 1e-15);
/// let c = mbs::Config::from_toml("[flow]\nslope = [0.001]\ndepth = 0.05\n")?;
/// assert!((c.tau_stars[0] - 0.05 * 0.001 / (1.65 * 0.5e-3)).abs() < 1e-15);
/// assert!(mbs::Config::from_toml("[flow]\nslope = [0.001]\nu_star_m_s = [0.03]\n").is_err());
/// # Ok::<(), mbs::ConfigError>(())
/// ```
pub fn flow_forms(file: &mut ConfigFile, s: f64, d: f64) -> Result<(), ConfigError> {
    let f = &file.flow;
    let h = f.depth;
    let (key, given, tau_of): (&str, &Vec<f64>, &dyn Fn(f64) -> f64) =
        match (&f.u_star_m_s, &f.slope) {
            (None, None) => return Ok(()),
            (Some(_), Some(slope)) => return need(
                false,
                "flow.slope",
                format!("{slope:?}"),
                "not given with flow.u_star_m_s: give the flow as one of tau_star, u_star_m_s or \
                 slope",
            ),
            (Some(u), None) => ("flow.u_star_m_s", u, &|u: f64| shields_number(u, s, G, d)),
            (None, Some(slope)) => ("flow.slope", slope, &|sl: f64| {
                uniform_flow_shields_number(h, sl, s, d)
            }),
        };
    need(
        !given.is_empty() && given.len() <= 1000,
        key,
        format!("{given:?}"),
        "a list of 1 to 1000 values",
    )?;
    let mut taus = Vec::with_capacity(given.len());
    for (k, &v) in given.iter().enumerate() {
        let tau = tau_of(v);
        need(
            v.is_finite() && v > 0.0 && tau > 0.0 && tau <= MAX_TAU_STAR,
            &format!("{key}[{k}]"),
            v,
            &format!(
                "> 0 and giving tau* in (0, 5] (here tau* = {tau:e}, on d_max = {d:e} m, s = {s})"
            ),
        )?;
        taus.push(tau);
    }
    need(
        f.tau_stars == FlowSection::default().tau_stars || f.tau_stars == taus,
        "flow.tau_star",
        format!("{:?}", f.tau_stars),
        &format!("not given with {key} (or equal to its values {taus:?})"),
    )?;
    file.flow.tau_stars = taus;
    Ok(())
}

/// `[flow]` except τ* into the kernel's flow specification, its intervals
/// checked as written (steps of constants_dt) and converted to integration
/// steps (`substeps` per constants_dt); κ and ε0 are checked by the kernel
/// with the flow at each τ*.
pub(super) fn flow_spec(file: &ConfigFile, d: f64, substeps: u32) -> Result<FlowSpec, ConfigError> {
    let f = &file.flow;
    need(
        !f.tau_stars.is_empty() && f.tau_stars.len() <= 1000,
        "flow.tau_star",
        format!("{:?}", f.tau_stars),
        "a list of 1 to 1000 values",
    )?;
    for (k, &t) in f.tau_stars.iter().enumerate() {
        tau_star_arg(&format!("flow.tau_star[{k}]"), t)?;
    }
    let mut sorted = f.tau_stars.clone();
    sorted.sort_by(f64::total_cmp);
    sorted.dedup();
    need(
        sorted.len() == f.tau_stars.len(),
        "flow.tau_star",
        format!("{:?}", f.tau_stars),
        "distinct values",
    )?;
    need(
        f.depth.is_finite() && f.depth > 0.0 && f.depth <= 100.0,
        "flow.depth",
        f.depth,
        "in (0, 100] m",
    )?;
    need(
        f.kappa.is_finite() && (0.1..=1.0).contains(&f.kappa),
        "flow.kappa",
        f.kappa,
        "in [0.1, 1] (von Karman's constant of the log law (14): 0.41 in clear water, down \
         to about 0.2 measured in flows carrying sediment)",
    )?;
    need(
        f.roughness_d.is_finite() && (0.01..=100.0).contains(&f.roughness_d),
        "flow.roughness_d",
        f.roughness_d,
        "in [0.01, 100] (k_s/d of the log law (14): 1-3 for a plane bed of grains; outside, \
         the law describes no bed made of these grains)",
    )?;
    need(
        f.bed_level_span.is_finite() && (1.0..=1e6).contains(&f.bed_level_span),
        "flow.bed_level_span",
        f.bed_level_span,
        "in [1, 1e6] largest diameters",
    )?;
    for (key, steps) in [
        ("flow.hold_steps", f.hold_steps),
        ("flow.bed_level_interval", f.bed_level_interval),
    ] {
        need(
            (1..=1_000_000).contains(&steps),
            key,
            steps,
            ">= 1 (steps of constants_dt) and <= 1000000 (the paper: 100 and 10; longer \
             than any window)",
        )?;
    }
    Ok(FlowSpec {
        kappa: f.kappa,
        depth: f.depth,
        eps0: f.eps0,
        roughness: f.roughness_d * d,
        reference_diameter: d,
        turbulence: f.turbulence,
        hold_steps: IntegrationSteps::from_constants_steps(f.hold_steps, substeps),
        bed_level_interval: IntegrationSteps::from_constants_steps(f.bed_level_interval, substeps),
        bed_level_span: f.bed_level_span,
        model: f.model.kernel(),
    })
}

/// `[fluid]` and `[channel]` into the kernel's [`FluidSpec`], its update
/// interval checked as written and converted to integration steps, and the largest height
/// of the column's fluid cells (m, [`Scenario::fluid_cell_height`]); checked
/// whatever the model, so that a bad value is an error before it is used.
pub(super) fn fluid_spec(
    f: &FluidSection,
    channel: Option<&ChannelSection>,
    d: f64,
    substeps: u32,
) -> Result<(FluidSpec, f64), ConfigError> {
    need(
        f.cell_d.is_finite() && (0.01..=10.0).contains(&f.cell_d),
        "fluid.cell_d",
        f.cell_d,
        "in [0.01, 10] largest diameters (HydroForceEngine resolves a grain with 3-30 \
         cells; finer cells than 1/100 of a grain resolve nothing the drag sees)",
    )?;
    need(
        f.viscosity_m2_s.is_finite() && (1e-8..=1.0).contains(&f.viscosity_m2_s),
        "fluid.viscosity_m2_s",
        f.viscosity_m2_s,
        "in [1e-8, 1] m^2/s (water: 1.0e-6; liquid metals 1e-7, glycerol 1e-3)",
    )?;
    need(
        f.phi_max.is_finite() && f.phi_max >= 0.1 && f.phi_max < 1.0,
        "fluid.phi_max",
        f.phi_max,
        "in [0.1, 1) (the bed's solid fraction where the mixing length (C3) stops growing: \
         HydroForceEngine 0.61, Frey's beads 0.51)",
    )?;
    need(
        (1..=1_000_000).contains(&f.update_steps),
        "fluid.update_steps",
        f.update_steps,
        "in [1, 1000000] steps of constants_dt",
    )?;
    need(
        f.hindrance.is_finite() && (0.0..=10.0).contains(&f.hindrance),
        "fluid.hindrance",
        f.hindrance,
        "in [0, 10] (Richardson-Zaki: 3.1; 0: off)",
    )?;
    let (channel_width, wall_friction, grain_wall_friction, lateral_ratio) = match channel {
        Some(c) => {
            need(
                c.width_m.is_finite() && c.width_m > 0.0 && c.width_m <= 100.0,
                "channel.width_m",
                c.width_m,
                "in (0, 100] m (Frey 2014: 0.0065)",
            )?;
            // A channel narrower than a grain cannot hold one (below about
            // 0.5 d the solid fraction of a packed slab passes 1).
            need(
                c.width_m >= d,
                "channel.width_m",
                c.width_m,
                &format!(
                    ">= the largest grain diameter, {d:e} m (the grains lie between the \
                     walls; Frey 2014: 6.5 mm for 6 mm beads)"
                ),
            )?;
            need(
                c.wall_friction.is_finite() && (0.0..=10.0).contains(&c.wall_friction),
                "channel.wall_friction",
                c.wall_friction,
                "in [0, 10] (1: Blasius's smooth wall)",
            )?;
            need(
                c.grain_friction.is_finite() && (0.0..=10.0).contains(&c.grain_friction),
                "channel.grain_friction",
                c.grain_friction,
                "in [0, 10] (glass on glass: 0.4)",
            )?;
            need(
                c.lateral_ratio.is_finite() && (0.0..=10.0).contains(&c.lateral_ratio),
                "channel.lateral_ratio",
                c.lateral_ratio,
                "in [0, 10] (0: no overburden on the walls)",
            )?;
            (
                c.width_m,
                c.wall_friction,
                c.grain_friction,
                c.lateral_ratio,
            )
        }
        None => (0.0, 1.0, 0.0, 0.0),
    };
    let spec = FluidSpec {
        viscosity: f.viscosity_m2_s,
        phi_max: f.phi_max,
        update_steps: IntegrationSteps::from_constants_steps(f.update_steps, substeps),
        hindrance: f.hindrance,
        channel_width,
        wall_friction,
        grain_wall_friction,
        lateral_ratio,
        drag: f.drag.kernel(),
        fluctuations: f.fluctuations.kernel(),
    };
    Ok((spec, f.cell_d * d))
}

/// `[channel]`, `fluid.drag` and `fluid.fluctuations` act on the coupled
/// flow only (docs/model.md (C8)–(C10)): with clear water each is an error,
/// not a setting silently ignored.
pub(super) fn closures_need_coupled(file: &ConfigFile) -> Result<(), ConfigError> {
    if file.flow.model == FlowModelKey::Coupled {
        return Ok(());
    }
    let only = "absent with flow.model = \"clear-water\" (it acts on the coupled flow only)";
    if let Some(c) = &file.channel {
        need(false, "channel.width_m", c.width_m, only)?;
    }
    let f = &file.fluid;
    need(
        f.drag == DragKey::Paper,
        "fluid.drag",
        format!("{:?}", f.drag).to_lowercase(),
        only,
    )?;
    need(
        f.fluctuations == FluctuationsKey::Paper,
        "fluid.fluctuations",
        format!("{:?}", f.fluctuations).to_lowercase(),
        only,
    )
}

/// The coupled flow of `scenario` at each τ* fits the host's column and is
/// driven forward: its cells at most [`FLUID_CELLS`], and the bed slope
/// alone not a stronger flow than τ* (docs/model.md §13: the driving
/// u*²/h − g sin θ ≥ 0).
pub(super) fn coupled_flow_fits(scenario: &Scenario, tau_stars: &[f64]) -> Result<(), ConfigError> {
    if scenario.flow.model != FlowModel::Coupled {
        return Ok(());
    }
    for (k, &tau_star) in tau_stars.iter().enumerate() {
        let flow = scenario.flow(tau_star);
        let cells = flow.fluid.cells;
        need(
            cells <= FLUID_CELLS,
            "fluid.cell_d",
            scenario.fluid_cell_height / scenario.bed.max_diameter(),
            &format!(
                "large enough for at most {FLUID_CELLS} cells over the column's {:e} m \
                 (here {cells} cells; or a smaller flow.depth)",
                flow.fluid.surface - flow.fluid.bottom
            ),
        )?;
        let (s, d) = (scenario.material.s, scenario.bed.max_diameter());
        let (h, angle) = (scenario.flow.depth, scenario.slope_angle);
        let least = uniform_flow_shields_number(h, angle.sin(), s, d);
        // A slope that alone drives more than the largest τ*: no τ* could
        // be asked for, so the slope (or the depth) is what to change.
        let steepest = (MAX_TAU_STAR * (s - 1.0) * d / h).min(1.0).asin();
        need(
            least <= MAX_TAU_STAR,
            "bed.slope_rad",
            angle,
            &format!(
                "<= {steepest:.4e} rad with flow.depth = {h} m: on a steeper bed the slope alone \
                 drives the coupled flow beyond tau* = {MAX_TAU_STAR} (h sin(theta)/((s - 1) \
                 d_max) = {least:.4e}); a smaller slope or a shallower flow"
            ),
        )?;
        need(
            flow.fluid.driving >= 0.0,
            &format!("flow.tau_star[{k}]"),
            tau_star,
            &format!(
                ">= h sin(theta)/((s - 1) d_max) = {least:e}, the Shields number the bed slope \
                 bed.slope_rad = {} alone drives over flow.depth = {h} m (a uniform flow: \
                 flow.slope = [sin(theta)])",
                angle
            ),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{canonical, Config};

    /// The file's intervals count steps of constants_dt; the kernel gets
    /// them as integration steps, converted once, and the defaults are the
    /// paper's 100 and 10 steps of constants_dt whatever the substeps.
    #[test]
    fn intervals_are_converted_to_integration_steps_once() {
        let c = Config::from_toml(
            "[time]\nsubsteps = 8\n[flow]\nhold_steps = 3\nbed_level_interval = 5\n\
             [fluid]\nupdate_steps = 7\n",
        )
        .unwrap();
        let (flow, fluid) = (c.scenario.flow, c.scenario.fluid);
        assert_eq!(flow.hold_steps, IntegrationSteps(24));
        assert_eq!(flow.bed_level_interval, IntegrationSteps(40));
        assert_eq!(fluid.update_steps, IntegrationSteps(56));
        let paper = Config::from_toml("[time]\nsubsteps = 4\n").unwrap();
        assert_eq!(paper.file.flow.hold_steps, 100);
        assert_eq!(paper.scenario.flow.hold_steps, IntegrationSteps(400));
        assert_eq!(paper.file.fluid.update_steps, 10);
        assert_eq!(paper.scenario.fluid.update_steps, IntegrationSteps(40));
    }

    #[test]
    fn the_flow_may_be_given_as_shear_velocities_or_slopes() {
        let (s, d) = (1.65, 0.5e-3);
        let by_u = Config::from_toml("[flow]\nu_star_m_s = [0.02, 0.04]\n").unwrap();
        let by_tau = Config::from_toml(&format!(
            "[flow]\ntau_star = [{}, {}]\n",
            0.02f64 * 0.02 / (s * G * d),
            0.04f64 * 0.04 / (s * G * d)
        ))
        .unwrap();
        assert_eq!(by_u.tau_stars, by_tau.tau_stars);
        // The same cells whichever form gave them.
        assert_eq!(canonical(&by_u.file), canonical(&by_tau.file));
        // τ = ρ g h S on a 5 cm deep flow.
        let by_slope = Config::from_toml("[flow]\ndepth = 0.05\nslope = [0.002]\n").unwrap();
        assert_eq!(by_slope.tau_stars, [0.05 * 0.002 / (s * d)]);
        // The saved configuration (both forms) loads back to the same run.
        for c in [&by_u, &by_slope] {
            let saved = toml::to_string(&c.file).unwrap();
            assert!(saved.contains("tau_star = ["), "{saved}");
            assert_eq!(Config::from_toml(&saved).unwrap().file, c.file);
        }
        for (text, message) in [
            (
                "[flow]\nu_star_m_s = [0.03]\nslope = [0.001]",
                "flow.slope = [0.001]: must be not given with flow.u_star_m_s",
            ),
            (
                "[flow]\nu_star_m_s = [0.03]\ntau_star = [0.2]",
                "flow.tau_star = [0.2]: must be not given with flow.u_star_m_s",
            ),
            (
                "[flow]\nu_star_m_s = [0.03, -0.01]",
                "flow.u_star_m_s[1] = -0.01: must be > 0 and giving tau* in (0, 5]",
            ),
            (
                "[flow]\nslope = [0.5]",
                "flow.slope[0] = 0.5: must be > 0 and giving tau* in (0, 5] (here tau* = 1.2121",
            ),
            (
                "[flow]\nu_star_m_s = []",
                "flow.u_star_m_s = []: must be a list of 1 to 1000",
            ),
        ] {
            let e = Config::from_toml(text).unwrap_err().to_string();
            assert!(e.contains(message), "{text}: {e}");
        }
    }
}
