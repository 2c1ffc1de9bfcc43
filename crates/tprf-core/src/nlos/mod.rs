//! Non-line-of-sight (NLOS) imaging: the paper's "shape recovery including hidden
//! surfaces" (its section 7) as today's research does it.
//!
//! A laser pulse hits a point `l` of a planar diffuse *relay wall*; light bounces into
//! the hidden scene and back to the wall, where a SPAD focused on a point `s` records
//! its transient. [`capture`] renders those transients (the wall-point integrator:
//! paths start from `s` at a point sampled on the hidden geometry, as mitransient's
//! `transient_nlos_path` "hidden geometry sampling" does, and join the laser spot `l`
//! from every vertex); [`files`] writes and reads them in tal's HDF5 capture format
//! (`nlos.hdf5`), as `H.npy` and `nlos.json`; `reconstruct` recovers the hidden
//! geometry on a voxel volume.
//!
//! One module per concept: [`wall`] (the relay wall and its grids), [`setup`] (the scan:
//! sensor and laser points, devices, time axis), [`capture`] (the renderer),
//! [`files`] (the capture format and the reconstruction's files), [`reconstruct`] (bp,
//! fbp, f-k migration, phasor fields), [`spad`] (`tprf sensor`'s SPAD on a capture).

pub mod capture;
pub mod files;
pub mod reconstruct;
pub mod setup;
pub mod spad;
pub mod wall;

pub use capture::{Capture, render_capture, render_capture_with};
pub use setup::{CaptureGeometry, CaptureSettings, Scan};
pub use wall::RelayWall;

/// Why an NLOS capture (or its files) could not be made. Messages name the flag, the
/// node or the file concerned and what to do.
#[derive(Debug, thiserror::Error)]
pub enum NlosError {
    /// In the words of the file the scene came from: a Mitsuba XML file's shape ids, a
    /// glTF file's node names.
    #[error("{}", no_relay_wall_message(.scene, .name, .known, *.xml))]
    NoRelayWall {
        /// The scene (its file, or `builtin:...`).
        scene: String,
        name: String,
        /// The names it has, as listed (at most [`KNOWN_LISTED`], then a count).
        known: String,
        /// Whether the scene is a Mitsuba XML file.
        xml: bool,
    },
    #[error(
        "relay wall '{name}' is not planar: a vertex lies {deviation_m:.3e} m off its plane \
         (allowed {tolerance_m:.1e} m); the relay wall must be one flat surface"
    )]
    WallNotPlanar {
        name: String,
        deviation_m: f64,
        tolerance_m: f64,
    },
    #[error("relay wall '{name}' has no area (its triangles are degenerate)")]
    WallEmpty { name: String },
    #[error("the scene has no hidden geometry: every triangle belongs to the relay wall '{name}'")]
    NoHiddenGeometry { name: String },
    #[error("{0}")]
    Setup(String),
    #[error(transparent)]
    Film(#[from] crate::film::FilmError),
    #[error(transparent)]
    Export(#[from] crate::export::ExportError),
    #[error(transparent)]
    Budget(#[from] crate::budget::BudgetError),
    #[error(transparent)]
    Sensor(#[from] crate::sensor::SensorError),
    #[error("{path}: {message}")]
    File { path: String, message: String },
}

/// Most object names a missing relay wall's error lists (a scene of 100 000 shapes with
/// ids would otherwise print them all).
pub const KNOWN_LISTED: usize = 12;

/// The error of a relay wall not found, with what the user can do in their file's terms.
fn no_relay_wall_message(scene: &str, name: &str, known: &str, xml: bool) -> String {
    if xml {
        format!(
            "no relay wall: {scene} has no <shape> with id=\"{name}\" (shape ids: {known}); \
             give the wall's <shape> id=\"{name}\", or put an nlos_capture_meter <sensor> in \
             it as mitransient's NLOS scenes do, or choose it with --relay-wall ID"
        )
    } else {
        format!(
            "no relay wall: {scene} has no object named '{name}' (named objects: {known}); \
             name the wall's glTF node '{name}' or choose it with --relay-wall NAME"
        )
    }
}
