//! The automatic time window: a small pilot render finds when light first arrives and
//! when the light that matters has arrived.

use super::integrator::{Renderer, Sink};
use super::sampler::Sampler;
use crate::film::{FilmError, MAX_BINS, TimeAxis};
use crate::units::C_M_PER_S;
use rayon::prelude::*;

/// What the user fixed of the time axis; the rest is chosen from a pilot render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WindowRequest {
    pub t0_s: Option<f64>,
    pub dt_s: Option<f64>,
    pub bins: usize,
    /// The film's width over its height: the pilot render samples the same field of
    /// view (0, or anything not positive and finite, is taken as square).
    pub aspect: f64,
}

/// Why no time axis could be chosen.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum WindowError {
    #[error("the number of bins must be at least 1")]
    NoBins,
    #[error(
        "no light reaches the camera in a pilot render: nothing to bin (check the lights, \
         or fix the window's start and bin width)"
    )]
    NoLight,
    /// The window's start was given, and the pilot saw no light arrive after it.
    #[error(
        "no light arrives after the window start {}: the pilot render saw the last at {}; \
         start the window earlier",
        crate::units::format_time(*t0_s),
        crate::units::format_time(*last_s)
    )]
    NoLightAfterStart { t0_s: f64, last_s: f64 },
    /// The axis asked for (or the one chosen) is not a valid [`TimeAxis`].
    #[error(transparent)]
    Axis(#[from] FilmError),
}

/// Pilot pixels (about; 48 x 48 for a square film) and samples per pixel.
const PILOT_PIXELS: f64 = 48.0 * 48.0;
const PILOT_SPP: u32 = 4;
/// Fraction of the pilot's energy the automatic window holds.
const ENERGY_HELD: f64 = 0.995;

struct PilotSink {
    end_s: f64,
    arrivals: Vec<(f64, f64)>,
}

impl Sink for PilotSink {
    fn add(&mut self, arrival_s: f64, value: f64, _scatterings: u32) {
        if value > 0.0 && value.is_finite() && arrival_s <= self.end_s {
            self.arrivals.push((arrival_s, value));
        }
    }
    fn window_end_s(&self) -> f64 {
        self.end_s
    }
}

/// Round `x > 0` up to 1, 2, 2.5 or 5 times a power of ten.
fn nice_ceil(x: f64) -> f64 {
    let p = 10f64.powf(x.log10().floor());
    for m in [1.0, 2.0, 2.5, 5.0, 10.0] {
        if m * p >= x * (1.0 - 1e-12) {
            return m * p;
        }
    }
    10.0 * p
}

/// Every arrival of a pilot render of `renderer` (about 2300 pixels in the film's
/// `aspect`, 4 spp) up to `horizon_s`, sorted by time: `(arrival_s, value)`.
fn pilot_arrivals(renderer: &Renderer, horizon_s: f64, aspect: f64) -> Vec<(f64, f64)> {
    let seed = renderer.settings().seed ^ 0x5049_4c4f_5400_0000;
    let aspect = if aspect.is_finite() && aspect > 0.0 {
        aspect.clamp(1e-3, 1e3)
    } else {
        1.0
    };
    let pilot_w = (PILOT_PIXELS * aspect).sqrt().round().max(1.0) as usize;
    let pilot_h = (PILOT_PIXELS / pilot_w as f64).round().max(1.0) as usize;
    let mut arrivals = (0..pilot_w * pilot_h)
        .into_par_iter()
        .map(|p| {
            let mut sink = PilotSink {
                end_s: horizon_s,
                arrivals: Vec::new(),
            };
            let mut rng = Sampler::new(seed, 0, p as u64);
            for _ in 0..PILOT_SPP {
                renderer.trace_sample(
                    p % pilot_w,
                    p / pilot_w,
                    pilot_w,
                    pilot_h,
                    &mut rng,
                    &mut sink,
                );
            }
            sink.arrivals
        })
        .flatten()
        .collect::<Vec<_>>();
    arrivals.sort_by(|a, b| a.0.total_cmp(&b.0));
    arrivals
}

/// When the surfaces' returns arrive through a scene-wide medium of extinction
/// `sigma_t_per_m` and index `n`: the time by which half of their light has arrived,
/// from the arrivals of a pilot with the media emptied (`clear`, sorted by time), each
/// attenuated by the medium over its whole path, `e^(-sigma_t opl / n)` (`opl = c t`).
/// In fog this is a slice where the near targets stand out of the backscatter; `None`
/// without arrivals.
fn returns_time_s(clear: &[(f64, f64)], sigma_t_per_m: f64, n: f64) -> Option<f64> {
    let attenuated = |&(t, v): &(f64, f64)| v * (-sigma_t_per_m * t * C_M_PER_S / n).exp();
    let total: f64 = clear.iter().map(attenuated).sum();
    if !(total > 0.0) {
        return None;
    }
    let mut acc = 0.0;
    for a in clear {
        acc += attenuated(a);
        if acc >= 0.5 * total {
            return Some(a.0);
        }
    }
    clear.last().map(|a| a.0)
}

/// The first arrival of time-sorted `arrivals` and the time by which they hold
/// [`ENERGY_HELD`] of their energy, seconds; `None` without arrivals.
fn energy_span(arrivals: &[(f64, f64)]) -> Option<(f64, f64)> {
    let first_s = arrivals.first()?.0;
    let total: f64 = arrivals.iter().map(|a| a.1).sum();
    let mut acc = 0.0;
    for &(t, v) in arrivals {
        acc += v;
        if acc >= ENERGY_HELD * total {
            return Some((first_s, t));
        }
    }
    Some((first_s, arrivals[arrivals.len() - 1].0))
}

/// Resolve the time axis. Given both `t0_s` and `dt_s`, no pilot is needed. Otherwise a
/// pilot render (about 2300 pixels in the film's aspect, 4 spp, window 1000 scene
/// diagonals long) records every
/// arrival; the window runs from just before the first arrival to the time that holds
/// 99.5 % of the pilot's energy, with a 2 % margin each side, and the bin width is
/// rounded up to 1, 2, 2.5 or 5 x 10^k seconds. In a scene with media a second pilot
/// with the media emptied ([`Renderer::without_extinction`]) times the surfaces'
/// returns, and the window holds 99.5 % of each pilot's energy: fog's backscatter and
/// the targets behind it.
pub fn auto_window(renderer: &Renderer, req: WindowRequest) -> Result<TimeAxis, WindowError> {
    choose_window(renderer, req).map(|w| w.axis)
}

/// The automatic window ([`auto_window`]) and, in a scene with media, when the
/// surfaces' returns arrive in it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChosenWindow {
    pub axis: TimeAxis,
    /// In a scene with a homogeneous scene-wide medium whose window a pilot chose: the
    /// time by which half of the surfaces' returns, attenuated by the medium, have
    /// arrived (seconds; `returns_time_s`). Where a view of targets behind fog opens:
    /// every pixel's own peak is the fog's backscatter at the start. `None` otherwise.
    pub surface_returns_s: Option<f64>,
}

/// [`auto_window`], with the time of the surfaces' returns in a scene with media.
pub fn choose_window(renderer: &Renderer, req: WindowRequest) -> Result<ChosenWindow, WindowError> {
    // Refused before the pilot render, which would be wasted.
    if req.bins == 0 {
        return Err(WindowError::NoBins);
    }
    if req.bins > MAX_BINS {
        return Err(FilmError::BinCount { bins: req.bins }.into());
    }
    if let Some(dt_s) = req.dt_s
        && !(dt_s > 0.0 && dt_s.is_finite())
    {
        return Err(FilmError::BinWidth { dt_s }.into());
    }
    if let Some(t0_s) = req.t0_s
        && !t0_s.is_finite()
    {
        return Err(FilmError::StartNotFinite { t0_s }.into());
    }
    if let (Some(t0), Some(dt)) = (req.t0_s, req.dt_s) {
        return Ok(ChosenWindow {
            axis: TimeAxis::new(t0, dt, req.bins)?,
            surface_returns_s: None,
        });
    }
    let diag_m = renderer
        .scene()
        .bounds_with_eye(renderer.camera().position())
        .diagonal_m() as f64;
    let cam_m = renderer.camera().position().length() as f64;
    let horizon_s = 1000.0 * (diag_m + cam_m).max(1e-9) / C_M_PER_S;
    // In a medium most of the light is its backscatter near the camera, and a target
    // behind it returns a small share later: the surfaces' returns are timed by a second
    // pilot with the media emptied (same indices, so the same arrival times).
    let own = pilot_arrivals(renderer, horizon_s, req.aspect);
    let clear = renderer
        .without_extinction()
        .map(|r| pilot_arrivals(&r, horizon_s, req.aspect));
    let surface_returns_s = match (&clear, renderer.scene_extinction()) {
        (Some(c), Some((sigma_t, n))) => returns_time_s(c, f64::from(sigma_t), f64::from(n)),
        _ => None,
    };
    let mut first_s = f64::INFINITY;
    let mut held_s = f64::NEG_INFINITY;
    let mut last_s = f64::NEG_INFINITY;
    for mut arrivals in std::iter::once(own).chain(clear) {
        if let Some(&(t, _)) = arrivals.last() {
            last_s = last_s.max(t);
        }
        if let Some(t0_s) = req.t0_s {
            arrivals.retain(|a| a.0 >= t0_s);
        }
        if let Some((first, held)) = energy_span(&arrivals) {
            first_s = first_s.min(first);
            held_s = held_s.max(held);
        }
    }
    if !first_s.is_finite() {
        return Err(match req.t0_s {
            Some(t0_s) if last_s.is_finite() => WindowError::NoLightAfterStart { t0_s, last_s },
            _ => WindowError::NoLight,
        });
    }
    let span_s = (held_s - first_s).max(first_s * 0.05).max(1e-18);
    let start_s = req.t0_s.unwrap_or((first_s - 0.02 * span_s).max(0.0));
    let end_s = held_s + 0.02 * span_s;
    let dt_s = match req.dt_s {
        Some(dt) => dt,
        None => nice_ceil(((end_s - start_s) / req.bins as f64).max(1e-21)),
    };
    let t0_s = match req.t0_s {
        Some(t0) => t0,
        None => (start_s / dt_s).floor() * dt_s,
    };
    Ok(ChosenWindow {
        axis: TimeAxis::new(t0_s, dt_s, req.bins)?,
        surface_returns_s,
    })
}

#[cfg(test)]
mod tests {
    use super::nice_ceil;

    #[test]
    fn nice_numbers() {
        assert_eq!(nice_ceil(1.0), 1.0);
        assert!((nice_ceil(1.2e-12) - 2e-12).abs() < 1e-24);
        assert!((nice_ceil(2.1e-12) - 2.5e-12).abs() < 1e-24);
        assert!((nice_ceil(3e-9) - 5e-9).abs() < 1e-21);
        assert!((nice_ceil(6e-9) - 1e-8).abs() < 1e-21);
    }
}
