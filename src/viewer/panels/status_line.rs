//! The status line at the bottom: the render's progress in wall time (a clock that runs
//! between passes), its progress toward the spp or error target with the time left, the
//! error estimate, the frame time with painting, and the latest message.

use crate::viewer::app::TprfApp;
use crate::viewer::source::Source;
use eframe::egui::{self, RichText};
use std::sync::Arc;
use std::time::Instant;
use tprf_core::film::FilmSnapshot;
use tprf_core::request::worker::{WorkerState, WorkerStatus};

/// Where a render stands against its target: the fraction done and the seconds left.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    pub fraction: f64,
    pub left_s: Option<f64>,
}

/// Progress toward the target at `elapsed_s` of wall time (at the last pass, which
/// ended `since_s` ago). An spp target: the spp rate so far, `spp / elapsed_s`, gives the
/// time left. An error target: the error falls as `t^-1/2`, so it reaches `target` at
/// `elapsed_s (error / target)^2`. `None` without a target or a rate yet.
pub fn progress(
    spp: u64,
    spp_target: Option<u64>,
    error: Option<f64>,
    error_target: Option<f64>,
    elapsed_s: f64,
    since_s: f64,
) -> Option<Progress> {
    let left = |total_s: f64| {
        (total_s.is_finite() && elapsed_s > 0.0).then(|| (total_s - elapsed_s - since_s).max(0.0))
    };
    if let Some(target) = spp_target.filter(|&t| t > 0) {
        let fraction = (spp as f64 / target as f64).min(1.0);
        let total_s = if spp > 0 {
            elapsed_s * target as f64 / spp as f64
        } else {
            f64::INFINITY
        };
        return Some(Progress {
            fraction,
            left_s: left(total_s),
        });
    }
    let target = error_target.filter(|t| *t > 0.0)?;
    let Some(e) = error.filter(|e| e.is_finite() && *e > 0.0) else {
        return Some(Progress {
            fraction: 0.0,
            left_s: None,
        });
    };
    let total_s = elapsed_s * (e / target).powi(2);
    Some(Progress {
        // Done in time as t^-1/2: the share of the total time.
        fraction: (elapsed_s / total_s).clamp(0.0, 1.0),
        left_s: left(total_s),
    })
}

/// `42 s`, `3 min 05 s`, `1 h 02 min`.
pub fn format_duration(s: f64) -> String {
    if !s.is_finite() {
        return "—".into();
    }
    let s = s.max(0.0);
    if s < 10.0 {
        format!("{s:.1} s")
    } else if s < 60.0 {
        format!("{s:.0} s")
    } else if s < 3600.0 {
        format!("{} min {:02} s", (s / 60.0) as u64, (s % 60.0) as u64)
    } else {
        format!(
            "{} h {:02} min",
            (s / 3600.0) as u64,
            ((s % 3600.0) / 60.0) as u64
        )
    }
}

impl TprfApp {
    /// Wall seconds the render has run, pauses left out: up to the last pass, plus the
    /// time since while it renders.
    fn elapsed_now_s(s: &WorkerStatus) -> (f64, f64) {
        let since = match (&s.state, s.updated_at) {
            (WorkerState::Rendering, Some(t)) => Instant::now().duration_since(t).as_secs_f64(),
            _ => 0.0,
        };
        (s.elapsed_s + since, since)
    }

    /// Progress toward the render's target, if it has one.
    pub fn render_progress(&self, snap: Option<&Arc<FilmSnapshot>>) -> Option<Progress> {
        let s = self.status()?;
        let (_, since) = Self::elapsed_now_s(&s);
        let job = match &self.source {
            Source::Live(w) => w.job(),
            _ => return None,
        };
        let p = progress(
            s.spp,
            job.spp,
            snap.and_then(|s| s.error_estimate),
            job.error_target,
            s.elapsed_s,
            since,
        )?;
        Some(if s.state == WorkerState::Done {
            Progress {
                fraction: 1.0,
                left_s: Some(0.0),
            }
        } else {
            p
        })
    }

    /// State, spp, wall time, passes/s, rays/s, error estimate, store, frame time.
    pub fn status_line(&self, snap: Option<&Arc<FilmSnapshot>>) -> String {
        self.status_parts(snap).join("  ·  ")
    }

    /// The parts of [`Self::status_line`], each shown whole (the bar wraps between them).
    fn status_parts(&self, snap: Option<&Arc<FilmSnapshot>>) -> Vec<String> {
        let mut parts = Vec::new();
        if let Some(s) = self.status() {
            let state = match &s.state {
                WorkerState::Loading => "loading".to_string(),
                WorkerState::Rendering => "rendering".to_string(),
                // Paused by the render itself: its next pass would not fit in memory.
                WorkerState::Paused => match &s.memory_stop {
                    Some(m) => format!("paused for memory: {m} (resume tries the pass again)"),
                    None => "paused".to_string(),
                },
                WorkerState::Done => "done".to_string(),
                WorkerState::Failed(e) => format!("failed: {e}"),
            };
            parts.push(state);
            parts.push(format!("{} spp", s.spp));
            let (elapsed, _) = Self::elapsed_now_s(&s);
            parts.push(format!("{} wall", format_duration(elapsed)));
            // Rates over the same wall time, at the last pass.
            let t = s.elapsed_s.max(1e-9);
            parts.push(format!("{:.1} passes/s", s.passes as f64 / t));
            parts.push(format!("{:.2} Mrays/s", s.rays as f64 / t / 1e6));
            if s.store.dense_bins > 0 {
                parts.push(format!(
                    "stored {:.1} % of bins ({} of {} dense)",
                    100.0 * s.store.stored_bins as f64 / s.store.dense_bins as f64,
                    human_bytes(s.store.bytes),
                    human_bytes(s.store.dense_bytes)
                ));
            }
            if s.ambient_pending {
                parts.push("ambient image: rendering after the first pass".into());
            } else if let Some(a) = self.ambient() {
                parts.push(format!("ambient image {} spp", a.spp));
            }
            let skipped = s.left_out.shadow_rays_late + s.left_out.shadow_rays_early;
            if skipped + s.left_out.paths_past_window > 0 {
                let paths = s.left_out.paths_past_window;
                parts.push(format!(
                    "left out: {skipped} shadow ray{}, {paths} path{} past the window",
                    if skipped == 1 { "" } else { "s" },
                    if paths == 1 { "" } else { "s" },
                ));
            }
        } else if let Source::Cube { dir, meta, .. } = &self.source {
            parts.push(format!(
                "cube {} · {} · {} spp · rendered in {:.1} s",
                dir.display(),
                meta.scene,
                meta.spp,
                meta.wall_seconds
            ));
            if let Some(a) = &meta.ambient {
                parts.push(format!("ambient image {} ({} spp)", a.file, a.spp));
            }
        }
        if let Some(e) = snap.and_then(|s| s.error_estimate) {
            parts.push(format!("error ≈ {:.2} %", 100.0 * e));
        }
        let t = &self.timing;
        parts.push(match t.cpu_ms {
            Some(cpu) => format!(
                "frame {cpu:.1} ms CPU with painting (UI {:.1} ms), every {:.0} ms",
                t.ui_ms, t.interval_ms
            ),
            None => format!("UI {:.1} ms/frame", t.ui_ms),
        });
        parts
    }

    /// The progress bar toward the target (when there is one), the status line, then
    /// the latest message (all of them: the left panel).
    pub(crate) fn status_bar_ui(&self, ui: &mut egui::Ui, snap: Option<&Arc<FilmSnapshot>>) {
        ui.horizontal_wrapped(|ui| {
            if let Some(p) = self.render_progress(snap) {
                let text = match p.left_s {
                    Some(l) if p.fraction < 1.0 => {
                        format!("{:.0} % · ~{} left", 100.0 * p.fraction, format_duration(l))
                    }
                    _ if p.fraction >= 1.0 => "target reached".to_string(),
                    _ => format!("{:.0} %", 100.0 * p.fraction),
                };
                ui.add(
                    egui::ProgressBar::new(p.fraction as f32)
                        .desired_width(200.0)
                        .text(text),
                );
            }
            for (i, part) in self.status_parts(snap).into_iter().enumerate() {
                if i > 0 {
                    ui.label("·");
                }
                ui.add(egui::Label::new(part).wrap_mode(egui::TextWrapMode::Extend));
            }
            if let Some(m) = self.messages.last() {
                ui.separator();
                ui.label(RichText::new(m).color(super::message_color(ui, m)));
            }
        });
    }
}

/// Bytes as `812 MB` / `1.4 GB` (powers of 1000, as file managers show them).
fn human_bytes(b: u64) -> String {
    let b = b as f64;
    if b >= 1e9 {
        format!("{:.1} GB", b / 1e9)
    } else if b >= 1e6 {
        format!("{:.0} MB", b / 1e6)
    } else {
        format!("{:.0} kB", b / 1e3)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_left_follows_the_rate_so_far() {
        // 64 of 256 spp in 10 s: 40 s in all, 30 s left; 5 s after that pass, 25 s.
        let p = progress(64, Some(256), None, None, 10.0, 0.0).unwrap();
        assert_eq!(p.fraction, 0.25);
        assert!((p.left_s.unwrap() - 30.0).abs() < 1e-9);
        let p = progress(64, Some(256), None, None, 10.0, 5.0).unwrap();
        assert!((p.left_s.unwrap() - 25.0).abs() < 1e-9);
        // Error 4 % after 10 s toward 1 %: error ~ t^-1/2, so 160 s in all.
        let p = progress(8, None, Some(0.04), Some(0.01), 10.0, 0.0).unwrap();
        assert!((p.left_s.unwrap() - 150.0).abs() < 1e-9);
        assert!((p.fraction - 10.0 / 160.0).abs() < 1e-12);
        // No estimate yet: no time left to say; no target: no progress.
        let p = progress(1, None, None, Some(0.01), 0.5, 0.0).unwrap();
        assert_eq!(p.left_s, None);
        assert_eq!(progress(64, None, Some(0.1), None, 10.0, 0.0), None);
        // Nothing rendered yet: no rate, no time left.
        let p = progress(0, Some(16), None, None, 0.0, 0.0).unwrap();
        assert_eq!((p.fraction, p.left_s), (0.0, None));
    }

    #[test]
    fn durations_read_as_people_say_them() {
        assert_eq!(format_duration(3.42), "3.4 s");
        assert_eq!(format_duration(42.4), "42 s");
        assert_eq!(format_duration(185.0), "3 min 05 s");
        assert_eq!(format_duration(3720.0), "1 h 02 min");
        assert_eq!(format_duration(f64::NAN), "—");
    }
}
