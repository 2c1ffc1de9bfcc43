//! Render a scene (glTF, Mitsuba XML or `builtin:NAME`) on one thread, for `perf`
//! (docs/benchmarks.md, the race's profile and the staircase's); prints how long loading
//! the scene and building the renderer (its BVH) took:
//!
//! ```sh
//! cargo build --profile profiling -p tprf-core --example profile_render
//! perf record -e cpu-clock target/profiling/examples/profile_render SCENE [SPP WIDTH HEIGHT BINS DT_M SEED THREADS OUT.npy]
//! ```
//!
//! The time axis starts at 0 with `BINS` bins of `DT_M` metres of optical path each. With
//! `OUT.npy` the cube `[H, W, T]` is written there (to compare with numpy, as
//! `benches/race/staircase_ab.py` compares `tprf render` cubes); `THREADS` is 1 unless given.
use std::ops::ControlFlow;
use std::sync::Arc;
use std::time::Instant;
use tprf_core::film::{FilmLayout, TimeAxis, TprfFilm};
use tprf_core::transport::progressive::{self, Schedule};
use tprf_core::transport::{RenderSettings, Renderer};
use tprf_core::units::C_M_PER_S;

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let args: Vec<String> = std::env::args().collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.into());
    let t_load = Instant::now();
    let scene = tprf_core::scene::load(&arg(1, "room.gltf"))?;
    let load_s = t_load.elapsed().as_secs_f64();
    let spp: u64 = arg(2, "256").parse()?;
    let width: usize = arg(3, "64").parse()?;
    let height: usize = arg(4, "48").parse()?;
    let bins: usize = arg(5, "256").parse()?;
    let dt_m: f64 = arg(6, "0.08").parse()?;
    let seed: u64 = arg(7, "0").parse()?;
    let threads: usize = arg(8, "1").parse()?;
    let out = args.get(9).cloned();
    let t_build = Instant::now();
    let triangles = scene.triangles.len();
    let settings = RenderSettings {
        seed,
        ..RenderSettings::default()
    };
    let renderer = Renderer::new(Arc::new(scene), settings);
    eprintln!(
        "scene loaded in {load_s:.3} s ({triangles} triangles), renderer built in {:.3} s",
        t_build.elapsed().as_secs_f64()
    );
    let axis = TimeAxis::new(0.0, dt_m / C_M_PER_S, bins)?;
    let layout = FilmLayout {
        width,
        height,
        axis,
        bounces_separate: 0,
        luminescence: false,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    pool.install(|| -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        let mut film = TprfFilm::new(layout)?;
        let reports = progressive::render(&renderer, &mut film, &Schedule::spp(spp), |_, _| {
            ControlFlow::Continue(())
        });
        let last = reports.last().ok_or("no pass rendered")?;
        eprintln!(
            "{spp} spp in {:.2} s, {} rays",
            last.render_s,
            renderer.rays_traced()
        );
        if let Some(out) = &out {
            let cube = film.snapshot().dense(None);
            let shape = [height as u64, width as u64, bins as u64];
            tprf_core::export::write_npy_f32(std::path::Path::new(out), &shape, &cube)?;
        }
        Ok(())
    })?;
    Ok(())
}
