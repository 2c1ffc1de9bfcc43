//! A render of several bands (`wavelengths`), what `render_to_folder` needs for it: the
//! request's checks, each band's request, the time window shared by the bands, the
//! weighted cube `tprf.npy` holds (their luminance or one band) and the disk's room.
//! `render_to_folder` renders one [`Session`] per band, each its own film, by the one
//! pass loop, and writes `tprf_spectral.npy` `[L, H, W, T]` beside `tprf.npy`.

use super::{Problem, RenderRequest, RequestError, Session};
use crate::export::{self, CubeFormat};
use crate::film::{FilmLayout, FilmSnapshot, TprfFilm};
use crate::scene::Channel;
use crate::scene::wavelengths::check_list;
use crate::units::format_time;
use std::path::Path;

/// The spectral cube's file name.
pub(super) const SPECTRAL_NPY: &str = "tprf_spectral.npy";

/// How `tprf.json` names the luminance weighting.
pub(super) const LUMINANCE_RULE: &str = "CIE 1931 Y normalised: sum_k w_k band_k, w_k = ybar(lambda_k) \
     D_k / sum_j ybar(lambda_j) D_j, the trapezoid rule over the wavelengths sorted (D_k \
     half the distance between a band's neighbours, to its one neighbour at an end); the \
     weights sum to 1, so a flat spectrum's luminance is its value";

impl RenderRequest {
    /// `wavelengths` checked: none twice, at most [`crate::scene::wavelengths::MAX_BANDS`];
    /// `channel` the grey default (luminance) or one of them; an `.npy` cube, the whole
    /// image, no bounce layers.
    pub(super) fn check_wavelengths(&self) -> Result<(), RequestError> {
        if self.wavelengths.is_empty() {
            return Ok(());
        }
        let refuse = |p: Problem| Err(RequestError::invalid(p));
        if let Err(why) = check_list(&self.wavelengths) {
            return refuse(Problem::field("wavelengths").text(format!(": {why}")));
        }
        match self.channel {
            Channel::Gray => {}
            Channel::Wavelength(w) if self.wavelengths.contains(&w) => {}
            other => {
                return refuse(
                    Problem::field("channel")
                        .text(format!(" {} with ", other.name()))
                        .and("wavelengths")
                        .text(
                            ": tprf.npy holds the bands' luminance (channel gray, the \
                             default) or one of the wavelengths",
                        ),
                );
            }
        }
        if self.format == CubeFormat::Zarr {
            return refuse(
                Problem::field("format")
                    .text(" zarr with ")
                    .and("wavelengths")
                    .text(": the spectral cube is written as .npy only"),
            );
        }
        for (field, set) in [
            ("shard", self.shard.is_some()),
            ("bounces_separate", self.bounces_separate > 0),
            ("polarized", self.polarized),
        ] {
            if set {
                return refuse(
                    Problem::field(field)
                        .text(" with ")
                        .and("wavelengths")
                        .text(": not available for a render of several bands"),
                );
            }
        }
        Ok(())
    }

    /// The request of band `k` alone: its wavelength as the channel, no list.
    pub fn band_request(&self, k: usize) -> Option<RenderRequest> {
        let w = *self.wavelengths.get(k)?;
        Some(RenderRequest {
            channel: Channel::Wavelength(w),
            wavelengths: Vec::new(),
            ..self.clone()
        })
    }
}

/// `request` with its time window fixed to hold every band's light: where `t0` or `dt`
/// is not given, each band's window is chosen by its own pilot render (a [`Session`]
/// made for it) and the union taken: `t0` the earliest start, `dt` the span to the
/// latest end over `bins` (with `dt` given, the window is `bins` of them from that
/// start).
pub(super) fn shared_window(
    request: &RenderRequest,
    message: &mut dyn FnMut(&str),
) -> Result<RenderRequest, RequestError> {
    if request.t0_s.is_some() && request.dt_s.is_some() {
        return Ok(request.clone());
    }
    let (mut start_s, mut end_s) = (f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..request.wavelengths.len() {
        let band = request.band_request(k).expect("k is a band");
        let axis = Session::new(&band)?.axis();
        start_s = start_s.min(axis.t0_s);
        end_s = end_s.max(axis.end_s());
    }
    let t0_s = request.t0_s.unwrap_or(start_s);
    let dt_s = request
        .dt_s
        .unwrap_or((end_s - t0_s) / request.bins.max(1) as f64);
    message(&format!(
        "bands' shared window: from {} to {} (each band's own window, joined)",
        format_time(t0_s),
        format_time(end_s)
    ));
    Ok(RenderRequest {
        t0_s: Some(t0_s),
        dt_s: Some(dt_s),
        ..request.clone()
    })
}

/// The cube `sum_k weights[k] snaps[k]` (summed in f64), a band of rows at a time; its
/// spp the fewest of the bands'.
pub(super) fn weighted_snapshot(
    snaps: &[FilmSnapshot],
    weights: &[f64],
    films: &[&TprfFilm],
) -> FilmSnapshot {
    let first = &snaps[0];
    let (w, t) = (first.width(), first.axis().bins);
    let layout = FilmLayout {
        width: w,
        height: first.height(),
        axis: *first.axis(),
        bounces_separate: 0,
        luminescence: false,
    };
    let spp = films.iter().map(|f| f.spp()).min().unwrap_or(0);
    let passes = films.iter().map(|f| f.passes()).min().unwrap_or(0);
    let error = films
        .iter()
        .filter_map(|f| f.half_error_estimate())
        .reduce(f64::max);
    let (mut row, mut sum) = (Vec::new(), Vec::new());
    let read = |y0: usize, _layer: Option<usize>, out: &mut [f32]| {
        for (r, dst) in out.chunks_exact_mut((w * t).max(1)).enumerate() {
            sum.clear();
            sum.resize(w * t, 0.0f64);
            for (snap, &weight) in snaps.iter().zip(weights) {
                if weight == 0.0 {
                    continue;
                }
                snap.row_dense(y0 + r, None, &mut row);
                for (s, v) in sum.iter_mut().zip(&row) {
                    *s += weight * f64::from(*v);
                }
            }
            for (d, s) in dst.iter_mut().zip(&sum) {
                *d = *s as f32;
            }
        }
        Ok::<(), std::convert::Infallible>(())
    };
    match FilmSnapshot::from_dense_rows(layout, spp, passes, 0, error, read, |_, _| Ok(())) {
        Ok(s) => s,
        Err(never) => match never {},
    }
}

/// Refuse now, not after the renders, the files the disk under `out` has no room for:
/// `L + 1` cubes of `session`'s shape.
pub(super) fn disk_room(
    request: &RenderRequest,
    session: &Session,
    out: &Path,
) -> Result<(), RequestError> {
    let parent = out
        .ancestors()
        .skip(1)
        .find(|p| !p.as_os_str().is_empty() && p.is_dir())
        .unwrap_or(Path::new("."));
    let (w, h, t) = (
        request.width as u64,
        request.height as u64,
        session.axis().bins as u64,
    );
    let l = request.wavelengths.len() as u64;
    let need =
        export::npy_f32_bytes(&[l, h, w, t]).saturating_add(export::npy_f32_bytes(&[h, w, t]));
    if let Some(free) = export::disk_free_bytes(parent)
        && need > free
    {
        let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
        return Err(RequestError::DiskFull {
            width: request.width,
            height: request.height,
            bins: session.axis().bins,
            need_gib: gib(need),
            out: out.display().to_string(),
            free_gib: gib(free),
        });
    }
    Ok(())
}
