//! The sweep drawn as error against time (plotters): FLIP mean over GPU kernel time, both
//! on log scales, one line per parameter through its values in the order tried, the base
//! setting ringed and the Pareto front drawn as a dashed black line. Drawn into memory (an
//! RGB buffer or an SVG string) so that the files are written whole or not at all.

use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{Parameter, Row, Summary};
use crate::error::{Error, Result};

/// Size of the plot in pixels.
pub const SIZE: (u32, u32) = (960, 640);

/// Errors below this are drawn at it (a log axis has no zero).
const FLOOR: f64 = 1e-5;

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is compiled in: the plot needs no fonts installed on the machine.
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .unwrap_or_else(|_| panic!("the embedded DejaVu Sans is a valid font"));
    });
}

fn colour(p: Parameter) -> RGBColor {
    match p {
        Parameter::Spp => RGBColor(31, 119, 180),
        Parameter::MaxDepth => RGBColor(255, 127, 14),
        Parameter::Precision => RGBColor(44, 160, 44),
        Parameter::Offset => RGBColor(214, 39, 40),
        Parameter::TableResolution => RGBColor(148, 103, 189),
        Parameter::Accel => RGBColor(140, 86, 75),
    }
}

fn draw_error(e: impl std::fmt::Display) -> Error {
    Error::Options(format!("cannot draw the plot: {e}"))
}

/// The chart [`draw`] plots into: log scales on both axes.
type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;

/// Where `r` is plotted along the time axis: its GPU kernel time in milliseconds, at least
/// a microsecond (a log axis has no zero).
fn time_ms(r: &Row) -> f64 {
    (r.gpu_s * 1e3).max(1e-3)
}

/// Where `r` is plotted along the error axis: its FLIP mean, at least [`FLOOR`].
fn plotted_error(r: &Row) -> f64 {
    r.error.flip_mean.max(FLOOR)
}

/// The time and error ranges of the axes: those of `rows` (or a default when there are
/// none) with a margin of a fifth of a decade either side, and a decade at least.
fn axis_ranges(rows: &[Row]) -> ((f64, f64), (f64, f64)) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for r in rows {
        (x0, x1) = (x0.min(time_ms(r)), x1.max(time_ms(r)));
        (y0, y1) = (y0.min(plotted_error(r)), y1.max(plotted_error(r)));
    }
    if rows.is_empty() {
        (x0, x1, y0, y1) = (1.0, 10.0, 1e-3, 1e-1);
    }
    // A margin of a fifth of a decade either side, and a decade at least on each axis.
    let widen = |lo: f64, hi: f64| {
        let (lo, hi) = (lo / 1.6, hi * 1.6);
        if hi / lo < 10.0 {
            let mid = (lo * hi).sqrt();
            (mid / 10f64.sqrt(), mid * 10f64.sqrt())
        } else {
            (lo, hi)
        }
    };
    (widen(x0, x1), widen(y0, y1))
}

/// The chart on `area`, titled `title`, with log axes over the ranges `x` and `y` and its
/// mesh, labels and axis descriptions drawn.
fn chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    title: &str,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Result<Chart<'a, DB>>
where
    DB::ErrorType: 'static,
{
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(draw_error)?;
    chart
        .configure_mesh()
        .x_desc("GPU kernel time (ms, log)")
        .y_desc("FLIP mean against the reference (log)")
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .light_line_style(RGBColor(238, 238, 238))
        .x_label_formatter(&|&v| match v {
            v if v >= 10.0 => format!("{v:.0}"),
            v if v >= 1.0 => format!("{v:.1}"),
            v => format!("{v:.2}"),
        })
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(draw_error)?;
    Ok(chart)
}

/// Draws one line per parameter of `rows`, in the order they first appear, through its
/// values in the order tried: the line (with its legend entry), a marker per value and the
/// value's text beside it.
fn draw_parameters<DB: DrawingBackend>(chart: &mut Chart<'_, DB>, rows: &[Row]) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let mut parameters: Vec<Parameter> = Vec::new();
    for r in rows {
        if !parameters.contains(&r.parameter) {
            parameters.push(r.parameter);
        }
    }
    for p in parameters {
        let c = colour(p);
        let pts: Vec<(f64, f64)> =
            rows.iter().filter(|r| r.parameter == p).map(|r| (time_ms(r), plotted_error(r))).collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
            .map_err(draw_error)?
            .label(p.name())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        chart.draw_series(pts.iter().map(|&xy| Circle::new(xy, 4, c.filled()))).map_err(draw_error)?;
        // Each point's value beside it, above and to the right of the marker.
        chart
            .draw_series(rows.iter().filter(|r| r.parameter == p).map(|r| {
                EmptyElement::at((time_ms(r), plotted_error(r)))
                    + Text::new(r.value.clone(), (6, -16), ("sans-serif", 12).into_font().color(&c))
            }))
            .map_err(draw_error)?;
    }
    Ok(())
}

/// Draws the ring around the base setting (if `rows` has one) and the Pareto front of
/// `summary` as a dashed black line with its legend entry (if it has two points or more).
fn draw_base_and_front<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    rows: &[Row],
    summary: &Summary,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    if let Some(b) = rows.iter().find(|r| r.base) {
        chart
            .draw_series(std::iter::once(Circle::new(
                (time_ms(b), plotted_error(b)),
                9,
                BLACK.stroke_width(2),
            )))
            .map_err(draw_error)?;
    }
    let mut front: Vec<(f64, f64)> =
        summary.pareto.iter().map(|&i| (time_ms(&rows[i]), plotted_error(&rows[i]))).collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    front.dedup();
    if front.len() > 1 {
        chart
            .draw_series(DashedLineSeries::new(front, 6, 4, BLACK.stroke_width(1)))
            .map_err(draw_error)?
            .label("Pareto front")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(1)));
    }
    Ok(())
}

/// Draws the whole plot of `rows` onto `area`: the axes, the parameters' lines, the base
/// setting and the Pareto front, and the legend.
fn draw<DB: DrawingBackend>(
    area: DrawingArea<DB, Shift>,
    title: &str,
    rows: &[Row],
    summary: &Summary,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    area.fill(&WHITE).map_err(draw_error)?;
    let (x, y) = axis_ranges(rows);
    let mut chart = chart(&area, title, x, y)?;
    draw_parameters(&mut chart, rows)?;
    draw_base_and_front(&mut chart, rows, summary)?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(draw_error)?;
    area.present().map_err(draw_error)?;
    Ok(())
}

/// The plot as an RGB image.
pub fn png(title: &str, rows: &[Row], summary: &Summary) -> Result<image::RgbImage> {
    register_font();
    let mut buf = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    draw(BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area(), title, rows, summary)?;
    Ok(image::RgbImage::from_raw(SIZE.0, SIZE.1, buf).expect("the buffer has the plot's size"))
}

/// The plot as an SVG document.
pub fn svg(title: &str, rows: &[Row], summary: &Summary) -> Result<String> {
    register_font();
    let mut out = String::new();
    draw(SVGBackend::with_string(&mut out, SIZE).into_drawing_area(), title, rows, summary)?;
    Ok(out)
}
