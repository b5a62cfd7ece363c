//! Validation: a parsed [`ConfigFile`], and the files it names as already
//! read ([`Named`]), checked value by value and built into the run plan
//! [`Config`]. A pure function: it reads no file (`load.rs` reads them).

use super::errors::need;
use super::file::{ConfigFile, Substeps};
use super::flow::{closures_need_coupled, coupled_flow_fits, flow_forms, flow_spec, fluid_spec};
use super::limits::{
    capacities_listed, CAPACITIES, GRAIN_STEPS_PER_S_PER_CORE, MAX_CELL_STEPS, MAX_PHASE_S,
    PHASE_REASON,
};
use super::specs::{bed_spec, explicit_contact, material, stability, time_rule, wide_enough};
use super::{Config, Durations};
use crate::error::ConfigError;
use crate::io::text::shown;
use crate::science::measured::MeasuredProfile;
use mbs_kernel::Scenario;

/// The files a configuration names, as read by `load.rs` before validation.
#[derive(Debug, Clone, Default)]
pub(super) struct Named {
    /// `run.measured_profiles`, read with its heights unshifted (z/d), or
    /// why it could not be; `None` where no file is named.
    pub(super) measured: Option<Result<MeasuredProfile, String>>,
}

/// Checks every value of `file` and builds the typed configuration, with
/// the files it names as `named` holds them.
pub(super) fn validate(mut file: ConfigFile, named: Named) -> Result<Config, ConfigError> {
    let bed = bed_spec(&file)?;
    let d = bed.max_diameter();
    let slope_angle = file.bed.slope_rad;
    need(
        slope_angle.is_finite() && (0.0..0.5).contains(&slope_angle),
        "bed.slope_rad",
        slope_angle,
        "in [0, 0.5) rad (0: the paper's horizontal bed)",
    )?;
    let material = material(&file)?;
    flow_forms(&mut file, material.s, d)?;
    let rule = time_rule(&file, d, &material)?;
    let explicit_contact = explicit_contact(&file.contact, material.nu)?;
    let t = &file.time;
    if let Substeps::Count(n) = t.substeps {
        need(
            (1..=10_000).contains(&n),
            "time.substeps",
            n,
            "in [1, 10000] or \"auto\"",
        )?;
    }
    let mut substeps = match t.substeps {
        Substeps::Count(n) => n,
        Substeps::Auto => 1,
    };
    let mut flow = flow_spec(&file, d, substeps)?;
    let (mut fluid, fluid_cell_height) =
        fluid_spec(&file.fluid, file.channel.as_ref(), d, substeps)?;
    // A window holds at least one step; settling and spin-up may be skipped.
    for (key, value, zero_allowed) in [
        ("time.settle", t.settle, true),
        ("time.spin_up", t.spin_up, true),
        ("time.window", t.window, false),
        ("time.window_min", t.window_min, false),
        ("time.block", t.block, false),
    ] {
        let least = if zero_allowed { "[0" } else { "(0" };
        need(
            value <= MAX_PHASE_S && (value > 0.0 || (zero_allowed && value == 0.0)),
            key,
            value,
            &format!("in {least}, {MAX_PHASE_S}] s{PHASE_REASON}"),
        )?;
    }
    need(
        t.sample_steps >= 1,
        "time.sample_steps",
        t.sample_steps,
        ">= 1",
    )?;
    let r = &file.run;
    need(
        !r.seeds.is_empty() && r.seeds.len() <= 1000,
        "run.seeds",
        format!("{:?}", r.seeds),
        "a list of 1 to 1000 seeds",
    )?;
    let mut sorted = r.seeds.clone();
    sorted.sort_unstable();
    sorted.dedup();
    need(
        sorted.len() == r.seeds.len(),
        "run.seeds",
        format!("{:?}", r.seeds),
        "distinct",
    )?;
    need(
        !r.output.as_os_str().is_empty(),
        "run.output",
        "\"\"",
        "a directory path",
    )?;
    need(
        r.skin_d.is_finite() && (0.01..=1.0).contains(&r.skin_d),
        "run.skin_d",
        r.skin_d,
        "in [0.01, 1] largest diameters (a thinner skin rebuilds the neighbour lists \
         nearly every step)",
    )?;
    need(
        r.measured_shift_d.is_finite() && r.measured_shift_d.abs() <= 1000.0,
        "run.measured_shift_d",
        r.measured_shift_d,
        "in [-1000, 1000] largest diameters (a shift of the measured heights; the profiles \
         span at most a flow depth, flow.depth <= 100 m)",
    )?;
    let measured = match &r.measured_profiles {
        None => None,
        Some(path) => {
            let read = named
                .measured
                .unwrap_or_else(|| Err("not read".to_string()));
            if let Some(label) = &r.measured_label {
                need(
                    !label.is_empty()
                        && label.chars().count() <= 100
                        && !label.contains(char::is_control),
                    "run.measured_label",
                    format!("{label:?}"),
                    "1 to 100 characters on one line (a legend label)",
                )?;
            }
            Some(
                read.map(|profile| shifted(profile, r.measured_shift_d))
                    .map(|mut profile| {
                        if let Some(label) = &r.measured_label {
                            profile.label.clone_from(label);
                        }
                        profile
                    })
                    .map_err(|why| ConfigError::Invalid {
                        key: "run.measured_profiles".into(),
                        value: shown(path.display().to_string()),
                        allowed: format!(
                            "a CSV with columns z_over_d, solid_fraction, particle_velocity_m_s \
                             (and optionally fluid_velocity_m_s), as validation/*/*.csv: {why}"
                        ),
                    })?,
            )
        }
    };
    need(
        CAPACITIES.contains(&r.capacity),
        "run.capacity",
        r.capacity,
        &format!("one of {}", capacities_listed()),
    )?;
    need(
        r.threads_per_cell <= super::MAX_THREADS as u32,
        "run.threads_per_cell",
        r.threads_per_cell,
        &format!(
            "in [0, {}] (0: automatic; results do not depend on it)",
            super::MAX_THREADS
        ),
    )?;
    let grains = bed.grains();
    need(
        grains <= r.capacity,
        "run.capacity",
        r.capacity,
        &format!(">= the bed's {grains} grains (a larger capacity or a smaller bed)"),
    )?;
    // The kernel's bound (`Sim::build_bed`): the highest fixed grain (2σ),
    // the lattice and one d_max below the domain's top, 2 h + 10 d_max
    // (`Scenario::sim_config`). The lattice may reach above the free
    // surface: those grains fall into the water as the bed settles.
    let bed_top = (2.0 * bed.fixed_spread + 1.0) * d + f64::from(bed.rows) * bed.pitch();
    let least = 0.5 * (bed_top - 10.0 * d);
    need(
        flow.depth > least,
        "flow.depth",
        flow.depth,
        &format!(
            "> {least:e} m (the initial lattice, {bed_top:e} m high, must lie below the domain's top, 2 flow.depth + 10 d)"
        ),
    )?;
    let mut scenario = Scenario {
        material,
        rule,
        explicit_contact,
        tension: file.contact.tension.kernel(),
        substeps,
        bed,
        flow,
        fluid,
        fluid_cell_height,
        slope_angle,
        skin: r.skin_d,
        seed: r.seeds[0],
    };
    let contact = scenario.contact().map_err(ConfigError::kernel)?;
    if t.substeps == Substeps::Auto {
        // The constants do not depend on the substeps; the flow's intervals do.
        substeps = t.substeps.resolve(
            &contact,
            &scenario.material,
            &scenario.bed,
            scenario.rule.constants_dt,
        );
        flow = flow_spec(&file, d, substeps)?;
        (fluid, _) = fluid_spec(&file.fluid, file.channel.as_ref(), d, substeps)?;
        scenario.substeps = substeps;
        (scenario.flow, scenario.fluid) = (flow, fluid);
    }
    stability(&scenario, &contact)?;
    wide_enough(&scenario)?;
    coupled_flow_fits(&scenario, &file.flow.tau_stars)?;
    closures_need_coupled(&file)?;
    for &tau_star in &file.flow.tau_stars {
        scenario
            .flow(tau_star)
            .validate()
            .map_err(ConfigError::kernel)?;
    }
    // The simulation's own checks, as a backstop.
    scenario
        .sim_config()
        .and_then(|c| c.validate())
        .map_err(ConfigError::kernel)?;
    let step_dt = scenario.step_dt();
    let sample = u64::from(t.sample_steps);
    let block = steps_of(t.block, step_dt);
    need(
        sample <= block,
        "time.sample_steps",
        sample,
        &format!(
            "<= a block's {block} integration steps (time.block/step_dt = {} s/{step_dt:e} s): \
             a longer sampling interval would stretch the block",
            t.block
        ),
    )?;
    need(
        t.window_min <= t.window,
        "time.window_min",
        t.window_min,
        &format!("<= time.window = {} s", t.window),
    )?;
    need(
        2.0 * t.block <= t.window_min * (1.0 + 1e-9),
        "time.block",
        t.block,
        &format!(
            "<= time.window_min/2 = {} s: the standard error of the window needs at least \
             two blocks",
            t.window_min / 2.0
        ),
    )?;
    let block_samples = block / sample;
    let blocks = |seconds: f64| (seconds / t.block).round().max(2.0) as u64;
    let durations = Durations {
        settle_until: t.settle_until,
        settle: steps_of(t.settle, step_dt),
        spin_up: steps_of(t.spin_up, step_dt),
        sample,
        block_samples,
        min_blocks: blocks(t.window_min),
        max_blocks: blocks(t.window).max(blocks(t.window_min)),
        window_until: t.window_until,
    };
    let target = &file.target;
    for (key, value) in [
        ("target.stderr_relative", target.stderr_relative),
        ("target.stderr_absolute", target.stderr_absolute),
    ] {
        need(
            (0.0..=1.0).contains(&value),
            key,
            value,
            "in [0, 1] (0: the window always runs to time.window)",
        )?;
    }
    // At most 3000 s of steps of at least 1e-12 s: no overflow.
    let cell = durations.settle + durations.cell();
    need(
        cell <= MAX_CELL_STEPS,
        "time.settle + time.spin_up + time.window",
        format!(
            "{} + {} + {} s = {:e} integration steps",
            t.settle, t.spin_up, t.window, cell as f64
        ),
        &format!(
            "<= {MAX_CELL_STEPS:e} integration steps of step_dt = {step_dt:e} s per cell \
             (at ~{GRAIN_STEPS_PER_S_PER_CORE:e} grain-steps/s per core, even 100 grains \
             would take {:.0} days per cell): shorten the phases or raise step_dt",
            MAX_CELL_STEPS as f64 * 100.0 / GRAIN_STEPS_PER_S_PER_CORE / 86400.0
        ),
    )?;
    Ok(Config {
        tau_stars: file.flow.tau_stars.clone(),
        seeds: r.seeds.clone(),
        durations,
        output: r.output.clone(),
        precision: r.precision,
        capacity: r.capacity,
        measured,
        renamed_keys: Vec::new(),
        file,
        scenario,
        contact,
    })
}

/// `profile` with its heights drawn at z/d − `shift_d`.
fn shifted(mut profile: MeasuredProfile, shift_d: f64) -> MeasuredProfile {
    for y in &mut profile.y_over_d {
        *y -= shift_d;
    }
    profile
}

/// Integration steps of step_dt in `seconds` (rounded).
pub(super) fn steps_of(seconds: f64, step_dt: f64) -> u64 {
    (seconds / step_dt).round() as u64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    /// Validation reads no file: the measured profile comes as read (its
    /// heights shifted here), or why it could not be, whatever the path.
    #[test]
    fn validation_takes_the_named_files_as_read() {
        let mut file = Config::load(None).unwrap().file;
        file.run.measured_profiles = Some("/nonexistent/m.csv".into());
        file.run.measured_shift_d = 0.5;
        let profile = MeasuredProfile {
            label: "measured (m.csv)".into(),
            y_over_d: vec![1.0, 2.5],
            solid_fraction: vec![0.5, 0.0],
            grain_velocity: vec![0.0, 0.1],
            fluid_velocity: vec![None, Some(0.3)],
        };
        let read = Named {
            measured: Some(Ok(profile)),
        };
        let c = validate(file.clone(), read).unwrap();
        assert_eq!(c.measured.unwrap().y_over_d, [0.5, 2.0]);
        let failed = Named {
            measured: Some(Err("no line".into())),
        };
        let e = validate(file, failed).unwrap_err().to_string();
        assert!(
            e.starts_with("run.measured_profiles = ") && e.ends_with(": no line"),
            "{e}"
        );
    }
}
