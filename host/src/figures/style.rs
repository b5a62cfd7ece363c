//! The style shared by the figures: the colours of simulated series and of
//! reference relations, and the marker shapes drawn at their points.

use super::Px;
use plotters::element::ComposedElement;
use plotters::prelude::*;

/// Colours of the simulated series: black, then none of the colours of
/// [`REFERENCE_COLOURS`]; ten, so that a figure of up to nine lines (a
/// calibration stage's scan) gives each its own.
pub(super) const SERIES_COLOURS: [RGBColor; 10] = [
    RGBColor(0, 0, 0),
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(23, 190, 207),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(0, 0, 128),
    RGBColor(128, 0, 0),
    RGBColor(85, 107, 47),
    RGBColor(218, 165, 32),
];

/// Colours of the reference relations.
pub(super) const REFERENCE_COLOURS: [RGBColor; 5] = [
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
];

/// Marker shapes, one per simulated series.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Shape {
    Circle,
    Square,
    Triangle,
    Diamond,
    /// The open downward triangle of values at or below the axis floor.
    Floor,
}

pub(super) const SHAPES: [Shape; 4] = [
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
pub(super) fn marker<C, DB: DrawingBackend>(
    shape: Shape,
    at: C,
    r: i32,
    colour: RGBColor,
    px: Px,
) -> Marker<C, DB> {
    drawn(shape, at, r, colour, px, shape == Shape::Floor)
}

/// The open form of [`marker`]: white inside, outlined in `colour` (a
/// point that is not a plain result, such as one without a steady part).
pub(super) fn open_marker<C, DB: DrawingBackend>(
    shape: Shape,
    at: C,
    r: i32,
    colour: RGBColor,
    px: Px,
) -> Marker<C, DB> {
    drawn(shape, at, r, colour, px, true)
}

fn drawn<C, DB: DrawingBackend>(
    shape: Shape,
    at: C,
    r: i32,
    colour: RGBColor,
    px: Px,
    open: bool,
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
    let (fill, line) = if open {
        (WHITE.filled(), colour.stroke_width(px.w(1.8)))
    } else {
        (colour.filled(), BLACK.mix(0.8).stroke_width(px.w(0.8)))
    };
    let mut closed = corners.clone();
    closed.push(corners[0]);
    EmptyElement::at(at) + Polygon::new(corners, fill) + PathElement::new(closed, line)
}
