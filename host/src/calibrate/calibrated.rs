//! What a calibration found, as a configuration `mbs run` reads as it is:
//! `DIR/calibrated.toml` (the base configuration with the fitted contact
//! constants, every key written out) and the lines `mbs calibrate` prints
//! at the end.

use super::stages::{beta::BetaStage, timestep::TimestepStage};
use crate::config::ConfigFile;
use crate::error::HostError;
use crate::io::output::write_text;
use crate::science::references::Reference;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The calibrated constants and how well they fit.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibrated {
    /// α_m (stage 1).
    pub alpha_m: f64,
    /// α_cn (stage 2).
    pub alpha_cn: f64,
    /// β (stage 3).
    pub beta: f64,
    /// The relation fitted to.
    pub reference: Reference,
    /// Worst factor between q* and the reference over the fitted τ*.
    pub worst_factor: f64,
    /// Stage 4's constants_dt (s) by (diameter (mm), layers), if it ran.
    pub constants_dt: Vec<(f64, u32, f64)>,
    /// Where `calibrated.toml` was written.
    pub path: PathBuf,
}

impl std::fmt::Display for Calibrated {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "calibrated: alpha_m = {}, alpha_cn = {}, beta = {} (q* within a factor {:.2} of {})",
            self.alpha_m,
            self.alpha_cn,
            self.beta,
            self.worst_factor,
            self.reference.name()
        )?;
        for (d, layers, dt) in &self.constants_dt {
            writeln!(
                f,
                "  d = {d} mm, {layers} layers: constants_dt = {dt:.3e} s"
            )?;
        }
        write!(
            f,
            "wrote {} (run it with `mbs run {}`)",
            self.path.display(),
            self.path.display()
        )
    }
}

/// Writes `dir/calibrated.toml`: `file` (the base configuration the
/// stages used, with stage 3's constants) with a header saying where each
/// value comes from.
pub fn write(
    dir: &Path,
    file: &ConfigFile,
    beta: &BetaStage,
    timestep: Option<&TimestepStage>,
    reference: Reference,
) -> Result<Calibrated, HostError> {
    let path = dir.join("calibrated.toml");
    let calibrated = Calibrated {
        alpha_m: beta.alpha_m,
        alpha_cn: beta.alpha_cn,
        beta: beta.beta,
        reference,
        worst_factor: beta.worst_factor,
        constants_dt: timestep.map_or_else(Vec::new, |t| {
            t.rows
                .iter()
                .map(|r| (r.diameter_mm, r.layers, r.constants_dt))
                .collect()
        }),
        path: path.clone(),
    };
    let mut text = String::from("# Written by `mbs calibrate` (docs/calibration.md): the base\n# configuration with the calibrated contact constants.\n");
    for line in calibrated.to_string().lines() {
        if !line.starts_with("wrote") {
            let _ = writeln!(text, "# {line}");
        }
    }
    text.push('\n');
    text.push_str(&toml::to_string(file).map_err(|e| HostError::Io {
        path: path.clone(),
        error: std::io::Error::other(e),
    })?);
    write_text(&path, &text)?;
    Ok(calibrated)
}
