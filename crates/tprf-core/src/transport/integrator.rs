//! The path integrator: one camera path per sample, next-event estimation to punctual
//! and area lights with MIS, Russian roulette, and every contribution delivered with its
//! arrival time and scattering count.

use super::bsdf::{Bsdf, Frame, LobeKind};
use super::carried::{Carried, Contribution, Intensity};
use super::connect::{EyeVertex, LazyLightVertex, connected_weight};
use super::lights::Lights;
use super::luminescence::{self, Choice, Decay, DelaySampling};
use super::media::Media;
use super::sampler::{Sampler, dim};
use super::split::Strategy;
use super::surface::{SurfacePoint, Surfaces};
use crate::accel::Accel;
use crate::film::{
    LeftOut, LeftOutCounts, PixelSink, RE_EMITTED, TimeAxis, TprfFilm, scattering_count,
};
use crate::scene::{Camera, Channel, PulseOrigin, Scene, TimeOrigin};
use crate::units::C_M_PER_S;
use glam::Vec3;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};

/// Where a path's contributions go.
pub trait Sink {
    /// One contribution: radiance `value` (W / (m^2 sr) per unit pulse energy, already
    /// divided by the path's pdf) arriving at `arrival_s` after `scatterings` events,
    /// with [`RE_EMITTED`] set in it when a luminescent surface re-emitted the path
    /// ([`scattering_count`] gives the count alone).
    fn add(&mut self, arrival_s: f64, value: f64, scatterings: u32);
    /// One polarized contribution: the Stokes vector `stokes` (S0..S3 in the camera's
    /// frame, unit of [`Sink::add`]'s `value`). A sink that keeps intensity only takes
    /// `S0` (the default).
    #[inline(always)]
    fn add_stokes(&mut self, arrival_s: f64, stokes: [f64; 4], scatterings: u32) {
        self.add(arrival_s, stokes[0], scatterings);
    }
    /// Latest arrival time that still counts, seconds.
    fn window_end_s(&self) -> f64;
    /// Earliest arrival time that counts, seconds: a contribution arriving before it is
    /// not recorded, so its shadow ray is not traced.
    fn window_start_s(&self) -> f64 {
        f64::NEG_INFINITY
    }
    /// Work left out because its light could not arrive inside the window: called once
    /// per shadow ray not traced or path ended. Does nothing by default.
    #[inline(always)]
    fn left_out(&mut self, _why: LeftOut) {}
    /// A ray about to be traced: from `origin` along unit `dir` up to `t_max_m` metres
    /// (infinite for path rays). Does nothing by default (and then costs nothing); the
    /// engine benchmark records the rays to replay them against the BVH alone.
    #[inline(always)]
    fn ray(&mut self, _origin: Vec3, _dir: Vec3, _t_max_m: f32, _kind: RayKind) {}
    /// The bins contributions land in, when the sink is a film's: lets a luminescent
    /// vertex deposit its decay's integral per bin ([`super::DelaySampling::Splat`]).
    /// `None` by default.
    #[inline(always)]
    fn time_axis(&self) -> Option<TimeAxis> {
        None
    }
}

/// `inner` with the contributions of fewer than `min` scattering events left out
/// ([`RenderSettings::min_bounces`]).
struct FromBounce<'a, S> {
    inner: &'a mut S,
    min: u32,
}

impl<S: Sink> Sink for FromBounce<'_, S> {
    #[inline]
    fn add(&mut self, arrival_s: f64, value: f64, scatterings: u32) {
        if scattering_count(scatterings) >= self.min {
            self.inner.add(arrival_s, value, scatterings);
        }
    }
    #[inline]
    fn add_stokes(&mut self, arrival_s: f64, stokes: [f64; 4], scatterings: u32) {
        if scattering_count(scatterings) >= self.min {
            self.inner.add_stokes(arrival_s, stokes, scatterings);
        }
    }
    #[inline]
    fn window_end_s(&self) -> f64 {
        self.inner.window_end_s()
    }
    #[inline]
    fn window_start_s(&self) -> f64 {
        self.inner.window_start_s()
    }
    #[inline(always)]
    fn left_out(&mut self, why: LeftOut) {
        self.inner.left_out(why);
    }
    #[inline(always)]
    fn ray(&mut self, origin: Vec3, dir: Vec3, t_max_m: f32, kind: RayKind) {
        self.inner.ray(origin, dir, t_max_m, kind);
    }
    #[inline(always)]
    fn time_axis(&self) -> Option<TimeAxis> {
        self.inner.time_axis()
    }
}

/// `inner` with every contribution spread over the later bins by `decay`
/// ([`Decay::splat`]: [`DelaySampling::Splat`]); where `inner` has no time axis, delayed by `fallback_delay_s`
/// and weighted by `fallback_weight` (a delay drawn for the window) instead.
struct Splat<'a, S> {
    inner: &'a mut S,
    decay: &'a Decay,
    fallback_delay_s: f64,
    fallback_weight: f64,
}

impl<S: Sink> Sink for Splat<'_, S> {
    fn add(&mut self, arrival_s: f64, value: f64, scatterings: u32) {
        match self.inner.time_axis() {
            Some(axis) => {
                let inner = &mut *self.inner;
                self.decay.splat(&axis, arrival_s, value, |t, v| {
                    inner.add(t, v, scatterings);
                });
            }
            None => self.inner.add(
                arrival_s + self.fallback_delay_s,
                value * self.fallback_weight,
                scatterings,
            ),
        }
    }
    fn window_end_s(&self) -> f64 {
        self.inner.window_end_s()
    }
    // Light arriving before the window may be re-emitted into it.
    fn window_start_s(&self) -> f64 {
        f64::NEG_INFINITY
    }
    fn left_out(&mut self, why: LeftOut) {
        self.inner.left_out(why);
    }
    fn ray(&mut self, origin: Vec3, dir: Vec3, t_max_m: f32, kind: RayKind) {
        self.inner.ray(origin, dir, t_max_m, kind);
    }
    fn time_axis(&self) -> Option<TimeAxis> {
        None
    }
}

/// Hand `c` to `sink`: an intensity to [`Sink::add`], a Stokes vector to
/// [`Sink::add_stokes`].
#[inline(always)]
fn deliver(sink: &mut impl Sink, arrival_s: f64, c: Contribution, scatterings: u32) {
    match c {
        Contribution::Intensity(value) => sink.add(arrival_s, value, scatterings),
        Contribution::Stokes(stokes) => sink.add_stokes(arrival_s, stokes, scatterings),
    }
}

/// What a traced ray is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    /// A camera or bounce ray: closest hit.
    Path,
    /// A shadow ray to a light: any hit along a segment.
    Shadow,
}

impl Sink for PixelSink<'_> {
    #[inline]
    fn add(&mut self, arrival_s: f64, value: f64, scatterings: u32) {
        PixelSink::add(self, arrival_s, value, scatterings);
    }
    #[inline]
    fn window_end_s(&self) -> f64 {
        PixelSink::window_end_s(self)
    }
    #[inline]
    fn window_start_s(&self) -> f64 {
        PixelSink::window_start_s(self)
    }
    #[inline]
    fn left_out(&mut self, why: LeftOut) {
        PixelSink::left_out(self, why);
    }
    #[inline]
    fn time_axis(&self) -> Option<TimeAxis> {
        Some(self.axis())
    }
}

/// Settings of the path tracer (the film's shape lives in the film).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Largest number of scattering events on a path.
    pub max_bounces: u32,
    /// Fewest scattering events of a recorded path: contributions after fewer are left
    /// out of the film (0, the default: every path; 2: no direct reflection; 3 in an
    /// NLOS view: no light from the relay wall straight to the wall). Paths are traced
    /// as before; only what reaches the film changes.
    pub min_bounces: u32,
    pub seed: u64,
    pub channel: Channel,
    /// Next-event estimation (shadow rays to lights). Off: lights are reached only by
    /// hitting emissive surfaces (punctual lights then contribute nothing).
    pub nee: bool,
    /// Scattering events before Russian roulette starts (in scenes with media, a few
    /// more: `MEDIA_RR_DELAY` in transport/media/walk.rs).
    pub rr_start: u32,
    /// Smallest survival probability of Russian roulette. 0 (the default): a path
    /// survives with its throughput capped at 1; 1: no roulette (paths end only at
    /// `max_bounces` or the window's end). A floor between trades time for less
    /// roulette noise; every value is unbiased.
    pub rr_min_survival: f32,
    /// Branches of a camera sample at its first scattering vertex: the camera ray, the
    /// first hit and its next-event estimate are shared, and `splits` independent
    /// continuations (bounce direction and everything after) each carry `1 / splits`
    /// of the sample. 1: no splitting; 0 (the default): chosen per render by a pilot
    /// for the least work times variance ([`super::split`]). Unbiased for every value.
    pub first_bounce_splits: u32,
    /// Join every eye vertex to a light vertex found from a punctual light, one per
    /// camera sample (MIS against BSDF sampling, `connect`). Off: paths to
    /// punctual lights are found by the path tracer alone. `None` (the default): chosen
    /// per render by the pilot, with the split. Unbiased either way.
    pub light_vertex: Option<bool>,
    /// Adaptive sampling: from the film's fourth sample per half on, where the film's
    /// noise is uneven enough for it to pay, each pass gives a pixel samples in
    /// proportion to its measured noise over the square root of its cost
    /// ([`super::adaptive`]). Off: every pixel draws every pass's samples. Unbiased
    /// either way.
    pub adaptive: bool,
    /// Where a camera path's clock starts (the pinhole, the near plane, or the first
    /// surface the camera ray meets): see [`TimeOrigin`].
    pub time_origin: TimeOrigin,
    /// When the pulse starts: as it leaves the light, or at the first surface it lights
    /// (the leg from the light left out of every arrival time): see [`PulseOrigin`].
    pub pulse_origin: PulseOrigin,
    /// How a luminescent vertex's delay reaches the film: its decay's integral deposited
    /// per bin (the default) or drawn ([`DelaySampling`]).
    pub luminescence_delay: DelaySampling,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            max_bounces: 1024,
            min_bounces: 0,
            seed: 0,
            channel: Channel::Gray,
            nee: true,
            rr_start: 3,
            rr_min_survival: 0.0,
            first_bounce_splits: 0,
            light_vertex: None,
            adaptive: true,
            time_origin: TimeOrigin::Pinhole,
            pulse_origin: PulseOrigin::Light,
            luminescence_delay: DelaySampling::Splat,
        }
    }
}

/// Work done by one pass.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PassStats {
    pub paths: u64,
    pub rays: u64,
    /// Mean per pixel of what arrived outside the time window.
    pub outside_per_pixel: f64,
    /// Shadow rays not traced and paths ended: their light could not reach the window.
    pub left_out: LeftOutCounts,
}

/// Largest number of straight pass-throughs (alpha coverage) along one segment chain.
const MAX_PASS_THROUGH: u32 = 1024;

/// The scene prepared for transport, seen from one camera. Immutable once built; shared
/// by all threads. The prepared scene (surfaces, BVH, lights, media) is shared with the
/// renderers [`Renderer::with_camera`] makes from it: a new camera needs no new BVH.
pub struct Renderer {
    surfaces: Arc<Surfaces>,
    accel: Arc<Accel>,
    lights: Arc<Lights>,
    settings: RenderSettings,
    /// The camera rendered: the scene's own ([`Renderer::new`]) or another
    /// ([`Renderer::seen_from`]).
    camera: Camera,
    /// Ray-offset length scale: 1e-6 of the scene's bounding diagonal (the camera
    /// rendered counted in the bounds), metres.
    eps_m: f32,
    /// Tangent of half the camera's field of view along its axis.
    tan_half_fov: f32,
    rays: AtomicU64,
    /// The sampling strategy in use: the settings', or the pilot's choice for the first
    /// film rendered ([`Renderer::strategy_for`]).
    strategy: OnceLock<Strategy>,
    /// The scene's participating media; `None` for a scene in vacuum, which the surface
    /// loop renders ([`super::media`] renders the others).
    media: Option<Arc<Media>>,
}

/// Whether a contribution arriving at `arrival_s` falls clearly outside `sink`'s window
/// (strictly: an arrival on the edge is left to the film to bin), and on which side.
#[inline]
pub(super) fn outside(sink: &impl Sink, arrival_s: f64) -> Option<LeftOut> {
    if arrival_s > sink.window_end_s() {
        Some(LeftOut::ShadowRayLate)
    } else if arrival_s < sink.window_start_s() {
        Some(LeftOut::ShadowRayEarly)
    } else {
        None
    }
}

/// The state of a path between two vertices; `C` what it carries beside its scalar
/// throughput ([`super::carried`]).
#[derive(Clone, Copy, Debug)]
struct Path<C> {
    /// The ray about to be traced (unit `dir`).
    origin: Vec3,
    dir: Vec3,
    /// Product of the BSDF sample weights and roulette factors so far.
    throughput: f32,
    /// Share of the camera sample this path carries: `1 / splits` after a split, else 1.
    share: f32,
    /// Eye-side optical path length, metres.
    opl_m: f64,
    /// `opl_m` at the last scattering vertex (the camera's start before the first):
    /// where a light found along this ray is timed from with [`PulseOrigin::FirstHit`].
    vertex_opl_m: f64,
    scatterings: u32,
    /// [`RE_EMITTED`] once a luminescent surface re-emitted the path, else 0: marks
    /// its later contributions for the film's luminescence layer.
    tag: u32,
    /// Refractive index of the medium the ray travels in.
    ior_here: f32,
    /// Solid-angle pdf of the last BSDF sample; `None` for the camera ray and delta lobes.
    last_pdf: Option<f32>,
    last_position: Vec3,
    /// Straight pass-throughs (alpha coverage) since the last scattering.
    pass_throughs: u32,
    /// The camera ray's first surface is still ahead and its distance is not counted
    /// ([`TimeOrigin::FirstHit`]).
    unwarp: bool,
    /// When the last vertex was joined to a light vertex and this ray is its BSDF
    /// sample: that sample's solid-angle pdf times the BSDF samples leaving the vertex
    /// (for the MIS weight of next-event estimation at the next vertex); else 0.
    connected_pdf: f32,
    /// Its polarization, in a polarized render; nothing otherwise.
    pol: C,
}

impl<C: Carried> Path<C> {
    /// A path leaving the eye at `origin` along unit `dir`, carrying `pol`.
    fn camera(origin: Vec3, dir: Vec3, pol: C) -> Path<C> {
        Path {
            origin,
            dir,
            throughput: 1.0,
            share: 1.0,
            opl_m: 0.0,
            vertex_opl_m: 0.0,
            scatterings: 0,
            tag: 0,
            ior_here: 1.0,
            last_pdf: None,
            last_position: origin,
            pass_throughs: 0,
            connected_pdf: 0.0,
            unwarp: false,
            pol,
        }
    }
}

/// Power heuristic (beta = 2) weight of strategy `a` against `b`.
#[inline]
pub(super) fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

impl Renderer {
    /// Build the BVH and light tables; the scene's own camera.
    pub fn new(scene: Arc<Scene>, settings: RenderSettings) -> Renderer {
        let camera = scene.camera;
        Renderer::seen_from(scene, camera, settings)
    }

    /// Build the BVH and light tables; `camera` rendered instead of the scene's (the
    /// same as [`Renderer::new`] on the scene with `camera` in it, without a copy of
    /// the scene).
    pub fn seen_from(scene: Arc<Scene>, camera: Camera, settings: RenderSettings) -> Renderer {
        let accel = Arc::new(Accel::build(&scene));
        let lights = Arc::new(Lights::new(&scene, settings.channel));
        let media = Media::new(&scene, settings.channel).map(Arc::new);
        let surfaces = Arc::new(Surfaces::new(scene, settings.channel));
        Renderer {
            eps_m: Renderer::eps_m(surfaces.scene(), &camera),
            tan_half_fov: (0.5 * camera.fov_rad).tan(),
            camera,
            surfaces,
            accel,
            lights,
            settings,
            rays: AtomicU64::new(0),
            strategy: OnceLock::new(),
            media,
        }
    }

    /// This prepared scene seen from `camera`: the BVH, lights and media shared, the
    /// ray count at zero and the sampling strategy chosen again by its first film. The
    /// same renderer as [`Renderer::seen_from`] with `camera` (every pixel the same,
    /// bit for bit), without loading or building anything.
    pub fn with_camera(&self, camera: Camera) -> Renderer {
        Renderer {
            eps_m: Renderer::eps_m(self.scene(), &camera),
            tan_half_fov: (0.5 * camera.fov_rad).tan(),
            camera,
            surfaces: self.surfaces.clone(),
            accel: self.accel.clone(),
            lights: self.lights.clone(),
            settings: self.settings,
            rays: AtomicU64::new(0),
            strategy: OnceLock::new(),
            media: self.media.clone(),
        }
    }

    /// This renderer with its media emptied (`Media::without_extinction`): the same
    /// surfaces, lights and camera, light crossing each medium at its index without
    /// scattering or attenuation. `None` for a scene without media.
    pub fn without_extinction(&self) -> Option<Renderer> {
        let media = self.media.as_ref()?;
        Some(Renderer {
            media: Some(Arc::new(media.without_extinction())),
            ..self.with_camera(self.camera)
        })
    }

    /// Whether a path at surface point `sp` of `triangle` (after `scatterings` events, at
    /// `opl_m`) reflects or is re-emitted later ([`luminescence::choose`], the window
    /// being `sink`'s); `None` when the material there is not luminescent (no number
    /// drawn). The surface and the media loops both ask it.
    #[allow(
        clippy::too_many_arguments,
        reason = "the vertex and its path's state, as the walks hold them"
    )]
    #[inline]
    pub(super) fn luminescent_choice<S: Sink + ?Sized>(
        &self,
        lights: &Lights,
        triangle: u32,
        sp: &SurfacePoint,
        opl_m: f64,
        scatterings: u32,
        rng: &Sampler,
        sink: &S,
    ) -> Option<Choice<'_>> {
        if !self.surfaces.any_luminescent() {
            return None;
        }
        let lum = self.surfaces.luminescence(triangle, sp.front)?;
        Some(luminescence::choose(
            lum,
            opl_m,
            luminescence::nearest_light_s(lights, sp.position),
            scatterings,
            rng,
            sink.window_start_s(),
            sink.window_end_s(),
        ))
    }

    /// Ray-offset length scale, metres: 1e-6 of the diagonal of the bounds of the
    /// scene's triangles and lights and `camera`'s position (1e-6 for an empty or
    /// non-finite scene).
    fn eps_m(scene: &Scene, camera: &Camera) -> f32 {
        let diag = scene.bounds_with_eye(camera.position()).diagonal_m();
        if diag.is_finite() && diag > 0.0 {
            diag * 1e-6
        } else {
            1e-6
        }
    }

    /// The camera rendered (the scene's own camera is [`Renderer::scene`]'s).
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Whether the scene has participating media (rendered by [`super::media`]).
    pub fn has_media(&self) -> bool {
        self.media.is_some()
    }

    /// The scene-wide medium's extinction per metre and refractive index in the band
    /// rendered, when it is homogeneous; `None` without media or with a density grid.
    pub fn scene_extinction(&self) -> Option<(f32, f32)> {
        let m = self.media.as_ref()?.scene;
        m.grid.is_none().then_some((m.sigma_t, m.n))
    }

    pub(super) fn lights(&self) -> &Lights {
        &self.lights
    }

    /// The scene prepared (its camera the scene's own: the one rendered is
    /// [`Renderer::camera`]).
    pub fn scene(&self) -> &Scene {
        self.surfaces.scene()
    }

    /// The scene prepared, shared.
    pub fn scene_shared(&self) -> &Arc<Scene> {
        self.surfaces.scene()
    }

    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    pub fn accel(&self) -> &Accel {
        &self.accel
    }

    pub(super) fn surfaces(&self) -> &Surfaces {
        &self.surfaces
    }

    /// Whether a material of the scene re-emits light in this band (a luminescent
    /// surface): a film of its render with bounce layers gets a luminescence layer.
    pub fn is_luminescent(&self) -> bool {
        self.surfaces.any_luminescent()
    }

    /// The sampling strategy of this render: the settings' first-bounce split and
    /// light-vertex choice, with what they leave automatic chosen by the pilot for a
    /// `width x height` film on `axis` ([`super::split`]), once (the first film rendered
    /// decides for the renderer's life, so every pass and thread uses the same).
    pub fn strategy_for(&self, axis: &TimeAxis, width: usize, height: usize) -> Strategy {
        *self.strategy.get_or_init(|| match self.media {
            // The media loop has neither splits nor light vertices.
            Some(_) => Strategy::PLAIN,
            None => super::split::choose(self, axis, width, height),
        })
    }

    /// The strategy in use: as chosen by [`Renderer::strategy_for`], else the settings'
    /// (no split and light vertices on where automatic and not chosen yet).
    pub fn strategy(&self) -> Strategy {
        self.strategy.get().copied().unwrap_or(match self.media {
            Some(_) => Strategy::PLAIN,
            None => Strategy {
                splits: self.settings.first_bounce_splits.max(1),
                light_vertex: self.settings.light_vertex.unwrap_or(true),
            },
        })
    }

    /// Whether the scene has pulsed punctual lights (what light vertices start from).
    pub(super) fn has_punctual_lights(&self) -> bool {
        !self.lights.punctual.is_empty()
    }

    /// The optical length, metres, that the leg from a light to the first surface it
    /// lights adds to an arrival: `leg_opl_m` as it is, or none when the pulse starts at
    /// that surface ([`PulseOrigin::FirstHit`]).
    #[inline]
    pub(super) fn light_leg_opl_m(&self, leg_opl_m: f64) -> f64 {
        match self.settings.pulse_origin {
            PulseOrigin::Light => leg_opl_m,
            PulseOrigin::FirstHit => 0.0,
        }
    }

    /// Whether a pulsed punctual light is a projector.
    pub(super) fn has_projectors(&self) -> bool {
        self.lights.punctual.iter().any(|l| l.is_projector())
    }

    /// Rays traced so far (camera, bounce and shadow rays).
    pub fn rays_traced(&self) -> u64 {
        self.rays.load(Ordering::Relaxed)
    }

    /// Offset of a new ray origin from `p`, metres: scene-relative plus a few ulps of
    /// the coordinates, so a scene scaled by s gets offsets scaled by s.
    #[inline]
    pub(super) fn offset_m(&self, p: Vec3) -> f32 {
        self.eps_m + p.abs().max_element() * 4.0 * f32::EPSILON
    }

    /// Unit direction through image point `(px, py)` (pixels, row 0 = top) for a
    /// `width x height` image (the field of view kept along the camera's axis).
    pub fn camera_ray(&self, px: f32, py: f32, width: usize, height: usize) -> (Vec3, Vec3) {
        let cam = &self.camera;
        let aspect = width as f32 / height.max(1) as f32;
        let (_, tan_half) = cam.fov_axis.tan_halves(self.tan_half_fov, aspect);
        let sx = (2.0 * px / width as f32 - 1.0) * tan_half * aspect;
        let sy = (1.0 - 2.0 * py / height as f32) * tan_half;
        let dir = cam
            .world_from_camera
            .transform_vector3(Vec3::new(sx, sy, -1.0))
            .normalize();
        (cam.position(), dir)
    }

    /// One pass: `spp` samples per pixel on average into `film` (each pixel's share
    /// planned from the film's noise when [`RenderSettings::adaptive`]), rows in parallel
    /// on the current rayon pool. Each half of the film (even and odd passes) has its own
    /// sample stream per pixel, and a pass continues it: sample `i` of a pixel's half
    /// depends only on (seed, half, pixel, i), not on pass sizes or threads, and the
    /// halves stay independent estimates.
    pub fn render_pass(&self, film: &mut TprfFilm, spp: u32) -> PassStats {
        let layout = *film.layout();
        let (w, h) = (layout.width, layout.height);
        let half = film.passes() % 2;
        let strategy = self.strategy_for(&layout.axis, w, h);
        let plan = if self.settings.adaptive {
            super::adaptive::plan(film, spp)
        } else {
            None
        };
        let tally = film.run_pass_planned(spp, plan.as_deref(), |x, y, pass, sink| {
            let mut rng = Sampler::new(self.settings.seed, half, (y * w + x) as u64)
                .starting_at(pass.first as u64);
            let mut rays = 0u64;
            for _ in 0..pass.samples {
                rays += self.trace_sample_with(x, y, w, h, strategy, &mut rng, sink);
            }
            rays
        });
        // Counted once a pass: an atomic add per pixel made the threads take turns
        // owning the counter's cache line.
        self.rays.fetch_add(tally.work, Ordering::Relaxed);
        let paths = match &plan {
            Some(p) => p.iter().map(|&n| n as u64).sum(),
            None => (w * film.rows_rendered()) as u64 * spp as u64,
        };
        PassStats {
            paths,
            rays: tally.work,
            outside_per_pixel: tally.outside_per_pixel,
            left_out: tally.left_out,
        }
    }

    /// Count `rays` traced by a pass made outside [`Renderer::render_pass`] (a polarized
    /// pass).
    pub(super) fn count_rays(&self, rays: u64) {
        self.rays.fetch_add(rays, Ordering::Relaxed);
    }

    /// Trace the next sample of `rng` through pixel `(x, y)` (jittered); returns the rays
    /// traced.
    pub fn trace_sample(
        &self,
        x: usize,
        y: usize,
        w: usize,
        h: usize,
        rng: &mut Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        self.trace_sample_with(x, y, w, h, self.strategy(), rng, sink)
    }

    /// [`Renderer::trace_sample`] with `strategy`.
    #[allow(
        clippy::too_many_arguments,
        reason = "the path walk's per-vertex state, passed by value on the hot path"
    )]
    pub(super) fn trace_sample_with(
        &self,
        x: usize,
        y: usize,
        w: usize,
        h: usize,
        strategy: Strategy,
        rng: &mut Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        self.trace_sample_carrying::<Intensity>(x, y, w, h, strategy, rng, sink)
    }

    /// [`Renderer::trace_sample_with`], the path carrying `C` ([`super::carried`]).
    #[allow(
        clippy::too_many_arguments,
        reason = "the path walk's per-vertex state, passed by value on the hot path"
    )]
    #[inline(always)]
    pub(super) fn trace_sample_carrying<C: Carried>(
        &self,
        x: usize,
        y: usize,
        w: usize,
        h: usize,
        strategy: Strategy,
        rng: &mut Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        if self.settings.min_bounces > 0 {
            let mut sink = FromBounce {
                inner: sink,
                min: self.settings.min_bounces,
            };
            return self.trace_camera_sample::<C>(x, y, w, h, strategy, rng, &mut sink);
        }
        self.trace_camera_sample::<C>(x, y, w, h, strategy, rng, sink)
    }

    /// [`Renderer::trace_sample_with`], every contribution to `sink`.
    #[allow(
        clippy::too_many_arguments,
        reason = "the path walk's per-vertex state, passed by value on the hot path"
    )]
    fn trace_camera_sample<C: Carried>(
        &self,
        x: usize,
        y: usize,
        w: usize,
        h: usize,
        strategy: Strategy,
        rng: &mut Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        rng.start_sample();
        let (jx, jy) = rng.get2(dim::CAMERA);
        let (origin, dir) = self.camera_ray(x as f32 + jx, y as f32 + jy, w, h);
        // The optical path already behind the pinhole (the time origin's offset).
        let start_opl_m = self.camera.start_opl_m(self.settings.time_origin, dir);
        if let Some(media) = &self.media {
            return self.walk_media(media, origin, dir, start_opl_m, rng, sink);
        }
        let up = || self.camera.world_from_camera.transform_vector3(Vec3::Y);
        let pol = if C::POLARIZED {
            C::at_camera(dir, up())
        } else {
            C::at_camera(dir, Vec3::Y)
        };
        let mut path = Path::camera(origin, dir, pol);
        match start_opl_m {
            Some(opl_m) => (path.opl_m, path.vertex_opl_m) = (opl_m, opl_m),
            None => path.unwarp = true,
        }
        self.walk::<false, C>(&self.lights, path, strategy, None, rng, sink)
    }

    /// Trace a path from the eye at `origin` along unit `dir`. The eye-side optical path
    /// length `opl_m` (sum of `n_i d_i`, metres, f64) grows along the path; a contribution
    /// reaching the eye through vertex k arrives at `(opl_m + n d(vertex, light)) / c`.
    /// Returns the rays traced.
    pub fn trace_path(
        &self,
        origin: Vec3,
        dir: Vec3,
        rng: &mut Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        self.trace::<false>(&self.lights, origin, dir, rng, sink)
    }

    /// A path lit by `lights` (with their emissive surfaces when not `AMBIENT`). The
    /// pulsed render is `AMBIENT = false`: the ambient code below compiles away and the
    /// loop is the one it always was. `AMBIENT = true` is the steady ambient image
    /// ([`super::ambient`]): `lights` is the ambient group (point, spot and directional
    /// lights, the sky), emissive surfaces are dark, and an escaping path picks up the
    /// sky radiance; it is not split (its pilot would be another render's).
    pub(super) fn trace<const AMBIENT: bool>(
        &self,
        lights: &Lights,
        origin: Vec3,
        dir: Vec3,
        rng: &mut Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        if !AMBIENT && let Some(media) = &self.media {
            return self.walk_media(media, origin, dir, Some(0.0), rng, sink);
        }
        let strategy = if AMBIENT {
            Strategy::PLAIN
        } else {
            self.strategy()
        };
        let path = Path::camera(origin, dir, Intensity);
        self.walk::<AMBIENT, Intensity>(lights, path, strategy, None, rng, sink)
    }

    /// Follow `path` with `strategy` until it ends; returns the rays traced. At its first
    /// scattering vertex the path splits into `strategy.splits` branches (see
    /// [`RenderSettings::first_bounce_splits`]), each followed with `1 / splits` of the
    /// path's share and its own draws ([`Sampler::start_branch`]). `light_vertex` is
    /// the sample's light vertex when drawn already (a branch shares its sample's).
    fn walk<const AMBIENT: bool, C: Carried>(
        &self,
        lights: &Lights,
        mut path: Path<C>,
        strategy: Strategy,
        mut light_vertex: LazyLightVertex,
        rng: &mut Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        let s = &self.settings;
        let splits = strategy.splits;
        // A polarized path is not split and not joined to light vertices (its callers
        // pass `Strategy::PLAIN`; the checks make sure).
        let splits = if C::POLARIZED { 1 } else { splits };
        let connects = !AMBIENT
            && !C::POLARIZED
            && s.nee
            && strategy.light_vertex
            && !lights.punctual.is_empty();
        let window_end_opl_m = sink.window_end_s() * C_M_PER_S;
        let mut rays = 0u64;
        loop {
            let slot = |use_| dim::vertex(path.scatterings, use_);
            let (origin, dir) = (path.origin, path.dir);
            rays += 1;
            sink.ray(origin, dir, f32::INFINITY, RayKind::Path);
            let Some(hit) = self.accel.closest_hit(origin, dir, f32::INFINITY) else {
                // Escaped: the pulsed render has no environment light; the ambient image
                // sees the sky's radiance L (found only by BSDF sampling: no MIS weight).
                if AMBIENT && lights.sky_radiance > 0.0 {
                    let value = path.throughput * path.share * lights.sky_radiance;
                    let c = path.pol.light(value);
                    deliver(sink, path.opl_m / C_M_PER_S, c, path.scatterings);
                }
                break;
            };
            if path.unwarp {
                path.unwarp = false; // the camera's leg is not counted
            } else {
                path.opl_m += hit.t_m as f64 * path.ior_here as f64;
            }
            if path.opl_m > window_end_opl_m {
                sink.left_out(LeftOut::PathPastWindow);
                break; // already too late to arrive inside the window
            }
            let mut sp = self.surfaces.at(&hit, origin, dir);
            // Virtual interface: the uncovered fraction passes straight through, undelayed.
            let u_cover = || match path.pass_throughs {
                0 => rng.get1(slot(dim::COVERAGE)),
                p => rng.get1_hashed(((path.scatterings as u64) << 16) + p as u64),
            };
            if sp.coverage < 1.0 && u_cover() >= sp.coverage {
                path.pass_throughs += 1;
                if path.pass_throughs > MAX_PASS_THROUGH {
                    break;
                }
                path.origin = sp.position - sp.n_face * self.offset_m(sp.position);
                continue;
            }
            // Emission seen along the path (R0 at t = 0 at the emitter).
            if !AMBIENT && sp.emission > 0.0 {
                let weight = match path.last_pdf {
                    None => 1.0,
                    Some(pdf_bsdf) => {
                        let d2 = (sp.position - path.last_position).length_squared();
                        let cos_l = sp.n_face.dot(-dir).abs();
                        let pdf_light = lights.pdf_area(hit.triangle) * d2 / cos_l.max(1e-12);
                        if s.nee {
                            power_heuristic(pdf_bsdf, pdf_light)
                        } else {
                            1.0
                        }
                    }
                };
                // The pulse at the first surface it lights: the emitter's leg left out.
                let opl_m = match s.pulse_origin {
                    PulseOrigin::Light => path.opl_m,
                    PulseOrigin::FirstHit => path.vertex_opl_m,
                };
                let c = path
                    .pol
                    .light(path.throughput * path.share * sp.emission * weight);
                deliver(sink, opl_m / C_M_PER_S, c, path.scatterings | path.tag);
            }
            if path.scatterings >= s.max_bounces {
                break;
            }
            // A luminescent surface reflects, or re-emits later ([`luminescence`]).
            let mut splat = None;
            if let Some(choice) = self.luminescent_choice(
                lights,
                hit.triangle,
                &sp,
                path.opl_m,
                path.scatterings,
                rng,
                sink,
            ) {
                match choice {
                    Choice::Reflect { weight } => path.throughput *= weight,
                    Choice::Reemit {
                        bsdf,
                        weight,
                        delay_weight,
                        delay_opl_m,
                        decay,
                    } => {
                        sp.bsdf = *bsdf;
                        path.throughput *= weight;
                        path.tag = RE_EMITTED;
                        // No light-vertex join finds a re-emission: its estimate here
                        // takes the whole weight.
                        path.connected_pdf = 0.0;
                        match s.luminescence_delay {
                            DelaySampling::Sampled => {
                                path.throughput *= delay_weight as f32;
                                path.opl_m += delay_opl_m;
                            }
                            DelaySampling::Splat => {
                                splat = Some((decay, delay_weight, delay_opl_m))
                            }
                        }
                    }
                    Choice::Late => {
                        sink.left_out(LeftOut::PathPastWindow);
                        break;
                    }
                }
            }
            let bsdf = sp.bsdf;
            let frame = Frame::new(sp.n_shading);
            let wo = frame.to_local(-dir);
            // Where shadow rays from this vertex start.
            let p_out = sp.position + sp.n_face * self.offset_m(sp.position);
            if let Some((decay, delay_weight, delay_opl_m)) = splat {
                // Its next-event estimates spread over the later bins, no joins; the
                // path goes on with the drawn delay.
                if s.nee && bsdf.has_smooth_lobe() {
                    let mut spread = Splat {
                        inner: &mut *sink,
                        decay,
                        fallback_delay_s: delay_opl_m / C_M_PER_S,
                        fallback_weight: delay_weight,
                    };
                    rays += self.next_event::<AMBIENT, C>(
                        lights,
                        &path.pol,
                        &bsdf,
                        &frame,
                        wo,
                        sp.position,
                        p_out,
                        sp.n_face,
                        path.opl_m,
                        path.ior_here,
                        path.throughput * path.share,
                        path.scatterings,
                        path.tag,
                        0.0,
                        rng,
                        &mut spread,
                    );
                }
                path.throughput *= delay_weight as f32;
                path.opl_m += delay_opl_m;
                match self.scatter(&sp, &frame, wo, path, rng) {
                    Some(next) => path = next,
                    None => break,
                }
                continue;
            }
            if s.nee && bsdf.has_smooth_lobe() {
                // The density with which the last vertex's BSDF sample found this one,
                // per unit area, when that vertex was also joined to the light vertex.
                let connected_pdf_area = if path.connected_pdf > 0.0 {
                    let d2 = (sp.position - path.last_position).length_squared();
                    path.connected_pdf * sp.n_face.dot(dir).abs() / d2
                } else {
                    0.0
                };
                rays += self.next_event::<AMBIENT, C>(
                    lights,
                    &path.pol,
                    &bsdf,
                    &frame,
                    wo,
                    sp.position,
                    p_out,
                    sp.n_face,
                    path.opl_m,
                    path.ior_here,
                    path.throughput * path.share,
                    path.scatterings,
                    path.tag,
                    connected_pdf_area,
                    rng,
                    sink,
                );
            }
            // Join this vertex to the sample's light vertex (drawn at the first vertex
            // that needs it), when the path could also reach it by a BSDF sample here.
            let connected = connects
                && bsdf.has_smooth_lobe()
                && path.ior_here == 1.0
                && path.scatterings + 2 <= s.max_bounces;
            if connected {
                if light_vertex.is_none() {
                    let (lv, n) = self.light_vertex(lights, path.scatterings, rng, sink);
                    rays += n;
                    light_vertex = Some(lv);
                }
                // By reference: a light vertex is over a hundred bytes.
                if let Some(Some(lv)) = &light_vertex {
                    let x = EyeVertex {
                        bsdf: &bsdf,
                        frame: &frame,
                        wo,
                        position: sp.position,
                        position_out: p_out,
                        n_face: sp.n_face,
                        opl_m: path.opl_m,
                        throughput: path.throughput * path.share,
                        scatterings: path.scatterings,
                        tag: path.tag,
                        bsdf_samples: splits as f32,
                    };
                    rays += self.connect(&x, lv, sink);
                }
            }
            // What the next vertex's next-event weight needs of this BSDF sample.
            let mark = |mut next: Path<C>, n: u32| {
                next.connected_pdf = match next.last_pdf {
                    Some(pdf) if connected => pdf * n as f32,
                    _ => 0.0,
                };
                next
            };
            if splits > 1 {
                // Split: each branch draws its own lobe, direction and what follows.
                let share = path.share / splits as f32;
                for j in 0..splits {
                    rng.start_branch(j, splits);
                    let branch = Path { share, ..path };
                    if let Some(next) = self.scatter(&sp, &frame, wo, branch, rng) {
                        let next = mark(next, splits);
                        let strategy = Strategy {
                            splits: 1,
                            ..strategy
                        };
                        rays += self.walk::<AMBIENT, C>(
                            lights,
                            next,
                            strategy,
                            light_vertex,
                            rng,
                            sink,
                        );
                    }
                }
                break;
            }
            match self.scatter(&sp, &frame, wo, path, rng) {
                Some(next) => path = mark(next, 1),
                None => break,
            }
        }
        rays
    }

    /// Sample the next direction at surface point `sp` (outgoing `wo`, local to
    /// `frame`) and step `path` onto it, Russian roulette included; `None` ends the path.
    /// Always inlined (its two call sites in `walk`): 4 % of a one-thread render
    /// measured, where left to the compiler it was a call.
    #[inline(always)]
    fn scatter<C: Carried>(
        &self,
        sp: &SurfacePoint,
        frame: &Frame,
        wo: Vec3,
        mut path: Path<C>,
        rng: &Sampler,
    ) -> Option<Path<C>> {
        let s = &self.settings;
        let slot = |use_| dim::vertex(path.scatterings, use_);
        let bsdf = &sp.bsdf;
        let u_lobe = if bsdf.single_lobe() {
            0.0
        } else {
            rng.get1(slot(dim::LOBE))
        };
        let bs = bsdf.sample(wo, u_lobe, rng.get2(slot(dim::BSDF_DIRECTION)))?;
        let wi_world = frame.to_world(bs.wi);
        let refracted = bs.kind == LobeKind::Refract;
        // The geometric side must agree with the lobe (shading normals can disagree).
        let geo = wi_world.dot(sp.n_face);
        if (refracted && geo >= 0.0) || (!refracted && geo <= 0.0) {
            return None;
        }
        path.throughput *= bs.weight;
        path.pol.scatter(bsdf, frame, wo, &bs);
        let u_roulette = slot(dim::ROULETTE);
        path.scatterings += 1;
        if refracted {
            // The group index: it times the path (the phase index refracts it).
            path.ior_here = if sp.front { sp.ior_group } else { 1.0 };
        }
        path.last_pdf = (!bs.is_delta()).then_some(bs.pdf);
        path.last_position = sp.position;
        path.vertex_opl_m = path.opl_m;
        path.pass_throughs = 0;
        path.origin = sp.position + sp.n_face * self.offset_m(sp.position) * geo.signum();
        path.dir = wi_world.normalize();
        // Russian roulette: stop when the remaining flux is small (unbiased). It looks at
        // the throughput, not at the share of a split path, so branches survive as an
        // unsplit path would.
        if path.scatterings >= s.rr_start {
            let q = path.throughput.min(1.0).max(s.rr_min_survival.min(1.0));
            if !(q > 0.0) || rng.get1(u_roulette) >= q {
                return None;
            }
            path.throughput /= q;
        }
        (path.throughput.is_finite() && path.throughput > 0.0).then_some(path)
    }

    /// Next-event estimation at a vertex with outgoing `wo` (local): every punctual light
    /// and one power-sampled point on the emitters (MIS against BSDF sampling). `vertex`
    /// counts the scattering events before this one; the contribution arrives at
    /// `(opl_m + n d) / c` with `vertex + 1` events. When the previous vertex was joined
    /// to a light vertex, `connected_pdf_area` (> 0) is the density per unit area with
    /// which its BSDF sample found this vertex, and the punctual terms take the power
    /// heuristic's weight against finding it from the light ([`connected_weight`]).
    ///
    /// Directions, distances and cosines are taken from the surface point `p` itself;
    /// only the shadow ray starts from the offset point `p_out`. (Taken from `p_out`, a
    /// light closer to the surface than the ray offset would lie behind the origin and
    /// light nothing.)
    ///
    /// With `AMBIENT`, `lights` is the ambient group: its directional lights are
    /// sampled too (delta in direction: a shadow ray to infinity, `f cos E`, no MIS) and
    /// there are no emitters.
    #[allow(
        clippy::too_many_arguments,
        reason = "the path walk's per-vertex state, passed by value on the hot path"
    )]
    fn next_event<const AMBIENT: bool, C: Carried>(
        &self,
        lights: &Lights,
        pol: &C,
        bsdf: &Bsdf,
        frame: &Frame,
        wo: Vec3,
        p: Vec3,
        p_out: Vec3,
        n_face: Vec3,
        opl_m: f64,
        ior_here: f32,
        throughput: f32,
        vertex: u32,
        tag: u32,
        connected_pdf_area: f32,
        rng: &Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        let scatterings = (vertex + 1) | tag;
        let mut rays = 0;
        // The optical length of the leg to the light, `d` metres away, counted in the
        // arrival time (none when the pulse starts at the surface it lights).
        let leg_opl_m = |d: f32| self.light_leg_opl_m(d as f64 * ior_here as f64);
        for (i, light) in lights.punctual.iter().enumerate() {
            let to = light.position - p;
            let d2 = to.length_squared();
            if !(d2 > 0.0) {
                continue;
            }
            let d = d2.sqrt();
            let wi_world = to / d;
            if wi_world.dot(n_face) <= 0.0 {
                continue;
            }
            let (f, _) = bsdf.eval(wo, frame.to_local(wi_world));
            let intensity = light.intensity_toward(-wi_world);
            if f <= 0.0 || intensity <= 0.0 {
                continue;
            }
            let arrival_s = (opl_m + leg_opl_m(d)) / C_M_PER_S;
            if let Some(why) = outside(sink, arrival_s) {
                sink.left_out(why);
                continue;
            }
            rays += 1;
            let t_max = (light.position - p_out).dot(wi_world);
            sink.ray(p_out, wi_world, t_max, RayKind::Shadow);
            let tr = self.transmittance(p_out, wi_world, t_max);
            if tr > 0.0 {
                let cos_i = frame.to_local(wi_world).z;
                let mis = if connected_pdf_area > 0.0 {
                    connected_weight(lights, i, connected_pdf_area, wi_world, d, n_face)
                } else {
                    1.0
                };
                let value = throughput * f * cos_i * intensity / d2 * tr * mis;
                let wi = frame.to_local(wi_world);
                let c = pol.light_through(value, bsdf, frame, wo, wi, f);
                deliver(sink, arrival_s, c, scatterings);
            }
        }
        if AMBIENT {
            for light in &lights.directional {
                let wi_world = light.toward_light;
                if wi_world.dot(n_face) <= 0.0 {
                    continue;
                }
                let wi = frame.to_local(wi_world);
                let (f, _) = bsdf.eval(wo, wi);
                if f <= 0.0 {
                    continue;
                }
                rays += 1;
                sink.ray(p_out, wi_world, f32::INFINITY, RayKind::Shadow);
                let tr = self.transmittance(p_out, wi_world, f32::INFINITY);
                if tr > 0.0 {
                    // Radiance f E cos(theta_i): E the irradiance facing the light, W/m^2.
                    let value = throughput * f * wi.z * light.irradiance_w_per_m2 * tr;
                    let arrival_s = opl_m / C_M_PER_S;
                    let c = pol.light_through(value, bsdf, frame, wo, wi, f);
                    deliver(sink, arrival_s, c, scatterings);
                }
            }
        }
        if !AMBIENT && lights.has_emitters() {
            let u = rng.get1(dim::vertex(vertex, dim::EMITTER_SELECT));
            let (u1, u2) = rng.get2(dim::vertex(vertex, dim::EMITTER_POINT));
            if let Some(es) = lights.sample_emitter(u, u1, u2) {
                let to = es.position - p;
                let d2 = to.length_squared();
                if d2 > 0.0 {
                    let d = d2.sqrt();
                    let wi_world = to / d;
                    let le = self.surfaces.emission(es.triangle, es.u, es.v, -wi_world);
                    let cos_l = self
                        .surfaces
                        .geometric_normal(es.triangle)
                        .dot(-wi_world)
                        .abs();
                    if le > 0.0 && cos_l > 0.0 && wi_world.dot(n_face) > 0.0 {
                        let wi = frame.to_local(wi_world);
                        let (f, pdf_bsdf) = bsdf.eval(wo, wi);
                        let arrival_s = (opl_m + leg_opl_m(d)) / C_M_PER_S;
                        let late = outside(sink, arrival_s);
                        if let Some(why) = late.filter(|_| f > 0.0) {
                            sink.left_out(why);
                        }
                        if f > 0.0 && late.is_none() {
                            rays += 1;
                            let t_max = (es.position - p_out).dot(wi_world)
                                - 2.0 * self.offset_m(es.position);
                            sink.ray(p_out, wi_world, t_max, RayKind::Shadow);
                            let tr = self.transmittance(p_out, wi_world, t_max);
                            if tr > 0.0 {
                                let pdf_light = es.pdf_area * d2 / cos_l;
                                let w = power_heuristic(pdf_light, pdf_bsdf);
                                let value = throughput * f * wi.z * le * w * tr / pdf_light;
                                let c = pol.light_through(value, bsdf, frame, wo, wi, f);
                                deliver(sink, arrival_s, c, scatterings);
                            }
                        }
                    }
                }
            }
        }
        rays
    }

    /// Fraction of light passing straight from `p` along unit `dir` for `dist_m`: the
    /// product of `1 - coverage` of the partly covered surfaces crossed; 0 when an opaque
    /// or refracting surface is in the way. 1 for `dist_m <= 0` (nothing fits in between).
    pub(super) fn transmittance(&self, p: Vec3, dir: Vec3, dist_m: f32) -> f32 {
        if !(dist_m > 0.0) {
            return 1.0;
        }
        let mut tr = 1.0f32;
        let blocked = self.accel.any_hit(p, dir, dist_m, |hit| {
            tr *= self
                .surfaces
                .shadow_transmission(hit.triangle, hit.u, hit.v);
            tr <= 0.0
        });
        if blocked { 0.0 } else { tr }
    }
}
