//! The camera: a pinhole, its field of view along one of the image's axes, and where a
//! path's clock starts ([`TimeOrigin`]).
//!
//! A field of view belongs to an axis, as in the file that gave it: glTF's `yfov` is
//! vertical, Mitsuba's `fov` is along its `fov_axis` (horizontal by default). The other
//! axis follows from the film's aspect, so a film of another size keeps the angle along
//! that axis (Mitsuba's rule for any film size).

use super::TimeOrigin;
use glam::{Affine3A, Vec3};

/// Mitsuba's default `near_clip`, metres: the near plane of cameras whose file gives
/// none (built-in scenes, framed cameras).
pub const DEFAULT_NEAR_M: f32 = 0.01;

/// A pinhole camera. `world_from_camera` maps camera space (-Z forward, +Y up, glTF) to
/// world space; it has no scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub world_from_camera: Affine3A,
    /// Field of view in radians, measured along `fov_axis` of the image.
    pub fov_rad: f32,
    pub fov_axis: FovAxis,
    /// Distance of the near clip plane from the pinhole, metres (glTF `znear`, Mitsuba
    /// `near_clip`): where [`TimeOrigin::NearPlane`] starts a path's clock.
    pub near_m: f32,
}

/// The image axis a field of view is measured along (Mitsuba's `fov_axis`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FovAxis {
    /// Horizontal.
    X,
    /// Vertical (glTF's `yfov`).
    #[default]
    Y,
    /// The image's diagonal.
    Diagonal,
    /// The shorter side's axis (`y` for a landscape image).
    Smaller,
    /// The longer side's axis.
    Larger,
}

impl FovAxis {
    /// `(tan(xfov / 2), tan(yfov / 2))` on an image of `aspect` = width / height, for
    /// `tan_half` the tangent of half the field of view along this axis.
    pub fn tan_halves(self, tan_half: f32, aspect: f32) -> (f32, f32) {
        let t = tan_half;
        let landscape = aspect > 1.0;
        match self {
            FovAxis::X => (t, t / aspect),
            FovAxis::Y => (t * aspect, t),
            FovAxis::Smaller if landscape => (t * aspect, t),
            FovAxis::Smaller => (t, t / aspect),
            FovAxis::Larger if landscape => (t, t / aspect),
            FovAxis::Larger => (t * aspect, t),
            FovAxis::Diagonal => {
                let x = t / (1.0 + 1.0 / (aspect * aspect)).sqrt();
                (x, x / aspect)
            }
        }
    }
}

impl Camera {
    /// A camera at `eye` looking at `target`, +Y up (or +Z when looking along Y), with
    /// the vertical field of view `yfov_rad`.
    pub fn look_at(eye: Vec3, target: Vec3, yfov_rad: f32) -> Self {
        let fwd = (target - eye).normalize();
        let up = if fwd.cross(Vec3::Y).length_squared() < 1e-8 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        let right = fwd.cross(up).normalize();
        let true_up = right.cross(fwd);
        Camera {
            world_from_camera: Affine3A::from_cols(
                right.into(),
                true_up.into(),
                (-fwd).into(),
                eye.into(),
            ),
            fov_rad: yfov_rad,
            fov_axis: FovAxis::Y,
            near_m: DEFAULT_NEAR_M,
        }
    }

    /// Camera position in world space, metres.
    pub fn position(&self) -> Vec3 {
        self.world_from_camera.translation.into()
    }

    /// Unit view direction in world space.
    pub fn forward(&self) -> Vec3 {
        -Vec3::from(self.world_from_camera.matrix3.z_axis).normalize()
    }

    /// `(tan(xfov / 2), tan(yfov / 2))` for an image of `aspect` = width / height: the
    /// field of view kept along its axis, the other axis following the aspect (Mitsuba's
    /// `parse_fov`: a diagonal field of view spans the image's diagonal).
    pub fn tan_half_fov(&self, aspect: f32) -> (f32, f32) {
        self.fov_axis.tan_halves((0.5 * self.fov_rad).tan(), aspect)
    }

    /// The vertical field of view, radians, on an image of `aspect` = width / height.
    pub fn yfov_rad(&self, aspect: f32) -> f32 {
        2.0 * self.tan_half_fov(aspect).1.atan()
    }

    /// This camera with the vertical field of view `yfov_rad` (an override's meaning).
    pub fn with_yfov(self, yfov_rad: f32) -> Camera {
        Camera {
            fov_rad: yfov_rad,
            fov_axis: FovAxis::Y,
            ..self
        }
    }

    /// Optical path, metres, that a camera ray along unit `dir` has already travelled
    /// when it leaves the pinhole, by `origin`'s count: 0 from the pinhole, `-near_m /
    /// cos a` from the near plane (`a` the ray's angle to the view direction). `None`
    /// for [`TimeOrigin::FirstHit`], whose offset is the first hit's distance.
    pub fn start_opl_m(&self, origin: TimeOrigin, dir: Vec3) -> Option<f64> {
        match origin {
            TimeOrigin::Pinhole => Some(0.0),
            TimeOrigin::NearPlane => {
                let cos_a = f64::from(dir.dot(self.forward())).max(1e-6);
                Some(-f64::from(self.near_m) / cos_a)
            }
            TimeOrigin::FirstHit => None,
        }
    }

    /// Whether the field of view is a usable angle and the pose and near plane finite.
    pub fn is_valid(&self) -> bool {
        self.world_from_camera.is_finite()
            && self.fov_rad > 0.0
            && self.fov_rad < std::f32::consts::PI
            && self.near_m.is_finite()
            && self.near_m >= 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(fov_deg: f32, axis: FovAxis) -> Camera {
        Camera {
            fov_rad: fov_deg.to_radians(),
            fov_axis: axis,
            ..Camera::look_at(Vec3::ZERO, -Vec3::Z, 1.0)
        }
    }

    /// Mitsuba's `parse_fov` (src/render/sensor.cpp), written out: the horizontal field
    /// of view in degrees for `fov` along `axis` on an image of `aspect`.
    fn mitsuba_x_fov_deg(fov: f64, axis: &str, aspect: f64) -> f64 {
        let axis = match axis {
            "smaller" if aspect > 1.0 => "y",
            "smaller" => "x",
            "larger" if aspect > 1.0 => "x",
            "larger" => "y",
            a => a,
        };
        let h = (0.5 * fov).to_radians();
        match axis {
            "x" => fov,
            "y" => 2.0 * (h.tan() * aspect).atan().to_degrees(),
            _ => {
                let diagonal = 2.0 * h.tan();
                let width = diagonal / (1.0 + 1.0 / (aspect * aspect)).sqrt();
                2.0 * (0.5 * width).atan().to_degrees()
            }
        }
    }

    #[test]
    fn fields_of_view_follow_mitsubas_rule_for_any_aspect() {
        let axes = [
            (FovAxis::X, "x"),
            (FovAxis::Y, "y"),
            (FovAxis::Diagonal, "diagonal"),
            (FovAxis::Smaller, "smaller"),
            (FovAxis::Larger, "larger"),
        ];
        for (axis, name) in axes {
            for aspect in [0.5625f64, 1.0, 1.7778, 3.0] {
                let c = camera(35.0, axis);
                let (tx, ty) = c.tan_half_fov(aspect as f32);
                let x = 2.0 * f64::from(tx).atan().to_degrees();
                let want = mitsuba_x_fov_deg(35.0, name, aspect);
                assert!((x - want).abs() < 1e-3, "{name} at {aspect}: {x} vs {want}");
                // Square pixels: the vertical follows from the horizontal.
                assert!((f64::from(ty) * aspect - f64::from(tx)).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn the_staircase_keeps_35_degrees_across_x_at_any_film() {
        // fov 35 along x (the default axis): a square film keeps 35 degrees across x,
        // so 35 vertically too (not the 58.5 the file's 720 x 1280 aspect gave).
        let c = camera(35.0, FovAxis::X);
        assert!((c.yfov_rad(1.0).to_degrees() - 35.0).abs() < 1e-4);
        let portrait = c.yfov_rad(720.0 / 1280.0).to_degrees();
        assert!((portrait - 58.52).abs() < 0.05, "{portrait}");
    }

    #[test]
    fn near_plane_origin_starts_off_axis_rays_further_out() {
        let mut c = camera(40.0, FovAxis::Y);
        c.near_m = 10.0;
        let on_axis = c.start_opl_m(TimeOrigin::NearPlane, c.forward()).unwrap();
        assert!((on_axis + 10.0).abs() < 1e-9);
        // 30 degrees off the axis: 10 / cos 30 = 11.547 m.
        let a = 30f32.to_radians();
        let dir = Vec3::new(a.sin(), 0.0, -a.cos());
        let off = c.start_opl_m(TimeOrigin::NearPlane, dir).unwrap();
        assert!(
            (off + 10.0 / 30f64.to_radians().cos()).abs() < 1e-5,
            "{off}"
        );
        assert_eq!(c.start_opl_m(TimeOrigin::Pinhole, dir), Some(0.0));
        assert_eq!(c.start_opl_m(TimeOrigin::FirstHit, dir), None);
    }
}
