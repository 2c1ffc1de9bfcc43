//! The convergence plot: relative error against render time, log-log, one colour per
//! curve (an estimator setting), its two-half noise estimate dashed, and a `t^-1/2`
//! guide. Drawn with plotters into a buffer (text in egui's bundled Ubuntu font, so no
//! system fonts are needed) and written as PNG. It draws the points it is given and
//! knows nothing of how they were measured.

use super::ReportError;
use crate::export::write_png_rgb;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// One estimator setting's curves.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    /// Legend text.
    pub label: String,
    /// `(seconds, relative error against the reference)`: a solid line with dots.
    pub error: Vec<(f64, f64)>,
    /// `(seconds, the film's own error estimate)`: dashed.
    pub estimate: Vec<(f64, f64)>,
}

/// Register the bundled font for plotters' "sans-serif" once.
fn fonts() -> Result<(), ReportError> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        )
        .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(ReportError::PlotFont)
    }
}

/// Plot size, pixels.
const SIZE: (u32, u32) = (960, 640);

/// Write the `converge.png` plot of `curves` to `path` (960 x 640 pixels).
pub fn write_convergence_png(
    path: &Path,
    title: &str,
    curves: &[Curve],
) -> Result<(), ReportError> {
    fonts()?;
    let (w, h) = SIZE;
    let mut buf = vec![0u8; (w * h * 3) as usize];
    draw(&mut buf, title, curves).map_err(|e| ReportError::Plot(e.to_string()))?;
    write_png_rgb(path, w as usize, h as usize, buf)?;
    Ok(())
}

fn draw(buf: &mut [u8], title: &str, curves: &[Curve]) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::with_buffer(buf, SIZE).into_drawing_area();
    root.fill(&WHITE)?;
    let positive = |v: f64| v.is_finite() && v > 0.0;
    let xs: Vec<f64> = curves
        .iter()
        .flat_map(|c| &c.error)
        .map(|p| p.0)
        .filter(|&v| positive(v))
        .collect();
    let ys: Vec<f64> = curves
        .iter()
        .flat_map(|c| c.error.iter().chain(&c.estimate))
        .map(|p| p.1)
        .filter(|&v| positive(v))
        .collect();
    if xs.is_empty() || ys.is_empty() {
        root.draw(&Text::new(
            "no data",
            (20, 20),
            ("sans-serif", 20).into_font(),
        ))?;
        root.present()?;
        return Ok(());
    }
    let fold = |v: &[f64], f: fn(f64, f64) -> f64, init: f64| v.iter().cloned().fold(init, f);
    let (x_lo, x_hi) = (
        fold(&xs, f64::min, f64::INFINITY) / 1.3,
        fold(&xs, f64::max, 0.0) * 1.3,
    );
    let (y_lo, y_hi) = (
        fold(&ys, f64::min, f64::INFINITY) / 1.6,
        fold(&ys, f64::max, 0.0) * 1.6,
    );
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d((x_lo..x_hi).log_scale(), (y_lo..y_hi).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("render time, s (error measurements not counted)")
        .y_desc("relative L2 error of the cube")
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .x_label_formatter(&|v| format!("{v}"))
        .draw()?;

    // The t^-1/2 guide through the middle of the first curve.
    if let Some(first) = curves.first() {
        let curve: Vec<&(f64, f64)> = first.error.iter().filter(|p| positive(p.1)).collect();
        if let Some((mid_s, mid_error)) = curve.get(curve.len() / 2) {
            let k = mid_error * mid_s.sqrt();
            let guide: Vec<(f64, f64)> = (0..=40)
                .map(|i| {
                    let x = x_lo * (x_hi / x_lo).powf(i as f64 / 40.0);
                    (x, k / x.sqrt())
                })
                .filter(|p| p.1 > y_lo && p.1 < y_hi)
                .collect();
            chart
                .draw_series(DashedLineSeries::new(
                    guide,
                    3,
                    5,
                    RGBColor(140, 140, 140).stroke_width(2),
                ))?
                .label("t^-1/2")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], RGBColor(140, 140, 140))
                });
        }
    }

    // Legend lines saying what solid and dashed mean.
    chart
        .draw_series(LineSeries::new(
            Vec::<(f64, f64)>::new(),
            BLACK.stroke_width(2),
        ))?
        .label("solid: error against the reference (fitted slope, last value)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
        .label("dashed: the film's own noise estimate (two halves, no reference)")
        .legend(|(x, y)| Rectangle::new([(x, y), (x + 7, y + 1)], BLACK.filled()));
    for (i, c) in curves.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        let curve: Vec<(f64, f64)> = c.error.iter().copied().filter(|p| positive(p.1)).collect();
        let estimate: Vec<(f64, f64)> = c
            .estimate
            .iter()
            .copied()
            .filter(|p| positive(p.1))
            .collect();
        chart
            .draw_series(LineSeries::new(curve.clone(), colour.stroke_width(3)))?
            .label(c.label.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(3))
            });
        chart.draw_series(curve.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
        chart.draw_series(DashedLineSeries::new(
            estimate,
            6,
            4,
            colour.stroke_width(1),
        ))?;
    }
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    root.present()?;
    Ok(())
}
