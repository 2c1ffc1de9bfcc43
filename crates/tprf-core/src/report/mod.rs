//! Reports: measurements of the renderer for people and papers. A report reads the
//! transport and the film (and the references); the renderer knows nothing of reports.
//!
//! - [`converge`]: error against run time for several estimator settings, against an
//!   exact reference or a long render (`tprf converge`).
//! - [`stability`]: stiff and extreme cases, each against an answer derived
//!   independently (`tprf stability`).
//! - [`sensor_cases`]: the suite's sensor rows (pulses, gates, noise, huge values).
//! - [`plot`]: the log-log convergence plot of given curves.
//!
//! Errors are [`ReportError`]s.

pub mod converge;
mod error;
pub mod plot;
pub mod sensor_cases;
pub mod stability;

pub use error::ReportError;
