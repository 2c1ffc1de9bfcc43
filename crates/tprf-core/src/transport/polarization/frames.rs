//! Reference frames of Stokes vectors: the implicit frame of a direction, the rotator
//! between two frames about a common direction, and a Mueller matrix re-expressed
//! between frames (Mitsuba 3's `stokes_basis`, `rotator`, `rotated_element`,
//! `rotate_stokes_basis`, `rotate_mueller_basis`).

use super::mueller::Mueller;
use glam::Vec3;

/// The implicit reference `x` of a beam travelling along unit `forward`: the first
/// tangent of Duff et al.'s orthonormal basis ("Building an Orthonormal Basis,
/// Revisited", JCGT 2017; Mitsuba's `coordinate_system(w).first`, the `t` of the
/// shading frame `transport::bsdf::Frame`): `(1 + s x^2 a, s x y a, -s x)` with `s =
/// sign(z)`, `a = -1 / (s + z)`. Its `y` is `forward x x`.
#[inline]
pub fn stokes_basis(forward: Vec3) -> Vec3 {
    let sign = 1.0f32.copysign(forward.z);
    let a = -1.0 / (sign + forward.z);
    let b = forward.x * forward.y * a;
    Vec3::new(
        1.0 + sign * forward.x * forward.x * a,
        sign * b,
        -sign * forward.x,
    )
}

/// The Mueller matrix that re-expresses a Stokes vector in a frame turned by `theta_rad`
/// about the direction of travel, counter-clockwise as the observer (looking back along
/// the beam) sees it: `[1 0 0 0; 0 c s 0; 0 -s c 0; 0 0 0 1]` with `(c, s) = (cos 2
/// theta, sin 2 theta)` (Collett ch. 5 eq. 43; Mitsuba's `rotator`). Light polarized
/// along the old `x`, `(1, 1, 0, 0)`, reads `(1, cos 2 theta, -sin 2 theta, 0)` in the
/// new frame: its angle, measured from the new `x`, is `-theta`.
#[inline]
pub fn rotator(theta_rad: f32) -> Mueller {
    let (s, c) = (2.0 * theta_rad).sin_cos();
    Mueller([
        [1.0, 0.0, 0.0, 0.0],
        [0.0, c, s, 0.0],
        [0.0, -s, c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ])
}

/// Element `m` turned by `theta_rad` counter-clockwise about the beam (Mitsuba's
/// `rotated_element`: `R(theta)^T M R(theta)`): a polarizer along `x` becomes one at
/// `theta` from `x`.
pub fn rotated_element(theta_rad: f32, m: &Mueller) -> Mueller {
    let r = rotator(theta_rad);
    r.transpose() * *m * r
}

/// The rotator taking a Stokes vector expressed with reference `basis_current` to the
/// same light expressed with reference `basis_target` (both unit, orthogonal to unit
/// `forward`, the direction of travel): `rotator(theta)`, `theta` the angle from current
/// to target, positive when `forward . (current x target) > 0` (Mitsuba's
/// `rotate_stokes_basis`).
#[inline]
pub fn rotate_stokes_basis(forward: Vec3, basis_current: Vec3, basis_target: Vec3) -> Mueller {
    let cos = basis_current.dot(basis_target).clamp(-1.0, 1.0);
    let sin = forward.dot(basis_current.cross(basis_target));
    // atan2 keeps the angle accurate near 0 and pi, where acos loses it.
    rotator(sin.atan2(cos))
}

/// `m`, an element taking light travelling along `in_forward` in frame `in_current` to
/// light along `out_forward` in frame `out_current`, re-expressed from frame `in_target`
/// to frame `out_target`: `R_out M R_in^T` (Mitsuba's `rotate_mueller_basis`).
pub fn rotate_mueller_basis(
    m: &Mueller,
    in_forward: Vec3,
    in_current: Vec3,
    in_target: Vec3,
    out_forward: Vec3,
    out_current: Vec3,
    out_target: Vec3,
) -> Mueller {
    let r_in = rotate_stokes_basis(in_forward, in_current, in_target);
    let r_out = rotate_stokes_basis(out_forward, out_current, out_target);
    r_out * *m * r_in.transpose()
}

#[cfg(test)]
mod tests {
    use super::super::stokes::Stokes;
    use super::*;

    /// Linear light along a fixed direction `e`, described in two frames about the same
    /// beam: its angle in each frame is measured geometrically, `atan2(e . y, e . x)` with
    /// `y = forward x x`, and the Stokes vector from one frame, rotated into the other, is
    /// the one of the angle measured there.
    #[test]
    fn changing_frames_matches_the_geometric_angle() {
        for forward in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
            Vec3::new(-0.9, 0.1, -0.2).normalize(),
        ] {
            let x0 = stokes_basis(forward);
            let y0 = forward.cross(x0);
            assert!(x0.dot(forward).abs() < 1e-6 && (x0.length() - 1.0).abs() < 1e-6);
            for (k, e_angle) in [0.1f32, 0.9, 2.0, -1.3].into_iter().enumerate() {
                let e = x0 * e_angle.cos() + y0 * e_angle.sin();
                let target_angle = [0.7f32, -2.5, 3.0, 1.57][k];
                let x1 = x0 * target_angle.cos() + y0 * target_angle.sin();
                let y1 = forward.cross(x1);
                let psi0 = e.dot(y0).atan2(e.dot(x0));
                let psi1 = e.dot(y1).atan2(e.dot(x1));
                let s0 = Stokes::linear(1.0, psi0);
                let s1 = rotate_stokes_basis(forward, x0, x1).apply(s0);
                let expected = Stokes::linear(1.0, psi1);
                for i in 0..4 {
                    assert!(
                        (s1.0[i] - expected.0[i]).abs() < 1e-5,
                        "forward {forward}, e {e_angle}, frame {target_angle}: {s1:?} vs {expected:?}"
                    );
                }
            }
        }
    }

    /// Mitsuba's documented examples: horizontal light `(1, 1, 0, 0)` after a +45 deg
    /// rotator reads `(1, 0, -1, 0)`; in basis `(1, 0, 0)` it reads `(1, 0, 1, 0)` in basis
    /// `(1, -1, 0) / sqrt 2` (beam along +z).
    #[test]
    fn rotator_matches_mitsubas_examples() {
        let h = Stokes([1.0, 1.0, 0.0, 0.0]);
        let r = rotator(std::f32::consts::FRAC_PI_4).apply(h);
        assert!(
            (r.0[1]).abs() < 1e-6 && (r.0[2] + 1.0).abs() < 1e-6,
            "{r:?}"
        );
        let t =
            rotate_stokes_basis(Vec3::Z, Vec3::X, Vec3::new(1.0, -1.0, 0.0).normalize()).apply(h);
        assert!(
            (t.0[1]).abs() < 1e-6 && (t.0[2] - 1.0).abs() < 1e-6,
            "{t:?}"
        );
    }

    /// Mitsuba's numbers (3.9.1, `llvm_ad_mono_polarized`): `mi.mueller.stokes_basis(f)`
    /// for `f = normalize(0.3, -0.5, 0.8)`, and `rotate_stokes_basis(f, that basis,
    /// normalize(f x (0, 1, 0)))` (the rotation mitransient's `stokes` integrator applies
    /// into the camera's frame).
    #[test]
    fn basis_and_rotation_match_mitsubas_numbers() {
        let f = Vec3::new(0.3, -0.5, 0.8).normalize();
        let b = stokes_basis(f);
        let want = Vec3::new(0.949_208_8, 0.084_652_04, -0.303_045_75);
        assert!((b - want).length() < 1e-6, "{b} vs {want}");
        let r = rotate_stokes_basis(f, b, f.cross(Vec3::Y).normalize());
        let (c, s) = (0.980_759_9f32, 0.195_217_9f32);
        let want = [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, c, -s, 0.0],
            [0.0, s, c, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ];
        for (got, want) in r.0.iter().flatten().zip(want.iter().flatten()) {
            assert!((got - want).abs() < 1e-5, "{r:?}");
        }
    }

    /// Turning the frame by `theta` turns `(S1, S2)` by `-2 theta` (the light turns by
    /// `+2 theta` relative to a frame turned by `-theta`), keeps `S0`, `S3` and the
    /// degree of polarization, and `R(a) R(b) = R(a + b)`.
    #[test]
    fn rotation_turns_s1_s2_by_twice_the_angle() {
        let s = Stokes([1.0, 0.3, -0.5, 0.2]);
        for theta in [-2.0f32, -0.4, 0.0, 0.3, 1.1, 3.0] {
            let r = rotator(theta).apply(s);
            let (sin2, cos2) = (2.0 * -theta).sin_cos();
            let (e1, e2) = (cos2 * 0.3 - sin2 * -0.5, sin2 * 0.3 + cos2 * -0.5);
            assert!(
                (r.0[1] - e1).abs() < 1e-6 && (r.0[2] - e2).abs() < 1e-6,
                "{theta}: {r:?} vs ({e1}, {e2})"
            );
            assert_eq!((r.0[0], r.0[3]), (1.0, 0.2));
            let ab = rotator(theta) * rotator(0.37);
            let sum = rotator(theta + 0.37);
            for (a, b) in ab.0.iter().flatten().zip(sum.0.iter().flatten()) {
                assert!((a - b).abs() < 1e-5);
            }
        }
    }
}
