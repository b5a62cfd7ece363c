//! The defaults: the embedded `default.toml` and every section's default,
//! the paper's case (the kernel's `Scenario::paper()`) on a bed of
//! [`DEFAULT_COLUMNS`].

use super::file::{
    BedSection, ContactSection, DragKey, FlowModelKey, FlowSection, FluctuationsKey, FluidSection,
    FractionBasis, GrainsSection, RunSection, SettleUntil, Substeps, TargetSection, TensionRule,
    TimeSection, WindowUntil,
};
use super::Precision;
use mbs_kernel::Scenario;
use std::path::PathBuf;

/// The embedded default configuration (the paper's case), commented.
pub const DEFAULT_TOML: &str = include_str!("../../default.toml");

impl Default for TargetSection {
    fn default() -> Self {
        TargetSection {
            stderr_relative: 0.1,
            stderr_absolute: 0.0,
        }
    }
}

// The defaults are the kernel's `Scenario::paper()`; `default.toml` must
// agree with them (test `embedded_file_is_the_default`).

impl Default for GrainsSection {
    fn default() -> Self {
        let p = Scenario::paper();
        GrainsSection {
            diameter_mm: None,
            classes: None,
            fractions: FractionBasis::Volume,
            specific_gravity: p.material.s,
        }
    }
}

/// Lattice columns of the default bed: the narrowest measured whose q* does
/// not depend on the width at any τ* in [0.06, 0.5]
/// (docs/findings/bed-width.md; the paper's 5 columns move collectively, 10
/// lock near the threshold).
pub const DEFAULT_COLUMNS: u32 = 40;

impl Default for BedSection {
    fn default() -> Self {
        let b = Scenario::paper().bed;
        BedSection {
            columns: DEFAULT_COLUMNS,
            rows: b.rows,
            spacing: b.spacing,
            vacancy: b.vacancy,
            fixed_spread: b.fixed_spread,
            slope_rad: 0.0,
        }
    }
}

impl Default for ContactSection {
    fn default() -> Self {
        let p = Scenario::paper();
        ContactSection {
            alpha_m: p.rule.alpha_m,
            alpha_cn: p.rule.alpha_cn,
            beta: p.rule.beta,
            friction: p.material.mu,
            poisson: p.material.nu,
            k_n: None,
            eta_n: None,
            tension: TensionRule::Dashpot,
        }
    }
}

impl Default for TimeSection {
    fn default() -> Self {
        let p = Scenario::paper();
        TimeSection {
            constants_dt: p.rule.constants_dt,
            substeps: Substeps::Auto,
            settle_until: SettleUntil::Rest,
            settle: 3.0,
            spin_up: 0.2,
            window: 2.0,
            window_min: 1.0,
            window_until: WindowUntil::Target,
            block: 0.1,
            sample_steps: 10,
        }
    }
}

impl Default for FlowSection {
    fn default() -> Self {
        let p = Scenario::paper();
        let f = p.flow;
        FlowSection {
            tau_stars: vec![0.03, 0.06, 0.1, 0.2, 0.4],
            kappa: f.kappa,
            depth: f.depth,
            eps0: f.eps0,
            roughness_d: f.roughness / p.bed.max_diameter(),
            turbulence: f.turbulence,
            hold_steps: f.hold_steps.to_constants_steps(p.substeps),
            bed_level_interval: f.bed_level_interval.to_constants_steps(p.substeps),
            bed_level_span: f.bed_level_span,
            fluid_density: p.material.rho,
            drag_coefficient: p.material.c_d,
            added_mass: p.material.c_m,
            u_star_m_s: None,
            slope: None,
            model: FlowModelKey::ClearWater,
        }
    }
}

impl Default for FluidSection {
    fn default() -> Self {
        let p = Scenario::paper();
        let f = p.fluid;
        FluidSection {
            cell_d: p.fluid_cell_height / p.bed.max_diameter(),
            viscosity_m2_s: f.viscosity,
            phi_max: f.phi_max,
            update_steps: f.update_steps.to_constants_steps(p.substeps),
            hindrance: f.hindrance,
            drag: DragKey::Paper,
            fluctuations: FluctuationsKey::Paper,
        }
    }
}

impl Default for RunSection {
    fn default() -> Self {
        RunSection {
            seeds: vec![1, 2, 3, 4],
            precision: Precision::F64,
            output: PathBuf::from("mbs-out"),
            capacity: 4096,
            skin_d: Scenario::paper().skin,
            measured_profiles: None,
            measured_shift_d: 0.0,
            measured_label: None,
            threads_per_cell: 1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{narrow_bed_warning, Config, ConfigFile};

    /// The default scenario: the paper's case (docs/model.md §9) on
    /// [`DEFAULT_COLUMNS`].
    fn default_scenario() -> Scenario {
        let mut s = Scenario::paper();
        s.bed.columns = DEFAULT_COLUMNS;
        s
    }

    #[test]
    fn embedded_file_is_the_default() {
        let parsed: ConfigFile = toml::from_str(DEFAULT_TOML).unwrap();
        let mut expected = ConfigFile::default();
        expected.grains.diameter_mm = Some(0.5);
        assert_eq!(parsed, expected);
        let c = Config::load(None).unwrap();
        assert_eq!(c.scenario, default_scenario());
    }

    #[test]
    fn empty_file_is_the_paper_case_on_a_converged_width() {
        let c = Config::from_toml("").unwrap();
        assert_eq!(c.scenario_at(1), default_scenario());
        assert_eq!(default_scenario().bed.columns, 40);
        assert!(narrow_bed_warning(&default_scenario().bed, &default_scenario().flow).is_none());
    }
}
