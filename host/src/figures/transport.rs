//! The transport figure: q* against τ* on log–log axes, the simulated
//! series as markers with error bars and the reference relations as curves.

use super::axes::{decades, draw_legend, draw_mesh, log_ticks, tick};
use super::style::{marker, open_marker, Shape, REFERENCE_COLOURS, SERIES_COLOURS, SHAPES};
use super::{err, Figure, Px};
use crate::science::references::Reference;
use plotters::coord::Shift;
use plotters::prelude::*;

/// x-axis label of transport figures: τ* defined.
pub const TAU_STAR_AXIS: &str = "Shields number τ* = u*² / ((s − 1) g d)";
/// y-axis label of transport figures: q* defined (docs/model.md §8).
pub const Q_STAR_AXIS: &str = "transport rate q* = q_B / √((s − 1) g d³)";

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

/// (τ*, q*, error bar's half-height).
pub type ErrorPoint = (f64, f64, f64);

/// What a point of a series is, beyond its value.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PointFlags {
    /// A seed found no steady part: drawn open.
    pub not_steady: bool,
    /// A seed's window ended at its cap short of the target: its error bar
    /// is dashed.
    pub capped: bool,
}

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
    /// Flags of the points of the first series, in order (empty: none).
    pub flags: Vec<PointFlags>,
}

impl TransportFigure {
    /// q*(τ*) of all classes together (`all`, the mean of the seeds with
    /// its 95 % interval, `flags` per point), then of each labelled size
    /// class.
    pub fn new(
        title: String,
        all: Vec<ErrorPoint>,
        flags: Vec<PointFlags>,
        classes: Vec<(String, Vec<ErrorPoint>)>,
    ) -> Self {
        let mut series = vec![("mbs (mean, 95 % interval)".to_string(), all)];
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
            flags,
        }
    }

    /// The axes' limits: τ* over the points and a quarter beyond (over
    /// [0.03, 0.5] without points); q* in whole decades from 10⁻⁴ (lower
    /// for smaller positive values, not below 10⁻⁶) to at least 1 and twice
    /// the highest error bar.
    fn limits(&self) -> ((f64, f64), (f64, f64)) {
        let points = || {
            self.series
                .iter()
                .flat_map(|s| s.1.iter())
                .filter(|p| p.0.is_finite() && p.0 > 0.0 && p.1.is_finite())
        };
        let t_lo = points().map(|p| p.0).fold(f64::INFINITY, f64::min);
        let t_hi = points().map(|p| p.0).fold(0.0, f64::max);
        let (t_lo, t_hi) = if t_lo <= t_hi {
            (t_lo / 1.25, t_hi * 1.25)
        } else {
            (0.03, 0.5)
        };
        let q_min = points()
            .map(|p| p.1)
            .filter(|&q| q > 0.0)
            .fold(1e-4, f64::min);
        // Headroom: a factor 2 above the highest error bar.
        let q_max = points()
            .map(|p| 2.0 * (p.1 + p.2.max(0.0)))
            .filter(|q| q.is_finite())
            .fold(1.0, f64::max);
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
        let (mut failed, mut floored, mut not_steady, mut capped) = (0, 0, 0, 0);
        for (i, (label, points)) in self.series.iter().enumerate() {
            let colour = SERIES_COLOURS[i % SERIES_COLOURS.len()];
            let shape = SHAPES[i % SHAPES.len()];
            // Side by side: ±5 % in τ* per series.
            let shift = 1.05f64.powf(i as f64 - 0.5 * (n as f64 - 1.0));
            let r = px.i(5);
            let flags = |k: usize| match i {
                0 => self.flags.get(k).copied().unwrap_or_default(),
                _ => PointFlags::default(),
            };
            let finite: Vec<(ErrorPoint, PointFlags)> = points
                .iter()
                .enumerate()
                .filter(|(_, p)| p.0.is_finite() && p.1.is_finite())
                .map(|(k, &(t, q, e))| {
                    let e = if e.is_finite() { e.max(0.0) } else { 0.0 };
                    ((t * shift, q, e), flags(k))
                })
                .collect();
            failed += points.len() - finite.len();
            let (shown, low): (Vec<_>, Vec<_>) = finite.into_iter().partition(|p| p.0 .1 > q_lo);
            floored += low.len();
            not_steady += shown.iter().filter(|p| p.1.not_steady).count();
            capped += shown.iter().filter(|p| p.1.capped).count();
            chart
                .draw_series(
                    shown
                        .iter()
                        .filter(|p| !p.1.not_steady)
                        .map(|&((t, q, _), _)| marker(shape, (t, q), r, colour, px)),
                )
                .map_err(err)?
                .label(label.as_str())
                .legend(move |(x, y)| marker(shape, (x + px.i(10), y), r, colour, px));
            chart
                .draw_series(
                    shown
                        .iter()
                        .filter(|p| p.1.not_steady)
                        .map(|&((t, q, _), _)| open_marker(shape, (t, q), r, colour, px)),
                )
                .map_err(err)?;
            chart
                .draw_series(
                    low.iter()
                        .map(|&((t, ..), _)| marker(Shape::Floor, (t, q_lo), r, colour, px)),
                )
                .map_err(err)?;
            // Error bars over the markers, with caps wider than the markers.
            let bar = colour.stroke_width(px.w(1.5));
            let cap = px.i(7);
            for &((t, q, e), f) in shown.iter().filter(|p| p.0 .2 > 0.0) {
                let (lo, hi) = ((q - e).max(q_lo), (q + e).min(q_hi));
                if f.capped {
                    chart
                        .draw_series(DashedLineSeries::new(
                            [(t, lo), (t, hi)],
                            px.n(5),
                            px.n(4),
                            bar,
                        ))
                        .map_err(err)?;
                } else {
                    chart
                        .draw_series([PathElement::new(vec![(t, lo), (t, hi)], bar)])
                        .map_err(err)?;
                }
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
        let grey = RGBColor(90, 90, 90);
        if not_steady > 0 {
            chart
                .draw_series(std::iter::empty::<EmptyElement<(f64, f64), DB>>())
                .map_err(err)?
                .label("open: a seed without a steady part (not a result)")
                .legend(move |(x, y)| {
                    open_marker(Shape::Circle, (x + px.i(10), y), px.i(5), grey, px)
                });
        }
        if capped > 0 {
            let bar = grey.stroke_width(px.w(1.5));
            chart
                .draw_series(std::iter::empty::<EmptyElement<(f64, f64), DB>>())
                .map_err(err)?
                .label("dashed bar: a window capped short of its target")
                .legend(move |(x, y)| {
                    PathElement::new(
                        vec![(x + px.i(10), y - px.i(8)), (x + px.i(10), y + px.i(8))],
                        bar,
                    )
                });
        }
        if floored > 0 {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figures::svg_texts;
    use crate::figures::tests::{assert_texts, svg_of};

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
        let flags = vec![
            PointFlags::default(),
            PointFlags {
                not_steady: true,
                capped: false,
            },
            PointFlags {
                not_steady: false,
                capped: true,
            },
        ];
        let figure = TransportFigure::new("mixed".into(), all, flags, classes);
        let text = svg_texts(&svg_of(&figure, "transport"));
        assert_texts(
            &text,
            &["0.0001", "0.001", "0.01", "0.03", "0.05", "0.1", "0.2", "1"],
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
                "open: a seed without a steady part (not a result)",
                "dashed bar: a window capped short of its target",
            ],
        );
    }
}
