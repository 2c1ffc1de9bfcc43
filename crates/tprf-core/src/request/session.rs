//! A request made ready to render, and its passes.

use super::memory::{MemoryBudget, MemoryStop};
use super::{Problem, RenderRequest, RequestError, apply_camera};
use crate::export::shard::ShardSpec;
use crate::film::{FilmLayout, StokesFilms, TimeAxis, TimeFilter, TprfFilm};
use crate::scene::{self, Camera, PulseOrigin, Scene};
use crate::transport::progressive::{self, PassReport, PassSize, Polarized};
use crate::transport::{Renderer, choose_window};
use std::ops::ControlFlow;
use std::sync::Arc;
use std::time::Instant;

/// A request made ready: its scene loaded (with the request's sky and medium), the
/// renderer seen from the request's camera, the time axis (chosen by a pilot render
/// where the request does not fix it), and an empty film of the request's shape (a
/// shard's rows only, with its time filter). Runs in the caller's rayon pool (the pilot
/// render is parallel).
pub struct Session {
    request: RenderRequest,
    scene: Arc<Scene>,
    renderer: Arc<Renderer>,
    film: TprfFilm,
    /// A polarized render's S1..S3 films, in lockstep with `film` (S0).
    stokes: Option<StokesFilms>,
    shard: Option<ShardSpec>,
    setup_s: f64,
    surface_returns_s: Option<f64>,
    memory: MemoryBudget,
    memory_stop: Option<MemoryStop>,
}

impl Session {
    /// Validate `request`, load its scene (`builtin:NAME` or a glTF path) and make it
    /// ready.
    pub fn new(request: &RenderRequest) -> Result<Session, RequestError> {
        let start = Instant::now();
        request.validate()?;
        let scene = scene::load(&request.scene)?;
        Session::prepared(request, Arc::new(scene), start)
    }

    /// Validate `request` and make it ready on a scene built in code (a reference's, a
    /// stability case's); `request.scene` names it in metadata (left empty: the scene's
    /// own name).
    pub fn with_scene(request: &RenderRequest, scene: Arc<Scene>) -> Result<Session, RequestError> {
        let start = Instant::now();
        let named;
        let request = if request.scene.trim().is_empty() {
            named = RenderRequest {
                scene: match scene.name.trim() {
                    "" => "a scene built in code".into(),
                    name => name.to_string(),
                },
                ..request.clone()
            };
            &named
        } else {
            request
        };
        request.validate()?;
        Session::prepared(request, scene, start)
    }

    /// Validate `request` and make it ready on the scene `previous` has prepared (its
    /// BVH, lights and media shared, seen from the request's camera): nothing is loaded
    /// or built. `previous` must have been made for a request that differs from this one
    /// only where [`RenderRequest::same_scene`] allows (a new camera, film, window or
    /// schedule); the caller checks. The film is the one [`Session::new`] would render,
    /// bit for bit.
    pub fn with_renderer(
        request: &RenderRequest,
        previous: &Renderer,
    ) -> Result<Session, RequestError> {
        let start = Instant::now();
        request.validate()?;
        // The scene's own camera: the request's pose is applied to it as on a load.
        let camera = apply_camera(request, &previous.scene().camera)?;
        let renderer = Arc::new(previous.with_camera(camera));
        Session::ready(request, renderer, start)
    }

    fn prepared(
        request: &RenderRequest,
        mut scene: Arc<Scene>,
        start: Instant,
    ) -> Result<Session, RequestError> {
        // The camera is the renderer's, not written into the scene: a scene shared with
        // its loader (the window's worker keeps it for the next camera) is not copied.
        let camera = apply_camera(request, &scene.camera)?;
        if let Some(l) = request.sky_radiance_w_m2_sr {
            // Validated: finite, >= 0 and within f32.
            Arc::make_mut(&mut scene).ambient.sky_radiance = [l as f32; 3];
        }
        if let Some(medium) = request.medium_override()? {
            Arc::make_mut(&mut scene).medium = medium;
        }
        let renderer = Arc::new(Renderer::seen_from(scene, camera, request.settings()));
        Session::ready(request, renderer, start)
    }

    /// The window, the empty film and its memory budget for `renderer`.
    fn ready(
        request: &RenderRequest,
        renderer: Arc<Renderer>,
        start: Instant,
    ) -> Result<Session, RequestError> {
        let scene = renderer.scene_shared().clone();
        if request.pulse_origin == PulseOrigin::FirstHit && renderer.has_media() {
            return Err(RequestError::Invalid(Problem::field("pulse_origin").text(
                " first-hit: the light's leg is not separated from the path in a scene \
                 with participating media (render it with the pulse leaving the light)",
            )));
        }
        let chosen = choose_window(&renderer, request.window())?;
        let axis = chosen.axis;
        let layout = FilmLayout {
            width: request.width,
            height: request.height,
            axis,
            bounces_separate: request.bounces_separate,
            luminescence: renderer.is_luminescent(),
        };
        let mut film = TprfFilm::new(layout)?.with_time_filter(request.time_filter);
        let shard = request.shard_spec()?;
        if let Some(spec) = &shard {
            film = film.with_rows(&spec.rows(request.height));
        }
        // A first pass (1 sample per pixel in every schedule) that cannot fit is refused
        // now, with the film a pilot render foresees.
        let mut memory = MemoryBudget::new(
            request.max_memory_bytes,
            &renderer,
            &film,
            request.time_filter == TimeFilter::Tent,
        );
        memory.check_first_pass(&film, 1)?;
        let stokes = if request.polarized {
            renderer.polarized().map_err(|e| {
                RequestError::Invalid(Problem::field("polarized").text(format!(": {e}")))
            })?;
            Some(StokesFilms::like(&film)?)
        } else {
            None
        };
        Ok(Session {
            request: request.clone(),
            scene,
            renderer,
            film,
            stokes,
            shard,
            setup_s: start.elapsed().as_secs_f64(),
            surface_returns_s: chosen.surface_returns_s,
            memory,
            memory_stop: None,
        })
    }

    /// Readers keep `copies` published snapshots beside the film while it renders (the
    /// window's worker: 2), whose rows a pass rebuilds beside them: counted in the
    /// memory each pass is foreseen to need.
    pub fn hold_snapshots(&mut self, copies: u64) {
        self.memory.set_reader_copies(copies);
    }

    /// New bins per pixel and sample the memory budget last saw (before any pass: the
    /// pilot render's).
    pub fn pilot_bins_per_sample(&self) -> f64 {
        self.memory.bins_per_sample()
    }

    /// Why the last [`Session::run`] stopped before its target: its next pass would not
    /// have fitted in memory (`None`: it did not stop for memory).
    pub fn memory_stop(&self) -> Option<&MemoryStop> {
        self.memory_stop.as_ref()
    }

    /// Add passes to the film until the request's spp target, time budget or error
    /// target is met, `on_pass` (called after each pass, with the film) breaks, or the
    /// next pass would not fit in memory ([`Session::memory_stop`] then says so, and the
    /// film holds the passes before it); the reports of the passes made. Called again,
    /// it goes on from where the film is.
    pub fn run(
        &mut self,
        mut on_pass: impl FnMut(&PassReport, &TprfFilm) -> ControlFlow<()>,
    ) -> Vec<PassReport> {
        let schedule = self.request.schedule();
        let error_target = self.request.error_target;
        self.memory_stop = None;
        let memory = &mut self.memory;
        let stop = &mut self.memory_stop;
        // A paced schedule's pass may be made smaller to fit (its size is the pace's,
        // not the result's); a doubling schedule's passes stay whole, so that a stopped
        // render is the render of the samples it reached.
        let shrink = matches!(schedule.pass_size, PassSize::Paced { .. });
        let before = |spp: u32, film: &TprfFilm| match memory.before_pass(film, spp, shrink) {
            Ok(spp) => ControlFlow::Continue(spp),
            Err((need_bytes, limit_bytes, limited_by)) => {
                *stop = Some(MemoryStop {
                    spp: film.spp(),
                    passes: film.passes(),
                    next_pass_spp: spp,
                    need_bytes,
                    limit_bytes,
                    limited_by,
                });
                ControlFlow::Break(())
            }
        };
        let after = |report: &PassReport, film: &TprfFilm| {
            on_pass(report, film)?;
            // The error target reached: done, like the spp target.
            if error_target
                .zip(film.half_error_estimate())
                .is_some_and(|(target, e)| e <= target)
            {
                return ControlFlow::Break(());
            }
            ControlFlow::Continue(())
        };
        let renderer = &*self.renderer;
        match (&mut self.stokes, renderer.polarized()) {
            (Some(s123), Ok(tracer)) => {
                let mut target = Polarized {
                    tracer,
                    s0: &mut self.film,
                    s123,
                };
                progressive::render_with(renderer, &mut target, &schedule, before, after)
            }
            // A polarized session's renderer was checked when it was made.
            _ => progressive::render_with(renderer, &mut self.film, &schedule, before, after),
        }
    }

    /// A polarized render's S1..S3 films (`None`: the request is not polarized); S0 is
    /// [`Session::film`].
    pub fn stokes(&self) -> Option<&StokesFilms> {
        self.stokes.as_ref()
    }

    pub fn request(&self) -> &RenderRequest {
        &self.request
    }

    /// The scene rendered (the request's sky and medium applied); its camera is the
    /// scene's own, the one rendered is [`Session::camera`].
    pub fn scene(&self) -> &Arc<Scene> {
        &self.scene
    }

    /// The camera rendered: the scene's, with the request's pose applied.
    pub fn camera(&self) -> &Camera {
        self.renderer.camera()
    }

    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// The renderer, shared: for work beside the passes (the worker's ambient image,
    /// rendered from inside its pass callback).
    pub fn shared_renderer(&self) -> Arc<Renderer> {
        self.renderer.clone()
    }

    pub fn film(&self) -> &TprfFilm {
        &self.film
    }

    /// The film, taken out of the session.
    pub fn into_film(self) -> TprfFilm {
        self.film
    }

    /// The film and a polarized render's S1..S3 films, taken out of the session.
    pub fn into_films(self) -> (TprfFilm, Option<StokesFilms>) {
        (self.film, self.stokes)
    }

    pub fn axis(&self) -> TimeAxis {
        *self.film.axis()
    }

    /// When the surfaces' returns arrive, in a scene with media whose window was chosen
    /// automatically ([`crate::transport::ChosenWindow::surface_returns_s`]), seconds.
    pub fn surface_returns_s(&self) -> Option<f64> {
        self.surface_returns_s
    }

    /// The shard rendered (`None`: the whole image).
    pub fn shard(&self) -> Option<ShardSpec> {
        self.shard
    }

    /// Seconds spent loading the scene, choosing the window and making the film.
    pub fn setup_s(&self) -> f64 {
        self.setup_s
    }
}
