//! The paper's 1-D world (its Figure 4) built as a 3-D scene, so that the path tracer
//! can be measured against the exact impulse train of [`crate::oned`].
//!
//! Radiance is constant along a ray, so a ray along the line's axis sees exactly what
//! the 1-D eye sees when every interface is a plane perpendicular to the axis that
//! - passes a fraction `t` of the light straight through, undelayed (alpha coverage
//!   `a = 1 - t`, the paper's virtual interface), and
//! - reflects a fraction `r` back (the covered part is a perfect mirror of reflectance
//!   `r / a`; a metal's Schlick Fresnel equals its base colour at normal incidence),
//!
//! and the light point L is a black emitting plane of radiance 1 (the pulse leaves it at
//! t = 0). A pixel of a camera at E looking along the axis with a narrow field of view
//! (0.1 degree: path lengths grow by at most 2e-7 relatively) then records, per time bin,
//! the summed weights of the impulses in that bin.
//!
//! What a 3-D plane cannot express is refused with a reason: a refractive index other
//! than 1, a light in front of the eye or between interfaces, an interface that treats
//! its two sides differently where light reaches both, or anything behind the light
//! that reflects towards it (the emitting plane would absorb it).

use super::ReferenceError;
use crate::film::TimeAxis;
use crate::oned::{Direction, ImpulseOptions, InterfaceKind, World, binned};
use crate::scene::{AlphaMode, Camera, Material, Scene, Triangle, TriangleAttrs};
use glam::{Vec2, Vec3};

/// The paper's Figure 4 world (`assets/oned/figure4.json`).
pub fn figure4_world() -> World {
    World::from_json_str(include_str!("../../../../assets/oned/figure4.json"))
        .expect("the bundled Figure 4 world is valid")
}

/// One interface as a 3-D plane: distance in front of the eye, coverage and the mirror
/// reflectance of the covered part (0 for a black absorber).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Layer {
    depth_m: f64,
    coverage: f64,
    mirror: f64,
}

/// A 1-D world and its 3-D stand-in.
#[derive(Clone, Debug, PartialEq)]
pub struct OnedScene {
    world: World,
    layers: Vec<Layer>,
    /// Distance of the emitting plane behind the eye, m.
    light_behind_m: f64,
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
}

/// Sides that differ by less than this are equal.
const SIDE_TOLERANCE: f64 = 1e-12;

impl OnedScene {
    /// Check that `world` has an exact 3-D stand-in and build it.
    pub fn new(world: World) -> Result<OnedScene, String> {
        if world.segment_ior().iter().any(|&n| n != 1.0) {
            return Err("the 3-D stand-in needs a refractive index of 1 in every segment".into());
        }
        let look = world.look();
        let s = look.sign();
        let ahead = |x: f64| (x - world.eye_m()) * s;
        let light_behind_m = -ahead(world.light_m());
        if !(light_behind_m > 0.0) {
            return Err(format!(
                "the 3-D stand-in needs the light behind the eye (the side it does not look \
                 to); the light is at {} m, the eye at {} m looking {look}",
                world.light_m(),
                world.eye_m()
            ));
        }
        // The side of an interface that light coming from the eye's side meets.
        let near_side = |i: &crate::oned::Interface| match look {
            Direction::Right => (i.left, i.right),
            Direction::Left => (i.right, i.left),
        };
        let mut front: Vec<&crate::oned::Interface> = Vec::new();
        for i in world.interfaces() {
            let a = ahead(i.x_m);
            if a > 0.0 {
                front.push(i);
            } else if a > -light_behind_m {
                return Err(format!(
                    "interface '{}' lies between the light and the eye: the 3-D stand-in \
                     needs the light right behind the eye",
                    i.name
                ));
            } else {
                // Behind the light: it must send nothing back towards it.
                let (near, _) = near_side(i);
                if i.kind == InterfaceKind::Real && near.reflectance > 0.0 {
                    return Err(format!(
                        "interface '{}' behind the light reflects light back (reflectance {}): \
                         the 3-D stand-in's emitting plane would absorb it",
                        i.name, near.reflectance
                    ));
                }
            }
        }
        front.sort_by(|a, b| ahead(a.x_m).total_cmp(&ahead(b.x_m)));
        let mut layers = Vec::new();
        for i in front {
            let depth_m = ahead(i.x_m);
            match i.kind {
                InterfaceKind::Virtual => continue,
                InterfaceKind::Boundary => {
                    layers.push(Layer {
                        depth_m,
                        coverage: 1.0,
                        mirror: 0.0,
                    });
                    break;
                }
                InterfaceKind::Real => {
                    let (near, far) = near_side(i);
                    if near.transmittance == 0.0 {
                        // Opaque: its far side is never reached.
                        layers.push(Layer {
                            depth_m,
                            coverage: 1.0,
                            mirror: near.reflectance,
                        });
                        break;
                    }
                    if (near.reflectance - far.reflectance).abs() > SIDE_TOLERANCE
                        || (near.transmittance - far.transmittance).abs() > SIDE_TOLERANCE
                    {
                        return Err(format!(
                            "interface '{}' treats its two sides differently (r {}, t {} vs \
                             r {}, t {}) and light reaches both: a 3-D surface has one material",
                            i.name,
                            near.reflectance,
                            near.transmittance,
                            far.reflectance,
                            far.transmittance
                        ));
                    }
                    let coverage = 1.0 - near.transmittance;
                    if coverage <= 0.0 {
                        continue;
                    }
                    layers.push(Layer {
                        depth_m,
                        coverage,
                        mirror: (near.reflectance / coverage).min(1.0),
                    });
                }
            }
        }
        Ok(OnedScene {
            world,
            layers,
            light_behind_m,
            fov_deg: 0.1,
        })
    }

    pub fn world(&self) -> &World {
        &self.world
    }

    /// The impulses up to `t_max_s`.
    fn impulses(&self, t_max_s: f64) -> Vec<crate::oned::Impulse> {
        let opts = ImpulseOptions {
            t_max_s,
            ..ImpulseOptions::default()
        };
        self.world.impulse_train(&opts).impulses
    }

    /// The scene: the eye at the origin looking along -Z; each layer a square at
    /// `z = -depth`, the emitting plane at `z = +light_behind`.
    pub fn scene(&self) -> Scene {
        let far_m = self.layers.last().map_or(1.0, |l| l.depth_m);
        // Wide enough for rays at the corner of the view to stay on the planes for 200
        // round trips to the farthest layer.
        let tan_half = (0.5 * self.fov_deg.to_radians()).tan();
        let half = (1.5 * tan_half * 400.0 * far_m).max(1.0) as f32;
        let mut s = Scene {
            name: "1-D world".into(),
            triangles: Vec::new(),
            attrs: Vec::new(),
            materials: Vec::new(),
            textures: Vec::new(),
            lights: Vec::new(),
            camera: Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, self.fov_deg.to_radians() as f32),
            ambient: Default::default(),
            objects: Vec::new(),
            medium: None,
            notes: Vec::new(),
        };
        let quad = |s: &mut Scene, z: f64, m: Material| {
            let z = z as f32;
            let id = s.materials.len() as u32;
            s.materials.push(m);
            let p = |x: f32, y: f32| Vec3::new(x, y, z);
            let (a, b, c, d) = (
                p(-half, -half),
                p(half, -half),
                p(half, half),
                p(-half, half),
            );
            for t in [[a, b, c], [a, c, d]] {
                s.triangles.push(Triangle { p: t });
                s.attrs.push(TriangleAttrs {
                    normals: None,
                    uv: [Vec2::ZERO; 3],
                    material: id,
                });
            }
        };
        for (k, l) in self.layers.iter().enumerate() {
            let m = if l.mirror > 0.0 {
                Material {
                    name: format!("layer {k}"),
                    base_color: [
                        l.mirror as f32,
                        l.mirror as f32,
                        l.mirror as f32,
                        l.coverage as f32,
                    ],
                    metallic: 1.0,
                    roughness: 0.0,
                    specular_factor: 1.0,
                    alpha_mode: if l.coverage < 1.0 {
                        AlphaMode::Blend
                    } else {
                        AlphaMode::Opaque
                    },
                    ..Material::default()
                }
            } else {
                let mut m = Material::lambertian(&format!("layer {k}"), [0.0; 3]);
                if l.coverage < 1.0 {
                    m.base_color[3] = l.coverage as f32;
                    m.alpha_mode = AlphaMode::Blend;
                }
                m
            };
            quad(&mut s, -l.depth_m, m);
        }
        let mut light = Material::lambertian("light", [0.0; 3]);
        light.emissive = [1.0; 3];
        quad(&mut s, self.light_behind_m, light);
        s
    }

    /// Bins from t = 0 to 5 % after the time holding all but 1e-6 of the train's weight;
    /// the start shifted by a fraction of a bin so that no impulse lies within 1 % of a
    /// bin edge where avoidable (rays at the edge of the view travel 2e-7 further).
    pub fn default_axis(&self, bins: usize) -> Result<TimeAxis, ReferenceError> {
        let imp = self.impulses(f64::INFINITY);
        let total: f64 = imp.iter().map(|i| i.weight).sum();
        if !(total > 0.0) {
            return Err(ReferenceError::Dark);
        }
        let mut acc = 0.0;
        let mut end_s = imp.last().map_or(0.0, |i| i.time_s);
        for i in &imp {
            acc += i.weight;
            if acc >= (1.0 - 1e-6) * total {
                end_s = i.time_s;
                break;
            }
        }
        let bins_f = bins.max(1) as f64;
        let dt = 1.05 * end_s / (bins_f - 1.0).max(1.0);
        let significant: Vec<f64> = imp
            .iter()
            .filter(|i| i.weight > 1e-9 * total && i.time_s <= end_s)
            .map(|i| i.time_s)
            .collect();
        let margin = |t0: f64| {
            significant
                .iter()
                .map(|t| {
                    let f = ((t - t0) / dt).rem_euclid(1.0);
                    f.min(1.0 - f)
                })
                .fold(0.5, f64::min)
        };
        let t0 = (0..64)
            .map(|k| -(k as f64) / 64.0 * dt)
            .max_by(|a, b| margin(*a).total_cmp(&margin(*b)))
            .unwrap_or(0.0);
        Ok(TimeAxis::new(t0.max(-dt), dt, bins)?)
    }

    /// The expected TPRF of every pixel on `axis` (the emitting plane has radiance 1).
    pub fn tprf(&self, axis: &TimeAxis) -> Vec<f64> {
        let imp = self.impulses(axis.end_s() * (1.0 + 1e-9));
        // The 1-D binning settles exact edges itself, the film uses TimeAxis::bin_of: they
        // agree except within rounding of an edge, which default_axis avoids.
        binned(&imp, axis.t0_s, axis.dt_s, axis.bins)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::units::C_M_PER_S;

    #[test]
    fn figure4_becomes_two_mirrors_and_a_light() {
        let o = OnedScene::new(figure4_world()).unwrap();
        assert_eq!(o.layers.len(), 2);
        assert!((o.layers[0].coverage - 0.4).abs() < 1e-12);
        assert!((o.layers[0].mirror - 0.75).abs() < 1e-12);
        assert_eq!(o.layers[1].coverage, 1.0);
        assert!((o.layers[1].mirror - 0.8).abs() < 1e-12);
        let axis = o.default_axis(256).unwrap();
        let t = o.tprf(&axis);
        // The first echo: A's reflectance 0.3 at 20.5 m of optical path.
        let b = axis.bin_of(20.5 / C_M_PER_S).unwrap();
        assert!((t[b] - 0.3).abs() < 1e-12);
        // Total: rA + tA tA' rB / (1 - rA' rB).
        let total: f64 = t.iter().sum();
        let want = 0.3 + 0.36 * 0.8 / (1.0 - 0.24);
        assert!((total - want).abs() < 1e-5 * want, "{total} vs {want}");
        assert_eq!(o.scene().validate().map_err(|e| e.to_string()), Ok(()));
    }

    #[test]
    fn unsupported_worlds_are_refused_with_a_reason() {
        let base = r#"{"interfaces": [{"name": "A", "x_m": 5.0,
            "left": {"reflectance": 0.3, "transmittance": 0.6},
            "right": {"reflectance": 0.1, "transmittance": 0.6}},
            {"name": "B", "x_m": 9.0, "left": {"reflectance": 0.5}}],
            "eye_m": 0.0, "look": "right", "light_m": -1.0}"#;
        let e = OnedScene::new(World::from_json_str(base).unwrap()).unwrap_err();
        assert!(e.contains("two sides"), "{e}");
        let front = base
            .replace("\"light_m\": -1.0", "\"light_m\": 1.0")
            .replace("\"reflectance\": 0.1", "\"reflectance\": 0.3");
        let e = OnedScene::new(World::from_json_str(&front).unwrap()).unwrap_err();
        assert!(e.contains("behind the eye"), "{e}");
        let ior = base
            .replace("\"reflectance\": 0.1", "\"reflectance\": 0.3")
            .replace(
                "\"light_m\": -1.0",
                "\"light_m\": -1.0, \"segment_ior\": [1, 1.5, 1]",
            );
        let e = OnedScene::new(World::from_json_str(&ior).unwrap()).unwrap_err();
        assert!(e.contains("refractive"), "{e}");
    }
}
