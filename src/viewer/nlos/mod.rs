//! The window on an NLOS capture folder (`nlos.hdf5` in tal's format, with `nlos.json`
//! and `H.npy` beside it as `tprf nlos` writes them, or any tal capture file): the
//! capture's time slices playing on the wall grid (the scrubber and playback of the
//! transient view, the wall grid as the image, axes in metres on the wall), the
//! transient of a clicked wall point, and the reconstruction's max-intensity
//! projections (front, top, side), recomputed off the UI thread when the method or the
//! volume changes, from the capture in memory (no re-rendering).
//!
//! Immediate mode as the rest of the window: each frame reads the loaded capture (the
//! store, as a loaded cube is) and the reconstruction thread's latest result, and
//! draws; it keeps only widget state (the wall point, method, volume as typed) and
//! textures keyed by what they show.
//!
//! - this file: [`NlosView`] (the loaded capture and the widget state) and the pure
//!   mappings between the wall grid, the images and metres (tested without a window);
//! - `volume`: the volume's fields, validated;
//! - `worker`: the reconstruction thread;
//! - `image`: an image with its axes in metres;
//! - `view`: the frame (panels, images, the transient plot, the projections).

mod image;
mod view;
pub mod volume;
pub mod worker;

use super::textures::TextureCache;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tprf_core::film::TimeAxis;
use tprf_core::nlos::files::{CaptureMetadata, HDF5_NAME, JSON_NAME, LoadedCapture, read_capture};
use tprf_core::nlos::reconstruct::{GridFrame, Method, Volume};
use tprf_core::units::C_M_PER_S;
use volume::VolumeText;
use worker::{Reconstructor, Request};

/// Whether `path` is something the NLOS view opens: a folder holding `nlos.hdf5`, or an
/// HDF5 file (`.hdf5`, `.h5`).
pub fn is_capture(path: &Path) -> bool {
    if path.is_dir() {
        path.join(HDF5_NAME).is_file()
    } else {
        matches!(
            path.extension()
                .and_then(|e| e.to_str())
                .map(|e| e.to_ascii_lowercase())
                .as_deref(),
            Some("hdf5" | "h5")
        )
    }
}

/// An open capture and what the window shows of it.
pub struct NlosView {
    /// The folder (or file) opened.
    pub path: PathBuf,
    pub capture: Arc<LoadedCapture>,
    /// `nlos.json`, when the folder has one (tprf's captures).
    pub metadata: Option<CaptureMetadata>,
    /// The sensor grid's frame: wall coordinates `u`, `v` from its centre.
    pub frame: GridFrame,
    /// Time of arrival per bin (seconds: `t_start` and `delta_t` over c).
    pub axis: TimeAxis,
    /// The bin a slice opens on: the median of the wall points' peak bins.
    pub light_bin: Option<usize>,
    /// Laser point shown (exhaustive captures: an index into the laser grid).
    pub laser: usize,
    /// The wall point whose transient is plotted: sensor grid indices `(ix, iy)`.
    pub wall_point: (usize, usize),
    /// Each slice scaled by its own 99.5 % quantile (else the capture's 99.9 %).
    pub per_frame_exposure: bool,
    /// The method chosen.
    pub method: Method,
    /// The volume as typed, and why it is refused.
    pub volume_text: VolumeText,
    pub volume_error: Option<String>,
    /// The volume last accepted.
    pub volume: Volume,
    /// The default volume of the capture ([`Volume::default_for`]).
    pub default_volume: Volume,
    pub(super) reconstructor: Reconstructor,
    /// The capture's 99.9 % quantile (the global exposure's white).
    global_white: f64,
    pub(super) slice_texture: TextureCache<(usize, usize, bool)>,
    pub(super) projection_textures: TextureCache<u64>,
}

impl NlosView {
    /// Read the capture at `path` (a capture folder or an HDF5 file) and start its
    /// reconstruction thread (`wake` asks for a frame); the first reconstruction
    /// (back-projection on the default volume) is asked for at once.
    pub fn open(path: &Path, wake: impl Fn() + Send + 'static) -> Result<NlosView, String> {
        let capture = read_capture(path).map_err(|e| e.to_string())?;
        let frame = GridFrame::of(&capture).map_err(|e| e.to_string())?;
        let axis = TimeAxis::new(
            capture.t_start_m / C_M_PER_S,
            capture.delta_t_m / C_M_PER_S,
            capture.bins(),
        )
        .map_err(|e| format!("{}: its time axis: {e}", capture.path.display()))?;
        let default_volume = Volume::default_for(&capture, &frame).map_err(|e| e.to_string())?;
        let metadata = if path.is_dir() {
            std::fs::read(path.join(JSON_NAME))
                .ok()
                .and_then(|b| serde_json::from_slice::<CaptureMetadata>(&b).ok())
        } else {
            None
        };
        let transients = capture.h.len() / capture.bins().max(1);
        let peaks: Vec<Option<u32>> = (0..transients)
            .map(|k| {
                let (mut best, mut at) = (0.0f32, None);
                for t in 0..capture.bins() {
                    let v = capture.h.get(t * transients + k).copied().unwrap_or(0.0);
                    if v > best {
                        (best, at) = (v, Some(t as u32));
                    }
                }
                at
            })
            .collect();
        let light_bin = super::timeline::light_bin(&peaks);
        let global_white =
            super::colormap::quantile_positive(capture.h.iter().copied(), 0.999).unwrap_or(1.0);
        let [sx, sy] = capture.sensor_shape;
        let capture = Arc::new(capture);
        let mut reconstructor = Reconstructor::spawn(capture.clone(), wake);
        let method = Method::Bp;
        reconstructor.request(Request {
            method,
            volume: default_volume,
        });
        Ok(NlosView {
            path: path.to_path_buf(),
            capture,
            metadata,
            frame,
            axis,
            light_bin,
            laser: 0,
            wall_point: (sx / 2, sy / 2),
            per_frame_exposure: true,
            method,
            volume_text: VolumeText::of(&default_volume),
            volume_error: None,
            volume: default_volume,
            default_volume,
            reconstructor,
            global_white,
            slice_texture: TextureCache::default(),
            projection_textures: TextureCache::default(),
        })
    }

    /// The sensor grid's size `[Sx, Sy]`.
    pub fn grid(&self) -> [usize; 2] {
        self.capture.sensor_shape
    }

    /// Laser points a sensor point has transients for (exhaustive: the laser grid's).
    pub fn lasers(&self) -> usize {
        if self.capture.exhaustive {
            self.capture.laser_grid.len()
        } else {
            1
        }
    }

    /// Whether f-k migration applies: it needs a confocal capture (each sensor point
    /// lit at its own position).
    pub fn fk_allowed(&self) -> bool {
        self.capture.is_confocal()
    }

    /// Index into a time slice of `H` of sensor point `(ix, iy)` with laser `l`.
    fn transient_index(&self, l: usize, ix: usize, iy: usize) -> usize {
        let [_, sy] = self.capture.sensor_shape;
        l * self.capture.sensor_grid.len() + ix * sy + iy
    }

    /// The transient of wall point `(ix, iy)` (laser [`Self::laser`]), one value a bin.
    pub fn transient(&self, ix: usize, iy: usize) -> Vec<f32> {
        let per_t = self.capture.h.len() / self.capture.bins().max(1);
        let k = self.transient_index(self.laser.min(self.lasers() - 1), ix, iy);
        (0..self.capture.bins())
            .map(|t| self.capture.h.get(t * per_t + k).copied().unwrap_or(0.0))
            .collect()
    }

    /// Time slice `bin` as the wall image shows it: `Sy` rows of `Sx` values, row 0 the
    /// grid's last `y` (`v` points up), column `ix` the grid's `x` (`u` to the right).
    pub fn slice_image(&self, bin: usize) -> Vec<f32> {
        let [sx, sy] = self.capture.sensor_shape;
        let per_t = self.capture.h.len() / self.capture.bins().max(1);
        let l = self.laser.min(self.lasers() - 1);
        let base = bin.min(self.capture.bins().saturating_sub(1)) * per_t;
        let mut out = Vec::with_capacity(sx * sy);
        for row in 0..sy {
            let iy = sy - 1 - row;
            for ix in 0..sx {
                let k = self.transient_index(l, ix, iy);
                out.push(self.capture.h.get(base + k).copied().unwrap_or(0.0));
            }
        }
        out
    }

    /// The white of the slice image `values`: its own 99.5 % quantile, or the
    /// capture's 99.9 % (global exposure).
    pub fn white(&self, values: &[f32]) -> f64 {
        if self.per_frame_exposure {
            super::colormap::quantile_positive(values.iter().copied(), 0.995).unwrap_or(0.0)
        } else {
            self.global_white
        }
    }

    /// The wall's coordinates of sensor point `(ix, iy)`, metres along `u`, `v` from
    /// the grid's centre.
    pub fn wall_uv_m(&self, ix: usize, iy: usize) -> [f64; 2] {
        let [_, sy] = self.capture.sensor_shape;
        let p = self
            .capture
            .sensor_grid
            .get(ix * sy + iy)
            .copied()
            .unwrap_or(self.frame.center)
            - self.frame.center;
        [p.dot(self.frame.u) as f64, p.dot(self.frame.v) as f64]
    }

    /// The wall image's extent in metres: `[u_lo, u_hi]`, `[v_lo, v_hi]` (each grid
    /// point the centre of its cell; a grid of one point along an axis is 1 cm wide).
    pub fn wall_extent_m(&self) -> [[f64; 2]; 2] {
        let [sx, sy] = self.capture.sensor_shape;
        let (a, b) = (
            self.wall_uv_m(0, 0),
            self.wall_uv_m(sx.saturating_sub(1), sy.saturating_sub(1)),
        );
        let half = |k: usize, n: usize| {
            let s = self.frame.spacing_m[k] as f64;
            0.5 * if n > 1 && s > 0.0 { s } else { 0.01 }
        };
        [
            [a[0].min(b[0]) - half(0, sx), a[0].max(b[0]) + half(0, sx)],
            [a[1].min(b[1]) - half(1, sy), a[1].max(b[1]) + half(1, sy)],
        ]
    }

    /// Where the pixel `(col, row)` of the wall image is on the grid: `(ix, iy)`.
    pub fn grid_of_pixel(&self, col: usize, row: usize) -> (usize, usize) {
        let [sx, sy] = self.capture.sensor_shape;
        (
            col.min(sx.saturating_sub(1)),
            sy.saturating_sub(1) - row.min(sy.saturating_sub(1)),
        )
    }

    /// The wall image's pixel `(col, row)` of grid point `(ix, iy)`.
    pub fn pixel_of_grid(&self, ix: usize, iy: usize) -> (usize, usize) {
        let [_, sy] = self.capture.sensor_shape;
        (ix, sy.saturating_sub(1).saturating_sub(iy))
    }

    /// What the times of this capture are: with the device legs or without.
    pub fn time_convention(&self) -> &'static str {
        if self.capture.device_legs {
            "times include the laser-to-wall and wall-to-SPAD legs \
             (t_accounts_first_and_last_bounces = true)"
        } else {
            "times from the laser spot on the wall to the sensor point, device legs left out \
             (t_accounts_first_and_last_bounces = false)"
        }
    }

    /// The unit of `H`'s values.
    pub fn value_unit(&self) -> &'static str {
        if self.metadata.is_some() {
            "W m⁻² sr⁻¹ s per J"
        } else {
            "file's units"
        }
    }

    /// Take the volume as typed: accepted, a new reconstruction is asked for; refused,
    /// the message stays under the fields.
    pub fn apply_volume(&mut self) {
        match self.volume_text.parse(&self.frame) {
            Ok(v) => {
                self.volume = v;
                self.volume_error = None;
                self.request();
            }
            Err(e) => self.volume_error = Some(e),
        }
    }

    /// Back to the capture's default volume.
    pub fn reset_volume(&mut self) {
        self.volume_text = VolumeText::of(&self.default_volume);
        self.apply_volume();
    }

    /// Choose `method`; f-k migration on a capture that is not confocal is refused with
    /// the reason.
    pub fn set_method(&mut self, method: Method) -> Result<(), String> {
        if method == Method::Fk && !self.fk_allowed() {
            return Err(
                "f-k migration needs a confocal capture (each wall point lit at itself); \
                 this one is not: use bp, fbp or pf"
                    .into(),
            );
        }
        self.method = method;
        self.request();
        Ok(())
    }

    /// Ask the thread for the current method and volume (nothing if already asked).
    fn request(&mut self) {
        self.reconstructor.request(Request {
            method: self.method,
            volume: self.volume,
        });
    }

    /// The reconstruction thread's state.
    pub fn reconstruction(&self) -> worker::Status {
        self.reconstructor.status()
    }
}

/// `values` of `width x height`, rows in reverse order (an image whose row 0 is the
/// largest index of the vertical axis).
pub(crate) fn flip_rows(values: &[f32], width: usize, height: usize) -> Vec<f32> {
    let mut out = Vec::with_capacity(width * height);
    for row in (0..height).rev() {
        out.extend_from_slice(values.get(row * width..(row + 1) * width).unwrap_or(&[]));
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn flipped_rows_put_the_last_row_first() {
        let v = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        assert_eq!(super::flip_rows(&v, 3, 2), [4.0, 5.0, 6.0, 1.0, 2.0, 3.0]);
        // A short buffer gives what it has, no panic.
        assert_eq!(super::flip_rows(&v[..4], 3, 2), [1.0, 2.0, 3.0]);
    }
}
