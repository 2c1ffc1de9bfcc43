//! Error against run time: render progressively and, at checkpoints spaced evenly in
//! log time, compare the cube (and its steady image) with a reference.
//!
//! Each estimator setting (next-event estimation on or off, box or tent time filter,
//! Russian roulette thresholds) renders the same scene from scratch for its own time
//! budget, so settings compare per second of rendering, not per sample. The clock
//! counts render passes only: the error measurements between passes are not charged.

use super::ReportError;
use super::plot::{self, Curve};
use crate::export::{self, ExportError, read_cube, write_atomic};
use crate::film::{TimeAxis, TimeFilter, TprfFilm};
use crate::reference::{Analytic, ReferenceCube};
use crate::request::{MemoryStop, RenderRequest, RequestError, Session};
use crate::scene::{Channel, Scene};
use serde::Serialize;
use std::fmt::Write as _;
use std::io::Write as _;
use std::ops::ControlFlow;
use std::path::Path;
use std::sync::Arc;

/// One estimator setting to compare: a label and what it changes from the defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct EstimatorSetting {
    /// As given (`default`, `nee=off`, `filter=tent,rr_start=8` ...).
    pub label: String,
    pub nee: Option<bool>,
    pub filter: TimeFilter,
    pub rr_start: Option<u32>,
    pub rr_min_survival: Option<f32>,
    pub max_bounces: Option<u32>,
    /// Branches at the first vertex (`RenderRequest::splits`; 0 = auto).
    pub splits: Option<u32>,
    /// Light-vertex connections on or off (`RenderRequest::light_vertex`; unset: the
    /// pilot chooses).
    pub light_vertex: Option<bool>,
    /// Adaptive sampling on or off (`RenderRequest::uniform`, negated).
    pub adaptive: Option<bool>,
    /// Its own time budget, seconds (default: the run's).
    pub seconds: Option<f64>,
}

/// `on` / `off` (or true / false, 1 / 0).
fn on_off(v: &str) -> Option<bool> {
    match v {
        "on" | "true" | "1" => Some(true),
        "off" | "false" | "0" => Some(false),
        _ => None,
    }
}

impl EstimatorSetting {
    /// The defaults.
    pub fn default_setting() -> EstimatorSetting {
        EstimatorSetting {
            label: "default".into(),
            nee: None,
            filter: TimeFilter::Box,
            rr_start: None,
            rr_min_survival: None,
            max_bounces: None,
            splits: None,
            light_vertex: None,
            adaptive: None,
            seconds: None,
        }
    }

    /// Parse `default` or comma-separated `key=value` pairs: `nee=on|off`,
    /// `filter=box|tent`, `rr_start=N`, `rr_floor=P` (survival floor in [0, 1]),
    /// `max_bounces=N`, `splits=N` (first-bounce branches, 1 ..= 64, or `auto`),
    /// `light_vertex=on|off` (eye vertices joined to a light vertex), `adaptive=on|off`
    /// (samples planned per pixel from the film's noise), `seconds=S`.
    pub fn parse(spec: &str) -> Result<EstimatorSetting, ReportError> {
        let mut s = EstimatorSetting::default_setting();
        s.label = spec.trim().to_string();
        if s.label.is_empty() {
            return Err(ReportError::EmptySetting);
        }
        if s.label == "default" {
            return Ok(s);
        }
        let error = |why: String| ReportError::Setting {
            spec: spec.to_string(),
            why,
        };
        for part in spec.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let (k, v) = part
                .split_once('=')
                .ok_or_else(|| error(format!("'{part}' is not key=value")))?;
            let bad = |why: &str| error(format!("{k}={v}: {why}"));
            match k.trim() {
                "nee" => s.nee = Some(on_off(v).ok_or_else(|| bad("expected on or off"))?),
                "filter" => {
                    s.filter = match v {
                        "box" => TimeFilter::Box,
                        "tent" => TimeFilter::Tent,
                        _ => return Err(bad("expected box or tent")),
                    }
                }
                "rr_start" => {
                    s.rr_start = Some(v.parse().map_err(|_| bad("expected a whole number"))?)
                }
                "rr_floor" => {
                    let p: f32 = v.parse().map_err(|_| bad("expected a number"))?;
                    if !(0.0..=1.0).contains(&p) {
                        return Err(bad("a survival probability must be in [0, 1]"));
                    }
                    s.rr_min_survival = Some(p);
                }
                "max_bounces" => {
                    s.max_bounces = Some(v.parse().map_err(|_| bad("expected a whole number"))?)
                }
                "splits" => {
                    s.splits = Some(match v {
                        "auto" => 0,
                        _ => match v.parse::<u32>() {
                            Ok(k) if (1..=64).contains(&k) => k,
                            _ => return Err(bad("expected auto or a whole number in 1 ..= 64")),
                        },
                    })
                }
                "light_vertex" => {
                    s.light_vertex = Some(on_off(v).ok_or_else(|| bad("expected on or off"))?)
                }
                "adaptive" => {
                    s.adaptive = Some(on_off(v).ok_or_else(|| bad("expected on or off"))?)
                }
                "seconds" => {
                    let t: f64 = v.parse().map_err(|_| bad("expected a number"))?;
                    if !(t.is_finite() && t > 0.0) {
                        return Err(bad("must be a positive number"));
                    }
                    s.seconds = Some(t);
                }
                _ => {
                    return Err(error(format!(
                        "unknown key '{k}' (known: nee, filter, rr_start, rr_floor, \
                         max_bounces, splits, light_vertex, adaptive, seconds)"
                    )));
                }
            }
        }
        Ok(s)
    }

    /// `base` with this setting's changes (its time filter always).
    pub fn apply(&self, base: RenderRequest) -> RenderRequest {
        RenderRequest {
            nee: self.nee.unwrap_or(base.nee),
            rr_start: self.rr_start.unwrap_or(base.rr_start),
            rr_floor: self.rr_min_survival.unwrap_or(base.rr_floor),
            max_bounces: self.max_bounces.unwrap_or(base.max_bounces),
            splits: match self.splits {
                Some(0) => None,
                Some(k) => Some(k),
                None => base.splits,
            },
            light_vertex: self.light_vertex.or(base.light_vertex),
            uniform: self.adaptive.map_or(base.uniform, |a| !a),
            time_filter: self.filter,
            ..base
        }
    }
}

/// One measurement.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Checkpoint {
    pub setting: String,
    /// Wall seconds of rendering so far (passes only).
    pub seconds: f64,
    pub spp: u64,
    pub passes: u64,
    /// `||cube - ref||_2 / ||ref||_2` over all pixels and bins.
    pub rel_l2_cube: f64,
    /// `sum |cube - ref| / sum |ref|`.
    pub rel_l1_cube: f64,
    pub rel_l2_steady: f64,
    pub rel_l1_steady: f64,
    /// The film's own estimate of its relative L2 error (two independent halves), no
    /// reference needed.
    pub half_estimate: Option<f64>,
    /// NaN or infinite values in the cube.
    pub non_finite: u64,
}

/// Relative L2 and L1 errors of `got` against `want`.
pub fn relative_errors(got: &[f64], want: &[f64]) -> (f64, f64) {
    let (mut d2, mut r2, mut d1, mut r1) = (0.0, 0.0, 0.0, 0.0);
    for (g, w) in got.iter().zip(want) {
        let d = g - w;
        d2 += d * d;
        r2 += w * w;
        d1 += d.abs();
        r1 += w.abs();
    }
    let rel = |d: f64, r: f64| if r > 0.0 { d / r } else { d };
    (rel(d2.sqrt(), r2.sqrt()), rel(d1, r1))
}

/// Measure `film` against `reference`.
pub fn measure(
    setting: &str,
    seconds: f64,
    film: &TprfFilm,
    reference: &ReferenceCube,
) -> Checkpoint {
    let cube = film.cube_f64();
    let non_finite = cube.iter().filter(|v| !v.is_finite()).count() as u64;
    let (rel_l2_cube, rel_l1_cube) = relative_errors(&cube, &reference.values);
    let steady = film.steady();
    let (rel_l2_steady, rel_l1_steady) = relative_errors(&steady, &reference.steady());
    Checkpoint {
        setting: setting.to_string(),
        seconds,
        spp: film.spp(),
        passes: film.passes(),
        rel_l2_cube,
        rel_l1_cube,
        rel_l2_steady,
        rel_l1_steady,
        half_estimate: film.half_error_estimate(),
        non_finite,
    }
}

/// How a run is done.
#[derive(Clone, Debug, PartialEq)]
pub struct RunConfig {
    /// Seconds of rendering per setting (unless the setting has its own).
    pub seconds: f64,
    /// Checkpoints per decade of time (evenly spaced in log time).
    pub per_decade: u32,
    /// The request every estimator setting starts from (seed, channel, threads...); its
    /// film, window and stopping rule are the run's.
    pub base: RenderRequest,
}

impl Default for RunConfig {
    fn default() -> Self {
        RunConfig {
            seconds: 10.0,
            per_decade: 8,
            base: RenderRequest::default(),
        }
    }
}

/// Render `scene` with `setting` on the reference's film (its size and time axis) for
/// the time budget, in the doubling passes of `tprf render`, measuring at checkpoints
/// `10^(k / per_decade)` seconds (the first pass end after each), after the first pass
/// and at the end. `on_checkpoint` sees each one as it is made. A setting whose next
/// pass would not fit in memory (the base request's `max_memory`, or what the process
/// may still allocate) ends there: its checkpoints so far, and the stop.
pub fn run_setting(
    scene: &Arc<Scene>,
    setting: &EstimatorSetting,
    config: &RunConfig,
    reference: &ReferenceCube,
    mut on_checkpoint: impl FnMut(&Checkpoint),
) -> Result<SettingRun, RequestError> {
    let request = RenderRequest {
        scene: scene.name.clone(),
        width: reference.width,
        height: reference.height,
        bins: reference.axis.bins,
        t0_s: Some(reference.axis.t0_s),
        dt_s: Some(reference.axis.dt_s),
        bounces_separate: 0,
        // The run's own clock ends it (`render_s`, below).
        spp: None,
        seconds: None,
        error_target: None,
        until_stopped: true,
        pass_seconds: None,
        shard: None,
        ..setting.apply(config.base.clone())
    };
    let mut session = Session::with_scene(&request, scene.clone())?;
    let budget = setting.seconds.unwrap_or(config.seconds);
    let per_decade = config.per_decade.max(1) as f64;
    let grid = |k: i64| 10f64.powf(k as f64 / per_decade);
    let mut next_k: Option<i64> = None;
    let mut out = Vec::new();
    // The clock is the renderer's own (`render_s`): measuring is not charged.
    session.run(|report, film| {
        let rendered = report.render_s;
        let done = !(rendered < budget);
        let due = next_k.is_none_or(|k| rendered >= grid(k));
        if due || done {
            let c = measure(&setting.label, rendered, film, reference);
            on_checkpoint(&c);
            out.push(c);
            // The first grid time after now.
            let mut k = (rendered.log10() * per_decade).floor() as i64;
            while grid(k) <= rendered {
                k += 1;
            }
            next_k = Some(k);
        }
        if done {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    Ok(SettingRun {
        checkpoints: out,
        memory_stop: session.memory_stop().cloned(),
    })
}

/// What [`run_setting`] measured.
#[derive(Clone, Debug, PartialEq)]
pub struct SettingRun {
    pub checkpoints: Vec<Checkpoint>,
    /// Why the setting ended before its time budget: its next pass would not have fitted
    /// in memory (`None`: it ran its budget).
    pub memory_stop: Option<MemoryStop>,
}

/// A least-squares line through `(log10 x, log10 y)`: `y = 10^intercept x^slope`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LogLogFit {
    pub slope: f64,
    pub intercept: f64,
    pub points: usize,
}

impl LogLogFit {
    pub fn at(&self, x: f64) -> f64 {
        10f64.powf(self.intercept + self.slope * x.log10())
    }
}

/// Fit `y ~ x^slope` over the pairs with both positive and finite; `None` with fewer
/// than 3 points or no spread in x.
pub fn fit_loglog(points: impl IntoIterator<Item = (f64, f64)>) -> Option<LogLogFit> {
    let pts: Vec<(f64, f64)> = points
        .into_iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.log10(), y.log10()))
        .collect();
    let n = pts.len();
    if n < 3 {
        return None;
    }
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n as f64;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n as f64;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if !(sxx > 0.0) {
        return None;
    }
    let slope = sxy / sxx;
    Some(LogLogFit {
        slope,
        intercept: my - slope * mx,
        points: n,
    })
}

/// Figures of one setting's run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    pub setting: String,
    /// Relative L2 error of the cube at 1 s, 10 s and 60 s (interpolated in log-log
    /// between checkpoints; `None` past the run's end).
    pub error_at: [(f64, Option<f64>); 3],
    /// Slope of log error against log seconds (checkpoints with at least 8 spp).
    pub slope_time: Option<LogLogFit>,
    /// Slope of log error against log spp (same checkpoints).
    pub slope_spp: Option<LogLogFit>,
    pub final_seconds: f64,
    pub final_spp: u64,
    pub final_error: f64,
    pub final_half_estimate: Option<f64>,
    /// `sqrt(max(0, error^2 - estimate^2))` at the end: the part of the error the noise
    /// estimate does not explain (a bias, or the reference's own error).
    pub excess_over_noise: Option<f64>,
    pub final_error_steady: f64,
}

/// Interpolate `y` at `x` in log-log between the checkpoints around it.
fn interpolate(points: &[(f64, f64)], x: f64) -> Option<f64> {
    let i = points.iter().position(|p| p.0 >= x)?;
    if i == 0 {
        return (points[0].0 == x).then_some(points[0].1);
    }
    let (a, b) = (points[i - 1], points[i]);
    if !(a.1 > 0.0 && b.1 > 0.0) {
        return Some(b.1);
    }
    let f = (x.ln() - a.0.ln()) / (b.0.ln() - a.0.ln());
    Some((a.1.ln() + f * (b.1.ln() - a.1.ln())).exp())
}

/// Summarise one setting's checkpoints.
pub fn summarise(checkpoints: &[Checkpoint]) -> Option<Summary> {
    let last = checkpoints.last()?;
    let curve: Vec<(f64, f64)> = checkpoints
        .iter()
        .map(|c| (c.seconds, c.rel_l2_cube))
        .collect();
    let asymptotic = || checkpoints.iter().filter(|c| c.spp >= 8);
    Some(Summary {
        setting: last.setting.clone(),
        error_at: [1.0, 10.0, 60.0].map(|t| (t, interpolate(&curve, t))),
        slope_time: fit_loglog(asymptotic().map(|c| (c.seconds, c.rel_l2_cube))),
        slope_spp: fit_loglog(asymptotic().map(|c| (c.spp as f64, c.rel_l2_cube))),
        final_seconds: last.seconds,
        final_spp: last.spp,
        final_error: last.rel_l2_cube,
        final_half_estimate: last.half_estimate,
        excess_over_noise: last
            .half_estimate
            .map(|e| (last.rel_l2_cube.powi(2) - e * e).max(0.0).sqrt()),
        final_error_steady: last.rel_l2_steady,
    })
}

/// The CSV of all checkpoints (one header line).
pub fn csv(checkpoints: &[Checkpoint]) -> String {
    let mut s = String::from(
        "setting,seconds,spp,passes,rel_l2_cube,rel_l1_cube,rel_l2_steady,rel_l1_steady,\
         half_estimate,non_finite\n",
    );
    for c in checkpoints {
        let _ = writeln!(
            s,
            "\"{}\",{:.6},{},{},{:.6e},{:.6e},{:.6e},{:.6e},{},{}",
            c.setting.replace('"', "'"),
            c.seconds,
            c.spp,
            c.passes,
            c.rel_l2_cube,
            c.rel_l1_cube,
            c.rel_l2_steady,
            c.rel_l1_steady,
            c.half_estimate
                .map_or(String::new(), |e| format!("{e:.6e}")),
            c.non_finite
        );
    }
    s
}

/// A plain-text table of the summaries.
pub fn summary_text(summaries: &[Summary]) -> String {
    let pct = |e: Option<f64>| e.map_or("-".to_string(), |e| format!("{:.3} %", 100.0 * e));
    let mut s = String::from(
        "| setting | error at 1 s | at 10 s | at 60 s | slope (time) | slope (spp) | spp | \
         final error | noise estimate | excess over noise | steady error |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for m in summaries {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            m.setting,
            pct(m.error_at[0].1),
            pct(m.error_at[1].1),
            pct(m.error_at[2].1),
            m.slope_time
                .map_or("-".into(), |f| format!("{:.3}", f.slope)),
            m.slope_spp
                .map_or("-".into(), |f| format!("{:.3}", f.slope)),
            m.final_spp,
            pct(Some(m.final_error)),
            pct(m.final_half_estimate),
            pct(m.excess_over_noise),
            pct(Some(m.final_error_steady)),
        );
    }
    s
}

/// What a run renders and compares against.
pub struct Target {
    /// For titles: `furnace rho=0.9`, or the cube's path.
    pub label: String,
    pub scene: Scene,
    pub reference: ReferenceCube,
    pub channel: Channel,
}

/// Film choices from the command line; `None` leaves them to the reference.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilmRequest {
    pub width: Option<usize>,
    pub height: Option<usize>,
    pub bins: Option<usize>,
    pub t0_s: Option<f64>,
    pub dt_s: Option<f64>,
}

/// Resolve the scene and the reference. `reference` is an `analytic:...` spec (whose
/// scene is built here; `scene` may then be omitted or repeat the spec) or a `.npy`
/// cube written by `tprf render` (its `tprf.json` beside it gives the time axis, and
/// `scene` names what to render). With neither `reference`, an `analytic:` `scene` is
/// its own reference.
pub fn resolve_target(
    scene: Option<&str>,
    reference: Option<&str>,
    film: &FilmRequest,
) -> Result<Target, ReportError> {
    let reference = match (reference, scene) {
        (Some(r), _) => r,
        (None, Some(s)) if s.starts_with("analytic:") => s,
        _ => return Err(ReportError::NoReference),
    };
    if reference.starts_with("analytic:") {
        if let Some(s) = scene
            && s != reference
            && s != "analytic"
        {
            return Err(ReportError::SceneWithAnalytic {
                reference: reference.to_string(),
                scene: s.to_string(),
            });
        }
        let a = Analytic::parse(reference)?;
        let (w0, h0, b0) = a.default_film();
        let (w, h, bins) = (
            film.width.unwrap_or(w0),
            film.height.unwrap_or(h0),
            film.bins.unwrap_or(b0),
        );
        check_film(w, h)?;
        if w.saturating_mul(h).saturating_mul(bins) > MAX_VALUES {
            return Err(ReportError::FilmTooLarge {
                width: w,
                height: h,
                bins,
                max: MAX_VALUES,
            });
        }
        check_memory(w, h, bins)?;
        let mut axis = a.default_axis(w, h, bins)?;
        if film.t0_s.is_some() || film.dt_s.is_some() {
            axis = TimeAxis::new(
                film.t0_s.unwrap_or(axis.t0_s),
                film.dt_s.unwrap_or(axis.dt_s),
                bins,
            )?;
        }
        return Ok(Target {
            label: a.label(),
            scene: a.scene(),
            reference: a.cube(w, h, &axis),
            channel: Channel::Gray,
        });
    }
    // A cube from a long render.
    let path = Path::new(reference);
    let npy = if path.is_dir() {
        path.join("tprf.npy")
    } else {
        path.to_path_buf()
    };
    if npy.extension().and_then(|e| e.to_str()) != Some("npy") {
        return Err(ReportError::UnknownReference(reference.to_string()));
    }
    let Some(scene_name) = scene.filter(|s| !s.starts_with("analytic")) else {
        return Err(ReportError::NoScene);
    };
    let (meta, data) = read_cube(&npy)?;
    check_memory(meta.width, meta.height, meta.bins)?;
    let meta_path = npy.with_file_name("tprf.json");
    let axis = meta.axis().map_err(|source| ExportError::Axis {
        path: meta_path.clone(),
        source,
    })?;
    if let Some(index) = data.iter().position(|v| !v.is_finite()) {
        return Err(ReportError::NotFinite { path: npy, index });
    }
    let conflicts = [
        film.width.is_some_and(|w| w != meta.width),
        film.height.is_some_and(|h| h != meta.height),
        film.bins.is_some_and(|b| b != meta.bins),
        film.t0_s.is_some_and(|t| t != meta.t0_s),
        film.dt_s.is_some_and(|t| t != meta.dt_s),
    ];
    if conflicts.iter().any(|&c| c) {
        return Err(ReportError::FilmFromCube);
    }
    let channel: Channel = match meta.channel.parse() {
        Ok(c) => c,
        Err(_) => {
            return Err(ReportError::UnknownChannel {
                path: meta_path,
                channel: meta.channel.clone(),
            });
        }
    };
    let scene = crate::scene::load(scene_name)?;
    Ok(Target {
        label: format!("{scene_name} against {} ({} spp)", npy.display(), meta.spp),
        scene,
        reference: ReferenceCube {
            width: meta.width,
            height: meta.height,
            axis,
            values: data.iter().map(|&v| v as f64).collect(),
        },
        channel,
    })
}

/// Largest film side a convergence run accepts.
const MAX_SIDE: usize = 4096;
/// Largest number of pixel-bins of a convergence run (f64 each, several copies).
const MAX_VALUES: usize = 1 << 27;

/// Bytes a convergence run holds per pixel-bin: the film's two f64 halves, the f64
/// reference and a dense f64 copy for the error.
const BYTES_PER_VALUE: u64 = 32;

/// Refuse a run on a `width x height x bins` film whose values do not fit in the memory
/// left ([`crate::budget`]).
fn check_memory(width: usize, height: usize, bins: usize) -> Result<(), ReportError> {
    let values = (width as u64)
        .saturating_mul(height as u64)
        .saturating_mul(bins as u64);
    crate::budget::check(
        values.saturating_mul(BYTES_PER_VALUE),
        "the convergence run",
        format_args!("a {width} x {height} x {bins} film, its reference and a copy"),
    )?;
    Ok(())
}

/// Both sides of the film in `1..=MAX_SIDE`.
fn check_film(width: usize, height: usize) -> Result<(), ReportError> {
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(ReportError::FilmSide {
            width,
            height,
            max: MAX_SIDE,
        });
    }
    Ok(())
}

/// Write `converge.csv`, `converge.png` (log-log, fitted slopes, `t^-1/2` guide) and
/// `summary.md` (the figures per setting) as the folder `dir`: written beside it and
/// swapped in whole ([`export::staging`]: `dir` must be new, empty, or an earlier tprf
/// output); `inputs` are what the run read (a reference cube), never replaced.
pub fn write_outputs(
    dir: &Path,
    inputs: &[&Path],
    title: &str,
    checkpoints: &[Checkpoint],
    summaries: &[Summary],
) -> Result<(), ReportError> {
    let staging = export::staging::Staging::new(dir, inputs)?;
    let out = staging.path();
    let text = csv(checkpoints);
    write_atomic(&out.join("converge.csv"), |w| {
        w.write_all(text.as_bytes())?;
        Ok(())
    })?;
    plot::write_convergence_png(
        &out.join("converge.png"),
        title,
        &plot_curves(checkpoints, summaries),
    )?;
    let md = format!("# {title}\n\n{}", summary_text(summaries));
    write_atomic(&out.join("summary.md"), |w| {
        w.write_all(md.as_bytes())?;
        Ok(())
    })?;
    staging.commit()?;
    Ok(())
}

/// One curve per summarised setting: its error against the reference, its two-half
/// estimate, and a legend with the fitted slope and the last value.
fn plot_curves(checkpoints: &[Checkpoint], summaries: &[Summary]) -> Vec<Curve> {
    summaries
        .iter()
        .map(|s| {
            let own = || checkpoints.iter().filter(|c| c.setting == s.setting);
            let slope = s
                .slope_time
                .map_or("slope -".to_string(), |f| format!("slope {:.2}", f.slope));
            Curve {
                label: format!(
                    "{}: {slope}, {:.2} % at {:.0} s",
                    s.setting,
                    100.0 * s.final_error,
                    s.final_seconds
                ),
                error: own().map(|c| (c.seconds, c.rel_l2_cube)).collect(),
                estimate: own()
                    .filter_map(|c| c.half_estimate.map(|e| (c.seconds, e)))
                    .collect(),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_parse() {
        let s = EstimatorSetting::parse("nee=off, filter=tent,rr_start=8,rr_floor=0.25").unwrap();
        assert_eq!(EstimatorSetting::parse("splits=3").unwrap().splits, Some(3));
        assert_eq!(
            EstimatorSetting::parse("splits=auto").unwrap().splits,
            Some(0)
        );
        assert!(EstimatorSetting::parse("splits=0").is_err());
        assert_eq!(s.nee, Some(false));
        assert_eq!(s.filter, TimeFilter::Tent);
        assert_eq!(s.rr_start, Some(8));
        assert_eq!(s.rr_min_survival, Some(0.25));
        let r = s.apply(RenderRequest::default()).settings();
        assert!(!r.nee && r.rr_start == 8 && r.rr_min_survival == 0.25);
        let auto = EstimatorSetting::parse("splits=auto").unwrap();
        let r = auto.apply(RenderRequest {
            splits: Some(4),
            ..RenderRequest::default()
        });
        assert_eq!(r.splits, None);
        assert_eq!(EstimatorSetting::parse("default").unwrap().label, "default");
        for bad in [
            "",
            "nee=maybe",
            "filter=gauss",
            "rr_floor=2",
            "rr_floor=NaN",
            "seconds=-1",
            "speed=fast",
            "nee",
        ] {
            assert!(EstimatorSetting::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn fit_recovers_a_power_law() {
        let f = fit_loglog((1..20).map(|i| (i as f64, 3.0 * (i as f64).powf(-0.5)))).unwrap();
        assert!((f.slope + 0.5).abs() < 1e-12 && (f.at(1.0) - 3.0).abs() < 1e-12);
        assert!(fit_loglog([(1.0, 1.0), (2.0, 0.5)]).is_none());
    }

    #[test]
    fn interpolation_is_log_log() {
        let pts = [(0.5, 4.0), (2.0, 1.0), (8.0, 0.5)];
        assert!((interpolate(&pts, 1.0).unwrap() - 2.0).abs() < 1e-12);
        assert!(interpolate(&pts, 10.0).is_none());
        assert!(interpolate(&pts, 0.1).is_none());
    }
}
