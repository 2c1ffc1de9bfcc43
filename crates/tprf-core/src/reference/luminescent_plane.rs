//! The lit plane of [`super::plane`] made luminescent: of the irradiance `E(q)` at a
//! ground point, the albedo `rho` is reflected at once and each decay component `k`
//! re-emits `Y_k E / pi` (Lambertian) with the delay density `e^{-t / tau_k} / tau_k`.
//! So a ground point at distance `q` from the axis's foot sends the camera its direct
//! return `rho E / pi` at `t(q)` plus `sum_k (Y_k E / pi) (1 / tau_k) e^{-(t - t(q)) / tau_k}`
//! for `t > t(q)`. A bin `[a, b)` of a pixel holds the footprint mean of
//! `(E(q) / pi) sum_k Y_k (e^{-max(a - t(q), 0) / tau_k} - e^{-max(b - t(q), 0) / tau_k})`
//! plus the direct return's bin integral ([`Plane::pixel_tprf`]). The footprint integral
//! is split where `t(q)` crosses a bin edge (the integrand's kinks) and each piece
//! integrated as the plane's are. Written from the formula, not from the renderer's
//! decay code.

use super::plane::Plane;
use crate::film::TimeAxis;
use crate::scene::{DecayComponent, Luminescence, Scene};

/// A luminescent lit plane: the plane (its `rho` the base colour) and its decay
/// components `(Y_k, tau_k_s)`.
#[derive(Clone, Debug, PartialEq)]
pub struct LuminescentPlane {
    pub plane: Plane,
    pub components: Vec<(f64, f64)>,
}

impl LuminescentPlane {
    /// The scene: the plane's, its material luminescent (white emission, no rise).
    pub fn scene(&self) -> Scene {
        let mut s = self.plane.scene();
        if let Some(m) = s.materials.first_mut() {
            m.luminescence = Some(Luminescence {
                components: self
                    .components
                    .iter()
                    .map(|&(y, tau)| DecayComponent {
                        yield_: y as f32,
                        lifetime_s: tau,
                    })
                    .collect(),
                rise_s: None,
                emission_color: [1.0; 3],
            });
        }
        s
    }

    /// Expected TPRF of pixel `(x, y)` of a `w x h` image on `axis`: the direct return
    /// plus the re-emission's bin integrals.
    pub fn pixel_tprf(&self, x: usize, y: usize, w: usize, h: usize, axis: &TimeAxis) -> Vec<f64> {
        let mut out = self.plane.pixel_tprf(x, y, w, h, axis);
        let rect = self.plane.pixel_rect(x, y, w, h);
        let (q_lo, q_hi) = rect.radial_range();
        let white = Plane {
            rho: 1.0,
            ..self.plane
        };
        // Kinks of every bin's integrand: the radii where t(q) crosses a bin edge.
        let mut cuts = vec![q_lo, q_hi];
        for b in 0..=axis.bins {
            let t = axis.bin_start_s(b);
            if t > white.arrival_s(q_lo) && t < white.arrival_s(q_hi) {
                cuts.push(white.q_of_arrival(t, q_hi));
            }
        }
        cuts.sort_by(f64::total_cmp);
        let area = rect.area();
        let survival = |x_s: f64| -> f64 {
            self.components
                .iter()
                .map(|&(y, tau)| y * (-x_s.max(0.0) / tau).exp())
                .sum()
        };
        for (b, o) in out.iter_mut().enumerate() {
            let (a, e) = (axis.bin_start_s(b), axis.bin_start_s(b + 1));
            let mut sum = 0.0;
            for seg in cuts.windows(2) {
                sum += rect.radial_integral(seg[0], seg[1], |q| {
                    let t = white.arrival_s(q);
                    // E / pi is the white plane's radiance.
                    white.radiance(q) * (survival(a - t) - survival(e - t))
                });
            }
            *o += sum / area;
        }
        out
    }
}
