//! SVG plots rendered to a string (plotters, SVG backend: no system fonts
//! needed). The CLI writes the string atomically.

use crate::lti::Bode;
use plotters::prelude::*;

/// Rendering failed (plotters reports drawing-area errors).
#[derive(Debug, thiserror::Error)]
#[error("plot: {0}")]
pub struct PlotError(String);

fn perr<E: std::fmt::Debug>(e: E) -> PlotError {
    PlotError(format!("{e:?}"))
}

/// One curve of a chart.
#[derive(Debug, Clone)]
pub struct Series<'a> {
    /// Legend text.
    pub label: &'a str,
    /// Abscissae.
    pub x: &'a [f64],
    /// Ordinates.
    pub y: &'a [f64],
}

const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(23, 190, 207),
];

fn bounds<'a>(series: &[Series<'a>], pick: impl Fn(&Series<'a>) -> &'a [f64]) -> (f64, f64) {
    let (lo, hi) = series
        .iter()
        .flat_map(|s| pick(s).iter().copied())
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 * (1.0 + lo.abs()) {
        return (lo - 0.5, hi + 0.5);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
}

/// An axis tick for people: `1e8` rather than `100000000.0`, `0.25`
/// rather than `0.25000000000000006`.
fn tick_label(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-2..1e5).contains(&a) {
        let text = format!("{v:.1e}");
        text.replace(".0e", "e")
    } else {
        let rounded = (v * 1e3).round() / 1e3;
        format!("{rounded}")
    }
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
    log_x: bool,
) -> Result<(), PlotError> {
    let (x0, x1) = bounds(series, |s| s.x);
    let (y0, y1) = bounds(series, |s| s.y);
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60);
    macro_rules! draw {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_label_formatter(&|v| tick_label(*v))
                .x_desc(x_label)
                .y_desc(y_label)
                .draw()
                .map_err(perr)?;
            for (i, s) in series.iter().enumerate() {
                let color = COLORS[i % COLORS.len()];
                chart
                    .draw_series(LineSeries::new(
                        s.x.iter()
                            .zip(s.y)
                            .filter(|(x, y)| {
                                x.is_finite() && y.is_finite() && (!log_x || **x > 0.0)
                            })
                            .map(|(x, y)| (*x, *y)),
                        color.stroke_width(1),
                    ))
                    .map_err(perr)?
                    .label(s.label)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color));
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(perr)?;
        }};
    }
    if log_x {
        let lo = series
            .iter()
            .flat_map(|s| s.x.iter().copied())
            .filter(|v| *v > 0.0)
            .fold(f64::INFINITY, f64::min);
        let lo = if lo.is_finite() { lo } else { 1.0 };
        draw!(
            builder
                .build_cartesian_2d((lo..x1.max(lo * 10.0)).log_scale(), y0..y1)
                .map_err(perr)?
        );
    } else {
        draw!(builder.build_cartesian_2d(x0..x1, y0..y1).map_err(perr)?);
    }
    Ok(())
}

/// A single x-y chart.
pub fn line_chart_svg(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
) -> Result<String, PlotError> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 540)).into_drawing_area();
        root.fill(&WHITE).map_err(perr)?;
        draw_panel(&root, title, x_label, y_label, series, false)?;
        root.present().map_err(perr)?;
    }
    Ok(out)
}

/// A single x-y chart with a logarithmic x axis (points with `x <= 0` are skipped).
pub fn line_chart_svg_log_x(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
) -> Result<String, PlotError> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 540)).into_drawing_area();
        root.fill(&WHITE).map_err(perr)?;
        draw_panel(&root, title, x_label, y_label, series, true)?;
        root.present().map_err(perr)?;
    }
    Ok(out)
}

/// Several charts stacked vertically, each `(title, x_label, y_label, series)`.
pub fn stacked_charts_svg(
    panels: &[(&str, &str, &str, Vec<Series<'_>>)],
) -> Result<String, PlotError> {
    let mut out = String::new();
    {
        let height = 360 * panels.len().max(1) as u32;
        let root = SVGBackend::with_string(&mut out, (900, height)).into_drawing_area();
        root.fill(&WHITE).map_err(perr)?;
        let areas = root.split_evenly((panels.len().max(1), 1));
        for (area, (title, xl, yl, series)) in areas.iter().zip(panels) {
            draw_panel(area, title, xl, yl, series, false)?;
        }
        root.present().map_err(perr)?;
    }
    Ok(out)
}

/// A Bode plot: magnitude (dB) above phase (deg), one curve per entry.
pub fn bode_svg(title: &str, curves: &[(&str, &Bode)], log_x: bool) -> Result<String, PlotError> {
    let mags: Vec<Vec<f64>> = curves.iter().map(|(_, b)| b.magnitude_db()).collect();
    let mag_series: Vec<Series<'_>> = curves
        .iter()
        .zip(&mags)
        .map(|((label, b), m)| Series {
            label,
            x: &b.freq_hz,
            y: m,
        })
        .collect();
    let phase_series: Vec<Series<'_>> = curves
        .iter()
        .map(|(label, b)| Series {
            label,
            x: &b.freq_hz,
            y: &b.phase_deg,
        })
        .collect();
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 720)).into_drawing_area();
        root.fill(&WHITE).map_err(perr)?;
        let (top, bottom) = root.split_vertically(360);
        draw_panel(
            &top,
            title,
            "frequency (Hz)",
            "magnitude (dB)",
            &mag_series,
            log_x,
        )?;
        draw_panel(
            &bottom,
            "",
            "frequency (Hz)",
            "phase (deg)",
            &phase_series,
            log_x,
        )?;
        root.present().map_err(perr)?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_svg() {
        let b = Bode::from_fn(&[1.0, 10.0, 100.0], |f| crate::lti::c64::new(1.0, f));
        let svg = bode_svg("t", &[("g", &b)], true).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("polyline"));
        let svg = line_chart_svg(
            "t",
            "x",
            "y",
            &[Series {
                label: "a",
                x: &[0.0, 1.0],
                y: &[1.0, 2.0],
            }],
        )
        .unwrap();
        assert!(svg.contains("polyline"));
    }
}
