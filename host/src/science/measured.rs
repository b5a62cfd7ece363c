//! A measured profile drawn over a run's `profiles.png`
//! (`run.measured_profiles`): a CSV in the format of `validation/*/*.csv`,
//! columns `z_over_d`, `solid_fraction`, `particle_velocity_m_s` and
//! optionally `fluid_velocity_m_s`, one height a line.

use serde::Deserialize;
use std::path::Path;

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
        let mut reader = csv::Reader::from_path(path).map_err(|e| e.to_string())?;
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
            let values = [l.z_over_d, l.solid_fraction, l.particle_velocity_m_s];
            if !values
                .iter()
                .chain(&l.fluid_velocity_m_s)
                .all(|v| v.is_finite())
            {
                return Err(format!("line {}: a value that is not finite", i + 2));
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
