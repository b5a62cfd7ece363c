//! The axes of a chart: tick labels without float noise, the labelled and
//! light ticks of logarithmic axes, the grid with its axis labels, and the
//! legend box.

use super::{err, Px};
use plotters::coord::ranged1d::ValueFormatter;
use plotters::prelude::*;

/// A tick label with at most 3 significant digits, without float noise;
/// below 10⁻⁴ and from 10⁵ on in scientific form (`2.5e-5`).
pub(super) fn tick(v: &f64) -> String {
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

/// `m`·10^`e` without float noise (3·10⁻⁵ is 3e-5, not 3.0000000000000004e-5).
fn decimal(m: f64, e: i32) -> f64 {
    format!("{m}e{e}").parse().unwrap_or(m * 10f64.powi(e))
}

/// The powers of ten at or below `lo` and at or above `hi`.
pub(super) fn decades(lo: f64, hi: f64) -> (f64, f64) {
    (
        decimal(1.0, lo.log10().floor() as i32),
        decimal(1.0, hi.log10().ceil() as i32),
    )
}

/// The labelled and the light ticks of a logarithmic axis over [lo, hi]:
/// every power of ten in range is labelled; so are 2, 3, 5 times it (2 and 5
/// over three decades) on short axes, and finer values until at least four
/// labels fall in range. Light ticks at every integer multiple.
pub(super) fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
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
pub(super) fn draw_mesh<DB, X, Y>(
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
pub(super) fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
