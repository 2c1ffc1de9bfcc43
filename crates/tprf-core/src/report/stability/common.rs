//! What the cases share: the size they run at, a render, and statistics of its pixels.

use crate::film::{TimeAxis, TprfFilm};
use crate::request::{RenderRequest, Session};
use crate::scene::{Scene, TriangleAttrs};
use crate::transport::RenderSettings;
use glam::Vec2;
use std::sync::Arc;

/// How big the cases are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Size {
    /// Small films, few samples: seconds, for the tests.
    Test,
    /// Larger films and more samples: `tprf stability`.
    Full,
}

impl Size {
    /// `test` at [`Size::Test`], `full` at [`Size::Full`].
    pub(super) fn pick<T>(self, test: T, full: T) -> T {
        match self {
            Size::Test => test,
            Size::Full => full,
        }
    }
}

/// Render `scene` at `w x h` on `axis`, `spp` samples in the progressive passes of
/// `tprf render`: the request `tprf render` would make of these settings.
pub(super) fn render(
    scene: Scene,
    w: usize,
    h: usize,
    axis: TimeAxis,
    spp: u64,
    settings: RenderSettings,
    bounces_separate: u32,
) -> TprfFilm {
    let request = RenderRequest {
        scene: scene.name.clone(),
        width: w,
        height: h,
        bins: axis.bins,
        t0_s: Some(axis.t0_s),
        dt_s: Some(axis.dt_s),
        spp: Some(spp),
        bounces_separate,
        ..RenderRequest::default()
    }
    .with_settings(settings);
    let mut session =
        Session::with_scene(&request, Arc::new(scene)).expect("stability films are small");
    session.run(|_, _| std::ops::ControlFlow::Continue(()));
    session.into_film()
}

/// NaN and infinite values in the film's cube.
pub(super) fn non_finite(film: &TprfFilm) -> u64 {
    film.cube_f64().iter().filter(|v| !v.is_finite()).count() as u64
}

/// Mean of `v` (0 when empty).
pub(super) fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Standard error of the mean of `v` (independent values).
pub(super) fn std_error(v: &[f64]) -> f64 {
    let m = mean(v);
    let n = v.len() as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0) / n).sqrt()
}

/// Energy-weighted mean of bin centres, seconds.
pub(super) fn mean_arrival_s(tprf: &[f64], axis: &TimeAxis) -> f64 {
    let total: f64 = tprf.iter().sum();
    tprf.iter()
        .enumerate()
        .map(|(b, v)| v * axis.bin_center_s(b))
        .sum::<f64>()
        / total
}

/// Per-pixel TPRFs of a film.
pub(super) fn pixels(film: &TprfFilm) -> Vec<Vec<f64>> {
    let l = film.layout();
    (0..l.height)
        .flat_map(|y| (0..l.width).map(move |x| (x, y)))
        .map(|(x, y)| film.pixel_tprf(x, y))
        .collect()
}

/// Attributes of a flat-shaded triangle of material `material`.
pub(super) fn triangle_attrs(material: u32) -> TriangleAttrs {
    TriangleAttrs {
        normals: None,
        uv: [Vec2::ZERO; 3],
        material,
    }
}
