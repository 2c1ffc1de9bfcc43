//! Single scattering of the punctual lights on a segment through a heterogeneous medium
//! (the grid's counterpart of [`Renderer::segment_nee`]).

use super::super::distance::Equiangular;
use super::{EQUIANGULAR_SHARE, MediaPath};
use crate::transport::integrator::{Renderer, Sink};
use crate::transport::media::Media;
use crate::transport::sampler::Sampler;
use crate::units::C_M_PER_S;

impl Renderer {
    /// Single scattering of every punctual light on the path's segment `[0, span_m)` in a
    /// density grid: per light, one point of the gate ([`gate`]) clipped to the grid's box,
    /// drawn from a mixture of `sigma_t(s) T(s)` along the ray (inverting the optical depth)
    /// and the light's `1 / r^2` (equiangular), joined to the light by a shadow ray; the
    /// estimate `sigma_s(s) p T(s) T_light I / r^2 / pdf(s)`, with exact transmittances,
    /// times the path's MIS weight against the glow technique (`MediaPath::nee_weight`).
    /// Returns the rays traced.
    pub(super) fn segment_nee_grid(
        &self,
        media: &Media,
        path: &MediaPath,
        span_m: f32,
        (u_pick, u_s): (f32, f32),
        rng: &Sampler,
        sink: &mut impl Sink,
    ) -> u64 {
        let region = path.region;
        let Some(line) = media.grid_line(&region, path.origin, path.dir) else {
            return 0;
        };
        let (box_in, box_out) = line.inside();
        let sigma_t = region.sigma_t as f64;
        let mut rays = 0;
        let d = path.dir.as_dvec3();
        for (i, light) in self.lights().punctual.iter().enumerate() {
            let Some(((u_pick, u_s), w, a, b)) =
                self.light_gate(media, path, i, light, (u_pick, u_s), rng, sink)
            else {
                continue;
            };
            // Outside the box the medium is empty: nothing scatters there.
            let (a, b) = (a.max(box_in), b.min(span_m as f64).min(box_out));
            if !(b > a) {
                continue;
            }
            let tau_a = sigma_t * line.integral(0.0, a);
            let mass = -(-sigma_t * line.integral(a, b)).exp_m1();
            let foot = -w.dot(d);
            let h = (w + d * foot).length();
            let equiangular = Equiangular::new(a, b, foot, h);
            let share = match (equiangular.is_some(), mass > 0.0) {
                (true, true) => EQUIANGULAR_SHARE,
                (true, false) => 1.0,
                (false, true) => 0.0,
                (false, false) => continue,
            };
            let s_m = match equiangular {
                Some(q) if (u_pick as f64) < share => q.sample(u_s as f64),
                _ => {
                    let target = -(-(u_s as f64) * mass).ln_1p() / sigma_t;
                    line.invert(a, b, target).unwrap_or(b).clamp(a, b)
                }
            };
            let density = line.density(s_m);
            if !(density > 0.0) {
                continue;
            }
            let tau_as = sigma_t * line.integral(a, s_m);
            let tracking = if mass > 0.0 {
                sigma_t * density * (-tau_as).exp() / mass
            } else {
                0.0
            };
            let pdf = share * equiangular.map_or(0.0, |q| q.pdf(s_m)) + (1.0 - share) * tracking;
            if !(pdf > 0.0 && pdf.is_finite()) {
                continue;
            }
            let Some((lit, opl_m)) = self.join_light(media, path, light, s_m, sink, &mut rays)
            else {
                continue;
            };
            let t_cam = (-(tau_a + tau_as)).exp();
            let sigma_s = region.sigma_s as f64 * density;
            let value = (path.throughput * path.nee_weight) as f64 * sigma_s * lit * t_cam / pdf;
            sink.add(opl_m / C_M_PER_S, value, (path.scatterings + 1) | path.tag);
        }
        rays
    }
}
