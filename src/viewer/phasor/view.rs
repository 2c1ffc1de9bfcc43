//! The phasor tab's central panel: the band (mitransient's `wl_mean:wl_sigma`), the
//! frequency chosen by a slider that says it per metre of optical path, in Hz and as a
//! wavelength, and that frequency's amplitude and phase images side by side, each with
//! its colour bar (the phase on a cyclic map), and a readout of the pixel under the
//! pointer.

use super::maths::{PHASE_FLOOR, PhasorPlanes, frequency_label, phase_color, phase_rgba};
use crate::viewer::axes::{self, BarScale, STEADY_UNIT};
use crate::viewer::colorbar::ColorBar;
use crate::viewer::colormap::{self, ColorMap, Tone};
use crate::viewer::textures::TextureCache;
use eframe::egui::{self, RichText, Sense, Vec2};
use tprf_core::export::phasor::{PhasorBand, PhasorMetadata, phasor_image};
use tprf_core::film::{FilmSnapshot, TimeFilter};

/// Where the phasors come from.
pub(crate) enum PhasorInput<'a> {
    /// Computed from the film at the band's frequencies (a render, or a cube folder
    /// without `phasor.npy`), the film binned with `filter`.
    Film {
        snap: &'a FilmSnapshot,
        filter: TimeFilter,
    },
    /// `phasor.npy` (or `tprf.zarr/phasor`) of a cube folder: `[H, W, F, 2]`.
    Files {
        meta: &'a PhasorMetadata,
        data: &'a [f32],
        width: usize,
        height: usize,
    },
}

/// What the tab keeps between frames: its textures, the planes of the frequency shown
/// (keyed on what they were made from) and the band as typed.
#[derive(Default)]
pub(crate) struct PhasorState {
    textures: TextureCache<u64>,
    planes: Option<(u64, PhasorPlanes)>,
    band_text: Option<String>,
    band_error: Option<String>,
}

/// Height of a colour bar with its labels, points.
const BAR_H: f32 = 30.0;

fn hash(x: &dyn std::fmt::Debug) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    format!("{x:?}").hash(&mut hasher);
    hasher.finish()
}

/// The band field: `band` edited when the text reads as one (mitransient's defaults
/// when unset).
fn band_ui(ui: &mut egui::Ui, state: &mut PhasorState, band: &mut Option<PhasorBand>) {
    let shown = band.unwrap_or_default();
    let text = state
        .band_text
        .get_or_insert_with(|| format!("{}:{}", shown.wl_mean_m, shown.wl_sigma_m));
    ui.horizontal_wrapped(|ui| {
        let l = ui.label("Band wl_mean:wl_sigma (m of optical path)");
        let r = ui
            .add(egui::TextEdit::singleline(text).desired_width(120.0))
            .labelled_by(l.id)
            .on_hover_text(
                "mitransient's phasor_hdr_film: frequencies of the bins' FFT within 3 sigma \
                 of 1 / wl_mean, sigma = 1 / (6 wl_sigma); unset: its defaults 100:1000",
            );
        if r.lost_focus() || ui.input(|i| i.key_pressed(egui::Key::Enter)) {
            match text.parse::<PhasorBand>() {
                Ok(b) => {
                    *band = Some(b);
                    state.band_error = None;
                }
                Err(e) => state.band_error = Some(e),
            }
        }
        if let Some(e) = &state.band_error {
            ui.label(RichText::new(e).color(ui.visuals().warn_fg_color));
        }
    });
}

/// The tab: the band (for phasors computed from the film), the frequency slider, the
/// amplitude and phase images with their colour bars, the readout. Returns the pixel
/// clicked.
pub(crate) fn phasor_ui(
    ui: &mut egui::Ui,
    state: &mut PhasorState,
    input: PhasorInput<'_>,
    band: &mut Option<PhasorBand>,
    index: &mut usize,
) -> Option<(usize, usize)> {
    // The frequencies, and how the planes of frequency `j` are made.
    let (meta, w, h) = match &input {
        PhasorInput::Film { snap, filter } => {
            band_ui(ui, state, band);
            let axis = snap.axis();
            let b = band.unwrap_or_default();
            match PhasorMetadata::new(b, axis.t0_s, axis.dt_s, axis.bins, *filter) {
                Ok(m) => (m, snap.width(), snap.height()),
                Err(e) => {
                    ui.label(RichText::new(e).color(ui.visuals().warn_fg_color));
                    return None;
                }
            }
        }
        PhasorInput::Files {
            meta,
            width,
            height,
            ..
        } => {
            ui.label(format!(
                "phasors of the cube folder ({}): wl_mean {} m, wl_sigma {} m",
                meta.file, meta.wl_mean_m, meta.wl_sigma_m
            ));
            ((*meta).clone(), *width, *height)
        }
    };
    let nf = meta.frequencies_per_m.len();
    if nf == 0 {
        ui.label("no frequency");
        return None;
    }
    *index = (*index).min(nf - 1);
    let j = *index;
    let f = meta.frequencies_per_m[j];
    ui.horizontal_wrapped(|ui| {
        let l = ui.label(format!(
            "Frequency (index {} of numpy's fftfreq({}, {} m))",
            meta.fft_index_first + j,
            meta.bins,
            axes::format_sig(meta.bin_width_opl_m, 4)
        ));
        ui.add(egui::Slider::new(index, 0..=nf - 1).show_value(false))
            .labelled_by(l.id);
        ui.label(RichText::new(frequency_label(f)).strong());
    });
    let key = match &input {
        PhasorInput::Film { snap, filter } => hash(&(snap.generation(), f.to_bits(), *filter)),
        PhasorInput::Files { data, .. } => hash(&(data.as_ptr() as usize, data.len(), j)),
    };
    if state.planes.as_ref().is_none_or(|(k, _)| *k != key) {
        let planes = match &input {
            PhasorInput::Film { snap, filter } => {
                PhasorPlanes::from_complex(&phasor_image(snap, f, *filter))
            }
            PhasorInput::Files { data, .. } => PhasorPlanes::from_array(data, nf, j),
        };
        state.planes = Some((key, planes));
    }
    let (_, planes) = state.planes.as_ref()?;
    if planes.amplitude.len() != w * h {
        return None;
    }
    ui.label(
        RichText::new(format!(
            "P = Σ value/spp · exp(−2πi f (opl − {} m)), mitransient's sign and scale; {}",
            axes::format_sig(meta.start_opl_m, 4),
            match meta.time_filter {
                TimeFilter::Box =>
                    "from the bins: each bin's centre phase × sinc(f dt), \
                                    the exact integral over the bin of light uniform in it",
                TimeFilter::Tent => "from the bins: each bin's centre phase (a tent film)",
            }
        ))
        .weak(),
    );
    let white = planes.white();
    let avail = ui.available_size();
    let title_h = 22.0;
    let readout_h = 26.0;
    let extra = title_h + BAR_H + 12.0;
    // Side by side, or one above the other: whichever shows them larger.
    let fit = |max: Vec2| {
        (max.x / w.max(1) as f32)
            .min(max.y / h.max(1) as f32)
            .max(0.01)
    };
    let beside = fit(Vec2::new(
        (avail.x - 16.0) / 2.0,
        avail.y - extra - readout_h,
    ));
    let above = fit(Vec2::new(avail.x, (avail.y - readout_h) / 2.0 - extra));
    let stacked = above > beside;
    let scale = beside.max(above);
    let size = Vec2::new(w as f32, h as f32) * scale;
    let ctx = ui.ctx().clone();
    let textures = &mut state.textures;
    let mut clicked = None;
    let mut hovered = None;
    let mut image = |ui: &mut egui::Ui, tex: &egui::TextureHandle, label: &str| {
        let r = ui.add(egui::Image::new((tex.id(), size)).sense(Sense::click()));
        r.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, label));
        let to_pixel = |pos: egui::Pos2| {
            let p = (pos - r.rect.min) / scale;
            (
                (p.x.max(0.0) as usize).min(w.saturating_sub(1)),
                (p.y.max(0.0) as usize).min(h.saturating_sub(1)),
            )
        };
        crate::viewer::textures::shrunk_note_ui(ui, w, h);
        if r.clicked() {
            clicked = r.interact_pointer_pos().map(to_pixel).or(clicked);
        }
        hovered = r.hover_pos().map(to_pixel).or(hovered);
    };
    let pair = |ui: &mut egui::Ui, add: &mut dyn FnMut(&mut egui::Ui)| {
        if stacked {
            ui.vertical(|ui| add(ui));
        } else {
            ui.horizontal_top(|ui| add(ui));
        }
    };
    pair(ui, &mut |ui: &mut egui::Ui| {
        ui.vertical(|ui| {
            ui.set_width(size.x);
            ui.add(egui::Label::new(RichText::new("amplitude |P|").strong()).truncate());
            let tone = Tone {
                scale: white.map_or(1.0, |m| 1.0 / m),
                log: false,
                decades: 3.0,
            };
            let tex = textures.get(&ctx, "phasor-amplitude", hash(&(key, "a")), || {
                egui::ColorImage::from_rgba_unmultiplied(
                    [w, h],
                    &colormap::colorize(&planes.amplitude, &tone, ColorMap::Inferno),
                )
            });
            image(ui, &tex, "phasor amplitude image");
            let ramp = |t: f64| colormap::color_of(ColorMap::Inferno, t);
            ColorBar {
                of: "phasor amplitude",
                ramp: &ramp,
                scale: BarScale::Linear {
                    lo: 0.0,
                    hi: white.unwrap_or(1.0),
                },
                unit: STEADY_UNIT,
                second: None,
                note: "|P|: white = the 98th percentile over the pixels (a light seen \
                       directly saturates); at f = 0 it is the steady image",
            }
            .ui(ui, size.x);
        });
        ui.vertical(|ui| {
            ui.set_width(size.x);
            ui.add(egui::Label::new(RichText::new("phase arg P").strong()).truncate());
            let floor = PHASE_FLOOR * white.unwrap_or(0.0);
            let tex = textures.get(&ctx, "phasor-phase", hash(&(key, "p")), || {
                egui::ColorImage::from_rgba_unmultiplied([w, h], &phase_rgba(planes, floor))
            });
            image(ui, &tex, "phasor phase image");
            let ramp = |t: f64| phase_color((t - 0.5) * std::f64::consts::TAU);
            ColorBar {
                of: "phasor phase",
                ramp: &ramp,
                scale: BarScale::Linear {
                    lo: -180.0,
                    hi: 180.0,
                },
                unit: "°",
                second: None,
                note: "arg P on a cyclic map (−180° and 180° are one colour); black: \
                       amplitude below 1e-3 of white, no phase to show",
            }
            .ui(ui, size.x);
        });
    });
    let text = match hovered {
        Some((x, y)) => {
            let i = y * w + x;
            format!(
                "row {y}, column {x} · |P| {} · arg P {:.1}°",
                axes::format_value(
                    f64::from(planes.amplitude.get(i).copied().unwrap_or(0.0)),
                    STEADY_UNIT
                ),
                f64::from(planes.phase_rad.get(i).copied().unwrap_or(0.0)).to_degrees()
            )
        }
        None => "Hover a pixel to read its amplitude and phase".to_string(),
    };
    ui.add(egui::Label::new(RichText::new(text).monospace()).truncate());
    clicked
}
