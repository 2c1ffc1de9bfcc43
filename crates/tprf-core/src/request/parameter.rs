//! Named scene parameters for differentiable rendering: `material:NAME.albedo`,
//! `material:NAME.emission`, `light:NAME.intensity`, `medium.sigma_s`,
//! `medium.sigma_a`, `medium.g`. NAME is everything between the prefix and the last dot
//! (so names may hold dots: `material:lambert_0.5.albedo`), matched against the glTF
//! material and node names or the Mitsuba XML ids.
//!
//! Each parameter is one number, the value in the rendered band (the cube is one
//! channel): setting it writes a grey colour, so the band's value is the number whatever
//! the channel (`Channel::pick` of `(v, v, v)` is `v`).
//!
//! Geometry (node positions, rotations, scales, the camera) is refused by name: moving
//! an edge moves the visibility discontinuities the integrand has, whose derivative is a
//! boundary term the interior estimator never samples (it needs edge sampling or a
//! reparameterisation; docs/gradients.md).

use crate::scene::{Material, Scene, SurfaceModel};
use crate::transport::derivative::Wrt;
use std::fmt;

/// What a named parameter is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// `Scene::materials[i]`'s albedo: its base colour factor grey, in [0, 1].
    Albedo(usize),
    /// `Scene::materials[i]`'s emitted radiance, W / (m^2 sr), > 0.
    Emission(usize),
    /// `Scene::lights[i]`'s radiant intensity, W/sr, > 0.
    Intensity(usize),
    /// The scene medium's scattering coefficient, 1/m.
    SigmaS,
    /// The scene medium's absorption coefficient, 1/m.
    SigmaA,
    /// The scene medium's Henyey-Greenstein asymmetry.
    G,
}

/// A parameter name that cannot be differentiated, and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParameterError {
    #[error("unknown parameter {name:?}: {why}; known: {known}")]
    Unknown {
        name: String,
        why: String,
        known: String,
    },
    #[error("{name:?} is not differentiable: {why}")]
    Refused { name: String, why: String },
    #[error("{name:?} = {value}: {why}")]
    Value {
        name: String,
        value: f64,
        why: &'static str,
    },
}

/// The fields a material's parameter may name.
const MATERIAL_FIELDS: [&str; 2] = ["albedo", "emission"];
/// Fields of a material that exist but are not differentiable here.
const MATERIAL_REFUSED: [&str; 6] = [
    "roughness",
    "metallic",
    "ior",
    "transmission",
    "specular",
    "alpha",
];
/// Words that name geometry or the camera.
const GEOMETRY: [&str; 9] = [
    "camera",
    "node",
    "object",
    "mesh",
    "position",
    "translation",
    "rotation",
    "scale",
    "fov",
];

const WHY_GEOMETRY: &str = "geometry and the camera move visibility edges, whose \
    derivative is a boundary term that path sampling does not see (it needs edge sampling or \
    a reparameterisation of the integral); only material, light and medium values are \
    differentiable (docs/gradients.md)";

impl Target {
    /// The parameter `name` of `scene` (the module doc gives the forms).
    pub fn parse(name: &str, scene: &Scene) -> Result<Target, ParameterError> {
        let refused = |why: String| ParameterError::Refused {
            name: name.into(),
            why,
        };
        let unknown = |why: String| ParameterError::Unknown {
            name: name.into(),
            why,
            known: known_names(scene).join(", "),
        };
        let lowered = name.to_ascii_lowercase();
        if let Some(field) = lowered.strip_prefix("medium.") {
            return match field {
                "sigma_s" => Ok(Target::SigmaS),
                "sigma_a" => Ok(Target::SigmaA),
                "g" => Ok(Target::G),
                "n" => Err(refused(
                    "a medium's index changes arrival times (it moves light between bins, \
                     a discontinuity in time)"
                        .into(),
                )),
                _ => Err(unknown(format!("a medium has no field {field:?}"))),
            };
        }
        let (kind, rest) = match name.split_once(':') {
            Some((k, r)) => (k.to_ascii_lowercase(), r),
            None => (String::new(), name),
        };
        let (object, field) = rest.rsplit_once('.').unwrap_or((rest, ""));
        let field_l = field.to_ascii_lowercase();
        if GEOMETRY.contains(&kind.as_str()) || GEOMETRY.contains(&field_l.as_str()) {
            return Err(refused(WHY_GEOMETRY.into()));
        }
        match kind.as_str() {
            "material" => {
                let i = find(
                    scene.materials.iter().map(|m| m.name.as_str()),
                    object,
                    "material",
                )
                .map_err(unknown)?;
                let m = &scene.materials[i];
                match field_l.as_str() {
                    "albedo" => {
                        if let SurfaceModel::Conductor { .. } = m.model {
                            return Err(refused(format!(
                                "material {object:?} is a conductor, which has no base \
                                 colour (its reflectance is its complex index's)"
                            )));
                        }
                        Ok(Target::Albedo(i))
                    }
                    "emission" => Ok(Target::Emission(i)),
                    f if MATERIAL_REFUSED.contains(&f) => Err(refused(format!(
                        "a material's {f} is not differentiable here (only {})",
                        MATERIAL_FIELDS.join(" and ")
                    ))),
                    f => Err(unknown(format!(
                        "a material has no field {f:?} (differentiable: {})",
                        MATERIAL_FIELDS.join(", ")
                    ))),
                }
            }
            "light" => {
                let i = find(
                    scene.lights.iter().map(|l| l.name.as_str()),
                    object,
                    "light",
                )
                .map_err(unknown)?;
                match field_l.as_str() {
                    "intensity" => Ok(Target::Intensity(i)),
                    "color" | "colour" | "spot" | "cone" => Err(refused(format!(
                        "a light's {field} is not differentiable here (only intensity)"
                    ))),
                    f => Err(unknown(format!(
                        "a light has no field {f:?} (differentiable: intensity)"
                    ))),
                }
            }
            _ => Err(unknown(
                "a parameter is material:NAME.FIELD, light:NAME.FIELD or medium.FIELD".into(),
            )),
        }
    }

    /// The parameter's value in `scene`, in the band `pick` takes of a colour.
    pub fn value(self, scene: &Scene, pick: impl Fn([f32; 3]) -> f32) -> f64 {
        let rgb = |c: [f32; 4]| [c[0], c[1], c[2]];
        let medium = |f: &dyn Fn(&crate::scene::Medium) -> f32| {
            scene.medium.as_ref().map_or(0.0, |m| f(m) as f64)
        };
        match self {
            Target::Albedo(i) => pick(rgb(scene.materials[i].base_color)) as f64,
            Target::Emission(i) => pick(scene.materials[i].emissive) as f64,
            Target::Intensity(i) => pick(scene.lights[i].intensity_w_per_sr) as f64,
            Target::SigmaS => medium(&|m| pick(m.sigma_s_per_m)),
            Target::SigmaA => medium(&|m| pick(m.sigma_a_per_m)),
            Target::G => medium(&|m| m.g),
        }
    }

    /// Write `value` into `scene` (grey, so that every band's value is `value`), after
    /// checking its range; errors name `name`.
    pub fn set(self, scene: &mut Scene, value: f64, name: &str) -> Result<(), ParameterError> {
        let bad = |why| ParameterError::Value {
            name: name.into(),
            value,
            why,
        };
        if !value.is_finite() {
            return Err(bad("not a finite number"));
        }
        let v = value as f32;
        let grey = |m: &mut Material| {
            m.base_color = [v, v, v, m.base_color[3]];
        };
        match self {
            Target::Albedo(i) => {
                if !(0.0..=1.0).contains(&value) {
                    return Err(bad("an albedo is in [0, 1]"));
                }
                grey(&mut scene.materials[i]);
            }
            Target::Emission(i) => {
                if !(value > 0.0) {
                    return Err(bad(
                        "an emission being differentiated must be positive (at 0 the \
                         material is no light source, and the light tables change)",
                    ));
                }
                scene.materials[i].emissive = [v; 3];
            }
            Target::Intensity(i) => {
                if !(value > 0.0) {
                    return Err(bad(
                        "an intensity being differentiated must be positive (at 0 the light \
                         is no light source, and the light tables change)",
                    ));
                }
                scene.lights[i].intensity_w_per_sr = [v; 3];
            }
            Target::SigmaS | Target::SigmaA | Target::G => {
                let Some(m) = scene.medium.as_mut() else {
                    return Err(bad("the scene has no medium"));
                };
                match self {
                    Target::SigmaS if value >= 0.0 => m.sigma_s_per_m = [v; 3],
                    Target::SigmaA if value >= 0.0 => m.sigma_a_per_m = [v; 3],
                    Target::G if value > -1.0 && value < 1.0 => m.g = v,
                    Target::G => return Err(bad("g is in (-1, 1)")),
                    _ => return Err(bad("a coefficient is at least 0")),
                }
            }
        }
        Ok(())
    }

    /// The transport's parameter for this one at `value`; `None` for the medium's.
    pub fn wrt(self, value: f64) -> Option<Wrt> {
        match self {
            Target::Albedo(material) => Some(Wrt::Albedo { material }),
            Target::Emission(material) => Some(Wrt::Emission {
                material,
                value: value as f32,
            }),
            Target::Intensity(light) => Some(Wrt::Intensity {
                light,
                value: value as f32,
            }),
            Target::SigmaS | Target::SigmaA | Target::G => None,
        }
    }
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{self:?}")
    }
}

/// The index of the one item of `names` equal to `name`; the error says why not.
fn find<'a>(names: impl Iterator<Item = &'a str>, name: &str, what: &str) -> Result<usize, String> {
    let hits: Vec<usize> = names
        .enumerate()
        .filter(|(_, n)| *n == name)
        .map(|(i, _)| i)
        .collect();
    match hits.as_slice() {
        [i] => Ok(*i),
        [] => Err(format!("the scene has no {what} named {name:?}")),
        _ => Err(format!(
            "{} {what}s are named {name:?}: rename them to tell them apart",
            hits.len()
        )),
    }
}

/// Every differentiable name of `scene`.
pub fn known_names(scene: &Scene) -> Vec<String> {
    let mut out = Vec::new();
    for m in &scene.materials {
        if !matches!(m.model, SurfaceModel::Conductor { .. }) {
            out.push(format!("material:{}.albedo", m.name));
        }
        out.push(format!("material:{}.emission", m.name));
    }
    for l in &scene.lights {
        out.push(format!("light:{}.intensity", l.name));
    }
    if scene.medium.is_some() {
        out.extend(["medium.sigma_s", "medium.sigma_a", "medium.g"].map(String::from));
    }
    out
}
