//! The lines figure: labelled lines y(x), optionally on logarithmic axes,
//! with dots and marked x values (packing, calibration stages, profiles).

use super::axes::{draw_legend, draw_mesh, log_ticks};
use super::style::{marker, SERIES_COLOURS, SHAPES};
use super::{err, Figure, Px};
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::Shift;
use plotters::prelude::*;

/// Labelled lines y(x), optionally on logarithmic axes.
#[derive(Default)]
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
    /// A marker of the line's own shape at every point of the lines
    /// (computed values), or at a dozen points of a dense line.
    pub markers: bool,
    /// The x values to label (empty: chosen automatically).
    pub x_ticks: Vec<f64>,
    /// Vertical lines at x with a label (a chosen value).
    pub marks: Vec<(f64, String)>,
    /// Shaded x ranges (x0, x1), drawn under the lines; overlapping ones
    /// darker.
    pub spans: Vec<(f64, f64)>,
    /// Dashed horizontal segments (line index, x0, x1, y) in the colour of
    /// that line (its mean over a range).
    pub levels: Vec<(usize, f64, f64, f64)>,
    /// Each line's label written at its last point in its colour, instead
    /// of a legend entry (many short lines: no box over the data).
    pub end_labels: bool,
    /// The colour of each line by index (empty: each line its own).
    pub colours: Vec<usize>,
    /// The lines drawn dashed, by index.
    pub dashed: Vec<usize>,
    /// Horizontal dashed lines at y with a label (a level such as the bed's
    /// surface).
    pub y_marks: Vec<(f64, String)>,
    /// The y range (linear axes), shared by panels; `None`: the data's.
    pub y_range: Option<(f64, f64)>,
}

/// The colour of line `i` of a figure.
fn line_colour(i: usize) -> RGBColor {
    SERIES_COLOURS[(i + 1) % SERIES_COLOURS.len()]
}

impl LinesFigure {
    /// The y extent of the lines and dots (finite points only).
    pub fn y_extent(&self) -> Option<(f64, f64)> {
        self.series
            .iter()
            .chain(&self.dots)
            .flat_map(|s| s.1.iter())
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .fold(None, |r, p| match r {
                None => Some((p.1, p.1)),
                Some((a, b)) => Some((p.1.min(a), p.1.max(b))),
            })
    }
}

impl LinesFigure {
    fn draw_on<'a, DB: DrawingBackend + 'a, X, Y>(
        &self,
        mut chart: ChartContext<'a, DB, Cartesian2d<X, Y>>,
        (x0, x1): (f64, f64),
        (y0, y1): (f64, f64),
        px: Px,
    ) -> Result<(), String>
    where
        X: Ranged<ValueType = f64> + ValueFormatter<f64>,
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        draw_mesh(&mut chart, px, &self.x_label, &self.y_label)?;
        chart
            .draw_series(
                self.spans
                    .iter()
                    .map(|&(a, b)| Rectangle::new([(a, y0), (b, y1)], BLACK.mix(0.12).filled())),
            )
            .map_err(err)?;
        let mut labelled = false;
        for (i, (label, points)) in self.series.iter().enumerate() {
            let colour = line_colour(self.colours.get(i).copied().unwrap_or(i));
            let style = colour.stroke_width(px.w(2.0));
            let drawn = if self.dashed.contains(&i) {
                chart.draw_series(DashedLineSeries::new(
                    points.iter().copied(),
                    px.n(7),
                    px.n(5),
                    style,
                ))
            } else {
                chart.draw_series(LineSeries::new(points.iter().copied(), style))
            }
            .map_err(err)?;
            if self.end_labels {
                if let Some(&last) = points.last() {
                    chart
                        .draw_series([EmptyElement::at(last)
                            + Text::new(
                                label.clone(),
                                (px.i(4), -px.i(14)),
                                px.font(13).color(&colour),
                            )])
                        .map_err(err)?;
                }
            } else if !label.is_empty() {
                labelled = true;
                drawn
                    .label(label.as_str())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + px.i(20), y)], style));
            }
            if self.markers {
                // Each line its own shape; on a dense line (a settling
                // curve) a dozen of them, staggered from line to line so that they do not stack.
                let shape = SHAPES[i % SHAPES.len()];
                let (every, skip) = if points.len() > 40 {
                    let every = points.len().div_ceil(12);
                    (every, i * every / self.series.len().max(1))
                } else {
                    (1, 0)
                };
                chart
                    .draw_series(
                        points
                            .iter()
                            .skip(skip)
                            .step_by(every)
                            .map(|&p| marker(shape, p, px.i(4), colour, px)),
                    )
                    .map_err(err)?;
            }
        }
        for (i, (label, points)) in self.dots.iter().enumerate() {
            let colour = SERIES_COLOURS[(i + 2) % SERIES_COLOURS.len()];
            let shape = SHAPES[(i + 1) % SHAPES.len()];
            let r = px.i(3);
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
        for &(i, a, b, y) in &self.levels {
            let style = line_colour(i).stroke_width(px.w(2.5));
            chart
                .draw_series(DashedLineSeries::new(
                    [(a, y), (b, y)],
                    px.n(10),
                    px.n(6),
                    style,
                ))
                .map_err(err)?;
        }
        for (y, label) in &self.y_marks {
            let style = BLACK.stroke_width(px.w(1.2));
            chart
                .draw_series(DashedLineSeries::new(
                    [(x0, *y), (x1, *y)],
                    px.n(4),
                    px.n(4),
                    style,
                ))
                .map_err(err)?;
            chart
                .draw_series([EmptyElement::at((x0, *y))
                    + Text::new(label.clone(), (px.i(4), -px.i(16)), px.font(12))])
                .map_err(err)?;
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
        for &(a, b) in &self.spans {
            (x0, x1) = (x0.min(a), x1.max(b));
        }
        if self.end_labels && x1 > x0 {
            // Room for the labels after the lines' ends.
            x1 += 0.04 * (x1 - x0);
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
            self.draw_on(chart, (x0, x1), (y0, y1), px)
        } else {
            let pad = ((y1 - y0) * 0.05).max(1e-12);
            let (y0, y1) = self.y_range.unwrap_or((y0 - pad, y1 + pad));
            // A little room right and left: no line on the frame.
            let pad = ((x1 - x0) * 0.03).max(1e-12);
            let (x0, x1) = (if x0 == 0.0 { 0.0 } else { x0 - pad }, x1 + pad);
            let chart = builder
                .build_cartesian_2d(x0..x1.max(x0 + 1e-12), y0..y1)
                .map_err(err)?;
            self.draw_on(chart, (x0, x1), (y0, y1), px)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figures::svg_texts;
    use crate::figures::tests::{assert_texts, svg_of};

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
            ..LinesFigure::default()
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
            ..LinesFigure::default()
        }
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
}
