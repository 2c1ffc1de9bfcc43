//! The operations of a `<transform>` block, as Mitsuba composes them: each operation
//! multiplies the transform so far from the left (`T = op * T`: the first operation
//! listed is applied first). Angles in degrees, `<matrix>` values row by row, and
//! `<lookat>` mapping the object's +Z to the viewing direction, +Y to `up` and +X to
//! `up x direction` (Mitsuba's camera space: +X is the image's left).

use super::xml::{Loc, err, parse_f64, parse_list, parse_vec3};
use crate::scene::SceneError;
use glam::{DMat3, DMat4, DVec3, DVec4};

/// An attribute of the operation element, after `$` substitution.
pub(super) type Attr<'a> = dyn Fn(&str) -> Result<Option<String>, SceneError> + 'a;

/// `x`, `y`, `z` attributes (each `default` when absent), or `value` with one number
/// (every component) or three.
fn xyz(attr: &Attr, default: f64, tag: &str, loc: &Loc) -> Result<DVec3, SceneError> {
    if let Some(v) = attr("value")? {
        if attr("x")?.is_some() || attr("y")?.is_some() || attr("z")?.is_some() {
            return Err(err(
                loc,
                format!("<{tag}>: give value=\"...\" or x, y, z, not both"),
            ));
        }
        let n = parse_list(&v).map_err(|m| err(loc, format!("<{tag}>: {m}")))?;
        return match *n.as_slice() {
            [a] => Ok(DVec3::splat(a)),
            [x, y, z] => Ok(DVec3::new(x, y, z)),
            _ => Err(err(
                loc,
                format!("<{tag} value=\"{v}\">: needs 1 or 3 numbers"),
            )),
        };
    }
    let mut out = DVec3::splat(default);
    for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
        if let Some(s) = attr(axis)? {
            out[k] = parse_f64(&s).map_err(|m| err(loc, format!("<{tag}> {axis}: {m}")))?;
        }
    }
    Ok(out)
}

/// A unit vector perpendicular to unit `n` (Duff et al. 2017, Mitsuba's
/// `coordinate_system`'s first vector).
fn perpendicular(n: DVec3) -> DVec3 {
    let sign = 1.0f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x)
}

/// Mitsuba's `look_at`: camera (or object) space to world, columns `left`, `up`, `dir`,
/// `origin`; `None` when `up` is parallel to the direction or the points coincide.
pub(super) fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (target - origin).try_normalize()?;
    let up = if up == DVec3::ZERO {
        perpendicular(dir)
    } else {
        up
    };
    let left = up.cross(dir).try_normalize()?;
    let new_up = dir.cross(left);
    let m = DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    );
    m.is_finite().then_some(m)
}

/// The matrix of one operation element `tag` (`translate`, `rotate`, `scale`, `lookat`,
/// `matrix`).
pub(super) fn apply(tag: &str, attr: &Attr, loc: &Loc) -> Result<DMat4, SceneError> {
    let m = match tag {
        "translate" => DMat4::from_translation(xyz(attr, 0.0, tag, loc)?),
        "scale" => DMat4::from_scale(xyz(attr, 1.0, tag, loc)?),
        "rotate" => {
            let axis = xyz(attr, 0.0, tag, loc)?;
            let angle =
                attr("angle")?.ok_or_else(|| err(loc, "<rotate> needs angle=\"...\" (degrees)"))?;
            let angle = parse_f64(&angle).map_err(|m| err(loc, format!("<rotate> angle: {m}")))?;
            let axis = axis
                .try_normalize()
                .ok_or_else(|| err(loc, "<rotate>: the rotation axis is zero"))?;
            DMat4::from_axis_angle(axis, angle.to_radians())
        }
        "lookat" => {
            let get = |name: &str| -> Result<DVec3, SceneError> {
                let v = attr(name)?
                    .ok_or_else(|| err(loc, format!("<lookat> needs {name}=\"x, y, z\"")))?;
                parse_vec3(&v)
                    .map(DVec3::from)
                    .map_err(|m| err(loc, format!("<lookat> {name}: {m}")))
            };
            let origin = get("origin")?;
            let target = get("target")?;
            let up = match attr("up")? {
                Some(v) => {
                    DVec3::from(parse_vec3(&v).map_err(|m| err(loc, format!("<lookat> up: {m}")))?)
                }
                None => DVec3::ZERO,
            };
            look_at(origin, target, up).ok_or_else(|| {
                err(
                    loc,
                    "<lookat>: origin and target coincide, or up is parallel to the viewing direction",
                )
            })?
        }
        "matrix" => {
            let v = attr("value")?.ok_or_else(|| {
                err(
                    loc,
                    "<matrix> needs value=\"...\" (16 or 9 numbers, row by row)",
                )
            })?;
            let n = parse_list(&v).map_err(|m| err(loc, format!("<matrix>: {m}")))?;
            match n.len() {
                // Row by row in the file; glam's constructors take columns.
                16 => DMat4::from_cols_slice(&n).transpose(),
                9 => DMat4::from_mat3(DMat3::from_cols_slice(&n).transpose()),
                k => return Err(err(loc, format!("<matrix> needs 16 or 9 numbers, got {k}"))),
            }
        }
        other => {
            return Err(err(
                loc,
                format!(
                    "<{other}> is not a transform operation (translate, rotate, scale, lookat, matrix)"
                ),
            ));
        }
    };
    Ok(m)
}

/// Whether `m` is affine (last row 0, 0, 0, 1): a projective `<matrix>` has no meaning
/// for an object's placement.
pub(super) fn is_affine(m: &DMat4) -> bool {
    m.row(3).abs_diff_eq(DVec4::new(0.0, 0.0, 0.0, 1.0), 1e-12)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn attrs<'a>(
        pairs: &'a [(&'a str, &'a str)],
    ) -> impl Fn(&str) -> Result<Option<String>, SceneError> + 'a {
        move |n: &str| {
            Ok(pairs
                .iter()
                .find(|(k, _)| *k == n)
                .map(|(_, v)| v.to_string()))
        }
    }

    fn loc() -> Loc {
        Loc {
            file: "t.xml".into(),
            line: 1,
        }
    }

    #[test]
    fn matrix_is_read_row_by_row() {
        let a = attrs(&[("value", "1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1")]);
        let m = apply("matrix", &a, &loc()).unwrap();
        assert_eq!(m.transform_point3(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0));
    }

    #[test]
    fn rotate_is_in_degrees_about_the_axis() {
        let a = attrs(&[("y", "1"), ("angle", "90")]);
        let m = apply("rotate", &a, &loc()).unwrap();
        // +X rotated 90 degrees about +Y goes to -Z (right-handed).
        assert!(m.transform_vector3(DVec3::X).abs_diff_eq(-DVec3::Z, 1e-12));
    }

    #[test]
    fn lookat_maps_z_to_the_view_direction_and_x_to_the_left() {
        let a = attrs(&[
            ("origin", "0, 0, 5"),
            ("target", "0, 0, 0"),
            ("up", "0, 1, 0"),
        ]);
        let m = apply("lookat", &a, &loc()).unwrap();
        assert!(m.transform_vector3(DVec3::Z).abs_diff_eq(-DVec3::Z, 1e-12));
        assert!(m.transform_vector3(DVec3::Y).abs_diff_eq(DVec3::Y, 1e-12));
        // Looking down -Z with +Y up, the viewer's left is -X.
        assert!(m.transform_vector3(DVec3::X).abs_diff_eq(-DVec3::X, 1e-12));
        let bad = attrs(&[
            ("origin", "0, 0, 0"),
            ("target", "0, 1, 0"),
            ("up", "0, 1, 0"),
        ]);
        assert!(apply("lookat", &bad, &loc()).is_err());
    }

    #[test]
    fn scale_value_is_uniform_and_translate_defaults_to_zero() {
        let m = apply("scale", &attrs(&[("value", "2")]), &loc()).unwrap();
        assert_eq!(m.transform_point3(DVec3::ONE), DVec3::splat(2.0));
        let t = apply("translate", &attrs(&[("y", "3")]), &loc()).unwrap();
        assert_eq!(t.transform_point3(DVec3::ZERO), DVec3::new(0.0, 3.0, 0.0));
        assert!(apply("rotate", &attrs(&[("angle", "10")]), &loc()).is_err());
    }
}
