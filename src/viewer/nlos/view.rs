//! The frame of the NLOS view: the capture's controls and the reconstruction's method
//! and volume (left), the clicked wall point's transient (right), the scrubber (bottom,
//! the transient view's), and in the middle the wall slice and the three
//! max-intensity projections, each with its axes in metres.

use super::NlosView;
use super::image::{MetreImage, cell_at, cell_center};
use crate::viewer::app::TprfApp;
use crate::viewer::axes::{self, BarScale};
use crate::viewer::colorbar::ColorBar;
use crate::viewer::colormap::{self, ColorMap, Tone};
use crate::viewer::plotting;
use eframe::egui::{self, Color32, RichText, Vec2};
use egui_plot::{Line, Plot, VLine};
use tprf_core::nlos::reconstruct::Method;
use tprf_core::units::C_M_PER_S;

/// Height of an image's title, points.
const TITLE_H: f32 = 20.0;
/// The marker of the chosen wall point and of the reconstruction's peak.
const MARK: Color32 = Color32::from_rgb(0x4e, 0xc9, 0xff);

/// The methods, in the order offered, with what each is.
const METHODS: [(Method, &str); 4] = [
    (
        Method::Bp,
        "back-projection: each voxel sums the transients at its path length",
    ),
    (
        Method::Fbp,
        "filtered back-projection: the transients band-passed by the phasor-field kernel, \
         back-projected, magnitude",
    ),
    (
        Method::Fk,
        "f-k migration (Lindell et al. 2019): a wave-equation solution in the Fourier domain",
    ),
    (
        Method::Pf,
        "phasor fields (Liu et al. 2019): the wall's phasor field propagated to each depth \
         by Rayleigh-Sommerfeld diffraction",
    ),
];

impl TprfApp {
    /// A frame of the NLOS view.
    pub(in crate::viewer) fn nlos_ui(&mut self, ui: &mut egui::Ui, v: &mut NlosView) {
        let ctx = ui.ctx().clone();
        let bins = v.axis.bins;
        if self.seek_light {
            if let Some(b) = v.light_bin {
                self.bin = b;
            }
            self.seek_light = false;
        }
        self.bin = self.bin.min(bins.saturating_sub(1));
        if !ctx.egui_wants_keyboard_input() {
            let (l, r, s) = ctx.input(|i| {
                (
                    i.num_presses(egui::Key::ArrowLeft),
                    i.num_presses(egui::Key::ArrowRight),
                    i.key_pressed(egui::Key::Space),
                )
            });
            self.bin_keys(l, r, s, bins);
        }
        self.advance_playback(&ctx, bins);
        let window_w = ui.available_width();
        egui::Panel::top("top")
            .frame(crate::viewer::panel_frame(ui))
            .show(ui, |ui| self.top_bar_ui(ui));
        egui::Panel::bottom("status")
            .frame(crate::viewer::panel_frame(ui))
            .show(ui, |ui| self.nlos_status_ui(ui, v));
        egui::Panel::left("controls")
            .frame(crate::viewer::panel_frame(ui))
            .resizable(true)
            .default_size(270.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| nlos_controls_ui(ui, v));
            });
        egui::Panel::right("plot")
            .frame(crate::viewer::panel_frame(ui))
            .resizable(true)
            .default_size((window_w * 0.3).clamp(320.0, 720.0))
            .show(ui, |ui| {
                ui.set_min_width(ui.available_width());
                self.nlos_transient_ui(ui, v);
            });
        let axis = v.axis;
        egui::Panel::bottom("timeline")
            .frame(crate::viewer::panel_frame(ui))
            .show(ui, |ui| self.scrubber_ui(ui, &axis));
        egui::CentralPanel::default()
            .frame(crate::viewer::central_frame(ui))
            .show(ui, |ui| self.nlos_images_ui(ui, v));
    }

    /// The status bar: the capture, the reconstruction's state, the latest message.
    fn nlos_status_ui(&self, ui: &mut egui::Ui, v: &NlosView) {
        ui.horizontal_wrapped(|ui| {
            ui.label(format!("NLOS capture {}", v.path.display()));
            ui.label("·");
            let st = v.reconstruction();
            match (&st.running, &st.finished) {
                (Some((r, since)), _) => {
                    ui.spinner();
                    ui.label(format!(
                        "reconstructing ({}, {} voxels) … {:.1} s",
                        r.method.name(),
                        voxels(r.volume.voxels),
                        since.elapsed().as_secs_f64()
                    ));
                    ui.ctx()
                        .request_repaint_after(std::time::Duration::from_millis(200));
                }
                (None, Some(f)) => {
                    ui.label(format!(
                        "{} on {} voxels in {:.2} s",
                        f.request.method.name(),
                        voxels(f.request.volume.voxels),
                        f.seconds
                    ));
                }
                (None, None) => {
                    ui.label("no reconstruction yet");
                }
            }
            if let Some(m) = self.messages.last() {
                ui.separator();
                ui.label(RichText::new(m).color(ui.visuals().warn_fg_color));
            }
        });
    }

    /// The chosen wall point's transient, times in ns in the capture's convention; a
    /// click or drag on the plot moves the scrubber.
    fn nlos_transient_ui(&mut self, ui: &mut egui::Ui, v: &NlosView) {
        ui.heading("Wall point transient");
        let (ix, iy) = v.wall_point;
        let [u, w] = v.wall_uv_m(ix, iy);
        ui.label(format!(
            "grid point ({ix}, {iy}) · u = {u:.3} m, v = {w:.3} m on the wall"
        ));
        ui.label(RichText::new(v.time_convention()).weak());
        if v.lasers() > 1 {
            ui.label(RichText::new(format!("laser point {} of {}", v.laser, v.lasers())).weak());
        }
        let ys: Vec<f64> = v.transient(ix, iy).iter().map(|&x| x as f64).collect();
        let axis = v.axis;
        let width_px = ui.available_width();
        let per_px = (axis.bins as f32 / width_px.max(1.0)).floor().max(1.0) as usize;
        let pts = plotting::steps(axis.t0_s * 1e9, axis.dt_s * 1e9, &ys, per_px);
        let x_label = if v.capture.device_legs {
            "time of arrival, device legs included (ns)"
        } else {
            "time from the laser spot, device legs left out (ns)"
        };
        let unit = v.value_unit();
        let plot = Plot::new("nlos-transient")
            .height((ui.available_height() - 20.0).max(160.0))
            .allow_drag(false)
            .label_formatter(move |hover| {
                let p = match hover {
                    egui_plot::HoverPosition::NearDataPoint { position, .. } => *position,
                    egui_plot::HoverPosition::Elsewhere { position } => *position,
                };
                Some(format!(
                    "{:.3} ns · {:.3} m\n{}",
                    p.x,
                    p.x * 1e-9 * C_M_PER_S,
                    axes::format_value(p.y, unit)
                ))
            })
            .include_x(axis.t0_s * 1e9)
            .include_x(axis.end_s() * 1e9)
            .include_y(0.0);
        let bin_now = self.bin;
        let y_label = format!("per bin ({unit})");
        let response = plotting::value_plot(plot, x_label, &y_label).show(ui, |p| {
            p.line(
                Line::new("transient", pts)
                    .color(Color32::from_rgb(0xff, 0xb0, 0x40))
                    .allow_band(false)
                    .width(1.8),
            );
            p.vline(
                VLine::new("scrubber", axis.bin_center_s(bin_now) * 1e9)
                    .color(Color32::WHITE)
                    .style(egui_plot::LineStyle::dotted_loose()),
            );
            p.pointer_coordinate()
        });
        // Drag on the plot moves the scrubber.
        self.scrub_from_plot(&response.response, response.inner, &axis);
        response
            .response
            .widget_info(|| egui::WidgetInfo::labeled(egui::Role::Figure, true, "transient plot"));
    }

    /// The wall slice and the front, top and side projections, two by two.
    fn nlos_images_ui(&mut self, ui: &mut egui::Ui, v: &mut NlosView) {
        let avail = ui.available_size();
        let bar_h = 34.0;
        let cell = Vec2::new(avail.x / 2.0 - 8.0, avail.y / 2.0 - 8.0);
        let room = |extra: f32| {
            (cell - MetreImage::outer_size(Vec2::ZERO) - Vec2::new(0.0, TITLE_H + extra))
                .max(Vec2::splat(16.0))
        };
        let st = v.reconstruction();
        ui.horizontal_top(|ui| {
            ui.allocate_ui(cell, |ui| {
                ui.vertical(|ui| self.wall_slice_ui(ui, v, room(bar_h)));
            });
            ui.allocate_ui(cell, |ui| {
                ui.vertical(|ui| projection_ui(ui, v, &st, 0, room(bar_h)));
            });
        });
        ui.horizontal_top(|ui| {
            for which in [1, 2] {
                ui.allocate_ui(cell, |ui| {
                    ui.vertical(|ui| projection_ui(ui, v, &st, which, room(0.0)));
                });
            }
        });
    }

    /// The time slice on the wall grid, its colour bar; a click chooses the wall point.
    fn wall_slice_ui(&mut self, ui: &mut egui::Ui, v: &mut NlosView, room: Vec2) {
        let [sx, sy] = v.grid();
        let values = v.slice_image(self.bin);
        let white = v.white(&values);
        ui.label(
            RichText::new(format!(
                "Wall, t = {}",
                crate::viewer::timeline::bin_label(&v.axis, self.bin)
            ))
            .strong(),
        );
        let key = (self.bin, v.laser, v.per_frame_exposure);
        let tex = v.slice_texture.get(&self.ctx, "nlos-wall", key, || {
            let tone = Tone {
                scale: if white > 0.0 { 1.0 / white } else { 0.0 },
                log: false,
                decades: 3.0,
            };
            let px = colormap::colorize(&values, &tone, ColorMap::Inferno);
            egui::ColorImage::from_rgba_premultiplied([sx, sy], &px)
        });
        let [xr, yr] = v.wall_extent_m();
        let size = fit(((xr[1] - xr[0]) / (yr[1] - yr[0])) as f32, room);
        let response = MetreImage {
            texture: &tex,
            label: "wall slice",
            x_m: xr,
            y_m: yr,
            x_name: "u on the wall (m)",
            y_name: "v on the wall (m)",
        }
        .ui(ui, size);
        if response.clicked()
            && let Some(pos) = response.interact_pointer_pos()
        {
            let (col, row) = cell_at(response.rect, pos, sx, sy);
            v.wall_point = v.grid_of_pixel(col, row);
        }
        let (col, row) = v.pixel_of_grid(v.wall_point.0, v.wall_point.1);
        let c = cell_center(response.rect, col, row, sx, sy);
        let half = Vec2::new(
            0.5 * response.rect.width() / sx.max(1) as f32,
            0.5 * response.rect.height() / sy.max(1) as f32,
        );
        ui.painter_at(response.rect).rect_stroke(
            egui::Rect::from_center_size(c, 2.0 * half).expand(1.0),
            0.0,
            (1.5, MARK),
            egui::StrokeKind::Outside,
        );
        let ramp = |t: f64| colormap::color_of(ColorMap::Inferno, t);
        let note = if v.per_frame_exposure {
            "white: this slice's 99.5 % quantile"
        } else {
            "white: the capture's 99.9 % quantile"
        };
        ColorBar {
            of: "wall slice",
            ramp: &ramp,
            scale: BarScale::Linear {
                lo: 0.0,
                hi: if white > 0.0 { white } else { 1.0 },
            },
            unit: v.value_unit(),
            second: None,
            note,
        }
        .ui(ui, size.x + MetreImage::outer_size(Vec2::ZERO).x);
    }
}

/// Projection `which` (0 front, 1 top, 2 side) of the latest reconstruction.
fn projection_ui(
    ui: &mut egui::Ui,
    v: &mut NlosView,
    st: &super::worker::Status,
    which: usize,
    room: Vec2,
) {
    let names = ["front (along n)", "top (along v)", "side (along u)"];
    let Some(f) = &st.finished else {
        ui.label(RichText::new(format!("Projection, {}", names[which])).strong());
        ui.label(match &st.error {
            Some((_, e)) => RichText::new(e).color(ui.visuals().error_fg_color),
            None => RichText::new("reconstructing…").weak(),
        });
        return;
    };
    let stale = st.running.is_some() || v.reconstructor.sent() != Some(f.request);
    ui.label(
        RichText::new(format!(
            "{}, {}{}",
            f.request.method.name(),
            names[which],
            if stale { " (previous)" } else { "" }
        ))
        .strong(),
    );
    let Some(p) = f.projections.get(which) else {
        return;
    };
    let vol = &f.request.volume;
    // The volume's extent along u, v and n (depth from the wall's plane), metres.
    let rel = glam::Vec3::from(vol.center) - v.frame.center;
    let span = |axis: glam::Vec3, k: usize| {
        let c = rel.dot(axis) as f64;
        let h = 0.5 * vol.size_m[k] as f64;
        [c - h, c + h]
    };
    let (u, w, n) = (span(v.frame.u, 0), span(v.frame.v, 1), span(v.frame.n, 2));
    // Front [Y][X], top [Z][X] and side [Y][Z]: rows flipped so v and depth point up.
    let (x_m, y_m, x_name, y_name, peak_cell) = match which {
        0 => (u, w, "u (m)", "v (m)", (f.peak_voxel[0], f.peak_voxel[1])),
        1 => (
            u,
            n,
            "u (m)",
            "depth n (m)",
            (f.peak_voxel[0], f.peak_voxel[2]),
        ),
        _ => (
            n,
            w,
            "depth n (m)",
            "v (m)",
            (f.peak_voxel[2], f.peak_voxel[1]),
        ),
    };
    let name: &'static str = ["nlos-front", "nlos-top", "nlos-side"][which];
    let max = f.max;
    let tex = v
        .projection_textures
        .get(ui.ctx(), name, st.generation, || {
            let flipped = super::flip_rows(&p.values, p.width, p.height);
            let tone = Tone {
                scale: if max > 0.0 { 1.0 / max as f64 } else { 0.0 },
                log: false,
                decades: 3.0,
            };
            let px = colormap::colorize(&flipped, &tone, ColorMap::Inferno);
            egui::ColorImage::from_rgba_premultiplied([p.width, p.height], &px)
        });
    let size = fit(((x_m[1] - x_m[0]) / (y_m[1] - y_m[0])) as f32, room);
    let label = format!("{} projection", ["front", "top", "side"][which]);
    let response = MetreImage {
        texture: &tex,
        label: &label,
        x_m,
        y_m,
        x_name,
        y_name,
    }
    .ui(ui, size);
    // The peak voxel, circled.
    let row = p.height.saturating_sub(1).saturating_sub(peak_cell.1);
    let c = cell_center(response.rect, peak_cell.0, row, p.width, p.height);
    ui.painter_at(response.rect)
        .circle_stroke(c, 6.0, (1.5, MARK));
    if which == 0 {
        let [x, y, z] = f.peak_m;
        ui.label(format!("peak at ({x:.3}, {y:.3}, {z:.3}) m (world)"));
        let ramp = |t: f64| colormap::color_of(ColorMap::Inferno, t);
        ColorBar {
            of: "projections",
            ramp: &ramp,
            scale: BarScale::Linear { lo: 0.0, hi: 1.0 },
            unit: "× peak",
            second: None,
            note: f.request.method.value_meaning(),
        }
        .ui(ui, size.x + MetreImage::outer_size(Vec2::ZERO).x);
        ui.label(
            RichText::new(format!(
                "1 = the volume's peak, {} ({}: hover the bar for its unit)",
                crate::viewer::axes::format_value(f64::from(max), ""),
                f.request.method.name()
            ))
            .weak()
            .small(),
        );
    }
}

/// The capture's facts, the laser point and exposure, the method and the volume.
fn nlos_controls_ui(ui: &mut egui::Ui, v: &mut NlosView) {
    ui.heading("NLOS capture");
    if let Some(m) = &v.metadata {
        ui.label(format!("scene: {}", m.scene));
    }
    let [sx, sy] = v.grid();
    let scan = if v.capture.exhaustive {
        format!("exhaustive, {} laser points", v.lasers())
    } else if v.capture.is_confocal() {
        "confocal".to_string()
    } else {
        "one laser point".to_string()
    };
    ui.label(format!("wall grid {sx} × {sy} · {scan}"));
    ui.label(format!(
        "{} bins of {:.3} ps ({:.4} m)",
        v.axis.bins,
        v.axis.dt_s * 1e12,
        v.capture.delta_t_m
    ));
    ui.label(RichText::new(v.time_convention()).weak());
    if v.lasers() > 1 {
        let l = ui.label("laser point");
        let max = v.lasers() - 1;
        ui.add(egui::Slider::new(&mut v.laser, 0..=max))
            .labelled_by(l.id)
            .on_hover_text("which laser point's transients the wall and the plot show");
    }
    ui.checkbox(&mut v.per_frame_exposure, "expose each slice by itself")
        .on_hover_text("else one white for the whole capture: brightness compares across time");
    ui.separator();
    ui.heading("Reconstruction");
    ui.label("method");
    ui.horizontal_wrapped(|ui| {
        for (m, what) in METHODS {
            let allowed = m != Method::Fk || v.fk_allowed();
            let r = ui
                .add_enabled(allowed, egui::Button::selectable(v.method == m, m.name()))
                .on_hover_text(what)
                .on_disabled_hover_text(
                    "f-k migration needs a confocal capture (each wall point lit at itself)",
                );
            if r.clicked() {
                // Refused only for fk on a non-confocal capture, which is disabled.
                let _ = v.set_method(m);
            }
        }
    });
    if !v.fk_allowed() {
        ui.label(
            RichText::new("fk: only for confocal captures (each wall point lit at itself)").weak(),
        );
    }
    ui.label("volume (world metres; size and voxels along the wall's u, v and its normal n)");
    let mut enter = false;
    egui::Grid::new("nlos-volume")
        .num_columns(2)
        .show(ui, |ui| {
            for (name, text, hint) in [
                ("centre", &mut v.volume_text.center, "x, y, z"),
                ("size", &mut v.volume_text.size, "u, v, n"),
                ("voxels", &mut v.volume_text.voxels, "u, v, n"),
            ] {
                let l = ui.label(name);
                let r = ui
                    .add(
                        egui::TextEdit::singleline(text)
                            .desired_width(150.0)
                            .hint_text(hint),
                    )
                    .labelled_by(l.id);
                if r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
                    enter = true;
                }
                ui.end_row();
            }
        });
    ui.horizontal(|ui| {
        if ui.button("Apply").clicked() || enter {
            v.apply_volume();
        }
        if ui.button("Default volume").clicked() {
            v.reset_volume();
        }
    });
    if let Some(e) = &v.volume_error {
        ui.label(RichText::new(e).color(ui.visuals().error_fg_color));
    }
    let st = v.reconstruction();
    if let Some((Some(_), e)) = &st.error {
        ui.label(RichText::new(e).color(ui.visuals().error_fg_color));
    }
}

/// `nx × ny × nz`.
fn voxels(v: [usize; 3]) -> String {
    format!("{} × {} × {}", v[0], v[1], v[2])
}

/// The largest size of width-over-height `aspect` inside `room`.
fn fit(aspect: f32, room: Vec2) -> Vec2 {
    let aspect = if aspect.is_finite() && aspect > 0.0 {
        aspect
    } else {
        1.0
    };
    if room.x / room.y.max(1.0) > aspect {
        Vec2::new(room.y * aspect, room.y)
    } else {
        Vec2::new(room.x, room.x / aspect)
    }
}
