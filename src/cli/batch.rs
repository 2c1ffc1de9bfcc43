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
//! ```

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Args, Parser};
use serde::Deserialize;

use super::{Cli, Command};

#[derive(Args, Debug)]
pub struct BatchArgs {
    /// The manifest: a TOML file of [[job]] and [[sweep]] tables (see docs/distributed.md).
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
    /// Worker threads of each render (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// What a job (or a sweep's settings entry, or the defaults) may set. Unset fields take
/// the defaults', then `tprf render`'s.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JobSettings {
    pub width: Option<usize>,
    pub height: Option<usize>,
    pub spp: Option<u64>,
    pub bins: Option<usize>,
    /// Window start, with a unit as for `tprf render --t0`.
    pub t0: Option<String>,
    /// Bin width, with a unit as for `--dt`.
    pub dt: Option<String>,
    pub seed: Option<u64>,
    pub max_bounces: Option<u32>,
    pub bounces_separate: Option<u32>,
    pub channel: Option<String>,
    /// `npy`, `zarr` or `auto`.
    pub format: Option<String>,
    /// Every pixel draws every pass's samples (`tprf render --uniform`); default false:
    /// adaptive sampling.
    pub uniform: Option<bool>,
    /// Sensor presets (TOML files or builtin:NAME) each measuring the cube into
    /// `OUT/sensor-NAME/`.
    pub sensors: Option<Vec<String>>,
}

impl JobSettings {
    /// `self`, its unset fields taken from `base`.
    fn over(self, base: &JobSettings) -> JobSettings {
        let b = base.clone();
        JobSettings {
            width: self.width.or(b.width),
            height: self.height.or(b.height),
            spp: self.spp.or(b.spp),
            bins: self.bins.or(b.bins),
            t0: self.t0.or(b.t0),
            dt: self.dt.or(b.dt),
            seed: self.seed.or(b.seed),
            max_bounces: self.max_bounces.or(b.max_bounces),
            bounces_separate: self.bounces_separate.or(b.bounces_separate),
            channel: self.channel.or(b.channel),
            format: self.format.or(b.format),
            uniform: self.uniform.or(b.uniform),
            sensors: self.sensors.or(b.sensors),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct JobTable {
    name: Option<String>,
    scene: String,
    out: PathBuf,
    #[serde(flatten)]
    settings: JobSettings,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SettingsEntry {
    name: String,
    #[serde(flatten)]
    settings: JobSettings,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SweepTable {
    scenes: Vec<String>,
    /// With `{scene}` (the scene's name: `cornell` for builtin:cornell, a file's stem)
    /// and `{settings}` (the settings entry's name).
    out: String,
    #[serde(default)]
    settings: Vec<SettingsEntry>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    #[serde(default)]
    defaults: JobSettings,
    #[serde(default)]
    job: Vec<JobTable>,
    #[serde(default)]
    sweep: Vec<SweepTable>,
}

/// One render of a batch, its paths resolved.
#[derive(Clone, Debug)]
pub struct Job {
    pub name: String,
    pub scene: String,
    pub out: PathBuf,
    pub settings: JobSettings,
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

/// The jobs of the manifest at `path`, in order: its `[[job]]`s, then each sweep's
/// scenes x settings. Relative scene and output paths are taken from the manifest's
/// folder. Refused: an unreadable or unknown field, two jobs of one name or one output.
pub fn load_jobs(path: &Path) -> Result<Vec<Job>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the manifest {}", path.display()))?;
    let m: Manifest = toml::from_str(&text)
        .with_context(|| format!("{} is not a batch manifest", path.display()))?;
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
    for j in m.job {
        let name = j.name.unwrap_or_else(|| {
            j.out.file_name().map_or_else(
                || j.out.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            )
        });
        jobs.push(Job {
            name,
            scene: resolve_scene(&j.scene),
            out: resolve_out(&j.out),
            settings: j.settings.over(&m.defaults),
        });
    }
    for (i, s) in m.sweep.into_iter().enumerate() {
        if s.scenes.is_empty() {
            bail!("{}: sweep {} lists no scenes", path.display(), i + 1);
        }
        let entries = if s.settings.is_empty() {
            vec![SettingsEntry {
                name: "default".into(),
                settings: JobSettings::default(),
            }]
        } else {
            s.settings
        };
        for scene in &s.scenes {
            for e in &entries {
                let out = s
                    .out
                    .replace("{scene}", &scene_name(scene))
                    .replace("{settings}", &e.name);
                let out = resolve_out(Path::new(&out));
                jobs.push(Job {
                    name: format!("{}-{}", scene_name(scene), e.name),
                    scene: resolve_scene(scene),
                    out,
                    settings: e.settings.clone().over(&m.defaults),
                });
            }
        }
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

/// The `tprf render` command line of a job.
fn render_argv(job: &Job, threads: Option<usize>) -> Vec<String> {
    let s = &job.settings;
    let mut argv = vec![
        "tprf".to_string(),
        "render".into(),
        job.scene.clone(),
        "--out".into(),
        job.out.to_string_lossy().into_owned(),
    ];
    let mut flag = |name: &str, value: Option<String>| {
        if let Some(v) = value {
            argv.push(format!("--{name}"));
            argv.push(v);
        }
    };
    flag("width", s.width.map(|v| v.to_string()));
    flag("height", s.height.map(|v| v.to_string()));
    flag("spp", s.spp.map(|v| v.to_string()));
    flag("bins", s.bins.map(|v| v.to_string()));
    flag("t0", s.t0.clone());
    flag("dt", s.dt.clone());
    flag("seed", s.seed.map(|v| v.to_string()));
    flag("max-bounces", s.max_bounces.map(|v| v.to_string()));
    flag(
        "bounces-separate",
        s.bounces_separate.map(|v| v.to_string()),
    );
    flag("channel", s.channel.clone());
    flag("format", s.format.clone());
    flag("threads", threads.map(|v| v.to_string()));
    if s.uniform == Some(true) {
        argv.push("--uniform".into());
    }
    argv
}

/// The folder a sensor preset's outputs go to inside a job's output.
fn sensor_dir(job: &Job, preset: &str) -> PathBuf {
    job.out.join(format!("sensor-{}", scene_name(preset)))
}

/// Why a job's output is not complete (`None`: it is): its cube is not
/// ([`cube_incomplete`]), or a sensor's `sensor.json` is missing.
pub fn incomplete(job: &Job) -> Option<String> {
    cube_incomplete(job).or_else(|| {
        job.settings
            .sensors
            .iter()
            .flatten()
            .map(|p| sensor_dir(job, p).join("sensor.json"))
            .find(|done| !done.is_file())
            .map(|done| format!("{} is missing", done.display()))
    })
}

/// Why a job's cube is not complete (`None`: it is): no folder, no readable
/// `tprf.json`, a shard's folder, other settings than the job's, or no cube file.
pub fn cube_incomplete(job: &Job) -> Option<String> {
    let json = job.out.join("tprf.json");
    if !json.exists() {
        return Some(format!("{} is missing", json.display()));
    }
    let meta = match tprf_core::export::read_metadata(&json) {
        Ok(m) => m,
        Err(e) => return Some(crate::cli::message_chain(&anyhow::Error::from(e))),
    };
    if meta.shard.is_some() {
        return Some(format!("{} holds a shard", job.out.display()));
    }
    let s = &job.settings;
    let differs = [
        ("width", s.width.map(|v| v as u64), meta.width as u64),
        ("height", s.height.map(|v| v as u64), meta.height as u64),
        ("spp", s.spp, meta.spp),
        ("bins", s.bins.map(|v| v as u64), meta.bins as u64),
        ("seed", s.seed, meta.seed),
    ]
    .into_iter()
    .find(|(_, want, have)| want.is_some_and(|w| w != *have));
    if let Some((field, want, have)) = differs {
        return Some(format!(
            "its {field} is {have}, the job's {}",
            want.unwrap_or_default()
        ));
    }
    if meta.scene != job.scene {
        return Some(format!("it renders {}, the job {}", meta.scene, job.scene));
    }
    let uniform = s.uniform.unwrap_or(false);
    if meta.adaptive == uniform {
        let sampling = |uniform| if uniform { "uniform" } else { "adaptive" };
        return Some(format!(
            "its sampling is {}, the job's {}",
            sampling(!meta.adaptive),
            sampling(uniform)
        ));
    }
    let cube = ["tprf.npy", tprf_core::export::zarr::ZARR_NAME];
    if !cube.iter().any(|c| job.out.join(c).exists()) {
        return Some(format!("{} has no cube file", job.out.display()));
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
/// through `tprf render`'s own code (the folder swapped in whole) unless its cube is
/// complete, then each sensor preset whose outputs are missing measured into
/// `OUT/sensor-NAME/` through `tprf sensor`'s.
pub fn run_job(job: &Job, threads: Option<usize>, force: bool) -> Result<JobOutcome> {
    if !force && incomplete(job).is_none() {
        return Ok(JobOutcome::Skipped);
    }
    if force || cube_incomplete(job).is_some() {
        render_job(job, threads)?;
    }
    for preset in job.settings.sensors.iter().flatten() {
        let out = sensor_dir(job, preset);
        if !force && out.join("sensor.json").is_file() {
            continue;
        }
        let sensor = super::sensor::SensorArgs {
            dir: job.out.clone(),
            preset: Some(preset.clone()),
            light: None,
            exposure: None,
            noise_sigma: None,
            photons_per_energy: None,
            seed: None,
            cycles: None,
            ambient_scale: None,
            ambient_exposure: None,
            pixels: Vec::new(),
            out,
        };
        super::sensor::run(&sensor).with_context(|| format!("sensor preset {preset}"))?;
    }
    Ok(JobOutcome::Done)
}

/// Render a job's cube through `tprf render`'s argument parsing and code.
fn render_job(job: &Job, threads: Option<usize>) -> Result<()> {
    let argv = render_argv(job, threads);
    let cli = Cli::try_parse_from(&argv).map_err(|e| {
        anyhow::anyhow!(
            "its settings do not make a render: {}",
            e.to_string().lines().next().unwrap_or_default()
        )
    })?;
    let Some(Command::Render(args)) = &cli.command else {
        bail!("internal: the job's command line is not a render");
    };
    super::render::run(args)
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
