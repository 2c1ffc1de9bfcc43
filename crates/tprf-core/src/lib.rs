//! tprf-core: transient rendering (Smith, Skorupski & Davis 2008) without a window or
//! a command line.
//!
//! Data flow, each arrow one-way (see ARCHITECTURE.md at the repository root):
//! `scene -> accel -> transport -> film -> (sensor, export, report)`.
//!
//! | module | what |
//! | --- | --- |
//! | [`budget`] | memory budgets checked before input-sized allocations; regular files read whole, bounded |
//! | [`scene`] | the world in metres: triangles, materials, lights, camera; glTF import and export, built-in scenes |
//! | [`accel`] | the obvhs CWBVH: closest-hit and any-hit queries |
//! | [`transport`] | the transient path tracer (NEE + MIS, Russian roulette, optical path length per path), the automatic time window, [`transport::progressive::render`] (the one pass loop) |
//! | [`film`] | the TPRF store: per pixel, per time bin, f64 sums in two independent halves, per-bounce layers; snapshots for readers |
//! | [`sensor`] | section 6 of the paper: `M_i = max(0, Noise + integral (TPRF * Light)(t) Exposure_i(t) dt)` through bin-integrated kernels `K_i` |
//! | [`oned`] | the paper's 1-D world as exact impulse trains |
//! | [`reference`](mod@reference) | exact answers (transient furnace, lit plane, 1-D world in 3-D) |
//! | [`export`] | `.npy` cubes with `tprf.json`, PNG images and frames, CSV |
//! | [`request`] | one render described once ([`request::RenderRequest`]), validated once; made ready ([`request::Session`]), rendered to a folder, or on the background [`request::worker`] |
//! | [`report`] | error against run time, stiff and extreme cases |
//! | [`nlos`] | non-line-of-sight captures (relay wall, wall-point integrator), tal's HDF5 capture format, reconstruction |
//!
//! A render from scene to one pixel's TPRF (radiance per bin against arrival time):
//!
//! ```
//! use std::ops::ControlFlow;
//! use std::sync::Arc;
//! use tprf_core::film::{FilmLayout, TprfFilm};
//! use tprf_core::transport::progressive::{self, Schedule};
//! use tprf_core::transport::{RenderSettings, Renderer, WindowRequest, auto_window};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let scene = tprf_core::scene::load("builtin:cornell")?;
//! let renderer = Renderer::new(Arc::new(scene), RenderSettings::default());
//! // A window from the first light to where 99.9 % of it has arrived, 64 bins.
//! let request = WindowRequest { bins: 64, ..WindowRequest::default() };
//! let axis = auto_window(&renderer, request)?;
//! let layout = FilmLayout { width: 8, height: 8, axis, bounces_separate: 2 , luminescence: false};
//! let mut film = TprfFilm::new(layout)?;
//! progressive::render(&renderer, &mut film, &Schedule::spp(4), |_, _| ControlFlow::Continue(()));
//!
//! // A bin holds the integral over the bin: summed over time, a pixel's TPRF is its
//! // steady-state radiance.
//! let tprf = film.pixel_tprf(4, 4);
//! let steady = film.steady()[4 * 8 + 4];
//! assert!(steady > 0.0);
//! assert!((tprf.iter().sum::<f64>() - steady).abs() <= 1e-9 * steady);
//! // The per-bounce layers (direct, 1, 2, more scatterings) add up to the total.
//! let by_bounce = film.pixel_bounces(4, 4);
//! for (b, total) in tprf.iter().enumerate() {
//!     let layers: f64 = by_bounce.iter().map(|layer| layer[b]).sum();
//!     assert!((layers - total).abs() <= 1e-9 * total.abs().max(1e-30));
//! }
//! # Ok(())
//! # }
//! ```

pub mod accel;
pub mod budget;
pub mod export;
pub mod film;
pub mod nlos;
pub mod oned;
pub mod reference;
pub mod report;
pub mod request;
pub mod scene;
pub mod sensor;
pub mod transport;
pub mod units;
