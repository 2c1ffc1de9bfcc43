//! Error per second of the two ways a luminescent vertex's delay reaches the film
//! (`DelaySampling::Sampled` against `Splat`), on the luminescent lit plane whose cube is
//! known exactly (`reference::luminescent_plane`): docs/luminescence.md's table.
//!
//! ```sh
//! cargo run --release -p tprf-core --example luminescence_delay [THREADS]
//! ```
//!
//! For each window (the return and the decay after it; the decay alone, from 16 ns, past
//! every pixel's return; a late gate 50-60 ns) and each
//! mode, renders 24 x 18 pixels at 64, 256 and 1024 spp on `THREADS` threads (1 unless given) and prints
//! the relative RMS error over all pixels and bins, the render time, and the efficiency
//! `1 / (error^2 x time)` (higher is better; constant in spp for an unbiased estimator).
use std::ops::ControlFlow;
use std::sync::Arc;
use std::time::Instant;
use tprf_core::film::{FilmLayout, TimeAxis, TprfFilm};
use tprf_core::reference::luminescent_plane::LuminescentPlane;
use tprf_core::reference::plane::Plane;
use tprf_core::transport::progressive::{self, Schedule};
use tprf_core::transport::{DelaySampling, RenderSettings, Renderer};

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let threads: usize = std::env::args().nth(1).map_or(Ok(1), |s| s.parse())?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let lp = LuminescentPlane {
        plane: Plane::colocated(2.0, 0.3, 3.0, 50.0, 40.0),
        components: vec![(0.4, 4e-9)],
    };
    let (w, h) = (24, 18);
    let windows = [
        (
            "decay after the return",
            TimeAxis::new(12.5e-9, 0.25e-9, 180)?,
        ),
        ("decay alone, 16-60 ns", TimeAxis::new(16e-9, 0.25e-9, 176)?),
        ("late gate 50-60 ns", TimeAxis::new(50e-9, 0.25e-9, 40)?),
    ];
    println!("| window | delay | spp | relative RMS error | time (s) | 1 / (error^2 time) |");
    println!("| --- | --- | --- | --- | --- | --- |");
    for (name, axis) in windows {
        let mut exact = Vec::with_capacity(w * h * axis.bins);
        for y in 0..h {
            for x in 0..w {
                exact.extend(lp.pixel_tprf(x, y, w, h, &axis));
            }
        }
        let norm = (exact.iter().map(|v| v * v).sum::<f64>() / exact.len() as f64).sqrt();
        for delay in [DelaySampling::Sampled, DelaySampling::Splat] {
            for spp in [64u64, 256, 1024] {
                let settings = RenderSettings {
                    seed: 1,
                    luminescence_delay: delay,
                    ..RenderSettings::default()
                };
                let renderer = Renderer::new(Arc::new(lp.scene()), settings);
                let mut film = TprfFilm::new(FilmLayout {
                    width: w,
                    height: h,
                    axis,
                    bounces_separate: 0,
                    luminescence: false,
                })?;
                let t = Instant::now();
                pool.install(|| {
                    progressive::render(&renderer, &mut film, &Schedule::spp(spp), |_, _| {
                        ControlFlow::Continue(())
                    })
                });
                let secs = t.elapsed().as_secs_f64();
                let mut se = 0.0;
                let mut k = 0;
                for y in 0..h {
                    for x in 0..w {
                        for v in film.pixel_tprf(x, y) {
                            se += (v - exact[k]).powi(2);
                            k += 1;
                        }
                    }
                }
                let err = (se / exact.len() as f64).sqrt() / norm;
                println!(
                    "| {name} | {delay:?} | {spp} | {err:.4} | {secs:.3} | {:.0} |",
                    1.0 / (err * err * secs)
                );
            }
        }
    }
    Ok(())
}
