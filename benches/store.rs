//! Store benchmark: `cargo bench --bench store` (a plain program, not a timed test).
//!
//! The sparse TPRF store against a dense one, in one run, on the same samples: for
//! `builtin:cornell`, `builtin:canopy` and the Cornell box with the 1 M-triangle blob of
//! `benches/engine.rs`, at 256 x 256 x 1024, the film is rendered with
//! `progressive::render` (as `tprf render` does), then the same passes (same pass sizes,
//! same random streams) are traced into a dense `[half][pixel][bin]` f64 accumulation
//! written here, as the store was before it became sparse. Runs alternate, best of two.
//! Printed: paths/s of both and their ratio, the store's bytes against the dense bytes
//! and against `16 B x stored bins + 64 B x pixels`, and the largest difference between
//! the two cubes (the same sums in another order: rounding only).

use rayon::prelude::*;
use std::ops::ControlFlow;
use std::sync::Arc;
use std::time::Instant;
use tprf_core::film::{FilmLayout, TimeAxis, TprfFilm};
use tprf_core::transport::progressive::{self, Schedule};
use tprf_core::transport::sampler::Sampler;
use tprf_core::transport::{RenderSettings, Renderer, Sink, WindowRequest, auto_window};

mod common;
use common::cornell_blob;

const W: usize = 256;
const H: usize = 256;
const BINS: usize = 1024;
const SPP: u64 = 64;
const REPEATS: usize = 2;

/// One pixel's bins in one half of a dense film: the box filter, as the film's.
struct DenseSink<'a> {
    axis: TimeAxis,
    bins: &'a mut [f64],
}

impl Sink for DenseSink<'_> {
    #[inline]
    fn add(&mut self, arrival_s: f64, value: f64, _scatterings: u32) {
        if let Some(slot) = self
            .axis
            .bin_of(arrival_s)
            .and_then(|b| self.bins.get_mut(b))
        {
            *slot += value;
        }
    }
    fn window_end_s(&self) -> f64 {
        self.axis.end_s()
    }
    fn window_start_s(&self) -> f64 {
        self.axis.t0_s
    }
}

/// The passes `(pass, spp)` traced into a dense film; returns its two halves.
fn render_dense(renderer: &Renderer, axis: TimeAxis, passes: &[(u64, u32)]) -> [Vec<f64>; 2] {
    let mut halves = [vec![0.0f64; W * H * BINS], vec![0.0f64; W * H * BINS]];
    let mut half_spp = [0u64; 2];
    for &(pass, spp) in passes {
        let h = (pass % 2) as usize;
        let first = half_spp[h];
        half_spp[h] += spp as u64;
        halves[h]
            .par_chunks_mut(W * BINS)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, bins) in row.chunks_mut(BINS).enumerate() {
                    // The film's streams: per (seed, half, pixel), continued pass to pass.
                    let mut rng =
                        Sampler::new(renderer.settings().seed, h as u64, (y * W + x) as u64)
                            .starting_at(first);
                    let mut sink = DenseSink { axis, bins };
                    for _ in 0..spp {
                        renderer.trace_sample(x, y, W, H, &mut rng, &mut sink);
                    }
                }
            });
    }
    halves
}

fn main() {
    println!(
        "| scene | sparse paths/s | dense paths/s | sparse / dense | bins stored | store | dense store | store / (16 B x stored + 64 B x pixels) | largest cube difference |"
    );
    println!("|---|--:|--:|--:|--:|--:|--:|--:|--:|");
    for name in ["builtin:cornell", "builtin:canopy", "cornell + blob"] {
        let scene = if name == "cornell + blob" {
            cornell_blob(512, 1024)
        } else {
            match tprf_core::scene::load(name) {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("{name}: {e}");
                    continue;
                }
            }
        };
        let name = if name == "cornell + blob" {
            format!("cornell + {}-triangle blob", scene.triangles.len() - 10)
        } else {
            name.to_string()
        };
        // Uniform samples: the dense replay draws every pixel's samples of each pass.
        let renderer = Renderer::new(
            Arc::new(scene),
            RenderSettings {
                adaptive: false,
                ..RenderSettings::default()
            },
        );
        let Ok(axis) = auto_window(
            &renderer,
            WindowRequest {
                bins: BINS,
                aspect: W as f64 / H as f64,
                ..WindowRequest::default()
            },
        ) else {
            eprintln!("{name}: no time window");
            continue;
        };
        let layout = FilmLayout {
            width: W,
            height: H,
            axis,
            bounces_separate: 0,
            luminescence: false,
        };
        let mut sparse_s = f64::INFINITY;
        let mut dense_s = f64::INFINITY;
        let mut film = None;
        let mut dense = None;
        for _ in 0..REPEATS {
            let mut f = TprfFilm::new(layout).expect("film");
            let start = Instant::now();
            let reports = progressive::render(&renderer, &mut f, &Schedule::spp(SPP), |_, _| {
                ControlFlow::Continue(())
            });
            sparse_s = sparse_s.min(start.elapsed().as_secs_f64());
            let passes: Vec<(u64, u32)> = reports.iter().map(|r| (r.pass, r.pass_spp)).collect();
            let start = Instant::now();
            let d = render_dense(&renderer, axis, &passes);
            dense_s = dense_s.min(start.elapsed().as_secs_f64());
            film = Some(f);
            dense = Some(d);
        }
        let (Some(film), Some([h0, h1])) = (film, dense) else {
            continue;
        };
        let n = film.spp() as f64;
        let mut worst = 0.0f64;
        for y in 0..H {
            for x in 0..W {
                let got = film.pixel_tprf(x, y);
                let base = (y * W + x) * BINS;
                for (b, g) in got.iter().enumerate() {
                    let want = (h0[base + b] + h1[base + b]) / n;
                    let scale = want.abs().max(1e-300);
                    worst = worst.max((g - want).abs() / scale);
                }
            }
        }
        let st = film.store_stats();
        let paths = (W * H) as f64 * SPP as f64;
        println!(
            "| {name} {W}x{H}x{BINS}, {SPP} spp | {:.2} M | {:.2} M | {:.3} | {:.1} % | {:.0} MB | {:.2} GB | {:.3} | {:.1e} (relative) |",
            paths / sparse_s / 1e6,
            paths / dense_s / 1e6,
            dense_s / sparse_s,
            100.0 * st.stored_bins as f64 / st.dense_bins as f64,
            st.bytes as f64 / 1e6,
            st.dense_bytes as f64 / 1e9,
            st.bytes as f64 / (16.0 * st.stored_bins as f64 + 64.0 * (W * H) as f64),
            worst
        );
    }
}
