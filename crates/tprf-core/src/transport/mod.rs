//! Transport: a progressive transient path tracer. It samples the Neumann series
//! `R = R0 + G R0 + G G R0 + ...` of the transient rendering equation `R = R0 + S P R`:
//! a path with k scattering events is one sample of the k-th term, and it arrives at
//! `t = (optical path length, light -> ... -> eye) / c`, plus the delays drawn at
//! luminescent vertices ([`luminescence`]), which re-emit light after they receive it.

pub mod adaptive;
pub mod ambient;
pub mod bsdf;
mod carried;
mod connect;
pub mod derivative;
mod integrator;
pub mod lights;
pub mod luminescence;
pub mod media;
pub mod polarization;
pub mod polarized;
pub mod progressive;
pub mod sampler;
pub mod split;
pub mod surface;
mod window;

pub use integrator::{PassStats, RayKind, RenderSettings, Renderer, Sink};
pub use luminescence::DelaySampling;
pub use polarized::{PolarizationError, PolarizedTracer};
pub use split::Strategy;
pub use window::{ChosenWindow, WindowError, WindowRequest, auto_window, choose_window};
