//! Directions toward the glow of the punctual lights, for the vertices of a path in a
//! scattering medium: the second technique of a one-sample MIS mixture with the BSDF's
//! or the phase function's own sampling.
//!
//! Seen from a point `y` in a medium, a point light at distance `D` is surrounded by the
//! light its neighbourhood scatters toward `y`: along a direction at angle `alpha` from
//! the light the single-scattered radiance is
//! `L(alpha) ~ sigma_s I / (alpha D) * integral_alpha^pi p(theta) dtheta`
//! (substitute `theta = alpha D / r` along the ray), a `1 / alpha` glow out to about the
//! phase function's width `(1 - g) / sqrt(g)` and `~ alpha^-3` beyond. A direction drawn
//! by the BSDF or the phase function has a density that stays finite at `alpha = 0`, so
//! its weight `L / pdf` grows as `1 / alpha`, whose square integrates to a logarithm over
//! the solid angle: the fireflies of a path that happens to turn toward the lamp through
//! fog (the segment NEE then sees `p` near its g = 0.9 peak of 15 / sr, measured on the
//! race's fog scene). The glow technique draws `alpha` uniformly on `[0, alpha_max]`, a
//! density `1 / (2 pi alpha_max sin alpha)` per steradian, so `L / pdf` stays bounded
//! toward the light. It estimates only the single scattering on the segment it draws
//! (`Renderer::glow_segment` in walk.rs), MIS-weighted against the vertex's own
//! direction; the path goes on along its own direction. (Letting the path follow a
//! mixture of both was tried: its weights `f / pdf_mixture` multiply along a path, and
//! in a dense white medium after dozens of scatterings that product's heavy tail lost
//! two thirds of a furnace's light at 64 spp.) With the roulette started later in media
//! (walk.rs), measured at 256 spp over four seeds against the loop without either: the
//! race's fog scene 6.5x less cube variance for 1.2x the CPU time, builtin:cornell
//! filled with fog (sigma_s 0.5 /m, g 0.9) 4.9x less for 1.8x.

use crate::transport::bsdf::{Frame, turn_cos_sin};
use crate::transport::lights::Punctual;
use glam::Vec3;
use std::f32::consts::PI;

/// Share of a vertex's direction samples drawn toward the lights' glow.
pub(super) const GLOW_SHARE: f32 = 0.3;

/// How many phase-function widths `(1 - g) / sqrt(g)` the glow's cone holds.
const CONE_WIDTHS: f32 = 4.0;

/// The glow's directions from one vertex: a cone about the direction to each punctual
/// light, one light chosen uniformly.
pub(super) struct Glow<'a> {
    from: Vec3,
    lights: &'a [Punctual],
    /// Half-angle of each light's cone, radians.
    alpha_max: f32,
}

impl<'a> Glow<'a> {
    /// The glow seen from `from` in a medium of phase asymmetry `g`; `None` without
    /// punctual lights.
    pub fn new(from: Vec3, lights: &'a [Punctual], g: f32) -> Option<Glow<'a>> {
        if lights.is_empty() {
            return None;
        }
        let width = if g > 0.0 { (1.0 - g) / g.sqrt() } else { PI };
        Some(Glow {
            from,
            lights,
            alpha_max: (CONE_WIDTHS * width).clamp(1e-3, PI),
        })
    }

    /// A unit direction for uniform `u_light` and `(u1, u2)` in [0, 1): a light chosen
    /// uniformly, the angle from it uniform on `[0, alpha_max]`, the azimuth uniform.
    /// `None` when the vertex sits on the light.
    pub fn sample(&self, u_light: f32, (u1, u2): (f32, f32)) -> Option<Vec3> {
        let n = self.lights.len();
        let i = ((u_light * n as f32) as usize).min(n - 1);
        let axis = (self.lights[i].position - self.from).try_normalize()?;
        let alpha = u1 * self.alpha_max;
        let (c, s) = turn_cos_sin(u2);
        let (sin_a, cos_a) = alpha.sin_cos();
        Some(Frame::new(axis).to_world(Vec3::new(sin_a * c, sin_a * s, cos_a)))
    }

    /// The density of [`Glow::sample`] at unit `dir`, 1/sr: the mean over the lights of
    /// `1 / (2 pi alpha_max sin alpha)` inside each one's cone.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        let mut sum = 0.0;
        for light in self.lights {
            let Some(axis) = (light.position - self.from).try_normalize() else {
                continue;
            };
            // The angle from the cross product's length: exact near 0 and pi, where
            // the density's 1 / sin is steep.
            let sin_a = axis.cross(dir).length();
            let alpha = sin_a.atan2(axis.dot(dir));
            if alpha < self.alpha_max {
                sum += 1.0 / (2.0 * PI * self.alpha_max * sin_a.max(1e-7));
            }
        }
        sum / self.lights.len() as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lamp(p: Vec3) -> Punctual {
        Punctual::point_at(p)
    }

    /// The sampled directions have the density `pdf` claims: the fraction landing in
    /// each of a few caps and rings about the lights matches the integral of `pdf` over
    /// it (integrated here on a fine grid in angle, independent of the sampler).
    #[test]
    fn sampled_directions_follow_the_pdf() {
        let lights = [
            lamp(Vec3::new(0.0, 0.0, 5.0)),
            lamp(Vec3::new(3.0, 0.0, 0.0)),
        ];
        let glow = Glow::new(Vec3::ZERO, &lights, 0.8).unwrap();
        let axis = Vec3::Z;
        // Rings about +Z, in angle from it.
        let rings = [(0.0f32, 0.05f32), (0.05, 0.2), (0.2, 0.5), (0.5, 1.2)];
        let n = 400_000;
        let mut hits = [0usize; 4];
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        for _ in 0..n {
            let d = glow.sample(next(), (next(), next())).unwrap();
            assert!((d.length() - 1.0).abs() < 1e-4);
            let a = axis.dot(d).clamp(-1.0, 1.0).acos();
            for (k, &(lo, hi)) in rings.iter().enumerate() {
                if a >= lo && a < hi {
                    hits[k] += 1;
                }
            }
        }
        for (k, &(lo, hi)) in rings.iter().enumerate() {
            // Integral of pdf over the ring: sum over theta (midpoint) and phi.
            let (m_t, m_p) = (2000, 256);
            let mut mass = 0.0f64;
            for i in 0..m_t {
                let t = lo + (hi - lo) * (i as f32 + 0.5) / m_t as f32;
                for j in 0..m_p {
                    let phi = 2.0 * PI * (j as f32 + 0.5) / m_p as f32;
                    let d = Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos());
                    mass += (glow.pdf(d) * t.sin()) as f64;
                }
            }
            mass *= ((hi - lo) / m_t as f32 * 2.0 * PI / m_p as f32) as f64;
            let got = hits[k] as f64 / n as f64;
            let sigma = (mass * (1.0 - mass) / n as f64).sqrt();
            assert!(
                (got - mass).abs() < 5.0 * sigma + 1e-3,
                "ring {k}: {got} vs {mass}"
            );
        }
        // Outside every cone: no density, no samples.
        assert_eq!(glow.pdf(-Vec3::X), 0.0);
    }

    /// Isotropic media get the whole sphere; a vertex on the light has no direction.
    #[test]
    fn cone_widths_and_degenerate_vertices() {
        let lights = [lamp(Vec3::ZERO)];
        let iso = Glow::new(Vec3::X, &lights, 0.0).unwrap();
        assert_eq!(iso.alpha_max, PI);
        assert!(
            iso.pdf(Vec3::Y) > 0.0,
            "the whole sphere is in an isotropic glow"
        );
        let fwd = Glow::new(Vec3::X, &lights, 0.9).unwrap();
        assert!((fwd.alpha_max - 4.0 * 0.1 / 0.9f32.sqrt()).abs() < 1e-5);
        assert!(
            Glow::new(Vec3::ZERO, &lights, 0.9)
                .unwrap()
                .sample(0.5, (0.5, 0.5))
                .is_none()
        );
        assert!(Glow::new(Vec3::ZERO, &[], 0.9).is_none());
    }
}
