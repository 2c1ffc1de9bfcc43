//! Polarized renders: the path walk carrying the path's Mueller matrix (`Polarization`
//! in `transport::carried`) and delivering Stokes vectors in the camera's frame (`S1 >
//! 0`: light polarized along the image's x axis; docs/polarization.md).
//!
//! Lights are unpolarized; lobes polarize as [`super::bsdf::polarized`] says. Next-event
//! estimation and its MIS are the intensity walk's. Not carried yet, and refused by name
//! rather than rendered wrong: participating media, luminescent materials. First-vertex
//! splits and light-vertex joins are not used (the walk is the plain path tracer:
//! unbiased, only noisier where those would have helped).

use super::carried::Polarization;
use super::integrator::{PassStats, Renderer, Sink};
use super::sampler::Sampler;
use super::split::Strategy;
use crate::film::{LeftOut, PixelSink, StokesFilms, StokesPixelSink, TimeAxis, TprfFilm};

/// Why a scene cannot be rendered polarized (yet).
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum PolarizationError {
    #[error(
        "polarized: the scene has participating media, which the polarized walk does not carry yet (render it without --polarized, or without its media)"
    )]
    Media,
    #[error(
        "polarized: material \"{0}\" is luminescent; re-emission is not carried by the polarized walk yet"
    )]
    Luminescent(String),
}

/// A [`Renderer`] checked for polarized rendering.
#[derive(Clone, Copy)]
pub struct PolarizedTracer<'a> {
    renderer: &'a Renderer,
}

impl Renderer {
    /// This renderer's polarized walk, or why the scene cannot have one.
    pub fn polarized(&self) -> Result<PolarizedTracer<'_>, PolarizationError> {
        if self.has_media() {
            return Err(PolarizationError::Media);
        }
        if let Some(m) = self
            .scene()
            .materials
            .iter()
            .find(|m| m.luminescence.is_some())
        {
            return Err(PolarizationError::Luminescent(m.name.clone()));
        }
        Ok(PolarizedTracer { renderer: self })
    }
}

impl PolarizedTracer<'_> {
    /// Trace the next sample of `rng` through pixel `(x, y)` of a `w x h` image
    /// (jittered), every contribution to `sink` by [`Sink::add_stokes`]; returns the rays
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
        self.renderer
            .trace_sample_carrying::<Polarization>(x, y, w, h, Strategy::PLAIN, rng, sink)
    }
}

impl PolarizedTracer<'_> {
    /// One pass of `spp` samples per pixel into the Stokes film `s0` (the intensity) and
    /// `s123`, as [`Renderer::render_pass`] makes one into an intensity film: the same
    /// sample streams (seed, half, pixel, index), the adaptive plan read from `s0` alone,
    /// every sample by [`PolarizedTracer::trace_sample`].
    pub fn render_pass(&self, s0: &mut TprfFilm, s123: &mut StokesFilms, spp: u32) -> PassStats {
        let r = self.renderer;
        let layout = *s0.layout();
        let (w, h) = (layout.width, layout.height);
        let half = s0.passes() % 2;
        let plan = if r.settings().adaptive {
            super::adaptive::plan(s0, spp)
        } else {
            None
        };
        let seed = r.settings().seed;
        let tally = s123.run_pass_planned(s0, spp, plan.as_deref(), |x, y, pass, sink| {
            let mut rng =
                Sampler::new(seed, half, (y * w + x) as u64).starting_at(pass.first as u64);
            let mut rays = 0u64;
            for _ in 0..pass.samples {
                rays += self.trace_sample(x, y, w, h, &mut rng, sink);
            }
            rays
        });
        r.count_rays(tally.work);
        let paths = match &plan {
            Some(p) => p.iter().map(|&n| n as u64).sum(),
            None => (w * s0.rows_rendered()) as u64 * spp as u64,
        };
        PassStats {
            paths,
            rays: tally.work,
            outside_per_pixel: tally.outside_per_pixel,
            left_out: tally.left_out,
        }
    }
}

/// A Stokes film's pixel: each component to its film's sink. An intensity contribution
/// (unpolarized) goes to S0 alone; a component that is exactly 0 is not added (a
/// depolarizing scene's S1..S3 films stay empty at the cost of a comparison).
impl Sink for StokesPixelSink<'_> {
    #[inline]
    fn add(&mut self, arrival_s: f64, value: f64, scatterings: u32) {
        self.sinks[0].add(arrival_s, value, scatterings);
    }
    #[inline]
    fn add_stokes(&mut self, arrival_s: f64, stokes: [f64; 4], scatterings: u32) {
        for (sink, s) in self.sinks.iter_mut().zip(stokes) {
            if s != 0.0 {
                sink.add(arrival_s, s, scatterings);
            }
        }
    }
    #[inline]
    fn window_end_s(&self) -> f64 {
        self.sinks[0].window_end_s()
    }
    #[inline]
    fn window_start_s(&self) -> f64 {
        self.sinks[0].window_start_s()
    }
    #[inline]
    fn left_out(&mut self, why: LeftOut) {
        PixelSink::left_out(&mut self.sinks[0], why);
    }
    #[inline]
    fn time_axis(&self) -> Option<TimeAxis> {
        Some(self.sinks[0].axis())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::{StokesFilms, TimeAxis, TprfFilm};
    use crate::scene::mitsuba::load_mitsuba;
    use crate::scene::{Scene, builtin};
    use crate::transport::RenderSettings;
    use glam::Vec3;
    use std::sync::Arc;

    /// Every contribution, kept: (arrival, Stokes, scatterings), and intensity ones apart.
    #[derive(Default)]
    struct Collect {
        stokes: Vec<[f64; 4]>,
        intensity: Vec<f64>,
    }

    impl Sink for Collect {
        fn add(&mut self, _arrival_s: f64, value: f64, _scatterings: u32) {
            self.intensity.push(value);
        }
        fn add_stokes(&mut self, _arrival_s: f64, stokes: [f64; 4], _scatterings: u32) {
            self.stokes.push(stokes);
        }
        fn window_end_s(&self) -> f64 {
            f64::INFINITY
        }
    }

    fn settings() -> RenderSettings {
        RenderSettings {
            max_bounces: 6,
            first_bounce_splits: 1,
            light_vertex: Some(false),
            ..RenderSettings::default()
        }
    }

    /// `n` samples of every pixel of a `w x h` image, polarized and not (same seeds).
    fn render(r: &Renderer, w: usize, h: usize, n: usize) -> (Collect, Collect) {
        let (mut pol, mut int) = (Collect::default(), Collect::default());
        let tracer = r.polarized().expect("a polarizable scene");
        for y in 0..h {
            for x in 0..w {
                let mut a = Sampler::new(7, 0, (y * w + x) as u64);
                let mut b = Sampler::new(7, 0, (y * w + x) as u64);
                for _ in 0..n {
                    tracer.trace_sample(x, y, w, h, &mut a, &mut pol);
                    r.trace_sample_with(x, y, w, h, Strategy::PLAIN, &mut b, &mut int);
                }
            }
        }
        (pol, int)
    }

    /// A diffuse-only scene under an unpolarized light (the Cornell box) gives `S1 = S2 =
    /// S3 = 0` for every contribution, and `S0` equal to the intensity walk's value for
    /// the same samples (the same paths: the polarized walk takes the same decisions).
    #[test]
    fn diffuse_scene_stays_unpolarized() {
        let scene = Arc::new(builtin::load("cornell").unwrap());
        let r = Renderer::new(scene, settings());
        let (pol, int) = render(&r, 6, 6, 8);
        assert_eq!(pol.stokes.len(), int.intensity.len());
        assert!(pol.stokes.len() > 500, "{}", pol.stokes.len());
        for (s, v) in pol.stokes.iter().zip(&int.intensity) {
            assert_eq!((s[1], s[2], s[3]), (0.0, 0.0, 0.0), "{s:?}");
            assert!((s[0] - v).abs() <= 1e-5 * v.abs(), "{s:?} vs {v}");
        }
    }

    /// A glass plane (n = 1.5) seen from `eye` (camera `up`) with a large area light at
    /// `light` (Mitsuba XML, a 5 x 5 film).
    fn brewster_xml(eye: Vec3, up: Vec3, light: Vec3) -> String {
        format!(
            r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="2"/>
    <transform name="to_world">
      <lookat origin="{},{},{}" target="0,0,0" up="{},{},{}"/>
    </transform>
    <film type="hdrfilm"><integer name="width" value="5"/><integer name="height" value="5"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><scale value="10"/></transform>
    <bsdf type="dielectric"><float name="int_ior" value="1.5"/><float name="ext_ior" value="1"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><scale value="2"/><lookat origin="{},{},{}" target="0,0,0" up="1,0,0"/></transform>
    <emitter type="area"><rgb name="radiance" value="1"/></emitter>
  </shape>
</scene>"#,
            eye.x, eye.y, eye.z, up.x, up.y, up.z, light.x, light.y, light.z
        )
    }

    /// A glass plane seen at Brewster's angle, reflecting a large area light: every
    /// contribution is fully polarized with its field across the plane of incidence (the
    /// world's x axis). Seen by the camera rolled by `alpha` about its axis, the Stokes
    /// vector is the one of that field's angle measured in the camera's frame (right,
    /// up): `(S1, S2)` turn by `2 alpha` as the camera rolls.
    #[test]
    fn brewster_reflection_seen_by_a_rolling_camera() {
        let theta = 1.5f32.atan();
        let (s, c) = theta.sin_cos();
        let eye = Vec3::new(0.0, -3.0 * s, 3.0 * c);
        let light = Vec3::new(0.0, 3.0 * s, 3.0 * c);
        let forward = -eye.normalize();
        // The unrolled camera's up: in the plane of incidence (y-z), across `forward`.
        let up0 = Vec3::Z.reject_from(forward).normalize();
        let right0 = forward.cross(up0);
        let dir = std::env::temp_dir().join(format!("tprf-brewster-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for alpha_deg in [0.0f32, 20.0, 45.0, 70.0, 120.0] {
            let alpha = alpha_deg.to_radians();
            let up = up0 * alpha.cos() + right0 * alpha.sin();
            let xml = brewster_xml(eye, up, light);
            let path = dir.join("brewster.xml");
            std::fs::write(&path, xml).unwrap();
            let (scene, _) = load_mitsuba(&path).unwrap();
            let scene: Arc<Scene> = Arc::new(scene);
            let r = Renderer::new(scene, settings());
            // The reflection is drawn with its probability, R ~ 0.074 at this angle.
            let (pol, _) = render(&r, 5, 5, 200);
            assert!(pol.stokes.len() > 100, "{}", pol.stokes.len());
            // The field: across the plane of incidence, world x. Its angle in the rolled
            // camera's frame (right, up), right = forward x up.
            let right = forward.cross(up);
            let psi = Vec3::X.dot(up).atan2(Vec3::X.dot(right));
            let expected = [(2.0 * psi).cos() as f64, (2.0 * psi).sin() as f64];
            let mut sum = [0.0f64; 4];
            for st in &pol.stokes {
                let dolp = (st[1] * st[1] + st[2] * st[2]).sqrt() / st[0];
                assert!(dolp > 0.99, "alpha {alpha_deg}: {st:?}");
                for i in 0..4 {
                    sum[i] += st[i];
                }
            }
            let (s1, s2) = (sum[1] / sum[0], sum[2] / sum[0]);
            assert!(
                (s1 - expected[0]).abs() < 0.01 && (s2 - expected[1]).abs() < 0.01,
                "alpha {alpha_deg}: (S1, S2) / S0 = ({s1}, {s2}), expected {expected:?}"
            );
            assert!(
                sum[3].abs() < 1e-6 * sum[0],
                "no circular part from a dielectric"
            );
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Gold boxes in a diffuse room: every contribution is a physical Stokes vector, and
    /// the conductor polarizes some light.
    #[test]
    fn conductor_scene_is_physical_and_polarizes() {
        let dir = std::env::temp_dir().join(format!("tprf-gold-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let xml = r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0,1,4" target="0,0.3,0" up="0,1,0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
  </sensor>
  <emitter type="point"><point name="position" x="1" y="2" z="1"/><rgb name="intensity" value="5"/></emitter>
  <shape type="rectangle">
    <transform name="to_world"><scale value="5"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"/>
  </shape>
  <shape type="cube">
    <transform name="to_world"><scale value="0.5"/><rotate y="1" angle="30"/><translate y="0.5"/></transform>
    <bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha" value="0.2"/></bsdf>
  </shape>
  <shape type="sphere">
    <point name="center" x="-1.2" y="0.5" z="0.5"/><float name="radius" value="0.5"/>
    <bsdf type="conductor"><string name="material" value="Al"/></bsdf>
  </shape>
</scene>"#;
        let path = dir.join("gold.xml");
        std::fs::write(&path, xml).unwrap();
        let (scene, _) = load_mitsuba(&path).unwrap();
        let r = Renderer::new(Arc::new(scene), settings());
        let (pol, int) = render(&r, 8, 8, 8);
        std::fs::remove_dir_all(&dir).ok();
        assert_eq!(pol.stokes.len(), int.intensity.len());
        let mut polarized = 0;
        for s in &pol.stokes {
            let p = (s[1] * s[1] + s[2] * s[2] + s[3] * s[3]).sqrt();
            assert!(s[0] >= p * (1.0 - 1e-4), "{s:?}");
            if p > 0.01 * s[0] {
                polarized += 1;
            }
        }
        assert!(polarized > 50, "{polarized} of {}", pol.stokes.len());
    }

    /// Films of a render, intensity and Stokes, of the same settings: (intensity film,
    /// S0 film, S1..S3 films), `spp` samples per pixel in doubling passes.
    fn render_films(
        r: &Renderer,
        w: usize,
        h: usize,
        spp: u64,
    ) -> (TprfFilm, TprfFilm, StokesFilms) {
        use crate::film::FilmLayout;
        use crate::transport::progressive::{self, Polarized, Schedule};
        use std::ops::ControlFlow;
        let layout = FilmLayout {
            width: w,
            height: h,
            axis: TimeAxis {
                t0_s: 0.0,
                dt_s: 2e-11,
                bins: 4000,
            },
            bounces_separate: 0,
            luminescence: false,
        };
        let schedule = Schedule::spp(spp);
        let mut int = TprfFilm::new(layout).unwrap();
        progressive::render(r, &mut int, &schedule, |_, _| ControlFlow::Continue(()));
        let mut s0 = TprfFilm::new(layout).unwrap();
        let mut s123 = StokesFilms::like(&s0).unwrap();
        let mut target = Polarized {
            tracer: r.polarized().unwrap(),
            s0: &mut s0,
            s123: &mut s123,
        };
        let reports = progressive::render_with(
            r,
            &mut target,
            &schedule,
            |n, _| ControlFlow::Continue(n),
            |_, _| ControlFlow::Continue(()),
        );
        assert_eq!(reports.last().map(|p| p.spp), Some(spp));
        for k in 1..=3 {
            let f = s123.component(k).unwrap();
            assert_eq!(
                (f.spp(), f.passes()),
                (s0.spp(), s0.passes()),
                "S{k} in lockstep"
            );
        }
        (int, s0, s123)
    }

    /// The Stokes films of the Cornell box (diffuse, an unpolarized light): S1..S3 store
    /// nothing (every contribution's is exactly 0), and S0 is the intensity render of the
    /// same seed and settings (the same paths: to rounding, the polarized walk's `S0` is
    /// `v N00` with `N00 = 1` up to float error).
    #[test]
    fn stokes_films_of_a_diffuse_scene() {
        let scene = Arc::new(builtin::load("cornell").unwrap());
        let r = Renderer::new(scene, settings());
        let (int, s0, s123) = render_films(&r, 6, 5, 12);
        for k in 1..=3 {
            let f = s123.component(k).unwrap();
            assert_eq!(f.store_stats().stored_bins, 0, "S{k}");
            assert!(f.cube_f64().iter().all(|&v| v == 0.0), "S{k}");
        }
        let (a, b) = (int.cube_f64(), s0.cube_f64());
        let lit = a.iter().filter(|&&v| v != 0.0).count();
        assert!(lit > 300, "{lit} lit bins");
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            assert!((x - y).abs() <= 1e-5 * x.abs(), "bin {i}: {x} vs {y}");
        }
        assert_eq!(
            int.half_error_estimate().is_some(),
            s0.half_error_estimate().is_some()
        );
    }

    /// The Brewster scene's Stokes films, the camera rolled 70 deg (so S1 < 0): summed
    /// over the image and bins, `(S1, S2) / S0` is `(cos 2 psi, sin 2 psi)` of the field's
    /// angle in the camera's frame (measured geometrically, as in
    /// `brewster_reflection_seen_by_a_rolling_camera`), DoLP ~1, no S3.
    #[test]
    fn stokes_films_of_a_brewster_reflection() {
        let theta = 1.5f32.atan();
        let (s, c) = theta.sin_cos();
        let eye = Vec3::new(0.0, -3.0 * s, 3.0 * c);
        let light = Vec3::new(0.0, 3.0 * s, 3.0 * c);
        let forward = -eye.normalize();
        let up0 = Vec3::Z.reject_from(forward).normalize();
        let right0 = forward.cross(up0);
        let alpha = 70f32.to_radians();
        let up = up0 * alpha.cos() + right0 * alpha.sin();
        let dir = std::env::temp_dir().join(format!("tprf-brewster-film-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("brewster.xml");
        std::fs::write(&path, brewster_xml(eye, up, light)).unwrap();
        let (scene, _) = load_mitsuba(&path).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        let r = Renderer::new(Arc::new(scene), settings());
        let (_, s0, s123) = render_films(&r, 5, 5, 64);
        let total = |f: &TprfFilm| f.cube_f64().iter().sum::<f64>();
        let sum = [
            total(&s0),
            total(s123.component(1).unwrap()),
            total(s123.component(2).unwrap()),
            total(s123.component(3).unwrap()),
        ];
        assert!(sum[0] > 0.0);
        let right = forward.cross(up);
        let psi = Vec3::X.dot(up).atan2(Vec3::X.dot(right));
        let want = [(2.0 * psi).cos() as f64, (2.0 * psi).sin() as f64];
        let (s1, s2) = (sum[1] / sum[0], sum[2] / sum[0]);
        assert!(want[0] < -0.5, "the roll makes S1 negative: {want:?}");
        assert!(
            (s1 - want[0]).abs() < 0.01 && (s2 - want[1]).abs() < 0.01,
            "(S1, S2) / S0 = ({s1}, {s2}), expected {want:?}"
        );
        assert!((s1 * s1 + s2 * s2).sqrt() > 0.99);
        assert!(sum[3].abs() < 1e-6 * sum[0]);
    }

    /// Media and luminescent materials are refused by name.
    #[test]
    fn refuses_what_it_does_not_carry() {
        let fog = Arc::new(builtin::load("fog").unwrap());
        let r = Renderer::new(fog, settings());
        assert_eq!(r.polarized().err(), Some(PolarizationError::Media));
        let flim = Arc::new(builtin::load("flim").unwrap());
        let r = Renderer::new(flim, settings());
        assert!(matches!(
            r.polarized(),
            Err(PolarizationError::Luminescent(_))
        ));
    }
}
