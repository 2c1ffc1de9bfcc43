//! A request rendered into a cube folder: what `tprf render` (and each `tprf batch`
//! job) writes: `tprf.npy` (or `tprf.zarr`), `tprf.json`, `steady.png`, the per-bounce
//! layers, the ambient image, frames, a shard's steady sums, the phasors when asked
//! (`phasor.npy`, `phasor.json`: [`crate::export::phasor`]); written into a new folder
//! beside the target and swapped in whole ([`crate::export::staging`]).

use super::{MemoryRefusal, MemoryStop, Problem, RenderRequest, RequestError, Session, spectral};
use crate::export::ambient::{AMBIENT_NPY, AMBIENT_UNITS, AmbientMetadata};
use crate::export::phasor::{self, PhasorMetadata};
use crate::export::shard::{self, ShardInfo};
use crate::export::{
    self, BIN_VALUE, CameraMetadata, CubeFormat, CubeMetadata, MediumMetadata, RenderStopped, zarr,
};
use crate::film::{FilmSnapshot, StokesFilms, TprfFilm};
use crate::transport::ambient::{AmbientImage, render_ambient};
use crate::transport::progressive::PassReport;
use crate::units::{C_M_PER_S, format_time};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What a folder render tells its caller as it goes: lines for the user, each pass,
/// and the start of the writing. Every method has a default that does nothing.
pub trait Observer {
    /// A line for the user: the scene's notes (`note: ...`), the time axis chosen, the
    /// ambient image.
    fn message(&mut self, _line: &str) {}

    /// After each pass, with the film; [`ControlFlow::Break`] ends the render there (the
    /// passes made are written).
    fn pass(&mut self, _report: &PassReport, _film: &TprfFilm) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }

    /// Before the output folder is begun and between its files: [`ControlFlow::Break`]
    /// abandons it ([`RequestError::Interrupted`]; the staging folder is removed and the
    /// old output stays as it was).
    fn writing(&mut self) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
}

/// What [`render_to_folder`] wrote.
#[derive(Clone, Debug)]
pub struct Written {
    /// `tprf.json` as written.
    pub meta: CubeMetadata,
    /// The concrete format (`auto` resolved).
    pub format: CubeFormat,
    /// Rows rendered (all, or a shard's).
    pub rows_rendered: usize,
    /// Every pass's report.
    pub passes: Vec<PassReport>,
    /// Why the render stopped before its target (its next pass would not have fitted in
    /// memory), when it did: the folder holds the passes made.
    pub stopped: Option<MemoryStop>,
}

/// The nearest of `path`'s parent folders that exists (`.` for a relative path whose
/// first folder is new).
fn existing_ancestor(path: &Path) -> PathBuf {
    path.ancestors()
        .skip(1)
        .find(|p| !p.as_os_str().is_empty() && p.is_dir())
        .map_or_else(|| PathBuf::from("."), PathBuf::from)
}

/// A request rendered in memory ([`render`]): the film, its metadata (`tprf.json` but
/// for what depends on the files: the cube's format and the ambient image's file name,
/// filled in by [`write_folder`]) and the ambient image when the scene has ambient
/// light.
pub struct Rendered {
    pub film: TprfFilm,
    /// A polarized render's S1..S3 films (`film` is S0); `None` otherwise.
    pub stokes: Option<StokesFilms>,
    pub meta: CubeMetadata,
    pub ambient: Option<(AmbientImage, AmbientMetadata)>,
    /// Every pass's report.
    pub passes: Vec<PassReport>,
    /// Why the render stopped before its target (its next pass would not have fitted in
    /// memory), when it did: the film holds the passes made.
    pub stopped: Option<MemoryStop>,
}

/// Render `request` in memory in the request's thread pool: its passes (each reported
/// to `observer`, which may end the render), then, where the scene has ambient light,
/// the ambient image. A render with NaN or infinite contributions is refused.
pub fn render(
    request: &RenderRequest,
    observer: &mut (dyn Observer + Send),
) -> Result<Rendered, RequestError> {
    request.validate()?;
    if !request.wavelengths.is_empty() {
        return Err(RequestError::invalid(
            super::Problem::field("wavelengths").text(
                ": a render of several bands is written to a folder (render_to_folder), \
             not held in memory",
            ),
        ));
    }
    let pool = request.thread_pool()?;
    let threads = pool.current_num_threads();
    pool.install(|| rendered(request, threads, observer, |_| Ok(())))
}

/// Render `request` into the folder `out` in the request's thread pool: the folder is
/// checked before anything is rendered (it must be new, empty or an earlier tprf output;
/// [`export::staging::check_target`], the scene file being an input it never replaces),
/// as is the disk's room for a dense cube; then [`render`]'s render, and its files
/// written by [`write_folder`].
pub fn render_to_folder(
    request: &RenderRequest,
    out: &Path,
    observer: &mut (dyn Observer + Send),
) -> Result<Written, RequestError> {
    request.validate()?;
    let scene_path = scene_path_of(request);
    export::staging::check_target(out, &[scene_path])?;
    let pool = request.thread_pool()?;
    let threads = pool.current_num_threads();
    if !request.wavelengths.is_empty() {
        return pool.install(|| render_bands_to_folder(request, threads, out, observer));
    }
    pool.install(|| {
        let format = |bins: usize| {
            let (w, h) = (request.width as u64, request.height as u64);
            request.format.resolve(&[h, w, bins as u64])
        };
        let done = rendered(request, threads, observer, |session| {
            disk_room(request, session, format(session.axis().bins), out)
        })?;
        let snap = done.film.snapshot();
        let steady = done.film.steady();
        let format = format(snap.axis().bins);
        let stokes = done
            .stokes
            .as_ref()
            .map(|s| [1, 2, 3].map(|k| s.component(k).map(TprfFilm::snapshot)));
        let stokes = match stokes {
            Some([Some(a), Some(b), Some(c)]) => Some([a, b, c]),
            _ => None,
        };
        let meta = write_cube_folder(
            &snap,
            stokes.as_ref().map(|[a, b, c]| [a, b, c]),
            &steady,
            done.meta,
            done.ambient
                .as_ref()
                .map(|(image, _)| image.radiance.as_slice()),
            format,
            request.frames,
            out,
            &[scene_path],
            observer,
            &mut |_| Ok(()),
        )?;
        Ok(Written {
            meta,
            format,
            rows_rendered: done.film.rows_rendered(),
            passes: done.passes,
            stopped: done.stopped,
        })
    })
}

/// Render every band of `request` (validated, `wavelengths` not empty) in the current
/// pool and write the folder `out` (checked by the caller).
fn render_bands_to_folder(
    request: &RenderRequest,
    threads: usize,
    out: &Path,
    observer: &mut (dyn Observer + Send),
) -> Result<Written, RequestError> {
    let start = Instant::now();
    let fixed = spectral::shared_window(request, &mut |line| observer.message(line))?;
    let mut bands: Vec<Rendered> = Vec::with_capacity(request.wavelengths.len());
    for (k, w) in request.wavelengths.iter().enumerate() {
        observer.message(&format!(
            "band {} of {}: {}",
            k + 1,
            request.wavelengths.len(),
            w.name()
        ));
        let band = fixed.band_request(k).expect("k is a band");
        let check_disk = |session: &Session| {
            if k == 0 {
                spectral::disk_room(request, session, out)
            } else {
                Ok(())
            }
        };
        bands.push(rendered(&band, threads, observer, check_disk)?);
    }
    let weights = crate::scene::wavelengths::luminance_weights(&request.wavelengths);
    // tprf.npy: the band `channel` names, else the luminance.
    let chosen = match request.channel {
        crate::scene::Channel::Wavelength(w) => request.wavelengths.iter().position(|&v| v == w),
        _ => None,
    };
    let snaps: Vec<FilmSnapshot> = bands.iter().map(|b| b.film.snapshot()).collect();
    let main_weights: Vec<f64> = match chosen {
        Some(j) => (0..bands.len())
            .map(|k| f64::from(u8::from(k == j)))
            .collect(),
        None => weights.clone(),
    };
    let films: Vec<&TprfFilm> = bands.iter().map(|b| &b.film).collect();
    let main = spectral::weighted_snapshot(&snaps, &main_weights, &films);
    let steadies: Vec<Vec<f64>> = bands.iter().map(|b| b.film.steady()).collect();
    let steady: Vec<f64> = (0..steadies[0].len())
        .map(|i| {
            steadies
                .iter()
                .zip(&main_weights)
                .map(|(s, w)| w * s[i])
                .sum()
        })
        .collect();
    let ambient: Option<Vec<f32>> = bands
        .iter()
        .map(|b| b.ambient.as_ref().map(|(image, _)| &image.radiance))
        .collect::<Option<Vec<_>>>()
        .map(|images| {
            (0..images[0].len())
                .map(|i| {
                    images
                        .iter()
                        .zip(&main_weights)
                        .map(|(im, w)| w * f64::from(im[i]))
                        .sum::<f64>() as f32
                })
                .collect()
        });
    let mut meta = bands[0].meta.clone();
    meta.channel = match chosen {
        Some(j) => request.wavelengths[j].name(),
        None => "luminance".into(),
    };
    meta.spp = main.spp;
    meta.wall_seconds = start.elapsed().as_secs_f64();
    meta.paths_traced = bands.iter().map(|b| b.meta.paths_traced).sum();
    meta.rays_traced = bands.iter().map(|b| b.meta.rays_traced).sum();
    meta.render_seconds = bands.iter().map(|b| b.meta.render_seconds).sum();
    meta.passes = bands.iter().map(|b| b.meta.passes).sum();
    meta.error_estimate = bands
        .iter()
        .filter_map(|b| b.meta.error_estimate)
        .reduce(f64::max);
    meta.request = serde_json::to_value(request).ok();
    meta.spectral = Some(export::SpectralMetadata {
        file: spectral::SPECTRAL_NPY.into(),
        wavelengths_nm: request.wavelengths.iter().map(|w| w.nm()).collect(),
        tprf_npy: meta.channel.clone(),
        luminance_weights: weights,
        luminance: spectral::LUMINANCE_RULE.into(),
        spp: bands.iter().map(|b| b.film.spp()).collect(),
    });
    let refs: Vec<&FilmSnapshot> = snaps.iter().collect();
    let meta = write_cube_folder(
        &main,
        None,
        &steady,
        meta,
        ambient.as_deref(),
        CubeFormat::Npy,
        request.frames,
        out,
        &[Path::new(&request.scene)],
        observer,
        &mut |dir| {
            Ok(export::write_snapshots_npy(
                &dir.join(spectral::SPECTRAL_NPY),
                &refs,
            )?)
        },
    )?;
    Ok(Written {
        meta,
        format: CubeFormat::Npy,
        rows_rendered: bands[0].film.rows_rendered(),
        stopped: bands.iter().find_map(|b| b.stopped.clone()),
        passes: bands.into_iter().flat_map(|b| b.passes).collect(),
    })
}

/// Refuse now, not after the render, a dense cube the disk under `out` has no room for.
fn disk_room(
    request: &RenderRequest,
    session: &Session,
    format: CubeFormat,
    out: &Path,
) -> Result<(), RequestError> {
    // The folder is written beside its place and swapped in at the end (export::staging),
    // which creates the folders above it then: nothing is made on disk before the render
    // is done. Its free space is that of the nearest folder above it that exists.
    let parent = existing_ancestor(out);
    let (width, height) = (request.width, request.height);
    let axis = session.axis();
    let (w, h, t) = (width as u64, height as u64, axis.bins as u64);
    let layers = session.film().layout().bounce_layers() as u64;
    let file_bytes =
        export::npy_f32_bytes(&[h, w, t]).saturating_add(export::npy_f32_bytes(&[layers, h, w, t]));
    if format == CubeFormat::Npy
        && let Some(free) = export::disk_free_bytes(&parent)
        && file_bytes > free
    {
        let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
        return Err(RequestError::DiskFull {
            width,
            height,
            bins: axis.bins,
            need_gib: gib(file_bytes),
            out: out.display().to_string(),
            free_gib: gib(free),
        });
    }
    Ok(())
}

/// The render of [`render`] in the current pool, `before_passes` checking the session
/// once it is ready.
pub(super) fn rendered(
    request: &RenderRequest,
    threads: usize,
    observer: &mut (dyn Observer + Send),
    before_passes: impl FnOnce(&Session) -> Result<(), RequestError>,
) -> Result<Rendered, RequestError> {
    let start = Instant::now();
    let mut session = Session::new(request)?;
    for note in &session.scene().notes {
        observer.message(&format!("note: {note}"));
    }
    let axis = session.axis();
    observer.message(&format!(
        "time axis: {} bins of {} from {} ({:.4} m to {:.4} m of optical path)",
        axis.bins,
        format_time(axis.dt_s),
        format_time(axis.t0_s),
        axis.t0_s * C_M_PER_S,
        axis.end_s() * C_M_PER_S
    ));
    before_passes(&session)?;
    let reports = session.run(|r, film| observer.pass(r, film));
    let stopped = session.memory_stop().cloned();
    if let Some(stop) = &stopped {
        if reports.is_empty() {
            // Memory ran short between the first pass's check and the pass: nothing to
            // write.
            let layout = session.film().layout();
            return Err(RequestError::Memory(MemoryRefusal {
                width: layout.width,
                height: layout.height,
                bins: layout.axis.bins,
                bins_per_sample: session.pilot_bins_per_sample(),
                need_bytes: stop.need_bytes,
                limit_bytes: stop.limit_bytes,
                limited_by: stop.limited_by,
            }));
        }
        observer.message(&format!("memory: {stop}"));
    }
    let last = reports.last().copied();
    if let Some(r) = last
        && r.left_out.non_finite > 0
    {
        return Err(RequestError::NonFinite {
            non_finite: r.left_out.non_finite,
            paths: r.paths,
            scene: request.scene.clone(),
        });
    }
    let ambient = render_ambient_image(&session, request.ambient_spp(), observer)?;
    let mut meta = cube_metadata(
        &session,
        threads,
        start.elapsed().as_secs_f64(),
        std::slice::from_ref(&reports),
    )?;
    meta.ambient = ambient.as_ref().map(|(_, m)| m.clone());
    let (film, stokes) = session.into_films();
    Ok(Rendered {
        film,
        stokes,
        meta,
        ambient,
        passes: reports,
        stopped,
    })
}

/// Write a cube folder at `out`: the cube `snap` (`tprf.npy`, with `tprf_bounces.npy`
/// for per-bounce layers, or `tprf.zarr`, as `format` says), `steady.png` from `steady`
/// (W m^-2 sr^-1 per pixel), a shard's steady sums, the ambient image `ambient` (W m^-2
/// sr^-1, `[H, W]`; `meta.ambient` describes it, and is dropped without it), frames when
/// asked, and `tprf.json` from `meta` (its format and file names filled in), into a
/// staging folder swapped in whole ([`export::staging`]; `inputs` are never replaced).
/// `observer.writing` may abandon it between files. What `tprf render` and
/// `Cube.save` write; returns the metadata written.
#[allow(
    clippy::too_many_arguments,
    reason = "the parts of the folder, one argument each; not yet one request"
)]
pub fn write_folder(
    snap: &FilmSnapshot,
    steady: &[f64],
    meta: CubeMetadata,
    ambient: Option<&[f32]>,
    format: CubeFormat,
    frames: bool,
    out: &Path,
    inputs: &[&Path],
    observer: &mut (dyn Observer + Send),
) -> Result<CubeMetadata, RequestError> {
    write_cube_folder(
        snap,
        None,
        steady,
        meta,
        ambient,
        format,
        frames,
        out,
        inputs,
        observer,
        &mut |_| Ok(()),
    )
}

/// [`write_folder`] with a polarized render's S1..S3 snapshots `stokes` (`snap` is
/// S0): the Stokes cube `tprf_stokes.npy` `[4, H, W, T]` beside `tprf.npy`, named in
/// `tprf.json`'s `stokes` (refused for a Zarr cube: not written yet); and `extra`
/// writing more files into the staging folder (its path given) before `tprf.json` (a
/// render of several bands: `tprf_spectral.npy`).
#[allow(
    clippy::too_many_arguments,
    reason = "the parts of the folder, one argument each; not yet one request"
)]
pub(super) fn write_cube_folder(
    snap: &FilmSnapshot,
    stokes: Option<[&FilmSnapshot; 3]>,
    steady: &[f64],
    mut meta: CubeMetadata,
    ambient: Option<&[f32]>,
    format: CubeFormat,
    frames: bool,
    out: &Path,
    inputs: &[&Path],
    observer: &mut (dyn Observer + Send),
    extra: &mut dyn FnMut(&Path) -> Result<(), RequestError>,
) -> Result<CubeMetadata, RequestError> {
    let interrupted = |observer: &mut (dyn Observer + Send)| match observer.writing() {
        ControlFlow::Break(()) => Err(RequestError::Interrupted),
        ControlFlow::Continue(()) => Ok(()),
    };
    interrupted(observer)?;
    let (width, height) = (snap.width(), snap.height());
    let zarr = format == CubeFormat::Zarr;
    if zarr && stokes.is_some() {
        return Err(RequestError::invalid(Problem::field("polarized").text(
            ": the cube is written as Zarr (format, or auto for a cube over 4 GiB), and \
             the Stokes cube is written as npy only for now (use format npy)",
        )));
    }
    meta.polarized = stokes.is_some();
    meta.stokes = None;
    meta.format = if zarr {
        "tprf cube v2: tprf.zarr (Zarr v3 group): cube float32 [H, W, T] and, with \
         bounces_separate > 0, bounces float32 [layers, H, W, T]; row 0 = top"
    } else {
        "tprf cube v1: tprf.npy float32 [H, W, T], row 0 = top"
    }
    .into();
    if let Some(s) = &mut meta.shard {
        s.format = if zarr { "zarr" } else { "npy" }.into();
    }
    if ambient.is_none() {
        meta.ambient = None;
    }
    if let Some(a) = &mut meta.ambient {
        a.file = if zarr {
            format!("{}/ambient", zarr::ZARR_NAME)
        } else {
            AMBIENT_NPY.into()
        };
    }
    let staging = export::staging::Staging::new(out, inputs)?;
    let dir = staging.path();
    let exposure = 0.8 * export::exposure_for(steady.iter().copied(), 0.99);
    export::write_png_gray(&dir.join("steady.png"), width, height, steady, exposure)?;
    if frames {
        export::write_frames(dir, snap)?;
    }
    if meta.shard.is_some() {
        shard::write_steady(dir, width, height, steady)?;
    }
    if zarr {
        zarr::write_snapshot_zarr(&dir.join(zarr::ZARR_NAME), snap, &meta)?;
    } else {
        export::write_snapshot_npy(&dir.join("tprf.npy"), snap, false)?;
        if snap.layers() > 0 {
            export::write_snapshot_npy(&dir.join("tprf_bounces.npy"), snap, true)?;
        }
        if let Some([s1, s2, s3]) = stokes {
            interrupted(observer)?;
            let m = export::StokesMetadata::npy();
            export::write_stokes_npy(&dir.join(&m.file), [snap, s1, s2, s3])?;
            meta.stokes = Some(m);
        }
    }
    if let Some(radiance) = ambient {
        // After the cube: a Zarr cube's group must exist.
        export::ambient::write_ambient(dir, zarr, width, height, radiance)?;
    }
    if let Some(p) = meta.phasor.take() {
        // After the cube, as the ambient image.
        interrupted(observer)?;
        meta.phasor = Some(phasor::write_phasors(dir, zarr, snap, p)?);
    }
    interrupted(observer)?;
    extra(dir)?;
    interrupted(observer)?;
    export::write_json(&dir.join("tprf.json"), &meta)?;
    interrupted(observer)?;
    staging.commit()?;
    Ok(meta)
}

/// `tprf.json` of `session`'s film as it is: `runs` holds each [`Session::run`]'s
/// reports (paths, render time and work left out are summed over them), `wall_s` the
/// seconds since the render began, `threads` the pool's. What depends on the files (the
/// format, the ambient image) is left for [`write_folder`].
pub fn cube_metadata(
    session: &Session,
    threads: usize,
    wall_s: f64,
    runs: &[Vec<PassReport>],
) -> Result<CubeMetadata, RequestError> {
    let request = session.request();
    let (width, height) = (request.width, request.height);
    let axis = session.axis();
    let film = session.film();
    let cam = session.camera();
    let renderer = session.renderer();
    let spec = session.shard();
    let lasts = runs.iter().filter_map(|r| r.last());
    let mut left_out = crate::film::LeftOutCounts::default();
    let (mut paths, mut render_s) = (0, 0.0);
    for r in lasts {
        left_out += r.left_out;
        paths += r.paths;
        render_s += r.render_s;
    }
    Ok(CubeMetadata {
        // Filled in by `write_folder`, which knows the files.
        format: String::new(),
        t0_s: axis.t0_s,
        dt_s: axis.dt_s,
        bins: axis.bins,
        width,
        height,
        spp: film.spp(),
        seed: request.seed,
        c_m_per_s: C_M_PER_S,
        channel: request.channel.name(),
        value: BIN_VALUE.into(),
        scene: request.scene.clone(),
        camera: CameraMetadata {
            position_m: cam.position().to_array(),
            world_from_camera: glam::Mat4::from(cam.world_from_camera).to_cols_array(),
            yfov_deg: cam
                .yfov_rad(request.width as f32 / request.height.max(1) as f32)
                .to_degrees(),
            time_origin: request.time_origin.to_string(),
            near_m: (request.time_origin == crate::scene::TimeOrigin::NearPlane)
                .then_some(cam.near_m),
        },
        pulse_origin: request.pulse_origin.to_string(),
        max_bounces: request.max_bounces,
        min_bounces: request.min_bounces,
        bounces_separate: request.bounces_separate,
        luminescence_layer: film.layout().luminescence_layer().is_some(),
        threads,
        wall_seconds: wall_s,
        rays_traced: renderer.rays_traced(),
        paths_traced: paths,
        first_bounce_splits: renderer.strategy().splits,
        light_vertex: renderer.strategy().light_vertex,
        adaptive: !request.uniform,
        error_estimate: film.half_error_estimate(),
        passes: runs.iter().map(|r| r.len() as u64).sum(),
        left_out,
        store: film.store_stats(),
        render_seconds: render_s,
        media: media_metadata(session.scene()),
        notes: session.scene().notes.clone(),
        shard: match &spec {
            Some(spec) => {
                let terms = film.row_error_terms();
                Some(ShardInfo {
                    k: spec.k,
                    n: spec.n,
                    band_rows: spec.band_rows,
                    rows: ShardInfo::row_ranges(spec, height),
                    half_spp: film.half_spp(),
                    scene_fingerprint: shard::scene_fingerprint(&request.scene)?,
                    filter: film.time_filter(),
                    // Filled in by `write_folder`.
                    format: String::new(),
                    row_error_terms: (0..height)
                        .filter(|&y| film.renders_row(y))
                        .filter_map(|y| terms.get(y).map(|t| [t.0, t.1]))
                        .collect(),
                    store_list_bytes: film.row_list_bytes(),
                })
            }
            None => None,
        },
        stopped: session.memory_stop().map(|stop| RenderStopped {
            reason: "memory".into(),
            message: stop.to_string(),
            spp_target: request.spp_target(),
            limit_bytes: stop.limit_bytes,
            limited_by: stop.limited_by.key().into(),
        }),
        ambient: None,
        polarized: request.polarized,
        // Filled in by `write_folder`, which writes the file.
        stokes: None,
        spectral: None,
        phasor: match request.phasor {
            Some(band) => Some(
                PhasorMetadata::new(band, axis.t0_s, axis.dt_s, axis.bins, film.time_filter())
                    .map_err(|why| {
                        RequestError::invalid(
                            super::Problem::field("phasor").text(format!(": {why}")),
                        )
                    })?,
            ),
            None => None,
        },
        request: serde_json::to_value(request).ok(),
    })
}

fn scene_path_of(request: &RenderRequest) -> &Path {
    Path::new(&request.scene)
}

/// The scene's ambient image and its metadata when the scene has an ambient group
/// (`None` otherwise), at `spp` samples per pixel.
fn render_ambient_image(
    session: &Session,
    spp: u32,
    observer: &mut (dyn Observer + Send),
) -> Result<Option<(AmbientImage, AmbientMetadata)>, RequestError> {
    let renderer = session.renderer();
    let group = &renderer.scene().ambient;
    if group.is_empty() {
        return Ok(None);
    }
    let start = Instant::now();
    let r = session.request();
    let image = render_ambient(renderer, r.width, r.height, spp);
    if image.non_finite > 0 {
        return Err(RequestError::AmbientNonFinite(image.non_finite));
    }
    observer.message(&format!(
        "ambient image: {} at {spp} spp in {:.1} s (mean {:.4e} W m^-2 sr^-1{})",
        group.describe().join(", "),
        start.elapsed().as_secs_f64(),
        image.radiance.iter().map(|&v| v as f64).sum::<f64>() / image.radiance.len().max(1) as f64,
        image.error_estimate.map_or(String::new(), |e| format!(
            ", error estimate {:.2} %",
            100.0 * e
        ))
    ));
    let meta = AmbientMetadata {
        file: String::new(),
        units: AMBIENT_UNITS.into(),
        lights: group.describe(),
        spp,
        error_estimate: image.error_estimate,
    };
    Ok(Some((image, meta)))
}

/// A scene's media as metadata: the scene-wide one, then those of the materials
/// some triangle uses.
fn media_metadata(scene: &crate::scene::Scene) -> Vec<MediumMetadata> {
    let row = |region: String, m: &crate::scene::Medium| MediumMetadata {
        region,
        sigma_s_per_m: m.sigma_s_per_m,
        sigma_a_per_m: m.sigma_a_per_m,
        g: m.g,
        n: m.n,
        density: m.density.as_ref().map(|d| {
            let [lo, hi] = d.bbox_m.unwrap_or_default();
            crate::export::DensityMetadata {
                file: d.file.as_ref().map(|f| f.display().to_string()),
                dims: d.dims,
                bbox_min_m: lo,
                bbox_max_m: hi,
                max: d.max(),
            }
        }),
    };
    let used = |i: usize| scene.attrs.iter().any(|a| a.material as usize == i);
    let materials = scene.materials.iter().enumerate();
    scene
        .medium
        .iter()
        .map(|m| row("scene".into(), m))
        .chain(materials.filter_map(|(i, mat)| {
            let m = mat.medium.as_ref().filter(|_| used(i))?;
            Some(row(format!("material '{}'", mat.name), m))
        }))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::NpyF32;

    struct Quiet;
    impl Observer for Quiet {}

    fn request(polarized: bool) -> RenderRequest {
        RenderRequest {
            width: 6,
            height: 5,
            spp: Some(4),
            uniform: true,
            polarized,
            // The plain path tracer, the polarized walk's strategy: the same paths.
            splits: Some(1),
            light_vertex: Some(false),
            ..RenderRequest::new("builtin:cornell")
        }
    }

    /// `--polarized` writes `tprf_stokes.npy` `[4, H, W, T]`: its S0 plane is `tprf.npy`
    /// value for value, S1..S3 of the diffuse Cornell box are 0 (the walk's are exactly),
    /// and `tprf.json` says `"polarized": true` and names the file and its frame; an
    /// intensity render writes neither.
    #[test]
    fn polarized_folder_has_the_stokes_cube() {
        let dir = std::env::temp_dir().join(format!("tprf-stokes-folder-{}", std::process::id()));
        let out = dir.join("pol");
        render_to_folder(&request(true), &out, &mut Quiet).unwrap();
        let cube = NpyF32::open(&out.join("tprf.npy")).unwrap();
        let stokes = NpyF32::open(&out.join("tprf_stokes.npy")).unwrap();
        let [h, w, t] = cube.shape() else {
            panic!("{:?}", cube.shape())
        };
        assert_eq!((*h, *w), (5, 6));
        assert_eq!(stokes.shape(), [4, *h, *w, *t]);
        let (c, s) = (cube.read_all().unwrap(), stokes.read_all().unwrap());
        let n = c.len();
        assert!(c.iter().any(|&v| v > 0.0));
        assert_eq!(s[..n], c[..]);
        assert!(s[n..].iter().all(|&v| v == 0.0));
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("tprf.json")).unwrap()).unwrap();
        assert_eq!(json["polarized"], serde_json::Value::Bool(true));
        assert_eq!(json["stokes"]["file"], "tprf_stokes.npy");
        assert!(json["stokes"]["frame"].as_str().unwrap().contains("camera"));
        assert_eq!(json["request"]["polarized"], serde_json::Value::Bool(true));

        let plain = dir.join("plain");
        render_to_folder(&request(false), &plain, &mut Quiet).unwrap();
        assert!(!plain.join("tprf_stokes.npy").exists());
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(plain.join("tprf.json")).unwrap()).unwrap();
        assert_eq!(json["polarized"], serde_json::Value::Bool(false));
        assert!(json.get("stokes").is_none());
        // The same samples: S0 of the polarized render is the intensity cube to float
        // rounding of the Mueller products (1e-5).
        let i = NpyF32::open(&plain.join("tprf.npy"))
            .unwrap()
            .read_all()
            .unwrap();
        for (a, b) in i.iter().zip(&c) {
            assert!((a - b).abs() <= 1e-5 * a.abs(), "{a} vs {b}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// What the polarized walk does not carry is refused by the field's name.
    #[test]
    fn polarized_refusals_name_the_field() {
        let dir = std::env::temp_dir().join(format!("tprf-stokes-refused-{}", std::process::id()));
        for (scene, format) in [
            ("builtin:fog", CubeFormat::Npy),
            ("builtin:flim", CubeFormat::Npy),
            ("builtin:cornell", CubeFormat::Zarr),
        ] {
            let r = RenderRequest {
                format,
                ..RenderRequest {
                    scene: scene.into(),
                    ..request(true)
                }
            };
            let e = render_to_folder(&r, &dir.join("x"), &mut Quiet).unwrap_err();
            assert!(e.to_string().contains("polarized"), "{scene}: {e}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
