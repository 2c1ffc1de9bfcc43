//! Single scattering of the punctual lights on a segment through a heterogeneous medium
//! (the grid's counterpart of [`Renderer::segment_nee`]).

use super::super::distance::{Equiangular, gate};
use super::{EQUIANGULAR_SHARE, MediaPath};
use crate::film::LeftOut;
use crate::transport::integrator::{Renderer, Sink};
use crate::transport::media::Media;
use crate::transport::media::phase::hg;
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
        let c = C_M_PER_S;
        let o = path.origin.as_dvec3();
        let d = path.dir.as_dvec3();
        let exact =
            !media.has_index_matched || (media.n_min == region.n && media.n_max == region.n);
        let n = region.n as f64;
        let k_a = (sink.window_start_s() * c - path.opl_m) / n;
        let k_b = (sink.window_end_s() * c - path.opl_m) / n;
        for (i, light) in self.lights().punctual.iter().enumerate() {
            let (u_pick, u_s) = if i == 0 {
                (u_pick, u_s)
            } else {
                let k = ((path.scatterings as u64) << 32) + ((i as u64) << 8) + 0xd7;
                (rng.get1_hashed(k), rng.get1_hashed(k + 1))
            };
            let w = o - light.position.as_dvec3();
            let (a, b) = if exact {
                match gate(w.to_array(), d.to_array(), k_a, k_b) {
                    Some(g) => g,
                    None => {
                        sink.left_out(LeftOut::ShadowRayLate);
                        continue;
                    }
                }
            } else {
                (0.0, f64::INFINITY)
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
            let x = (o + d * s_m).as_vec3();
            let to = light.position - x;
            let r2 = to.length_squared();
            if !(r2 > 0.0) {
                continue;
            }
            let r = r2.sqrt();
            let wl = to / r;
            let intensity = light.intensity_toward(-wl);
            let f = hg(wl.dot(path.dir), region.g);
            if !(intensity > 0.0 && f > 0.0) {
                continue;
            }
            let opl_here = path.opl_m + s_m * n;
            let Some((tr, opl_m)) =
                self.media_shadow(media, x, wl, r, region, opl_here, sink, &mut rays)
            else {
                continue;
            };
            let t_cam = (-(tau_a + tau_as)).exp();
            let sigma_s = region.sigma_s as f64 * density;
            let value = (path.throughput * path.nee_weight) as f64
                * sigma_s
                * (f * intensity * tr / r2) as f64
                * t_cam
                / pdf;
            sink.add(opl_m / C_M_PER_S, value, path.scatterings + 1);
        }
        rays
    }
}
