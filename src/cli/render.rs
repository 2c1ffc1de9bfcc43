//! `tprf render`: a scene into a transient cube folder (`tprf.npy`, `tprf.json`,
//! `steady.png`, optional per-bounce layers and frames), with a progress bar. The
//! render and its files are `tprf_core::request::render_to_folder`'s; this command
//! turns its arguments into a request and reports progress.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use tprf_core::film::TprfFilm;
use tprf_core::request::{Observer, RenderRequest, render_to_folder};
use tprf_core::transport::progressive::{PassReport, Schedule};

use super::args::{RequestArgs, request_error};

#[derive(Args, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    pub request: RequestArgs,
    /// Output folder: a new or empty one, or an earlier tprf output (replaced whole when
    /// the render is written: the files go into a new folder beside it and are swapped
    /// in, so a reader never sees half of a render). A folder holding anything tprf did
    /// not write, a file, a link, a device or the current folder is refused up front.
    #[arg(long, required_unless_present = "save_gltf")]
    pub out: Option<PathBuf>,
    /// Also write the loaded scene (a Mitsuba XML scene's too) as a self-contained .gltf
    /// file, before rendering; without --out, write it and stop.
    #[arg(long, value_name = "FILE.gltf")]
    pub save_gltf: Option<PathBuf>,
}

/// `tprf render`.
pub fn run(a: &RenderArgs) -> Result<()> {
    let scene_name = &a.request.scene;
    // A Mitsuba XML scene's film, sampler and integrator settings stand in for the
    // options not given: read from the XML alone (its meshes and textures are read once,
    // by the render), or from the whole scene where it is also saved as glTF.
    let request = if a.save_gltf.is_some() || tprf_core::scene::is_mitsuba_path(scene_name) {
        let file = match &a.save_gltf {
            Some(path) => {
                let (scene, file) = tprf_core::scene::load_with_settings(scene_name)?;
                tprf_core::scene::gltf_save::save_gltf(&scene, path)
                    .with_context(|| format!("--save-gltf {}", path.display()))?;
                eprintln!(
                    "wrote {} ({} triangles)",
                    path.display(),
                    scene.triangles.len()
                );
                file
            }
            None => tprf_core::scene::file_settings(scene_name)?,
        };
        if file.nlos.is_some() && a.out.is_some() {
            anyhow::bail!(
                "{scene_name} is an NLOS capture scene (mitransient's transient_nlos_path): render it with tprf nlos {scene_name} --out DIR"
            );
        }
        let (request, used) = a.request.request_with(&file)?;
        for line in used {
            eprintln!("from the scene file: {line}");
        }
        request
    } else {
        a.request.request()?
    };
    let Some(out) = &a.out else {
        return Ok(());
    };
    render_request(&request, out, request_error)
}

/// Render `request` into the folder `out` with a progress bar and the render's lines
/// on stderr, then a line saying what was written. `error` words the request's errors
/// for the caller (options on the command line, a manifest's keys in a batch).
pub fn render_request(
    request: &RenderRequest,
    out: &Path,
    error: impl Fn(tprf_core::request::RequestError) -> anyhow::Error,
) -> Result<()> {
    request.validate().map_err(&error)?;
    super::args::check_out("--out", out, &[Path::new(&request.scene)])?;
    if request.until_stopped {
        // Ctrl-C ends the passes (at the end of the one running) and the render is
        // written; a second one, while writing, drops what was written.
        super::interrupt::catch();
        eprintln!("rendering until Ctrl-C");
    }
    let mut progress = Progress::new(request.schedule());
    let written = render_to_folder(request, out, &mut progress).map_err(&error)?;
    let meta = &written.meta;
    eprintln!(
        "wrote {}{} ({} spp, {:.1} s, {:.2} Mrays/s{})",
        out.display(),
        meta.shard.as_ref().map_or(String::new(), |s| format!(
            " (shard {}/{}: {} of {} rows)",
            s.k, s.n, written.rows_rendered, meta.height
        )) + &meta.spectral.as_ref().map_or(String::new(), |s| format!(
            " ({} bands in tprf_spectral.npy; tprf.npy: {})",
            s.wavelengths_nm.len(),
            s.tprf_npy
        )),
        meta.spp,
        meta.wall_seconds,
        meta.rays_traced as f64 / meta.wall_seconds.max(1e-9) / 1e6,
        meta.error_estimate.map_or(String::new(), |e| format!(
            ", error estimate {:.2} %",
            100.0 * e
        ))
    );
    match written.stopped {
        Some(stop) => Err(StoppedForMemory(stop.text_with(super::args::flag)).into()),
        None => Ok(()),
    }
}

/// The render stopped before its target, its next pass not fitting in memory; the
/// output holds the passes made. `tprf` exits with [`StoppedForMemory::EXIT_STATUS`].
#[derive(Debug)]
pub struct StoppedForMemory(pub String);

impl std::fmt::Display for StoppedForMemory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for StoppedForMemory {}

impl StoppedForMemory {
    /// The exit status of a render stopped for memory (README's exit statuses).
    pub const EXIT_STATUS: u8 = 3;
}

/// The render's lines on stderr and a progress bar over its passes (in spp, or in
/// tenths of a second for a time budget), shown from the first pass until the render
/// says something else; Ctrl-C caught once the files are being written.
struct Progress {
    schedule: Schedule,
    bar: Option<ProgressBar>,
}

impl Progress {
    fn new(schedule: Schedule) -> Progress {
        Progress {
            schedule,
            bar: None,
        }
    }

    fn bar(&mut self) -> &ProgressBar {
        let schedule = self.schedule;
        self.bar.get_or_insert_with(|| {
            let bar = match (schedule.spp_target, schedule.time_budget_s) {
                (Some(n), _) => ProgressBar::new(n),
                (None, Some(s)) => ProgressBar::new((s * 10.0).ceil() as u64),
                // An error target, or Ctrl-C: no end known in advance.
                (None, None) => ProgressBar::new_spinner(),
            };
            bar.set_style(
                ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            bar
        })
    }

    fn passes_done(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}

impl Observer for Progress {
    fn message(&mut self, line: &str) {
        self.passes_done();
        eprintln!("{line}");
    }

    fn pass(&mut self, r: &PassReport, _film: &TprfFilm) -> ControlFlow<()> {
        let spp_target = self.schedule.spp_target;
        let bar = self.bar();
        bar.set_position(match spp_target {
            Some(_) => r.spp,
            None => (r.wall_s * 10.0) as u64,
        });
        bar.set_message(format!(
            "{} spp, {:.1} Mrays/s",
            r.spp,
            r.rays as f64 / r.render_s.max(1e-9) / 1e6
        ));
        // Only a render until Ctrl-C catches it before writing.
        if super::interrupt::take() {
            return ControlFlow::Break(());
        }
        ControlFlow::Continue(())
    }

    fn writing(&mut self) -> ControlFlow<()> {
        self.passes_done();
        // Ctrl-C from here on drops what was written (the staging folder) and leaves the
        // old output as it was; checked between files.
        super::interrupt::catch();
        match super::interrupt::check() {
            Ok(()) => ControlFlow::Continue(()),
            Err(_) => ControlFlow::Break(()),
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.passes_done();
    }
}
