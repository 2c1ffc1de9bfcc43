//! The central panel in transient mode: the time slice, the steady image and the
//! rainbow image, with pixel picking (click a pixel, drag a box) and a hover readout.

use super::PIN_COLORS;
use crate::viewer::app::TprfApp;
use crate::viewer::selection::Selection;
use crate::viewer::textures::ImageKey;
use crate::viewer::timeline::bin_label;
use crate::viewer::tone::{View, view_pixels};
use eframe::egui::{self, Color32, RichText, Sense, TextureHandle, Vec2};
use tprf_core::film::FilmSnapshot;

impl TprfApp {
    /// The texture of `view`, made again only when the snapshot, bin or tone changed.
    fn texture(&mut self, view: View, snap: &FilmSnapshot) -> TextureHandle {
        let key = ImageKey::new(view, snap, self.bin, &self.settings);
        self.textures.get(&self.ctx, view.name(), key, || {
            egui::ColorImage::from_rgba_unmultiplied(
                [snap.width(), snap.height()],
                &view_pixels(view, snap, self.bin, &self.settings),
            )
        })
    }

    /// One image, as large as fits in `max`, with pixel picking; updates the selection.
    fn image_ui(
        &mut self,
        ui: &mut egui::Ui,
        view: View,
        snap: &FilmSnapshot,
        max: Vec2,
        label: &str,
    ) {
        let tex = self.texture(view, snap);
        let (w, h) = (snap.width() as f32, snap.height() as f32);
        let scale = (max.x / w).min(max.y / h).max(0.01);
        let size = Vec2::new(w * scale, h * scale);
        let response = ui.add(egui::Image::new((tex.id(), size)).sense(Sense::click_and_drag()));
        response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, label));
        crate::viewer::textures::shrunk_note_ui(ui, &tex, snap.width(), snap.height());
        let to_pixel = |pos: egui::Pos2| -> (usize, usize) {
            let p = (pos - response.rect.min) / scale;
            (
                (p.x.max(0.0) as usize).min(snap.width().saturating_sub(1)),
                (p.y.max(0.0) as usize).min(snap.height().saturating_sub(1)),
            )
        };
        if response.drag_started()
            && let Some(pos) = response.interact_pointer_pos()
        {
            self.drag_start = Some(to_pixel(pos));
        }
        if let (Some(start), Some(pos)) = (self.drag_start, response.interact_pointer_pos())
            && response.dragged()
        {
            let end = to_pixel(pos);
            self.selection = Some(
                Selection {
                    x0: start.0,
                    y0: start.1,
                    x1: end.0,
                    y1: end.1,
                }
                .normalized(),
            );
        }
        if response.drag_stopped() {
            self.drag_start = None;
        }
        if response.clicked()
            && let Some(pos) = response.interact_pointer_pos()
        {
            let (x, y) = to_pixel(pos);
            self.selection = Some(Selection::pixel(x, y));
        }
        // Outline the selection and pins.
        let painter = ui.painter_at(response.rect);
        let outline = |s: &Selection, color: Color32| {
            let s = s.normalized();
            let min = response.rect.min + Vec2::new(s.x0 as f32, s.y0 as f32) * scale;
            let max = response.rect.min + Vec2::new((s.x1 + 1) as f32, (s.y1 + 1) as f32) * scale;
            painter.rect_stroke(
                egui::Rect::from_min_max(min, max).expand(1.0),
                0.0,
                (1.5, color),
                egui::StrokeKind::Outside,
            );
        };
        for (i, p) in self.pins.iter().enumerate() {
            outline(p, PIN_COLORS[(i + 1) % PIN_COLORS.len()]);
        }
        if let Some(s) = &self.selection {
            outline(s, PIN_COLORS[0]);
        }
        if let Some(pos) = response.hover_pos() {
            let (x, y) = to_pixel(pos);
            let v = snap.pixel(x, y).get(self.bin).copied().unwrap_or(0.0);
            response.on_hover_text(format!(
                "({x}, {y})  slice {v:.4e}  steady {:.4e}",
                snap.pixel(x, y).iter().map(|&v| v as f64).sum::<f64>()
            ));
        }
    }

    /// The time slice large on the left, the steady and rainbow images beside it.
    pub(crate) fn images_ui(&mut self, ui: &mut egui::Ui, snap: &FilmSnapshot) {
        let avail = ui.available_size();
        let side_w = (avail.x * 0.3).max(120.0);
        ui.horizontal_top(|ui| {
            ui.vertical(|ui| {
                ui.label(
                    RichText::new(format!("Time slice · {}", bin_label(snap.axis(), self.bin)))
                        .strong(),
                );
                let max = Vec2::new(avail.x - side_w - 16.0, avail.y - 24.0);
                self.image_ui(ui, View::Slice, snap, max, "time slice");
            });
            ui.vertical(|ui| {
                let max = Vec2::new(side_w, (avail.y - 60.0) / 2.0);
                ui.label(RichText::new("Steady state (sum over time)").strong());
                self.image_ui(ui, View::Steady, snap, max, "steady image");
                ui.label(RichText::new("Rainbow (hue = peak arrival)").strong());
                self.image_ui(ui, View::Rainbow, snap, max, "rainbow image");
            });
        });
    }
}
