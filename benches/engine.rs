//! Engine benchmark: `cargo bench --bench engine` (a plain program, not a timed test).
//!
//! In one run, for `builtin:cornell` and for the Cornell box with its blocks replaced by a
//! displaced sphere of over a million triangles:
//!
//! - the transient render (progressive passes on the rayon pool, as `tprf render` does):
//!   paths/s and rays/s (camera, bounce and shadow rays);
//! - the same passes again with a sink that only sums (no time binning), and once more
//!   recording every ray the paths trace;
//! - the recorded rays replayed against the BVH alone: obvhs CWBVH traversal + the
//!   triangle test (`Accel::build_bvh`, `closest_hit`) on every ray, on the same pool
//!   and on one thread; and with the renderer's own tracing (its `Accel`: the blocks of a
//!   small scene, and its query kinds: closest hit for path rays, any hit for shadow
//!   rays);
//! - BVH build time and heap, and the film's memory for a 256 x 256 x 1024 cube.
//!
//! It prints markdown tables (docs/benchmarks.md keeps a copy).

use glam::Vec3;
use rayon::prelude::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::hint::black_box;
use std::ops::ControlFlow;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use std::time::Instant;
use tprf_core::accel::Accel;
use tprf_core::film::{FilmLayout, TimeAxis, TprfFilm};
use tprf_core::scene::Scene;
use tprf_core::transport::progressive::{self, Schedule};
use tprf_core::transport::sampler::Sampler;
use tprf_core::transport::{RayKind, RenderSettings, Renderer, Sink, WindowRequest, auto_window};

mod common;

use common::cornell_blob;

// ---------------------------------------------------------------------------------------
// Heap accounting: live and peak bytes of the system allocator.

struct CountingAlloc;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grew(bytes: usize) {
    let now = LIVE.fetch_add(bytes, Relaxed) + bytes;
    PEAK.fetch_max(now, Relaxed);
}

// SAFETY: every call is passed on to the system allocator unchanged; the counters only
// observe the sizes.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller keeps `GlobalAlloc`'s contract, which the system allocator has.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller keeps `GlobalAlloc`'s contract, which the system allocator has.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller keeps `GlobalAlloc`'s contract, which the system allocator has.
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Relaxed);
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller keeps `GlobalAlloc`'s contract, which the system allocator has.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            LIVE.fetch_sub(layout.size(), Relaxed);
            grew(new_size);
        }
        p
    }
}

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

/// Run `f`, returning its value, wall seconds, heap bytes it left allocated, and the peak
/// heap above the starting level while it ran.
fn measured<T>(f: impl FnOnce() -> T) -> (T, f64, isize, usize) {
    let before = LIVE.load(Relaxed);
    PEAK.store(before, Relaxed);
    let start = Instant::now();
    let value = f();
    let seconds = start.elapsed().as_secs_f64();
    let after = LIVE.load(Relaxed);
    let peak = PEAK.load(Relaxed);
    (
        value,
        seconds,
        after as isize - before as isize,
        peak.saturating_sub(before),
    )
}

/// Bytes in KiB, MiB or GiB.
fn human(bytes: f64) -> String {
    let units = [("GiB", 30), ("MiB", 20), ("KiB", 10)];
    for (unit, shift) in units {
        let v = bytes / (1u64 << shift) as f64;
        if v.abs() >= 1.0 {
            return format!("{v:.1} {unit}");
        }
    }
    format!("{bytes:.0} B")
}

// ---------------------------------------------------------------------------------------
// Scenes.

// ---------------------------------------------------------------------------------------
// Sinks for replaying the timed passes.

/// Sums what arrives (so the shading stays live) but bins nothing.
struct SumSink {
    end_s: f64,
    sum: f64,
}

impl Sink for SumSink {
    #[inline]
    fn add(&mut self, _arrival_s: f64, value: f64, _scatterings: u32) {
        self.sum += value;
    }
    fn window_end_s(&self) -> f64 {
        self.end_s
    }
}

#[derive(Clone, Copy)]
struct TracedRay {
    origin: Vec3,
    dir: Vec3,
    t_max_m: f32,
    kind: RayKind,
}

/// Records every ray.
struct RecordSink {
    end_s: f64,
    rays: Vec<TracedRay>,
}

impl Sink for RecordSink {
    fn add(&mut self, _arrival_s: f64, _value: f64, _scatterings: u32) {}
    fn window_end_s(&self) -> f64 {
        self.end_s
    }
    fn ray(&mut self, origin: Vec3, dir: Vec3, t_max_m: f32, kind: RayKind) {
        self.rays.push(TracedRay {
            origin,
            dir,
            t_max_m,
            kind,
        });
    }
}

/// Trace the samples of `passes` (pass index, spp) of a `w x h` image into one sink per
/// row, rows in parallel, with exactly the sample streams `Renderer::render_pass` uses
/// (one per film half, even and odd passes, continued from pass to pass).
/// Returns the sinks (in row order) and the rays traced.
fn replay<S: Sink + Send>(
    renderer: &Renderer,
    (w, h): (usize, usize),
    passes: &[(u64, u32)],
    new_sink: impl Fn() -> S + Sync,
) -> (Vec<S>, u64) {
    let rows: Vec<(S, u64)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut sink = new_sink();
            let mut rays = 0;
            let mut half_spp = [0u64; 2];
            for &(pass, spp) in passes {
                let half = pass % 2;
                let first = half_spp[half as usize];
                half_spp[half as usize] += spp as u64;
                for x in 0..w {
                    let mut rng = Sampler::new(renderer.settings().seed, half, (y * w + x) as u64)
                        .starting_at(first);
                    for _ in 0..spp {
                        rays += renderer.trace_sample(x, y, w, h, &mut rng, &mut sink);
                    }
                }
            }
            (sink, rays)
        })
        .collect();
    let rays = rows.iter().map(|r| r.1).sum();
    (rows.into_iter().map(|r| r.0).collect(), rays)
}

// ---------------------------------------------------------------------------------------
// Raw BVH replay.

const CHUNK: usize = 4096;

/// `Accel::closest_hit` on every ray (path and shadow rays alike, each up to its own
/// `t_max`); returns the hit count.
fn closest_all(accel: &Accel, rays: &[TracedRay]) -> usize {
    rays.iter()
        .filter(|r| accel.closest_hit(r.origin, r.dir, r.t_max_m).is_some())
        .count()
}

/// The renderer's query kinds: closest hit for path rays, any hit (the first hit blocks,
/// as for the opaque surfaces of these scenes) for shadow rays.
fn as_renderer(accel: &Accel, rays: &[TracedRay]) -> usize {
    rays.iter()
        .filter(|r| match r.kind {
            RayKind::Path => accel.closest_hit(r.origin, r.dir, r.t_max_m).is_some(),
            RayKind::Shadow => accel.any_hit(r.origin, r.dir, r.t_max_m, |_| true),
        })
        .count()
}

/// Rounds of the timed runs, each round running every kind once in turn (so a drift of
/// the machine's speed over the minutes of a case touches every kind alike); per kind
/// the fastest counts (the others absorb page faults, cache warm-up and whatever else
/// the machine was doing).
const REPEATS: usize = 3;

/// CPU seconds this process has used so far, all threads (utime + stime from
/// /proc/self/stat, in USER_HZ = 100 ticks); 0 where that is not available.
fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the command name: state is the first, utime the 12th, stime the 13th.
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .map_or("", |(_, rest)| rest)
        .split_whitespace()
        .collect();
    let ticks = |i: usize| fields.get(i).and_then(|v| v.parse::<f64>().ok());
    ticks(11)
        .zip(ticks(12))
        .map_or(0.0, |(u, s)| (u + s) / 100.0)
}

/// Wall and CPU seconds of one run.
#[derive(Clone, Copy)]
struct Timing {
    wall_s: f64,
    cpu_s: f64,
}

impl Timing {
    fn of(f: impl FnOnce()) -> Timing {
        let (cpu, start) = (cpu_s(), Instant::now());
        f();
        Timing {
            wall_s: start.elapsed().as_secs_f64(),
            cpu_s: cpu_s() - cpu,
        }
    }

    /// CPU seconds per wall second: the thread count when nothing else competes for the
    /// cores.
    fn busy(&self) -> f64 {
        self.cpu_s / self.wall_s
    }
}

/// Time `f` once, keeping the faster of that and `best`.
fn keep_fastest(best: &mut Option<Timing>, f: impl FnOnce()) {
    let t = Timing::of(f);
    if best.is_none_or(|b| t.wall_s < b.wall_s) {
        *best = Some(t);
    }
}

// ---------------------------------------------------------------------------------------

struct Case {
    label: &'static str,
    width: usize,
    height: usize,
    spp: u64,
}

struct Figures {
    label: String,
    triangles: usize,
    width: usize,
    height: usize,
    spp: u64,
    bins: usize,
    scene_s: f64,
    scene_bytes: isize,
    bvh_s: f64,
    bvh_bytes: isize,
    bvh_peak: usize,
    renderer_s: f64,
    paths: u64,
    rays: u64,
    shadow_rays: usize,
    render: Timing,
    nobin: Timing,
    record_s: f64,
    raw_pool: Timing,
    raw_one: Timing,
    raw_kinds_pool: Timing,
    hits: usize,
}

fn run_case(case: &Case, make_scene: impl FnOnce() -> Scene) -> Figures {
    let (scene, scene_s, scene_bytes, _) = measured(make_scene);
    let triangles = scene.triangles.len();
    eprintln!("{}: {triangles} triangles", case.label);

    // The CWBVH on its own, whatever the scene's size: the raw obvhs baseline.
    let (bvh, bvh_s, bvh_bytes, bvh_peak) = measured(|| Accel::build_bvh(&scene));
    let scene = Arc::new(scene);
    // Uniform samples: the replays below draw every pixel's samples of each pass, as a
    // pass without an adaptive plan does.
    let uniform = RenderSettings {
        adaptive: false,
        ..RenderSettings::default()
    };
    let (renderer, renderer_s, _, _) = measured(|| Renderer::new(scene.clone(), uniform));
    let axis = auto_window(
        &renderer,
        WindowRequest {
            bins: 256,
            ..Default::default()
        },
    )
    .expect("time window");
    let layout = FilmLayout {
        width: case.width,
        height: case.height,
        axis,
        bounces_separate: 0,
        luminescence: false,
    };
    // 1. The transient render, as `tprf render` runs it, on a fresh film each time.
    let render_once = || {
        let mut film = TprfFilm::new(layout).expect("film");
        let rays_before = renderer.rays_traced();
        let reports =
            progressive::render(&renderer, &mut film, &Schedule::spp(case.spp), |_, _| {
                ControlFlow::Continue(())
            });
        let rays = renderer.rays_traced() - rays_before;
        eprintln!(
            "  rendered in {:.2} s",
            reports.last().expect("one pass").render_s
        );
        (reports, rays)
    };
    let mut render = None;
    let mut first = None;
    keep_fastest(&mut render, || first = Some(render_once()));
    let (reports, rays) = first.expect("rendered");
    let last = *reports.last().expect("one pass");
    let mut passes = Vec::new();
    let mut spp_before = 0;
    for r in &reports {
        passes.push((r.pass, (r.spp - spp_before) as u32));
        spp_before = r.spp;
    }
    let size = (case.width, case.height);
    let end_s = axis.end_s();

    // 2. The same paths, recording their rays.
    let start = Instant::now();
    let (sinks, _) = replay(&renderer, size, &passes, || RecordSink {
        end_s,
        rays: Vec::new(),
    });
    let recorded: Vec<TracedRay> = sinks.into_iter().flat_map(|s| s.rays).collect();
    let record_s = start.elapsed().as_secs_f64();
    assert_eq!(recorded.len() as u64, rays, "recorded other rays");
    let shadow_rays = recorded
        .iter()
        .filter(|r| r.kind == RayKind::Shadow)
        .count();

    // 3. Rounds of: the render again; the same paths summed instead of binned; their
    // rays against the CWBVH alone (on the pool and on one thread), and with the
    // renderer's own tracing.
    let accel = renderer.accel();
    let (mut nobin, mut raw_pool, mut raw_one, mut raw_kinds_pool) = (None, None, None, None);
    // Closest hits among the recorded rays: counted by the first raw run, the same in all.
    let mut hits = None;
    for round in 0..REPEATS {
        if round > 0 {
            keep_fastest(&mut render, || {
                let (_, again) = render_once();
                assert_eq!(again, rays, "the render traced other rays");
            });
        }
        keep_fastest(&mut nobin, || {
            let (sinks, nobin_rays) =
                replay(&renderer, size, &passes, || SumSink { end_s, sum: 0.0 });
            black_box(sinks.iter().map(|s| s.sum).sum::<f64>());
            assert_eq!(nobin_rays, rays, "the replay traced other rays");
        });
        keep_fastest(&mut raw_pool, || {
            let n: usize = recorded
                .par_chunks(CHUNK)
                .map(|c| closest_all(&bvh, c))
                .sum();
            assert_eq!(black_box(n), *hits.get_or_insert(n));
        });
        keep_fastest(&mut raw_one, || {
            let n: usize = recorded.chunks(CHUNK).map(|c| closest_all(&bvh, c)).sum();
            assert_eq!(black_box(n), *hits.get_or_insert(n));
        });
        keep_fastest(&mut raw_kinds_pool, || {
            black_box(
                recorded
                    .par_chunks(CHUNK)
                    .map(|c| as_renderer(accel, c))
                    .sum::<usize>(),
            );
        });
    }
    let timed = "REPEATS > 0";
    let (render, nobin) = (render.expect(timed), nobin.expect(timed));
    let (raw_pool, raw_one) = (raw_pool.expect(timed), raw_one.expect(timed));
    let raw_kinds_pool = raw_kinds_pool.expect(timed);
    let hits = hits.expect(timed);

    Figures {
        label: case.label.to_string(),
        triangles,
        width: case.width,
        height: case.height,
        spp: last.spp,
        bins: axis.bins,
        scene_s,
        scene_bytes,
        bvh_s,
        bvh_bytes,
        bvh_peak,
        renderer_s,
        paths: last.paths,
        rays,
        shadow_rays,
        render,
        nobin,
        record_s,
        raw_pool,
        raw_one,
        raw_kinds_pool,
        hits,
    }
}

fn main() {
    let threads = rayon::current_num_threads();
    let load_before = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let total = Instant::now();
    let cases = [
        (
            Case {
                label: "builtin:cornell",
                width: 256,
                height: 256,
                spp: 32,
            },
            None,
        ),
        (
            Case {
                label: "cornell + blob",
                width: 256,
                height: 256,
                spp: 32,
            },
            Some((512, 1024)),
        ),
    ];
    let figures: Vec<Figures> = cases
        .iter()
        .map(|(case, blob)| match blob {
            None => run_case(case, || {
                tprf_core::scene::load("builtin:cornell").expect("builtin:cornell")
            }),
            Some((lat, lon)) => run_case(case, || cornell_blob(*lat, *lon)),
        })
        .collect();

    // Film memory of a typical cube: computed, and allocated (without per-bounce layers).
    let cube = |bounces_separate| FilmLayout {
        width: 256,
        height: 256,
        axis: TimeAxis::new(0.0, 1e-11, 1024).expect("axis"),
        bounces_separate,
        luminescence: false,
    };
    let (film, film_s, film_bytes, _) = measured(|| TprfFilm::new(cube(0)).expect("film"));
    drop(black_box(film));

    println!(
        "{threads} rayon threads; load average before the run: {}.\n",
        load_before
            .split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    println!("## Render throughput\n");
    println!(
        "Default settings (max 1024 bounces, Russian roulette from bounce 3, NEE), a \
         256-bin time window chosen by the pilot render, progressive passes as `tprf \
         render` runs them; fastest of {REPEATS} runs, each kind of run below once per round \
         in turn.\n"
    );
    println!(
        "| scene | triangles | image x spp | bins | paths | rays (shadow) | rays/path | render s | paths/s | rays/s |"
    );
    println!("|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|");
    for f in &figures {
        println!(
            "| {} | {} | {}x{} x {} | {} | {} | {} ({:.0} %) | {:.2} | {:.2} | {:.0} k | {:.2} M |",
            f.label,
            f.triangles,
            f.width,
            f.height,
            f.spp,
            f.bins,
            f.paths,
            f.rays,
            100.0 * f.shadow_rays as f64 / f.rays as f64,
            f.rays as f64 / f.paths as f64,
            f.render.wall_s,
            f.paths as f64 / f.render.wall_s / 1e3,
            f.rays as f64 / f.render.wall_s / 1e6,
        );
    }

    println!("\n## The renderer's rays against the BVH alone\n");
    println!(
        "Mrays/s. The renderer's rays are recorded by replaying its passes, then traced \
         again in chunks of {CHUNK} rays in recorded order: *raw obvhs closest-hit* with \
         the CWBVH (`Accel::build_bvh`: obvhs traversal + Moller-Trumbore) whatever the \
         scene's size; *renderer's own tracing* with the renderer's `Accel` (eight \
         triangles at a time, without a BVH, for scenes of at most {} triangles) and its \
         query kinds (any hit for shadow rays). *per wall s*: rays over the run's wall \
         time; *per CPU s*: over the CPU time the process used (all threads), which holds \
         up when other programs share the cores.\n",
        tprf_core::accel::SMALL_SCENE_TRIANGLES
    );
    println!(
        "| scene | per | renderer | renderer, no binning | raw obvhs closest-hit, {threads} threads | raw obvhs closest-hit, 1 thread | renderer's own tracing, {threads} threads | renderer : raw obvhs closest-hit | ray hits |"
    );
    println!("|---|---|--:|--:|--:|--:|--:|--:|--:|");
    for f in &figures {
        let r = f.rays as f64;
        let wall = |t: &Timing| t.wall_s;
        let cpu = |t: &Timing| t.cpu_s;
        for (per, secs) in [
            ("wall s", &wall as &dyn Fn(&Timing) -> f64),
            ("CPU s", &cpu),
        ] {
            println!(
                "| {} | {per} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | 1 : {:.2} | {:.0} % |",
                f.label,
                r / secs(&f.render) / 1e6,
                r / secs(&f.nobin) / 1e6,
                r / secs(&f.raw_pool) / 1e6,
                r / secs(&f.raw_one) / 1e6,
                r / secs(&f.raw_kinds_pool) / 1e6,
                secs(&f.render) / secs(&f.raw_pool),
                100.0 * f.hits as f64 / r,
            );
        }
    }

    println!("\n## Where the render time goes\n");
    println!(
        "Shares of the render's CPU time: tracing = the same rays with the renderer's own \
         tracing alone; binning = render minus the no-binning replay; the rest is \
         sampling, shading, NEE and bookkeeping.\n"
    );
    println!("| scene | tracing | time binning | sampling, shading, rest |");
    println!("|---|--:|--:|--:|");
    for f in &figures {
        let tracing = f.raw_kinds_pool.cpu_s / f.render.cpu_s;
        let binning = (f.render.cpu_s - f.nobin.cpu_s) / f.render.cpu_s;
        println!(
            "| {} | {:.0} % | {:.0} % | {:.0} % |",
            f.label,
            100.0 * tracing,
            100.0 * binning,
            100.0 * (1.0 - tracing - binning)
        );
    }

    println!("\n## Self-check: CPU seconds per wall second\n");
    println!(
        "{threads} on the pool (1 for the one-thread run) when nothing else ran on the \
         machine; less means the timed run shared the cores.\n"
    );
    println!("| scene | render | no binning | raw, pool | raw, 1 thread | own tracing, pool |");
    println!("|---|--:|--:|--:|--:|--:|");
    for f in &figures {
        println!(
            "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
            f.label,
            f.render.busy(),
            f.nobin.busy(),
            f.raw_pool.busy(),
            f.raw_one.busy(),
            f.raw_kinds_pool.busy(),
        );
    }

    println!("\n## Scene and BVH\n");
    println!(
        "| scene | triangles | scene built in | scene heap | CWBVH build | CWBVH heap (B/triangle) | CWBVH build peak heap | Renderer::new |"
    );
    println!("|---|--:|--:|--:|--:|--:|--:|--:|");
    for f in &figures {
        println!(
            "| {} | {} | {:.1} ms | {} | {:.1} ms | {} ({:.0}) | {} | {:.1} ms |",
            f.label,
            f.triangles,
            1e3 * f.scene_s,
            human(f.scene_bytes as f64),
            1e3 * f.bvh_s,
            human(f.bvh_bytes as f64),
            f.bvh_bytes as f64 / f.triangles as f64,
            human(f.bvh_peak as f64),
            1e3 * f.renderer_s,
        );
    }

    println!("\n## Film memory\n");
    println!(
        "Two f64 halves per bin (for the error estimate), plus one f64 per bin per \
         per-bounce layer when asked for (`--bounces-separate K`: K + 2 layers).\n"
    );
    println!(
        "| cube | bounce layers | FilmLayout::bytes | bytes per pixel per bin | allocated and zeroed |"
    );
    println!("|---|--:|--:|--:|--:|");
    for k in [0, 4] {
        let layout = cube(k);
        let cells = (layout.pixels() * layout.axis.bins) as f64;
        let allocated = if k == 0 {
            format!("{} in {film_s:.2} s", human(film_bytes as f64))
        } else {
            "not allocated".into()
        };
        println!(
            "| {}x{}x{} | {} | {} | {:.0} | {allocated} |",
            layout.width,
            layout.height,
            layout.axis.bins,
            layout.bounce_layers(),
            human(layout.dense_bytes() as f64),
            layout.dense_bytes() as f64 / cells,
        );
    }
    let record_s: f64 = figures.iter().map(|f| f.record_s).sum();
    println!(
        "\nBenchmark wall time {:.0} s (recording the rays: {:.1} s).",
        total.elapsed().as_secs_f64(),
        record_s
    );
}
