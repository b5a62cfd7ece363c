//! The profiles of a run ([`crate::work::profiles`]) as files: `profiles.csv`
//! and `profiles.png`/`.svg`, the mean over the seeds of each τ*.

use crate::config::Config;
use crate::error::HostError;
use crate::figures::{LinesFigure, Panels};
use crate::io::output::{decimal, write_csv};
use crate::io::text::number;
use crate::work::cell::CellResult;
use crate::work::profiles::{CellProfile, ProfileGrid, ProfileSums};
use serde::Serialize;
use std::path::Path;

/// A line of `profiles.csv`.
#[derive(Serialize)]
struct Line {
    #[serde(serialize_with = "decimal")]
    tau_star: f64,
    #[serde(serialize_with = "decimal")]
    y_over_d: f64,
    #[serde(serialize_with = "decimal")]
    solid_fraction: f64,
    /// Empty where no grain ever was.
    grain_velocity_m_s: Option<String>,
    #[serde(serialize_with = "decimal")]
    fluid_velocity_m_s: f64,
    #[serde(serialize_with = "decimal")]
    contact_stress_pa: f64,
    #[serde(serialize_with = "decimal")]
    kinetic_stress_pa: f64,
    #[serde(serialize_with = "decimal")]
    viscous_stress_pa: f64,
    #[serde(serialize_with = "decimal")]
    reynolds_stress_pa: f64,
}

/// The profiles of τ* `tau_star`: the mean of its seeds' (φ and u_f plain
/// means, u_p weighted by φ), or `None` if no seed has one.
fn mean_profile(results: &[CellResult], tau_star: f64) -> Option<CellProfile> {
    let cells: Vec<&CellProfile> = results
        .iter()
        .filter(|r| r.tau_star == tau_star)
        .filter_map(|r| r.profile.as_ref())
        .collect();
    let n = cells.first()?.solid_fraction.len();
    let fits = |c: &CellProfile| {
        [c.grain_velocity.len(), c.fluid_velocity.len()] == [n; 2]
            && c.solid_fraction.len() == n
            && c.stresses
                .columns()
                .iter()
                .all(|s| s.len() == n || s.is_empty())
    };
    if !cells.iter().all(|c| fits(c)) {
        return None;
    }
    // The seeds' profiles as samples of one: φ and u_f means, u_p by φ.
    let mut sums = ProfileSums::new(n);
    sums.samples = cells.len() as u64;
    for c in &cells {
        for j in 0..n {
            sums.solid[j] += c.solid_fraction[j];
            sums.momentum[j] += c.solid_fraction[j] * c.grain_velocity[j];
            sums.fluid[j] += c.fluid_velocity[j];
        }
        // Stresses of a cell store written before them count as 0.
        for (sum, seed) in sums
            .stresses
            .columns_mut()
            .into_iter()
            .zip(c.stresses.columns())
        {
            for (s, x) in sum.iter_mut().zip(seed) {
                *s += x;
            }
        }
    }
    Some(sums.means())
}

/// Writes `profiles.csv`: per τ* and fluid cell of the column, bottom up, the
/// height y/d of its centre, φ, u_p, u_f and the shear stresses (the
/// grains' by contacts and by fluctuations, the fluid's viscous and
/// Reynolds), each the mean over the seeds.
pub fn write_profiles(
    path: &Path,
    config: &Config,
    results: &[CellResult],
) -> Result<(), HostError> {
    let y = ProfileGrid::heights_d(config);
    let mut lines = Vec::new();
    for &tau_star in &config.tau_stars {
        let Some(p) = mean_profile(results, tau_star) else {
            continue;
        };
        for (j, &y_over_d) in y.iter().enumerate().take(p.solid_fraction.len()) {
            let phi = p.solid_fraction[j];
            lines.push(Line {
                tau_star,
                y_over_d,
                solid_fraction: phi,
                grain_velocity_m_s: (phi > 0.0).then(|| p.grain_velocity[j].to_string()),
                fluid_velocity_m_s: p.fluid_velocity[j],
                contact_stress_pa: p.stresses.contact[j],
                kinetic_stress_pa: p.stresses.kinetic[j],
                viscous_stress_pa: p.stresses.viscous[j],
                reynolds_stress_pa: p.stresses.reynolds[j],
            });
        }
    }
    write_csv(path, None, &lines)
}

/// A labelled line of a panel.
type Curve = (String, Vec<(f64, f64)>);

/// Heights drawn above the highest slab that ever held a grain, in d.
pub const ABOVE_BED_D: f64 = 15.0;

/// φ, u_p, u_f and the shear stresses (the grains' and the fluid's)
/// against y/d, side by side, a line per τ*: from the column's bottom to
/// [`ABOVE_BED_D`] above the highest grain; the measured profile of
/// `run.measured_profiles` as dots.
pub fn profiles_figure(config: &Config, results: &[CellResult]) -> Panels {
    let y = ProfileGrid::heights_d(config);
    let profiles: Vec<(f64, CellProfile)> = config
        .tau_stars
        .iter()
        .filter_map(|&t| mean_profile(results, t).map(|p| (t, p)))
        .collect();
    let top = profiles
        .iter()
        .filter_map(|(_, p)| p.solid_fraction.iter().rposition(|&s| s > 0.0))
        .max()
        .and_then(|j| y.get(j))
        .map_or(ABOVE_BED_D, |&t| t + ABOVE_BED_D);
    let shown = |values: &dyn Fn(&CellProfile) -> &Vec<f64>, grains_only: bool| {
        profiles
            .iter()
            .map(|(t, p)| {
                let points = (y.iter().zip(values(p)).zip(&p.solid_fraction))
                    .filter(|((yj, _), phi)| **yj <= top && (!grains_only || **phi > 0.0))
                    .map(|((&yj, &v), _)| (v, yj))
                    .collect();
                (format!("τ* = {}", tau_label(*t)), points)
            })
            .collect::<Vec<_>>()
    };
    let model = match config.file.flow.model {
        crate::config::FlowModelKey::ClearWater => "clear water",
        crate::config::FlowModelKey::Coupled => "coupled flow",
    };
    // `run.measured_profiles` as dots on each panel (u_f where it has it).
    let measured = config
        .measured
        .as_ref()
        .map(|m| (m.label.clone(), m.points()));
    let dots = |k: usize| match measured.as_ref().and_then(|(l, p)| Some((l, p.get(k)?))) {
        Some((label, points)) if !points.is_empty() => vec![(label.clone(), points.clone())],
        _ => Vec::new(),
    };
    // The bed's surface: the mean bed level of the cells (docs/model.md §6).
    let d = config.scenario.bed.max_diameter();
    let surface = (!results.is_empty())
        .then(|| results.iter().map(|r| r.bed_level).sum::<f64>() / results.len() as f64 / d);
    let panel = |series, k: usize, title: &str, x_label: &str| LinesFigure {
        series,
        dots: dots(k),
        title: title.into(),
        x_label: x_label.into(),
        y_label: "y/d".into(),
        y_marks: surface
            .filter(|s| s.is_finite())
            .map(|s| (s, format!("bed surface {s:.1} d")))
            .into_iter()
            .collect(),
        ..LinesFigure::default()
    };
    // The legend once (colours by τ*, the same in every panel), where the
    // solid fraction leaves room: above the bed, right.
    let unlabelled = |lines: Vec<Curve>| {
        lines
            .into_iter()
            .map(|(_, p)| (String::new(), p))
            .collect::<Vec<_>>()
    };
    let (stress_lines, stress_colours) = stresses(&y, top, &profiles);
    let mut panels = vec![
        panel(
            shown(&|p| &p.solid_fraction, false),
            0,
            &format!("solid fraction ({model})"),
            "φ",
        ),
        panel(
            unlabelled(shown(&|p| &p.grain_velocity, true)),
            1,
            "grain velocity",
            "u_p (m/s)",
        ),
        panel(
            unlabelled(shown(&|p| &p.fluid_velocity, false)),
            2,
            "fluid velocity",
            "u_f (m/s)",
        ),
        LinesFigure {
            dashed: (0..stress_lines.len()).filter(|i| i % 2 == 1).collect(),
            colours: stress_colours,
            ..panel(
                stress_lines,
                3,
                "shear stress: grains —, fluid - -",
                "τ (Pa)",
            )
        },
    ];
    // One y range for all: the lowest point drawn to the top.
    let low = panels
        .iter()
        .filter_map(LinesFigure::y_extent)
        .map(|e| e.0)
        .fold(f64::INFINITY, f64::min);
    let high = panels
        .iter()
        .filter_map(LinesFigure::y_extent)
        .map(|e| e.1)
        .fold(f64::NEG_INFINITY, f64::max);
    if low < high {
        let pad = 0.03 * (high - low);
        for p in &mut panels {
            p.y_range = Some((low - pad, high + pad));
        }
    }
    Panels {
        panels,
        side_by_side: true,
    }
}

/// τ* as a legend shows it: four decimals at most (a τ* from a slope is
/// long).
fn tau_label(t: f64) -> String {
    let tau = number(t);
    if tau.len() <= 6 {
        tau
    } else {
        format!("{t:.4}")
    }
}

/// The shear stresses of each τ*'s profile up to `top` (y/d): the grains'
/// (contacts and fluctuations) and the fluid's (viscous and Reynolds), a
/// line each, unlabelled (the φ panel's legend names the τ*), and each
/// line's colour: its τ*'s.
fn stresses(y: &[f64], top: f64, profiles: &[(f64, CellProfile)]) -> (Vec<Curve>, Vec<usize>) {
    let mut lines = Vec::new();
    for (_, p) in profiles {
        let s = &p.stresses;
        let at = |v: &Vec<f64>, j: usize| v.get(j).copied().unwrap_or(0.0);
        let line = |f: &dyn Fn(usize) -> f64| {
            (y.iter().enumerate())
                .filter(|(_, yj)| **yj <= top)
                .map(|(j, &yj)| (f(j), yj))
                .collect::<Vec<_>>()
        };
        let grains = line(&|j| at(&s.contact, j) + at(&s.kinetic, j));
        let fluid = line(&|j| at(&s.viscous, j) + at(&s.reynolds, j));
        lines.push((String::new(), grains));
        lines.push((String::new(), fluid));
    }
    let colours = (0..lines.len()).map(|i| i / 2).collect();
    (lines, colours)
}
