//! The window's camera as numbers and gestures, without egui: a [`CameraPose`]
//! (position and look-at point in metres, an up direction, the vertical field of view in
//! degrees), the pose that renders a scene's camera, and what the mouse does to it on the
//! images: orbit about the look-at point, pan, dolly, field of view. A pose is the render
//! request's camera override (`camera_position`, `look_at`, `up`, `fov`), so `tprf
//! render` given the same numbers renders the same view ([`CameraPose::flags`]).
//! [`PoseText`] is the pose as it is typed: parsed, checked, and each field left exact
//! when it was not edited.

use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};
use tprf_core::request::{RenderRequest, apply_camera};
use tprf_core::scene::{Bounds, Camera};

/// Orbit per point of drag: a drag over the image's height turns the view half round.
pub const ORBIT_RAD_PER_HEIGHT: f64 = std::f64::consts::PI;
/// Closest an orbit goes to looking straight along the up direction, radians (the
/// request refuses an up along the view).
const POLE_MARGIN_RAD: f64 = 0.5_f64 * (std::f64::consts::PI / 180.0);
/// Field of view the gestures keep within, degrees (the request takes (0, 180)).
pub const FOV_RANGE_DEG: (f64, f64) = (1.0, 170.0);
/// Nearest the camera dollies to its look-at point, metres.
const MIN_DISTANCE_M: f64 = 1e-6;

/// A camera pose: where the camera stands and looks (metres), which way is up (a
/// direction, any length) and its vertical field of view (degrees).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraPose {
    pub position_m: [f64; 3],
    pub look_at_m: [f64; 3],
    pub up: [f64; 3],
    pub fov_deg: f64,
}

impl CameraPose {
    /// The pose that renders `camera` (through [`apply_camera`], to f32 precision): its
    /// position; a look-at point along its view, as far as the centre of `bounds` (the
    /// orbit's pivot; 1 m without bounds); up +Y when the camera is upright and not
    /// rolled (its right vector level), else its own up; its field of view.
    pub fn of_camera(camera: &Camera, aspect: f32, bounds: Option<Bounds>) -> CameraPose {
        let m = camera.world_from_camera.matrix3;
        let (right, up_c, forward) = (
            m.x_axis.as_dvec3().normalize_or_zero(),
            m.y_axis.as_dvec3().normalize_or_zero(),
            -m.z_axis.as_dvec3().normalize_or_zero(),
        );
        let position = camera.position().as_dvec3();
        let distance_m = bounds
            .map(|b| (b.center().as_dvec3() - position).length())
            .filter(|d| d.is_finite() && *d > MIN_DISTANCE_M)
            .unwrap_or(1.0);
        let up = if right.y.abs() < 1e-4 && up_c.y > 0.0 && forward.y.abs() < 0.9999 {
            DVec3::Y
        } else {
            up_c
        };
        // The camera holds f32s: each number is the shortest one that f32 reads back
        // (0.2775, not 0.2775000035762787), the same camera to f32 precision.
        let short = |v: f64| (v as f32).to_string().parse::<f64>().unwrap_or(v);
        let short3 = |v: DVec3| v.to_array().map(short);
        CameraPose {
            position_m: short3(position),
            look_at_m: short3(position + forward * distance_m),
            up: short3(up),
            fov_deg: short(f64::from(camera.yfov_rad(aspect)).to_degrees()),
        }
    }

    /// `request` with this pose as its camera override.
    pub fn into_request(self, request: RenderRequest) -> RenderRequest {
        RenderRequest {
            camera_position_m: Some(self.position_m),
            look_at_m: Some(self.look_at_m),
            up: Some(self.up),
            fov_deg: Some(self.fov_deg),
            ..request
        }
    }

    /// The request's override as a pose, when it sets all four fields.
    pub fn of_request(r: &RenderRequest) -> Option<CameraPose> {
        Some(CameraPose {
            position_m: r.camera_position_m?,
            look_at_m: r.look_at_m?,
            up: r.up?,
            fov_deg: r.fov_deg?,
        })
    }

    /// What is wrong with this pose, as the request says it (naming its field:
    /// `up = 0,1,0 lies along the view direction …`), or nothing. With all four fields
    /// set the camera placed does not depend on the scene's, so this is the whole check.
    pub fn problem(&self) -> Option<String> {
        let r = self.into_request(RenderRequest::new("camera"));
        let any = Camera::look_at(glam::Vec3::ZERO, glam::Vec3::NEG_Z, 1.0);
        r.validate()
            .and_then(|()| apply_camera(&r, &any).map(|_| ()))
            .err()
            .map(|e| e.to_string())
    }

    /// `tprf render`'s options for this pose, every number exact (Rust's shortest text
    /// that reads back as the same f64).
    pub fn flags(&self) -> String {
        let v = |v: [f64; 3]| format!("{},{},{}", v[0], v[1], v[2]);
        format!(
            "--camera-position {} --look-at {} --up {} --fov {}",
            v(self.position_m),
            v(self.look_at_m),
            v(self.up),
            self.fov_deg
        )
    }

    fn position(&self) -> DVec3 {
        DVec3::from(self.position_m)
    }

    fn target(&self) -> DVec3 {
        DVec3::from(self.look_at_m)
    }

    /// The camera's right and up (unit vectors) as the request places it: right =
    /// forward x up, up = right x forward.
    fn frame(&self) -> Option<(DVec3, DVec3)> {
        let forward = (self.target() - self.position()).try_normalize()?;
        let right = forward.cross(DVec3::from(self.up)).try_normalize()?;
        Some((right, right.cross(forward)))
    }

    /// Orbit about the look-at point: turned by `yaw_rad` about the up direction (a
    /// drag to the right, positive, carries the scene to the right: the camera goes to
    /// its left) and raised by `pitch_rad` toward the up direction, stopping half a
    /// degree short of looking along it. Distance to the look-at point, the look-at
    /// point and the up direction are kept.
    pub fn orbit(&self, yaw_rad: f64, pitch_rad: f64) -> CameraPose {
        let (Some(up), Some((right, _))) = (DVec3::from(self.up).try_normalize(), self.frame())
        else {
            return *self;
        };
        let offset = self.position() - self.target();
        let offset = DQuat::from_axis_angle(up, -yaw_rad) * offset;
        let right = DQuat::from_axis_angle(up, -yaw_rad) * right;
        let polar = offset
            .normalize()
            .dot(up)
            .clamp(-1.0, 1.0)
            .acos()
            .clamp(POLE_MARGIN_RAD, std::f64::consts::PI - POLE_MARGIN_RAD);
        let new_polar =
            (polar - pitch_rad).clamp(POLE_MARGIN_RAD, std::f64::consts::PI - POLE_MARGIN_RAD);
        let offset = DQuat::from_axis_angle(right, new_polar - polar) * offset;
        CameraPose {
            position_m: (self.target() + offset).to_array(),
            ..*self
        }
    }

    /// Move camera and look-at point together across the view by `(dx, dy)` fractions
    /// of the image's height (x to the right, y down), scaled to the view's height at
    /// the look-at point (`2 d tan(fov / 2)`): the point under the pointer follows it.
    pub fn pan(&self, dx: f64, dy: f64) -> CameraPose {
        let Some((right, up)) = self.frame() else {
            return *self;
        };
        let d = (self.target() - self.position()).length();
        let view_h_m = 2.0 * d * (0.5 * self.fov_deg.to_radians()).tan();
        let shift = (-dx * right + dy * up) * view_h_m;
        CameraPose {
            position_m: (self.position() + shift).to_array(),
            look_at_m: (self.target() + shift).to_array(),
            ..*self
        }
    }

    /// The camera moved along its view so that its distance to the look-at point is
    /// `factor` times what it was (below 1: closer), at least a micrometre.
    pub fn dolly(&self, factor: f64) -> CameraPose {
        let offset = self.position() - self.target();
        let d = offset.length();
        if !(factor.is_finite() && factor > 0.0) || d == 0.0 {
            return *self;
        }
        let new_d = (d * factor).max(MIN_DISTANCE_M);
        CameraPose {
            position_m: (self.target() + offset * (new_d / d)).to_array(),
            ..*self
        }
    }

    /// The field of view times `factor`, kept in [`FOV_RANGE_DEG`].
    pub fn zoom_fov(&self, factor: f64) -> CameraPose {
        if !(factor.is_finite() && factor > 0.0) {
            return *self;
        }
        CameraPose {
            fov_deg: (self.fov_deg * factor).clamp(FOV_RANGE_DEG.0, FOV_RANGE_DEG.1),
            ..*self
        }
    }

    /// Where `point_m` falls on the image, as fractions of its width and height from
    /// the top left (the renderer's pinhole: vertical field of view `fov`, the width
    /// from `aspect` = width / height); `None` behind the camera.
    pub fn project(&self, point_m: DVec3, aspect: f64) -> Option<(f64, f64)> {
        let (right, up) = self.frame()?;
        let forward = up.cross(right);
        let v = point_m - self.position();
        let z = v.dot(forward);
        if z <= 1e-9 {
            return None;
        }
        let half_h = (0.5 * self.fov_deg.to_radians()).tan();
        let half_w = half_h * aspect;
        let sx = v.dot(right) / (z * half_w);
        let sy = v.dot(up) / (z * half_h);
        Some((0.5 + 0.5 * sx, 0.5 - 0.5 * sy))
    }
}

/// `v` rounded to a tenth of a millimetre for the fields (no trailing zeros).
pub fn number_text(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    match s {
        "-0" | "" => "0".into(),
        s => s.into(),
    }
}

/// `x, y, z` as the fields show a point or direction.
pub fn vec3_text(v: [f64; 3]) -> String {
    format!(
        "{}, {}, {}",
        number_text(v[0]),
        number_text(v[1]),
        number_text(v[2])
    )
}

/// Three numbers (separated by commas and/or spaces) typed into the field named
/// `field`, or what is wrong with them.
pub fn parse_vec3(field: &str, text: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = text
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|p| !p.is_empty())
        .collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(format!(
            "{field}: \"{}\" is not three numbers x, y, z (metres, e.g. 0, 1.5, 3)",
            text.trim()
        ));
    };
    let mut out = [0.0; 3];
    for (o, p) in out.iter_mut().zip([x, y, z]) {
        *o = p
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("{field}: \"{p}\" is not a finite number"))?;
    }
    Ok(out)
}

/// A field of view typed in degrees (a trailing `°` or `deg` allowed), or what is wrong.
pub fn parse_fov(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let t = t
        .strip_suffix('°')
        .or_else(|| t.strip_suffix("deg"))
        .unwrap_or(t)
        .trim();
    t.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            format!(
                "field of view: \"{}\" is not a number of degrees",
                text.trim()
            )
        })
}

/// The pose as typed: one text per field (position, look-at, up, field of view), and
/// the pose they were last filled from.
#[derive(Clone, Debug, Default)]
pub struct PoseText {
    pub position: String,
    pub look_at: String,
    pub up: String,
    pub fov: String,
    shown: Option<CameraPose>,
}

impl PoseText {
    /// Fill the fields from `pose` when it is not the one they show (a gesture, a new
    /// render); what is being typed for the same pose stays.
    pub fn follow(&mut self, pose: &CameraPose) {
        if self.shown.as_ref() != Some(pose) {
            *self = PoseText {
                position: vec3_text(pose.position_m),
                look_at: vec3_text(pose.look_at_m),
                up: vec3_text(pose.up),
                fov: number_text(pose.fov_deg),
                shown: Some(*pose),
            };
        }
    }

    /// Whether a field differs from the pose it was filled from.
    pub fn edited(&self) -> bool {
        let Some(p) = &self.shown else {
            return false;
        };
        self.position != vec3_text(p.position_m)
            || self.look_at != vec3_text(p.look_at_m)
            || self.up != vec3_text(p.up)
            || self.fov != number_text(p.fov_deg)
    }

    /// The pose typed: each edited field parsed, each other one the shown pose's exact
    /// value (the fields round to 0.1 mm), checked as the request checks it.
    pub fn parse(&self) -> Result<CameraPose, String> {
        let Some(p) = &self.shown else {
            return Err("no camera yet: the scene is still loading".into());
        };
        let vec = |name: &str, text: &str, exact: [f64; 3]| {
            if text == vec3_text(exact) {
                Ok(exact)
            } else {
                parse_vec3(name, text)
            }
        };
        let pose = CameraPose {
            position_m: vec("position", &self.position, p.position_m)?,
            look_at_m: vec("look at", &self.look_at, p.look_at_m)?,
            up: vec("up", &self.up, p.up)?,
            fov_deg: if self.fov == number_text(p.fov_deg) {
                p.fov_deg
            } else {
                parse_fov(&self.fov)?
            },
        };
        match pose.problem() {
            Some(e) => Err(e),
            None => Ok(pose),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        (DVec3::from(a) - DVec3::from(b)).length() < tol
    }

    fn scene_bounds() -> Bounds {
        Bounds {
            min: Vec3::new(-1.0, 0.0, -1.0),
            max: Vec3::new(1.0, 2.0, 1.0),
        }
    }

    /// A scene's camera, upright or rolled, is placed again by its pose through the
    /// request's override (the pose is exact where the camera is: the same matrix to
    /// f32 precision), and the pivot is the bounds' centre when the camera looks at it.
    #[test]
    fn the_pose_of_a_camera_renders_that_camera() {
        let upright = Camera::look_at(Vec3::new(0.0, 1.0, 5.0), Vec3::new(0.0, 1.0, 0.0), 0.7);
        let mut rolled = upright;
        rolled.world_from_camera.matrix3 =
            glam::Mat3A::from_rotation_z(0.3) * rolled.world_from_camera.matrix3;
        let down = Camera::look_at(Vec3::new(3.0, 4.0, 2.0), Vec3::new(0.0, 1.0, 0.0), 1.1);
        for cam in [upright, rolled, down] {
            let pose = CameraPose::of_camera(&cam, 1.5, Some(scene_bounds()));
            assert!(pose.problem().is_none(), "{:?}", pose.problem());
            let placed = apply_camera(&pose.into_request(RenderRequest::new("x")), &upright)
                .expect("placed");
            let (a, b) = (
                glam::Mat4::from(placed.world_from_camera),
                glam::Mat4::from(cam.world_from_camera),
            );
            assert!(a.abs_diff_eq(b, 1e-5), "{a} vs {b}");
            assert!((placed.yfov_rad(1.5) - cam.yfov_rad(1.5)).abs() < 1e-6);
        }
        let pose = CameraPose::of_camera(&upright, 1.5, Some(scene_bounds()));
        assert!(close(pose.look_at_m, [0.0, 1.0, 0.0], 1e-6));
        assert_eq!(pose.up, [0.0, 1.0, 0.0]);
        // Rolled: its own up, not +Y.
        let pose = CameraPose::of_camera(&rolled, 1.5, Some(scene_bounds()));
        assert!(pose.up[0].abs() > 0.2, "{:?}", pose.up);
    }

    /// Worked by hand: from (0, 0, 2) looking at the origin, a quarter turn of yaw
    /// (to the right) takes the camera to (-2, 0, 0); pitching up by 45 degrees then
    /// lifts it to (-sqrt 2, sqrt 2, 0). Pitching past the pole stops half a degree
    /// short of it.
    #[test]
    fn orbit_as_worked_by_hand() {
        let pose = CameraPose {
            position_m: [0.0, 0.0, 2.0],
            look_at_m: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov_deg: 40.0,
        };
        let quarter = std::f64::consts::FRAC_PI_2;
        let p = pose.orbit(quarter, 0.0);
        assert!(close(p.position_m, [-2.0, 0.0, 0.0], 1e-12), "{p:?}");
        let p = p.orbit(0.0, quarter / 2.0);
        let s = 2.0_f64.sqrt();
        assert!(close(p.position_m, [-s, s, 0.0], 1e-12), "{p:?}");
        assert_eq!((p.look_at_m, p.up, p.fov_deg), ([0.0; 3], pose.up, 40.0));
        let top = pose.orbit(0.0, 10.0);
        let polar = (DVec3::from(top.position_m).normalize().y)
            .acos()
            .to_degrees();
        assert!((polar - 0.5).abs() < 1e-9, "{polar}");
        assert!(top.problem().is_none());
        assert!((DVec3::from(top.position_m).length() - 2.0).abs() < 1e-12);
    }

    /// Pan moves camera and look-at point by one vector across the view, the view's
    /// height at the look-at point for a drag of the image's height; dolly keeps the
    /// look-at point and scales the distance; the field of view stays in its range.
    #[test]
    fn pan_dolly_and_field_of_view() {
        let pose = CameraPose {
            position_m: [0.0, 0.0, 2.0],
            look_at_m: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov_deg: 90.0,
        };
        // View height at 2 m with 90 degrees: 2 * 2 * tan 45 = 4 m. A drag right by
        // half the height moves the camera 2 m to the left, down by a quarter 1 m up.
        let p = pose.pan(0.5, 0.25);
        assert!(close(p.position_m, [-2.0, 1.0, 2.0], 1e-12), "{p:?}");
        assert!(close(p.look_at_m, [-2.0, 1.0, 0.0], 1e-12), "{p:?}");
        let d = pose.dolly(0.5);
        assert!(close(d.position_m, [0.0, 0.0, 1.0], 1e-12));
        assert_eq!(d.look_at_m, pose.look_at_m);
        assert_eq!(pose.dolly(0.0), pose);
        assert_eq!(pose.zoom_fov(0.5).fov_deg, 45.0);
        assert_eq!(pose.zoom_fov(100.0).fov_deg, FOV_RANGE_DEG.1);
        // The look-at point projects to the image centre; a point on the top edge of
        // the view to the top.
        let (x, y) = pose.project(DVec3::ZERO, 1.0).unwrap();
        assert!((x - 0.5).abs() < 1e-12 && (y - 0.5).abs() < 1e-12);
        let (_, y) = pose.project(DVec3::new(0.0, 2.0, 0.0), 1.0).unwrap();
        assert!(y.abs() < 1e-12, "{y}");
        assert!(pose.project(DVec3::new(0.0, 0.0, 3.0), 1.0).is_none());
    }

    /// Typed fields: unedited ones keep the pose's exact values (not the 0.1 mm the
    /// field shows), edited ones are parsed, bad ones refused naming the field.
    #[test]
    fn typed_poses_round_trip_and_bad_ones_are_named() {
        let pose = CameraPose {
            position_m: [0.123456789, 1.0, 3.0],
            look_at_m: [0.0, 1.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_deg: 39.99999,
        };
        let mut t = PoseText::default();
        t.follow(&pose);
        assert!(!t.edited());
        assert_eq!(t.position, "0.1235, 1, 3");
        assert_eq!(t.parse(), Ok(pose));
        t.look_at = "0.5 1.25,-2".into();
        t.fov = "30°".into();
        assert!(t.edited());
        let p = t.parse().unwrap();
        assert_eq!(p.position_m, pose.position_m);
        assert_eq!((p.look_at_m, p.fov_deg), ([0.5, 1.25, -2.0], 30.0));
        // The same pose shown again keeps what is typed.
        t.follow(&pose);
        assert_eq!(t.fov, "30°");
        for (field, text, want) in [
            (
                "position",
                "1, 2",
                "position: \"1, 2\" is not three numbers",
            ),
            (
                "position",
                "1, 2, inf",
                "position: \"inf\" is not a finite number",
            ),
            ("fov", "wide", "field of view: \"wide\" is not a number"),
            ("fov", "180", "fov = 180 degrees"),
            ("up", "0, 0, 0", "up = 0,0,0 is no direction"),
            ("up", "-0.123456789, 0, -3", "lies along the view direction"),
            (
                "look_at",
                "0.123456789, 1, 3",
                "look_at = 0.123456789,1,3 is the",
            ),
        ] {
            let mut t = PoseText::default();
            t.follow(&pose);
            match field {
                "position" => t.position = text.into(),
                "fov" => t.fov = text.into(),
                "up" => t.up = text.into(),
                _ => t.look_at = text.into(),
            }
            let e = t.parse().unwrap_err();
            assert!(e.contains(want), "{field} = {text}: {e}");
        }
        assert_eq!(
            pose.flags(),
            "--camera-position 0.123456789,1,3 --look-at 0,1,0 --up 0,1,0 --fov 39.99999"
        );
    }
}
