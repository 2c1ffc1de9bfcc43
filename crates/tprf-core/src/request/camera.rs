//! The request's camera override: a position, a point to look at, an up direction
//! (metres) and a vertical field of view (degrees), each optional, applied to the
//! scene's camera (glTF's convention: the camera looks along its -Z, +Y up).

use super::{Problem, RenderRequest, RequestError};
use crate::scene::Camera;
use glam::{Affine3A, DVec3, Vec3};

fn invalid(problem: Problem) -> RequestError {
    RequestError::Invalid(problem)
}

fn finite(v: [f64; 3]) -> bool {
    v.iter().all(|c| c.is_finite())
}

fn text(v: [f64; 3]) -> String {
    format!("{},{},{}", v[0], v[1], v[2])
}

/// The override's fields each on their own: finite points, a non-zero up, a field of
/// view in (0, 180) degrees, a look-at point away from the position. What depends on
/// the scene's camera (an up along the view direction it keeps) is checked in
/// [`apply_camera`].
pub(super) fn check(r: &RenderRequest) -> Result<(), RequestError> {
    for (field, v) in [
        ("camera_position", r.camera_position_m),
        ("look_at", r.look_at_m),
        ("up", r.up),
    ] {
        if let Some(v) = v
            && !finite(v)
        {
            return Err(invalid(
                Problem::field(field)
                    .text(format!(" = {}: every coordinate must be finite", text(v))),
            ));
        }
    }
    if let Some(up) = r.up
        && DVec3::from(up).length_squared() == 0.0
    {
        return Err(invalid(
            Problem::field("up").text(" = 0,0,0 is no direction"),
        ));
    }
    if let (Some(p), Some(t)) = (r.camera_position_m, r.look_at_m)
        && DVec3::from(p) == DVec3::from(t)
    {
        return Err(invalid(
            Problem::field("look_at")
                .text(format!(" = {} is the ", text(t)))
                .and("camera_position")
                .text(": the camera must look somewhere else"),
        ));
    }
    if let Some(fov) = r.fov_deg
        && !(fov > 0.0 && fov < 180.0)
    {
        return Err(invalid(Problem::field("fov").text(format!(
            " = {fov} degrees: a vertical field of view must be in (0, 180)"
        ))));
    }
    Ok(())
}

/// `camera` with the request's override: moved to `camera_position` (its orientation
/// kept) and/or turned toward `look_at` (from the position) with `up` (default +Y, or
/// +Z when looking along Y; `up` alone turns the camera about its view direction), its
/// vertical field of view set to `fov`. Without an override, `camera` itself.
pub fn apply_camera(r: &RenderRequest, camera: &Camera) -> Result<Camera, RequestError> {
    check(r)?;
    let old_position = camera.position().as_dvec3();
    let position = r.camera_position_m.map_or(old_position, DVec3::from);
    let mut world_from_camera = camera.world_from_camera;
    if r.look_at_m.is_some() || r.up.is_some() {
        let forward = match r.look_at_m {
            Some(t) => DVec3::from(t) - position,
            None => -camera.world_from_camera.matrix3.z_axis.as_dvec3(),
        };
        if forward.length_squared() == 0.0 {
            return Err(invalid(
                Problem::field("look_at")
                    .text(" is where the scene's camera stands: give a ")
                    .and("camera_position")
                    .text(" or another point"),
            ));
        }
        let forward = forward.normalize();
        let up = match r.up {
            Some(u) => DVec3::from(u).normalize(),
            None if forward.cross(DVec3::Y).length_squared() < 1e-8 => DVec3::Z,
            None => DVec3::Y,
        };
        let right = forward.cross(up);
        if right.length_squared() < 1e-12 {
            return Err(invalid(Problem::field("up").text(format!(
                " = {} lies along the view direction {}: choose an up across it",
                text(up.to_array()),
                text(forward.to_array())
            ))));
        }
        let right = right.normalize();
        let true_up = right.cross(forward);
        world_from_camera = Affine3A::from_cols(
            right.as_vec3().into(),
            true_up.as_vec3().into(),
            (-forward).as_vec3().into(),
            Vec3::ZERO.into(),
        );
    }
    world_from_camera.translation = position.as_vec3().into();
    let placed = Camera {
        world_from_camera,
        ..*camera
    };
    Ok(match r.fov_deg {
        Some(d) => placed.with_yfov(d.to_radians() as f32),
        None => placed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene_camera() -> Camera {
        Camera::look_at(Vec3::new(0.0, 1.0, 5.0), Vec3::new(0.0, 1.0, 0.0), 0.7)
    }

    fn forward(c: &Camera) -> Vec3 {
        -Vec3::from(c.world_from_camera.matrix3.z_axis)
    }

    /// Worked by hand: from (3, 0, 0) looking at the origin the camera looks along -X,
    /// its right is forward x up = (-1,0,0) x (0,1,0) = (0,0,-1), its up +Y.
    #[test]
    fn a_pose_is_placed_as_worked_by_hand() {
        let r = RenderRequest {
            camera_position_m: Some([3.0, 0.0, 0.0]),
            look_at_m: Some([0.0, 0.0, 0.0]),
            fov_deg: Some(90.0),
            ..RenderRequest::new("x")
        };
        let c = apply_camera(&r, &scene_camera()).unwrap();
        assert_eq!(c.position(), Vec3::new(3.0, 0.0, 0.0));
        assert!((forward(&c) - Vec3::NEG_X).length() < 1e-6);
        assert!((Vec3::from(c.world_from_camera.matrix3.x_axis) - Vec3::NEG_Z).length() < 1e-6);
        assert!((Vec3::from(c.world_from_camera.matrix3.y_axis) - Vec3::Y).length() < 1e-6);
        assert!((c.fov_rad - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    }

    /// A position alone moves the camera and keeps where it looks; nothing given keeps
    /// the camera bit for bit; up along the view is refused, naming `up`.
    #[test]
    fn parts_of_a_pose() {
        let cam = scene_camera();
        let same = apply_camera(&RenderRequest::new("x"), &cam).unwrap();
        assert_eq!(same.world_from_camera, cam.world_from_camera);
        assert_eq!(same.fov_rad, cam.fov_rad);
        let moved = apply_camera(
            &RenderRequest {
                camera_position_m: Some([1.0, 2.0, 3.0]),
                ..RenderRequest::new("x")
            },
            &cam,
        )
        .unwrap();
        assert_eq!(moved.position(), Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(
            moved.world_from_camera.matrix3,
            cam.world_from_camera.matrix3
        );
        let e = apply_camera(
            &RenderRequest {
                up: Some([0.0, 0.0, -2.0]),
                ..RenderRequest::new("x")
            },
            &cam,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("up = 0,0,-1 lies along the view direction"),
            "{e}"
        );
        let e = RenderRequest {
            fov_deg: Some(180.0),
            ..RenderRequest::new("x")
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("fov = 180 degrees"), "{e}");
    }
}
