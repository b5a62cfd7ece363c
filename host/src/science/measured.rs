//! A measured profile drawn over a run's `profiles.png`
//! (`run.measured_profiles`): a CSV in the format of `validation/*/*.csv`,
//! columns `z_over_d`, `solid_fraction`, `particle_velocity_m_s` and
//! optionally `fluid_velocity_m_s`, one height a line.

use crate::io::input::{read_text_bounded, Bound};
use serde::Deserialize;
use std::path::Path;

/// The longest measured profile: 1 MiB, some 20 000 heights (Frey's
/// profiles have 30-100).
const PROFILE_BOUND: Bound = Bound {
    bytes: 1 << 20,
    reason: "the largest measured profile (some 20000 heights)",
};

/// The heights a profile may give, in largest diameters (as
/// `run.measured_shift_d`).
const MAX_HEIGHT_D: f64 = 1000.0;

/// The fastest velocity a profile may give (m/s): faster than any river.
const MAX_SPEED: f64 = 100.0;

/// A measured profile, its heights shifted onto the run's y/d.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredProfile {
    /// The legend's label (the file's name).
    pub label: String,
    /// Heights over the largest diameter, shifted: z/d − `run.measured_shift_d`.
    pub y_over_d: Vec<f64>,
    /// φ.
    pub solid_fraction: Vec<f64>,
    /// u_p (m/s).
    pub grain_velocity: Vec<f64>,
    /// u_f (m/s) where the file gives it.
    pub fluid_velocity: Vec<Option<f64>>,
}

/// A line of the file (further columns are ignored).
#[derive(Deserialize)]
struct Line {
    z_over_d: f64,
    solid_fraction: f64,
    particle_velocity_m_s: f64,
    fluid_velocity_m_s: Option<f64>,
}

impl MeasuredProfile {
    /// Reads `path`, its heights drawn at z/d − `shift_d`: an error (why, as
    /// text) if it cannot be read, lacks a column, has no line or a value
    /// that is not finite.
    pub fn read(path: &Path, shift_d: f64) -> Result<MeasuredProfile, String> {
        let text = read_text_bounded(path, PROFILE_BOUND).map_err(|e| e.to_string())?;
        let mut reader = csv::Reader::from_reader(text.as_bytes());
        let mut m = MeasuredProfile {
            label: format!(
                "measured ({})",
                path.file_name()
                    .map_or(String::new(), |n| n.to_string_lossy().into_owned())
            ),
            y_over_d: Vec::new(),
            solid_fraction: Vec::new(),
            grain_velocity: Vec::new(),
            fluid_velocity: Vec::new(),
        };
        for (i, line) in reader.deserialize::<Line>().enumerate() {
            let l = line.map_err(|e| e.to_string())?;
            let speeds = [Some(l.particle_velocity_m_s), l.fluid_velocity_m_s];
            let checks = [
                (
                    "z_over_d",
                    l.z_over_d,
                    l.z_over_d.abs() <= MAX_HEIGHT_D,
                    format!("in [-{MAX_HEIGHT_D}, {MAX_HEIGHT_D}] diameters"),
                ),
                (
                    "solid_fraction",
                    l.solid_fraction,
                    (0.0..=1.0).contains(&l.solid_fraction),
                    "in [0, 1]".to_string(),
                ),
            ]
            .into_iter()
            .chain(
                speeds
                    .into_iter()
                    .zip(["particle_velocity_m_s", "fluid_velocity_m_s"])
                    .filter_map(|(u, name)| {
                        u.map(|u| {
                            (
                                name,
                                u,
                                u.abs() <= MAX_SPEED,
                                format!("in [-{MAX_SPEED}, {MAX_SPEED}] m/s"),
                            )
                        })
                    }),
            );
            for (name, value, ok, allowed) in checks {
                if !(ok && value.is_finite()) {
                    return Err(format!(
                        "line {}: {name} = {}: must be {allowed}",
                        i + 2,
                        crate::io::text::number(value)
                    ));
                }
            }
            m.y_over_d.push(l.z_over_d - shift_d);
            m.solid_fraction.push(l.solid_fraction);
            m.grain_velocity.push(l.particle_velocity_m_s);
            m.fluid_velocity.push(l.fluid_velocity_m_s);
        }
        if m.y_over_d.is_empty() {
            return Err("no line".into());
        }
        Ok(m)
    }

    /// (value, y/d) points of φ, u_p (where φ > 0, as the run's) and u_f
    /// (where given).
    pub fn points(&self) -> [Vec<(f64, f64)>; 3] {
        let y = &self.y_over_d;
        let solid = self.solid_fraction.iter().copied().zip(y.iter().copied());
        let grains = (self.grain_velocity.iter().zip(&self.solid_fraction).zip(y))
            .filter(|((_, phi), _)| **phi > 0.0)
            .map(|((&u, _), &y)| (u, y));
        let fluid = (self.fluid_velocity.iter().zip(y)).filter_map(|(u, &y)| u.map(|u| (u, y)));
        [solid.collect(), grains.collect(), fluid.collect()]
    }
}
