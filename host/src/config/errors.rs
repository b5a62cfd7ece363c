//! How the configuration's errors are made: a value out of range
//! ([`need`]), a kernel error under its configuration key
//! ([`ConfigError::kernel`]), toml's parse error with the new name of a
//! renamed key ([`parse_message`]). The error type itself, [`ConfigError`],
//! is `crate::error`'s.

use crate::error::ConfigError;
use crate::io::text::{excerpt, shown, QUOTE};
use std::fmt;

impl ConfigError {
    /// A kernel error under the configuration key of the parameter it names.
    pub(super) fn kernel(source: mbs_kernel::Error) -> ConfigError {
        let key = match source {
            mbs_kernel::Error::InvalidParameter { name, .. } => config_key(name),
            _ => "configuration",
        };
        ConfigError::Kernel { key, source }
    }
}

/// The configuration key of a kernel parameter: the kernel names most
/// parameters by their key already, the material's are spread over sections.
fn config_key(name: &'static str) -> &'static str {
    match name {
        "material.rho" => "flow.fluid_density",
        "material.c_d" => "flow.drag_coefficient",
        "material.c_m" => "flow.added_mass",
        "material.s" => "grains.specific_gravity",
        "material.mu" => "contact.friction",
        "material.nu" => "contact.poisson",
        "grains.fraction (sum)" => "grains.classes (sum of fractions)",
        "slope_angle" => "bed.slope_rad",
        "fluid.viscosity" => "fluid.viscosity_m2_s",
        "fluid.cells" => "fluid.cell_d",
        "fluid.density" => "flow.fluid_density",
        "fluid.kappa" => "flow.kappa",
        "fluid.driving" => "flow.tau_star",
        other => other,
    }
}

/// Keys of earlier versions of mbs and what they are now.
const RENAMED: [(&str, &str); 1] = [(
    "time.dt",
    "time.constants_dt (the constants' time step; the integration step is \
     step_dt = constants_dt/substeps)",
)];

/// toml's message, long lines quoted as excerpts; for a key that was
/// renamed, also its new name.
pub(super) fn parse_message(text: &str, e: &toml::de::Error) -> String {
    let message = excerpt(e.to_string().trim_end(), QUOTE);
    let Some(span) = e
        .span()
        .filter(|_| e.message().starts_with("unknown field"))
    else {
        return message;
    };
    let before = text.get(..span.start).unwrap_or("");
    let section = before
        .lines()
        .rev()
        .find_map(|line| line.trim().strip_prefix('[')?.split(']').next())
        .unwrap_or("");
    let key = format!("{section}.{}", text.get(span).unwrap_or("").trim());
    match RENAMED.iter().find(|(old, _)| *old == key) {
        Some((old, new)) => format!("{message}\n{old} is now {new}"),
        None => message,
    }
}

/// Fails with [`ConfigError::Invalid`] unless `ok`.
pub(crate) fn need(
    ok: bool,
    key: &str,
    value: impl fmt::Display,
    allowed: &str,
) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError::Invalid {
            key: key.to_string(),
            value: shown(value.to_string()),
            allowed: allowed.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    #[test]
    fn errors_name_key_value_and_range() {
        let cases = [
            ("[grains]\ndiameter_mm = -0.5", "grains.diameter_mm = -0.5: must be > 0"),
            ("[bed]\ncolumns = 2", "bed.columns = 2: must be in [3, 100000]"),
            ("[time]\nsubsteps = 0", "time.substeps = 0: must be in [1, 10000] or \"auto\""),
            ("[flow]\ntau_star = [0.1, -1.0]", "flow.tau_star[1] = -1: must be in (0, 5]"),
            ("[run]\ncapacity = 100", "run.capacity = 100: must be one of"),
            ("[run]\ncapacity = 256\n[bed]\ncolumns = 30", "run.capacity = 256: must be >= the bed's 330 grains"),
            ("[contact]\nalpha_m = 2.0\nbeta = 1.0\n[time]\nsubsteps = 1", "step_dt = 2e-5 s: must be <= 1.8"),
            ("[contact]\nk_n = 1.0", "contact.k_n = 1: must be given with contact.eta_n"),
            ("[contact]\nalpha_m = -1.0", "contact.alpha_m = -1: must be in [0.01, 10000]"),
            ("[contact]\nbeta = 1e308", "contact.beta = 1e308: must be in [0.01, 10000]"),
            ("[flow]\nkappa = 1e308", "flow.kappa = 1e308: must be in [0.1, 1]"),
            ("[flow]\nadded_mass = 1e308", "flow.added_mass = 1e308: must be in [0, 10]"),
            ("[flow]\ndrag_coefficient = 1e308", "flow.drag_coefficient = 1e308: must be in [0, 100]"),
            ("[flow]\nroughness_d = 1e-300", "flow.roughness_d = 1e-300: must be in [0.01, 100]"),
            ("[flow]\nmodel = \"coupled\"\n[fluid]\ncell_d = 1e-300", "fluid.cell_d = 1e-300: must be in [0.01, 10]"),
            ("[flow]\nmodel = \"coupled\"\n[fluid]\nphi_max = 1e-300", "fluid.phi_max = 1e-300: must be in [0.1, 1)"),
            ("[run]\nmeasured_shift_d = 1.7e308", "run.measured_shift_d = 1.7e308: must be in [-1000, 1000]"),
            ("[flow]\nmodel = \"coupled\"\ndepth = 0.3\n[bed]\nslope_rad = 0.45", "bed.slope_rad = 0.45: must be <= 1.3750e-2 rad"),
            ("[grains]\nclasses = [{ diameter_mm = 1.0, fraction = 0.6 }, { diameter_mm = 0.7, fraction = 0.6 }]", "grains.classes (sum of fractions) = 1.2: must be = 1"),
            ("[run]\nseeds = [1, 1]", "run.seeds = [1, 1]: must be distinct"),
            ("[flow]\ntau_star = [0.1, 0.1]", "flow.tau_star = [0.1, 0.1]: must be distinct values"),
            // Intervals in steps of constants_dt: the key and the value as written, never the
            // integration steps the kernel gets (here 8 to each step of constants_dt).
            ("[flow]\nhold_steps = 0", "flow.hold_steps = 0: must be >= 1 (steps of constants_dt)"),
            ("[time]\nsubsteps = 8\n[flow]\nbed_level_interval = 0", "flow.bed_level_interval = 0: must be >= 1 (steps of constants_dt)"),
            ("[time]\nsubsteps = 8\n[fluid]\nupdate_steps = 0", "fluid.update_steps = 0: must be in [1, 1000000] steps of constants_dt"),
            ("[time]\nsubsteps = 8\n[fluid]\nupdate_steps = 1000001", "fluid.update_steps = 1000001: must be in [1, 1000000] steps of constants_dt"),
        ];
        for (text, message) in cases {
            let e = Config::from_toml(text).unwrap_err().to_string();
            assert!(
                e.starts_with(message),
                "{text}\n  gave: {e}\n  want: {message}"
            );
        }
        let e = Config::from_toml("[time]\nsubsteps = \"fast\"")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("substeps = \"fast\"")
                && e.ends_with(
                    "invalid value: string \"fast\", expected an integer in [1, 10000] or \"auto\""
                ),
            "{e}"
        );
        // Checks the kernel makes are the kernel's: its error is kept as a value.
        let kernel_cases = [
            (
                "[flow]\nfluid_density = -1.0",
                "flow.fluid_density",
                "flow.fluid_density = -1: must be finite and > 0",
            ),
            (
                "[contact]\npoisson = 0.5",
                "contact.poisson",
                "contact.poisson = 0.5: must be in (-1, 0.5)",
            ),
            (
                "[bed]\nspacing = 3.0",
                "bed.spacing",
                "bed.spacing = 3: must be in (1, 2]",
            ),
            (
                "[flow]\neps0 = 2.0",
                "flow.eps0",
                "flow.eps0 = 2: must be in [0, 1]",
            ),
            (
                "[contact]\nk_n = -1.0\neta_n = 1e-4",
                "contact.k_n",
                "contact.k_n = -1: must be finite and > 0",
            ),
        ];
        for (text, want_key, message) in kernel_cases {
            let e = Config::from_toml(text).unwrap_err();
            assert!(
                matches!(e, ConfigError::Kernel { key, source: mbs_kernel::Error::InvalidParameter { .. } } if key == want_key),
                "{text}: {e:?}"
            );
            assert!(
                e.to_string().starts_with(message),
                "{text}\n  gave: {e}\n  want: {message}"
            );
        }
        let renamed = Config::from_toml("[time]\ndt = 2e-5")
            .unwrap_err()
            .to_string();
        assert!(
            renamed.contains("unknown field `dt`, expected one of `constants_dt`")
                && renamed.contains("time.dt is now time.constants_dt"),
            "{renamed}"
        );
        let unknown = Config::from_toml("[grains]\ndiameter = 0.5").unwrap_err();
        assert!(
            unknown.to_string().contains("unknown field `diameter`"),
            "{unknown}"
        );
    }
}
