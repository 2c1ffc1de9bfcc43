//! The one way to run a render: passes of samples added to every pixel of a film until
//! the schedule is met or the caller stops it, with a report after each pass.
//!
//! The command line, the viewer's worker, the convergence and stability reports, the
//! tests and the benchmarks all render through [`render`]; they differ only in the
//! [`Schedule`] and in what their `on_pass` callback does (a progress bar, publishing a
//! snapshot, measuring an error, waiting while paused). The callback is also how a
//! render is cancelled: it returns [`ControlFlow::Break`].

use super::PolarizedTracer;
use super::integrator::{PassStats, Renderer};
use crate::film::{LeftOutCounts, StokesFilms, TprfFilm};
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

/// How many samples per pixel each pass adds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PassSize {
    /// 1, 1, 2, 2, 4, 4, ... up to `cap`, or on a small film up to the size that makes a
    /// pass [`PASS_SAMPLES`] samples (at most [`MAX_DOUBLING_SPP`] per pixel): a fixed
    /// schedule, so the same settings give the same film (bit for bit) on any machine
    /// and thread count. Pairs keep the two halves of the film (even and odd passes)
    /// balanced. (Each pass ends with merging every pixel's bins into the film, which
    /// costs about as much as 2 samples of a pixel: the passes of a small film grow so
    /// that this stays a few per cent.)
    Doubling { cap: u32 },
    /// Passes sized from the rate the last pass measured (1 to 256 samples per pixel):
    /// about `seconds` each at first, growing to [`PACED_GROWTH`] times that over the
    /// first [`PACED_GROWTH_S`] seconds of the render: fresh previews while the image
    /// is young, and later fewer of the merges into the film and the snapshots a pass
    /// costs (at a fixed 0.25 s they held a window to 0.75 of `tprf render`'s rate).
    /// Pass sizes then depend on the machine's speed, and so does which half of the
    /// film (even or odd passes) each sample lands in.
    Paced { seconds: f64 },
}

/// When a render stops. With neither an spp target nor a time budget it runs until
/// `on_pass` breaks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Schedule {
    pub pass_size: PassSize,
    /// Stop at exactly this many samples per pixel (the last pair of passes is cut, or
    /// stretched, to fit: see [`toward_target`]).
    pub spp_target: Option<u64>,
    /// Stop at the end of the first pass that ends after this many seconds of wall time
    /// (callbacks included; at least one pass is made).
    pub time_budget_s: Option<f64>,
}

impl Schedule {
    /// Exactly `spp` samples per pixel in doubling passes (capped at 16 per pass, more
    /// on small films; the last pair up to half as much again, see [`toward_target`]).
    pub fn spp(spp: u64) -> Schedule {
        Schedule {
            pass_size: PassSize::Doubling { cap: 16 },
            spp_target: Some(spp),
            time_budget_s: None,
        }
    }

    /// Doubling passes (capped at 16 per pass, more on small films) until `seconds` of
    /// wall time have passed.
    pub fn seconds(seconds: f64) -> Schedule {
        Schedule {
            pass_size: PassSize::Doubling { cap: 16 },
            spp_target: None,
            time_budget_s: Some(seconds),
        }
    }

    /// Passes of about `seconds` each, for an interactive preview, until `spp_target`.
    pub fn paced(seconds: f64, spp_target: Option<u64>) -> Schedule {
        Schedule {
            pass_size: PassSize::Paced { seconds },
            spp_target,
            time_budget_s: None,
        }
    }
}

/// State after a pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassReport {
    /// Index of the pass just made (0 for the first pass into an empty film).
    pub pass: u64,
    /// Samples per pixel in the film after it.
    pub spp: u64,
    /// Samples per pixel this pass added.
    pub pass_spp: u32,
    /// Wall time since [`render`] was called, seconds (callbacks included).
    pub wall_s: f64,
    /// Time spent inside passes, seconds (callbacks excluded): the renderer's own time.
    pub render_s: f64,
    /// Rays the renderer has traced since it was made.
    pub rays: u64,
    /// Camera paths traced by this call to [`render`].
    pub paths: u64,
    /// Work left out by this call to [`render`] (light that could not reach the window).
    pub left_out: LeftOutCounts,
}

/// Samples a doubling pass reaches on a small film (pixels x samples per pixel).
pub const PASS_SAMPLES: u64 = 1 << 20;
/// Largest doubling pass on a small film, samples per pixel.
pub const MAX_DOUBLING_SPP: u32 = 256;

/// The cap of [`PassSize::Doubling`] passes on a film of `pixels`: `cap`, or more on a
/// small film (see there).
pub fn doubling_cap(cap: u32, pixels: usize) -> u32 {
    let small = (PASS_SAMPLES / (pixels as u64).max(1)).min(MAX_DOUBLING_SPP as u64) as u32;
    cap.max(small)
}

/// Samples per pixel of pass `pass` in [`PassSize::Doubling`]: 1, 1, 2, 2, 4, 4, ...
/// up to `cap`.
pub fn doubling_spp(pass: u64, cap: u32) -> u32 {
    let doubling = (pass / 2).min(31) as u32;
    (1u32 << doubling).min(cap.max(1))
}

/// [`doubling_spp`] of the first pass after the pair (even pass, odd pass) that `pass`
/// belongs to.
fn doubling_spp_after_pair(pass: u64, cap: u32) -> u32 {
    let after = pass + if pass.is_multiple_of(2) { 2 } else { 1 };
    doubling_spp(after, cap)
}

/// Samples per pixel of pass `pass` of a render with `left` still to draw, where the
/// schedule's passes are `spp` now and `next` after this pair (0 where not known).
///
/// Even passes fill one half of the film and odd passes the other, so passes go in pairs
/// of equal size: an even pass takes at most half of what is left, so the last pair ends
/// balanced. And where a full pair would leave less than one `next` pass, this pair takes
/// what is left (up to `spp + next / 2` each): a pair of runt passes after it would cost
/// two merges of every pixel's bins into the film for a few samples.
pub fn toward_target(pass: u64, spp: u32, next: u32, left: u64) -> u32 {
    let (spp, next) = (spp as u64, next as u64);
    let take = if pass.is_multiple_of(2) {
        let half = left.div_ceil(2);
        let rest = left.saturating_sub(2 * spp);
        if rest > 0 && rest < next {
            half
        } else {
            spp.min(half)
        }
    } else if left < spp + next {
        // The even pass before took what was left over two (see above), or all was
        // at most `spp` anyway.
        left
    } else {
        spp.min(left)
    };
    take.min(u32::MAX as u64) as u32
}

/// Largest pass of [`PassSize::Paced`], samples per pixel.
const MAX_PACED_SPP: u32 = 256;

/// How much longer than its first passes a [`PassSize::Paced`] pass grows.
pub const PACED_GROWTH: f64 = 4.0;

/// Seconds of rendering over which [`PassSize::Paced`] passes grow to [`PACED_GROWTH`]
/// times their first length (linearly).
pub const PACED_GROWTH_S: f64 = 6.0;

/// The length a [`PassSize::Paced`] pass aims at, `render_s` seconds into the render.
pub fn paced_target_s(seconds: f64, render_s: f64) -> f64 {
    let grown = 1.0 + (PACED_GROWTH - 1.0) * (render_s / PACED_GROWTH_S).clamp(0.0, 1.0);
    seconds * grown
}

/// What the passes of [`render_with`] render into: an intensity film, or a Stokes film
/// ([`Polarized`]). Generic, so an intensity render's loop is what it was.
pub trait Passes {
    /// The intensity film (a Stokes film's S0): what schedules, adaptive plans, memory
    /// budgets and the callbacks read.
    fn film(&self) -> &TprfFilm;
    /// One pass of `spp` samples per pixel.
    fn render_pass(&mut self, renderer: &Renderer, spp: u32) -> PassStats;
}

impl Passes for TprfFilm {
    #[inline]
    fn film(&self) -> &TprfFilm {
        self
    }
    #[inline]
    fn render_pass(&mut self, renderer: &Renderer, spp: u32) -> PassStats {
        renderer.render_pass(self, spp)
    }
}

/// A polarized render's passes: S0 in `s0`, S1..S3 in `s123`, every sample by `tracer`
/// (the renderer's polarized walk; the renderer [`render_with`] is given counts its rays
/// through it).
pub struct Polarized<'a, 'r> {
    pub tracer: PolarizedTracer<'r>,
    pub s0: &'a mut TprfFilm,
    pub s123: &'a mut StokesFilms,
}

impl Passes for Polarized<'_, '_> {
    fn film(&self) -> &TprfFilm {
        self.s0
    }
    fn render_pass(&mut self, _renderer: &Renderer, spp: u32) -> PassStats {
        self.tracer.render_pass(self.s0, self.s123, spp)
    }
}

/// Run passes of `renderer` into `film` until `schedule` is met or `on_pass` breaks;
/// returns the report of every pass made. A film that already holds samples goes on
/// from where it is (its pass index and spp).
pub fn render(
    renderer: &Renderer,
    film: &mut TprfFilm,
    schedule: &Schedule,
    on_pass: impl FnMut(&PassReport, &TprfFilm) -> ControlFlow<()>,
) -> Vec<PassReport> {
    render_with(
        renderer,
        film,
        schedule,
        |spp, _| ControlFlow::Continue(spp),
        on_pass,
    )
}

/// [`render`] with `before_pass(spp, film)` asked before each pass, with the samples
/// per pixel the schedule would add: it answers the samples per pixel to add (at most
/// `spp`: a paced schedule's passes may be made smaller), or [`ControlFlow::Break`] to
/// stop the render there, the film holding the passes before it (what a memory budget
/// does when the pass would not fit). `target` is a film ([`TprfFilm`]) or a polarized
/// render's films ([`Polarized`]); `before_pass` and `on_pass` see its intensity film.
pub fn render_with<P: Passes + ?Sized>(
    renderer: &Renderer,
    target: &mut P,
    schedule: &Schedule,
    mut before_pass: impl FnMut(u32, &TprfFilm) -> ControlFlow<(), u32>,
    mut on_pass: impl FnMut(&PassReport, &TprfFilm) -> ControlFlow<()>,
) -> Vec<PassReport> {
    let start = Instant::now();
    let mut reports = Vec::new();
    let mut render_time = Duration::ZERO;
    let mut paths = 0u64;
    let mut left_out = LeftOutCounts::default();
    let mut paced_spp = 1u32;
    let pixels = target.film().layout().pixels();
    loop {
        let film = target.film();
        let pass = film.passes();
        let mut spp = match schedule.pass_size {
            PassSize::Doubling { cap } => doubling_spp(pass, doubling_cap(cap, pixels)),
            PassSize::Paced { .. } => paced_spp,
        };
        if let Some(target) = schedule.spp_target {
            let left = target.saturating_sub(film.spp());
            if left == 0 {
                break;
            }
            // What the pass after this pair would be: in a doubling schedule, known now.
            let next = match schedule.pass_size {
                PassSize::Doubling { cap } => {
                    doubling_spp_after_pair(pass, doubling_cap(cap, pixels))
                }
                PassSize::Paced { .. } => 0,
            };
            spp = toward_target(pass, spp, next, left);
        }
        spp = match before_pass(spp, film) {
            ControlFlow::Continue(s) => s.clamp(1, spp),
            ControlFlow::Break(()) => break,
        };
        let pass_start = Instant::now();
        let stats = target.render_pass(renderer, spp);
        let film = target.film();
        let pass_time = pass_start.elapsed();
        render_time += pass_time;
        paths += stats.paths;
        left_out += stats.left_out;
        if let PassSize::Paced { seconds } = schedule.pass_size {
            let target = paced_target_s(seconds, render_time.as_secs_f64());
            let ratio = target / pass_time.as_secs_f64().max(1e-4);
            paced_spp = ((spp as f64 * ratio).round().max(1.0) as u32).min(MAX_PACED_SPP);
        }
        let mut report = PassReport {
            pass,
            spp: film.spp(),
            pass_spp: spp,
            wall_s: start.elapsed().as_secs_f64(),
            render_s: render_time.as_secs_f64(),
            rays: renderer.rays_traced(),
            paths,
            left_out,
        };
        let flow = on_pass(&report, film);
        report.wall_s = start.elapsed().as_secs_f64();
        reports.push(report);
        if flow.is_break() {
            break;
        }
        // `!(wall < budget)`: a NaN budget stops after one pass rather than never.
        if schedule.time_budget_s.is_some_and(|s| !(report.wall_s < s)) {
            break;
        }
    }
    reports
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pass sizes of a doubling schedule toward `target` spp (cap 16).
    fn passes_toward(target: u64) -> Vec<u32> {
        let (mut drawn, mut sizes) = (0u64, Vec::new());
        for pass in 0.. {
            let left = target - drawn;
            if left == 0 {
                break;
            }
            let next = doubling_spp_after_pair(pass, 16);
            let n = toward_target(pass, doubling_spp(pass, 16), next, left);
            sizes.push(n);
            drawn += n as u64;
        }
        sizes
    }

    /// Hand-worked schedules: pairs of equal size (the halves balanced to within one
    /// sample), no runt pair at the end, and the sizes of a plain doubling schedule up
    /// to the last pair.
    #[test]
    fn a_target_ends_on_a_whole_pair_without_runts() {
        assert_eq!(passes_toward(1), [1]);
        assert_eq!(passes_toward(2), [1, 1]);
        assert_eq!(passes_toward(3), [2, 1]);
        assert_eq!(passes_toward(4), [1, 1, 1, 1]);
        assert_eq!(passes_toward(32), [1, 1, 2, 2, 4, 4, 9, 9]);
        assert_eq!(passes_toward(64), [1, 1, 2, 2, 4, 4, 8, 8, 17, 17]);
        assert_eq!(passes_toward(64 + 2), [1, 1, 2, 2, 4, 4, 8, 8, 18, 18]);
        assert_eq!(
            passes_toward(64 + 40),
            [1, 1, 2, 2, 4, 4, 8, 8, 16, 16, 21, 21]
        );
        for target in 1..300u64 {
            let sizes = passes_toward(target);
            let half = |h: usize| {
                sizes
                    .iter()
                    .skip(h)
                    .step_by(2)
                    .map(|&n| n as u64)
                    .sum::<u64>()
            };
            assert_eq!(half(0) + half(1), target);
            assert!(half(0) - half(1) <= 1, "{target}: {sizes:?}");
            assert!(sizes.iter().all(|&n| n <= 24), "{target}: {sizes:?}");
        }
    }

    /// Hand-computed: 0.25 s passes at the start, 4 x 0.25 = 1 s from 6 s on, half
    /// way (3 s) 0.25 (1 + 3 / 2) = 0.625 s.
    #[test]
    fn paced_passes_grow_from_their_first_length_to_four_times_it() {
        for (render_s, want) in [(0.0, 0.25), (3.0, 0.625), (6.0, 1.0), (100.0, 1.0)] {
            let got = paced_target_s(0.25, render_s);
            assert!((got - want).abs() < 1e-12, "{render_s} s: {got} vs {want}");
        }
    }
}
