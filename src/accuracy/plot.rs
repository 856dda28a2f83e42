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
    let ms = |r: &Row| (r.gpu_s * 1e3).max(1e-3);
    let err = |r: &Row| r.error.flip_mean.max(FLOOR);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for r in rows {
        (x0, x1) = (x0.min(ms(r)), x1.max(ms(r)));
        (y0, y1) = (y0.min(err(r)), y1.max(err(r)));
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
    let ((x0, x1), (y0, y1)) = (widen(x0, x1), widen(y0, y1));
    let mut chart = ChartBuilder::on(&area)
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

    let mut parameters: Vec<Parameter> = Vec::new();
    for r in rows {
        if !parameters.contains(&r.parameter) {
            parameters.push(r.parameter);
        }
    }
    for p in parameters {
        let c = colour(p);
        let pts: Vec<(f64, f64)> =
            rows.iter().filter(|r| r.parameter == p).map(|r| (ms(r), err(r))).collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
            .map_err(draw_error)?
            .label(p.name())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        chart.draw_series(pts.iter().map(|&xy| Circle::new(xy, 4, c.filled()))).map_err(draw_error)?;
        // Each point's value beside it, above and to the right of the marker.
        chart
            .draw_series(rows.iter().filter(|r| r.parameter == p).map(|r| {
                EmptyElement::at((ms(r), err(r)))
                    + Text::new(r.value.clone(), (6, -16), ("sans-serif", 12).into_font().color(&c))
            }))
            .map_err(draw_error)?;
    }
    if let Some(b) = rows.iter().find(|r| r.base) {
        chart
            .draw_series(std::iter::once(Circle::new((ms(b), err(b)), 9, BLACK.stroke_width(2))))
            .map_err(draw_error)?;
    }
    let mut front: Vec<(f64, f64)> = summary.pareto.iter().map(|&i| (ms(&rows[i]), err(&rows[i]))).collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    front.dedup();
    if front.len() > 1 {
        chart
            .draw_series(DashedLineSeries::new(front, 6, 4, BLACK.stroke_width(1)))
            .map_err(draw_error)?
            .label("Pareto front")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(1)));
    }
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
