//! Progressive rendering: passes of samples added to every pixel until a budget is met,
//! with a report after each pass (the caller may stop early).

use super::integrator::Renderer;
use crate::film::TprfFilm;
use serde::{Deserialize, Serialize};
use std::ops::ControlFlow;
use std::time::Instant;

/// When to stop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// Exactly this many samples per pixel (deterministic).
    Spp(u64),
    /// Until this many seconds of wall time have passed (at least one pass).
    Seconds(f64),
}

/// State after a pass.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PassReport {
    pub pass: u64,
    pub spp: u64,
    pub seconds: f64,
    pub rays: u64,
    pub paths: u64,
}

/// Samples per pixel of pass `pass`: 1, 1, 2, 2, 4, 4, ... up to `cap` (pairs keep the
/// two halves of the film balanced).
pub fn pass_spp(pass: u64, cap: u32) -> u32 {
    let doubling = (pass / 2).min(31) as u32;
    (1u32 << doubling).min(cap.max(1))
}

/// Run passes of `renderer` into `film` until `budget` is met or `on_pass` breaks.
pub fn render(
    renderer: &Renderer,
    film: &mut TprfFilm,
    budget: Budget,
    mut on_pass: impl FnMut(&PassReport, &TprfFilm) -> ControlFlow<()>,
) -> Vec<PassReport> {
    let start = Instant::now();
    let mut reports = Vec::new();
    let mut paths = 0u64;
    loop {
        let pass = film.passes();
        let mut spp = pass_spp(pass, 16);
        if let Budget::Spp(target) = budget {
            let left = target.saturating_sub(film.spp());
            if left == 0 {
                break;
            }
            spp = spp.min(left.min(u32::MAX as u64) as u32);
        }
        let stats = renderer.render_pass(film, spp);
        paths += stats.paths;
        let report = PassReport {
            pass,
            spp: film.spp(),
            seconds: start.elapsed().as_secs_f64(),
            rays: renderer.rays_traced(),
            paths,
        };
        reports.push(report);
        if on_pass(&report, film).is_break() {
            break;
        }
        if let Budget::Seconds(s) = budget
            && report.seconds >= s
        {
            break;
        }
    }
    reports
}
