//! Figures (PNG or SVG, by the file extension) drawn with `plotters`.
//!
//! [`release_test_figure`] reproduces the six panels of the paper's
//! Fig. 7.1: acceleration (with a measured record if given), acceleration
//! coloured by phase, displacement, velocity, and the force-displacement
//! loops of the rubber bearings and of the slider.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use thiserror::Error;

use crate::criticism::FormSeries;
use crate::model::{PhaseKind, Response, Sample, SimError};

/// Draws with `$draw(area, args...)` on a PNG or SVG backend by `$ext`,
/// naming the file in any error.
macro_rules! render {
    ($path:expr, $ext:expr, $size:expr, $draw:ident($($arg:expr),* $(,)?)) => {{
        let result = if $ext == "png" {
            $draw(BitMapBackend::new($path, $size).into_drawing_area(), $($arg),*)
        } else {
            $draw(SVGBackend::new($path, $size).into_drawing_area(), $($arg),*)
        };
        result.map_err(|message| FigureError::Draw {
            path: $path.to_path_buf(),
            message,
        })
    }};
}

/// Errors while drawing a figure.
#[derive(Debug, Error)]
pub enum FigureError {
    #[error("figure {path}: the file name must end in .png or .svg")]
    Format { path: PathBuf },
    #[error("figure {path}: {message}")]
    Draw { path: PathBuf, message: String },
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// A measured acceleration record to draw under the model's.
#[derive(Debug, Clone, Copy)]
pub struct Measured<'a> {
    /// Times (s).
    pub t: &'a [f64],
    /// Accelerations (m/s^2).
    pub a: &'a [f64],
    /// Legend label.
    pub label: &'a str,
}

const FONT: &str = "sans-serif";

/// Register the embedded font once; plotters' `ab_glyph` backend has none.
fn font_ready() -> bool {
    static READY: OnceLock<bool> = OnceLock::new();
    *READY.get_or_init(|| {
        plotters::style::register_font(
            FONT,
            FontStyle::Normal,
            include_bytes!("../../assets/DejaVuSans.ttf"),
        )
        .is_ok()
    })
}

/// One colour per phase kind.
fn phase_colour(k: PhaseKind) -> RGBColor {
    match k {
        PhaseKind::Elastic => RGBColor(31, 119, 180),
        PhaseKind::Plastic1 => RGBColor(255, 127, 14),
        PhaseKind::Plastic2 => RGBColor(44, 160, 44),
        PhaseKind::Plastic3 => RGBColor(214, 39, 40),
        PhaseKind::Rest => RGBColor(127, 127, 127),
    }
}

/// A curve: points, colour, legend label (empty for none).
struct Curve {
    points: Vec<(f64, f64)>,
    colour: RGBColor,
    label: String,
}

/// An axis label as plotters writes it, but never "-0" (a tick at a
/// round-off below zero).
fn tick(v: &f64) -> String {
    use plotters::coord::ranged1d::ValueFormatter;
    let s = <plotters::coord::types::RangedCoordf64 as ValueFormatter<f64>>::format(v);
    if s.parse::<f64>() == Ok(0.0) {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// Range of the data with a 5 % margin; never empty.
fn range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        });
    if !lo.is_finite() {
        return -1.0..1.0;
    }
    let pad = if hi - lo > 1e-12 * (1.0 + hi.abs().max(lo.abs())) {
        0.05 * (hi - lo)
    } else {
        1.0f64.max(hi.abs()) * 0.1
    };
    (lo - pad)..(hi + pad)
}

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    x_label: &str,
    y_label: &str,
    curves: &[Curve],
) -> Result<(), String> {
    shaded_panel(area, caption, x_label, y_label, curves, &[])
}

/// A time span `[t0, t1)` shaded in a colour behind a panel's curves.
type Shade = (f64, f64, RGBColor);

/// [`panel`] over `shade`d time spans.
fn shaded_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    x_label: &str,
    y_label: &str,
    curves: &[Curve],
    shade: &[Shade],
) -> Result<(), String> {
    let xs = range(curves.iter().flat_map(|c| c.points.iter().map(|p| p.0)));
    let ys = range(curves.iter().flat_map(|c| c.points.iter().map(|p| p.1)));
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FONT, 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(xs, ys.clone())
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(|e| e.to_string())?;
    chart
        .draw_series(shade.iter().map(|&(t0, t1, colour)| {
            Rectangle::new([(t0, ys.start), (t1, ys.end)], colour.mix(0.13).filled())
        }))
        .map_err(|e| e.to_string())?;
    let mut labelled = false;
    for c in curves {
        let series = chart
            // Thick polylines of dense, jagged data grow long miter spikes
            // at their sharp joins; one pixel draws them faithfully.
            .draw_series(LineSeries::new(
                c.points.iter().copied(),
                c.colour
                    .stroke_width(if c.points.len() > 500 { 1 } else { 2 }),
            ))
            .map_err(|e| e.to_string())?;
        if !c.label.is_empty() {
            let colour = c.colour;
            series.label(c.label.clone()).legend(move |(x, y)| {
                PathElement::new([(x, y), (x + 20, y)], colour.stroke_width(3))
            });
            labelled = true;
        }
    }
    if labelled {
        chart
            .configure_series_labels()
            .label_font((FONT, 15))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Split samples into maximal runs of one phase kind, so that panel (b)
/// shows the jumps between phases as breaks.
fn runs_by_phase(samples: &[Sample]) -> Vec<Curve> {
    let mut out: Vec<Curve> = Vec::new();
    let mut seen = Vec::new();
    let mut last: Option<PhaseKind> = None;
    for s in samples {
        if last != Some(s.phase) {
            let label = if seen.contains(&s.phase) {
                String::new()
            } else {
                seen.push(s.phase);
                s.phase.as_str().to_string()
            };
            out.push(Curve {
                points: Vec::new(),
                colour: phase_colour(s.phase),
                label,
            });
            last = Some(s.phase);
        }
        if let Some(c) = out.last_mut() {
            c.points.push((s.t, s.a));
        }
    }
    out
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    samples: &[Sample],
    measured: Option<Measured<'_>>,
    title: &str,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let root = root.titled(title, (FONT, 28)).map_err(|e| e.to_string())?;
    let areas = root.split_evenly((3, 2));
    let series = |f: fn(&Sample) -> (f64, f64), colour: RGBColor, label: &str| Curve {
        points: samples.iter().map(f).collect(),
        colour,
        label: label.to_string(),
    };
    let blue = RGBColor(31, 119, 180);
    let mut accel = Vec::new();
    if let Some(m) = measured {
        accel.push(Curve {
            points: m.t.iter().copied().zip(m.a.iter().copied()).collect(),
            colour: RGBColor(160, 160, 160),
            label: m.label.to_string(),
        });
    }
    accel.push(series(
        |s| (s.t, s.a),
        blue,
        if measured.is_some() { "model" } else { "" },
    ));
    panel(&areas[0], "(a) acceleration", "t (s)", "a (m/s²)", &accel)?;
    panel(
        &areas[1],
        "(b) acceleration by phase",
        "t (s)",
        "a (m/s²)",
        &runs_by_phase(samples),
    )?;
    panel(
        &areas[2],
        "(c) displacement",
        "t (s)",
        "u (m)",
        &[series(|s| (s.t, s.u), blue, "")],
    )?;
    panel(
        &areas[3],
        "(d) velocity",
        "t (s)",
        "v (m/s)",
        &[series(|s| (s.t, s.v), blue, "")],
    )?;
    let red = RGBColor(214, 39, 40);
    panel(
        &areas[4],
        "(e) rubber bearings (HDRB)",
        "u (m)",
        "F_S/m (N/kg)",
        &[series(|s| (s.u, s.f_spring), red, "")],
    )?;
    panel(
        &areas[5],
        "(f) sliding bearings (LFSB)",
        "u (m)",
        "F_F/m (N/kg)",
        &[series(|s| (s.u, s.f_friction), red, "")],
    )?;
    root.present().map_err(|e| e.to_string())
}

/// The six panels of the paper's Fig. 7.1 for a simulated response sampled
/// every `dt`, with an optional measured record under panel (a). PNG or SVG
/// by the extension of `path`.
pub fn release_test_figure(
    path: &Path,
    response: &Response,
    dt: f64,
    measured: Option<Measured<'_>>,
    title: &str,
) -> Result<(), FigureError> {
    let ext = checked_extension(path)?;
    let samples = response.sample_grid(dt)?;
    let size = (1600, 1500);
    render!(path, &ext, size, draw(&samples, measured, title))
}

/// How the residual panel of [`fit_figure`] is scaled: at least
/// `±half` (the same for every figure of a ladder, so that the error is
/// seen to fall), with the noise floor `±sigma` drawn.
#[derive(Debug, Clone, Copy)]
pub struct ResidualScale {
    /// Half the axis (m/s^2); 0 for the residual's own range.
    pub half: f64,
    /// The noise floor drawn as `±sigma` (m/s^2).
    pub sigma: f64,
    /// Its legend, e.g. `±σ: residual RMS at the MAP`.
    pub label: &'static str,
}

/// What [`fit_figure`] draws beside the record, the model and the
/// residual.
#[derive(Debug, Clone, Copy, Default)]
pub struct Overlays<'a> {
    /// A band around the model, e.g. the 90 % posterior-predictive
    /// interval: `(lower, upper)`, one value per sample.
    pub band: Option<(&'a [f64], &'a [f64])>,
    /// The residual panel's scale and noise floor.
    pub scale: Option<ResidualScale>,
    /// The phase of the model's motion at each sample (`elastic`,
    /// `plastic1`, ...), shaded behind the acceleration.
    pub phases: Option<&'a [String]>,
}

/// Measured against model acceleration (top, with an optional band such as
/// a 90 % posterior-predictive interval, drawn under the record) and the
/// residual (bottom, with the noise floor if `scale` is given). PNG or SVG
/// by the extension of `path`.
pub fn fit_figure(
    path: &Path,
    t: &[f64],
    measured: &[f64],
    model: &[f64],
    overlays: &Overlays,
    title: &str,
) -> Result<(), FigureError> {
    let ext = checked_extension(path)?;
    let Overlays {
        band,
        scale,
        phases,
    } = *overlays;
    let shade = phases.map_or_else(Vec::new, |p| phase_spans(t, p));
    let size = (1600, 1000);
    // An SVG (for report.html) keeps each curve's lowest and highest value
    // in each pixel column: peaks survive, the file stays small however
    // long the record. A PNG draws every sample.
    let shown = |points: Vec<(f64, f64)>| {
        if ext == "svg" {
            decimate(&points, size.0 as usize)
        } else {
            points
        }
    };
    let residual: Vec<(f64, f64)> = t
        .iter()
        .zip(measured.iter().zip(model))
        .map(|(&t, (m, a))| (t, m - a))
        .collect();
    let mut top = Vec::new();
    if let Some((lo, hi)) = band {
        for (edge, label) in [(lo, "90 % predictive band"), (hi, "")] {
            top.push(Curve {
                points: shown(t.iter().copied().zip(edge.iter().copied()).collect()),
                colour: RGBColor(120, 170, 220),
                label: label.into(),
            });
        }
    }
    top.extend([
        Curve {
            points: shown(t.iter().copied().zip(measured.iter().copied()).collect()),
            colour: RGBColor(90, 90, 90),
            label: "measured".into(),
        },
        Curve {
            points: shown(t.iter().copied().zip(model.iter().copied()).collect()),
            colour: RGBColor(214, 39, 40),
            label: "model (MAP)".into(),
        },
    ]);
    let (t0, t1) = (
        t.first().copied().unwrap_or(0.0),
        t.last().copied().unwrap_or(1.0),
    );
    let mut bottom = Vec::new();
    if let Some(sc) = scale {
        // Invisible edges that set the shared scale.
        for y in [-sc.half, sc.half] {
            bottom.push(Curve {
                points: vec![(t0, y), (t1, y)],
                colour: WHITE,
                label: String::new(),
            });
        }
    }
    bottom.push(Curve {
        points: shown(residual),
        colour: RGBColor(44, 44, 160),
        label: String::new(),
    });
    if let Some(sc) = scale {
        for (y, label) in [(sc.sigma, sc.label), (-sc.sigma, "")] {
            bottom.push(Curve {
                points: vec![(t0, y), (t1, y)],
                colour: RGBColor(230, 140, 0),
                label: label.into(),
            });
        }
    }
    render!(path, &ext, size, draw_fit(title, &top, &bottom, &shade))
}

/// A curve for display: of the points (in increasing x) that fall in each
/// of `columns` equal columns of the x range, only the lowest and the
/// highest, in their order. Drawn one column to a pixel, the line looks the
/// same as with every point, peaks included; a curve of at most two points
/// per column is returned whole.
///
/// ```
/// use hbis::report::figures::decimate;
///
/// let wave: Vec<(f64, f64)> = (0..20_000)
///     .map(|i| (i as f64 * 0.005, (i as f64 * 0.01).sin() * (i % 997 == 0) as u8 as f64))
///     .collect();
/// let shown = decimate(&wave, 800);
/// assert!(shown.len() <= 1600);
/// let peak = |p: &[(f64, f64)]| p.iter().map(|q| q.1).fold(f64::MIN, f64::max);
/// assert_eq!(peak(&shown), peak(&wave));
/// assert_eq!(decimate(&wave[..1000], 800), wave[..1000].to_vec());
/// ```
pub fn decimate(points: &[(f64, f64)], columns: usize) -> Vec<(f64, f64)> {
    let columns = columns.max(1);
    if points.len() <= 2 * columns {
        return points.to_vec();
    }
    let (x0, x1) = (points[0].0, points[points.len() - 1].0);
    let width = (x1 - x0) / columns as f64;
    if width.is_nan() || width <= 0.0 {
        return points.to_vec();
    }
    let column = |x: f64| (((x - x0) / width).max(0.0) as usize).min(columns - 1);
    let mut out = Vec::with_capacity(2 * columns);
    let mut start = 0;
    while start < points.len() {
        let c = column(points[start].0);
        let mut end = start;
        let (mut lo, mut hi) = (start, start);
        while end < points.len() && column(points[end].0) == c {
            if points[end].1 < points[lo].1 {
                lo = end;
            }
            if points[end].1 > points[hi].1 {
                hi = end;
            }
            end += 1;
        }
        out.push(points[lo.min(hi)]);
        if lo != hi {
            out.push(points[lo.max(hi)]);
        }
        start = end;
    }
    out
}

/// Runs of one phase along `t` as shaded spans, coloured as panel (b) of
/// the release-test figure colours the phases.
fn phase_spans(t: &[f64], phases: &[String]) -> Vec<Shade> {
    let kind = |p: &str| match p {
        "elastic" => Some(PhaseKind::Elastic),
        "plastic1" => Some(PhaseKind::Plastic1),
        "plastic2" => Some(PhaseKind::Plastic2),
        "plastic3" => Some(PhaseKind::Plastic3),
        "rest" => Some(PhaseKind::Rest),
        _ => None,
    };
    let n = t.len().min(phases.len());
    let dt = if n > 1 { t[1] - t[0] } else { 0.0 };
    let mut spans = Vec::new();
    let mut start = 0;
    for i in 1..=n {
        if i == n || phases[i] != phases[start] {
            if let Some(k) = kind(&phases[start]) {
                let end = if i < n { t[i] } else { t[n - 1] + dt };
                spans.push((t[start], end, phase_colour(k)));
            }
            start = i;
        }
    }
    spans
}

fn draw_fit<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    top: &[Curve],
    bottom: &[Curve],
    shade: &[Shade],
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let root = root.titled(title, (FONT, 28)).map_err(|e| e.to_string())?;
    let (a, b) = root.split_vertically(root.dim_in_pixel().1 * 3 / 5);
    let caption = if shade.is_empty() {
        "(a) acceleration"
    } else {
        "(a) acceleration; shading: phase of the model's motion (blue elastic, orange plastic1, green plastic2, red plastic3, grey rest)"
    };
    shaded_panel(&a, caption, "t (s)", "a (m/s²)", top, shade)?;
    panel(
        &b,
        "(b) residual, measured - model",
        "t (s)",
        "r (m/s²)",
        bottom,
    )?;
    root.present().map_err(|e| e.to_string())
}

/// A corner plot: histograms of each parameter on the diagonal, pairwise
/// scatter of the draws below it. `points` are draws (thin them to a few
/// thousand); `marks` optional reference values (e.g. the MAP or a truth).
///
/// Each diagonal cell is titled with the parameter (name and unit as given
/// in `names`), its median and 90 % interval; `truth` (when the record is
/// synthetic) is drawn as black lines.
pub fn corner_figure(
    path: &Path,
    names: &[String],
    points: &[Vec<f64>],
    marks: Option<&[f64]>,
    truth: Option<&[f64]>,
    title: &str,
) -> Result<(), FigureError> {
    let ext = checked_extension(path)?;
    let d = names.len();
    // A truth or mark for other parameters than drawn is not drawn.
    let truth = truth.filter(|t| t.len() == d);
    let marks = marks.filter(|m| m.len() == d);
    let size = ((260 * d as u32).max(600), (260 * d as u32).max(600));
    render!(
        path,
        &ext,
        size,
        draw_corner(names, points, marks, truth, title)
    )
}

/// 4 significant digits, for figure titles.
fn short(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let mag = x.abs().log10().floor();
    if !(-3.0..5.0).contains(&mag) {
        format!("{x:.3e}")
    } else {
        let decimals = (3.0 - mag).max(0.0) as usize;
        format!("{x:.decimals$}")
    }
}

/// The corner plot's layout, in pixels of a cell: every cell keeps the
/// same margins, so that columns and rows line up; the diagonal cells'
/// titles sit in the top margin, above the histogram and its marks; the
/// axis titles sit outside the tick labels.
const CORNER_TITLE: u32 = 40;
const CORNER_X_AREA: u32 = 52;
const CORNER_Y_AREA: u32 = 78;

fn draw_corner<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    names: &[String],
    points: &[Vec<f64>],
    marks: Option<&[f64]>,
    truth: Option<&[f64]>,
    title: &str,
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let size = title_size(root.dim_in_pixel().0, title, 26.0);
    let root = root.titled(title, (FONT, size)).map_err(e)?;
    let d = names.len();
    let cells = root.split_evenly((d, d));
    let ranges: Vec<std::ops::Range<f64>> = (0..d)
        .map(|k| range(points.iter().map(|p| p[k]).chain(truth.map(|t| t[k]))))
        .collect();
    let blue = RGBColor(31, 119, 180);
    for i in 0..d {
        for j in 0..d {
            let area = &cells[i * d + j];
            if j > i {
                continue;
            }
            let bottom = i == d - 1;
            // Inner cells keep a thin label area: it draws their frame.
            let x_area = if bottom { CORNER_X_AREA } else { 5 };
            let y_area = if j == 0 { CORNER_Y_AREA } else { 5 };
            if i == j {
                let bins = 30usize;
                let r = &ranges[i];
                let w = (r.end - r.start) / bins as f64;
                let mut counts = vec![0u32; bins];
                for p in points {
                    let b = (((p[i] - r.start) / w) as usize).min(bins - 1);
                    counts[b] += 1;
                }
                let top = counts.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.05;
                let mut chart = ChartBuilder::on(area)
                    .margin(4)
                    .margin_top(CORNER_TITLE)
                    .x_label_area_size(x_area)
                    .y_label_area_size(y_area)
                    .build_cartesian_2d(r.clone(), 0.0..top)
                    .map_err(e)?;
                let mut mesh = chart.configure_mesh();
                mesh.disable_mesh()
                    .x_label_formatter(&tick)
                    .x_labels(if bottom { 3 } else { 0 })
                    .y_labels(0)
                    .label_style((FONT, 12))
                    .axis_desc_style((FONT, 15));
                if bottom {
                    mesh.x_desc(names[j].as_str());
                }
                mesh.draw().map_err(e)?;
                chart
                    .draw_series(counts.iter().enumerate().map(|(b, &c)| {
                        let x0 = r.start + b as f64 * w;
                        Rectangle::new([(x0, 0.0), (x0 + w, c as f64)], blue.mix(0.6).filled())
                    }))
                    .map_err(e)?;
                if let Some(m) = marks {
                    chart
                        .draw_series(std::iter::once(PathElement::new(
                            [(m[i], 0.0), (m[i], top)],
                            RED.stroke_width(2),
                        )))
                        .map_err(e)?;
                }
                if let Some(tr) = truth {
                    chart
                        .draw_series(std::iter::once(PathElement::new(
                            [(tr[i], 0.0), (tr[i], top)],
                            BLACK.stroke_width(2),
                        )))
                        .map_err(e)?;
                }
                // Name each diagonal cell, since inner cells carry no axis
                // titles: the parameter, then its median and 90 % interval,
                // in the top margin over the plot.
                let mut v: Vec<f64> = points.iter().map(|p| p[i]).collect();
                v.sort_by(f64::total_cmp);
                let q = |p: f64| crate::inference::summary::quantile(&v, p);
                let x = if j == 0 { CORNER_Y_AREA as i32 } else { 6 };
                area.draw_text(&names[i], &(FONT, 15).into_text_style(area), (x, 3))
                    .map_err(e)?;
                let interval =
                    format!("{} [{}, {}]", short(q(0.5)), short(q(0.05)), short(q(0.95)));
                area.draw_text(&interval, &(FONT, 13).into_text_style(area), (x, 21))
                    .map_err(e)?;
            } else {
                let mut chart = ChartBuilder::on(area)
                    .margin(4)
                    .margin_top(CORNER_TITLE)
                    .x_label_area_size(x_area)
                    .y_label_area_size(y_area)
                    .build_cartesian_2d(ranges[j].clone(), ranges[i].clone())
                    .map_err(e)?;
                let mut mesh = chart.configure_mesh();
                mesh.disable_mesh()
                    .x_label_formatter(&tick)
                    .y_label_formatter(&tick)
                    .x_labels(if bottom { 3 } else { 0 })
                    .y_labels(if j == 0 { 3 } else { 0 })
                    .label_style((FONT, 12))
                    .axis_desc_style((FONT, 15));
                if bottom {
                    mesh.x_desc(names[j].as_str());
                }
                if j == 0 {
                    mesh.y_desc(names[i].as_str());
                }
                mesh.draw().map_err(e)?;
                chart
                    .draw_series(
                        points
                            .iter()
                            .map(|p| Circle::new((p[j], p[i]), 1, blue.mix(0.3).filled())),
                    )
                    .map_err(e)?;
                if let Some(m) = marks {
                    chart
                        .draw_series(std::iter::once(Circle::new((m[j], m[i]), 4, RED.filled())))
                        .map_err(e)?;
                }
                if let Some(tr) = truth {
                    let (x, y) = (&ranges[j], &ranges[i]);
                    chart
                        .draw_series([
                            PathElement::new([(tr[j], y.start), (tr[j], y.end)], BLACK.mix(0.7)),
                            PathElement::new([(x.start, tr[i]), (x.end, tr[i])], BLACK.mix(0.7)),
                        ])
                        .map_err(e)?;
                }
            }
        }
    }
    root.present().map_err(e)
}

/// Trace plots: each parameter against the step for some walkers of every
/// ensemble, one colour per ensemble, with the end of burn-in marked.
/// `traces[k][w]` is series `w` of parameter `k` (one value per step),
/// from ensemble `ensemble[w]`; `names` label the y axes (name and unit,
/// e.g. `u0 (m)`). An SVG (for report.html) keeps each series' lowest and
/// highest value in each of 200 columns of steps; a PNG draws every step.
pub fn trace_figure(
    path: &Path,
    names: &[String],
    traces: &[Vec<Vec<f64>>],
    ensemble: &[usize],
    burn: usize,
    title: &str,
) -> Result<(), FigureError> {
    let ext = checked_extension(path)?;
    let size = (1400, (180 * names.len() as u32).max(500));
    let series: Vec<Vec<Vec<(f64, f64)>>> = traces
        .iter()
        .map(|walkers| {
            walkers
                .iter()
                .map(|t| {
                    let points: Vec<(f64, f64)> =
                        t.iter().enumerate().map(|(s, v)| (s as f64, *v)).collect();
                    if ext == "svg" {
                        decimate(&points, 200)
                    } else {
                        points
                    }
                })
                .collect()
        })
        .collect();
    render!(
        path,
        &ext,
        size,
        draw_traces(names, &series, ensemble, burn, title)
    )
}

fn draw_traces<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    names: &[String],
    traces: &[Vec<Vec<(f64, f64)>>],
    ensemble: &[usize],
    burn: usize,
    title: &str,
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let size = title_size(root.dim_in_pixel().0, title, 24.0);
    let root = root.titled(title, (FONT, size)).map_err(e)?;
    let rows = root.split_evenly((names.len(), 1));
    for (k, area) in rows.iter().enumerate() {
        let last = k == names.len() - 1;
        let steps = traces[k]
            .iter()
            .filter_map(|t| t.last().map(|p| p.0 + 1.0))
            .fold(1.0, f64::max);
        let yr = range(traces[k].iter().flat_map(|t| t.iter().map(|p| p.1)));
        let mut chart = ChartBuilder::on(area)
            .margin(4)
            .x_label_area_size(if last { 45 } else { 5 })
            .y_label_area_size(95)
            .build_cartesian_2d(0.0..steps, yr.clone())
            .map_err(e)?;
        let mut mesh = chart.configure_mesh();
        mesh.disable_mesh()
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_label_formatter(&tick)
            .y_desc(names[k].as_str())
            .x_labels(if last { 8 } else { 0 })
            // Five at most: the nice step (1, 2 or 5 x 10^k) is then at
            // most half the range, so at least two ticks fall on it; three
            // left a range of -0.004..0.004 with the one tick at 0.
            .y_labels(5)
            .label_style((FONT, 12))
            .axis_desc_style((FONT, 15));
        if last {
            mesh.x_desc("step of the sampler");
        }
        mesh.draw().map_err(e)?;
        for (w, t) in traces[k].iter().enumerate() {
            let colour = Palette99::pick(ensemble.get(w).copied().unwrap_or(0)).mix(0.6);
            chart
                .draw_series(LineSeries::new(t.iter().copied(), colour))
                .map_err(e)?;
        }
        chart
            .draw_series(std::iter::once(PathElement::new(
                [(burn as f64, yr.start), (burn as f64, yr.end)],
                BLACK.stroke_width(2),
            )))
            .map_err(e)?;
    }
    root.present().map_err(e)
}

/// The ladder: `e2` and the log-evidence at each step, each step labelled
/// by `models` (e.g. the effect it added), and the record's noise floor in
/// `e2` (`floor`) as a dashed line when given.
pub fn ladder_figure(
    path: &Path,
    models: &[String],
    e2: &[f64],
    log_evidence: &[f64],
    floor: Option<f64>,
) -> Result<(), FigureError> {
    let ext = checked_extension(path)?;
    let size = (1400, 800);
    render!(
        path,
        &ext,
        size,
        draw_ladder(models, e2, log_evidence, floor)
    )
}

fn draw_ladder<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    models: &[String],
    e2: &[f64],
    log_evidence: &[f64],
    floor: Option<f64>,
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let root = root
        .titled("The ladder: adding the best supported effect", (FONT, 26))
        .map_err(e)?;
    let (a, b) = root.split_vertically(root.dim_in_pixel().1 / 2);
    let steps: Vec<(f64, f64)> = e2.iter().enumerate().map(|(k, v)| (k as f64, *v)).collect();
    let z: Vec<(f64, f64)> = log_evidence
        .iter()
        .enumerate()
        .map(|(k, v)| (k as f64, *v))
        .collect();
    let label = |k: usize| models.get(k).cloned().unwrap_or_default();
    for (area, pts, name) in [(&a, &steps, "e2"), (&b, &z, "log-evidence")] {
        let floor = floor.filter(|f| f.is_finite() && name == "e2");
        let ys = range(pts.iter().map(|p| p.1).chain(floor));
        let mut chart = ChartBuilder::on(area)
            .margin(20)
            .x_label_area_size(40)
            .y_label_area_size(90)
            .build_cartesian_2d(-0.3..(pts.len() as f64 - 0.7).max(0.3), ys)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_labels(pts.len().max(1))
            .x_label_formatter(&|x| label(x.round() as usize))
            .y_label_formatter(&tick)
            .y_desc(name)
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 16))
            .draw()
            .map_err(e)?;
        chart
            .draw_series(LineSeries::new(
                pts.iter().copied(),
                RGBColor(214, 39, 40).stroke_width(3),
            ))
            .map_err(e)?;
        chart
            .draw_series(
                pts.iter()
                    .map(|p| Circle::new(*p, 6, RGBColor(214, 39, 40).filled())),
            )
            .map_err(e)?;
        if let Some(f) = floor {
            let x1 = (pts.len() as f64 - 0.7).max(0.3);
            let orange = RGBColor(230, 140, 0);
            chart
                .draw_series(DashedLineSeries::new(
                    [(-0.3, f), (x1, f)],
                    10,
                    6,
                    orange.stroke_width(2),
                ))
                .map_err(e)?
                .label("noise floor (white noise, from second differences)")
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], orange.stroke_width(2))
                });
            legend(&mut chart)?;
        }
    }
    root.present().map_err(e)
}

/// The form of what is missing: the residual force per unit mass (grey
/// dots) and the force the selected terms describe (red), against time,
/// displacement and velocity.
pub fn missing_form_figure(
    path: &Path,
    series: &FormSeries,
    title: &str,
) -> Result<(), FigureError> {
    let ext = checked_extension(path)?;
    render!(path, &ext, (1400, 1000), draw_missing_form(series, title))
}

fn draw_missing_form<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    series: &FormSeries,
    title: &str,
) -> Result<(), String> {
    let (t, u, v) = (&series.t, &series.u, &series.v);
    let (r, f) = (&series.residual, &series.described);
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let size = title_size(root.dim_in_pixel().0, title, 24.0);
    let root = root.titled(title, (FONT, size)).map_err(e)?;
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 / 2);
    let (left, right) = bottom.split_horizontally(bottom.dim_in_pixel().0 / 2);
    let ys = range(r.iter().chain(f).copied());
    let red = RGBColor(214, 39, 40);
    let grey = RGBColor(150, 150, 150);
    for (area, x, name, line) in [
        (&top, t, "time since release (s)", true),
        (&left, u, "displacement u (m)", false),
        (&right, v, "velocity v (m/s)", false),
    ] {
        let mut chart = ChartBuilder::on(area)
            .margin(20)
            .x_label_area_size(45)
            .y_label_area_size(90)
            .build_cartesian_2d(range(x.iter().copied()), ys.clone())
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc(name)
            .y_desc("force per unit mass (m/s^2)")
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 16))
            .draw()
            .map_err(e)?;
        chart
            .draw_series(
                x.iter()
                    .zip(r)
                    .map(|(a, b)| Circle::new((*a, *b), 1, grey.filled())),
            )
            .map_err(e)?
            .label("residual")
            .legend(move |(x, y)| Circle::new((x + 10, y), 3, grey.filled()));
        let described = chart.draw_series(
            x.iter()
                .zip(f)
                .map(|(a, b)| Circle::new((*a, *b), 1, red.filled())),
        );
        if line {
            chart
                .draw_series(LineSeries::new(
                    x.iter().zip(f).map(|(a, b)| (*a, *b)),
                    red.stroke_width(2),
                ))
                .map_err(e)?
                .label("described by the terms")
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], red.stroke_width(2)));
            legend(&mut chart)?;
        } else {
            described.map_err(e)?;
        }
    }
    root.present().map_err(e)
}

/// The restoring-force residual map: the mean residual force per unit mass
/// over bins of displacement (x) and velocity (y), blue negative, red
/// positive, white zero, grey where no sample fell.
pub fn residual_map_figure(
    path: &Path,
    u_edges: &[f64],
    v_edges: &[f64],
    force: &[Vec<f64>],
    title: &str,
) -> Result<(), FigureError> {
    let ext = checked_extension(path)?;
    let size = (1000, 800);
    render!(path, &ext, size, draw_map(u_edges, v_edges, force, title))
}

fn draw_map<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    ue: &[f64],
    ve: &[f64],
    force: &[Vec<f64>],
    title: &str,
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let scale = force
        .iter()
        .flatten()
        .filter(|v| v.is_finite())
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(1e-12);
    let (u0, u1) = (ue[0], ue[ue.len() - 1]);
    let (v0, v1) = (ve[0], ve[ve.len() - 1]);
    let root = root.titled(title, (FONT, 22)).map_err(e)?;
    let (main, bar) = root.split_horizontally(root.dim_in_pixel().0 * 85 / 100);
    let mut chart = ChartBuilder::on(&main)
        .margin(20)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(u0..u1.max(u0 + 1e-9), v0..v1.max(v0 + 1e-9))
        .map_err(e)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .x_desc("u (m)")
        .y_desc("v (m/s)")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()
        .map_err(e)?;
    let colour = |f: f64| -> RGBColor {
        if !f.is_finite() {
            return RGBColor(200, 200, 200);
        }
        let x = (f / scale).clamp(-1.0, 1.0);
        let fade = |c: u8, t: f64| (255.0 - (255.0 - c as f64) * t) as u8;
        if x >= 0.0 {
            RGBColor(fade(214, x), fade(39, x), fade(40, x))
        } else {
            RGBColor(fade(31, -x), fade(119, -x), fade(180, -x))
        }
    };
    for (i, row) in force.iter().enumerate() {
        for (j, f) in row.iter().enumerate() {
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(ue[i], ve[j]), (ue[i + 1], ve[j + 1])],
                    colour(*f).filled(),
                )))
                .map_err(e)?;
        }
    }
    // The colour bar: the residual force each colour stands for.
    let mut cb = ChartBuilder::on(&bar)
        .margin_top(20)
        .margin_bottom(65)
        .margin_right(10)
        .y_label_area_size(75)
        .build_cartesian_2d(0.0..1.0, -scale..scale)
        .map_err(e)?;
    cb.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_label_formatter(&|v| bar_label(*v, scale))
        .y_desc("residual force (N/kg)")
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 15))
        .draw()
        .map_err(e)?;
    let levels = 64;
    cb.draw_series((0..levels).map(|k| {
        let lo = -scale + 2.0 * scale * k as f64 / levels as f64;
        let hi = lo + 2.0 * scale / levels as f64;
        Rectangle::new([(0.0, lo), (1.0, hi)], colour(0.5 * (lo + hi)).filled())
    }))
    .map_err(e)?;
    root.present().map_err(e)
}

/// A colour bar's tick label: `0` where the tick generator's round-off
/// leaves a zero as some 1e-18 (the residual map's bar read "6.9e-18").
///
/// ```
/// use hbis::report::figures::bar_label;
/// assert_eq!(bar_label(6.9e-18, 0.06), "0");
/// assert_eq!(bar_label(-0.02, 0.06), "-2.0e-2");
/// ```
pub fn bar_label(v: f64, scale: f64) -> String {
    if v.abs() <= 1e-9 * scale {
        "0".into()
    } else {
        format!("{v:.1e}")
    }
}

/// The SVG text of a figure: `draw` writes it to a temporary `.svg` file
/// (removed afterwards), as for any output path. For `report.html`.
pub fn svg_text(
    draw: impl FnOnce(&Path) -> Result<(), FigureError>,
) -> Result<String, FigureError> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static COUNT: AtomicUsize = AtomicUsize::new(0);
    let path = std::env::temp_dir().join(format!(
        "hbis-{}-{}.svg",
        std::process::id(),
        COUNT.fetch_add(1, Ordering::Relaxed)
    ));
    let result = draw(&path).and_then(|()| {
        std::fs::read_to_string(&path).map_err(|e| FigureError::Draw {
            path: path.clone(),
            message: e.to_string(),
        })
    });
    let _ = std::fs::remove_file(&path);
    result.map(|svg| compact_svg(&svg))
}

/// The same drawing in fewer bytes: each run of circles that differ only
/// in their centre and radius (a scatter plot's dots, one line each as
/// plotters writes them) becomes one group that carries their style once.
/// A circle that paints only its fill (or only its stroke) looks the same
/// with its `opacity` given as the group's `fill-opacity` (or
/// `stroke-opacity`), which, unlike `opacity`, each circle inherits.
///
/// ```
/// use hbis::report::figures::compact_svg;
///
/// let dot = |x: u32| format!("<circle cx=\"{x}\" cy=\"5\" r=\"1\" opacity=\"0.3\" fill=\"#1F77B4\" stroke=\"none\" stroke-width=\"1\"/>\n");
/// let svg = format!("<svg>\n{}{}</svg>\n", dot(1), dot(2));
/// assert_eq!(
///     compact_svg(&svg),
///     "<svg>\n<g fill=\"#1F77B4\" fill-opacity=\"0.3\" stroke=\"none\">\n<circle cx=\"1\" cy=\"5\" r=\"1\"/>\n<circle cx=\"2\" cy=\"5\" r=\"1\"/>\n</g>\n</svg>\n"
/// );
/// ```
pub fn compact_svg(svg: &str) -> String {
    // (cx, cy, r) and the group's attributes, for a circle that can join one.
    fn dot(line: &str) -> Option<((&str, &str, &str), String)> {
        let inner = line.strip_prefix("<circle ")?.strip_suffix("/>")?;
        let mut attrs = std::collections::BTreeMap::new();
        for pair in inner.split_terminator("\" ") {
            let (key, value) = pair.split_once("=\"")?;
            attrs.insert(key.trim(), value.trim_end_matches('"'));
        }
        let get = |k: &str| attrs.get(k).copied();
        let (cx, cy, r) = (get("cx")?, get("cy")?, get("r")?);
        let (opacity, fill, stroke) = (get("opacity")?, get("fill")?, get("stroke")?);
        if attrs.len() != 7 {
            return None;
        }
        let group = match (fill, stroke) {
            ("none", "none") => return None,
            (f, "none") => format!("fill=\"{f}\" fill-opacity=\"{opacity}\" stroke=\"none\""),
            ("none", s) => format!(
                "fill=\"none\" stroke=\"{s}\" stroke-opacity=\"{opacity}\" stroke-width=\"{}\"",
                get("stroke-width")?
            ),
            _ => return None,
        };
        Some(((cx, cy, r), group))
    }
    let mut out = String::with_capacity(svg.len());
    let mut open: Option<String> = None;
    let lines: Vec<&str> = svg.split_inclusive('\n').collect();
    for (k, line) in lines.iter().enumerate() {
        let this = dot(line.trim_end());
        let joins = |g: &String| this.as_ref().is_some_and(|(_, h)| h == g);
        if open.as_ref().is_some_and(|g| !joins(g)) {
            out.push_str("</g>\n");
            open = None;
        }
        match this {
            Some(((cx, cy, r), group)) => {
                let next = lines.get(k + 1).and_then(|l| dot(l.trim_end()));
                if open.is_none() && next.is_some_and(|(_, h)| h == group) {
                    out.push_str(&format!("<g {group}>\n"));
                    open = Some(group);
                }
                if open.is_some() {
                    out.push_str(&format!("<circle cx=\"{cx}\" cy=\"{cy}\" r=\"{r}\"/>\n"));
                } else {
                    out.push_str(line);
                }
            }
            None => out.push_str(line),
        }
    }
    if open.is_some() {
        out.push_str("</g>\n");
    }
    out
}

/// The lowercase extension (`png` or `svg`), with the font registered.
fn checked_extension(path: &Path) -> Result<String, FigureError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext {
        Some(e) if e == "png" || e == "svg" => {
            if !font_ready() {
                return Err(FigureError::Draw {
                    path: path.to_path_buf(),
                    message: "the embedded font could not be loaded".into(),
                });
            }
            Ok(e)
        }
        _ => Err(FigureError::Format {
            path: path.to_path_buf(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ModelSpec, Params};

    #[test]
    fn draws_test5_as_png_and_svg() {
        let r = Response::simulate(&ModelSpec::FULL, &Params::table_8_1(5).unwrap(), 10.0).unwrap();
        let dir = tempfile::tempdir().unwrap();
        for name in ["f.png", "f.svg"] {
            let p = dir.path().join(name);
            release_test_figure(&p, &r, 0.005, None, "Test 5").unwrap();
            assert!(std::fs::metadata(&p).unwrap().len() > 20_000, "{name}");
        }
        let t: Vec<f64> = (0..10).map(|i| i as f64).collect();
        let m = Measured {
            t: &t,
            a: &t,
            label: "measured",
        };
        release_test_figure(&dir.path().join("m.png"), &r, 0.01, Some(m), "with record").unwrap();
        assert!(matches!(
            release_test_figure(&dir.path().join("f.jpg"), &r, 0.005, None, ""),
            Err(FigureError::Format { .. })
        ));
    }
}

#[cfg(test)]
mod tick_tests {
    #[test]
    fn a_tick_at_a_round_off_below_zero_reads_0() {
        for v in [-1e-17, -0.0, -2.5e-9] {
            let t = super::tick(&v);
            assert!(
                !t.starts_with("-0") || t.parse::<f64>().unwrap() != 0.0,
                "{v}: {t}"
            );
        }
        assert_eq!(super::tick(&-0.0), "0.0");
        assert_eq!(super::tick(&-0.25), "-0.25");
        eprintln!("{} {}", super::tick(&-1e-17), super::tick(&-2.5e-9));
    }
}

/// The series labels in a framed box, top right.
fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|x| x.to_string())
}

/// A title's font size: `max` px, less when the title (a long model name)
/// would run past the figure's edges, taking a glyph as 0.6 em wide (DejaVu
/// Sans' digits are 0.64, its lowercase letters 0.5 to 0.65); 10 px at
/// least.
fn title_size(width: u32, title: &str, max: f64) -> f64 {
    let glyphs = title.chars().count().max(1) as f64;
    ((f64::from(width) - 40.0) / (0.6 * glyphs)).clamp(10.0, max)
}

/// The axes in the figures' style: the descriptions (empty: none), ticks
/// that never read "-0", labels 14 px, descriptions 16 px.
fn styled_axes<DB: DrawingBackend>(
    chart: &mut ChartContext<
        '_,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    x_desc: &str,
    y_desc: &str,
) -> Result<(), String> {
    let mut mesh = chart.configure_mesh();
    mesh.x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16));
    if !x_desc.is_empty() {
        mesh.x_desc(x_desc);
    }
    if !y_desc.is_empty() {
        mesh.y_desc(y_desc);
    }
    mesh.draw().map_err(|x| x.to_string())
}

/// What [`response_band_figure`] draws.
#[derive(Debug, Clone, Copy)]
pub struct ResponseFigure<'a> {
    /// The displacement band over the pairs.
    pub band: &'a crate::inference::summary::Band,
    /// The ground motions `(dt, ag)`.
    pub motions: &'a [(f64, &'a [f64])],
    /// Displacement capacity (m).
    pub capacity: Option<f64>,
    /// The release displacement `u0` the test identified (m; median over
    /// the draws): beyond it the laws are extrapolated.
    pub release: Option<f64>,
    /// Share of pairs whose peak went beyond their `u0`.
    pub share_beyond_release: f64,
    /// Posterior draws simulated.
    pub draws: usize,
}

/// The posterior predictive displacement under the ground motions: the
/// 5-95 % band over the pairs and the median over time, the release
/// displacement beyond which the laws are extrapolated and the capacity
/// (top); the ground accelerations (bottom).
pub fn response_band_figure(path: &Path, fig: &ResponseFigure) -> Result<(), FigureError> {
    let ext = checked_extension(path)?;
    render!(path, &ext, (1400, 900), draw_band(fig))
}

/// The axis of `data` with the levels `±extra` on it when the data would
/// still span at least a quarter of it (else the levels are left off, and
/// the legend says so): a far level would squeeze the data into a sliver.
fn axis_with(data: std::ops::Range<f64>, extra: &[f64]) -> (std::ops::Range<f64>, Vec<bool>) {
    let mut axis = data.clone();
    let mut on = vec![false; extra.len()];
    let mut order: Vec<usize> = (0..extra.len()).collect();
    order.sort_by(|&a, &b| extra[a].abs().total_cmp(&extra[b].abs()));
    for k in order {
        let x = extra[k].abs();
        let with = range([axis.start, axis.end, x, -x].into_iter());
        if (data.end - data.start) >= 0.25 * (with.end - with.start) {
            axis = with;
            on[k] = true;
        }
    }
    (axis, on)
}

fn draw_band<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    fig: &ResponseFigure,
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    let band = fig.band;
    let n_motions = fig.motions.len();
    root.fill(&WHITE).map_err(e)?;
    let title = if n_motions == 1 {
        format!(
            "Response of {} posterior draws to one ground motion (posterior uncertainty only)",
            fig.draws
        )
    } else {
        format!(
            "Response of {} posterior draws paired with {n_motions} ground motions",
            fig.draws
        )
    };
    let root = root.titled(&title, (FONT, 24)).map_err(e)?;
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 * 2 / 3);
    let t1 = band
        .t
        .last()
        .copied()
        .unwrap_or(1.0)
        .max(fig.motions.iter().map(|m| m.0).fold(0.0, f64::max));
    let data = range(band.q05.iter().chain(&band.q95).map(|v| 1e3 * v));
    let levels: Vec<f64> = [fig.release, fig.capacity]
        .iter()
        .map(|x| x.map_or(f64::NAN, |v| 1e3 * v))
        .collect();
    let (ys, on) = axis_with(data, &levels);
    let mut chart = ChartBuilder::on(&top)
        .margin(20)
        .x_label_area_size(40)
        .y_label_area_size(90)
        .build_cartesian_2d(0.0..t1, ys.clone())
        .map_err(e)?;
    styled_axes(&mut chart, "", "isolator displacement u (mm)")?;
    let orange = RGBColor(255, 127, 14);
    if let Some(u0) = fig.release {
        let u0 = 1e3 * u0;
        let label = format!(
            "beyond the release u0 = {u0:.0} mm: extrapolated ({:.0} % of the {} went there){}",
            100.0 * fig.share_beyond_release,
            if n_motions == 1 { "draws" } else { "pairs" },
            if on[0] { "" } else { "; off the axis" }
        );
        // Shaded beyond +-u0 where the axis reaches there.
        let shade: Vec<Rectangle<(f64, f64)>> = [(u0, ys.end), (ys.start, -u0)]
            .into_iter()
            .filter(|(lo, hi)| hi > lo)
            .map(|(lo, hi)| Rectangle::new([(0.0, lo), (t1, hi)], orange.mix(0.12).filled()))
            .collect();
        chart
            .draw_series(shade)
            .map_err(e)?
            .label(label)
            .legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 20, y + 5)], orange.mix(0.3).filled())
            });
    }
    let blue = RGBColor(31, 119, 180);
    let pts = |q: &[f64]| -> Vec<(f64, f64)> {
        band.t.iter().zip(q).map(|(t, v)| (*t, 1e3 * v)).collect()
    };
    let (upper, lower) = (pts(&band.q95), pts(&band.q05));
    let spread = if n_motions == 1 {
        "5-95 % over the draws"
    } else {
        "5-95 % over draws and motions"
    };
    chart
        .draw_series(std::iter::once(Polygon::new(
            upper
                .iter()
                .chain(lower.iter().rev())
                .copied()
                .collect::<Vec<_>>(),
            blue.mix(0.3).filled(),
        )))
        .map_err(e)?
        .label(spread)
        .legend(move |(x, y)| {
            Rectangle::new([(x, y - 5), (x + 20, y + 5)], blue.mix(0.3).filled())
        });
    // The band's edges drawn too: a narrow band stays visible under the
    // median.
    for edge in [upper, lower] {
        chart
            .draw_series(LineSeries::new(edge, blue.mix(0.7).stroke_width(1)))
            .map_err(e)?;
    }
    let navy = RGBColor(8, 48, 107);
    chart
        .draw_series(LineSeries::new(pts(&band.q50), navy.stroke_width(1)))
        .map_err(e)?
        .label("median")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], navy.stroke_width(2)));
    if let Some(c) = fig.capacity {
        let red = RGBColor(214, 39, 40);
        let c = 1e3 * c;
        let lines: Vec<plotters::element::DashedPathElement<_, _>> = if on[1] {
            [c, -c]
                .into_iter()
                .map(|y| {
                    plotters::element::DashedPathElement::new(
                        vec![(0.0, y), (t1, y)],
                        10,
                        6,
                        red.stroke_width(2),
                    )
                })
                .collect()
        } else {
            Vec::new()
        };
        chart
            .draw_series(lines)
            .map_err(e)?
            .label(if on[1] {
                format!("capacity ±{c:.0} mm")
            } else {
                format!("capacity ±{c:.0} mm: off the axis")
            })
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], red.stroke_width(2)));
    }
    legend(&mut chart)?;
    draw_motions(&bottom, fig.motions, t1)?;
    root.present().map_err(e)
}

/// The ground accelerations, at most 20 of a suite (faint when several).
fn draw_motions<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    motions: &[(f64, &[f64])],
    t1: f64,
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    const SHOWN: usize = 20;
    let shown = &motions[..motions.len().min(SHOWN)];
    let ys = range(shown.iter().flat_map(|m| m.1.iter().copied()));
    let desc = match motions.len() {
        1 => "ground acceleration (m/s^2)".to_string(),
        n if n <= SHOWN => format!("ground accel., {n} motions (m/s^2)"),
        n => format!("ground accel., {SHOWN} of {n} motions (m/s^2)"),
    };
    let mut chart = ChartBuilder::on(area)
        .margin(20)
        .x_label_area_size(40)
        .y_label_area_size(90)
        .build_cartesian_2d(0.0..t1, ys)
        .map_err(e)?;
    styled_axes(&mut chart, "time (s)", &desc)?;
    let grey = RGBColor(90, 90, 90);
    let alpha = if shown.len() == 1 { 1.0 } else { 0.25 };
    for &(dt, ag) in shown {
        chart
            .draw_series(LineSeries::new(
                ag.iter().enumerate().map(|(i, a)| (i as f64 * dt, *a)),
                grey.mix(alpha).stroke_width(1),
            ))
            .map_err(e)?;
    }
    Ok(())
}

/// The fragility curve: the probability that the peak displacement
/// exceeds the capacity against the peak ground acceleration, with the
/// 95 % interval at each level.
pub fn fragility_figure(
    path: &Path,
    points: &[crate::predict::FragilityPoint],
    capacity: f64,
    motions: usize,
) -> Result<(), FigureError> {
    let ext = checked_extension(path)?;
    render!(
        path,
        &ext,
        (1200, 800),
        draw_fragility(points, capacity, motions)
    )
}

fn draw_fragility<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    points: &[crate::predict::FragilityPoint],
    capacity: f64,
    motions: usize,
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let pairs = points.first().map_or(0, |p| p.pairs);
    let title = format!(
        "Fragility: P(peak displacement > {:.0} mm), {motions} motion{} x posterior, {pairs} pairs per level",
        1e3 * capacity,
        if motions == 1 { "" } else { "s" }
    );
    let root = root.titled(&title, (FONT, 22)).map_err(e)?;
    let xs = range(points.iter().map(|p| p.pga_g).chain([0.0]));
    let mut chart = ChartBuilder::on(&root)
        .margin(20)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(xs.start.max(0.0)..xs.end, 0.0..1.0)
        .map_err(e)?;
    styled_axes(
        &mut chart,
        "peak ground acceleration (g)",
        "probability of exceeding the capacity (-)",
    )?;
    let blue = RGBColor(31, 119, 180);
    // Caps at both ends of each interval, 16 px wide whatever the axis.
    let cap = move |x: f64, y: f64| {
        EmptyElement::at((x, y)) + PathElement::new([(-8, 0), (8, 0)], blue.stroke_width(2))
    };
    chart
        .draw_series(
            points
                .iter()
                .flat_map(|p| [cap(p.pga_g, p.ci_low), cap(p.pga_g, p.ci_high)]),
        )
        .map_err(e)?;
    chart
        .draw_series(points.iter().map(|p| {
            PathElement::new(
                [(p.pga_g, p.ci_low), (p.pga_g, p.ci_high)],
                blue.stroke_width(2),
            )
        }))
        .map_err(e)?
        .label("95 % interval (motions as clusters)")
        .legend(move |(x, y)| {
            PathElement::new([(x + 10, y - 6), (x + 10, y + 6)], blue.stroke_width(2))
        });
    chart
        .draw_series(LineSeries::new(
            points.iter().map(|p| (p.pga_g, p.p_exceed)),
            blue.stroke_width(2),
        ))
        .map_err(e)?
        .label("share of pairs beyond the capacity")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], blue.stroke_width(2)));
    chart
        .draw_series(
            points
                .iter()
                .map(|p| Circle::new((p.pga_g, p.p_exceed), 5, blue.filled())),
        )
        .map_err(e)?;
    chart
        .configure_series_labels()
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(e)?;
    root.present().map_err(e)
}

/// The distribution of the peak isolator displacement over the draws, the
/// capacity marked, with the share beyond it.
pub fn peak_displacement_figure(
    path: &Path,
    peaks: &[f64],
    capacity: Option<f64>,
    p_exceed: Option<f64>,
) -> Result<(), FigureError> {
    let ext = checked_extension(path)?;
    render!(
        path,
        &ext,
        (1200, 800),
        draw_peaks(peaks, capacity, p_exceed)
    )
}

/// The histogram's x axis (mm) and whether the capacity is on it: the
/// capacity joins the axis only when the draws would still span at least
/// a quarter of it; a capacity far from a narrow distribution would
/// otherwise squeeze the histogram into a sliver.
fn peaks_axis(
    mm: &[f64],
    data: std::ops::Range<f64>,
    capacity_mm: Option<f64>,
) -> (std::ops::Range<f64>, bool) {
    match capacity_mm {
        Some(c) => {
            let with = range(mm.iter().copied().chain([c]));
            if (data.end - data.start) >= 0.25 * (with.end - with.start) {
                (with, true)
            } else {
                (data, false)
            }
        }
        None => (data, false),
    }
}

fn draw_peaks<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    peaks: &[f64],
    capacity: Option<f64>,
    p_exceed: Option<f64>,
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let title = match (capacity, p_exceed) {
        (Some(c), Some(p)) => format!(
            "Peak isolator displacement over {} draws: P(peak > {:.0} mm) = {:.3}",
            peaks.len(),
            1e3 * c,
            p
        ),
        _ => format!("Peak isolator displacement over {} draws", peaks.len()),
    };
    let root = root.titled(&title, (FONT, 24)).map_err(e)?;
    let mm: Vec<f64> = peaks.iter().map(|p| 1e3 * p).collect();
    // Bins over the draws only; the axis also reaches the capacity when
    // that leaves the histogram room.
    let data = range(mm.iter().copied());
    let (xr, on_axis) = peaks_axis(&mm, data.clone(), capacity.map(|c| 1e3 * c));
    let bins = ((mm.len() as f64).sqrt().ceil() as usize).clamp(5, 60);
    let width = (data.end - data.start) / bins as f64;
    let mut counts = vec![0usize; bins];
    for x in &mm {
        let k = (((x - data.start) / width) as usize).min(bins - 1);
        counts[k] += 1;
    }
    let top = counts.iter().copied().max().unwrap_or(1) as f64 * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .margin(20)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(xr.clone(), 0.0..top)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("peak displacement (mm)")
        .y_desc("draws")
        .x_label_formatter(&tick)
        .y_label_formatter(&|y| format!("{y:.0}"))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()
        .map_err(e)?;
    let blue = RGBColor(31, 119, 180);
    chart
        .draw_series(counts.iter().enumerate().map(|(k, c)| {
            let x0 = data.start + k as f64 * width;
            Rectangle::new([(x0, 0.0), (x0 + width, *c as f64)], blue.mix(0.6).filled())
        }))
        .map_err(e)?;
    if let Some(c) = capacity.filter(|_| !on_axis) {
        // Off the axis: named in the legend, with its side.
        let side = if 1e3 * c > data.end { "right" } else { "left" };
        let red = RGBColor(214, 39, 40);
        chart
            .draw_series(std::iter::empty::<Rectangle<(f64, f64)>>())
            .map_err(e)?
            .label(format!(
                "capacity {:.0} mm: off the axis, to the {side}",
                1e3 * c
            ))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], red.stroke_width(3)));
        legend(&mut chart)?;
    }
    if let Some(c) = capacity.filter(|_| on_axis) {
        let red = RGBColor(214, 39, 40);
        chart
            .draw_series(DashedLineSeries::new(
                [(1e3 * c, 0.0), (1e3 * c, top)],
                10,
                6,
                red.stroke_width(3),
            ))
            .map_err(e)?
            .label(format!("capacity {:.0} mm", 1e3 * c))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], red.stroke_width(3)));
        legend(&mut chart)?;
    }
    root.present().map_err(e)
}

#[cfg(test)]
mod layout_tests {
    use super::*;

    /// The demo's case: peaks 195-197 mm against a 300 mm capacity keep
    /// their own axis; a capacity among or near the draws joins it.
    #[test]
    fn a_far_capacity_does_not_squeeze_the_peak_histogram() {
        let mm = [195.0, 196.0, 197.0];
        let data = range(mm.iter().copied());
        let (axis, on) = peaks_axis(&mm, data.clone(), Some(300.0));
        assert!(!on && axis == data, "{axis:?}");
        let (axis, on) = peaks_axis(&mm, data.clone(), Some(196.5));
        assert!(on && axis.start < 195.0 && axis.end > 197.0, "{axis:?}");
        let (axis, on) = peaks_axis(&mm, data.clone(), Some(198.0));
        assert!(on && axis.end > 198.0, "{axis:?}");
        assert_eq!(peaks_axis(&mm, data.clone(), None), (data, false));
    }

    /// A text's box in the SVG, from its anchor, size and rotation, taking
    /// a glyph as 0.6 em wide (DejaVu Sans' digits are 0.64, its lowercase
    /// letters 0.5 to 0.65).
    fn text_boxes(svg: &str) -> Vec<(String, [f64; 4])> {
        let attr = |tag: &str, k: &str| -> Option<String> {
            let start = tag.find(&format!(" {k}=\""))? + k.len() + 3;
            Some(tag[start..].split('"').next()?.to_string())
        };
        let mut out = Vec::new();
        for chunk in svg.split("<text ").skip(1) {
            let (tag, rest) = chunk.split_once('>').unwrap();
            let tag = &format!(" {tag}");
            let text = rest.split("</text>").next().unwrap().trim().to_string();
            if text.is_empty() {
                continue;
            }
            let num = |k: &str| attr(tag, k).unwrap().parse::<f64>().unwrap();
            let (x, y, f) = (num("x"), num("y"), num("font-size"));
            let w = 0.6 * f * text.chars().count() as f64;
            let (x0, x1) = match attr(tag, "text-anchor").as_deref() {
                Some("middle") => (x - w / 2.0, x + w / 2.0),
                Some("end") => (x - w, x),
                _ => (x, x + w),
            };
            let (y0, y1) = match attr(tag, "dy").as_deref() {
                Some("0.76em") => (y, y + f),
                Some("0.5ex") => (y - f / 2.0, y + f / 2.0),
                Some("-0.5ex") => (y - f, y),
                _ => (y - 0.8 * f, y + 0.2 * f),
            };
            let b = match attr(tag, "transform") {
                // rotate(270, x, y): (dx, dy) about (x, y) goes to (dy, -dx).
                Some(t) if t.starts_with("rotate(270") => {
                    [x + (y0 - y), y - (x1 - x), x + (y1 - y), y - (x0 - x)]
                }
                Some(t) => panic!("a text turned by {t}"),
                None => [x0, y0, x1, y1],
            };
            out.push((text, b));
        }
        out
    }

    /// The segments of polylines of `stroke` with `stroke-width` 2.
    fn thick_lines(svg: &str, stroke: &str) -> Vec<[f64; 4]> {
        let mut out = Vec::new();
        for chunk in svg.split("<polyline ").skip(1) {
            let tag = chunk.split("/>").next().unwrap();
            if !tag.contains(&format!("stroke=\"{stroke}\" stroke-width=\"2\"")) {
                continue;
            }
            let pts: Vec<(f64, f64)> = tag
                .split("points=\"")
                .nth(1)
                .unwrap()
                .split('"')
                .next()
                .unwrap()
                .split_whitespace()
                .map(|p| {
                    let (x, y) = p.split_once(',').unwrap();
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect();
            for w in pts.windows(2) {
                out.push([
                    w[0].0.min(w[1].0),
                    w[0].1.min(w[1].1),
                    w[0].0.max(w[1].0),
                    w[0].1.max(w[1].1),
                ]);
            }
        }
        out
    }

    fn overlap(a: &[f64; 4], b: &[f64; 4]) -> bool {
        a[0] < b[2] - 0.5 && b[0] < a[2] - 0.5 && a[1] < b[3] - 0.5 && b[1] < a[3] - 0.5
    }

    /// The corner plot's titles, tick labels and axis titles do not overlap
    /// one another, and the MAP (red) and truth (black) lines of the
    /// histograms stay clear of the titles.
    #[test]
    fn the_corner_plot_has_no_overlaps() {
        let names: Vec<String> = ["u0 (m)", "uF0 (m)", "zeta0 (-)", "f0 (Hz)"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let centre = [0.1076, 0.001768, 0.02877, 0.5644];
        let spread = [3e-4, 2e-5, 8e-4, 1e-3];
        let points: Vec<Vec<f64>> = (0..400)
            .map(|i| {
                (0..4)
                    .map(|k| {
                        let z = ((i * (k + 3)) as f64 * 0.7137).sin()
                            + ((i * 7 + k) as f64 * 1.31).cos();
                        centre[k] + spread[k] * z
                    })
                    .collect()
            })
            .collect();
        // The marks at the histograms' peaks, where the titles would be.
        let svg = svg_text(|p| {
            corner_figure(
                p,
                &names,
                &points,
                Some(&centre),
                Some(&[0.1077, 0.00177, 0.0289, 0.5646]),
                "model: posterior (red: MAP, black: truth)",
            )
        })
        .unwrap();
        let texts = text_boxes(&svg);
        assert!(texts.iter().any(|(t, _)| t == "f0 (Hz)"), "{texts:?}");
        for (i, (a, ba)) in texts.iter().enumerate() {
            for (b, bb) in &texts[i + 1..] {
                assert!(!overlap(ba, bb), "`{a}` {ba:?} overlaps `{b}` {bb:?}");
            }
        }
        let lines: Vec<[f64; 4]> = ["#FF0000", "#000000"]
            .iter()
            .flat_map(|c| thick_lines(&svg, c))
            .collect();
        assert_eq!(lines.len(), 8, "a MAP and a truth line per histogram");
        for l in &lines {
            for (t, b) in &texts {
                assert!(!overlap(l, b), "a mark {l:?} crosses `{t}` {b:?}");
            }
        }
    }

    /// Every trace panel has at least two y ticks, whatever its range
    /// (issue 38: rF0's and zeta0's had one).
    #[test]
    fn each_trace_panel_has_two_y_ticks_at_least() {
        let names = vec!["rF0 (-)".to_string()];
        for (c, h) in [
            (0.0, 0.0042),
            (0.029, 0.0024),
            (0.1075, 0.0006),
            (0.03, 0.011),
        ] {
            let wave: Vec<f64> = (0..300).map(|i| c + h * (0.1 * i as f64).sin()).collect();
            let traces = vec![vec![wave]];
            let svg = svg_text(|p| trace_figure(p, &names, &traces, &[0], 50, "t")).unwrap();
            // The y tick labels: numbers left of the panel.
            let ticks: Vec<String> = text_boxes(&svg)
                .into_iter()
                .filter(|(t, b)| b[2] < 100.0 && t.parse::<f64>().is_ok())
                .map(|(t, _)| t)
                .collect();
            assert!(ticks.len() >= 2, "{c} +- {h}: {ticks:?}");
        }
    }

    /// A long model's trace title stays within the figure (it ran past
    /// both edges for the 13 parameters of velocity friction and offset).
    #[test]
    fn a_long_trace_title_fits_the_figure() {
        let names = vec!["u0 (m)".to_string()];
        let traces = vec![vec![vec![0.1, 0.2, 0.15]]];
        let title =
            "trilinear+lcfm+viscous+velocity-friction+offset: traces, 3 walkers of each of \
                     the 2 ensembles (one colour each; black line: end of burn-in)";
        let svg = svg_text(|p| trace_figure(p, &names, &traces, &[0], 1, title)).unwrap();
        let (_, b) = text_boxes(&svg)
            .into_iter()
            .find(|(t, _)| t.starts_with("trilinear+lcfm"))
            .unwrap();
        assert!(b[0] >= 0.0 && b[2] <= 1400.0, "title box {b:?}");
    }

    /// A long model's corner title stays within the figure (two parameters
    /// draw a 600 px figure; the title of a five-effect model is some
    /// 110 glyphs).
    #[test]
    fn a_long_corner_title_fits_the_figure() {
        let names = vec!["u0 (m)".to_string(), "uy (m)".to_string()];
        let points = vec![vec![0.1, 0.01], vec![0.11, 0.012], vec![0.105, 0.011]];
        let title = "trilinear+lcfm+viscous+velocity-friction+offset: posterior (red: MAP, \
                     black: truth; titles: median [90 % interval])";
        let svg = svg_text(|p| corner_figure(p, &names, &points, None, None, title)).unwrap();
        let (_, b) = text_boxes(&svg)
            .into_iter()
            .find(|(t, _)| t.starts_with("trilinear+lcfm"))
            .unwrap();
        assert!(b[0] >= 0.0 && b[2] <= 600.0, "title box {b:?}");
    }

    /// The fit figure's SVG keeps two points per pixel column: a long
    /// record's stays small, with its peak.
    #[test]
    fn the_fit_svg_of_a_long_record_is_decimated_with_its_peaks() {
        let n = 40_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.005).collect();
        let a: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, t)| (3.0 * t).sin() + if i == 12_345 { 7.5 } else { 0.0 })
            .collect();
        let model: Vec<f64> = t.iter().map(|t| (3.0 * t).sin()).collect();
        let svg =
            svg_text(|p| fit_figure(p, &t, &a, &model, &Overlays::default(), "long")).unwrap();
        assert!(svg.len() < 250_000, "{} bytes", svg.len());
        let points: usize = svg
            .split("points=\"")
            .skip(1)
            .map(|p| p.split('"').next().unwrap().split_whitespace().count())
            .sum();
        assert!(points < 3 * 2 * 1600 + 100, "{points} points");
    }
}
