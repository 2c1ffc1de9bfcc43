//! Stokes vectors: the polarization state of a beam in its reference frame (see the
//! module's conventions).

use std::ops::{Add, AddAssign, Mul};

/// `(S0, S1, S2, S3)`: total, linear along `x` minus along `y`, linear at +45 deg minus
/// at -45 deg, right minus left circular. Same unit as `S0` (radiance, a bin's integral,
/// a path weight).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stokes(pub [f32; 4]);

impl Stokes {
    /// Unpolarized light of intensity `s0`.
    pub const fn unpolarized(s0: f32) -> Stokes {
        Stokes([s0, 0.0, 0.0, 0.0])
    }

    /// Fully linearly polarized light of intensity `s0`, its field along
    /// `cos(psi) x + sin(psi) y` (`psi_rad` from the frame's `x` towards its `y`):
    /// `(s0, s0 cos 2 psi, s0 sin 2 psi, 0)`.
    pub fn linear(s0: f32, psi_rad: f32) -> Stokes {
        let (s, c) = (2.0 * psi_rad).sin_cos();
        Stokes([s0, s0 * c, s0 * s, 0.0])
    }

    pub fn s0(&self) -> f32 {
        self.0[0]
    }

    /// The polarized intensity `sqrt(S1^2 + S2^2 + S3^2)`.
    pub fn polarized_intensity(&self) -> f32 {
        let [_, s1, s2, s3] = self.0;
        (s1 * s1 + s2 * s2 + s3 * s3).sqrt()
    }

    /// Degree of polarization `sqrt(S1^2 + S2^2 + S3^2) / S0` (0 for `S0 <= 0`).
    pub fn dop(&self) -> f32 {
        if self.0[0] > 0.0 {
            self.polarized_intensity() / self.0[0]
        } else {
            0.0
        }
    }

    /// Degree of linear polarization `sqrt(S1^2 + S2^2) / S0` (0 for `S0 <= 0`).
    pub fn dolp(&self) -> f32 {
        let [s0, s1, s2, _] = self.0;
        if s0 > 0.0 {
            (s1 * s1 + s2 * s2).sqrt() / s0
        } else {
            0.0
        }
    }

    /// Angle of linear polarization `atan2(S2, S1) / 2`, radians in (-pi/2, pi/2], from
    /// the frame's `x` towards its `y`.
    pub fn aolp_rad(&self) -> f32 {
        0.5 * self.0[2].atan2(self.0[1])
    }

    /// Whether `S0 >= sqrt(S1^2 + S2^2 + S3^2)` within `tolerance` (in the unit of `S0`):
    /// a physical state.
    pub fn is_physical(&self, tolerance: f32) -> bool {
        self.0[0] + tolerance >= self.polarized_intensity()
    }
}

impl Add for Stokes {
    type Output = Stokes;
    fn add(self, o: Stokes) -> Stokes {
        Stokes(std::array::from_fn(|i| self.0[i] + o.0[i]))
    }
}

impl AddAssign for Stokes {
    fn add_assign(&mut self, o: Stokes) {
        *self = *self + o;
    }
}

impl Mul<f32> for Stokes {
    type Output = Stokes;
    fn mul(self, s: f32) -> Stokes {
        Stokes(self.0.map(|v| v * s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_states_have_unit_dolp_and_their_angle() {
        for psi in [-1.2f32, -0.3, 0.0, 0.4, 0.78, 1.5] {
            let s = Stokes::linear(2.0, psi);
            assert!((s.dolp() - 1.0).abs() < 1e-6 && s.is_physical(1e-6));
            // The angle comes back modulo pi.
            let d = (s.aolp_rad() - psi).rem_euclid(std::f32::consts::PI);
            assert!(
                d < 1e-5 || (std::f32::consts::PI - d) < 1e-5,
                "{psi}: {s:?}"
            );
        }
        let u = Stokes::unpolarized(3.0);
        assert_eq!((u.dolp(), u.dop()), (0.0, 0.0));
        assert!(!Stokes([1.0, 0.8, 0.7, 0.0]).is_physical(1e-3));
        // Mixing two orthogonal states of equal power depolarizes.
        let m = Stokes::linear(1.0, 0.3) + Stokes::linear(1.0, 0.3 + std::f32::consts::FRAC_PI_2);
        assert!(m.dolp() < 1e-6, "{m:?}");
    }
}
