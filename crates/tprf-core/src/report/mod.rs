//! Reports: measurements of the renderer for people and papers. A report reads the
//! transport and the film (and the references); the renderer knows nothing of reports.
//!
//! - [`converge`]: error against run time for several estimator settings, against an
//!   exact reference or a long render (`tprf converge`).
//! - [`stability`]: stiff and extreme cases as a verdict table, each row against an
//!   independently derived answer or, for the scale and bin-count rows, against the
//!   renderer's own result on an equivalent input (an invariance check)
//!   (`tprf stability`).
//! - [`plot`]: the log-log convergence plot of given curves.
//!
//! Errors are [`ReportError`]s.

pub mod converge;
mod error;
pub mod plot;
pub mod stability;

pub use error::ReportError;
