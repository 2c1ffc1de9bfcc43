//! Why a report could not be made.

use crate::export::ExportError;
use crate::film::FilmError;
use crate::reference::ReferenceError;
use crate::scene::SceneError;
use std::path::PathBuf;

/// Why a report could not be made. Messages name the value or the file; they speak of
/// the film and the reference, not of command-line flags (the command adds those).
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The run does not fit in the memory left.
    #[error(transparent)]
    Budget(#[from] crate::budget::BudgetError),
    #[error("an empty estimator setting (use 'default')")]
    EmptySetting,
    #[error("setting '{spec}': {why}")]
    Setting { spec: String, why: String },
    #[error(
        "give a reference: analytic:furnace?rho=0.9 (or analytic:plane, analytic:oned), or a \
         .npy cube from a long `tprf render`"
    )]
    NoReference,
    #[error(
        "the analytic reference '{reference}' builds its own scene: leave the scene out (got '{scene}')"
    )]
    SceneWithAnalytic { reference: String, scene: String },
    #[error(
        "unknown reference '{0}': expected analytic:furnace, analytic:plane, analytic:oned, \
         or a .npy cube written by `tprf render`"
    )]
    UnknownReference(String),
    #[error("a .npy reference needs the scene it was rendered from")]
    NoScene,
    #[error("film width and height must be in 1..={max} (got {width} x {height})")]
    FilmSide {
        width: usize,
        height: usize,
        max: usize,
    },
    #[error(
        "a {width} x {height} x {bins} film is too large for a convergence run (at most \
         {max} pixel-bins: the film, its reference and a copy are kept)"
    )]
    FilmTooLarge {
        width: usize,
        height: usize,
        bins: usize,
        max: usize,
    },
    #[error(
        "the film (size and time axis) comes from the reference cube; leave its width, \
         height, bins, start and bin width unset"
    )]
    FilmFromCube,
    #[error("{path}: value {index} is not finite")]
    NotFinite { path: PathBuf, index: usize },
    #[error("{path}: unknown channel '{channel}'")]
    UnknownChannel { path: PathBuf, channel: String },
    #[error("cannot load the plot font")]
    PlotFont,
    #[error("drawing the plot: {0}")]
    Plot(String),
    #[error(transparent)]
    Reference(#[from] ReferenceError),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Film(#[from] FilmError),
    #[error(transparent)]
    Export(#[from] ExportError),
}
