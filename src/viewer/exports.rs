//! Files saved from the window: the time slice or steady image as PNG, every bin as PNG
//! frames plus an animated GIF, the plotted curves as CSV. Images are encoded on a named
//! background thread that reports back through a channel polled each frame; the UI
//! thread never waits for one.

use super::app::TprfApp;
use super::axes::BarScale;
use super::colormap::{self, ColorMap};
use super::tone::{self, View};
use eframe::egui;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;
use tprf_core::export;
use tprf_core::export::legend::{Legend, four_digits, with_legend};
use tprf_core::film::FilmSnapshot;
use tprf_core::units::C_M_PER_S;

/// Frames per second of the GIF.
const GIF_FPS: u32 = 30;

/// The background writers and the messages they sent when done.
pub(super) struct Exports {
    done_tx: Sender<String>,
    done_rx: Receiver<String>,
    running: Vec<JoinHandle<()>>,
}

impl Default for Exports {
    fn default() -> Self {
        let (done_tx, done_rx) = channel();
        Exports {
            done_tx,
            done_rx,
            running: Vec::new(),
        }
    }
}

impl Exports {
    /// Run `write` on a thread named `tprf-export`; when it ends, its message ("saved
    /// WHAT" or the error) is sent back and the window repainted. Returns an error
    /// message when no thread could be started.
    pub(super) fn spawn(
        &mut self,
        ctx: &egui::Context,
        what: String,
        write: impl FnOnce() -> anyhow::Result<()> + Send + 'static,
    ) -> Result<(), String> {
        let (tx, ctx) = (self.done_tx.clone(), ctx.clone());
        let handle = std::thread::Builder::new()
            .name("tprf-export".into())
            .spawn(move || {
                let message = match write() {
                    Ok(()) => format!("saved {what}"),
                    Err(e) => format!("{e:#}"),
                };
                // The window may be gone; then nobody is waiting for the message.
                let _ = tx.send(message);
                ctx.request_repaint();
            })
            .map_err(|e| format!("cannot start the export thread: {e}"))?;
        self.running.push(handle);
        Ok(())
    }

    /// Messages of the writers that finished since the last call; never waits.
    pub(super) fn finished(&mut self) -> Vec<String> {
        self.running.retain(|h| !h.is_finished());
        self.done_rx.try_iter().collect()
    }

    /// Whether a file is still being written.
    pub(super) fn busy(&self) -> bool {
        self.running.iter().any(|h| !h.is_finished())
    }
}

impl Drop for Exports {
    /// Files being written when the window closes are finished first.
    fn drop(&mut self) {
        for h in self.running.drain(..) {
            let _ = h.join();
        }
    }
}

/// `rgba` (`w x h`, RGBA8) as a PNG at `path`, written atomically.
fn write_png_rgba(path: &Path, w: usize, h: usize, rgba: Vec<u8>) -> anyhow::Result<()> {
    let img = image::RgbaImage::from_raw(w as u32, h as u32, rgba)
        .ok_or_else(|| anyhow::anyhow!("image size mismatch"))?;
    Ok(export::write_atomic(path, |out| {
        img.write_to(out, image::ImageFormat::Png)?;
        Ok(())
    })?)
}

/// What a saved image's legend says: its colour bar (the view's colours, its exposure's
/// range) and a line naming what it shows.
struct ViewLegend {
    map: Option<ColorMap>,
    bar: BarScale,
    unit: &'static str,
    note: String,
}

impl ViewLegend {
    fn of(
        view: View,
        snap: &FilmSnapshot,
        bin: usize,
        exposure: &tone::Exposure,
        settings: &super::ViewerSettings,
    ) -> ViewLegend {
        let axis = snap.axis();
        let (map, unit, note) = match view {
            View::Slice => (
                Some(settings.colormap),
                // ASCII units: the PNG's font has no superscripts.
                "W m-2 sr-1 s",
                format!(
                    "t = {} ns ({} m), bin {} of {}",
                    four_digits(axis.bin_center_s(bin) * 1e9),
                    four_digits(axis.bin_center_s(bin) * C_M_PER_S),
                    bin,
                    axis.bins
                ),
            ),
            View::Steady => (
                Some(ColorMap::Gray),
                "W m-2 sr-1",
                format!("steady state: the sum over {} bins", axis.bins),
            ),
            View::Rainbow => (
                None,
                "",
                "hue: the time of each pixel's peak; brightness: its energy".to_string(),
            ),
        };
        ViewLegend {
            map,
            bar: exposure.bar_scale(),
            unit,
            note,
        }
    }

    /// `rgba` (`w x h`) with this legend under it, as a PNG at `path`.
    fn write(&self, path: &Path, w: usize, h: usize, rgba: &[u8]) -> anyhow::Result<()> {
        let Some(map) = self.map else {
            return write_png_rgba(path, w, h, rgba.to_vec());
        };
        let rgb: Vec<u8> = rgba
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        let ramp = |t: f64| colormap::color_of(map, t);
        let (lo, hi, log) = match self.bar {
            BarScale::Linear { lo, hi } => (lo, hi, false),
            BarScale::Log { lo, hi } => (lo, hi, true),
        };
        let legend = Legend {
            ramp: &ramp,
            lo,
            hi,
            log,
            unit: self.unit,
            note: &self.note,
        };
        let (rgb, cw, ch) = with_legend(rgb, w, h, &legend)?;
        Ok(export::write_png_rgb(path, cw, ch, rgb)?)
    }
}

/// Every bin of `snap` through `tone` and `map` as `dir/NNNN.png` and the animated
/// `dir/tprf.gif` (looping, [`GIF_FPS`] frames a second). `dir` is an output folder as
/// the CLI's (`export::staging`): new, empty or an earlier tprf output, written beside
/// its place and swapped in whole; a folder holding anything else is refused.
fn write_video(
    dir: &Path,
    snap: &FilmSnapshot,
    tone: &colormap::Tone,
    map: colormap::ColorMap,
) -> anyhow::Result<()> {
    let staging = export::staging::Staging::new(dir, &[])?;
    write_frames_and_gif(staging.path(), snap, tone, map)?;
    Ok(staging.commit()?)
}

/// [`write_video`]'s files into `dir`.
fn write_frames_and_gif(
    dir: &Path,
    snap: &FilmSnapshot,
    tone: &colormap::Tone,
    map: colormap::ColorMap,
) -> anyhow::Result<()> {
    let (w, h) = (snap.width() as u32, snap.height() as u32);
    let mut frames = Vec::with_capacity(snap.axis().bins);
    for b in 0..snap.axis().bins {
        let rgba = colormap::colorize(&snap.slice(b), tone, map);
        let img = image::RgbaImage::from_raw(w, h, rgba)
            .ok_or_else(|| anyhow::anyhow!("image size mismatch"))?;
        export::write_atomic(&dir.join(format!("{b:04}.png")), |out| {
            img.write_to(out, image::ImageFormat::Png)?;
            Ok(())
        })?;
        frames.push(image::Frame::from_parts(
            img,
            0,
            0,
            image::Delay::from_numer_denom_ms(1000, GIF_FPS),
        ));
    }
    Ok(export::write_atomic(&dir.join("tprf.gif"), |out| {
        let mut enc = image::codecs::gif::GifEncoder::new(out);
        enc.set_repeat(image::codecs::gif::Repeat::Infinite)?;
        enc.encode_frames(frames)?;
        Ok(())
    })?)
}

impl TprfApp {
    /// Save `view` of `snap` at `path` as shown (encoded in the background).
    pub(super) fn save_view_png(&mut self, view: View, snap: &Arc<FilmSnapshot>, path: PathBuf) {
        let (rgba, exposure) =
            tone::view_pixels(view, snap, self.bin, &self.settings, &mut self.scratch);
        let (w, h) = (snap.width(), snap.height());
        let what = path.display().to_string();
        let result = if self.settings.png_legend {
            let legend = ViewLegend::of(view, snap, self.bin, &exposure, &self.settings);
            let write = move || legend.write(&path, w, h, &rgba);
            self.exports.spawn(&self.ctx, what, write)
        } else {
            let write = move || write_png_rgba(&path, w, h, rgba);
            self.exports.spawn(&self.ctx, what, write)
        };
        if let Err(e) = result {
            self.messages.push(e);
        }
    }

    /// Write every bin into the folder `dir` as a PNG plus an animated GIF, with one
    /// global exposure (coloured and encoded in the background).
    pub(super) fn save_video(&mut self, snap: &Arc<FilmSnapshot>, dir: PathBuf) {
        let tone = tone::global_tone(&self.settings, snap);
        let map = self.settings.colormap;
        let snap = snap.clone();
        let what = format!(
            "{} frames and tprf.gif in {}",
            snap.axis().bins,
            dir.display()
        );
        let write = move || write_video(&dir, &snap, &tone, map);
        if let Err(e) = self.exports.spawn(&self.ctx, what, write) {
            self.messages.push(e);
        }
    }

    /// Write the plotted curves to `path`: one row per bin with its start and centre
    /// (s) and the optical path length at its centre (m), then one column per curve
    /// named with its unit (radiance per bin, W m^-2 sr^-1 s per unit pulse energy).
    pub(super) fn export_csv(&mut self, snap: &FilmSnapshot, path: &Path) {
        let curves = self.plotted_curves(snap);
        let axis = *snap.axis();
        let mut header: Vec<String> = ["bin", "t_start_s", "t_centre_s", "opl_centre_m"]
            .map(String::from)
            .into();
        header.extend(curves.iter().map(|c| {
            format!(
                "\"{} [{}]\"",
                c.name.replace('"', "'"),
                super::axes::BIN_UNIT_ASCII
            )
        }));
        let rows = (0..axis.bins).map(|b| {
            let t_s = axis.bin_center_s(b);
            let mut row = vec![b as f64, axis.bin_start_s(b), t_s, t_s * C_M_PER_S];
            row.extend(
                curves
                    .iter()
                    .map(|c| c.values.get(b).copied().unwrap_or(0.0)),
            );
            row
        });
        match export::write_csv(path, &header, rows) {
            Ok(()) => self.messages.push(format!("saved {}", path.display())),
            Err(e) => self.messages.push(format!("{e:#}")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tprf_core::film::{FilmLayout, TimeAxis};

    /// A video written in the background: one PNG per bin and the GIF, reported back
    /// as a message without the caller waiting.
    #[test]
    fn video_is_written_in_the_background_and_reported() {
        let dir = std::env::temp_dir().join(format!("tprf-export-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let layout = FilmLayout {
            width: 3,
            height: 2,
            axis: TimeAxis::new(0.0, 1e-9, 4).unwrap(),
            bounces_separate: 0,
            luminescence: false,
        };
        let cube: Vec<f32> = (0..24).map(|i| i as f32).collect();
        let snap = Arc::new(FilmSnapshot::from_dense(layout, 1, 1, &cube, &[], None));
        let tone = tone::global_tone(&Default::default(), &snap);
        let mut exports = Exports::default();
        let (out, s) = (dir.clone(), snap.clone());
        exports
            .spawn(&egui::Context::default(), "video".into(), move || {
                write_video(&out, &s, &tone, colormap::ColorMap::Inferno)
            })
            .unwrap();
        let start = std::time::Instant::now();
        let messages = loop {
            let m = exports.finished();
            if !m.is_empty() {
                break m;
            }
            assert!(start.elapsed().as_secs() < 30, "no message from the writer");
            std::thread::sleep(std::time::Duration::from_millis(5));
        };
        assert_eq!(messages, vec!["saved video".to_string()]);
        for name in ["0000.png", "0003.png", "tprf.gif"] {
            assert!(dir.join(name).is_file(), "{name} missing");
        }
        assert!(!dir.join("0004.png").exists());
        // Into a folder holding a file of the user's, nothing is written and the file
        // stays: the message names it.
        std::fs::write(dir.join("notes.txt"), b"mine").unwrap();
        let (out, s) = (dir.clone(), snap.clone());
        exports
            .spawn(&egui::Context::default(), "video".into(), move || {
                write_video(&out, &s, &tone, colormap::ColorMap::Inferno)
            })
            .unwrap();
        let start = std::time::Instant::now();
        let refused = loop {
            let m = exports.finished();
            if !m.is_empty() {
                break m;
            }
            assert!(start.elapsed().as_secs() < 30, "no message from the writer");
            std::thread::sleep(std::time::Duration::from_millis(5));
        };
        assert!(refused[0].contains("notes.txt"), "{refused:?}");
        assert_eq!(std::fs::read(dir.join("notes.txt")).unwrap(), b"mine");
        std::fs::remove_file(dir.join("notes.txt")).unwrap();
        // A failure is a message too.
        exports
            .spawn(&egui::Context::default(), "x".into(), || {
                anyhow::bail!("disk full")
            })
            .unwrap();
        let start = std::time::Instant::now();
        while exports.busy() {
            assert!(start.elapsed().as_secs() < 30, "the writer did not end");
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        assert_eq!(exports.finished(), vec!["disk full".to_string()]);
        drop(exports);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
