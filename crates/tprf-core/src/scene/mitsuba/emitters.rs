//! Mitsuba emitters as tprf lights, in Mitsuba's units, which are tprf's:
//!
//! - `point`: radiant `intensity` W/sr at `position` (or `to_world`'s origin): a pulsed
//!   point light;
//! - `spot`: `intensity` W/sr on its axis (`to_world`'s +Z), `cutoff_angle` (default
//!   20 degrees) and `beam_width` (default 3/4 of it): a pulsed spot light whose cone
//!   is the same, but whose falloff between the two angles is tprf's (KHR's smooth
//!   falloff in the cosine, Mitsuba's is linear in the angle; noted);
//! - `area` (inside a shape): `radiance` W m^-2 sr^-1 from the shape's front side;
//! - `angulararea` (mitransient's, inside a shape): an `area` emitter whose radiance at
//!   angle theta to the normal is full within `beam_width`, falls linearly in theta to
//!   0 at `cutoff_angle` (degrees; defaults 10 and the cutoff), exactly as mitransient;
//! - `projector` (read in `nlos.rs`, where it is also an NLOS laser): a constant
//!   `irradiance` E times `scale` through a square frustum of `fov`: intensity `pi E
//!   scale / cos^3 theta` inside it, Mitsuba's uniform irradiance across its axis;
//! - `directional`: `irradiance` W/m^2 travelling along `direction` (or `to_world`'s
//!   +Z), and `constant`: `radiance` from every direction: tprf's ambient group, steady
//!   light that the transient cube does not hold (rendered into the ambient image;
//!   noted, since mitransient pulses them).

use super::Builder;
use super::xml::{Color, err};
use crate::scene::{AngularFalloff, DirectionalLight, PunctualLight, Scene, SceneError, Spot};

/// An area emitter of a shape (`area`, `angulararea`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct AreaEmitter {
    /// Radiance, W m^-2 sr^-1, RGB.
    pub radiance: [f64; 3],
    /// The angular profile of an `angulararea` emitter.
    pub falloff: Option<AngularFalloff>,
}
use glam::{DMat3, DVec3};

/// A point light at the camera of a scene with no light (see [`Scene::colocated_light`]).
pub(super) fn colocated_light(scene: &Scene) -> PunctualLight {
    scene.colocated_light()
}

impl Builder<'_> {
    /// A constant radiometric quantity `name` of emitter `o` (textures refused).
    pub(super) fn quantity(
        &self,
        o: &super::xml::Object,
        name: &str,
    ) -> Result<[f64; 3], SceneError> {
        match o.color(name, Some([1.0; 3]))? {
            Some(Color::Rgb(c)) => {
                if c.iter().any(|v| *v < 0.0) {
                    return Err(err(
                        &o.loc,
                        format!("{}: {name} {c:?} is negative", o.describe()),
                    ));
                }
                Ok(c)
            }
            Some(Color::Texture(k)) => {
                let t = self.object(k);
                match t.plugin.as_str() {
                    "uniform" => Ok([t.float("value", 1.0)?; 3]),
                    "srgb" | "d65" => match t.color("color", Some([1.0; 3]))? {
                        Some(Color::Rgb(c)) => Ok(c),
                        _ => Err(err(
                            &t.loc,
                            format!("{} needs <rgb name=\"color\">", t.describe()),
                        )),
                    },
                    _ => Err(err(
                        &t.loc,
                        format!(
                            "{} as the {name} of {}: tprf's emitters are constant (give <rgb> or a number)",
                            t.describe(),
                            o.describe()
                        ),
                    )),
                }
            }
            None => Ok([1.0; 3]),
        }
    }

    /// An `area` or `angulararea` emitter object: its radiance, W m^-2 sr^-1, and for
    /// `angulararea` its profile: full within `beam_width` (degrees; default the
    /// cutoff), falling linearly in angle to 0 at `cutoff_angle` (default 10), as
    /// mitransient defines it.
    pub(super) fn area_emitter(&mut self, k: usize) -> Result<AreaEmitter, SceneError> {
        let o = self.object(k);
        let radiance = self.quantity(o, "radiance")?;
        let falloff = if o.plugin == "angulararea" {
            let cutoff = o.float("cutoff_angle", 10.0)?;
            let beam = o.float("beam_width", cutoff)?;
            let f = AngularFalloff {
                beam_width_rad: beam.to_radians() as f32,
                cutoff_rad: cutoff.to_radians() as f32,
            };
            f.check()
                .map_err(|e| err(&o.loc, format!("{}: {e}", o.describe())))?;
            Some(f)
        } else {
            None
        };
        Ok(AreaEmitter { radiance, falloff })
    }

    /// A top-level `<emitter>`.
    pub(super) fn add_emitter(&mut self, k: usize) -> Result<(), SceneError> {
        let o = self.object(k);
        let name =
            o.id.clone()
                .unwrap_or_else(|| format!("{} at {}", o.plugin, o.loc));
        let to_world = o.transform("to_world")?;
        let axis = |m: &glam::DMat4| -> Result<glam::Vec3, SceneError> {
            (DMat3::from_mat4(*m) * DVec3::Z)
                .try_normalize()
                .map(|d| d.as_vec3())
                .ok_or_else(|| {
                    err(
                        &o.loc,
                        format!("{}: to_world has no +Z direction", o.describe()),
                    )
                })
        };
        match o.plugin.as_str() {
            "point" | "spot" => {
                let position = match o.vector("position")? {
                    Some(p) => DVec3::from(p),
                    None => to_world.transform_point3(DVec3::ZERO),
                };
                let intensity = self.quantity(o, "intensity")?;
                let spot = if o.plugin == "spot" {
                    let cutoff = o.float("cutoff_angle", 20.0)?;
                    let beam = o.float("beam_width", cutoff * 0.75)?;
                    if !(cutoff > 0.0 && cutoff <= 90.0 && beam >= 0.0 && beam <= cutoff) {
                        return Err(err(
                            &o.loc,
                            format!(
                                "{}: cutoff_angle {cutoff} and beam_width {beam} must satisfy 0 <= beam_width <= cutoff_angle <= 90 degrees",
                                o.describe()
                            ),
                        ));
                    }
                    if o.prop("texture").is_some() {
                        return Err(Builder::unsupported(o, "a projected texture"));
                    }
                    self.note_at(&o.loc, "<emitter type=\"spot\">: the falloff between beam_width and cutoff_angle is tprf's smooth one (Mitsuba's is linear in the angle)".into());
                    Some(Spot {
                        direction: axis(&to_world)?,
                        inner_cone_rad: beam.to_radians() as f32,
                        outer_cone_rad: cutoff.to_radians() as f32,
                    })
                } else {
                    None
                };
                self.lights.push(PunctualLight {
                    name,
                    position: position.as_vec3(),
                    intensity_w_per_sr: intensity.map(|v| v as f32),
                    spot,
                    projector: None,
                });
            }
            "directional" => {
                let direction = match o.vector("direction")? {
                    Some(d) => DVec3::from(d)
                        .try_normalize()
                        .map(|d| d.as_vec3())
                        .ok_or_else(|| {
                            err(&o.loc, "<emitter type=\"directional\">: direction is zero")
                        })?,
                    None => axis(&to_world)?,
                };
                let irradiance = self.quantity(o, "irradiance")?;
                self.ambient.directional.push(DirectionalLight {
                    name,
                    direction,
                    irradiance_w_per_m2: irradiance.map(|v| v as f32),
                });
                self.note_at(&o.loc, "<emitter type=\"directional\"> is steady light in tprf's ambient group (in the ambient image, not the transient cube)".into());
            }
            "constant" => {
                let radiance = self.quantity(o, "radiance")?;
                self.ambient.sky_radiance = radiance.map(|v| v as f32);
                self.note_at(&o.loc, "<emitter type=\"constant\"> is tprf's steady sky (in the ambient image, not the transient cube)".into());
            }
            "area" => {
                return Err(err(
                    &o.loc,
                    "<emitter type=\"area\"> outside a shape: put it inside the <shape> that emits",
                ));
            }
            "projector" => return self.read_projector(k),
            _ => return Err(Builder::unsupported(o, "")),
        }
        Ok(())
    }
}
