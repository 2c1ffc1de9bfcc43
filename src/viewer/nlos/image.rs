//! An image drawn with its axes in metres: round ticks ([`axes::axis_marks`]) under it
//! and at its left, each axis named, and the image clickable (its accessible label
//! names it for tests and screen readers).

use crate::viewer::axes;
use eframe::egui::{self, Align2, Color32, FontId, Rect, Sense, TextureHandle, Vec2, pos2};

/// Room left of the image for the vertical ticks, points.
const LEFT: f32 = 46.0;
/// Room under the image for the horizontal ticks and the axis name, points.
const BOTTOM: f32 = 32.0;
/// Labelled ticks at least this far apart, points.
const LABEL_PX: f64 = 56.0;

/// An image and its axes.
pub(super) struct MetreImage<'a> {
    pub texture: &'a TextureHandle,
    /// Accessible label ("wall slice", "front projection").
    pub label: &'a str,
    /// The image's left and right edges, bottom and top edges, metres.
    pub x_m: [f64; 2],
    pub y_m: [f64; 2],
    pub x_name: &'a str,
    pub y_name: &'a str,
}

impl MetreImage<'_> {
    /// The room the axes take around an image of `size`.
    pub(super) fn outer_size(size: Vec2) -> Vec2 {
        size + Vec2::new(LEFT, BOTTOM)
    }

    /// Draw the image `size` large (plus its axes' room) at the cursor; the image's
    /// response.
    pub(super) fn ui(&self, ui: &mut egui::Ui, size: Vec2) -> egui::Response {
        let (outer, _) = ui.allocate_exact_size(Self::outer_size(size), Sense::hover());
        let rect = Rect::from_min_size(outer.min + Vec2::new(LEFT, 0.0), size);
        let response = ui.interact(rect, ui.scope_id().with(self.label), Sense::click());
        let label = self.label.to_owned();
        response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, &label));
        let painter = ui.painter_at(outer.expand(2.0));
        painter.image(
            self.texture.id(),
            rect,
            Rect::from_min_max(pos2(0.0, 0.0), pos2(1.0, 1.0)),
            Color32::WHITE,
        );
        let text = ui.visuals().text_color();
        let weak = ui.visuals().weak_text_color();
        let font = FontId::proportional(11.0);
        let stroke = egui::Stroke::new(1.0, weak);
        // Horizontal axis.
        let [x0, x1] = self.x_m;
        let marks = axes::axis_marks(x0, x1, rect.width() as f64, LABEL_PX);
        let major_step = largest_step(&marks);
        for m in marks {
            let x = rect.left() + ((m.value - x0) / (x1 - x0)) as f32 * rect.width();
            let major = m.step == major_step;
            let len = if major { 5.0 } else { 2.5 };
            painter.line_segment(
                [pos2(x, rect.bottom()), pos2(x, rect.bottom() + len)],
                stroke,
            );
            if major {
                painter.text(
                    pos2(x, rect.bottom() + 6.0),
                    Align2::CENTER_TOP,
                    axes::format_tick(m.value, m.step),
                    font.clone(),
                    text,
                );
            }
        }
        painter.text(
            pos2(rect.center().x, rect.bottom() + BOTTOM),
            Align2::CENTER_BOTTOM,
            self.x_name,
            font.clone(),
            text,
        );
        // Vertical axis: the top edge is y_m[1].
        let [y0, y1] = self.y_m;
        let marks = axes::axis_marks(y0, y1, rect.height() as f64, LABEL_PX * 0.6);
        let major_step = largest_step(&marks);
        for m in marks {
            let y = rect.bottom() - ((m.value - y0) / (y1 - y0)) as f32 * rect.height();
            let major = m.step == major_step;
            let len = if major { 5.0 } else { 2.5 };
            painter.line_segment([pos2(rect.left() - len, y), pos2(rect.left(), y)], stroke);
            if major {
                painter.text(
                    pos2(rect.left() - 7.0, y),
                    Align2::RIGHT_CENTER,
                    axes::format_tick(m.value, m.step),
                    font.clone(),
                    text,
                );
            }
        }
        let name = painter.layout_no_wrap(self.y_name.to_owned(), font, text);
        // The vertical axis's name turned a quarter turn, along the left edge.
        let at = pos2(outer.left(), rect.center().y + 0.5 * name.size().x);
        painter.add(
            egui::epaint::TextShape::new(at, name, text).with_angle(-std::f32::consts::FRAC_PI_2),
        );
        response
    }
}

/// The step of an axis's labelled marks: [`axes::axis_marks`] gives them the largest.
fn largest_step(marks: &[axes::Mark]) -> f64 {
    marks.iter().map(|k| k.step).fold(0.0f64, f64::max)
}

/// Where `pos` falls on an image of `cols x rows` cells drawn in `rect`: its cell.
pub(super) fn cell_at(rect: Rect, pos: egui::Pos2, cols: usize, rows: usize) -> (usize, usize) {
    let p = pos - rect.min;
    let f = |v: f32, len: f32, n: usize| {
        ((v / len.max(1e-6) * n as f32).max(0.0) as usize).min(n.saturating_sub(1))
    };
    (f(p.x, rect.width(), cols), f(p.y, rect.height(), rows))
}

/// The centre of cell `(col, row)` of an image of `cols x rows` cells in `rect`.
pub(super) fn cell_center(
    rect: Rect,
    col: usize,
    row: usize,
    cols: usize,
    rows: usize,
) -> egui::Pos2 {
    pos2(
        rect.left() + (col as f32 + 0.5) / cols.max(1) as f32 * rect.width(),
        rect.top() + (row as f32 + 0.5) / rows.max(1) as f32 * rect.height(),
    )
}
