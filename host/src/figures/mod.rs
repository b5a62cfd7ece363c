//! Figures, each drawn once and saved as PNG and SVG: q* against τ* with the
//! reference relations, lines y(x) (packing, calibration stages), and the
//! bed itself.
//!
//! Every figure is designed at 1× in pixels and drawn at a higher scale
//! ([`Px`]): the PNG at `PNG_SUPERSAMPLE`× and averaged down, so lines,
//! curves and markers are antialiased; the SVG at `SVG_SCALE`× in user
//! units and shown at 1× (its `viewBox`), so the integer coordinates of the
//! plotting library fall on a quarter pixel and curves are smooth when zoomed.
//!
//! Figures take plain series (numbers and labels). The files:
//!
//! - `mod.rs`: the [`Figure`] trait, [`save`] (PNG with supersampling, SVG),
//!   [`Px`], the embedded font and [`svg_texts`];
//! - `axes.rs`: tick labels, logarithmic ticks, the grid and the legend;
//! - `style.rs`: the series' and references' colours and the marker shapes;
//! - `transport.rs`: [`TransportFigure`], q* against τ* with the reference
//!   relations;
//! - `lines.rs`: [`LinesFigure`], labelled lines y(x);
//! - `bed.rs`: [`BedFigure`] of [`Disc`]s, the bed to scale beside its flow;
//! - `panels.rs`: [`Panels`], line figures stacked or side by side.

mod axes;
mod bed;
mod lines;
mod panels;
mod style;
mod transport;

pub use bed::{BedFigure, Disc};
pub use lines::LinesFigure;
pub use panels::Panels;
pub use transport::{ErrorPoint, PointFlags, TransportFigure, Q_STAR_AXIS, TAU_STAR_AXIS};

use crate::error::HostError;
use crate::io::output::{write_atomic_with, write_text};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// The embedded font (DejaVu Sans, see `assets/DejaVuSans-LICENSE.txt`):
/// the PNG backend needs one and a fresh machine may have none.
static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// Scale at which a PNG is drawn before it is averaged down to its size.
const PNG_SUPERSAMPLE: u32 = 3;
/// Scale of an SVG's coordinates relative to its displayed size.
const SVG_SCALE: u32 = 4;

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The embedded font is a valid TrueType file (test `figures_render`).
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Pixel sizes at the scale a figure is drawn at: a figure gives every size
/// at 1× through these.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Px(pub u32);

impl Px {
    /// `v` pixels at 1×.
    pub fn n(self, v: u32) -> u32 {
        v * self.0
    }

    /// `v` pixels at 1× as a signed offset.
    pub fn i(self, v: i32) -> i32 {
        v * self.0 as i32
    }

    /// A line width of `w` pixels at 1× (at least one device pixel).
    pub fn w(self, w: f64) -> u32 {
        ((w * f64::from(self.0)).round() as u32).max(1)
    }

    /// The sans-serif font at `size` pixels at 1×.
    pub fn font(self, size: u32) -> TextStyle<'static> {
        ("sans-serif", self.n(size)).into_text_style(&(self.n(1), self.n(1)))
    }
}

/// A figure that can be drawn on any plotters backend.
pub trait Figure {
    /// Size in pixels at 1×.
    fn size(&self) -> (u32, u32);
    /// Draws the figure on `root`, of `size()` scaled by `px`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, px: Px)
        -> Result<(), String>;
}

/// The text of every `<text>` element of an SVG these figures write, in
/// order (`&amp;` as `&`): the labels, ticks and legend a reader sees.
///
/// ```
/// let svg = r#"<svg><text x="1">0.01</text><text y="2">q* &amp; τ*</text></svg>"#;
/// assert_eq!(mbs::figures::svg_texts(svg), ["0.01", "q* & τ*"]);
/// ```
pub fn svg_texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| t.split_once('>').map(|(_, rest)| rest))
        .filter_map(|t| {
            t.split_once("</text>")
                .map(|(text, _)| text.trim().replace("&amp;", "&"))
        })
        .collect()
}

/// Saves `figure` as `stem.png` and `stem.svg`, each atomically.
pub fn save(figure: &impl Figure, dir: &Path, stem: &str) -> Result<(), HostError> {
    register_font();
    let (w, h) = figure.size();
    let png = dir.join(format!("{stem}.png"));
    let fail = |path: &Path| {
        let path = path.to_path_buf();
        move |message| HostError::Plot { path, message }
    };
    let k = PNG_SUPERSAMPLE;
    let mut large = vec![0u8; (w * k * h * k * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut large, (w * k, h * k)).into_drawing_area();
        figure
            .draw(&root, Px(k))
            .and_then(|()| root.present().map_err(err))
            .map_err(fail(&png))?;
    }
    let small = downsample(&large, w, h, k);
    write_atomic_with(&png, |tmp| {
        let mut backend = BitMapBackend::new(tmp, (w, h));
        backend
            .blit_bitmap((0, 0), (w, h), &small)
            .and_then(|()| backend.present())
            .map_err(err)
            .map_err(fail(&png))
    })?;
    let svg_path = dir.join(format!("{stem}.svg"));
    let mut svg = String::new();
    {
        let size = (w * SVG_SCALE, h * SVG_SCALE);
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        figure
            .draw(&root, Px(SVG_SCALE))
            .and_then(|()| root.present().map_err(err))
            .map_err(fail(&svg_path))?;
    }
    // Shown at 1×: the viewBox keeps the scaled coordinates.
    let scaled = format!(
        "<svg width=\"{}\" height=\"{}\"",
        w * SVG_SCALE,
        h * SVG_SCALE
    );
    let svg = svg.replacen(&scaled, &format!("<svg width=\"{w}\" height=\"{h}\""), 1);
    write_text(&svg_path, &svg)
}

/// Averages `k`×`k` blocks of an RGB image of `w k` × `h k` pixels.
fn downsample(large: &[u8], w: u32, h: u32, k: u32) -> Vec<u8> {
    let (w, h, k) = (w as usize, h as usize, k as usize);
    let mut small = vec![0u8; w * h * 3];
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                let mut sum = 0u32;
                for dy in 0..k {
                    let row = (y * k + dy) * w * k;
                    for dx in 0..k {
                        sum += u32::from(large[(row + x * k + dx) * 3 + c]);
                    }
                }
                small[(y * w + x) * 3 + c] = ((sum + (k * k / 2) as u32) / (k * k) as u32) as u8;
            }
        }
    }
    small
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Saves `figure` into a fresh directory and returns the SVG text.
    pub(super) fn svg_of(figure: &impl Figure, stem: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        save(figure, dir.path(), stem).unwrap();
        let png = std::fs::read(dir.path().join(format!("{stem}.png"))).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        std::fs::read_to_string(dir.path().join(format!("{stem}.svg"))).unwrap()
    }

    pub(super) fn assert_texts(text: &[String], labels: &[&str]) {
        for label in labels {
            assert!(text.iter().any(|t| t == label), "{label}: {text:?}");
        }
    }

    #[test]
    fn figures_render() {
        let svg = svg_of(
            &TransportFigure::new("test".into(), vec![(0.2, 0.3, 0.03)], vec![], vec![]),
            "transport",
        );
        assert!(svg.starts_with(r#"<svg width="900" height="680" viewBox="0 0 3600 2720""#));
        assert!(svg.contains("Meyer-Peter"));
    }
}
