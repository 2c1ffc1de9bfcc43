//! `tprf batch MANIFEST`: many renders from one TOML file (jobs, and sweeps that expand
//! scenes x settings into jobs), each optionally measured by sensor presets; a job
//! whose output is complete is skipped, so a re-run resumes. A failed job is reported
//! and the others go on; the exit status is non-zero if any failed.
//!
//! [`run_job`] is the one way a job runs: `tprf batch` calls it for every job, and a
//! cluster runs one job per task through `tprf batch MANIFEST --only NAME` (the Python
//! package `python/tprf_dist` does).
//!
//! ```toml
//! [defaults]            # any job field; a job's own value wins
//! width = 64
//! height = 48
//! spp = 16
//!
//! [[job]]
//! scene = "builtin:cornell"
//! out = "out/cornell"   # relative paths are from the manifest's folder
//! sensors = ["builtin:lidar"]
//!
//! [[sweep]]             # every scene x every settings entry
//! scenes = ["builtin:cornell", "scenes/room.glb"]
//! out = "out/{scene}-{settings}"
//! settings = [{ name = "lo", spp = 8 }, { name = "hi", spp = 64, bins = 512 }]
//!
//! [[measure]]           # a cube measured again (tprf sensor's options), after the renders
//! dir = "out/cornell"
//! out = "out/cornell-gated-s2"
//! preset = "builtin:gated"
//! seed = 2
//!
//! [[capture]]           # an NLOS capture (tprf nlos's options), after the measurements
//! scene = "builtin:nlos-z"
//! out = "out/nlos-z"
//! grid = [32, 32]
//! confocal = true
//!
//! [[reconstruct]]       # a reconstruction (tprf nlos reconstruct's options), last
//! capture = "out/nlos-z"
//! out = "out/nlos-z-fk"
//! method = "fk"
//! ```

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use serde::Deserialize;
use tprf_core::request::{
    CaptureRequest, MeasureError, MeasureRequest, ReconstructRequest, RenderRequest, RequestError,
};

#[derive(Args, Debug)]
pub struct BatchArgs {
    /// The manifest: a TOML file of [[job]] and [[sweep]] tables (see docs/distributed.md).
    #[allow(
        rustdoc::broken_intra_doc_links,
        reason = "clap's help text: the brackets are TOML, not links"
    )]
    pub manifest: PathBuf,
    /// Run only the job of this name (repeatable); default: every job.
    #[arg(long)]
    pub only: Vec<String>,
    /// Print the jobs' names, one a line, with "complete" or "to do", and stop.
    #[arg(long)]
    pub list: bool,
    /// Render a job even when its output is complete.
    #[arg(long)]
    pub force: bool,
    /// Worker threads of each render (default: all cores, or a job's own `threads`).
    #[arg(long)]
    pub threads: Option<usize>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SweepTable {
    scenes: Vec<String>,
    /// With `{scene}` (the scene's name: `cornell` for builtin:cornell, a file's stem)
    /// and `{settings}` (the settings entry's name).
    out: String,
    /// Each entry: `name` and any request field (and `sensors`).
    #[serde(default)]
    settings: Vec<toml::Table>,
}

/// A manifest: `[defaults]` and each `[[job]]` or sweep settings entry are tables of
/// [`RenderRequest`] fields (the keys of `tprf render`'s options: `width`, `spp`, `t0`,
/// `max_bounces` ...) and a job's own keys (`name`, `scene`, `out`, `sensors`); each
/// `[[measure]]` a [`MeasureRequest`]'s fields (`tprf sensor`'s options: `dir`,
/// `preset`, `exposure`, `seed` ...) and its `name` and `out`, run after the renders;
/// each `[[capture]]` a [`CaptureRequest`]'s (`tprf nlos`'s options: `scene`, `grid`,
/// `confocal`, `spp` ...) and each `[[reconstruct]]` a [`ReconstructRequest`]'s (`tprf
/// nlos reconstruct`'s: `capture`, `method`, `volume` ...), with their `name` and `out`,
/// run in that order after the measurements.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    #[serde(default)]
    defaults: toml::Table,
    #[serde(default)]
    job: Vec<toml::Table>,
    #[serde(default)]
    sweep: Vec<SweepTable>,
    #[serde(default)]
    measure: Vec<toml::Table>,
    #[serde(default)]
    capture: Vec<toml::Table>,
    #[serde(default)]
    reconstruct: Vec<toml::Table>,
}

/// One job of a batch, its paths resolved.
#[derive(Clone, Debug)]
pub struct Job {
    pub name: String,
    pub out: PathBuf,
    pub work: Work,
}

/// What a job does.
#[derive(Clone, Debug)]
pub enum Work {
    /// A render (`[[job]]`, `[[sweep]]`), its cube then measured by sensor presets.
    Render {
        /// Sensor presets (TOML files or builtin:NAME) each measuring the cube into
        /// `OUT/sensor-NAME/`.
        sensors: Vec<String>,
        /// The render (its scene resolved against the manifest's folder, a Mitsuba
        /// file's settings in the keys the job does not give), validated.
        request: Box<RenderRequest>,
        /// What came from the scene file ([`RenderRequest::with_file_defaults`]).
        from_scene_file: Vec<String>,
    },
    /// A measurement of a cube already rendered (`[[measure]]`: `tprf sensor`'s
    /// options, its `dir` resolved against the manifest's folder), validated.
    Measure(MeasureRequest),
    /// An NLOS capture (`[[capture]]`: `tprf nlos`'s options, its scene resolved
    /// against the manifest's folder), validated; a Mitsuba NLOS scene's settings fill
    /// the keys it does not give (`given`) when it runs.
    Capture {
        request: Box<CaptureRequest>,
        given: BTreeSet<String>,
    },
    /// A reconstruction (`[[reconstruct]]`: `tprf nlos reconstruct`'s options, its
    /// capture resolved against the manifest's folder), validated.
    Reconstruct(ReconstructRequest),
}

/// A scene's short name: `cornell` for `builtin:cornell`, the file stem of a path.
fn scene_name(scene: &str) -> String {
    match scene.strip_prefix("builtin:") {
        Some(b) => b.to_string(),
        None => Path::new(scene)
            .file_stem()
            .map_or_else(|| scene.to_string(), |s| s.to_string_lossy().into_owned()),
    }
}

/// A job's own keys taken out of its table, the rest read as a [`RenderRequest`].
struct JobTable {
    name: Option<String>,
    out: Option<String>,
    sensors: Vec<String>,
    request: RenderRequest,
    /// The request keys the job gives (its own or the defaults').
    given: BTreeSet<String>,
}

/// `table` over `base` (its own keys win), split into a job's keys and its request; a
/// wrong type or an unknown key is refused, naming it.
fn job_table(table: &toml::Table, base: &toml::Table) -> Result<JobTable> {
    let mut t = base.clone();
    t.extend(table.iter().map(|(k, v)| (k.clone(), v.clone())));
    let mut text = |key: &str| -> Result<Option<String>> {
        match t.remove(key) {
            None => Ok(None),
            Some(toml::Value::String(s)) => Ok(Some(s)),
            Some(v) => bail!("{key} must be a string (got {v})"),
        }
    };
    let name = text("name")?;
    let out = text("out")?;
    let sensors = match t.remove("sensors") {
        None => Vec::new(),
        Some(v) => v
            .try_into::<Vec<String>>()
            .context("sensors must be a list of preset names or files")?,
    };
    let given = t.keys().cloned().collect();
    let request: RenderRequest = toml::Value::Table(t).try_into()?;
    Ok(JobTable {
        name,
        out,
        sensors,
        request,
        given,
    })
}

/// The jobs of the manifest at `path`, in order: its `[[job]]`s, then each sweep's
/// scenes x settings. Relative scene and output paths are taken from the manifest's
/// folder. Refused: an unreadable manifest, an unknown key or a wrong type, a job whose
/// request is invalid (naming its key), two jobs of one name or one output.
pub fn load_jobs(path: &Path) -> Result<Vec<Job>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the manifest {}", path.display()))?;
    let not_manifest = || format!("{} is not a batch manifest", path.display());
    let m: Manifest = toml::from_str(&text).with_context(not_manifest)?;
    for key in ["name", "out"] {
        if m.defaults.contains_key(key) {
            bail!("{}: [defaults] cannot set a job's {key}", not_manifest());
        }
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let resolve_scene = |s: &str| -> String {
        if s.starts_with("builtin:") || Path::new(s).is_absolute() {
            s.to_string()
        } else {
            base.join(s).to_string_lossy().into_owned()
        }
    };
    let resolve_out = |o: &Path| -> PathBuf {
        if o.is_absolute() {
            o.to_path_buf()
        } else {
            base.join(o)
        }
    };
    let mut jobs = Vec::new();
    let mut add = |name: String, out: PathBuf, t: JobTable| -> Result<()> {
        let mut request = RenderRequest {
            scene: resolve_scene(&t.request.scene),
            ..t.request
        };
        // A Mitsuba file's film, sampler and integrator fill the keys the job does not
        // give; a file that cannot be read is the render's to report (that job fails,
        // the others run).
        let from_scene_file = match tprf_core::scene::file_settings(&request.scene) {
            Ok(file) => request
                .with_file_defaults(&file, |key| t.given.contains(key))
                .iter()
                .map(ToString::to_string)
                .collect(),
            Err(_) => Vec::new(),
        };
        request
            .validate()
            .with_context(|| format!("{}: job '{name}'", path.display()))?;
        jobs.push(Job {
            name,
            out,
            work: Work::Render {
                sensors: t.sensors,
                request: Box::new(request),
                from_scene_file,
            },
        });
        Ok(())
    };
    for (i, table) in m.job.iter().enumerate() {
        let t = job_table(table, &m.defaults)
            .with_context(|| format!("{}: job {}", not_manifest(), i + 1))?;
        let Some(out) = t.out.clone() else {
            bail!("{}: job {} has no out", not_manifest(), i + 1);
        };
        if !table.contains_key("scene") {
            bail!("{}: job {} has no scene", not_manifest(), i + 1);
        }
        let out = PathBuf::from(out);
        let name = t.name.clone().unwrap_or_else(|| {
            out.file_name().map_or_else(
                || out.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            )
        });
        add(name, resolve_out(&out), t)?;
    }
    for (i, s) in m.sweep.into_iter().enumerate() {
        if s.scenes.is_empty() {
            bail!("{}: sweep {} lists no scenes", path.display(), i + 1);
        }
        let entries = if s.settings.is_empty() {
            let mut default = toml::Table::new();
            default.insert("name".into(), "default".into());
            vec![default]
        } else {
            s.settings
        };
        for scene in &s.scenes {
            for (j, e) in entries.iter().enumerate() {
                let mut entry = e.clone();
                for key in ["scene", "out"] {
                    if entry.contains_key(key) {
                        bail!(
                            "{}: sweep {} settings {}: {key} is the sweep's, not an entry's",
                            not_manifest(),
                            i + 1,
                            j + 1
                        );
                    }
                }
                entry.insert("scene".into(), scene.clone().into());
                let t = job_table(&entry, &m.defaults).with_context(|| {
                    format!("{}: sweep {} settings {}", not_manifest(), i + 1, j + 1)
                })?;
                let Some(entry_name) = t.name.clone() else {
                    bail!(
                        "{}: sweep {} settings {} has no name",
                        not_manifest(),
                        i + 1,
                        j + 1
                    );
                };
                let out = s
                    .out
                    .replace("{scene}", &scene_name(scene))
                    .replace("{settings}", &entry_name);
                let out = resolve_out(Path::new(&out));
                add(format!("{}-{}", scene_name(scene), entry_name), out, t)?;
            }
        }
    }
    // [[measure]], [[capture]] and [[reconstruct]]: a name, an out, and the rest a
    // request's keys (`needs` one of them), read as the request `R`.
    fn request_job<R: serde::de::DeserializeOwned>(
        kind: &str,
        i: usize,
        table: &toml::Table,
        needs: &str,
        manifest: &str,
        resolve_out: impl Fn(&Path) -> PathBuf,
    ) -> Result<(String, PathBuf, BTreeSet<String>, R)> {
        let what = || format!("{manifest}: {kind} {}", i + 1);
        let mut t = table.clone();
        let mut text = |key: &str| -> Result<Option<String>> {
            match t.remove(key) {
                None => Ok(None),
                Some(toml::Value::String(s)) => Ok(Some(s)),
                Some(v) => bail!("{}: {key} must be a string (got {v})", what()),
            }
        };
        let name = text("name")?;
        let Some(out) = text("out")? else {
            bail!("{} has no out", what());
        };
        if !t.contains_key(needs) {
            bail!("{} has no {needs}", what());
        }
        let out = resolve_out(Path::new(&out));
        let name = name.unwrap_or_else(|| {
            out.file_name().map_or_else(
                || out.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            )
        });
        let given: BTreeSet<String> = t.keys().cloned().collect();
        let request: R = toml::Value::Table(t).try_into().with_context(what)?;
        Ok((name, out, given, request))
    }
    let manifest = not_manifest();
    let job_of = |name: &str| format!("{}: job '{name}'", path.display());
    for (i, table) in m.measure.iter().enumerate() {
        let (name, out, _, request): (_, _, _, MeasureRequest) =
            request_job("measure", i, table, "dir", &manifest, resolve_out)?;
        let request = MeasureRequest {
            dir: resolve_out(&request.dir),
            ..request
        };
        request.validate().with_context(|| job_of(&name))?;
        jobs.push(Job {
            name,
            out,
            work: Work::Measure(request),
        });
    }
    for (i, table) in m.capture.iter().enumerate() {
        let (name, out, given, request): (_, _, _, CaptureRequest) =
            request_job("capture", i, table, "scene", &manifest, resolve_out)?;
        let request = CaptureRequest {
            scene: resolve_scene(&request.scene),
            ..request
        };
        request
            .validate()
            .map_err(|e| super::nlos::capture_error(e, str::to_string))
            .with_context(|| job_of(&name))?;
        jobs.push(Job {
            name,
            out,
            work: Work::Capture {
                request: Box::new(request),
                given,
            },
        });
    }
    for (i, table) in m.reconstruct.iter().enumerate() {
        let (name, out, _, request): (_, _, _, ReconstructRequest) =
            request_job("reconstruct", i, table, "capture", &manifest, resolve_out)?;
        let request = ReconstructRequest {
            capture: resolve_out(&request.capture),
            ..request
        };
        request
            .validate()
            .map_err(|e| super::nlos::reconstruct_error(e, str::to_string))
            .with_context(|| job_of(&name))?;
        jobs.push(Job {
            name,
            out,
            work: Work::Reconstruct(request),
        });
    }
    let (mut names, mut outs) = (BTreeSet::new(), BTreeSet::new());
    for j in &jobs {
        if !names.insert(j.name.clone()) {
            bail!(
                "{}: two jobs are named '{}' (give them names, or a sweep an out with {{scene}} and {{settings}})",
                path.display(),
                j.name
            );
        }
        if !outs.insert(j.out.clone()) {
            bail!(
                "{}: two jobs write {} (job '{}' and another)",
                path.display(),
                j.out.display(),
                j.name
            );
        }
    }
    Ok(jobs)
}

/// The folder a sensor preset's outputs go to inside a job's output.
fn sensor_dir(job: &Job, preset: &str) -> PathBuf {
    job.out.join(format!("sensor-{}", scene_name(preset)))
}

/// Why a job's output is not complete (`None`: it is): its cube is not
/// ([`cube_incomplete`]), or a sensor's `sensor.json` is missing.
pub fn incomplete(job: &Job) -> Option<String> {
    let missing =
        |done: PathBuf| (!done.is_file()).then(|| format!("{} is missing", done.display()));
    match &job.work {
        Work::Render {
            sensors, request, ..
        } => cube_incomplete(&job.out, request).or_else(|| {
            sensors
                .iter()
                .find_map(|p| missing(sensor_dir(job, p).join("sensor.json")))
        }),
        Work::Measure(_) => missing(job.out.join("sensor.json")),
        Work::Capture { .. } => missing(job.out.join(tprf_core::nlos::files::JSON_NAME))
            .or_else(|| missing(job.out.join(tprf_core::nlos::files::HDF5_NAME))),
        Work::Reconstruct(_) => missing(job.out.join("volume.json")),
    }
}

/// Why a job's cube is not complete (`None`: it is): no folder, no readable
/// `tprf.json`, a shard's folder, other settings than the job's, or no cube file.
pub fn cube_incomplete(out: &Path, r: &RenderRequest) -> Option<String> {
    let json = out.join("tprf.json");
    if !json.exists() {
        return Some(format!("{} is missing", json.display()));
    }
    let meta = match tprf_core::export::read_metadata(&json) {
        Ok(m) => m,
        Err(e) => return Some(crate::cli::message_chain(&anyhow::Error::from(e))),
    };
    if meta.shard.is_some() {
        return Some(format!("{} holds a shard", out.display()));
    }
    if let Some(stop) = &meta.stopped {
        return Some(format!("stopped before its target ({})", stop.message));
    }
    let differs = [
        ("width", Some(r.width as u64), meta.width as u64),
        ("height", Some(r.height as u64), meta.height as u64),
        ("spp", r.spp_target(), meta.spp),
        ("bins", Some(r.bins as u64), meta.bins as u64),
        ("seed", Some(r.seed), meta.seed),
    ]
    .into_iter()
    .find(|(_, want, have)| want.is_some_and(|w| w != *have));
    if let Some((field, want, have)) = differs {
        return Some(format!(
            "its {field} is {have}, the job's {}",
            want.unwrap_or_default()
        ));
    }
    if meta.scene != r.scene {
        return Some(format!("it renders {}, the job {}", meta.scene, r.scene));
    }
    let uniform = r.uniform;
    if meta.adaptive == uniform {
        let sampling = |uniform| if uniform { "uniform" } else { "adaptive" };
        return Some(format!(
            "its sampling is {}, the job's {}",
            sampling(!meta.adaptive),
            sampling(uniform)
        ));
    }
    let cube = ["tprf.npy", tprf_core::export::zarr::ZARR_NAME];
    if !cube.iter().any(|c| out.join(c).exists()) {
        return Some(format!("{} has no cube file", out.display()));
    }
    None
}

/// What [`run_job`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JobOutcome {
    /// The output was complete: nothing done.
    Skipped,
    /// Rendered (and measured) now.
    Done,
}

/// Run one job: skipped when its output is complete (unless `force`); else rendered
/// as `tprf render` renders (the folder swapped in whole) unless its cube is
/// complete, then each sensor preset whose outputs are missing measured into
/// `OUT/sensor-NAME/` through `tprf sensor`'s.
pub fn run_job(job: &Job, threads: Option<usize>, force: bool) -> Result<JobOutcome> {
    if !force && incomplete(job).is_none() {
        return Ok(JobOutcome::Skipped);
    }
    let (sensors, request, from_scene_file) = match &job.work {
        Work::Render {
            sensors,
            request,
            from_scene_file,
        } => (sensors, request, from_scene_file),
        Work::Measure(request) => {
            super::args::check_out("out", &job.out, &[&request.dir])?;
            super::sensor::measure(request, &job.out, |e| match e {
                MeasureError::Invalid(p) => {
                    anyhow::anyhow!("its settings do not make a measurement: {p}")
                }
                e => e.into(),
            })?;
            return Ok(JobOutcome::Done);
        }
        Work::Capture { request, given } => {
            super::args::check_out("out", &job.out, &[Path::new(&request.scene)])?;
            let request = CaptureRequest {
                threads: threads.or(request.threads),
                ..(**request).clone()
            };
            super::nlos::capture_request(request, |k| given.contains(k), &job.out, str::to_string)
                .context("its capture")?;
            return Ok(JobOutcome::Done);
        }
        Work::Reconstruct(request) => {
            super::args::check_out("out", &job.out, &[&request.capture])?;
            let request = ReconstructRequest {
                threads: threads.or(request.threads),
                ..request.clone()
            };
            super::nlos::reconstruct_request(&request, &job.out, str::to_string)
                .context("its reconstruction")?;
            return Ok(JobOutcome::Done);
        }
    };
    if force || cube_incomplete(&job.out, request).is_some() {
        for line in from_scene_file {
            eprintln!("  from the scene file: {line}");
        }
        render_job(request, &job.out, threads)?;
    }
    for preset in sensors {
        let out = sensor_dir(job, preset);
        if !force && out.join("sensor.json").is_file() {
            continue;
        }
        let request = tprf_core::request::MeasureRequest {
            preset: Some(preset.clone()),
            ..tprf_core::request::MeasureRequest::new(&job.out)
        };
        super::args::check_out("out", &out, &[&job.out])
            .and_then(|()| super::sensor::measure(&request, &out, anyhow::Error::from))
            .with_context(|| format!("sensor preset {preset}"))?;
    }
    Ok(JobOutcome::Done)
}

/// Render a job's request (`threads`, when given, replacing the job's own) as
/// `tprf render` does; an invalid request names the manifest's key.
fn render_job(request: &RenderRequest, out: &Path, threads: Option<usize>) -> Result<()> {
    let request = RenderRequest {
        threads: threads.or(request.threads),
        ..request.clone()
    };
    super::render::render_request(&request, out, |e| match e {
        RequestError::Invalid(p) => anyhow::anyhow!("its settings do not make a render: {p}"),
        e => e.into(),
    })
}

/// `tprf batch`.
pub fn run(a: &BatchArgs) -> Result<()> {
    let jobs = load_jobs(&a.manifest)?;
    for name in &a.only {
        if !jobs.iter().any(|j| &j.name == name) {
            bail!(
                "--only {name}: {} has no job of that name (it has {})",
                a.manifest.display(),
                jobs.iter()
                    .map(|j| j.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    let chosen: Vec<&Job> = jobs
        .iter()
        .filter(|j| a.only.is_empty() || a.only.contains(&j.name))
        .collect();
    if a.list {
        for j in &chosen {
            let state = if incomplete(j).is_none() {
                "complete"
            } else {
                "to do"
            };
            println!("{}\t{state}\t{}", j.name, j.out.display());
        }
        return Ok(());
    }
    let start = Instant::now();
    let (mut done, mut skipped, mut failed) = (0, 0, Vec::new());
    for (i, job) in chosen.iter().enumerate() {
        eprintln!("[{}/{}] {}", i + 1, chosen.len(), job.name);
        if let Some(why) = incomplete(job).filter(|_| !a.force) {
            eprintln!("  to do: {why}");
        }
        match run_job(job, a.threads, a.force) {
            Ok(JobOutcome::Skipped) => {
                skipped += 1;
                eprintln!("  complete, skipped: {}", job.out.display());
            }
            Ok(JobOutcome::Done) => done += 1,
            Err(e) => {
                eprintln!("  job {} failed: {}", job.name, super::message_chain(&e));
                failed.push(job.name.clone());
            }
        }
    }
    eprintln!(
        "batch: {done} rendered, {skipped} skipped (complete), {} failed, {:.1} s",
        failed.len(),
        start.elapsed().as_secs_f64()
    );
    if !failed.is_empty() {
        bail!(
            "{} of {} jobs failed: {}",
            failed.len(),
            chosen.len(),
            failed.join(", ")
        );
    }
    Ok(())
}
