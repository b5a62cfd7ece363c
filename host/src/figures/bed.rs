//! The bed figure: the grains ([`Disc`]s) drawn to scale and coloured by
//! speed, with a colour bar, the periodic edges, the mean bed level and
//! beside the bed the mean flow velocity U(y).

use super::axes::tick;
use super::{err, Figure, Px};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figures::svg_texts;
    use crate::figures::tests::{assert_texts, svg_of};

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
