//! One NLOS capture, described once: [`CaptureRequest`] is what `tprf nlos SCENE` does,
//! as data (the scene, the relay wall and its grid of sensor points, the laser's scan,
//! the devices, the time axis, the samples, the bounces, the band, the threads),
//! serialised with `tprf nlos`'s option names, which are also the keys of a batch
//! manifest's `[[capture]]` jobs and Python's `tprf.nlos.capture` keywords.
//! [`CaptureRequest::validate`] checks it naming the field;
//! [`CaptureRequest::with_file_defaults`] fills the fields a front end was not given from
//! a Mitsuba NLOS scene's capture meter and integrator; [`CaptureRequest::run`] renders it
//! (the wall-point integrator, [`crate::nlos::capture`]) reporting each sensor point to an
//! [`CaptureObserver`], which may cancel it; [`CaptureRequest::write_folder`] writes
//! `nlos.hdf5`, `H.npy` and `nlos.json` (which embeds the request), staged beside the
//! output and swapped in whole.
//!
//! Units: times in seconds (read from a number of seconds, or text with a unit: `"3mm"`
//! of optical path, `"10ps"`), lengths in metres.

use super::file_defaults::FileNote;
use super::{Problem, from_text};
use crate::export::staging::Staging;
use crate::export::{ExportError, write_json, write_npy_f32};
use crate::nlos::capture::{Capture, Progress, render_capture_with};
use crate::nlos::files::{CaptureMetadata, HDF5_NAME, JSON_NAME, NPY_NAME, write_hdf5};
use crate::nlos::{CaptureGeometry, CaptureSettings, NlosError, Scan};
use crate::scene::{Channel, FileSetting, FileSettings, Scene, SceneError};
use crate::units::{C_M_PER_S, format_time};
use serde::{Deserialize, Deserializer, Serialize};
use std::ops::ControlFlow;
use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

/// Bin width of a capture given none: 3 mm of optical path (as `--dt 3mm` reads it).
pub const DEFAULT_CAPTURE_DT_S: f64 = 3.0 * 1e-3 / C_M_PER_S;

/// Laser points of an exhaustive scan given no `laser_grid`, along u and v.
pub const DEFAULT_LASER_GRID: [usize; 2] = [8, 8];

/// An NLOS capture: `tprf nlos`'s options as data (a field left out takes its default).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CaptureRequest {
    /// What to capture: `builtin:NAME` (`nlos-z`, `nlos-shapes`), a .gltf/.glb path or a
    /// Mitsuba NLOS scene (.xml), holding a planar relay wall and the hidden geometry.
    pub scene: String,
    /// Name of the relay wall's object (its glTF node, else its mesh; a Mitsuba scene's
    /// shape id). Default `relay_wall`.
    pub relay_wall: String,
    /// Sensor points on the wall along its u and v axes (default 64 x 64).
    pub grid: [usize; 2],
    /// The laser at each sensor point in turn.
    pub confocal: bool,
    /// Every point of `laser_grid` with every sensor point.
    pub exhaustive: bool,
    /// Laser points of an exhaustive scan along u and v (default 8 x 8).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub laser_grid: Option<[usize; 2]>,
    /// The one laser point of a single scan, metres (projected onto the wall); unset: the
    /// wall's centre.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub laser_point: Option<[f32; 3]>,
    /// Laser device position, metres (unset: tal's, 0.5 m along -u from the wall's
    /// centre and 0.25 m in front).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub laser_origin: Option<[f32; 3]>,
    /// SPAD device position, metres (unset: as the laser's default).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor_origin: Option<[f32; 3]>,
    /// Time bins (unset: up to the longest three-bounce path).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bins: Option<usize>,
    /// Bin width, seconds (`dt`; default 3 mm of optical path over c).
    #[serde(rename = "dt", deserialize_with = "time_s_value")]
    pub dt_s: f64,
    /// Start of the time axis, seconds (`t0`; default 0).
    #[serde(rename = "t0", deserialize_with = "time_s_value")]
    pub t0_s: f64,
    /// Times start when the pulse hits the wall and end when light returns to it (the
    /// device-to-wall legs left out: tal's default).
    pub unwarped: bool,
    /// Samples per sensor point (default 256).
    pub spp: u32,
    pub seed: u64,
    /// Largest number of scattering events in the hidden scene, the two on the wall not
    /// counted (default 1024).
    pub max_bounces: u32,
    /// The spectral band: red, green, blue or gray.
    #[serde(deserialize_with = "from_text")]
    pub channel: Channel,
    /// Worker threads (unset: one per core). The capture does not depend on it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub threads: Option<usize>,
}

impl Default for CaptureRequest {
    fn default() -> Self {
        CaptureRequest {
            scene: String::new(),
            relay_wall: "relay_wall".into(),
            grid: [64, 64],
            confocal: false,
            exhaustive: false,
            laser_grid: None,
            laser_point: None,
            laser_origin: None,
            sensor_origin: None,
            bins: None,
            dt_s: DEFAULT_CAPTURE_DT_S,
            t0_s: 0.0,
            unwarped: false,
            spp: 256,
            seed: 0,
            max_bounces: 1024,
            channel: Channel::Gray,
            threads: None,
        }
    }
}

/// A time field that must have a value: a number of seconds, or text with a unit.
fn time_s_value<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    super::time_s(d)?.ok_or_else(|| serde::de::Error::custom("a time is needed (e.g. \"3mm\")"))
}

/// Why a capture cannot be made or written.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// A field's value is not allowed; the message names it.
    #[error("{0}")]
    Invalid(Problem),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Nlos(#[from] NlosError),
    #[error(transparent)]
    Export(#[from] ExportError),
    #[error("cannot start the capture's threads")]
    Threads(#[source] rayon::ThreadPoolBuildError),
    /// The observer stopped the capture before every sensor point was rendered.
    #[error("capture cancelled")]
    Cancelled,
    /// The observer stopped the writing of the output (Ctrl-C): nothing was written.
    #[error("interrupted (Ctrl-C) while writing: nothing was written")]
    Interrupted,
}

/// A field's problem: `field` and the message after it.
fn invalid(field: &'static str, text: impl Into<String>) -> CaptureError {
    CaptureError::Invalid(Problem::field(field).text(text))
}

/// What a capture tells its caller as it goes. Every method has a default that does
/// nothing.
pub trait CaptureObserver {
    /// A line for the user: the scene's notes (`note: ...`), the wall and scan resolved,
    /// the render's time.
    fn message(&mut self, _line: &str) {}

    /// After each sensor point, and while points run every
    /// [`crate::nlos::capture::POLL_SAMPLES`] samples (from the worker threads): `done` of
    /// `total` points. [`ControlFlow::Break`] cancels the capture (the points running
    /// stop, the others are skipped, and [`CaptureRequest::run`] returns
    /// [`CaptureError::Cancelled`]).
    fn points(&mut self, _done: u64, _total: u64) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }

    /// Before the output folder is begun and between its files: [`ControlFlow::Break`]
    /// abandons it ([`CaptureError::Interrupted`]; the staging folder is removed and the
    /// old output stays as it was).
    fn writing(&mut self) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
}

/// An observer that says and stops nothing.
pub struct Quiet;

impl CaptureObserver for Quiet {}

impl CaptureRequest {
    /// A capture of `scene` with every other field at its default.
    pub fn new(scene: impl Into<String>) -> CaptureRequest {
        CaptureRequest {
            scene: scene.into(),
            ..CaptureRequest::default()
        }
    }

    /// Check every field and the fields together, before the scene is loaded; the
    /// error names the field (`grid 0x4: a grid needs at least one sensor point ...`).
    /// What needs the scene (the wall, points on it, the devices in front of it, the
    /// scan's size in memory) is checked when it is resolved ([`crate::nlos::setup`]).
    pub fn validate(&self) -> Result<(), CaptureError> {
        if self.scene.trim().is_empty() {
            return Err(invalid(
                "scene",
                ": no scene given (builtin:nlos-z, builtin:nlos-shapes, a .gltf/.glb or a Mitsuba .xml path)",
            ));
        }
        if self.relay_wall.trim().is_empty() {
            return Err(invalid("relay_wall", ": no object named"));
        }
        let [nx, ny] = self.grid;
        if nx == 0 || ny == 0 {
            return Err(CaptureError::Invalid(
                Problem::field("grid")
                    .text(format!(
                        " {nx}x{ny}: a grid needs at least one sensor point along each axis (e.g. "
                    ))
                    .and("grid")
                    .text(" 64x64)"),
            ));
        }
        if self.confocal && self.exhaustive {
            return Err(CaptureError::Invalid(
                Problem::field("confocal")
                    .text(" and ")
                    .and("exhaustive")
                    .text(" are two scans: choose one"),
            ));
        }
        if self.laser_point.is_some() && (self.confocal || self.exhaustive) {
            let scan = if self.confocal {
                "confocal"
            } else {
                "exhaustive"
            };
            return Err(CaptureError::Invalid(
                Problem::field("laser_point")
                    .text(" is the one laser point of a single scan, not of a ")
                    .and(scan)
                    .text(" one"),
            ));
        }
        if let Some([lx, ly]) = self.laser_grid {
            if !self.exhaustive {
                return Err(CaptureError::Invalid(
                    Problem::field("laser_grid")
                        .text(" is the laser points of an ")
                        .and("exhaustive")
                        .text(" scan: give it too"),
                ));
            }
            if lx == 0 || ly == 0 {
                return Err(CaptureError::Invalid(
                    Problem::field("laser_grid")
                        .text(format!(
                            " {lx}x{ly}: an exhaustive scan needs at least one laser point along each axis (e.g. "
                        ))
                        .and("laser_grid")
                        .text(" 8x8)"),
                ));
            }
        }
        for (field, p) in [
            ("laser_point", self.laser_point),
            ("laser_origin", self.laser_origin),
            ("sensor_origin", self.sensor_origin),
        ] {
            if let Some(p) = p
                && !p.iter().all(|c| c.is_finite())
            {
                return Err(invalid(
                    field,
                    format!(" {p:?}: expected three finite numbers X,Y,Z in metres"),
                ));
            }
        }
        if self.bins == Some(0) {
            return Err(invalid("bins", " 0: a capture needs at least one time bin"));
        }
        if !(self.dt_s.is_finite() && self.dt_s > 0.0) {
            return Err(invalid(
                "dt",
                format!(
                    " {} s: the bin width must be a positive time or length (e.g. 3mm, 10ps)",
                    self.dt_s
                ),
            ));
        }
        if !self.t0_s.is_finite() {
            return Err(invalid("t0", format!(" {} s is not finite", self.t0_s)));
        }
        if self.spp == 0 {
            return Err(invalid(
                "spp",
                " 0: a capture needs at least one sample per sensor point",
            ));
        }
        if self.threads == Some(0) {
            return Err(invalid("threads", " must be at least 1"));
        }
        Ok(())
    }

    /// Take each setting a Mitsuba NLOS scene carries (`file`: its capture meter and
    /// integrator, [`crate::scene::load_with_settings`]) into the field its front end was
    /// not given (`given(key)` false, keys as the request is serialised); returns what
    /// was taken, in order: `grid`, the scan (`scan`: the integrator's `capture_type`,
    /// unless `confocal`, `exhaustive` or `laser_point` is set; an exhaustive one lights
    /// the sensor grid's points, as mitransient's does), a single scan's `laser_point`,
    /// `laser_origin`, `sensor_origin`, `dt` and `t0` (metres of optical path over c),
    /// `bins`, whether times include the device legs (`unwarped`), `spp`, `max_bounces`
    /// (the file's `max_depth - 3`) and `relay_wall`.
    pub fn with_file_defaults(
        &mut self,
        file: &FileSettings,
        given: impl Fn(&str) -> bool,
    ) -> Vec<FileNote> {
        let Some(file) = &file.nlos else {
            return Vec::new();
        };
        let mut notes = Vec::new();
        let mut take = |field: &'static str, value: String, from: &str| {
            notes.push(FileNote {
                field,
                taken: format!("{value} ({from})"),
            });
        };
        let count = |v: u64| usize::try_from(v).unwrap_or(usize::MAX);
        if !given("grid")
            && let Some(g) = &file.grid
        {
            take("grid", format!("{}x{}", g.value[0], g.value[1]), &g.from);
            self.grid = g.value.map(count);
        }
        let flagged_scan = self.confocal || self.exhaustive || self.laser_point.is_some();
        if !flagged_scan && let Some(k) = &file.capture_type {
            take("scan", k.value.clone(), &k.from);
            match k.value.as_str() {
                "confocal" => self.confocal = true,
                "exhaustive" => {
                    self.exhaustive = true;
                    // mitransient's exhaustive scan lights the sensor grid's points.
                    self.laser_grid = Some(self.grid);
                }
                _ => {}
            }
        }
        if !self.confocal
            && !self.exhaustive
            && !given("laser_point")
            && let Some(f) = &file.laser_point
        {
            take("laser_point", format!("{:?}", f.value), &f.from);
            self.laser_point = Some(f.value.map(|c| c as f32));
        }
        let mut origin = |field: &'static str,
                          slot: &mut Option<[f32; 3]>,
                          f: &Option<FileSetting<[f64; 3]>>| {
            if !given(field)
                && let Some(f) = f
            {
                take(field, format!("{:?}", f.value), &f.from);
                *slot = Some(f.value.map(|c| c as f32));
            }
        };
        origin("laser_origin", &mut self.laser_origin, &file.laser_origin);
        origin(
            "sensor_origin",
            &mut self.sensor_origin,
            &file.sensor_origin,
        );
        let mut opl = |field: &'static str, slot: &mut f64, f: &Option<FileSetting<f64>>| {
            if !given(field)
                && let Some(f) = f
            {
                take(field, format!("{}m of optical path", f.value), &f.from);
                *slot = f.value / C_M_PER_S;
            }
        };
        opl("dt", &mut self.dt_s, &file.dt_opl_m);
        opl("t0", &mut self.t0_s, &file.t0_opl_m);
        if !given("bins")
            && let Some(b) = &file.bins
        {
            take("bins", b.value.to_string(), &b.from);
            self.bins = Some(count(b.value));
        }
        if !self.unwarped
            && !given("unwarped")
            && let Some(l) = &file.device_legs
        {
            take(
                "unwarped",
                if l.value { "included" } else { "left out" }.into(),
                &l.from,
            );
            self.unwarped = !l.value;
        }
        if !given("spp")
            && let Some(f) = &file.spp
        {
            take("spp", f.value.to_string(), &f.from);
            self.spp = u32::try_from(f.value).unwrap_or(u32::MAX);
        }
        if !given("max_bounces")
            && let Some(f) = &file.hidden_bounces
        {
            take("max_bounces", f.value.to_string(), &f.from);
            self.max_bounces = f.value;
        }
        if !given("relay_wall")
            && let Some(f) = &file.relay_wall
        {
            take("relay_wall", f.value.clone(), &f.from);
            self.relay_wall = f.value.clone();
        }
        notes
    }

    /// Load the scene, refuse a file that is a camera's view of an NLOS integrator (no
    /// capture meter: `tprf render` renders it) unless `relay_wall` is given, take the
    /// file's settings into the fields not given ([`CaptureRequest::with_file_defaults`])
    /// and check the request ([`CaptureRequest::validate`]): the one way the command line,
    /// a batch job and Python prepare a capture. Returns the scene and what came from
    /// the file.
    pub fn load_scene(
        &mut self,
        given: impl Fn(&str) -> bool,
    ) -> Result<(Scene, Vec<FileNote>), CaptureError> {
        self.validate()?;
        let (scene, file) = crate::scene::load_with_settings(&self.scene)?;
        if file.nlos_view && !given("relay_wall") {
            let s = &self.scene;
            return Err(CaptureError::Invalid(
                Problem::field("scene")
                    .text(format!(
                        " {s} is mitransient's NLOS integrator watched by a camera (no \
                         nlos_capture_meter on a relay wall): render its view with tprf render \
                         {s} --out DIR, or capture a wall by naming it with "
                    ))
                    .and("relay_wall")
                    .text(" (its shapes' ids)"),
            ));
        }
        let notes = self.with_file_defaults(&file, given);
        self.validate()?;
        Ok((scene, notes))
    }

    /// The scan: confocal, exhaustive (on `laser_grid`, default 8 x 8) or one laser point.
    pub fn scan(&self) -> Scan {
        if self.confocal {
            Scan::Confocal
        } else if self.exhaustive {
            let [lx, ly] = self.laser_grid.unwrap_or(DEFAULT_LASER_GRID);
            Scan::Exhaustive { lx, ly }
        } else {
            Scan::Single {
                laser_point: self.laser_point,
            }
        }
    }

    /// The wall-point integrator's settings.
    pub fn settings(&self) -> CaptureSettings {
        CaptureSettings {
            relay_wall: self.relay_wall.clone(),
            grid: self.grid,
            scan: self.scan(),
            laser_origin: self.laser_origin,
            sensor_origin: self.sensor_origin,
            bins: self.bins,
            dt_s: self.dt_s,
            t0_s: self.t0_s,
            device_legs: !self.unwarped,
            spp: self.spp,
            seed: self.seed,
            max_bounces: self.max_bounces,
            channel: self.channel,
        }
    }

    /// The worker pool the request asks for: `threads` threads, or one per core.
    pub fn thread_pool(&self) -> Result<rayon::ThreadPool, CaptureError> {
        let mut pool = rayon::ThreadPoolBuilder::new();
        if let Some(n) = self.threads {
            pool = pool.num_threads(n);
        }
        pool.build().map_err(CaptureError::Threads)
    }

    /// Render the capture of `scene` (loaded, with the file's settings taken:
    /// [`CaptureRequest::load_scene`]) in the request's thread pool: the wall and scan
    /// resolved and said (`observer.message`), then every sensor point, each reported to
    /// `observer.points`, which may cancel the capture. The capture does not depend on
    /// the threads.
    pub fn run(
        &self,
        scene: Arc<Scene>,
        observer: &mut (dyn CaptureObserver + Send),
    ) -> Result<Capture, CaptureError> {
        self.validate()?;
        for note in &scene.notes {
            observer.message(&format!("note: {note}"));
        }
        let settings = self.settings();
        // The geometry first, so a bad wall or grid is refused before any work.
        let geometry = crate::nlos::setup::resolve(&scene, &settings)?;
        observer.message(&describe(&geometry));
        let total = geometry.sensors.len() as u64;
        let pool = self.thread_pool()?;
        let progress = Progress::default();
        let observer = Mutex::new(observer);
        let poll = || {
            let done = progress.points_done.load(Ordering::Relaxed);
            let stop = match observer.lock() {
                Ok(mut o) => o.points(done, total).is_break(),
                Err(_) => true,
            };
            if stop {
                progress.cancel.store(true, Ordering::Relaxed);
            }
        };
        let captured = pool.install(|| render_capture_with(scene, &settings, &progress, &poll));
        let observer = observer.into_inner().map_err(|_| CaptureError::Cancelled)?;
        if progress.cancel.load(Ordering::Relaxed) {
            return Err(CaptureError::Cancelled);
        }
        let capture = captured?;
        observer.message(&format!(
            "rendered in {:.2} s ({:.1} M rays)",
            capture.render_s,
            capture.rays as f64 / 1e6
        ));
        Ok(capture)
    }

    /// Write the capture folder `out`: `H.npy`, `nlos.json` (with this request under
    /// `request`) and tal's `nlos.hdf5`, into a staging folder swapped in whole
    /// ([`Staging`]; `inputs`, the scene file among them, are never replaced).
    /// `observer.writing` may abandon it between files.
    pub fn write_folder(
        &self,
        capture: &Capture,
        out: &Path,
        inputs: &[&Path],
        observer: &mut (dyn CaptureObserver + Send),
    ) -> Result<CaptureMetadata, CaptureError> {
        let interrupted = |observer: &mut (dyn CaptureObserver + Send)| match observer.writing() {
            ControlFlow::Break(()) => Err(CaptureError::Interrupted),
            ControlFlow::Continue(()) => Ok(()),
        };
        interrupted(observer)?;
        let mut meta = CaptureMetadata::of(capture);
        meta.request = Some(serde_json::to_value(self).map_err(|e| {
            invalid(
                "scene",
                format!(": the request cannot be written as JSON: {e}"),
            )
        })?);
        let staging = Staging::new(out, inputs)?;
        let dir = staging.path();
        let shape: Vec<u64> = capture.shape().iter().map(|&d| d as u64).collect();
        write_npy_f32(&dir.join(NPY_NAME), &shape, &capture.h)?;
        interrupted(observer)?;
        write_json(&dir.join(JSON_NAME), &meta)?;
        interrupted(observer)?;
        write_hdf5(capture, &dir.join(HDF5_NAME))?;
        interrupted(observer)?;
        staging.commit()?;
        Ok(meta)
    }

    /// `tprf nlos`: the output folder checked first (new, empty or an earlier tprf
    /// output), the scene loaded with its file's settings in the fields not given
    /// ([`CaptureRequest::load_scene`]; what came from it is `observer.message`d as
    /// `from the scene file: FIELD VALUE (WHERE)`, fields named by `name`), the capture
    /// rendered and written. Returns the capture.
    pub fn capture_to_folder(
        &mut self,
        out: &Path,
        given: impl Fn(&str) -> bool,
        name: impl Fn(&str) -> String,
        observer: &mut (dyn CaptureObserver + Send),
    ) -> Result<Capture, CaptureError> {
        self.validate()?;
        let scene_path = self.scene.clone();
        let inputs = [Path::new(&scene_path)];
        crate::export::staging::check_target(out, &inputs)?;
        let (scene, notes) = self.load_scene(given)?;
        for n in &notes {
            observer.message(&format!("from the scene file: {}", n.text_with(&name)));
        }
        let capture = self.run(Arc::new(scene), observer)?;
        self.write_folder(&capture, out, &inputs, observer)?;
        Ok(capture)
    }
}

/// The wall and scan resolved, in one line.
fn describe(g: &CaptureGeometry) -> String {
    format!(
        "relay wall '{}': {:.3} m x {:.3} m; {} sensor points, {} laser point{}; {} bins of {} ({:.4} m) from {}{}",
        g.wall.name,
        g.wall.width_m,
        g.wall.height_m,
        g.sensors.len(),
        g.lasers.len(),
        if g.lasers.len() == 1 { "" } else { "s" },
        g.axis.bins,
        format_time(g.axis.dt_s),
        g.axis.dt_s * C_M_PER_S,
        format_time(g.axis.t0_s),
        if g.device_legs {
            ", device legs included"
        } else {
            ", unwarped"
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::NlosFileSettings;

    fn set<T>(value: T, from: &str) -> Option<FileSetting<T>> {
        Some(FileSetting {
            value,
            from: from.into(),
        })
    }

    /// A manifest's table: the option names, times with units; unknown keys refused;
    /// written back, it reads the same.
    #[test]
    fn capture_requests_read_toml_with_the_option_names() {
        let r: CaptureRequest = toml::from_str(
            "scene = \"builtin:nlos-z\"\ngrid = [16, 8]\nexhaustive = true\nlaser_grid = [3, 2]\n\
             dt = \"5mm\"\nt0 = 1e-9\nchannel = \"Red\"\nlaser_origin = [-0.5, 0, 0.25]\n",
        )
        .unwrap();
        assert_eq!(r.grid, [16, 8]);
        assert_eq!(r.scan(), Scan::Exhaustive { lx: 3, ly: 2 });
        assert_eq!(r.dt_s, crate::units::parse_time_s("5mm").unwrap());
        assert_eq!(r.t0_s, 1e-9);
        assert_eq!(r.channel, Channel::Red);
        assert_eq!(r.spp, 256);
        let back: CaptureRequest = toml::from_str(&toml::to_string(&r).unwrap()).unwrap();
        assert_eq!(back, r);
        let e = toml::from_str::<CaptureRequest>("scene = \"x\"\ngrids = [1, 1]\n").unwrap_err();
        assert!(e.to_string().contains("grids"), "{e}");
        // The default bin width is --dt 3mm's.
        assert_eq!(
            CaptureRequest::default().dt_s.to_bits(),
            crate::units::parse_time_s("3mm").unwrap().to_bits()
        );
    }

    /// Each refusal names its field, as the command line's flags where it reads them.
    #[test]
    fn bad_fields_are_named() {
        let r = CaptureRequest::new("builtin:nlos-z");
        r.validate().unwrap();
        let cases = [
            (CaptureRequest::new(" "), "scene: no scene given"),
            (
                CaptureRequest {
                    grid: [0, 4],
                    ..r.clone()
                },
                "grid 0x4: a grid needs at least one sensor point along each axis (e.g. grid 64x64)",
            ),
            (
                CaptureRequest {
                    confocal: true,
                    exhaustive: true,
                    ..r.clone()
                },
                "confocal and exhaustive are two scans",
            ),
            (
                CaptureRequest {
                    confocal: true,
                    laser_point: Some([0.0; 3]),
                    ..r.clone()
                },
                "laser_point is the one laser point of a single scan, not of a confocal one",
            ),
            (
                CaptureRequest {
                    laser_grid: Some([2, 2]),
                    ..r.clone()
                },
                "laser_grid is the laser points of an exhaustive scan",
            ),
            (
                CaptureRequest {
                    exhaustive: true,
                    laser_grid: Some([2, 0]),
                    ..r.clone()
                },
                "laser_grid 2x0: an exhaustive scan needs",
            ),
            (
                CaptureRequest {
                    sensor_origin: Some([0.0, f32::NAN, 0.0]),
                    ..r.clone()
                },
                "sensor_origin [0.0, NaN, 0.0]: expected three finite numbers",
            ),
            (
                CaptureRequest {
                    bins: Some(0),
                    ..r.clone()
                },
                "bins 0: a capture needs at least one time bin",
            ),
            (
                CaptureRequest {
                    dt_s: -1.0,
                    ..r.clone()
                },
                "dt -1 s: the bin width must be a positive",
            ),
            (
                CaptureRequest {
                    spp: 0,
                    ..r.clone()
                },
                "spp 0: a capture needs at least one sample",
            ),
            (
                CaptureRequest {
                    threads: Some(0),
                    ..r.clone()
                },
                "threads must be at least 1",
            ),
        ];
        for (req, want) in cases {
            let got = req.validate().unwrap_err().to_string();
            assert!(got.starts_with(want), "{got:?} should start {want:?}");
        }
        let Err(CaptureError::Invalid(p)) = CaptureRequest { grid: [0, 4], ..r }.validate() else {
            panic!("accepted");
        };
        assert!(
            p.text_with(|f| format!("--{}", f.replace('_', "-")))
                .ends_with("(e.g. --grid 64x64)")
        );
    }

    /// mitransient's NLOS scene as its capture meter and integrator say it: every
    /// setting taken into the fields not given, in order, each noted.
    fn nlos_file() -> FileSettings {
        FileSettings {
            nlos: Some(NlosFileSettings {
                relay_wall: set("wall".into(), "id"),
                grid: set([32, 16], "width"),
                capture_type: set("exhaustive".into(), "capture_type"),
                sensor_origin: set([-0.5, 0.0, 0.25], "sensor_origin"),
                laser_origin: set([0.5, 0.0, 0.25], "laser_origin"),
                laser_point: set([0.1, 0.2, 0.0], "laser_lookat"),
                device_legs: set(false, "account"),
                bins: set(300, "temporal_bins"),
                dt_opl_m: set(0.006, "bin_width_opl"),
                t0_opl_m: set(1.85, "start_opl"),
                spp: set(8, "sample_count"),
                hidden_bounces: set(2, "max_depth"),
                ..NlosFileSettings::default()
            }),
            ..FileSettings::default()
        }
    }

    #[test]
    fn a_file_fills_what_was_not_given() {
        let mut r = CaptureRequest::new("x.xml");
        let notes = r.with_file_defaults(&nlos_file(), |_| false);
        let fields: Vec<_> = notes.iter().map(|n| n.field).collect();
        // An exhaustive scan has no single laser point: the file's is not taken.
        assert_eq!(
            fields,
            [
                "grid",
                "scan",
                "laser_origin",
                "sensor_origin",
                "dt",
                "t0",
                "bins",
                "unwarped",
                "spp",
                "max_bounces",
                "relay_wall"
            ]
        );
        // mitransient's exhaustive scan lights the sensor grid's points.
        assert_eq!(r.scan(), Scan::Exhaustive { lx: 32, ly: 16 });
        assert_eq!(r.grid, [32, 16]);
        assert_eq!(r.laser_origin, Some([0.5, 0.0, 0.25]));
        assert_eq!(r.dt_s, 0.006 / C_M_PER_S);
        assert_eq!(r.t0_s, 1.85 / C_M_PER_S);
        assert_eq!((r.bins, r.spp, r.max_bounces), (Some(300), 8, 2));
        assert!(r.unwarped);
        assert_eq!(r.relay_wall, "wall");
        assert_eq!(notes[0].to_string(), "grid 32x16 (width)");
        assert_eq!(notes[7].to_string(), "unwarped left out (account)");
        // A scene file without NLOS settings changes nothing.
        let mut plain = CaptureRequest::new("builtin:nlos-z");
        assert!(
            plain
                .with_file_defaults(&FileSettings::default(), |_| false)
                .is_empty()
        );
        assert_eq!(plain, CaptureRequest::new("builtin:nlos-z"));
    }

    /// A field given keeps its value (the default's too); a scan given keeps the file's
    /// out, and a single scan takes the file's laser point.
    #[test]
    fn what_was_given_wins() {
        let mut r = CaptureRequest {
            confocal: true,
            ..CaptureRequest::new("x.xml")
        };
        let given = ["grid", "spp", "dt", "relay_wall", "confocal"];
        let notes = r.with_file_defaults(&nlos_file(), |k| given.contains(&k));
        assert!(
            notes
                .iter()
                .all(|n| !given.contains(&n.field) && n.field != "scan")
        );
        assert_eq!(r.scan(), Scan::Confocal);
        assert_eq!(
            (r.grid, r.spp, r.dt_s),
            ([64, 64], 256, DEFAULT_CAPTURE_DT_S)
        );
        assert_eq!(r.relay_wall, "relay_wall");
        let mut f = nlos_file();
        if let Some(n) = &mut f.nlos {
            n.capture_type = set("single".into(), "capture_type");
        }
        let mut single = CaptureRequest::new("x.xml");
        single.with_file_defaults(&f, |_| false);
        assert_eq!(
            single.scan(),
            Scan::Single {
                laser_point: Some([0.1, 0.2, 0.0])
            }
        );
    }

    /// An observer sees every sensor point once, counted up to the total; one that
    /// breaks cancels the capture.
    #[test]
    fn the_observer_sees_each_point_and_may_cancel() {
        #[derive(Default)]
        struct Count {
            calls: u64,
            last: (u64, u64),
            stop_after: Option<u64>,
            lines: Vec<String>,
        }
        impl CaptureObserver for Count {
            fn message(&mut self, line: &str) {
                self.lines.push(line.into());
            }
            fn points(&mut self, done: u64, total: u64) -> ControlFlow<()> {
                self.calls += 1;
                self.last = (self.last.0.max(done), total);
                if self.stop_after.is_some_and(|n| self.calls >= n) {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            }
        }
        let mut r = CaptureRequest {
            grid: [4, 3],
            spp: 4,
            threads: Some(2),
            ..CaptureRequest::new("builtin:nlos-z")
        };
        let (scene, notes) = r.load_scene(|_| false).unwrap();
        assert!(notes.is_empty());
        let scene = Arc::new(scene);
        let mut seen = Count::default();
        let c = r.run(scene.clone(), &mut seen).unwrap();
        assert_eq!((seen.calls, seen.last), (12, (12, 12)));
        assert_eq!(c.shape()[1..], [4, 3]);
        assert!(
            seen.lines
                .iter()
                .any(|l| l.starts_with("relay wall 'relay_wall'"))
        );
        let mut stop = Count {
            stop_after: Some(1),
            ..Count::default()
        };
        let one_thread = CaptureRequest {
            threads: Some(1),
            ..r
        };
        assert!(matches!(
            one_thread.run(scene.clone(), &mut stop),
            Err(CaptureError::Cancelled)
        ));
        assert_eq!(stop.calls, 1);
        // A point of far more samples than a test has time for is asked about while it
        // runs: the third look stops it.
        let endless = CaptureRequest {
            grid: [1, 1],
            spp: 1 << 30,
            ..one_thread
        };
        let mut stop = Count {
            stop_after: Some(3),
            ..Count::default()
        };
        assert!(matches!(
            endless.run(scene, &mut stop),
            Err(CaptureError::Cancelled)
        ));
        assert_eq!((stop.calls, stop.last), (3, (0, 1)));
    }
}
