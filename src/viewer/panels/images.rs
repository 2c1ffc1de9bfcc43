//! The central panel in transient mode: the time slice, the steady image and the
//! rainbow image, each with its colour bar and unit, laid out to grow with the window;
//! pixel picking (click a pixel, drag a box) and the camera's gestures (other buttons,
//! the wheel: `camera`); and a readout of the pixel under the
//! cursor (value with its unit, peak arrival time) under the images and at the pointer.

use super::PIN_COLORS;
use crate::viewer::app::TprfApp;
use crate::viewer::axes::{self, BIN_UNIT, BarScale, STEADY_UNIT};
use crate::viewer::colorbar::ColorBar;
use crate::viewer::colormap;
use crate::viewer::layout::image_layout;
use crate::viewer::selection::Selection;
use crate::viewer::settings::SteadyBlock;
use crate::viewer::textures::ImageKey;
use crate::viewer::timeline::bin_label;
use crate::viewer::tone::{View, view_pixels};
use eframe::egui::{self, Color32, Rect, RichText, Sense, TextureHandle, UiBuilder, Vec2};
use tprf_core::film::FilmSnapshot;
use tprf_core::units::C_M_PER_S;

/// Height of an image's title row, points.
const TITLE_H: f32 = 22.0;
/// Height of the readout line under the images, points.
const READOUT_H: f32 = 24.0;
/// Space between image blocks, points.
const GAP: f32 = 10.0;
/// The samples image's scale: a pixel's samples over the image's mean, 1/16 to 16.
const SAMPLES_SCALE: BarScale = BarScale::Log {
    lo: 1.0 / 16.0,
    hi: 16.0,
};

impl TprfApp {
    /// The texture of `view` and how it was exposed, made again only when the snapshot,
    /// bin or tone changed. A new snapshot remakes the time slice at once and the
    /// steady and rainbow images one a frame in the frames after it (each keeps its
    /// last picture meanwhile, with its colour bar): the three together made the frame
    /// a snapshot arrived in the slowest of all at 512^2.
    fn texture(&mut self, view: View, snap: &FilmSnapshot) -> TextureHandle {
        let key = ImageKey::new(view, snap, self.bin, &self.settings);
        let cached = self.textures.cached(view.name());
        if let Some((old, stale)) = cached
            && old.generation() != key.generation()
        {
            // A new snapshot. Deferred: a whole-film image whose tone did not change,
            // when this frame already remade one.
            if view != View::Slice && self.remade_this_frame && old.with_generation(&key) == key {
                self.ctx.request_repaint();
                return stale;
            }
            self.remade_this_frame = true;
        }
        let (bin, settings) = (self.bin, &self.settings);
        let (exposures, scratch) = (&mut self.exposures, &mut self.scratch);
        self.textures.get(&self.ctx, view.name(), key, || {
            let (px, exposure) = view_pixels(view, snap, bin, settings, scratch);
            exposures.retain(|(v, _)| *v != view);
            exposures.push((view, exposure));
            // Opaque pixels: premultiplied is unmultiplied, and the bytes are taken as
            // they are.
            egui::ColorImage::from_rgba_premultiplied([snap.width(), snap.height()], &px)
        })
    }

    /// One image at `size` with pixel picking; updates the selection and returns the
    /// pixel under the pointer.
    fn image_ui(
        &mut self,
        ui: &mut egui::Ui,
        tex: TextureHandle,
        snap: &FilmSnapshot,
        size: Vec2,
        label: &str,
    ) -> Option<(usize, usize)> {
        let scale = size.x / snap.width().max(1) as f32;
        let response = ui.add(egui::Image::new((tex.id(), size)).sense(Sense::click_and_drag()));
        response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, label));
        crate::viewer::textures::shrunk_note_ui(ui, snap.width(), snap.height());
        let to_pixel = |pos: egui::Pos2| -> (usize, usize) {
            let p = (pos - response.rect.min) / scale;
            (
                (p.x.max(0.0) as usize).min(snap.width().saturating_sub(1)),
                (p.y.max(0.0) as usize).min(snap.height().saturating_sub(1)),
            )
        };
        // The left button picks pixels; the others move the camera.
        if response.drag_started_by(egui::PointerButton::Primary)
            && let Some(pos) = response.interact_pointer_pos()
        {
            self.drag_start = Some(to_pixel(pos));
        }
        if let (Some(start), Some(pos)) = (self.drag_start, response.interact_pointer_pos())
            && response.dragged_by(egui::PointerButton::Primary)
        {
            let end = to_pixel(pos);
            self.select(
                Selection {
                    x0: start.0,
                    y0: start.1,
                    x1: end.0,
                    y1: end.1,
                }
                .normalized(),
                snap,
            );
        }
        if response.drag_stopped_by(egui::PointerButton::Primary) {
            self.drag_start = None;
        }
        self.camera_gestures(
            ui,
            &response,
            snap.width() as f64 / snap.height().max(1) as f64,
        );
        if self.showing_previous_camera() && self.camera_gesture.is_none() {
            ui.painter_at(response.rect).text(
                response.rect.left_top() + Vec2::new(6.0, 6.0),
                egui::Align2::LEFT_TOP,
                "the previous camera's film, until the new one has light",
                egui::FontId::proportional(13.0),
                Color32::from_rgb(0x4e, 0xc9, 0xff),
            );
        }
        if response.clicked()
            && let Some(pos) = response.interact_pointer_pos()
        {
            let (x, y) = to_pixel(pos);
            self.select(Selection::pixel(x, y), snap);
        }
        // Outline the selection and pins.
        let painter = ui.painter_at(response.rect);
        let outline = |s: &Selection, color: Color32| {
            let s = s.normalized();
            let min = response.rect.min + Vec2::new(s.x0 as f32, s.y0 as f32) * scale;
            let max = response.rect.min + Vec2::new((s.x1 + 1) as f32, (s.y1 + 1) as f32) * scale;
            painter.rect_stroke(
                Rect::from_min_max(min, max).expand(1.0),
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
        // Read out in the line under the images (a tooltip at the pointer covered it).
        response.hover_pos().map(to_pixel)
    }

    /// What the window says of pixel `(x, y)`: its value in the scrubber's bin and its
    /// steady value with their units, when its light peaks (ns and optical path m), and
    /// the samples it drew against the image's mean (adaptive sampling gives noisy
    /// pixels more).
    pub fn pixel_readout(&self, snap: &FilmSnapshot, x: usize, y: usize) -> String {
        let axis = snap.axis();
        let tprf = snap.pixel(x, y);
        let v = tprf.get(self.bin).copied().unwrap_or(0.0);
        let steady: f64 = tprf.iter().map(|&v| f64::from(v)).sum();
        let peak = snap
            .peak_bins()
            .get(y * snap.width() + x)
            .copied()
            .flatten()
            .map_or("no light".to_string(), |b| {
                let t = axis.bin_center_s(b as usize);
                format!("peak at {:.3} ns ({:.3} m)", t * 1e9, t * C_M_PER_S)
            });
        let samples = match snap.pixel_samples_drawn(x, y) {
            Some(n) if snap.spp > 0 => {
                format!(" · {n} spp ({:.2}x the mean)", n as f64 / snap.spp as f64)
            }
            _ => String::new(),
        };
        format!(
            "row {y}, column {x} · bin {}: {} · steady {} · {peak}{samples}",
            self.bin,
            axes::format_value(f64::from(v), BIN_UNIT),
            axes::format_value(steady, STEADY_UNIT),
        )
    }

    /// The colour bar of `view`, from the exposure its texture was made with.
    fn view_bar_ui(&self, ui: &mut egui::Ui, view: View, snap: &FilmSnapshot, width: f32) {
        let axis = snap.axis();
        let map = self.settings.colormap;
        let exposure = self
            .exposures
            .iter()
            .find(|(v, _)| *v == view)
            .map(|e| &e.1);
        let Some(exposure) = exposure else {
            return;
        };
        match view {
            View::Slice => {
                let ramp = move |t: f64| colormap::color_of(map, t);
                ColorBar {
                    of: "time slice",
                    ramp: &ramp,
                    scale: exposure.bar_scale(),
                    unit: BIN_UNIT,
                    second: None,
                    note: &format!(
                        "radiance in the bin (integral over the bin, unit pulse energy); {}",
                        exposure.note
                    ),
                }
                .ui(ui, width);
            }
            View::Steady => {
                let ramp = |t: f64| colormap::color_of(colormap::ColorMap::Gray, t);
                ColorBar {
                    of: "steady image",
                    ramp: &ramp,
                    scale: exposure.bar_scale(),
                    unit: STEADY_UNIT,
                    second: None,
                    note: &format!("steady-state radiance (sum over bins); {}", exposure.note),
                }
                .ui(ui, width);
            }
            View::Rainbow => {
                let first = axis.bin_center_s(0) * 1e9;
                let last = axis.bin_center_s(axis.bins.saturating_sub(1)) * 1e9;
                let (lo, hi) = if last > first {
                    (first, last)
                } else {
                    (first - 0.5 * axis.dt_s * 1e9, first + 0.5 * axis.dt_s * 1e9)
                };
                let to_m = |ns: f64| ns * 1e-9 * C_M_PER_S;
                ColorBar {
                    of: "rainbow image",
                    ramp: &colormap::turbo,
                    scale: BarScale::Linear { lo, hi },
                    unit: "ns",
                    second: Some(("m", &to_m)),
                    note: &format!(
                        "hue: arrival time of the pixel's peak (ns; optical path in m); {}",
                        exposure.note
                    ),
                }
                .ui(ui, width);
            }
        }
    }

    /// One image with its title over it and its colour bar under it; returns the pixel
    /// under the pointer.
    fn image_block_ui(
        &mut self,
        ui: &mut egui::Ui,
        view: View,
        snap: &FilmSnapshot,
        size: Vec2,
    ) -> Option<(usize, usize)> {
        // The steady block offers the scene's ambient image, when it has one of the
        // film's size, and the samples each pixel drew, when the film records them.
        let ambient = self
            .ambient()
            .filter(|a| a.width == snap.width() && a.height == snap.height());
        let has_samples = snap.spp > 0 && snap.pixel_samples_drawn(0, 0).is_some();
        if view == View::Steady && (ambient.is_some() || has_samples) {
            let mut tabs = vec![(
                SteadyBlock::Steady,
                "Steady",
                "steady state: the sum over time of the TPRF",
            )];
            if ambient.is_some() {
                tabs.push((
                    SteadyBlock::Ambient,
                    "Ambient",
                    "the ambient light group (sun, sky, lamps tagged ambient): steady light, \
                     W m⁻² sr⁻¹",
                ));
            }
            if has_samples {
                tabs.push((
                    SteadyBlock::Samples,
                    "Samples",
                    "the samples each pixel drew, over the image's mean: adaptive sampling \
                     gives the noisy pixels more",
                ));
            }
            // Tabs where they fit the block's width, else a menu (a tab cut off at the
            // block's edge could not be read or clicked).
            let font = egui::TextStyle::Button.resolve(ui.style());
            let pad = 2.0 * ui.spacing().button_padding.x + ui.spacing().item_spacing.x;
            let needed: f32 = tabs
                .iter()
                .map(|(_, name, _)| {
                    let g =
                        ui.painter()
                            .layout_no_wrap(name.to_string(), font.clone(), Color32::WHITE);
                    g.size().x + pad + 2.0
                })
                .sum();
            let s = &mut self.settings.steady_block;
            ui.horizontal(|ui| {
                ui.set_height(TITLE_H - 4.0);
                if needed <= size.x {
                    for (block, name, hover) in &tabs {
                        ui.selectable_value(s, *block, RichText::new(*name).strong())
                            .on_hover_text(*hover);
                    }
                } else {
                    let now = tabs.iter().find(|t| t.0 == *s).map_or("Steady", |t| t.1);
                    egui::ComboBox::from_id_salt("steady-block")
                        .selected_text(RichText::new(now).strong())
                        .width((size.x - 8.0).max(40.0))
                        .show_ui(ui, |ui| {
                            for (block, name, hover) in &tabs {
                                ui.selectable_value(s, *block, *name).on_hover_text(*hover);
                            }
                        })
                        .response
                        .on_hover_text("what this image shows");
                }
            });
            self.pending.steady_block = self.settings.steady_block;
            match (self.settings.steady_block, ambient) {
                (SteadyBlock::Ambient, Some(a)) => {
                    let tex = self.ambient_texture_of(&a);
                    let hovered = self.image_ui(ui, tex, snap, size, "ambient image");
                    let ramp = |t: f64| colormap::color_of(colormap::ColorMap::Gray, t);
                    ColorBar {
                        of: "ambient image",
                        ramp: &ramp,
                        scale: BarScale::Linear {
                            lo: 0.0,
                            hi: self.ambient_white.unwrap_or(1.0),
                        },
                        unit: STEADY_UNIT,
                        second: None,
                        note: &format!(
                            "radiance of the scene's ambient light group (sun, sky, lamps \
                             tagged ambient), steady, {} spp; white = the 99.9th percentile",
                            a.spp
                        ),
                    }
                    .ui(ui, size.x);
                    return hovered;
                }
                (SteadyBlock::Samples, _) if has_samples => {
                    let tex = self.samples_texture_of(snap);
                    let hovered = self.image_ui(ui, tex, snap, size, "samples image");
                    let ramp = |t: f64| colormap::color_of(colormap::ColorMap::Inferno, t);
                    ColorBar {
                        of: "samples image",
                        ramp: &ramp,
                        scale: SAMPLES_SCALE,
                        unit: "× the mean",
                        second: None,
                        note: &format!(
                            "samples each pixel drew over the image's mean ({} spp), clamped \
                             to the bar: adaptive sampling gives the noisy pixels more",
                            snap.spp
                        ),
                    }
                    .ui(ui, size.x);
                    return hovered;
                }
                _ => {}
            }
            let tex = self.texture(view, snap);
            let hovered = self.image_ui(ui, tex, snap, size, "steady image");
            self.view_bar_ui(ui, view, snap, size.x);
            return hovered;
        }
        // Short titles (the small images' were cut off at 1280 px), what each shows in
        // the tooltip.
        let (title, label, what) = match view {
            View::Slice => (
                format!("Time slice · {}", bin_label(snap.axis(), self.bin)),
                "time slice",
                "the radiance arriving in the scrubber's bin",
            ),
            View::Steady => (
                "Steady state".to_string(),
                "steady image",
                "each pixel's TPRF summed over time: the ordinary image",
            ),
            View::Rainbow => (
                "Rainbow".to_string(),
                "rainbow image",
                "hue: when each pixel's light peaks (see its colour bar); brightness: its \
                 steady energy, square-rooted",
            ),
        };
        ui.add_sized(
            Vec2::new(size.x, TITLE_H - 4.0),
            egui::Label::new(RichText::new(title).strong()).truncate(),
        )
        .on_hover_text(what);
        let tex = self.texture(view, snap);
        let hovered = self.image_ui(ui, tex, snap, size, label);
        self.view_bar_ui(ui, view, snap, size.x);
        hovered
    }

    /// The ambient image's texture: grey, linear from 0 to its 99.9th percentile (in
    /// W m^-2 sr^-1, kept in `ambient_white` for the colour bar), made (and the
    /// percentile taken) again only for a new image.
    fn ambient_texture_of(
        &mut self,
        a: &std::sync::Arc<tprf_core::transport::ambient::AmbientImage>,
    ) -> TextureHandle {
        let key = (std::sync::Arc::as_ptr(a) as usize, self.settings.log_image);
        let (cache, ctx, white_slot) = (
            &mut self.ambient_texture,
            &self.ctx,
            &mut self.ambient_white,
        );
        cache.get(ctx, "ambient", key, || {
            let white = tprf_core::film::quantile_positive(a.radiance.iter().copied(), 0.999);
            *white_slot = white;
            let tone = colormap::Tone {
                scale: white.map_or(1.0, |m| 1.0 / m),
                log: false,
                decades: 3.0,
            };
            egui::ColorImage::from_rgba_unmultiplied(
                [a.width, a.height],
                &colormap::colorize(&a.radiance, &tone, colormap::ColorMap::Gray),
            )
        })
    }

    /// The samples image's texture: per pixel the samples it drew over the film's mean,
    /// on [`SAMPLES_SCALE`] (clamped), inferno; made again only for a new snapshot.
    fn samples_texture_of(&mut self, snap: &FilmSnapshot) -> TextureHandle {
        let (cache, ctx) = (&mut self.samples_texture, &self.ctx);
        cache.get(ctx, "samples", snap.generation(), || {
            let (w, h) = (snap.width(), snap.height());
            let mean = snap.spp.max(1) as f64;
            let mut rgba = Vec::with_capacity(w * h * 4);
            for y in 0..h {
                for x in 0..w {
                    let r = snap.pixel_samples_drawn(x, y).unwrap_or(0) as f64 / mean;
                    let t = if r > 0.0 {
                        SAMPLES_SCALE.fraction(r).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let [cr, cg, cb] = colormap::color_of(colormap::ColorMap::Inferno, t);
                    rgba.extend([cr, cg, cb, 255]);
                }
            }
            egui::ColorImage::from_rgba_unmultiplied([w, h], &rgba)
        })
    }

    /// The time slice large, the steady and rainbow images beside or under it (whichever
    /// lets the slice grow larger), and the readout of the pixel under the pointer (or
    /// of the selected pixel).
    pub(crate) fn images_ui(&mut self, ui: &mut egui::Ui, snap: &FilmSnapshot) {
        let full = ui.available_rect_before_wrap();
        let bar_h = 2.0 + 10.0 + 2.0 + 2.0 * 14.0;
        let extra = TITLE_H + bar_h + 2.0 * ui.spacing().item_spacing.y;
        let aspect = snap.width().max(1) as f32 / snap.height().max(1) as f32;
        let area = (full.width(), full.height() - READOUT_H);
        let l = image_layout(area, aspect, extra, GAP);
        let big = Vec2::new(l.big.0, l.big.1);
        let small = Vec2::new(l.small.0, l.small.1);
        let block = |min: egui::Pos2, size: Vec2| {
            Rect::from_min_size(min, Vec2::new(size.x, size.y + extra))
        };
        let big_rect = block(full.min, big);
        let (r1, r2) = if l.below {
            let y = big_rect.bottom() + GAP;
            let r1 = block(egui::pos2(full.left(), y), small);
            (r1, block(egui::pos2(r1.right() + GAP, y), small))
        } else {
            let x = big_rect.right() + GAP;
            let r1 = block(egui::pos2(x, full.top()), small);
            (r1, block(egui::pos2(x, r1.bottom() + GAP), small))
        };
        let mut hovered = None;
        for (rect, view, size) in [
            (big_rect, View::Slice, big),
            (r1, View::Steady, small),
            (r2, View::Rainbow, small),
        ] {
            let h = ui
                .scope_builder(UiBuilder::new().max_rect(rect), |ui| {
                    self.image_block_ui(ui, view, snap, size)
                })
                .inner;
            hovered = hovered.or(h);
        }
        // The readout right under the time slice when the small images sit beside it
        // (wrapping there), else along the panel's bottom.
        let readout_rect = if l.below {
            Rect::from_min_max(egui::pos2(full.left(), full.bottom() - READOUT_H), full.max)
        } else {
            Rect::from_min_max(
                egui::pos2(full.left(), big_rect.bottom() + GAP / 2.0),
                egui::pos2(big_rect.right(), full.bottom()),
            )
        };
        let text = match (hovered, self.selection) {
            (Some((x, y)), _) => self.pixel_readout(snap, x, y),
            (None, Some(s)) if s.x0 == s.x1 && s.y0 == s.y1 => {
                format!("selected {}", self.pixel_readout(snap, s.x0, s.y0))
            }
            _ => format!("Hover a pixel to read its value · {}", super::GESTURES_HINT),
        };
        ui.scope_builder(UiBuilder::new().max_rect(readout_rect), |ui| {
            let label = egui::Label::new(RichText::new(text));
            ui.add(if l.below {
                label.truncate()
            } else {
                label.wrap()
            });
        });
        ui.advance_cursor_after_rect(full);
    }
}
