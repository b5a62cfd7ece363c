//! Figures, each drawn once and saved as PNG and SVG: q* against τ* with the
//! reference relations, lines y(x) (packing, calibration stages), and the
//! bed itself.
//!
//! Every figure is designed at 1× in pixels and drawn at a higher scale
//! ([`Px`]): the PNG at [`PNG_SUPERSAMPLE`]× and averaged down, so lines,
//! curves and markers are antialiased; the SVG at [`SVG_SCALE`]× in user
//! units and shown at 1× (its `viewBox`), so the integer coordinates of the
//! plotting library fall on a quarter pixel and curves are smooth when zoomed.

use crate::error::HostError;
use crate::io::output::{write_atomic_with, write_text};
use crate::science::references::Reference;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::Shift;
use plotters::element::ComposedElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use std::sync::Once;

/// The embedded font (DejaVu Sans, see `assets/DejaVuSans-LICENSE.txt`):
/// the PNG backend needs one and a fresh machine may have none.
static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// Scale at which a PNG is drawn before it is averaged down to its size.
const PNG_SUPERSAMPLE: u32 = 3;
/// Scale of an SVG's coordinates relative to its displayed size.
const SVG_SCALE: u32 = 4;

/// x-axis label of transport figures: τ* defined.
pub const TAU_STAR_AXIS: &str = "Shields number τ* = u*² / ((s − 1) g d)";
/// y-axis label of transport figures: q* defined (docs/model.md §8).
pub const Q_STAR_AXIS: &str = "transport rate q* = q_B / √((s − 1) g d³)";

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

/// A tick label with at most 3 significant digits, without float noise;
/// below 10⁻⁴ and from 10⁵ on in scientific form (`2.5e-5`).
fn tick(v: &f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        return "0".into();
    }
    let trim = |s: &str| -> String {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s.to_string()
        }
    };
    if !(1e-4..1e5).contains(&a) {
        let s = format!("{v:.2e}");
        return match s.split_once('e') {
            Some((mantissa, exponent)) => format!("{}e{exponent}", trim(mantissa)),
            None => s,
        };
    }
    let digits = (2 - a.log10().floor() as i32).max(0) as usize;
    trim(&format!("{v:.digits$}"))
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// `m`·10^`e` without float noise (3·10⁻⁵ is 3e-5, not 3.0000000000000004e-5).
fn decimal(m: f64, e: i32) -> f64 {
    format!("{m}e{e}").parse().unwrap_or(m * 10f64.powi(e))
}

/// The powers of ten at or below `lo` and at or above `hi`.
fn decades(lo: f64, hi: f64) -> (f64, f64) {
    (
        decimal(1.0, lo.log10().floor() as i32),
        decimal(1.0, hi.log10().ceil() as i32),
    )
}

/// The labelled and the light ticks of a logarithmic axis over [lo, hi]:
/// every power of ten in range is labelled; so are 2, 3, 5 times it (2 and 5
/// over three decades) on short axes, and finer values until at least four
/// labels fall in range. Light ticks at every integer multiple.
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    const STEPS: [&[f64]; 5] = [
        &[1.0],
        &[1.0, 2.0, 5.0],
        &[1.0, 2.0, 3.0, 5.0],
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
        &[1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0],
    ];
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return (Vec::new(), Vec::new());
    }
    let (e0, e1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let in_range = |v: &f64| *v >= lo * (1.0 - 1e-9) && *v <= hi * (1.0 + 1e-9);
    let values = |mantissas: &[f64]| -> Vec<f64> {
        (e0..=e1)
            .flat_map(|e| mantissas.iter().map(move |&m| decimal(m, e)))
            .filter(in_range)
            .collect()
    };
    let span = (hi / lo).log10();
    let first = if span > 3.05 {
        0
    } else if span > 2.05 {
        1
    } else {
        2
    };
    let mut labels = values(STEPS[first]);
    for step in &STEPS[first + 1..] {
        if labels.len() >= 4 {
            break;
        }
        labels = values(step);
    }
    let light = values(STEPS[3])
        .into_iter()
        .filter(|v| !labels.contains(v))
        .collect();
    (labels, light)
}

/// The grid, axes, tick labels and axis labels of a chart, sized by `px`.
fn draw_mesh<DB, X, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    px: Px,
    x_label: &str,
    y_label: &str,
) -> Result<(), String>
where
    DB: DrawingBackend,
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .bold_line_style(BLACK.mix(0.25).stroke_width(px.w(1.0)))
        .light_line_style(BLACK.mix(0.07).stroke_width(px.w(1.0)))
        .axis_style(BLACK.stroke_width(px.w(1.0)))
        .set_all_tick_mark_size(px.n(5))
        .label_style(px.font(13))
        .axis_desc_style(px.font(16))
        .draw()
        .map_err(err)
}

/// The legend box, sized by `px`.
fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    px: Px,
    position: SeriesLabelPosition,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .position(position)
        .margin(px.n(8))
        .legend_area_size(px.n(26))
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.stroke_width(px.w(1.0)))
        .label_font(px.font(13))
        .draw()
        .map_err(err)
}

/// Colours of the simulated series: black, then none of the colours of
/// [`REFERENCE_COLOURS`].
const SERIES_COLOURS: [RGBColor; 6] = [
    RGBColor(0, 0, 0),
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(23, 190, 207),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
];

/// Colours of the reference relations.
const REFERENCE_COLOURS: [RGBColor; 5] = [
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
];

/// Marker shapes, one per simulated series.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Shape {
    Circle,
    Square,
    Triangle,
    Diamond,
    /// The open downward triangle of values at or below the axis floor.
    Floor,
}

const SHAPES: [Shape; 4] = [
    Shape::Circle,
    Shape::Square,
    Shape::Triangle,
    Shape::Diamond,
];

/// A drawn marker: a filled polygon and its outline, around a point.
type Marker<C, DB> = ComposedElement<C, DB, Polygon<(i32, i32)>, PathElement<(i32, i32)>>;

/// A marker of radius `r` (device pixels) at `at`: filled in `colour` with a
/// thin dark outline, or white with a `colour` outline for [`Shape::Floor`]
/// (drawn just above `at`).
fn marker<C, DB: DrawingBackend>(
    shape: Shape,
    at: C,
    r: i32,
    colour: RGBColor,
    px: Px,
) -> Marker<C, DB> {
    let corners: Vec<(i32, i32)> = match shape {
        Shape::Circle => (0..24)
            .map(|k| {
                let a = std::f64::consts::TAU * f64::from(k) / 24.0;
                let r = f64::from(r);
                ((r * a.cos()).round() as i32, (r * a.sin()).round() as i32)
            })
            .collect(),
        Shape::Square => {
            let s = r * 7 / 8;
            vec![(-s, -s), (s, -s), (s, s), (-s, s)]
        }
        Shape::Triangle => vec![(0, -r - r / 4), (r, r * 3 / 4), (-r, r * 3 / 4)],
        Shape::Diamond => vec![(0, -r - r / 5), (r, 0), (0, r + r / 5), (-r, 0)],
        Shape::Floor => vec![(-r, -2 * r), (r, -2 * r), (0, 0)],
    };
    let (fill, line) = match shape {
        Shape::Floor => (WHITE.filled(), colour.stroke_width(px.w(1.8))),
        _ => (colour.filled(), BLACK.mix(0.8).stroke_width(px.w(0.8))),
    };
    let mut closed = corners.clone();
    closed.push(corners[0]);
    EmptyElement::at(at) + Polygon::new(corners, fill) + PathElement::new(closed, line)
}

/// τ in [lo, hi] where the increasing `f` reaches `target` (bisection).
fn solve(f: impl Fn(f64) -> f64, target: f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// The curve of `r` between the q* limits of the axes, smooth on log axes:
/// τ* − τ*c spaced logarithmically, so that steps in log q* stay small up to
/// the threshold.
fn reference_curve(
    r: Reference,
    (t_lo, t_hi): (f64, f64),
    (q_lo, q_hi): (f64, f64),
) -> Vec<(f64, f64)> {
    const POINTS: u32 = 400;
    let q = |t: f64| r.q_star(t);
    let tc = r.tau_star_c();
    let start = tc.max(t_lo);
    if q(t_hi) < q_lo || start >= t_hi {
        return Vec::new();
    }
    let a = if q(start) >= q_lo {
        start
    } else {
        solve(q, q_lo, start, t_hi)
    };
    let b = if q(t_hi) > q_hi {
        solve(q, q_hi, a, t_hi)
    } else {
        t_hi
    };
    let (ea, eb) = (a - tc, b - tc);
    (0..=POINTS)
        .map(|k| {
            let t = if ea > 0.0 {
                tc + ea * (eb / ea).powf(f64::from(k) / f64::from(POINTS))
            } else {
                a + (b - a) * f64::from(k) / f64::from(POINTS)
            };
            (t, q(t).clamp(q_lo, q_hi))
        })
        .collect()
}

/// (τ*, q*, standard error).
pub type ErrorPoint = (f64, f64, f64);

/// q* against τ* on log–log axes with every decade labelled: simulated
/// series as markers with error bars (values at or below the axis floor as
/// open triangles on it) and the docs/model.md §10 relations as curves.
pub struct TransportFigure {
    /// Labelled simulated series.
    pub series: Vec<(String, Vec<ErrorPoint>)>,
    /// Relations drawn as curves.
    pub references: Vec<Reference>,
    /// Title.
    pub title: String,
    /// x-axis label ([`TAU_STAR_AXIS`] for q*(τ*)).
    pub x_label: String,
    /// y-axis label ([`Q_STAR_AXIS`] for q*(τ*)).
    pub y_label: String,
}

impl TransportFigure {
    /// q*(τ*) of all classes together (`all`, the mean ± standard error
    /// of the seeds), then of each labelled size class.
    pub fn new(
        title: String,
        all: Vec<ErrorPoint>,
        classes: Vec<(String, Vec<ErrorPoint>)>,
    ) -> Self {
        let mut series = vec![("mbs (mean ± standard error)".to_string(), all)];
        series.extend(
            classes
                .into_iter()
                .map(|(label, points)| (format!("mbs, class {label}"), points)),
        );
        TransportFigure {
            series,
            references: Reference::ALL.to_vec(),
            title,
            x_label: TAU_STAR_AXIS.into(),
            y_label: Q_STAR_AXIS.into(),
        }
    }

    /// The axes' limits: whole decades around the points, τ* at least over
    /// [0.03, 0.5], q* from 10⁻⁴ (lower for smaller positive values, not
    /// below 10⁻⁶) to at least 1 and twice the highest error bar.
    fn limits(&self) -> ((f64, f64), (f64, f64)) {
        let points = || {
            self.series
                .iter()
                .flat_map(|s| s.1.iter())
                .filter(|p| p.0.is_finite() && p.0 > 0.0 && p.1.is_finite())
        };
        let t_lo = points().map(|p| p.0).fold(0.03, f64::min);
        let t_hi = points().map(|p| p.0).fold(0.5, f64::max);
        let q_min = points()
            .map(|p| p.1)
            .filter(|&q| q > 0.0)
            .fold(1e-4, f64::min);
        // Headroom: a factor 2 above the highest error bar.
        let q_max = points()
            .map(|p| 2.0 * (p.1 + p.2.max(0.0)))
            .filter(|q| q.is_finite())
            .fold(1.0, f64::max);
        let (t_lo, t_hi) = decades(t_lo, t_hi);
        let (q_lo, q_hi) = decades(q_min.max(1e-6), q_max);
        ((t_lo, t_hi), (q_lo, q_hi))
    }
}

impl Figure for TransportFigure {
    fn size(&self) -> (u32, u32) {
        (900, 680)
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        px: Px,
    ) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let ((t_lo, t_hi), (q_lo, q_hi)) = self.limits();
        let (t_labels, t_light) = log_ticks(t_lo, t_hi);
        let (q_labels, q_light) = log_ticks(q_lo, q_hi);
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, px.font(19))
            .margin(px.n(15))
            .x_label_area_size(px.n(50))
            .y_label_area_size(px.n(75))
            .build_cartesian_2d(
                (t_lo..t_hi)
                    .log_scale()
                    .with_key_points(t_labels)
                    .with_light_points(t_light),
                (q_lo..q_hi)
                    .log_scale()
                    .with_key_points(q_labels)
                    .with_light_points(q_light),
            )
            .map_err(err)?;
        draw_mesh(&mut chart, px, &self.x_label, &self.y_label)?;
        for (i, &r) in self.references.iter().enumerate() {
            let colour = REFERENCE_COLOURS[i % REFERENCE_COLOURS.len()];
            let style = colour.stroke_width(px.w(2.0));
            let curve = reference_curve(r, (t_lo, t_hi), (q_lo, q_hi));
            chart
                .draw_series(LineSeries::new(curve, style))
                .map_err(err)?
                .label(r.label())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + px.i(20), y)], style));
        }
        let n = self.series.len();
        let (mut failed, mut floored) = (0, 0);
        for (i, (label, points)) in self.series.iter().enumerate() {
            let colour = SERIES_COLOURS[i % SERIES_COLOURS.len()];
            let shape = SHAPES[i % SHAPES.len()];
            // Side by side: ±5 % in τ* per series.
            let shift = 1.05f64.powf(i as f64 - 0.5 * (n as f64 - 1.0));
            let r = px.i(5);
            let finite: Vec<ErrorPoint> = points
                .iter()
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .map(|&(t, q, e)| (t * shift, q, if e.is_finite() { e.max(0.0) } else { 0.0 }))
                .collect();
            failed += points.len() - finite.len();
            let (shown, low): (Vec<ErrorPoint>, Vec<ErrorPoint>) =
                finite.into_iter().partition(|p| p.1 > q_lo);
            floored += low.len();
            chart
                .draw_series(
                    shown
                        .iter()
                        .map(|&(t, q, _)| marker(shape, (t, q), r, colour, px)),
                )
                .map_err(err)?
                .label(label.as_str())
                .legend(move |(x, y)| marker(shape, (x + px.i(10), y), r, colour, px));
            chart
                .draw_series(
                    low.iter()
                        .map(|&(t, ..)| marker(Shape::Floor, (t, q_lo), r, colour, px)),
                )
                .map_err(err)?;
            // Error bars over the markers, with caps wider than the markers.
            let bar = colour.stroke_width(px.w(1.5));
            let cap = px.i(7);
            for &(t, q, e) in shown.iter().filter(|p| p.2 > 0.0) {
                let (lo, hi) = ((q - e).max(q_lo), (q + e).min(q_hi));
                chart
                    .draw_series([PathElement::new(vec![(t, lo), (t, hi)], bar)])
                    .map_err(err)?;
                let capped = [hi].into_iter().chain((q - e > q_lo).then_some(lo));
                chart
                    .draw_series(capped.map(|y| {
                        EmptyElement::at((t, y)) + PathElement::new(vec![(-cap, 0), (cap, 0)], bar)
                    }))
                    .map_err(err)?;
            }
        }
        let mut notes = Vec::new();
        if n > 1 {
            notes.push("series side by side: τ* × 1.05 per series".to_string());
        }
        if failed > 0 {
            notes.push(format!("{failed} failed point(s) not drawn (see the CSV)"));
        }
        if floored > 0 {
            let grey = RGBColor(90, 90, 90);
            chart
                .draw_series(std::iter::empty::<EmptyElement<(f64, f64), DB>>())
                .map_err(err)?
                .label(format!(
                    "q* ≤ {} (zero or negative mean): on the axis floor",
                    tick(&q_lo)
                ))
                .legend(move |(x, y)| {
                    marker(Shape::Floor, (x + px.i(10), y + px.i(5)), px.i(5), grey, px)
                });
        }
        for text in notes {
            chart
                .draw_series(std::iter::empty::<EmptyElement<(f64, f64), DB>>())
                .map_err(err)?
                .label(text);
        }
        draw_legend(&mut chart, px, SeriesLabelPosition::LowerRight)
    }
}

/// Labelled lines y(x), optionally on logarithmic axes.
pub struct LinesFigure {
    /// (label, points) per line; an empty label draws no legend entry.
    pub series: Vec<(String, Vec<(f64, f64)>)>,
    /// (label, points) drawn as markers only, after the lines.
    pub dots: Vec<(String, Vec<(f64, f64)>)>,
    /// Title.
    pub title: String,
    /// x-axis label.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// Logarithmic x and y axes (all values must then be > 0).
    pub log_axes: bool,
    /// A dot at every point of the lines (computed values rather than dense curves).
    pub markers: bool,
    /// The x values to label (empty: chosen automatically).
    pub x_ticks: Vec<f64>,
    /// Vertical lines at x with a label (a chosen value).
    pub marks: Vec<(f64, String)>,
}

impl LinesFigure {
    fn draw_on<'a, DB: DrawingBackend + 'a, X, Y>(
        &self,
        mut chart: ChartContext<'a, DB, Cartesian2d<X, Y>>,
        (y0, y1): (f64, f64),
        px: Px,
    ) -> Result<(), String>
    where
        X: Ranged<ValueType = f64> + ValueFormatter<f64>,
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        draw_mesh(&mut chart, px, &self.x_label, &self.y_label)?;
        let mut labelled = false;
        for (i, (label, points)) in self.series.iter().enumerate() {
            let colour = SERIES_COLOURS[(i + 1) % SERIES_COLOURS.len()];
            let style = colour.stroke_width(px.w(2.0));
            let drawn = chart
                .draw_series(LineSeries::new(points.iter().copied(), style))
                .map_err(err)?;
            if !label.is_empty() {
                labelled = true;
                drawn
                    .label(label.as_str())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + px.i(20), y)], style));
            }
            if self.markers {
                chart
                    .draw_series(
                        points
                            .iter()
                            .map(|&p| marker(Shape::Circle, p, px.i(4), colour, px)),
                    )
                    .map_err(err)?;
            }
        }
        for (i, (label, points)) in self.dots.iter().enumerate() {
            let colour = SERIES_COLOURS[(i + 2) % SERIES_COLOURS.len()];
            let shape = SHAPES[(i + 1) % SHAPES.len()];
            let r = px.i(4);
            let drawn = chart
                .draw_series(points.iter().map(|&p| marker(shape, p, r, colour, px)))
                .map_err(err)?;
            if !label.is_empty() {
                labelled = true;
                drawn
                    .label(label.as_str())
                    .legend(move |(x, y)| marker(shape, (x + px.i(10), y), r, colour, px));
            }
        }
        for (x, label) in &self.marks {
            let style = BLACK.stroke_width(px.w(1.5));
            chart
                .draw_series(DashedLineSeries::new(
                    [(*x, y0), (*x, y1)],
                    px.n(8),
                    px.n(5),
                    style,
                ))
                .map_err(err)?;
            chart
                .draw_series([EmptyElement::at((*x, y1))
                    + Text::new(label.clone(), (px.i(6), px.i(6)), px.font(14))])
                .map_err(err)?;
        }
        if labelled {
            draw_legend(&mut chart, px, SeriesLabelPosition::UpperRight)?;
        }
        Ok(())
    }
}

impl Figure for LinesFigure {
    fn size(&self) -> (u32, u32) {
        (900, 550)
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        px: Px,
    ) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let all = || {
            self.series
                .iter()
                .chain(&self.dots)
                .flat_map(|s| s.1.iter())
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .filter(|p| !self.log_axes || (p.0 > 0.0 && p.1 > 0.0))
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
            .caption(&self.title, px.font(19))
            .margin(px.n(15))
            .x_label_area_size(px.n(50))
            .y_label_area_size(px.n(80));
        if self.log_axes {
            let (x0, x1) = (x0 / 1.2, x1 * 1.2);
            let (y0, y1) = (y0 / 1.5, y1 * 1.5);
            let (mut x_labels, x_light) = log_ticks(x0, x1);
            if !self.x_ticks.is_empty() {
                x_labels = self.x_ticks.clone();
            }
            let (y_labels, y_light) = log_ticks(y0, y1);
            let chart = builder
                .build_cartesian_2d(
                    (x0..x1)
                        .log_scale()
                        .with_key_points(x_labels)
                        .with_light_points(x_light),
                    (y0..y1)
                        .log_scale()
                        .with_key_points(y_labels)
                        .with_light_points(y_light),
                )
                .map_err(err)?;
            self.draw_on(chart, (y0, y1), px)
        } else {
            let pad = ((y1 - y0) * 0.05).max(1e-12);
            let (y0, y1) = (y0 - pad, y1 + pad);
            let chart = builder
                .build_cartesian_2d(x0..x1.max(x0 + 1e-12), y0..y1)
                .map_err(err)?;
            self.draw_on(chart, (y0, y1), px)
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

/// The bed drawn to scale: mobile grains coloured by speed (viridis, with a
/// colour bar), fixed grains grey; the periodic edges dashed, with the
/// grains' periodic images faded beyond them; the mean bed level; and beside
/// the bed the mean flow velocity U(y).
pub struct BedFigure<'a> {
    /// Grains.
    pub discs: &'a [Disc],
    /// Periodic width (m).
    pub width: f64,
    /// Title.
    pub title: String,
    /// The mean bed level (m), once the flow has found one.
    pub bed_level: Option<f64>,
    /// The mean flow velocity: (y (m), U (m/s)) from the bed up; empty
    /// without a flow.
    pub flow_profile: Vec<(f64, f64)>,
}

/// Widths (1×) of the bed figure's flow panel and colour bar panel.
const PROFILE_PANEL: u32 = 190;
const COLOUR_BAR_PANEL: u32 = 120;
/// Width (1×) of the bed itself.
const BED_PANEL: u32 = 1000;

impl BedFigure<'_> {
    /// Lowest and highest point of the picture (m).
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

    /// The margin beyond each periodic edge (m): one largest diameter.
    fn margin(&self) -> f64 {
        self.discs.iter().map(|d| d.diameter).fold(0.0, f64::max)
    }

    fn max_speed(&self) -> f64 {
        self.discs
            .iter()
            .filter(|d| !d.fixed)
            .map(|d| d.speed)
            .fold(0.0, f64::max)
    }
}

/// A chart builder on one panel of the bed figure: the panels share the
/// vertical layout, so y maps alike in all of them.
fn panel<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    px: Px,
    y_labels: u32,
    right: u32,
) -> ChartBuilder<'a, 'b, DB> {
    let mut b = ChartBuilder::on(area);
    b.margin_top(px.n(12))
        .margin_bottom(px.n(8))
        .margin_left(px.n(8))
        .margin_right(px.n(right))
        .x_label_area_size(px.n(50))
        .y_label_area_size(px.n(y_labels));
    b
}

/// The fill of a fixed grain.
const FIXED_GREY: RGBColor = RGBColor(170, 170, 170);

impl Figure for BedFigure<'_> {
    fn size(&self) -> (u32, u32) {
        let (lo, hi) = self.extent();
        let shown = self.width + 2.0 * self.margin();
        let aspect = ((hi - lo) / shown.max(1e-12)).clamp(0.1, 4.0);
        (
            BED_PANEL + PROFILE_PANEL + COLOUR_BAR_PANEL,
            (200.0 + 900.0 * aspect) as u32,
        )
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        px: Px,
    ) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let (lo, hi) = self.extent();
        let (lo, hi) = match self.bed_level {
            Some(b) => (lo.min(b), hi.max(b)),
            None => (lo, hi),
        };
        let (y0, y1) = (lo * 1e3, hi * 1e3);
        let v_max = self.max_speed();
        let m = self.margin();
        let title = format!(
            "{}: colour = grain speed, grey = fixed grains, faded = periodic images",
            self.title
        );
        let (head, area) = root.split_vertically(px.n(34));
        let centre = (head.dim_in_pixel().0 / 2) as i32;
        head.draw(&Text::new(
            title,
            (centre, px.i(10)),
            px.font(17).pos(Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(err)?;
        let (bed, rest) = area.split_horizontally(px.n(BED_PANEL));
        let (flow, bar) = rest.split_horizontally(px.n(PROFILE_PANEL));

        // The bed.
        let mut chart = panel(&bed, px, 65, 4)
            .build_cartesian_2d(-m * 1e3..(self.width + m) * 1e3, y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x (mm)")
            .y_desc("y (mm)")
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .axis_style(BLACK.stroke_width(px.w(1.0)))
            .set_all_tick_mark_size(px.n(5))
            .label_style(px.font(13))
            .axis_desc_style(px.font(16))
            .draw()
            .map_err(err)?;
        let scale = {
            let a = chart.backend_coord(&(0.0, y0));
            let b = chart.backend_coord(&(self.width * 1e3, y0));
            f64::from(b.0 - a.0) / (self.width * 1e3)
        };
        let outline = BLACK.stroke_width(px.w(0.6));
        for d in self.discs {
            let radius = (0.5 * d.diameter * 1e3 * scale).round().max(1.0) as u32;
            let fill = if d.fixed {
                FIXED_GREY
            } else {
                let f = if v_max > 0.0 { d.speed / v_max } else { 0.0 };
                ViridisRGB::get_color(f)
            };
            for shift in [-self.width, 0.0, self.width] {
                let x = d.x + shift;
                if x + d.diameter < -m || x - d.diameter > self.width + m {
                    continue;
                }
                let image = !(0.0..self.width).contains(&x);
                let alpha = if image { 0.35 } else { 1.0 };
                let at = (x * 1e3, d.y * 1e3);
                chart
                    .draw_series([
                        Circle::new(at, radius, fill.mix(alpha).filled()),
                        Circle::new(
                            at,
                            radius,
                            outline.color.mix(alpha).stroke_width(outline.stroke_width),
                        ),
                    ])
                    .map_err(err)?;
            }
        }
        let edge = RGBColor(200, 30, 30).stroke_width(px.w(2.0));
        for x in [0.0, self.width * 1e3] {
            chart
                .draw_series(DashedLineSeries::new(
                    [(x, y0), (x, y1)],
                    px.n(9),
                    px.n(6),
                    edge,
                ))
                .map_err(err)?;
        }
        chart
            .draw_series([
                EmptyElement::at((0.0, y1))
                    + Text::new(
                        "periodic edge x = 0",
                        (px.i(5), px.i(3)),
                        px.font(13).color(&edge.color),
                    ),
                EmptyElement::at((self.width * 1e3, y1))
                    + Text::new(
                        "x = L",
                        (px.i(-45), px.i(3)),
                        px.font(13).color(&edge.color),
                    ),
            ])
            .map_err(err)?;
        let level = BLACK.stroke_width(px.w(2.0));
        if let Some(b) = self.bed_level {
            chart
                .draw_series(DashedLineSeries::new(
                    [(-m * 1e3, b * 1e3), ((self.width + m) * 1e3, b * 1e3)],
                    px.n(12),
                    px.n(6),
                    level,
                ))
                .map_err(err)?;
        }

        // The flow beside it.
        let u_max = self.flow_profile.iter().map(|p| p.1).fold(0.0, f64::max);
        let u_hi = if u_max > 0.0 { u_max * 1.1 } else { 1.0 };
        let mut chart = panel(&flow, px, 8, 8)
            .build_cartesian_2d(0.0..u_hi, y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("mean flow U (m/s)")
            .y_labels(0)
            .x_labels(3)
            .x_label_formatter(&tick)
            .bold_line_style(BLACK.mix(0.2).stroke_width(px.w(1.0)))
            .light_line_style(BLACK.mix(0.0))
            .axis_style(BLACK.stroke_width(px.w(1.0)))
            .set_all_tick_mark_size(px.n(5))
            .label_style(px.font(13))
            .axis_desc_style(px.font(16))
            .draw()
            .map_err(err)?;
        let blue = RGBColor(31, 119, 180);
        let profile: Vec<(f64, f64)> = self
            .flow_profile
            .iter()
            .filter(|p| p.0 * 1e3 >= y0 && p.0 * 1e3 <= y1)
            .map(|&(y, u)| (u, y * 1e3))
            .collect();
        if !profile.is_empty() {
            chart
                .draw_series([EmptyElement::at((0.0, y1))
                    + Text::new("U(y), (14)", (px.i(6), px.i(6)), px.font(13).color(&blue))])
                .map_err(err)?;
        }
        chart
            .draw_series(LineSeries::new(profile, blue.stroke_width(px.w(2.0))))
            .map_err(err)?;
        match self.bed_level {
            Some(b) => {
                chart
                    .draw_series(DashedLineSeries::new(
                        [(0.0, b * 1e3), (u_hi, b * 1e3)],
                        px.n(12),
                        px.n(6),
                        level,
                    ))
                    .map_err(err)?;
                chart
                    .draw_series([EmptyElement::at((0.0, b * 1e3))
                        + Text::new(
                            format!("mean bed level {} mm", tick(&(b * 1e3))),
                            (px.i(4), px.i(4)),
                            px.font(12),
                        )])
                    .map_err(err)?;
            }
            None => {
                chart
                    .draw_series([EmptyElement::at((0.0, y1))
                        + Text::new("no flow yet", (px.i(4), px.i(4)), px.font(12))])
                    .map_err(err)?;
            }
        }

        // The colour bar.
        let v_hi = if v_max > 0.0 { v_max } else { 1.0 };
        let mut chart = panel(&bar, px, 0, 8)
            .right_y_label_area_size(px.n(75))
            .build_cartesian_2d(0.0..1.0, 0.0..v_hi)
            .map_err(err)?;
        const STEPS: u32 = 128;
        chart
            .draw_series((0..STEPS).map(|k| {
                let (a, b) = (
                    f64::from(k) / f64::from(STEPS),
                    f64::from(k + 1) / f64::from(STEPS),
                );
                Rectangle::new(
                    [(0.0, a * v_hi), (1.0, b * v_hi)],
                    ViridisRGB::get_color(0.5 * (a + b)).filled(),
                )
            }))
            .map_err(err)?;
        let mut mesh = chart.configure_mesh();
        mesh.disable_mesh()
            .disable_x_axis()
            .x_labels(0)
            .y_desc("grain speed |v| (m/s)")
            .y_label_formatter(&tick)
            .axis_style(BLACK.stroke_width(px.w(1.0)))
            .set_all_tick_mark_size(px.n(5))
            .label_style(px.font(13))
            .axis_desc_style(px.font(15));
        mesh.draw().map_err(err)?;
        Ok(())
    }
}

/// Figures in panels of 900 × 260 stacked vertically, or of 400 × 560 side
/// by side.
pub struct Panels {
    /// The panels, top to bottom or left to right.
    pub panels: Vec<LinesFigure>,
    /// Side by side rather than stacked.
    pub side_by_side: bool,
}

impl Figure for Panels {
    fn size(&self) -> (u32, u32) {
        let n = self.panels.len().max(1) as u32;
        if self.side_by_side {
            (400 * n, 560)
        } else {
            (900, 260 * n)
        }
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        px: Px,
    ) -> Result<(), String> {
        let n = self.panels.len().max(1);
        let areas = if self.side_by_side {
            root.split_evenly((1, n))
        } else {
            root.split_evenly((n, 1))
        };
        for (panel, area) in self.panels.iter().zip(&areas) {
            panel.draw(area, px)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mixed bed's series (all, then two classes): zero and negative
    /// means, a failed point.
    fn mixed_series() -> (Vec<ErrorPoint>, Vec<(String, Vec<ErrorPoint>)>) {
        let taus = [0.03, 0.06, 0.1, 0.2, 0.4];
        let all = [0.0, 0.005, 0.05, 0.4, f64::NAN];
        let a = [
            (0.0, 0.0),
            (0.004, 0.001),
            (0.04, 0.003),
            (0.35, 0.03),
            (f64::NAN, f64::NAN),
        ];
        let b = [
            (-1e-5, 1e-5),
            (0.006, 0.001),
            (0.06, 0.004),
            (0.45, 0.03),
            (f64::NAN, f64::NAN),
        ];
        let points =
            |qe: &[(f64, f64)]| taus.iter().zip(qe).map(|(&t, &(q, e))| (t, q, e)).collect();
        let all: Vec<(f64, f64)> = all.iter().map(|&q| (q, 0.1 * f64::abs(q))).collect();
        (
            points(&all),
            vec![
                ("d = 1 mm".to_string(), points(&a)),
                ("d = 0.7 mm".to_string(), points(&b)),
            ],
        )
    }

    fn bed_discs() -> Vec<Disc> {
        (0..40)
            .map(|i| Disc {
                x: 0.5e-3 * f64::from(i % 10) + 0.25e-3,
                y: 0.5e-3 * f64::from(i / 10),
                diameter: 0.5e-3,
                speed: 0.01 * f64::from(i),
                fixed: i < 10,
            })
            .collect()
    }

    fn bed_figure(discs: &[Disc]) -> BedFigure<'_> {
        BedFigure {
            discs,
            width: 5e-3,
            title: "bed".into(),
            bed_level: Some(1.5e-3),
            flow_profile: (0..50)
                .map(|k| (1.4e-3 + 5e-5 * f64::from(k), 0.01 * f64::from(k)))
                .collect(),
        }
    }

    fn misfit_figure() -> LinesFigure {
        let grid: Vec<(f64, f64)> = [1.0, 1.585, 2.512, 3.981, 6.31, 10.0, 15.85, 25.12]
            .iter()
            .map(|&b: &f64| (b, (b.ln() - 1.3).powi(2) + 0.05))
            .collect();
        LinesFigure {
            x_ticks: grid.iter().map(|p| p.0).collect(),
            series: vec![("grid".into(), grid)],
            dots: vec![(
                "precise curves".into(),
                vec![(3.5, 0.06), (3.8, 0.055), (4.1, 0.07)],
            )],
            title: "misfit".into(),
            x_label: "β".into(),
            y_label: "misfit".into(),
            log_axes: true,
            markers: true,
            marks: vec![(3.8, "chosen β = 3.800".into())],
        }
    }

    fn timestep_figure() -> LinesFigure {
        LinesFigure {
            series: vec![(
                String::new(),
                vec![
                    (0.1, 8e-6),
                    (0.2, 1.1e-5),
                    (0.5, 1.6e-5),
                    (1.0, 2.2e-5),
                    (2.0, 3e-5),
                ],
            )],
            dots: Vec::new(),
            title: "constants_dt".into(),
            x_label: "d (mm)".into(),
            y_label: "constants_dt (s)".into(),
            log_axes: true,
            markers: true,
            x_ticks: Vec::new(),
            marks: Vec::new(),
        }
    }

    /// Saves `figure` into a fresh directory and returns the SVG text.
    fn svg_of(figure: &impl Figure, stem: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        save(figure, dir.path(), stem).unwrap();
        let png = std::fs::read(dir.path().join(format!("{stem}.png"))).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        std::fs::read_to_string(dir.path().join(format!("{stem}.svg"))).unwrap()
    }

    fn assert_texts(text: &[String], labels: &[&str]) {
        for label in labels {
            assert!(text.iter().any(|t| t == label), "{label}: {text:?}");
        }
    }

    #[test]
    fn figures_render() {
        let svg = svg_of(
            &TransportFigure::new("test".into(), vec![(0.2, 0.3, 0.03)], vec![]),
            "transport",
        );
        assert!(svg.starts_with(r#"<svg width="900" height="680" viewBox="0 0 3600 2720""#));
        assert!(svg.contains("Meyer-Peter"));
    }

    #[test]
    fn ticks_have_no_float_noise() {
        assert_eq!(tick(&0.30000000000000004), "0.3");
        assert_eq!(tick(&1e-4), "0.0001");
        assert_eq!(tick(&3.0000000000000004e-5), "3e-5");
        assert_eq!(tick(&1.5e-5), "1.5e-5");
        assert_eq!(tick(&10.0), "10");
        assert_eq!(tick(&0.0), "0");
    }

    #[test]
    fn log_axes_label_every_decade_and_at_least_four_values() {
        let (labels, light) = log_ticks(0.01, 1.0);
        assert_eq!(labels, [0.01, 0.02, 0.03, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0]);
        assert!(light.contains(&0.06) && light.contains(&0.04));
        let (labels, _) = log_ticks(1e-4, 10.0);
        assert_eq!(labels, [1e-4, 1e-3, 0.01, 0.1, 1.0, 10.0]);
        // Within one decade: still labelled.
        let (labels, _) = log_ticks(8e-6, 3.6e-5);
        assert!(labels.len() >= 4, "{labels:?}");
        assert!(labels.contains(&1e-5) && labels.contains(&2e-5) && labels.contains(&3e-5));
    }

    #[test]
    fn reference_curves_are_dense_up_to_their_thresholds() {
        for r in Reference::ALL {
            let curve = reference_curve(r, (0.01, 1.0), (1e-4, 10.0));
            assert!(curve.len() > 300, "{r:?}");
            // The curve starts on the floor, just above τ*c.
            assert!((curve[0].1 - 1e-4).abs() < 1e-9, "{r:?} {:?}", curve[0]);
            assert!(curve[0].0 > r.tau_star_c() && curve[0].0 < r.tau_star_c() + 0.01);
            // No step in log q* larger than a few hundredths of a decade.
            for w in curve.windows(2) {
                assert!((w[1].1 / w[0].1).log10() < 0.05, "{r:?} {w:?}");
            }
        }
    }

    #[test]
    fn transport_figure_labels_decades_thresholds_floor_and_classes() {
        let (all, classes) = mixed_series();
        let figure = TransportFigure::new("mixed".into(), all, classes);
        let text = svg_texts(&svg_of(&figure, "transport"));
        assert_texts(
            &text,
            &[
                "0.0001", "0.001", "0.01", "0.02", "0.03", "0.05", "0.1", "1",
            ],
        );
        for r in Reference::ALL {
            assert!(r.label().contains(&format!("τ*c {}", r.tau_star_c())));
            assert_texts(&text, &[&r.label()]);
        }
        assert_texts(
            &text,
            &[
                Q_STAR_AXIS,
                TAU_STAR_AXIS,
                "mbs, class d = 1 mm",
                "mbs, class d = 0.7 mm",
                "q* ≤ 0.0001 (zero or negative mean): on the axis floor",
                "3 failed point(s) not drawn (see the CSV)",
            ],
        );
    }

    #[test]
    fn lines_figure_labels_the_given_ticks_and_marks_the_chosen_value() {
        let text = svg_texts(&svg_of(&misfit_figure(), "misfit"));
        assert_texts(
            &text,
            &[
                "1",
                "1.58",
                "2.51",
                "3.98",
                "6.31",
                "10",
                "15.8",
                "25.1",
                "chosen β = 3.800",
                "precise curves",
            ],
        );
        // A narrow logarithmic y axis still has labelled ticks.
        let text = svg_texts(&svg_of(&timestep_figure(), "dt"));
        assert_texts(&text, &["1e-5", "2e-5", "3e-5", "0.1", "1", "2"]);
    }

    #[test]
    fn bed_figure_has_a_colour_bar_the_bed_level_the_flow_and_the_edges() {
        let discs = bed_discs();
        let text = svg_texts(&svg_of(&bed_figure(&discs), "snapshot"));
        assert_texts(
            &text,
            &[
                "grain speed |v| (m/s)",
                "mean flow U (m/s)",
                "mean bed level 1.5 mm",
                "U(y), (14)",
                "periodic edge x = 0",
                "x = L",
            ],
        );
    }
}
