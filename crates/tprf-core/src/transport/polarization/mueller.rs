//! Mueller matrices: how an element changes a Stokes vector, `S_out = M S_in`, and the
//! ideal elements of Mitsuba 3's `mueller.h` (depolarizer, linear polarizer,
//! diattenuator, linear retarder).

use super::stokes::Stokes;
use std::ops::{Add, Mul};

/// A 4x4 Mueller matrix, row-major: `self.0[row][column]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mueller(pub [[f32; 4]; 4]);

impl Mueller {
    pub const IDENTITY: Mueller = Mueller([
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]);

    pub const ZERO: Mueller = Mueller([[0.0; 4]; 4]);

    /// A scalar attenuation `value` (Mitsuba's `absorber`): `value` times the identity.
    pub fn absorber(value: f32) -> Mueller {
        Mueller::IDENTITY * value
    }

    /// An ideal depolarizer passing `value` of the intensity: only `M00 = value` (Mitsuba's
    /// `depolarizer`). What a diffuse surface does.
    pub fn depolarizer(value: f32) -> Mueller {
        let mut m = Mueller::ZERO;
        m.0[0][0] = value;
        m
    }

    /// A linear polarizer transmitting the field along the frame's `x`, with transmittance
    /// `value` along it (1: ideal). Collett, "Polarized Light", ch. 5 eq. (13); Mitsuba's
    /// `linear_polarizer`: `value / 2` in the top-left 2x2 block.
    pub fn linear_polarizer(value: f32) -> Mueller {
        let a = 0.5 * value;
        let mut m = Mueller::ZERO;
        m.0[0][0] = a;
        m.0[0][1] = a;
        m.0[1][0] = a;
        m.0[1][1] = a;
        m
    }

    /// A linear diattenuator of intensity transmittances `x` along the frame's `x` and `y`
    /// along its `y` (Mitsuba's `diattenuator`, whose comment calls them field
    /// attenuations; its matrix is the one of intensity transmittances):
    /// `[(x+y)/2, (x-y)/2, 0, 0; (x-y)/2, (x+y)/2, 0, 0; 0, 0, sqrt(xy), 0; 0, 0, 0,
    /// sqrt(xy)]`. `linear_polarizer(v)` is `diattenuator(v, 0)`; a polarizer of
    /// extinction ratio `r` is `diattenuator(1, 1 / r)`.
    pub fn diattenuator(x: f32, y: f32) -> Mueller {
        let (a, b, c) = (0.5 * (x + y), 0.5 * (x - y), (x * y).max(0.0).sqrt());
        Mueller([
            [a, b, 0.0, 0.0],
            [b, a, 0.0, 0.0],
            [0.0, 0.0, c, 0.0],
            [0.0, 0.0, 0.0, c],
        ])
    }

    /// A linear retarder with its fast axis along `x` and phase difference `phase_rad`
    /// between fast and slow axes (Goldstein, "Polarized Light", 3rd ed., eq. 6.43;
    /// Mitsuba's `linear_retarder`): a quarter-wave plate is `pi / 2`.
    pub fn linear_retarder(phase_rad: f32) -> Mueller {
        let (s, c) = phase_rad.sin_cos();
        Mueller([
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, c, s],
            [0.0, 0.0, -s, c],
        ])
    }

    pub fn transpose(&self) -> Mueller {
        Mueller(std::array::from_fn(|r| {
            std::array::from_fn(|c| self.0[c][r])
        }))
    }

    /// `M S`.
    #[inline]
    pub fn apply(&self, s: Stokes) -> Stokes {
        Stokes(std::array::from_fn(|r| {
            (0..4).map(|c| self.0[r][c] * s.0[c]).sum()
        }))
    }

    /// The first column, `M (1, 0, 0, 0)`: what the element makes of unit unpolarized
    /// light.
    pub fn first_column(&self) -> Stokes {
        Stokes(std::array::from_fn(|r| self.0[r][0]))
    }
}

impl Mul for Mueller {
    type Output = Mueller;
    #[inline]
    fn mul(self, o: Mueller) -> Mueller {
        Mueller(std::array::from_fn(|r| {
            std::array::from_fn(|c| (0..4).map(|k| self.0[r][k] * o.0[k][c]).sum())
        }))
    }
}

impl Mul<f32> for Mueller {
    type Output = Mueller;
    #[inline]
    fn mul(self, s: f32) -> Mueller {
        Mueller(self.0.map(|row| row.map(|v| v * s)))
    }
}

impl Add for Mueller {
    type Output = Mueller;
    fn add(self, o: Mueller) -> Mueller {
        Mueller(std::array::from_fn(|r| {
            std::array::from_fn(|c| self.0[r][c] + o.0[r][c])
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::super::frames::rotated_element;
    use super::*;

    /// Malus's law: unpolarized light of unit intensity through an ideal polarizer keeps
    /// 1/2; through a second one at `theta` to the first, `cos^2 theta / 2` remains, and a
    /// third at 90 deg to the first passes `cos^2 theta sin^2 theta / 2`.
    #[test]
    fn polarizer_chain_obeys_malus() {
        let first = Mueller::linear_polarizer(1.0);
        let light = first.apply(Stokes::unpolarized(1.0));
        assert_eq!(light.0, [0.5, 0.5, 0.0, 0.0]);
        for deg in [0.0f32, 10.0, 30.0, 45.0, 60.0, 89.0, 90.0, 135.0] {
            let theta = deg.to_radians();
            let second = rotated_element(theta, &first);
            let out = second.apply(light);
            let malus = 0.5 * theta.cos().powi(2);
            assert!(
                (out.0[0] - malus).abs() < 1e-6,
                "{deg} deg: {out:?} vs {malus}"
            );
            // The light leaving the second polarizer is linear along its axis.
            if out.0[0] > 1e-4 {
                assert!((out.dolp() - 1.0).abs() < 1e-4, "{deg}: {out:?}");
                let d = (out.aolp_rad() - theta).rem_euclid(std::f32::consts::PI);
                assert!(
                    d < 1e-4 || std::f32::consts::PI - d < 1e-4,
                    "{deg}: {out:?}"
                );
            }
            let third = rotated_element(std::f32::consts::FRAC_PI_2, &first);
            let three = (third * second * first).apply(Stokes::unpolarized(1.0));
            let expected = 0.5 * theta.cos().powi(2) * theta.sin().powi(2);
            assert!((three.0[0] - expected).abs() < 1e-6, "{deg}: {three:?}");
        }
    }

    /// A half-wave plate at 45 deg turns horizontal light vertical; a quarter-wave plate at
    /// 45 deg makes it circular (`|S3| = S0`); a diattenuator of equal transmittances is
    /// an absorber.
    #[test]
    fn retarders_and_diattenuators() {
        let h = Stokes::linear(1.0, 0.0);
        let half = rotated_element(
            std::f32::consts::FRAC_PI_4,
            &Mueller::linear_retarder(std::f32::consts::PI),
        );
        let v = half.apply(h);
        assert!((v.0[1] + 1.0).abs() < 1e-6 && v.0[2].abs() < 1e-6, "{v:?}");
        let quarter = rotated_element(
            std::f32::consts::FRAC_PI_4,
            &Mueller::linear_retarder(std::f32::consts::FRAC_PI_2),
        );
        let c = quarter.apply(h);
        assert!(
            (c.0[3].abs() - 1.0).abs() < 1e-6 && c.0[1].abs() < 1e-6,
            "{c:?}"
        );
        assert_eq!(Mueller::diattenuator(0.3, 0.3), Mueller::absorber(0.3));
        assert_eq!(
            Mueller::diattenuator(0.7, 0.0),
            Mueller::linear_polarizer(0.7)
        );
    }
}
