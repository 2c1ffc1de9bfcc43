//! The status line at the bottom: the render's progress (or the cube's origin), the
//! error estimate, the frame time, and the latest message.

use crate::viewer::app::TprfApp;
use crate::viewer::source::Source;
use eframe::egui::{self, RichText};
use std::sync::Arc;
use tprf_core::film::FilmSnapshot;
use tprf_core::transport::worker::WorkerState;

impl TprfApp {
    /// spp, passes/s, elapsed time, error estimate and frame time.
    pub fn status_line(&self, snap: Option<&Arc<FilmSnapshot>>) -> String {
        let mut parts = Vec::new();
        if let Some(s) = self.status() {
            let state = match &s.state {
                WorkerState::Loading => "loading".to_string(),
                WorkerState::Rendering => "rendering".to_string(),
                WorkerState::Paused => "paused".to_string(),
                WorkerState::Done => "done".to_string(),
                WorkerState::Failed(e) => format!("failed: {e}"),
            };
            parts.push(state);
            parts.push(format!("{} spp", s.spp));
            parts.push(format!("{:.1} passes/s", s.passes_per_s));
            parts.push(format!("{:.1} s", s.elapsed_s));
            parts.push(format!(
                "{:.1} Mrays/s",
                s.rays as f64 / s.elapsed_s.max(1e-9) / 1e6
            ));
            if s.store.dense_bins > 0 {
                parts.push(format!(
                    "stored {:.1} % of bins ({} of {} dense)",
                    100.0 * s.store.stored_bins as f64 / s.store.dense_bins as f64,
                    human_bytes(s.store.bytes),
                    human_bytes(s.store.dense_bytes)
                ));
            }
            let skipped = s.left_out.shadow_rays_late + s.left_out.shadow_rays_early;
            if skipped + s.left_out.paths_past_window > 0 {
                parts.push(format!(
                    "left out: {skipped} shadow rays, {} paths past the window",
                    s.left_out.paths_past_window
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
        }
        if let Some(e) = snap.and_then(|s| s.error_estimate) {
            parts.push(format!("error ≈ {:.2} %", 100.0 * e));
        }
        parts.push(format!("frame {:.1} ms", self.frame_ms));
        parts.join("  ·  ")
    }

    /// The status line, then the latest message (all of them: the left panel).
    pub(crate) fn status_bar_ui(&self, ui: &mut egui::Ui, snap: Option<&Arc<FilmSnapshot>>) {
        ui.horizontal(|ui| {
            ui.label(RichText::new(self.status_line(snap)).small());
            if let Some(m) = self.messages.last() {
                ui.separator();
                ui.label(RichText::new(m).small().color(ui.visuals().error_fg_color));
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
