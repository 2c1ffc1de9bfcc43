//! The path loop for scenes with media (see the module doc of [`super`]).

use super::distance::{Equiangular, Exponential, PathLength, gate};
use super::glow::{GLOW_SHARE, Glow};
use super::phase::{hg, sample_hg};
use super::{BandMedium, Boundary, Media};
use crate::film::{LeftOut, RE_EMITTED};
use crate::transport::bsdf::{Bsdf, Frame, LobeKind};
use crate::transport::integrator::{RayKind, Renderer, Sink, outside, power_heuristic};
use crate::transport::lights::Punctual;
use crate::transport::luminescence::Choice;
use crate::transport::sampler::{Sampler, dim};
use crate::transport::surface::SurfacePoint;
use crate::units::C_M_PER_S;
use glam::{DVec3, Vec3};

mod grid_nee;

/// Largest number of straight crossings (alpha coverage, index-matched boundaries)
/// along one segment chain, and of surfaces a shadow ray walks through.
const MAX_PASS_THROUGH: u32 = 1024;

/// How the camera ray passing a medium to a surface whose light can still arrive
/// inside the window is favoured: with probability `q = max(T, min(PASS_BOOST T,
/// PASS_MAX))`, its weight `T / q`. A target behind fog of optical depth 4 (T = 0.018)
/// is reached by 37 % of the samples, not 1.8 %; behind a depth of 20 (T = 2e-9), where
/// nothing comes through, by as few as the transmittance says. Only the camera ray's
/// first segment: later segments are analog (`q = T`), since a boost at every segment
/// multiplies weights along the path (a closed room of fog with optical depth 3 across
/// lost its late light to the roulette that way, measured).
const PASS_BOOST: f32 = 20.0;
const PASS_MAX: f32 = 0.5;

/// How many scatterings after the surface loop's `rr_start` Russian roulette begins in
/// media. A survivor of the roulette carries weight 1 however unlikely its path, and in
/// fog the light it may meet next (the glow around a lamp, [`super::glow`]) is far
/// brighter than the pixel's mean: the race's fog scene had 70 % of its cube variance in
/// paths of 4 or more scatterings, with 2 % of the light. Measured on it (256 spp, four
/// seeds, glow directions on): starting at 8 instead of 3 cut the cube variance 4.2x for the same rays and
/// time (the window and the open road end the paths, not the roulette); on
/// builtin:cornell filled with fog (sigma_s 0.5 /m, g 0.9) 4.3x for 1.3x the time.
const MEDIA_RR_DELAY: u32 = 5;

/// Share of the gate's samples drawn in proportion to the light's `1 / r^2`
/// (equiangular), the rest in proportion to the transmittance of both legs.
const EQUIANGULAR_SHARE: f64 = 0.5;

/// The state of a path between two vertices.
#[derive(Clone, Copy, Debug)]
struct MediaPath {
    /// The ray about to be traced (unit `dir`).
    origin: Vec3,
    dir: Vec3,
    /// Product of the sample weights and roulette factors so far.
    throughput: f32,
    /// Eye-side optical path length, metres.
    opl_m: f64,
    scatterings: u32,
    /// [`RE_EMITTED`] once a luminescent surface re-emitted the path, else 0.
    tag: u32,
    /// The medium the ray travels in.
    region: BandMedium,
    /// Solid-angle pdf of the last direction sampled (BSDF or phase function); `None`
    /// for the camera ray and delta lobes.
    last_pdf: Option<f32>,
    last_position: Vec3,
    /// Straight crossings (alpha coverage, index-matched boundaries) since the last
    /// scattering.
    pass_throughs: u32,
    /// MIS weight of the single scattering that the segment's next-event estimation
    /// finds, against the glow technique that estimates it from the same vertex
    /// ([`Renderer::glow_segment`]); 1 where that did not run (the camera ray, a delta
    /// lobe, a refraction) and on the pieces after a straight crossing, which the glow
    /// technique's segment does not reach.
    nee_weight: f32,
}

/// How a segment's path continues ([`Renderer::continue_segment`]).
enum Next {
    /// To the surface the ray hit (the throughput weighted already).
    Surface,
    /// To a scattering event this far along the ray, metres.
    Scatter(f32),
    /// Nowhere: the path ends.
    End,
}

/// A uniform number in [0, 1) for `use_` at the path's vertex: the sample's slot on a
/// segment's first piece, hashed ones on the pieces after straight crossings (so each
/// piece of a chain draws afresh).
#[inline]
fn draw(rng: &Sampler, path: &MediaPath, use_: u32) -> f32 {
    match path.pass_throughs {
        0 => rng.get1(dim::vertex(path.scatterings, use_)),
        p => rng.get1_hashed(((path.scatterings as u64) << 24) + ((use_ as u64) << 16) + p as u64),
    }
}

impl Renderer {
    /// Trace a camera path from `origin` along unit `dir` through a scene with media;
    /// returns the rays traced. `start_opl_m` is the optical path already behind the
    /// pinhole (the time origin's offset: 0 from the pinhole); `None` counts from the
    /// camera ray's first surface (mitransient's `camera_unwarp`: scattering in the
    /// medium before it arrives at negative optical path, as there).
    pub(in crate::transport) fn walk_media(
        &self,
        media: &Media,
        origin: Vec3,
        dir: Vec3,
        start_opl_m: Option<f64>,
        rng: &Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        let s = *self.settings();
        let lights = self.lights();
        let window_end_opl_m = sink.window_end_s() * C_M_PER_S;
        let mut path = MediaPath {
            origin,
            dir,
            throughput: 1.0,
            opl_m: start_opl_m.unwrap_or(0.0),
            scatterings: 0,
            tag: 0,
            region: media.scene,
            last_pdf: None,
            last_position: origin,
            pass_throughs: 0,
            nee_weight: 1.0,
        };
        let mut unwarp = start_opl_m.is_none();
        let mut rays = 0u64;
        loop {
            let (origin, dir) = (path.origin, path.dir);
            rays += 1;
            sink.ray(origin, dir, f32::INFINITY, RayKind::Path);
            let hit = self.accel().closest_hit(origin, dir, f32::INFINITY);
            let t_hit = hit.map_or(f32::INFINITY, |h| h.t_m);
            let region = path.region;
            if let (true, Some(h)) = (std::mem::take(&mut unwarp), hit) {
                path.opl_m = -(h.t_m as f64) * region.n as f64;
            }
            // How far along the ray light can still go and arrive inside the window.
            let t_window = ((window_end_opl_m - path.opl_m) / region.n as f64) as f32;
            if !(t_window > 0.0) {
                sink.left_out(LeftOut::PathPastWindow);
                break;
            }
            let span = t_hit.min(t_window);
            let can_scatter = region.sigma_s > 0.0
                && path.scatterings < s.max_bounces
                && (path.scatterings + 1 < s.max_bounces || lights.has_emitters());
            if s.nee && region.sigma_s > 0.0 && path.scatterings < s.max_bounces {
                let u = match path.pass_throughs {
                    0 => rng.get2(dim::vertex(path.scatterings, dim::LIGHT_DIRECTION)),
                    _ => (
                        draw(rng, &path, dim::LIGHT_DIRECTION),
                        draw(rng, &path, dim::PER_VERTEX + dim::LIGHT_DIRECTION),
                    ),
                };
                rays += self.segment_nee(media, &path, span, u, rng, sink);
            }
            let u_next = draw(rng, &path, dim::LIGHT_SELECT);
            let next =
                self.continue_segment(media, &mut path, t_hit, t_window, can_scatter, u_next);
            match next {
                Next::End => {
                    if hit.is_some() && t_hit >= t_window {
                        sink.left_out(LeftOut::PathPastWindow);
                    }
                    break;
                }
                Next::Scatter(d_m) => {
                    let (ok, n) = self.medium_vertex(media, &mut path, d_m, rng, sink);
                    rays += n;
                    if !ok {
                        break;
                    }
                    continue;
                }
                Next::Surface => {}
            }
            let Some(hit) = hit else { break };
            path.opl_m += hit.t_m as f64 * region.n as f64;
            if path.opl_m > window_end_opl_m {
                sink.left_out(LeftOut::PathPastWindow);
                break;
            }
            let material = self
                .scene()
                .attrs
                .get(hit.triangle as usize)
                .map_or(u32::MAX, |a| a.material);
            let boundary = media.boundary(material);
            let mut sp = self.surfaces().at(&hit, origin, dir);
            // Index-matched boundary: into (or out of) its medium, straight on.
            if let Boundary::IndexMatched { inside } = boundary {
                path.region = if sp.front { inside } else { media.scene };
                path.pass_throughs += 1;
                path.nee_weight = 1.0;
                if path.pass_throughs > MAX_PASS_THROUGH {
                    break;
                }
                path.origin = sp.position - sp.n_face * self.offset_m(sp.position);
                continue;
            }
            // Virtual interface: the uncovered fraction passes straight through, undelayed.
            if sp.coverage < 1.0 && draw(rng, &path, dim::COVERAGE) >= sp.coverage {
                path.pass_throughs += 1;
                path.nee_weight = 1.0;
                if path.pass_throughs > MAX_PASS_THROUGH {
                    break;
                }
                path.origin = sp.position - sp.n_face * self.offset_m(sp.position);
                continue;
            }
            // Emission seen along the path (R0 at t = 0 at the emitter).
            if sp.emission > 0.0 {
                let weight = match path.last_pdf {
                    None => 1.0,
                    Some(pdf_dir) if s.nee => {
                        let d2 = (sp.position - path.last_position).length_squared();
                        let cos_l = sp.n_face.dot(-dir).abs();
                        let pdf_light = lights.pdf_area(hit.triangle) * d2 / cos_l.max(1e-12);
                        power_heuristic(pdf_dir, pdf_light)
                    }
                    Some(_) => 1.0,
                };
                sink.add(
                    path.opl_m / C_M_PER_S,
                    (path.throughput * sp.emission * weight) as f64,
                    path.scatterings | path.tag,
                );
            }
            if path.scatterings >= s.max_bounces {
                break;
            }
            // A luminescent surface reflects, or re-emits after a drawn delay (the media
            // loop always draws it: `transport::luminescence`).
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
                        ..
                    } => {
                        sp.bsdf = *bsdf;
                        path.throughput *= weight * delay_weight as f32;
                        path.opl_m += delay_opl_m;
                        path.tag = RE_EMITTED;
                    }
                    Choice::Late => {
                        sink.left_out(LeftOut::PathPastWindow);
                        break;
                    }
                }
            }
            let frame = Frame::new(sp.n_shading);
            let wo = frame.to_local(-dir);
            let p_out = sp.position + sp.n_face * self.offset_m(sp.position);
            if s.nee && sp.bsdf.has_smooth_lobe() {
                rays += self.surface_nee(media, &path, &sp, &frame, wo, p_out, rng, sink);
                if let Some(glow) = self.surface_glow(&path, &sp) {
                    // The BSDF's f cos and pdf toward a direction on the side it left by.
                    let eval = |wi_world: Vec3| {
                        if wi_world.dot(sp.n_face) <= 0.0 {
                            return (0.0, 0.0);
                        }
                        let wi = frame.to_local(wi_world);
                        let (f, pdf) = sp.bsdf.eval(wo, wi);
                        (f * wi.z, pdf)
                    };
                    let leaving = MediaPath {
                        scatterings: path.scatterings + 1,
                        ..path
                    };
                    rays += self.glow_segment(media, &leaving, &glow, p_out, eval, rng, sink);
                }
            }
            let inside = match boundary {
                Boundary::Surface { inside } | Boundary::IndexMatched { inside } => inside,
            };
            if !self.scatter_surface(media, &sp, &frame, wo, inside, &mut path, rng) {
                break;
            }
        }
        rays
    }

    /// Decide how the path continues along its segment (hit at `t_hit`, light arriving
    /// in the window only from the first `t_window` metres), weighting its throughput.
    ///
    /// Where the medium cannot scatter (clear, purely absorbing, or the bounce limit
    /// reached) the path goes on to the surface with the transmittance as its weight.
    /// Else it passes with probability `q`, when the surface lies inside the window
    /// (weight `T / q`, `T = T(t_hit)`; `q = T`, or boosted on the camera ray, see
    /// [`PASS_BOOST`]), and otherwise scatters at a distance
    /// drawn in proportion to `sigma_t e^(-sigma_t s)` on `[0, min(t_hit, t_window))`
    /// (weight `(1 - e^(-sigma_t span)) (sigma_s / sigma_t) / (1 - q)`): the integral of
    /// `T(s) sigma_s` over the part of the segment whose light can still arrive,
    /// importance sampled.
    #[inline(always)]
    fn continue_segment(
        &self,
        media: &Media,
        path: &mut MediaPath,
        t_hit: f32,
        t_window: f32,
        can_scatter: bool,
        u: f32,
    ) -> Next {
        let region = path.region;
        let reach = t_hit <= t_window;
        let tr_hit = media.transmittance(&region, path.origin, path.dir, t_hit);
        if !can_scatter || region.sigma_t <= 0.0 {
            if !reach || !(tr_hit > 0.0) {
                return Next::End;
            }
            path.throughput *= tr_hit;
            return Next::Surface;
        }
        let camera_ray = path.scatterings == 0 && path.pass_throughs == 0;
        let q = match (reach, camera_ray) {
            (false, _) => 0.0,
            (true, true) => tr_hit.max((PASS_BOOST * tr_hit).min(PASS_MAX)),
            (true, false) => tr_hit,
        };
        if u < q {
            path.throughput *= tr_hit / q;
            return if path.throughput > 0.0 {
                Next::Surface
            } else {
                Next::End
            };
        }
        let u = ((u - q) / (1.0 - q)).clamp(0.0, 1.0 - f32::EPSILON) as f64;
        let span = t_hit.min(t_window) as f64;
        let (d, mass) = media.free_flight(&region, path.origin, path.dir, span, u);
        path.throughput *=
            (mass * (region.sigma_s / region.sigma_t) as f64 / (1.0 - q) as f64) as f32;
        if path.throughput > 0.0 && path.throughput.is_finite() {
            Next::Scatter(d as f32)
        } else {
            Next::End
        }
    }

    /// A scattering event `d_m` along the path's ray: the event counted, next-event
    /// estimation to the emitters (MIS against phase sampling), a new direction from the
    /// phase function, Russian roulette. Returns whether the path goes on, and the rays
    /// traced.
    fn medium_vertex(
        &self,
        media: &Media,
        path: &mut MediaPath,
        d_m: f32,
        rng: &Sampler,
        sink: &mut impl Sink,
    ) -> (bool, u64) {
        let s = self.settings();
        let lights = self.lights();
        let region = path.region;
        let vertex = path.scatterings;
        let slot = |use_| dim::vertex(vertex, use_);
        let x = path.origin + path.dir * d_m;
        path.opl_m += d_m as f64 * region.n as f64;
        // This event is the path's (vertex + 1)-th: light joined to it by next-event
        // estimation, or found by its phase sample, has scattered vertex + 1 times.
        path.scatterings += 1;
        let mut rays = 0;
        if s.nee && lights.has_emitters() {
            let u = rng.get1(slot(dim::EMITTER_SELECT));
            let (u1, u2) = rng.get2(slot(dim::EMITTER_POINT));
            if let Some(es) = lights.sample_emitter(u, u1, u2) {
                let to = es.position - x;
                let d2 = to.length_squared();
                if d2 > 0.0 {
                    let d = d2.sqrt();
                    let wi = to / d;
                    let le = self.surfaces().emission(es.triangle, es.u, es.v, -wi);
                    let cos_l = self.surfaces().geometric_normal(es.triangle).dot(-wi).abs();
                    let f = hg(path.dir.dot(wi), region.g);
                    if le > 0.0 && cos_l > 0.0 && f > 0.0 {
                        let t_max = d - 2.0 * self.offset_m(es.position);
                        if let Some((tr, opl_m)) = self
                            .media_shadow(media, x, wi, t_max, region, path.opl_m, sink, &mut rays)
                        {
                            let pdf_light = es.pdf_area * d2 / cos_l;
                            let w = power_heuristic(pdf_light, f);
                            let value = path.throughput * f * le * w * tr / pdf_light;
                            sink.add(opl_m / C_M_PER_S, value as f64, (vertex + 1) | path.tag);
                        }
                    }
                }
            }
        }
        let dir = sample_hg(path.dir, region.g, rng.get2(slot(dim::BSDF_DIRECTION)));
        let f = hg(path.dir.dot(dir), region.g);
        path.last_pdf = Some(f);
        path.nee_weight = 1.0;
        let glow = Glow::new(x, &lights.punctual, region.g);
        if let Some(glow) = glow.filter(|_| s.nee && path.scatterings < s.max_bounces) {
            let incoming = path.dir;
            let eval = |d: Vec3| {
                let f = hg(incoming.dot(d), region.g);
                (f, f)
            };
            let leaving = MediaPath { origin: x, ..*path };
            rays += self.glow_segment(media, &leaving, &glow, x, eval, rng, sink);
            path.nee_weight = f / (GLOW_SHARE * glow.pdf(dir) + f);
        }
        path.last_position = x;
        path.pass_throughs = 0;
        path.origin = x;
        path.dir = dir;
        // Nothing more can arrive in time when the nearest punctual light is too far
        // for even a straight shadow ray (and there is no emitter to meet on the way).
        if !lights.has_emitters() {
            let end_opl_m = sink.window_end_s() * C_M_PER_S;
            let nearest = lights
                .punctual
                .iter()
                .map(|l| (l.position - x).length())
                .fold(f32::INFINITY, f32::min);
            if path.opl_m + (nearest * media.n_min) as f64 > end_opl_m {
                sink.left_out(LeftOut::PathPastWindow);
                return (false, rays);
            }
        }
        if path.scatterings >= s.rr_start + MEDIA_RR_DELAY {
            let q = path.throughput.min(1.0).max(s.rr_min_survival.min(1.0));
            if !(q > 0.0) || rng.get1(slot(dim::ROULETTE)) >= q {
                return (false, rays);
            }
            path.throughput /= q;
        }
        (path.throughput.is_finite() && path.throughput > 0.0, rays)
    }

    /// The lights' glow at a surface vertex, where the path leaves it in a scattering
    /// medium and next-event estimation is on ([`super::glow`]).
    fn surface_glow<'a>(&'a self, path: &MediaPath, sp: &SurfacePoint) -> Option<Glow<'a>> {
        let region = path.region;
        if !(self.settings().nee && region.sigma_s > 0.0) {
            return None;
        }
        Glow::new(sp.position, &self.lights().punctual, region.g)
    }

    /// The glow technique of a vertex: the single scattering of the punctual lights on a
    /// segment drawn toward their glow ([`super::glow`]), the second technique beside
    /// the segment of the vertex's own direction, combined by the balance heuristic. It
    /// runs with probability `GLOW_SHARE` (its expected sample count), so a direction
    /// `w` of density `p_glow` weighs `f(w) / (GLOW_SHARE p_glow(w) + p_own(w))` and
    /// the own segment's estimate `p_own / (GLOW_SHARE p_glow + p_own)`
    /// ([`MediaPath::nee_weight`]). The path itself does not follow the glow, so the
    /// weights do not multiply along it. `leaving` is the path leaving the vertex
    /// (scatterings counted, throughput up to the vertex), `origin` the segment's start,
    /// `eval(w)` the vertex's `f |cos|` (the phase function in a medium) and own pdf
    /// toward `w`, `f` 0 where the path cannot go. Returns the rays traced.
    #[allow(
        clippy::too_many_arguments,
        reason = "the path walk's per-vertex state, passed by value on the hot path"
    )]
    fn glow_segment(
        &self,
        media: &Media,
        leaving: &MediaPath,
        glow: &Glow,
        origin: Vec3,
        eval: impl Fn(Vec3) -> (f32, f32),
        rng: &Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        let key = ((leaving.scatterings as u64) << 32) + 0x61f0;
        if leaving.scatterings >= self.settings().max_bounces || rng.get1_hashed(key) >= GLOW_SHARE
        {
            return 0;
        }
        let u = (rng.get1_hashed(key + 2), rng.get1_hashed(key + 3));
        let Some(dir) = glow.sample(rng.get1_hashed(key + 1), u) else {
            return 0;
        };
        let (f, pdf_own) = eval(dir);
        let p = GLOW_SHARE * glow.pdf(dir) + pdf_own;
        if !(f > 0.0 && p > 0.0) {
            return 0;
        }
        sink.ray(origin, dir, f32::INFINITY, RayKind::Path);
        let t_hit = self
            .accel()
            .closest_hit(origin, dir, f32::INFINITY)
            .map_or(f32::INFINITY, |h| h.t_m);
        let region = leaving.region;
        let window_end_opl_m = sink.window_end_s() * C_M_PER_S;
        let t_window = ((window_end_opl_m - leaving.opl_m) / region.n as f64) as f32;
        if !(t_window > 0.0) {
            return 1;
        }
        let segment = MediaPath {
            origin,
            dir,
            throughput: leaving.throughput * f / p,
            pass_throughs: 0,
            nee_weight: 1.0,
            ..*leaving
        };
        let u = (rng.get1_hashed(key + 4), rng.get1_hashed(key + 5));
        1 + self.segment_nee(media, &segment, t_hit.min(t_window), u, rng, sink)
    }

    /// Single scattering of every punctual light on the path's segment `[0, span_m)`:
    /// per light, one point drawn inside the gate (the distances whose light arrives in
    /// the window, [`gate`]) from the mixture of the transmittance's and the light's
    /// `1 / r^2` densities, joined to the light by a shadow ray. Returns the rays traced.
    fn segment_nee(
        &self,
        media: &Media,
        path: &MediaPath,
        span_m: f32,
        (u_pick, u_s): (f32, f32),
        rng: &Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        let region = path.region;
        if region.grid.is_some() {
            return self.segment_nee_grid(media, path, span_m, (u_pick, u_s), rng, sink);
        }
        let mut rays = 0;
        let d = path.dir.as_dvec3();
        let exact = media.index_fixed(&region);
        for (i, light) in self.lights().punctual.iter().enumerate() {
            let Some(((u_pick, u_s), w, a, b)) =
                self.light_gate(media, path, i, light, (u_pick, u_s), rng, sink)
            else {
                continue;
            };
            let b = b.min(span_m as f64);
            if !(b > a) {
                sink.left_out(if a >= span_m as f64 && b > 0.0 {
                    LeftOut::ShadowRayEarly
                } else {
                    LeftOut::ShadowRayLate
                });
                continue;
            }
            let sigma_t = region.sigma_t as f64;
            if b.is_infinite() && sigma_t <= 0.0 {
                continue;
            }
            // The transmittance of both legs where the gate is exact, else of the ray's.
            let path_length = if exact {
                PathLength::new(w.to_array(), d.to_array(), a, b, sigma_t)
            } else {
                None
            };
            let exponential = Exponential::new(a, b, sigma_t);
            let transmittance = |s: f64| match &path_length {
                Some(p) => p.pdf(s),
                None => exponential.pdf(s),
            };
            let foot = -w.dot(d);
            let h = (w + d * foot).length();
            let equiangular = Equiangular::new(a, b, foot, h);
            let share = if equiangular.is_some() {
                EQUIANGULAR_SHARE
            } else {
                0.0
            };
            let s_m = match (equiangular, &path_length) {
                (Some(q), _) if (u_pick as f64) < share => q.sample(u_s as f64),
                (_, Some(p)) => p.sample(u_s as f64),
                (_, None) => exponential.sample(u_s as f64),
            };
            let pdf = share * equiangular.map_or(0.0, |q| q.pdf(s_m))
                + (1.0 - share) * transmittance(s_m);
            if !(pdf > 0.0 && pdf.is_finite()) {
                continue;
            }
            let Some((lit, opl_m)) = self.join_light(media, path, light, s_m, sink, &mut rays)
            else {
                continue;
            };
            let t_cam = (-sigma_t * s_m).exp();
            let value =
                (path.throughput * path.nee_weight) as f64 * region.sigma_s as f64 * lit * t_cam
                    / pdf;
            sink.add(opl_m / C_M_PER_S, value, (path.scatterings + 1) | path.tag);
        }
        rays
    }

    /// Light `i`'s part of a segment's single scattering: its uniform numbers (`u`, the
    /// segment's own, for the first light; hashed ones for the others), the vector from the
    /// light to the segment's origin, and the gate `[a, b)`: the distances along the
    /// segment whose light arrives inside the window ([`gate`]; the whole ray where a
    /// shadow ray may change index). `None`, counted as left out, when none can.
    #[allow(
        clippy::too_many_arguments,
        reason = "the path walk's per-vertex state, passed by value on the hot path"
    )]
    fn light_gate(
        &self,
        media: &Media,
        path: &MediaPath,
        i: usize,
        light: &Punctual,
        u: (f32, f32),
        rng: &Sampler,
        sink: &mut impl Sink,
    ) -> Option<((f32, f32), DVec3, f64, f64)> {
        let u = if i == 0 {
            u
        } else {
            let k = ((path.scatterings as u64) << 32) + ((i as u64) << 8) + 0xd7;
            (rng.get1_hashed(k), rng.get1_hashed(k + 1))
        };
        let w = path.origin.as_dvec3() - light.position.as_dvec3();
        if !media.index_fixed(&path.region) {
            return Some((u, w, 0.0, f64::INFINITY));
        }
        let n = path.region.n as f64;
        let k_a = (sink.window_start_s() * C_M_PER_S - path.opl_m) / n;
        let k_b = (sink.window_end_s() * C_M_PER_S - path.opl_m) / n;
        match gate(w.to_array(), path.dir.as_dvec3().to_array(), k_a, k_b) {
            Some((a, b)) => Some((u, w, a, b)),
            None => {
                sink.left_out(LeftOut::ShadowRayLate);
                None
            }
        }
    }

    /// Light scattered toward the eye at the point `s_m` along the path's segment: the
    /// phase function times the light's intensity, its shadow ray's transmittance and
    /// `1 / r^2` (W/sr/m^2 per unit sigma_s, before the eye leg), and the optical path
    /// length at the light; `None` when it is dark, blocked or cannot arrive in time.
    fn join_light(
        &self,
        media: &Media,
        path: &MediaPath,
        light: &Punctual,
        s_m: f64,
        sink: &mut impl Sink,
        rays: &mut u64,
    ) -> Option<(f64, f64)> {
        let x = (path.origin.as_dvec3() + path.dir.as_dvec3() * s_m).as_vec3();
        let to = light.position - x;
        let r2 = to.length_squared();
        if !(r2 > 0.0) {
            return None;
        }
        let r = r2.sqrt();
        let wl = to / r;
        let intensity = light.intensity_toward(-wl);
        // The light travels along -wl, then toward the eye along -dir.
        let f = hg(wl.dot(path.dir), path.region.g);
        if !(intensity > 0.0 && f > 0.0) {
            return None;
        }
        let opl_here = path.opl_m + s_m * path.region.n as f64;
        let (tr, opl_m) = self.media_shadow(media, x, wl, r, path.region, opl_here, sink, rays)?;
        Some(((f * intensity * tr / r2) as f64, opl_m))
    }

    /// Next-event estimation at a surface vertex in media: every punctual light and one
    /// power-sampled point on the emitters (MIS against BSDF sampling), shadow rays
    /// through the media ([`Renderer::media_shadow`]). Returns the rays traced.
    #[allow(
        clippy::too_many_arguments,
        reason = "the path walk's per-vertex state, passed by value on the hot path"
    )]
    fn surface_nee(
        &self,
        media: &Media,
        path: &MediaPath,
        sp: &SurfacePoint,
        frame: &Frame,
        wo: Vec3,
        p_out: Vec3,
        rng: &Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        let lights = self.lights();
        let bsdf: &Bsdf = &sp.bsdf;
        let (p, n_face) = (sp.position, sp.n_face);
        let scatterings = (path.scatterings + 1) | path.tag;
        let mut rays = 0;
        for light in &lights.punctual {
            let to = light.position - p;
            let d2 = to.length_squared();
            if !(d2 > 0.0) {
                continue;
            }
            let d = d2.sqrt();
            let wi = to / d;
            if wi.dot(n_face) <= 0.0 {
                continue;
            }
            let (f, _) = bsdf.eval(wo, frame.to_local(wi));
            let intensity = light.intensity_toward(-wi);
            if f <= 0.0 || intensity <= 0.0 {
                continue;
            }
            let t_max = (light.position - p_out).dot(wi);
            let opl_m = path.opl_m + path.region.n as f64 * (d - t_max).max(0.0) as f64;
            if let Some((tr, opl_m)) =
                self.media_shadow(media, p_out, wi, t_max, path.region, opl_m, sink, &mut rays)
            {
                let cos_i = frame.to_local(wi).z;
                let value = path.throughput * f * cos_i * intensity / d2 * tr;
                sink.add(opl_m / C_M_PER_S, value as f64, scatterings);
            }
        }
        if lights.has_emitters() {
            let u = rng.get1(dim::vertex(path.scatterings, dim::EMITTER_SELECT));
            let (u1, u2) = rng.get2(dim::vertex(path.scatterings, dim::EMITTER_POINT));
            if let Some(es) = lights.sample_emitter(u, u1, u2) {
                let to = es.position - p;
                let d2 = to.length_squared();
                if d2 > 0.0 {
                    let d = d2.sqrt();
                    let wi_world = to / d;
                    let le = self.surfaces().emission(es.triangle, es.u, es.v, -wi_world);
                    let cos_l = self
                        .surfaces()
                        .geometric_normal(es.triangle)
                        .dot(-wi_world)
                        .abs();
                    if le > 0.0 && cos_l > 0.0 && wi_world.dot(n_face) > 0.0 {
                        let wi = frame.to_local(wi_world);
                        let (f, pdf_bsdf) = bsdf.eval(wo, wi);
                        let t_max =
                            (es.position - p_out).dot(wi_world) - 2.0 * self.offset_m(es.position);
                        let opl_m = path.opl_m + path.region.n as f64 * (d - t_max).max(0.0) as f64;
                        if f > 0.0
                            && let Some((tr, opl_m)) = self.media_shadow(
                                media,
                                p_out,
                                wi_world,
                                t_max,
                                path.region,
                                opl_m,
                                sink,
                                &mut rays,
                            )
                        {
                            let pdf_light = es.pdf_area * d2 / cos_l;
                            let w = power_heuristic(pdf_light, pdf_bsdf);
                            let value = path.throughput * f * wi.z * le * w * tr / pdf_light;
                            sink.add(opl_m / C_M_PER_S, value as f64, scatterings);
                        }
                    }
                }
            }
        }
        rays
    }

    /// Sample the BSDF at a surface vertex and step the path onto the new direction
    /// (the medium changing where it refracts), Russian roulette included. Returns
    /// whether the path goes on.
    #[allow(
        clippy::too_many_arguments,
        reason = "the path walk's per-vertex state, passed by value on the hot path"
    )]
    fn scatter_surface(
        &self,
        media: &Media,
        sp: &SurfacePoint,
        frame: &Frame,
        wo: Vec3,
        inside: BandMedium,
        path: &mut MediaPath,
        rng: &Sampler,
    ) -> bool {
        let s = self.settings();
        let slot = |use_| dim::vertex(path.scatterings, use_);
        let bsdf = &sp.bsdf;
        let u_lobe = if bsdf.single_lobe() {
            0.0
        } else {
            rng.get1(slot(dim::LOBE))
        };
        let Some(bs) = bsdf.sample(wo, u_lobe, rng.get2(slot(dim::BSDF_DIRECTION))) else {
            return false;
        };
        let wi_world = frame.to_world(bs.wi);
        let refracted = bs.kind == LobeKind::Refract;
        let geo = wi_world.dot(sp.n_face);
        if (refracted && geo >= 0.0) || (!refracted && geo <= 0.0) {
            return false;
        }
        let u_roulette = slot(dim::ROULETTE);
        path.throughput *= bs.weight;
        path.scatterings += 1;
        if refracted {
            path.region = if sp.front { inside } else { media.scene };
        }
        path.last_pdf = (!bs.is_delta()).then_some(bs.pdf);
        path.nee_weight = match self.surface_glow(path, sp) {
            Some(glow) if !bs.is_delta() && !refracted => {
                bs.pdf / (GLOW_SHARE * glow.pdf(wi_world) + bs.pdf)
            }
            _ => 1.0,
        };
        path.last_position = sp.position;
        path.pass_throughs = 0;
        path.origin = sp.position + sp.n_face * self.offset_m(sp.position) * geo.signum();
        path.dir = wi_world.normalize();
        if path.scatterings >= s.rr_start + MEDIA_RR_DELAY {
            let q = path.throughput.min(1.0).max(s.rr_min_survival.min(1.0));
            if !(q > 0.0) || rng.get1(u_roulette) >= q {
                return false;
            }
            path.throughput /= q;
        }
        path.throughput.is_finite() && path.throughput > 0.0
    }

    /// A shadow ray from `p` along unit `dir` for `dist_m`, starting in `region` with the
    /// eye side's optical path `opl_m` up to `p`: the fraction of light that passes (the
    /// media's transmittance times the partly covered surfaces'), and the optical path
    /// length at the light; `None` when an opaque or refracting surface blocks it, or the
    /// light cannot arrive inside the window (counted as left out, and not traced).
    /// Crossing an index-matched boundary changes the medium.
    #[allow(
        clippy::too_many_arguments,
        reason = "the path walk's per-vertex state, passed by value on the hot path"
    )]
    fn media_shadow(
        &self,
        media: &Media,
        p: Vec3,
        dir: Vec3,
        dist_m: f32,
        region: BandMedium,
        opl_m: f64,
        sink: &mut impl Sink,
        rays: &mut u64,
    ) -> Option<(f32, f64)> {
        let dist = dist_m.max(0.0);
        let (n_lo, n_hi) = if media.has_index_matched {
            (region.n.min(media.n_min), region.n.max(media.n_max))
        } else {
            (region.n, region.n)
        };
        let early = (opl_m + n_hi as f64 * dist as f64) / C_M_PER_S;
        let late = (opl_m + n_lo as f64 * dist as f64) / C_M_PER_S;
        if let Some(why) = outside(sink, late).or_else(|| outside(sink, early)) {
            sink.left_out(why);
            return None;
        }
        if !media.has_index_matched {
            *rays += 1;
            sink.ray(p, dir, dist, RayKind::Shadow);
            let tr = self.transmittance(p, dir, dist) * media.transmittance(&region, p, dir, dist);
            return (tr > 0.0).then_some((tr, opl_m + region.n as f64 * dist as f64));
        }
        // Surface by surface to the end, the medium changing at index-matched boundaries.
        let target = p + dir * dist;
        let (mut origin, mut left, mut region) = (p, dist, region);
        let (mut tr, mut opl) = (1.0f32, opl_m);
        for _ in 0..MAX_PASS_THROUGH {
            *rays += 1;
            sink.ray(origin, dir, left, RayKind::Shadow);
            let Some(hit) = self.accel().closest_hit(origin, dir, left) else {
                tr *= media.transmittance(&region, origin, dir, left);
                opl += region.n as f64 * left as f64;
                return (tr > 0.0).then_some((tr, opl));
            };
            tr *= media.transmittance(&region, origin, dir, hit.t_m);
            opl += region.n as f64 * hit.t_m as f64;
            let material = self
                .scene()
                .attrs
                .get(hit.triangle as usize)
                .map_or(u32::MAX, |a| a.material);
            let normal = self.surfaces().geometric_normal(hit.triangle);
            let front = normal.dot(dir) < 0.0;
            match media.boundary(material) {
                Boundary::IndexMatched { inside } => {
                    region = if front { inside } else { media.scene };
                }
                Boundary::Surface { .. } => {
                    tr *= self
                        .surfaces()
                        .shadow_transmission(hit.triangle, hit.u, hit.v);
                }
            }
            if !(tr > 0.0) {
                return None;
            }
            let at = origin + dir * hit.t_m;
            let n_face = if front { normal } else { -normal };
            origin = at - n_face * self.offset_m(at);
            left = (target - origin).dot(dir);
            if !(left > 0.0) {
                return Some((tr, opl));
            }
        }
        None
    }
}
