//! Light-vertex connections: a second way to sample the paths `eye ... x -> y -> light`
//! that end at a punctual light, for scenes where a light close to a wall makes a bright
//! spot.
//!
//! The path tracer finds `y` by sampling the BSDF at `x` and then connects `y` to the
//! light (next-event estimation): its estimate carries the light's `1 / r^2` at `y`, so
//! the few directions from `x` that land in the spot next to a light carry most of the
//! variance of the second bounce. Here `y` is found from the light instead: a ray from a
//! punctual light (picked by power, direction uniform in its cone) hits `y`, and the eye
//! vertex `x` is joined to `y` by a shadow ray. The density of `y` is then
//! `p_B = p(light, dir) cos_y' / r^2`, which cancels the `1 / r^2`; it is poor where `x`
//! and `y` are close (`1 / d^2`), where BSDF sampling is good. The two are combined with
//! the power heuristic (Veach's multiple importance sampling), the path tracer's side
//! weighted in [`Renderer::next_event`]'s punctual term with
//! [`connected_weight`], so every weight pair sums to 1 and the sum is
//! unbiased. This is bidirectional path tracing's strategy with one light vertex, one
//! per camera sample, shared by every eye vertex that connects to it.
//!
//! Time: the path's optical length is the eye side's `opl_m`, plus `d(x, y)` and
//! `r = d(y, light)` in air (connections are made only from vertices in air).

use super::bsdf::{Bsdf, Frame};
use super::integrator::{RayKind, Renderer, Sink, outside, power_heuristic};
use super::lights::Lights;
use super::sampler::{Sampler, dim};
use crate::units::C_M_PER_S;
use glam::Vec3;

/// Largest number of straight pass-throughs of a light vertex's ray.
const MAX_PASS_THROUGH: u32 = 1024;

/// A point `y` on a surface lit straight by a punctual light, found from the light.
#[derive(Clone, Copy, Debug)]
pub(super) struct LightVertex {
    position: Vec3,
    /// Geometric normal on the light's side.
    n_face: Vec3,
    frame: Frame,
    bsdf: Bsdf,
    /// Unit direction from `y` to the light, local to `frame`.
    to_light_local: Vec3,
    /// `I cos_s / (p cos_g)`: the light's intensity toward `y` over the density of
    /// picking the light and its direction, times the shading over the geometric cosine
    /// at `y` (1 for flat shading), W.
    weight_w: f32,
    /// Area density of `y` under this sampling, `p cos_g / r^2`, 1/m^2.
    pdf_area: f32,
    /// Distance from the light, metres.
    r_m: f32,
}

/// The light vertex of a camera sample: not drawn yet, or drawn (`None` when its ray
/// left the scene or met no surface that scatters smoothly).
pub(super) type LazyLightVertex = Option<Option<LightVertex>>;

/// One eye vertex about to be connected: the surface point and its outgoing direction.
pub(super) struct EyeVertex<'a> {
    pub bsdf: &'a Bsdf,
    pub frame: &'a Frame,
    /// Outgoing direction (toward the previous vertex), local to `frame`.
    pub wo: Vec3,
    pub position: Vec3,
    /// Where its shadow rays start (offset along `n_face`).
    pub position_out: Vec3,
    /// Geometric normal on the side the path arrived from.
    pub n_face: Vec3,
    /// Eye-side optical path length to this vertex, metres.
    pub opl_m: f64,
    /// Throughput times the sample share of the path at this vertex.
    pub throughput: f32,
    /// Scattering events before this vertex.
    pub scatterings: u32,
    /// [`crate::film::RE_EMITTED`] when a luminescent surface re-emitted the path, else 0.
    pub tag: u32,
    /// How many BSDF samples leave this vertex (the split's branches, else 1): the
    /// path tracer's strategy counts that many times in the heuristic.
    pub bsdf_samples: f32,
}

/// The weight of the path tracer's next-event term at `y` for punctual light `light`,
/// when the path reached `y` by a BSDF sample from a vertex that connects to light
/// vertices: `bsdf_pdf_area` is that sample's density of `y` (per unit area, times the
/// BSDF samples leaving the vertex), `to_light` the unit direction from `y` to the light
/// at distance `r_m`, `n_face` the geometric normal at `y`. Power heuristic against
/// [`LightVertex::pdf_area`] of the same `y`.
#[inline]
pub(super) fn connected_weight(
    lights: &Lights,
    light: usize,
    bsdf_pdf_area: f32,
    to_light: Vec3,
    r_m: f32,
    n_face: Vec3,
) -> f32 {
    let pdf_light =
        lights.emission_pdf(light, -to_light) * n_face.dot(to_light).abs() / (r_m * r_m);
    power_heuristic(bsdf_pdf_area, pdf_light)
}

impl Renderer {
    /// Draw a light vertex: a punctual light by power, a direction in its cone, the first
    /// surface its ray stops at (partly covered surfaces are passed with the uncovered
    /// fraction's probability). Draws from the sample's slots of vertex `vertex`. Returns
    /// the vertex (if any) and the rays traced.
    pub(super) fn light_vertex(
        &self,
        lights: &Lights,
        vertex: u32,
        rng: &Sampler,
        sink: &mut impl Sink,
    ) -> (Option<LightVertex>, u64) {
        let u = rng.get1(dim::vertex(vertex, dim::LIGHT_SELECT));
        let u2 = rng.get2(dim::vertex(vertex, dim::LIGHT_DIRECTION));
        let Some(e) = lights.sample_emission(u, u2) else {
            return (None, 0);
        };
        let light_pos = lights.punctual[e.light].position;
        let mut origin = light_pos;
        let mut rays = 0;
        for pass in 0..=MAX_PASS_THROUGH {
            rays += 1;
            sink.ray(origin, e.dir, f32::INFINITY, RayKind::Path);
            let Some(hit) = self.accel().closest_hit(origin, e.dir, f32::INFINITY) else {
                return (None, rays);
            };
            let sp = self.surfaces().at(&hit, origin, e.dir);
            if sp.coverage < 1.0
                && rng.get1_hashed((1 << 32) + ((vertex as u64) << 16) + pass as u64) >= sp.coverage
            {
                origin = sp.position - sp.n_face * self.offset_m(sp.position);
                continue;
            }
            if !sp.bsdf.has_smooth_lobe() {
                return (None, rays);
            }
            let to_light = light_pos - sp.position;
            let r2 = to_light.length_squared();
            let r_m = r2.sqrt();
            let to_light = to_light / r_m;
            let cos_g = sp.n_face.dot(to_light);
            let frame = Frame::new(sp.n_shading);
            let to_light_local = frame.to_local(to_light);
            if !(cos_g > 1e-6 && r2 > 0.0 && to_light_local.z > 0.0) {
                return (None, rays);
            }
            let vertex = LightVertex {
                position: sp.position,
                n_face: sp.n_face,
                frame,
                bsdf: sp.bsdf,
                to_light_local,
                weight_w: e.intensity_w_per_sr / e.pdf * to_light_local.z / cos_g,
                pdf_area: e.pdf * cos_g / r2,
                r_m,
            };
            return (vertex.weight_w.is_finite().then_some(vertex), rays);
        }
        (None, rays)
    }

    /// Join eye vertex `x` to light vertex `y` by a shadow ray: the path `x -> y ->
    /// light`, weighted by the power heuristic against `x`'s BSDF sampling of `y`,
    /// arrives at `(opl_m + d + r) / c` after `scatterings + 2` events. Returns the rays
    /// traced (0 or 1).
    pub(super) fn connect(&self, x: &EyeVertex, y: &LightVertex, sink: &mut impl Sink) -> u64 {
        let to = y.position - x.position;
        let d2 = to.length_squared();
        if !(d2 > 0.0) {
            return 0;
        }
        let d = d2.sqrt();
        let w = to / d;
        let cos_y = -y.n_face.dot(w);
        if w.dot(x.n_face) <= 0.0 || cos_y <= 0.0 {
            return 0;
        }
        let wi = x.frame.to_local(w);
        let (f_x, pdf_x) = x.bsdf.eval(x.wo, wi);
        if !(f_x > 0.0 && wi.z > 0.0) {
            return 0;
        }
        let (f_y, _) = y.bsdf.eval(y.frame.to_local(-w), y.to_light_local);
        if !(f_y > 0.0) {
            return 0;
        }
        let light_leg_m = self.light_leg_opl_m(y.r_m as f64);
        let arrival_s = (x.opl_m + d as f64 + light_leg_m) / C_M_PER_S;
        if let Some(why) = outside(sink, arrival_s) {
            sink.left_out(why);
            return 0;
        }
        let bsdf_pdf_area = x.bsdf_samples * pdf_x * cos_y / d2;
        let mis = power_heuristic(y.pdf_area, bsdf_pdf_area);
        let value = x.throughput * f_x * wi.z * cos_y / d2 * f_y * y.weight_w * mis;
        if !(value > 0.0 && value.is_finite()) {
            return 0;
        }
        let t_max = (y.position - x.position_out).dot(w) - 2.0 * self.offset_m(y.position);
        sink.ray(x.position_out, w, t_max, RayKind::Shadow);
        let tr = self.transmittance(x.position_out, w, t_max);
        if tr > 0.0 {
            sink.add(arrival_s, (value * tr) as f64, (x.scatterings + 2) | x.tag);
        }
        1
    }
}
