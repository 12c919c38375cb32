//! Plots rendered to bytes, SVG or PNG as the output file's extension says
//! ([`PlotFormat::from_path`]); the CLI writes them atomically. Text is laid
//! out (and, in a PNG, drawn) with the embedded DejaVu Sans subset of
//! `assets/fonts`, so no system font is needed; an SVG names `sans-serif`
//! and leaves the face to its viewer.

use crate::lti::Bode;
use plotters::prelude::*;
use std::path::Path;

/// The image formats a plot is written in, chosen by the file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlotFormat {
    /// `.svg`: vector, text as text.
    Svg,
    /// `.png`: 8-bit RGB bitmap.
    Png,
}

/// The extensions [`PlotFormat::from_path`] accepts, for messages.
pub const PLOT_EXTENSIONS: &str = ".svg, .png";

impl PlotFormat {
    /// The format a plot file's extension names (any case); `Err` says why
    /// none does.
    pub fn from_path(path: &Path) -> Result<Self, String> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_lowercase());
        match ext.as_deref() {
            Some("svg") => Ok(PlotFormat::Svg),
            Some("png") => Ok(PlotFormat::Png),
            Some(other) => Err(format!(
                "a plot's format is its file's extension: {PLOT_EXTENSIONS}; .{other} is not one"
            )),
            None => Err(format!(
                "a plot's format is its file's extension: {PLOT_EXTENSIONS}; the name has none"
            )),
        }
    }
}

/// DejaVu Sans cut to Latin, Greek and a few symbols (`assets/fonts/subset.sh`).
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-fts.ttf");

/// Makes the embedded font plotters' `sans-serif` (once per process).
fn register_font() -> Result<(), PlotError> {
    static REGISTERED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError("the embedded font does not load".into()))
    }
}

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
    if a < 1e-12 {
        // Rounding residue of a tick at zero (`-2.2e-16`).
        "0".into()
    } else if !(1e-2..1e5).contains(&a) {
        let text = format!("{v:.1e}");
        text.replace(".0e", "e")
    } else {
        let rounded = (v * 1e3).round() / 1e3;
        // `-0` is a rounding artefact, not a value.
        format!("{}", if rounded == 0.0 { 0.0 } else { rounded })
    }
}

/// A tick label; `decades`: written `1eK` (a wide log axis).
fn axis_label(v: f64, decades: bool) -> String {
    if decades && v > 0.0 {
        format!("{v:.0e}")
    } else {
        tick_label(v)
    }
}

/// How a curve is drawn.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Style {
    /// A solid line.
    #[default]
    Line,
    /// Light dots: data shown for context but not trusted (low coherence,
    /// outside the excited band).
    Faint,
    /// A cross at each point (a few points of interest).
    Marker,
    /// A zero-order-hold staircase: each value held until the next sample
    /// (a discrete-time signal, which has no values between its samples).
    Stairs,
    /// A lighter dashed line (a secondary branch, e.g. negative
    /// frequencies on a Nyquist plot).
    Dashed,
}

/// One chart: its curves, axes and an optional shaded interval of x.
#[derive(Debug, Clone, Default)]
pub struct Panel<'a> {
    /// Caption above the chart.
    pub title: &'a str,
    /// x axis description, with its unit.
    pub x_label: &'a str,
    /// y axis description, with its unit.
    pub y_label: &'a str,
    /// Curves with their style.
    pub series: Vec<(Series<'a>, Style)>,
    /// Logarithmic x axis (points with `x <= 0` are skipped).
    pub log_x: bool,
    /// Logarithmic y axis (points with `y <= 0` are skipped), for errors
    /// that fall by decades.
    pub log_y: bool,
    /// Shade `[x0, x1]` and say what it is in the legend.
    pub shade: Option<(f64, f64, &'a str)>,
    /// One unit is as long on x as on y (a path's projection: a circle
    /// looks round); the shorter range is widened about its centre.
    /// Linear axes only.
    pub equal_aspect: bool,
}

impl<'a> Panel<'a> {
    /// A panel of solid lines.
    pub fn lines(
        title: &'a str,
        x_label: &'a str,
        y_label: &'a str,
        series: Vec<Series<'a>>,
    ) -> Self {
        Panel {
            title,
            x_label,
            y_label,
            series: series.into_iter().map(|s| (s, Style::Line)).collect(),
            ..Panel::default()
        }
    }

    /// The same panel with equal x and y scales.
    pub fn with_equal_aspect(self) -> Self {
        Panel {
            equal_aspect: true,
            ..self
        }
    }
}

/// Width of the legend column right of every chart: legends never cover data.
const LEGEND_WIDTH: u32 = 270;
const SHADE: RGBColor = RGBColor(255, 200, 80);

fn legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    panel: &Panel<'_>,
) -> Result<(), PlotError> {
    let font = ("sans-serif", 13).into_font();
    let mut y = 40;
    let mut entry = |text: &str, mark: &dyn Fn(i32) -> Result<(), PlotError>| {
        mark(y)?;
        area.draw(&Text::new(text.to_owned(), (34, y - 7), font.clone()))
            .map_err(perr)?;
        y += 20;
        Ok::<(), PlotError>(())
    };
    for (i, (s, style)) in panel.series.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        if s.label.is_empty() {
            continue;
        }
        match style {
            Style::Line => entry(s.label, &|y| {
                area.draw(&PathElement::new(
                    vec![(6, y), (28, y)],
                    color.stroke_width(2),
                ))
                .map_err(perr)
            })?,
            Style::Faint => entry(s.label, &|y| {
                area.draw(&Circle::new((17, y), 2, color.mix(0.45).filled()))
                    .map_err(perr)
            })?,
            Style::Marker => entry(s.label, &|y| {
                area.draw(&Cross::new((17, y), 5, color.stroke_width(2)))
                    .map_err(perr)
            })?,
            Style::Stairs => entry(s.label, &|y| {
                area.draw(&PathElement::new(
                    vec![(6, y + 4), (17, y + 4), (17, y - 4), (28, y - 4)],
                    color.stroke_width(2),
                ))
                .map_err(perr)
            })?,
            Style::Dashed => entry(s.label, &|y| {
                for x in [6, 16] {
                    area.draw(&PathElement::new(
                        vec![(x, y), (x + 6, y)],
                        color.mix(0.6).stroke_width(2),
                    ))
                    .map_err(perr)?;
                }
                Ok(())
            })?,
        }
    }
    if let Some((_, _, label)) = panel.shade {
        entry(label, &|y| {
            area.draw(&Rectangle::new(
                [(6, y - 5), (28, y + 5)],
                SHADE.mix(0.3).filled(),
            ))
            .map_err(perr)
        })?;
    }
    Ok(())
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    panel: &Panel<'_>,
) -> Result<(), PlotError> {
    let (plot_area, legend_area) = area.split_horizontally(area.dim_in_pixel().0 - LEGEND_WIDTH);
    legend(&legend_area, panel)?;
    let all: Vec<Series<'_>> = panel.series.iter().map(|(s, _)| s.clone()).collect();
    let (x0, x1) = bounds(&all, |s| s.x);
    // Faint (untrusted) data does not set the scale: noise must not squash
    // the curves that matter; faint points beyond it are left out.
    let solid: Vec<Series<'_>> = panel
        .series
        .iter()
        .filter(|(s, style)| *style != Style::Faint && s.y.iter().any(|v| v.is_finite()))
        .map(|(s, _)| s.clone())
        .collect();
    let (y0, y1) = bounds(if solid.is_empty() { &all } else { &solid }, |s| s.y);
    let (log_x, log_y) = (panel.log_x, panel.log_y);
    let (y0, y1) = if log_y {
        positive_range(&all, |s| s.y, y1)
    } else {
        (y0, y1)
    };
    let equal = panel.equal_aspect && !log_x && !log_y;
    // With equal scales the title is drawn first, so that the plotting
    // area's size in pixels is known before the ranges are chosen.
    let plot_area = if equal {
        plot_area
            .titled(panel.title, ("sans-serif", 18))
            .map_err(perr)?
    } else {
        plot_area
    };
    let ((x0, x1), (y0, y1)) = if equal {
        let (w, h) = plot_area.dim_in_pixel();
        let pixels = (w.saturating_sub(2 * 10 + 60), h.saturating_sub(2 * 10 + 35));
        equal_ranges((x0, x1), (y0, y1), pixels)
    } else {
        ((x0, x1), (y0, y1))
    };
    let mut builder = ChartBuilder::on(&plot_area);
    if !equal {
        builder.caption(panel.title, ("sans-serif", 18));
    }
    builder
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60);
    let (lo, hi) = positive_range(&all, |s| s.x, x1);
    // A log axis that leaves 0.01..1e5 writes every decade as 1eK, not a
    // mix of `10000` and `1e5`.
    let wide = |a: f64, b: f64| a < 1e-2 || b >= 1e5;
    let (x_decades, y_decades) = (log_x && wide(lo, hi), log_y && wide(y0, y1));
    macro_rules! draw {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_label_formatter(&|v| axis_label(*v, x_decades))
                .y_label_formatter(&|v| axis_label(*v, y_decades))
                .x_desc(panel.x_label)
                .y_desc(panel.y_label)
                .draw()
                .map_err(perr)?;
            if let Some((a, b, _)) = panel.shade {
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(a, y0), (b, y1)],
                        SHADE.mix(0.3).filled(),
                    )))
                    .map_err(perr)?;
            }
            for (i, (s, style)) in panel.series.iter().enumerate() {
                let color = COLORS[i % COLORS.len()];
                let drawable = |(x, y): (&f64, &f64)| {
                    x.is_finite() && y.is_finite() && (!log_x || *x > 0.0) && (!log_y || *y > 0.0)
                };
                let points =
                    s.x.iter()
                        .zip(s.y)
                        .filter(|p| drawable(*p))
                        .map(|(x, y)| (*x, *y));
                match style {
                    Style::Line | Style::Stairs | Style::Dashed => {
                        // A non-finite point breaks the line: gaps stay gaps.
                        for run in
                            s.x.iter()
                                .zip(s.y)
                                .collect::<Vec<_>>()
                                .split(|p| !drawable(*p))
                        {
                            let run: Vec<(f64, f64)> =
                                run.iter().map(|(x, y)| (**x, **y)).collect();
                            if *style == Style::Dashed {
                                chart
                                    .draw_series(DashedLineSeries::new(
                                        run,
                                        6,
                                        4,
                                        color.mix(0.6).stroke_width(1),
                                    ))
                                    .map_err(perr)?;
                                continue;
                            }
                            let run = if *style == Style::Stairs {
                                staircase(&run)
                            } else {
                                run
                            };
                            chart
                                .draw_series(LineSeries::new(run, color.stroke_width(1)))
                                .map_err(perr)?;
                        }
                    }
                    Style::Faint => {
                        chart
                            .draw_series(
                                points
                                    .filter(|(_, y)| (y0..=y1).contains(y))
                                    .map(|p| Circle::new(p, 2, color.mix(0.45).filled())),
                            )
                            .map_err(perr)?;
                    }
                    Style::Marker => {
                        chart
                            .draw_series(points.map(|p| Cross::new(p, 6, color.stroke_width(2))))
                            .map_err(perr)?;
                    }
                }
            }
        }};
    }
    // Log axes carry our own ticks: every decade labelled, 2..9 as light
    // grid lines (plotters' own choice can leave the first decade bare).
    let log_axis = |a: f64, b: f64| {
        let (bold, light) = log_ticks(a, b);
        (a..b)
            .log_scale()
            .with_key_points(bold)
            .with_light_points(light)
    };
    match (log_x, log_y) {
        (false, false) => draw!(builder.build_cartesian_2d(x0..x1, y0..y1).map_err(perr)?),
        (true, false) => draw!(
            builder
                .build_cartesian_2d(log_axis(lo, hi), y0..y1)
                .map_err(perr)?
        ),
        (false, true) => draw!(
            builder
                .build_cartesian_2d(x0..x1, log_axis(y0, y1))
                .map_err(perr)?
        ),
        (true, true) => draw!(
            builder
                .build_cartesian_2d(log_axis(lo, hi), log_axis(y0, y1))
                .map_err(perr)?
        ),
    }
    Ok(())
}

/// The corners of a zero-order-hold staircase through `points` (sorted by
/// x): each value held until the next point's abscissa.
pub fn staircase(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(2 * points.len());
    for (i, &(x, y)) in points.iter().enumerate() {
        if i > 0 {
            out.push((x, points[i - 1].1));
        }
        out.push((x, y));
    }
    out
}

/// Ticks of a logarithmic axis over `[lo, hi]`: labelled (bold) ticks at
/// every power of ten in the range, and light ticks at 2..9 times each.
/// A range holding fewer than two powers of ten is labelled at 1, 2 and 5
/// times each decade instead, so that every axis carries at least two
/// labels.
pub fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return (Vec::new(), Vec::new());
    }
    // A relative slack so that a range ending at 1e3 computed as
    // 999.9999999 still shows its 1e3.
    let inside = |v: f64| v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9);
    let (first, last) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let decades: Vec<f64> = (first..=last)
        .map(|k| 10f64.powi(k))
        .filter(|v| inside(*v))
        .collect();
    let multiples = |m: &[f64]| -> Vec<f64> {
        (first..=last)
            .flat_map(|k| m.iter().map(move |f| f * 10f64.powi(k)))
            .filter(|v| inside(*v))
            .collect()
    };
    if decades.len() >= 2 {
        (
            decades,
            multiples(&[2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]),
        )
    } else {
        (
            multiples(&[1.0, 2.0, 5.0]),
            multiples(&[3.0, 4.0, 6.0, 7.0, 8.0, 9.0]),
        )
    }
}

/// The ranges widened (about their centres) so that a unit spans as many
/// pixels on x as on y in a plotting area of `pixels` (width, height).
fn equal_ranges(x: (f64, f64), y: (f64, f64), pixels: (u32, u32)) -> ((f64, f64), (f64, f64)) {
    let (w, h) = (f64::from(pixels.0.max(1)), f64::from(pixels.1.max(1)));
    let per_pixel = ((x.1 - x.0) / w).max((y.1 - y.0) / h);
    let about = |(lo, hi): (f64, f64), n: f64| {
        let (mid, half) = (0.5 * (lo + hi), 0.5 * per_pixel * n);
        (mid - half, mid + half)
    };
    (about(x, w), about(y, h))
}

/// A range for a logarithmic axis: from the smallest positive value of
/// `axis` (1 when there is none) to `top`, at least a decade wide.
fn positive_range<'a>(
    series: &[Series<'a>],
    axis: impl Fn(&Series<'a>) -> &'a [f64],
    top: f64,
) -> (f64, f64) {
    let lo = series
        .iter()
        .flat_map(|s| axis(s).iter().copied())
        .filter(|v| *v > 0.0 && v.is_finite())
        .fold(f64::INFINITY, f64::min);
    let lo = if lo.is_finite() { lo } else { 1.0 };
    (lo, top.max(lo * 10.0))
}

/// Charts stacked vertically, 360 pixels each, as an SVG document.
pub fn panels_svg(panels: &[Panel<'_>]) -> Result<String, PlotError> {
    let bytes = render(panels, PlotFormat::Svg)?;
    Ok(String::from_utf8(bytes).expect("the SVG backend writes UTF-8"))
}

/// Charts stacked vertically, 360 pixels each, in `format`.
pub fn render(panels: &[Panel<'_>], format: PlotFormat) -> Result<Vec<u8>, PlotError> {
    register_font()?;
    let size = (900 + LEGEND_WIDTH, 360 * panels.len().max(1) as u32);
    match format {
        PlotFormat::Svg => {
            let mut out = String::new();
            draw_panels(
                &SVGBackend::with_string(&mut out, size).into_drawing_area(),
                panels,
            )?;
            Ok(out.into_bytes())
        }
        PlotFormat::Png => {
            let mut rgb = vec![0u8; 3 * size.0 as usize * size.1 as usize];
            draw_panels(
                &BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area(),
                panels,
            )?;
            encode_png(&rgb, size)
        }
    }
}

fn draw_panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    panels: &[Panel<'_>],
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(perr)?;
    let areas = root.split_evenly((panels.len().max(1), 1));
    for (area, panel) in areas.iter().zip(panels) {
        draw_panel(area, panel)?;
    }
    root.present().map_err(perr)
}

/// An 8-bit RGB buffer of `size` pixels as a PNG file.
fn encode_png(rgb: &[u8], size: (u32, u32)) -> Result<Vec<u8>, PlotError> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, size.0, size.1);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(perr)?;
    writer.write_image_data(rgb).map_err(perr)?;
    writer.finish().map_err(perr)?;
    Ok(out)
}

/// A single x-y chart.
pub fn line_chart_svg(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
) -> Result<String, PlotError> {
    panels_svg(&[Panel::lines(title, x_label, y_label, series.to_vec())])
}

/// A single x-y chart in `format`.
pub fn line_chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
    format: PlotFormat,
) -> Result<Vec<u8>, PlotError> {
    render(
        &[Panel::lines(title, x_label, y_label, series.to_vec())],
        format,
    )
}

/// A single x-y chart with a logarithmic x axis (points with `x <= 0` are
/// skipped), in `format`.
pub fn line_chart_log_x(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
    format: PlotFormat,
) -> Result<Vec<u8>, PlotError> {
    let panel = Panel {
        log_x: true,
        ..Panel::lines(title, x_label, y_label, series.to_vec())
    };
    render(&[panel], format)
}

/// Several charts stacked vertically, each `(title, x_label, y_label,
/// series)`, in `format`.
pub fn stacked_charts(
    panels: &[(&str, &str, &str, Vec<Series<'_>>)],
    format: PlotFormat,
) -> Result<Vec<u8>, PlotError> {
    let panels: Vec<Panel<'_>> = panels
        .iter()
        .map(|(t, xl, yl, s)| Panel::lines(t, xl, yl, s.clone()))
        .collect();
    render(&panels, format)
}

/// The two panels of a Bode plot (magnitude in dB, phase in degrees, log
/// frequency in Hz), each curve with its style.
pub fn bode_panels<'a>(
    title: &'a str,
    curves: &[(&'a str, &'a Bode, Style)],
    magnitudes_db: &'a [Vec<f64>],
) -> [Panel<'a>; 2] {
    // The phase panel repeats no legend: its curves are the magnitude's.
    let pick = |y: &dyn Fn(usize) -> &'a [f64], labelled: bool| {
        curves
            .iter()
            .enumerate()
            .map(|(i, (label, b, style))| {
                let s = Series {
                    label: if labelled { label } else { "" },
                    x: &b.freq_hz,
                    y: y(i),
                };
                (s, *style)
            })
            .collect::<Vec<_>>()
    };
    [
        Panel {
            title,
            x_label: "frequency (Hz)",
            y_label: "magnitude (dB)",
            series: pick(&|i| &magnitudes_db[i], true),
            log_x: true,
            ..Panel::default()
        },
        Panel {
            title: "",
            x_label: "frequency (Hz)",
            y_label: "phase (deg)",
            series: pick(&|i| &curves[i].1.phase_deg, false),
            log_x: true,
            ..Panel::default()
        },
    ]
}

/// A Bode plot: magnitude (dB) above phase (deg) on a logarithmic frequency
/// axis (0 Hz is left out), one curve per entry, as SVG.
pub fn bode_svg(title: &str, curves: &[(&str, &Bode)]) -> Result<String, PlotError> {
    let bytes = bode(title, curves, PlotFormat::Svg)?;
    Ok(String::from_utf8(bytes).expect("the SVG backend writes UTF-8"))
}

/// [`bode_svg`] in `format`.
pub fn bode(
    title: &str,
    curves: &[(&str, &Bode)],
    format: PlotFormat,
) -> Result<Vec<u8>, PlotError> {
    let styled: Vec<(&str, &Bode, Style)> =
        curves.iter().map(|(l, b)| (*l, *b, Style::Line)).collect();
    let mags: Vec<Vec<f64>> = curves.iter().map(|(_, b)| b.magnitude_db()).collect();
    render(&bode_panels(title, &styled, &mags), format)
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn equal_ranges_give_one_scale_and_keep_the_data() {
        // 100 x 10 units in 400 x 200 pixels: 0.25 units a pixel on both.
        let ((x0, x1), (y0, y1)) = equal_ranges((0.0, 100.0), (-5.0, 5.0), (400, 200));
        assert_eq!((x0, x1), (0.0, 100.0));
        assert_eq!((y0, y1), (-25.0, 25.0));
        // Tall data in a wide area: x is widened instead.
        let ((x0, x1), (y0, y1)) = equal_ranges((0.0, 1.0), (0.0, 10.0), (400, 200));
        assert_eq!((y0, y1), (0.0, 10.0));
        assert!(((x1 - x0) / 400.0 - 10.0 / 200.0).abs() < 1e-15 && x0 < 0.0 && x1 > 1.0);
    }

    pub fn every_decade_of_a_log_axis_is_labelled() {
        for (lo, hi) in [(0.0098, 512.0), (1e-3, 1e3), (2.5e-7, 3e7), (0.5, 0.5e5)] {
            let (bold, light) = log_ticks(lo, hi);
            let (first, last) = (lo.log10().ceil() as i32, hi.log10().floor() as i32);
            let want: Vec<f64> = (first..=last).map(|k| 10f64.powi(k)).collect();
            assert_eq!(bold, want, "[{lo}, {hi}]");
            assert!(
                light
                    .iter()
                    .all(|v| *v >= lo * (1.0 - 1e-9) && *v <= hi * (1.0 + 1e-9))
            );
            // Every label is written as its decade.
            for v in &bold {
                let text = tick_label(*v);
                assert!(
                    (text.parse::<f64>().unwrap() / v - 1.0).abs() < 1e-12,
                    "{text}"
                );
            }
        }
        // A wide log axis writes every decade alike.
        let labels: Vec<String> = log_ticks(0.5, 2e6)
            .0
            .iter()
            .map(|v| axis_label(*v, true))
            .collect();
        assert_eq!(labels, ["1e0", "1e1", "1e2", "1e3", "1e4", "1e5", "1e6"]);
        // Within one decade: 1-2-5 labels, never none.
        assert_eq!(log_ticks(3.0, 40.0).0, vec![5.0, 10.0, 20.0]);
        assert_eq!(log_ticks(0.0, 1.0), (vec![], vec![]));
    }

    pub fn a_staircase_holds_each_sample() {
        let s = staircase(&[(0.0, 1.0), (1.0, 3.0), (2.0, 2.0)]);
        assert_eq!(
            s,
            vec![(0.0, 1.0), (1.0, 1.0), (1.0, 3.0), (2.0, 3.0), (2.0, 2.0)]
        );
    }

    pub fn the_extension_picks_the_format_and_others_are_refused() {
        let f = |p: &str| PlotFormat::from_path(Path::new(p));
        assert_eq!(f("a/b.svg"), Ok(PlotFormat::Svg));
        assert_eq!(f("B.PNG"), Ok(PlotFormat::Png));
        for bad in ["x.pdf", "x", "x.svg.gz", "x.jpg"] {
            let e = f(bad).unwrap_err();
            assert!(e.contains(".svg, .png"), "{bad}: {e}");
        }
    }

    pub fn renders_png_with_text_without_system_fonts() {
        let series = [Series {
            label: "a",
            x: &[0.0, 1.0],
            y: &[1.0, 2.0],
        }];
        let panel = Panel::lines("title", "x", "y", series.to_vec());
        let png = render(std::slice::from_ref(&panel), PlotFormat::Png).unwrap();
        assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"));
        // The same panel without any text must differ: the labels were drawn.
        let blank = Panel::lines(
            "",
            "",
            "",
            vec![Series {
                label: "",
                ..series[0].clone()
            }],
        );
        assert_ne!(png, render(&[blank], PlotFormat::Png).unwrap());
    }

    pub fn renders_svg() {
        let b = Bode::from_fn(&[1.0, 10.0, 100.0], |f| crate::lti::c64::new(1.0, f));
        let svg = bode_svg("t", &[("g", &b)]).unwrap();
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
