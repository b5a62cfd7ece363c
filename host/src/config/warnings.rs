//! Warnings about a valid but questionable configuration: f32 on a wide
//! bed, a bed too narrow for width-independent q*, a long run, an explicit
//! damping number beyond the converged one.

use super::limits::GRAIN_STEPS_PER_S_PER_CORE;
use super::{Config, Precision};
use mbs_kernel::{explicit_damping_number, BedSpec, FlowSpec};

/// Explicit damping number above which q* was found to depend on the
/// integration step: a grain with four sticking contacts multiplies the
/// single-contact number by about four (docs/findings/explicit-damping-limit.md).
pub const DAMPING_NUMBER_CONVERGED: f64 = 0.5;

/// Slowest speed (m/s) a grain must reach to count as moving: an f32 bed on
/// which slower grains cannot move in x in one step gets a warning.
pub const F32_RESOLVED_SPEED: f64 = 1e-3;

/// The speed (m/s) below which an f32 grain near x = L does not move in x in
/// one integration step: half the spacing of f32 numbers at L, over step_dt.
pub fn f32_frozen_speed(width: f64, step_dt: f64) -> f64 {
    let spacing = width.log2().floor().exp2() * f64::from(f32::EPSILON);
    0.5 * spacing / step_dt
}

/// The warning for an f32 bed `width` wide integrated with `step_dt`, if
/// grains slower than [`F32_RESOLVED_SPEED`] cannot move in x.
pub fn f32_width_warning(width: f64, step_dt: f64) -> Option<String> {
    let frozen = f32_frozen_speed(width, step_dt);
    (frozen > F32_RESOLVED_SPEED).then(|| {
        format!(
            "precision f32 on a bed {width:.3} m wide: a grain slower than {frozen:.2e} m/s \
             does not move in x in one step, so the bed cannot settle or creep correctly; \
             use precision = \"f64\" or a narrower bed"
        )
    })
}

/// Width, in largest diameters, from which q* was measured not to depend on
/// the width at any τ* in [0.06, 0.5] (docs/findings/bed-width.md: 40 columns).
pub const CONVERGED_WIDTH_D: f64 = 40.0;

/// The warning for a bed too narrow for width-independent q*: narrower than
/// two bed-level spans the whole periodic bed moves collectively, and
/// narrower than [`CONVERGED_WIDTH_D`] its surface locks near the threshold.
pub fn narrow_bed_warning(bed: &BedSpec, flow: &FlowSpec) -> Option<String> {
    let d = bed.max_diameter();
    let needed = (2.0 * flow.bed_level_span).max(CONVERGED_WIDTH_D) * d;
    let width = bed.width();
    (width < needed).then(|| {
        let columns = (needed / bed.pitch()).ceil();
        format!(
            "bed {:.2} mm wide ({} columns) is narrower than {:.0} grain diameters: on narrower \
             periodic beds q* depends on the width (below two bed-level spans the whole bed \
             moves, near the threshold its surface locks); bed.columns = {columns} or more gives \
             width-independent q*",
            width * 1e3,
            bed.columns,
            needed / d,
        )
    })
}

/// Estimated wall time (s) above which `mbs run` warns.
pub const LONG_RUN_S: f64 = 86400.0;

/// The warning for a run of `config` on `cores` cores estimated to take
/// longer than [`LONG_RUN_S`]: its integration steps and grain-steps and the
/// wall time at [`GRAIN_STEPS_PER_S_PER_CORE`].
pub fn long_run_warning(config: &Config, cores: usize) -> Option<String> {
    let sc = &config.scenario;
    let grains = sc.bed.grains() as f64;
    let cells = config.tau_stars.len() * config.seeds.len();
    let steps = config.durations.cell() as f64;
    let settling = config.seeds.len() as f64 * config.durations.settle as f64;
    let grain_steps = (cells as f64 * steps + settling) * grains;
    let parallel = cores.clamp(1, cells.max(1)) as f64;
    let wall = grain_steps / (GRAIN_STEPS_PER_S_PER_CORE * parallel);
    (wall > LONG_RUN_S).then(|| {
        format!(
            "a long run: {} bed(s) settling for up to {:.3e} and {cells} cell(s) of {steps:.3e} \
             integration steps (step_dt = {:e} s) of up to {grains} grains, {grain_steps:.2e} \
             grain-steps: about {:.1} days on {parallel} core(s) at \
             ~{GRAIN_STEPS_PER_S_PER_CORE:e} grain-steps/s per core; check time.settle, \
             time.spin_up, time.window and time.constants_dt",
            config.seeds.len(),
            config.durations.settle as f64,
            sc.step_dt(),
            wall / 86400.0
        )
    })
}

/// A warning for a command that runs `steps` integration steps of a bed of
/// `grains` on one core (`mbs digest`, `mbs snapshot`) for longer than
/// [`LONG_RUN_S`]: the estimated time, so that a mistyped count is seen.
///
/// ```
/// assert!(mbs::config::long_steps_warning("mbs digest", 4000, 55).is_none());
/// let w = mbs::config::long_steps_warning("mbs digest", 100_000_000_000, 55).unwrap();
/// assert!(w.contains("2.5 days"), "{w}");
/// ```
pub fn long_steps_warning(what: &str, steps: u64, grains: usize) -> Option<String> {
    let grain_steps = steps as f64 * grains as f64;
    let wall = grain_steps / GRAIN_STEPS_PER_S_PER_CORE;
    (wall > LONG_RUN_S).then(|| {
        format!(
            "a long run: {what} runs {:.3e} integration steps of {grains} grains, about {:.1} \
             days at ~{GRAIN_STEPS_PER_S_PER_CORE:e} grain-steps/s; Ctrl-C stops it",
            steps as f64,
            wall / 86400.0
        )
    })
}

/// Warnings about a valid but questionable configuration, for runs with
/// flow (`under_flow`) or without.
pub fn warnings(config: &Config, under_flow: bool) -> Vec<String> {
    let sc = &config.scenario;
    let mut out = config.renamed_keys.clone();
    if under_flow {
        out.extend(narrow_bed_warning(&sc.bed, &sc.flow));
    }
    if config.precision == Precision::F32 {
        out.extend(f32_width_warning(sc.bed.width(), sc.step_dt()));
    }
    for class in &sc.bed.classes {
        let n =
            explicit_damping_number(&config.contact, &sc.material, class.diameter, sc.step_dt());
        if n > DAMPING_NUMBER_CONVERGED {
            let advice = (f64::from(sc.substeps) * n / DAMPING_NUMBER_CONVERGED).ceil();
            out.push(format!(
                "explicit damping number {n:.2} > {DAMPING_NUMBER_CONVERGED} for d = {} mm: \
                 results depend on the integration step (beyond 2 beds never come to rest); \
                 time.substeps = {advice} or more gives converged results",
                class.diameter * 1e3,
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    #[test]
    fn f32_on_a_wide_bed_is_warned_about() {
        let warned = |columns: u32, precision: &str| {
            let text = format!("[bed]\ncolumns = {columns}\n[run]\nprecision = \"{precision}\"\n");
            let config = Config::from_toml(&text).unwrap();
            warnings(&config, true)
                .iter()
                .any(|w| w.contains("precision f32"))
        };
        // 93 columns: 4.9 cm, f32 spacing 3.7e-9 m, frozen below 0.7 mm/s.
        assert!(!warned(93, "f32"));
        // 200 columns: 10.5 cm, frozen below 1.5 mm/s.
        assert!(warned(200, "f32"));
        assert!(!warned(200, "f64"));
        let frozen = f32_frozen_speed(0.105, 2.5e-6);
        assert!((frozen - 0.0625 * f64::from(f32::EPSILON) / 5e-6).abs() < 1e-12);
    }

    /// `flow.bed_level_window`, the old name of `flow.bed_level_span`, in a
    /// file or a `--set` (over the default, which names the new key): the
    /// same configuration, and a warning naming the new key.
    #[test]
    fn the_old_bed_level_key_is_read_and_warned_about() {
        let new = Config::from_toml("[flow]\nbed_level_span = 4.0\n").unwrap();
        let old = Config::from_toml("[flow]\nbed_level_window = 4.0\n").unwrap();
        let set = Config::load_with(None, &["flow.bed_level_window=4.0".into()]).unwrap();
        let back = Config::load_with(None, &["flow.bed_level_span=4.0".into()]).unwrap();
        let warning = "flow.bed_level_window is now flow.bed_level_span;";
        assert!(!warnings(&new, true).iter().any(|w| w.starts_with(warning)));
        assert!(!warnings(&back, true).iter().any(|w| w.starts_with(warning)));
        assert_eq!((&old.file, &old.scenario), (&new.file, &new.scenario));
        assert_eq!((&set.file, &set.scenario), (&back.file, &back.scenario));
        assert_eq!(set.scenario.flow.bed_level_span, 4.0);
        for c in [&old, &set] {
            assert!(
                warnings(c, true)[0].starts_with(warning),
                "{:?}",
                warnings(c, true)
            );
        }
    }

    #[test]
    fn a_bed_narrower_than_two_bed_level_spans_is_warned_about() {
        let warned = |columns: u32, span: f64, under_flow: bool| {
            let text = format!("[bed]\ncolumns = {columns}\n[flow]\nbed_level_span = {span}\n");
            let config = Config::from_toml(&text).unwrap();
            warnings(&config, under_flow)
                .iter()
                .any(|w| w.contains("q* depends on the width"))
        };
        // Pitch 1.05 d: 38 columns are 39.9 d, 39 are 40.95 d.
        assert!(warned(5, 5.0, true));
        assert!(!warned(5, 5.0, false), "packing has no flow");
        assert!(warned(38, 5.0, true));
        assert!(!warned(39, 5.0, true));
        // Two spans of 25 d are 50 d: 48 columns (50.4 d) suffice.
        assert!(warned(47, 25.0, true));
        assert!(!warned(48, 25.0, true));
    }
}
