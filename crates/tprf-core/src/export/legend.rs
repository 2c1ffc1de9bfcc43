//! A picture's legend: the colour bar under an exported image, its scale's ends and
//! middle written in the values' unit, and a line saying what the picture is (a time
//! slice's time, a depth image's meaning). What a PNG needs to be read on its own.

use crate::budget::BudgetError;

/// The colour scale drawn under an image: `ramp(t)` for `t` from 0 (at `lo`) to 1 (at
/// `hi`), linear, or with `log` over the decades from `lo` to `hi` (the middle label is
/// then their geometric mean); in `unit`, with a note.
pub struct Legend<'a> {
    pub ramp: &'a dyn Fn(f64) -> [u8; 3],
    pub lo: f64,
    pub hi: f64,
    pub log: bool,
    pub unit: &'a str,
    pub note: &'a str,
}

/// Why a legend could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum LegendError {
    #[error(transparent)]
    Budget(#[from] BudgetError),
    #[error("cannot draw a legend: {0}")]
    Draw(String),
}

/// Height of the legend's strip, pixels.
pub const LEGEND_H: usize = 56;
/// Narrowest picture with a legend: a smaller image is enlarged by a whole factor
/// (pixels stay square and sharp) so the legend's labels fit.
pub const LEGEND_MIN_W: usize = 360;

/// The image `rgb` (`w x h`, RGB8) enlarged by the smallest whole factor that makes it
/// at least [`LEGEND_MIN_W`] wide, over a white strip holding its colour bar with `lo`,
/// the middle and `hi` written in `unit`, and the note. Returns the picture and its
/// size; an `rgb` of the wrong length is returned as it is.
pub fn with_legend(
    rgb: Vec<u8>,
    w: usize,
    h: usize,
    legend: &Legend,
) -> Result<(Vec<u8>, usize, usize), LegendError> {
    if w == 0 || h == 0 || rgb.len() != 3 * w * h {
        return Ok((rgb, w, h));
    }
    let k = LEGEND_MIN_W.div_ceil(w).max(1);
    let (cw, ch) = (w * k, h * k + LEGEND_H);
    crate::budget::check(
        (3 * cw * ch) as u64,
        "a picture with its legend",
        format_args!("{cw} x {ch} pixels"),
    )?;
    let mut out = vec![255u8; 3 * cw * ch];
    for y in 0..h * k {
        for x in 0..w * k {
            let src = 3 * ((y / k) * w + x / k);
            let dst = 3 * (y * cw + x);
            out[dst..dst + 3].copy_from_slice(&rgb[src..src + 3]);
        }
    }
    // The bar: a quarter of the strip's height, inset from the edges.
    let (bx0, bx1) = (12, cw.saturating_sub(12).max(13));
    let (by0, by1) = (h * k + 6, h * k + 20);
    for x in bx0..bx1 {
        let c = (legend.ramp)((x - bx0) as f64 / (bx1 - bx0 - 1).max(1) as f64);
        for y in by0..by1 {
            let dst = 3 * (y * cw + x);
            out[dst..dst + 3].copy_from_slice(&c);
        }
    }
    draw_text(&mut out, (cw, ch), (bx0, bx1, by1), legend)
        .map_err(|e| LegendError::Draw(e.to_string()))?;
    Ok((out, cw, ch))
}

/// `v` to four significant digits: `0.6123`, `12.35`, `1.235e4`.
pub fn four_digits(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let mag = v.abs().log10().floor();
    if !(-3.0..4.0).contains(&mag) {
        return format!("{v:.3e}");
    }
    format!("{v:.*}", (3.0 - mag).max(0.0) as usize)
}

/// The labels of [`with_legend`]'s bar (plotters, in egui's bundled Ubuntu font: no
/// system font needed).
fn draw_text(
    buf: &mut [u8],
    (cw, ch): (usize, usize),
    (bx0, bx1, by1): (usize, usize, usize),
    legend: &Legend,
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    static FONT: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *FONT.get_or_init(|| {
        plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        )
        .is_ok()
    });
    if !ok {
        return Err("no font".into());
    }
    let root = BitMapBackend::with_buffer(buf, (cw as u32, ch as u32)).into_drawing_area();
    let font = ("sans-serif", 13).into_font().color(&BLACK);
    let label = |v: f64| format!("{} {}", four_digits(v), legend.unit);
    let middle = if legend.log {
        (legend.lo * legend.hi).sqrt()
    } else {
        0.5 * (legend.lo + legend.hi)
    };
    let y = (by1 + 2) as i32;
    let (x0, x1) = (bx0 as i32, bx1 as i32);
    for (text, x, h) in [
        (label(legend.lo), x0, HPos::Left),
        (label(middle), (x0 + x1) / 2, HPos::Center),
        (label(legend.hi), x1, HPos::Right),
    ] {
        root.draw(&Text::new(
            text,
            (x, y),
            font.clone().pos(Pos::new(h, VPos::Top)),
        ))?;
    }
    root.draw(&Text::new(
        legend.note.to_string(),
        ((x0 + x1) / 2, y + 17),
        font.pos(Pos::new(HPos::Center, VPos::Top)),
    ))?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_keep_four_digits() {
        assert_eq!(four_digits(0.61234), "0.6123");
        assert_eq!(four_digits(12.346), "12.35");
        assert_eq!(four_digits(12346.0), "1.235e4");
    }

    /// A log legend's middle label is the geometric mean of its ends: 1e-3 .. 1 has
    /// 0.03162 in the middle, drawn in dark pixels under the bar's centre; a linear one
    /// 0.5005 (different text, so different pixels there).
    #[test]
    fn a_log_legend_labels_its_middle_by_the_geometric_mean() {
        let grey = |t: f64| [(255.0 * t) as u8; 3];
        let draw = |log| {
            let l = Legend {
                ramp: &grey,
                lo: 1e-3,
                hi: 1.0,
                log,
                unit: "W",
                note: "",
            };
            with_legend(vec![0u8; 3 * 4 * 2], 4, 2, &l).unwrap()
        };
        let (lin, w, h) = draw(false);
        let (log, w2, h2) = draw(true);
        assert_eq!((w, h), (360, 2 * 90 + LEGEND_H));
        assert_eq!((w2, h2), (w, h));
        // The bar's ends: the ramp's 0 and 1.
        let px = |img: &[u8], x: usize, y: usize| img[3 * (y * w + x)];
        assert_eq!(px(&lin, 12, 190), 0);
        assert_eq!(px(&lin, 347, 190), 255);
        // The middle label's band differs, the outer labels' do not.
        let band = |img: &[u8], x0: usize, x1: usize| -> Vec<u8> {
            (203..220)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .map(|(x, y)| px(img, x, y))
                .collect()
        };
        assert_ne!(band(&lin, 150, 210), band(&log, 150, 210));
        assert_eq!(band(&lin, 12, 80), band(&log, 12, 80));
        assert_eq!(four_digits((1e-3f64 * 1.0).sqrt()), "0.03162");
    }

    #[test]
    fn a_wrong_length_is_returned_as_is() {
        let grey = |_: f64| [0u8; 3];
        let l = Legend {
            ramp: &grey,
            lo: 0.0,
            hi: 1.0,
            log: false,
            unit: "",
            note: "",
        };
        let (img, w, h) = with_legend(vec![1, 2], 4, 2, &l).unwrap();
        assert_eq!((img, w, h), (vec![1, 2], 4, 2));
    }
}
