//! Figures, each drawn once and saved as PNG and SVG: q* against τ* with the
//! reference relations, y_gc(t) of a packing run, and the bed itself.

use crate::error::HostError;
use crate::experiment::TransportRow;
use crate::output::{write_atomic_with, write_text};
use crate::references::Reference;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// The embedded font (DejaVu Sans, see `assets/DejaVuSans-LICENSE.txt`):
/// the PNG backend needs one and a fresh machine may have none.
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The embedded font is a valid TrueType file (test `figures_render`).
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// A figure that can be drawn on any plotters backend.
pub trait Figure {
    /// Size in pixels.
    fn size(&self) -> (u32, u32);
    /// Draws the figure.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// Saves `figure` as `stem.png` and `stem.svg`, each atomically.
pub fn save(figure: &impl Figure, dir: &Path, stem: &str) -> Result<(), HostError> {
    register_font();
    let png = dir.join(format!("{stem}.png"));
    write_atomic_with(&png, |tmp| {
        let root = BitMapBackend::new(tmp, figure.size()).into_drawing_area();
        figure
            .draw(&root)
            .and_then(|()| root.present().map_err(|e| e.to_string()))
            .map_err(|message| HostError::Plot {
                path: png.clone(),
                message,
            })
    })?;
    let svg_path = dir.join(format!("{stem}.svg"));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, figure.size()).into_drawing_area();
        figure
            .draw(&root)
            .and_then(|()| root.present().map_err(|e| e.to_string()))
            .map_err(|message| HostError::Plot {
                path: svg_path.clone(),
                message,
            })?;
    }
    write_text(&svg_path, &svg)
}

/// A tick label with at most 3 significant digits, without float noise.
fn tick(v: &f64) -> String {
    if *v == 0.0 {
        return "0".into();
    }
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// Colour of the i-th series.
fn series_colour(i: usize) -> RGBColor {
    const COLOURS: [RGBColor; 6] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(127, 127, 127),
    ];
    COLOURS[i % COLOURS.len()]
}

/// (τ*, q*, standard error).
pub type ErrorPoint = (f64, f64, f64);

/// q* against τ* on log–log axes: simulated series with error bars and the
/// docs/model.md §10 relations as curves.
pub struct TransportFigure {
    /// Labelled simulated series.
    pub series: Vec<(String, Vec<ErrorPoint>)>,
    /// Relations drawn as curves.
    pub references: Vec<Reference>,
    /// Title.
    pub title: String,
}

impl TransportFigure {
    /// The figure of `transport.csv`: all classes together, then each class.
    pub fn of_rows(rows: &[TransportRow], class_labels: &[String], title: String) -> Self {
        let mut series = vec![(
            "mbs (mean ± standard error)".to_string(),
            rows.iter()
                .map(|r| (r.tau_star, r.q_star, r.q_star_stderr))
                .collect(),
        )];
        for (k, label) in class_labels.iter().enumerate() {
            let points = rows
                .iter()
                .filter_map(|r| r.classes.get(k).map(|&(q, e)| (r.tau_star, q, e)))
                .collect();
            series.push((format!("mbs, {label}"), points));
        }
        TransportFigure {
            series,
            references: Reference::ALL.to_vec(),
            title,
        }
    }
}

impl Figure for TransportFigure {
    fn size(&self) -> (u32, u32) {
        (900, 650)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let points = || self.series.iter().flat_map(|s| s.1.iter());
        let t_lo = points().map(|p| p.0).fold(0.03, f64::min) / 1.5;
        let t_hi = points().map(|p| p.0).fold(0.5, f64::max) * 1.5;
        let q_hi = points()
            .map(|p| p.1 + p.2)
            .filter(|q| q.is_finite())
            .fold(Reference::MeyerPeterMuller.q_star(t_hi), f64::max)
            * 2.0;
        let q_lo = 1e-4;
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(65)
            .build_cartesian_2d((t_lo..t_hi).log_scale(), (q_lo..q_hi).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("Shields number τ*")
            .y_desc("transport rate q*")
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .axis_desc_style(("sans-serif", 16))
            .draw()
            .map_err(err)?;
        let grid: Vec<f64> = (0..=200)
            .map(|k| t_lo * (t_hi / t_lo).powf(f64::from(k) / 200.0))
            .collect();
        for (i, r) in self.references.iter().enumerate() {
            let colour = series_colour(i + 1);
            let curve: Vec<(f64, f64)> = grid
                .iter()
                .map(|&t| (t, r.q_star(t)))
                .filter(|&(_, q)| q >= q_lo)
                .collect();
            chart
                .draw_series(LineSeries::new(curve, colour.stroke_width(2)))
                .map_err(err)?
                .label(r.label())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        }
        let mut hidden = 0;
        for (i, (label, points)) in self.series.iter().enumerate() {
            let colour = if i == 0 { BLACK } else { series_colour(i + 5) };
            let shown: Vec<ErrorPoint> = points
                .iter()
                .copied()
                .filter(|p| p.1.is_finite() && p.1 > q_lo)
                .collect();
            hidden += points.len() - shown.len();
            chart
                .draw_series(shown.iter().map(|&(t, q, e)| {
                    let e = if e.is_finite() { e } else { 0.0 };
                    ErrorBar::new_vertical(
                        t,
                        (q - e).max(q_lo),
                        q,
                        q + e,
                        colour.stroke_width(2),
                        8,
                    )
                }))
                .map_err(err)?;
            chart
                .draw_series(
                    shown
                        .iter()
                        .map(|&(t, q, _)| Circle::new((t, q), 5, colour.filled())),
                )
                .map_err(err)?
                .label(label.as_str())
                .legend(move |(x, y)| Circle::new((x + 10, y), 5, colour.filled()));
        }
        if hidden > 0 {
            let note =
                format!("{hidden} point(s) with q* ≤ 1e-4 or failed not drawn (see the CSV)");
            root.draw(&Text::new(note, (80, 60), ("sans-serif", 14)))
                .map_err(err)?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(err)
    }
}

/// Labelled lines y(x), optionally on logarithmic axes.
pub struct LinesFigure {
    /// (label, points) per line; an empty label draws no legend entry.
    pub series: Vec<(String, Vec<(f64, f64)>)>,
    /// Title.
    pub title: String,
    /// x-axis label.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// Logarithmic x and y axes (all values must then be > 0).
    pub log_axes: bool,
    /// A dot at every point (computed values rather than dense curves).
    pub markers: bool,
}

impl LinesFigure {
    fn draw_on<'a, DB: DrawingBackend + 'a, X, Y>(
        &self,
        mut chart: ChartContext<'a, DB, Cartesian2d<X, Y>>,
    ) -> Result<(), String>
    where
        X: Ranged<ValueType = f64> + ValueFormatter<f64>,
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        chart
            .configure_mesh()
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .axis_desc_style(("sans-serif", 16))
            .draw()
            .map_err(err)?;
        let mut labelled = false;
        for (i, (label, points)) in self.series.iter().enumerate() {
            let colour = series_colour(i);
            let drawn = chart
                .draw_series(LineSeries::new(
                    points.iter().copied(),
                    colour.stroke_width(2),
                ))
                .map_err(err)?;
            if !label.is_empty() {
                labelled = true;
                drawn
                    .label(label.as_str())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
            }
            if self.markers {
                chart
                    .draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                    .map_err(err)?;
            }
        }
        if labelled {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .draw()
                .map_err(err)?;
        }
        Ok(())
    }
}

impl Figure for LinesFigure {
    fn size(&self) -> (u32, u32) {
        (900, 550)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let all = || {
            self.series
                .iter()
                .flat_map(|s| s.1.iter())
                .filter(|p| p.0.is_finite() && p.1.is_finite())
        };
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in all() {
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
        if x0 > x1 {
            (x0, x1, y0, y1) = (1.0, 2.0, 1.0, 2.0);
        }
        let mut builder = ChartBuilder::on(root);
        builder
            .caption(&self.title, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70);
        if self.log_axes {
            let chart = builder
                .build_cartesian_2d(
                    (x0 / 1.2..x1 * 1.2).log_scale(),
                    (y0 / 1.5..y1 * 1.5).log_scale(),
                )
                .map_err(err)?;
            self.draw_on(chart)
        } else {
            let pad = ((y1 - y0) * 0.05).max(1e-12);
            let chart = builder
                .build_cartesian_2d(x0..x1.max(x0 + 1e-12), (y0 - pad)..(y1 + pad))
                .map_err(err)?;
            self.draw_on(chart)
        }
    }
}

/// One grain of a bed picture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disc {
    /// Centre x (m).
    pub x: f64,
    /// Centre y (m).
    pub y: f64,
    /// Diameter (m).
    pub diameter: f64,
    /// Speed (m/s).
    pub speed: f64,
    /// Fixed grain.
    pub fixed: bool,
}

/// The bed drawn to scale: fixed grains shaded grey, mobile grains coloured
/// by speed (blue slow → red fast).
pub struct BedFigure<'a> {
    /// Grains.
    pub discs: &'a [Disc],
    /// Periodic width (m).
    pub width: f64,
    /// Title.
    pub title: String,
}

impl BedFigure<'_> {
    fn extent(&self) -> (f64, f64) {
        let lo = self
            .discs
            .iter()
            .map(|d| d.y - d.diameter)
            .fold(f64::MAX, f64::min);
        let hi = self
            .discs
            .iter()
            .map(|d| d.y + d.diameter)
            .fold(f64::MIN, f64::max);
        if lo < hi {
            (lo, hi)
        } else {
            (0.0, 1e-3)
        }
    }

    fn max_speed(&self) -> f64 {
        self.discs
            .iter()
            .filter(|d| !d.fixed)
            .map(|d| d.speed)
            .fold(0.0, f64::max)
    }
}

impl Figure for BedFigure<'_> {
    fn size(&self) -> (u32, u32) {
        let (lo, hi) = self.extent();
        let aspect = ((hi - lo) / self.width.max(1e-12)).clamp(0.1, 4.0);
        (1000, (180.0 + 900.0 * aspect) as u32)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let (lo, hi) = self.extent();
        let v_max = self.max_speed();
        let title = format!(
            "{} — colour: speed, blue 0 → red {v_max:.3} m/s; grey: fixed",
            self.title
        );
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 18))
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..self.width * 1e3, lo * 1e3..hi * 1e3)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x (mm)")
            .y_desc("y (mm)")
            .draw()
            .map_err(err)?;
        let scale = {
            let a = chart.backend_coord(&(0.0, lo * 1e3));
            let b = chart.backend_coord(&(self.width * 1e3, lo * 1e3));
            f64::from(b.0 - a.0) / (self.width * 1e3)
        };
        for d in self.discs {
            let radius = (0.5 * d.diameter * 1e3 * scale).round().max(1.0) as u32;
            let fill: RGBColor = if d.fixed {
                RGBColor(150, 150, 150)
            } else {
                let f = if v_max > 0.0 { d.speed / v_max } else { 0.0 };
                let c = HSLColor(0.66 * (1.0 - f), 0.85, 0.5).to_rgba();
                RGBColor(c.0, c.1, c.2)
            };
            // Periodic images at the seam, so grains cut by it show on both sides.
            for shift in [-self.width, 0.0, self.width] {
                let x = (d.x + shift) * 1e3;
                if x + d.diameter * 1e3 < 0.0 || x - d.diameter * 1e3 > self.width * 1e3 {
                    continue;
                }
                chart
                    .draw_series([
                        Circle::new((x, d.y * 1e3), radius, fill.filled()),
                        Circle::new((x, d.y * 1e3), radius, BLACK.stroke_width(1)),
                    ])
                    .map_err(err)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_render() {
        let dir = tempfile::tempdir().unwrap();
        let rows = vec![TransportRow {
            tau_star: 0.2,
            q_star: 0.3,
            q_star_stderr: 0.05,
            seeds: 2,
            mpm: 0.48,
            wong_parker: 0.23,
            classes: vec![],
        }];
        let fig = TransportFigure::of_rows(&rows, &[], "test".into());
        save(&fig, dir.path(), "transport").unwrap();
        let png = std::fs::read(dir.path().join("transport.png")).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let svg = std::fs::read_to_string(dir.path().join("transport.svg")).unwrap();
        assert!(svg.contains("<svg") && svg.contains("Meyer-Peter"));
    }
}
