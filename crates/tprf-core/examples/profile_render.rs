//! Render a glTF scene on one thread, for `perf` (docs/benchmarks.md, the race's profile):
//!
//! ```sh
//! cargo build --profile profiling -p tprf-core --example profile_render
//! perf record -e cpu-clock target/profiling/examples/profile_render SCENE.gltf [SPP WIDTH HEIGHT BINS DT_M]
//! ```
//!
//! The time axis starts at 0 with `BINS` bins of `DT_M` metres of optical path each.
use std::ops::ControlFlow;
use std::path::Path;
use std::sync::Arc;
use tprf_core::film::{FilmLayout, TimeAxis, TprfFilm};
use tprf_core::scene::gltf_load::load_gltf;
use tprf_core::transport::progressive::{self, Schedule};
use tprf_core::transport::{RenderSettings, Renderer};
use tprf_core::units::C_M_PER_S;

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let args: Vec<String> = std::env::args().collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.into());
    let scene = load_gltf(Path::new(&arg(1, "room.gltf")))?;
    let spp: u64 = arg(2, "256").parse()?;
    let width: usize = arg(3, "64").parse()?;
    let height: usize = arg(4, "48").parse()?;
    let bins: usize = arg(5, "256").parse()?;
    let dt_m: f64 = arg(6, "0.08").parse()?;
    let renderer = Renderer::new(Arc::new(scene), RenderSettings::default());
    let axis = TimeAxis::new(0.0, dt_m / C_M_PER_S, bins)?;
    let layout = FilmLayout {
        width,
        height,
        axis,
        bounces_separate: 0,
    };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
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
        Ok(())
    })?;
    Ok(())
}
