//! The colour bar drawn under every image: the colour ramp the image uses, round ticks
//! on its scale (linear or log, from [`axes::bar_ticks`]) and the unit, so a value can be
//! read off any picture. Its accessible label states the range and the unit.

use super::axes::{self, BarScale};
use eframe::egui::{self, Color32, Rect, Sense, Vec2, pos2};

/// A colour bar: what it is of, its ramp and scale, its unit.
pub(crate) struct ColorBar<'a> {
    /// What the bar is of, for its accessible label ("time slice").
    pub of: &'a str,
    /// The colour at a fraction of the bar in `[0, 1]`: the image's own mapping.
    pub ramp: &'a dyn Fn(f64) -> [u8; 3],
    pub scale: BarScale,
    /// The unit of the tick values ("W m⁻² sr⁻¹ s", "ns", "m").
    pub unit: &'a str,
    /// A second row of tick labels under the first: its unit and the conversion from the
    /// first row's values (the rainbow bar: optical path in m under arrival time in ns).
    pub second: Option<(&'a str, &'a dyn Fn(f64) -> f64)>,
    /// Said on hover: how the range was chosen (exposure, percentile).
    pub note: &'a str,
}

/// Height of one row of tick labels, points.
const LABEL_H: f32 = 14.0;
/// Height of the colour strip, points.
const STRIP_H: f32 = 10.0;
/// Font size of the ticks and the unit.
const TICK_FONT: f32 = 12.0;

impl ColorBar<'_> {
    /// Height the bar takes.
    pub(crate) fn height(&self) -> f32 {
        STRIP_H + 2.0 + LABEL_H * if self.second.is_some() { 2.0 } else { 1.0 }
    }

    /// "colour bar: time slice, 0 … 3.2e-3 W m⁻² sr⁻¹ s, linear".
    pub(crate) fn describe(&self) -> String {
        let (lo, hi, kind) = match self.scale {
            BarScale::Linear { lo, hi } => (lo, hi, "linear"),
            BarScale::Log { lo, hi } => (lo, hi, "log"),
        };
        format!(
            "colour bar: {}, {} … {}, {kind}",
            self.of,
            axes::format_value(lo, ""),
            axes::format_value(hi, self.unit)
        )
    }

    /// Draw the bar `width` wide at the cursor.
    pub(crate) fn ui(&self, ui: &mut egui::Ui, width: f32) -> egui::Response {
        let (rect, response) =
            ui.allocate_exact_size(Vec2::new(width, self.height()), Sense::hover());
        let painter = ui.painter_at(rect.expand(2.0));
        let font = egui::FontId::proportional(TICK_FONT);
        let text_color = ui.visuals().text_color();
        let weak = ui.visuals().weak_text_color();
        // The unit at the strip's right end; the strip takes the rest.
        let unit = painter.layout_no_wrap(self.unit.to_owned(), font.clone(), text_color);
        let strip_right = (rect.right() - unit.size().x - 6.0).max(rect.left() + 20.0);
        painter.galley(
            pos2(
                strip_right + 4.0,
                rect.top() + (STRIP_H - unit.size().y) / 2.0,
            ),
            unit,
            text_color,
        );
        let strip = Rect::from_min_max(rect.min, pos2(strip_right, rect.top() + STRIP_H));
        let segments = (strip.width() / 2.0).clamp(8.0, 256.0) as usize;
        for k in 0..segments {
            let f0 = k as f32 / segments as f32;
            let f1 = (k + 1) as f32 / segments as f32;
            let [r, g, b] = (self.ramp)((k as f64 + 0.5) / segments as f64);
            painter.rect_filled(
                Rect::from_min_max(
                    pos2(strip.left() + f0 * strip.width(), strip.top()),
                    pos2(strip.left() + f1 * strip.width() + 0.5, strip.bottom()),
                ),
                0.0,
                Color32::from_rgb(r, g, b),
            );
        }
        painter.rect_stroke(strip, 0.0, (1.0, weak), egui::StrokeKind::Outside);
        let describe = self.describe();
        response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, &describe));
        if !self.scale.is_valid() {
            return response;
        }
        let ticks = axes::bar_ticks(self.scale, strip.width() as f64, 64.0);
        let mut last_right = f32::NEG_INFINITY;
        for (f, label) in ticks {
            let x = strip.left() + f as f32 * strip.width();
            painter.line_segment(
                [pos2(x, strip.bottom() - 3.0), pos2(x, strip.bottom() + 2.0)],
                (1.0, text_color),
            );
            let mut rows = vec![label];
            if let Some((unit2, convert)) = self.second {
                let v = self.scale.value(f);
                rows.push(format!("{} {unit2}", axes::format_sig(convert(v), 3)));
            }
            let galleys: Vec<_> = rows
                .into_iter()
                .enumerate()
                .map(|(i, t)| {
                    painter.layout_no_wrap(t, font.clone(), if i == 0 { text_color } else { weak })
                })
                .collect();
            let w = galleys.iter().fold(0.0f32, |a, g| a.max(g.size().x));
            let left = (x - w / 2.0).clamp(rect.left(), (strip_right - w).max(rect.left()));
            if left < last_right + 4.0 {
                continue;
            }
            last_right = left + w;
            for (i, g) in galleys.into_iter().enumerate() {
                let y = strip.bottom() + 2.0 + i as f32 * LABEL_H;
                painter.galley(pos2(left, y), g, text_color);
            }
        }
        if self.note.is_empty() {
            response
        } else {
            response.on_hover_text(self.note)
        }
    }
}
