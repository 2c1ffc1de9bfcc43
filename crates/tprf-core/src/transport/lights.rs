//! Light sources for next-event estimation: punctual lights (delta in position) and
//! emissive triangles (area lights, sampled by emitted power) for the pulsed render
//! ([`Lights::new`]); for the steady ambient image ([`Lights::ambient`]) the scene's
//! ambient group instead: its point and spot lights, directional lights (delta in
//! direction) and a constant sky.

use crate::scene::{Channel, DirectionalLight, PunctualLight, Scene};
use glam::Vec3;

/// A point or spot light reduced to one band.
#[derive(Clone, Copy, Debug)]
pub struct Punctual {
    pub position: Vec3,
    /// Radiant intensity in this band, W/sr.
    pub intensity_w_per_sr: f32,
    spot: Option<(Vec3, f32, f32)>,
}

impl Punctual {
    fn new(l: &PunctualLight, channel: Channel) -> Punctual {
        let spot = l.spot.map(|s| {
            let cos_outer = s.outer_cone_rad.cos();
            let cos_inner = s.inner_cone_rad.cos();
            let scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
            (s.direction.normalize_or_zero(), scale, -cos_outer * scale)
        });
        Punctual {
            position: l.position,
            intensity_w_per_sr: channel.pick(l.intensity_w_per_sr).max(0.0),
            spot,
        }
    }

    /// Radiant intensity toward unit direction `dir` (from the light), W/sr. Spot lights
    /// use KHR_lights_punctual's recommended smooth falloff between the cone angles.
    pub fn intensity_toward(&self, dir: Vec3) -> f32 {
        match self.spot {
            None => self.intensity_w_per_sr,
            Some((axis, scale, offset)) => {
                let a = (axis.dot(dir) * scale + offset).clamp(0.0, 1.0);
                self.intensity_w_per_sr * a * a
            }
        }
    }
}

/// A directional light (the sun) reduced to one band: delta in direction.
#[derive(Clone, Copy, Debug)]
pub struct Directional {
    /// Unit direction toward the light (minus the direction it travels).
    pub toward_light: Vec3,
    /// Irradiance in this band on a surface facing the light, W/m^2.
    pub irradiance_w_per_m2: f32,
}

impl Directional {
    fn new(d: &DirectionalLight, channel: Channel) -> Directional {
        Directional {
            toward_light: -d.direction.normalize_or_zero(),
            irradiance_w_per_m2: channel.pick(d.irradiance_w_per_m2).max(0.0),
        }
    }
}

/// An emissive triangle.
#[derive(Clone, Copy, Debug)]
pub struct Emitter {
    pub triangle: u32,
    p0: Vec3,
    e1: Vec3,
    e2: Vec3,
    pub area_m2: f32,
}

/// A point sampled on an emitter.
#[derive(Clone, Copy, Debug)]
pub struct EmitterSample {
    pub triangle: u32,
    pub position: Vec3,
    pub u: f32,
    pub v: f32,
    /// Probability density per unit area, 1/m^2 (emitter choice included).
    pub pdf_area: f32,
}

/// All lights of a scene in one band.
pub struct Lights {
    pub punctual: Vec<Punctual>,
    /// Directional lights: only in the ambient group ([`Lights::ambient`]).
    pub directional: Vec<Directional>,
    /// Radiance of a constant sky in this band, W m^-2 sr^-1, seen by paths that escape
    /// the scene: only in the ambient group.
    pub sky_radiance: f32,
    emitters: Vec<Emitter>,
    /// Cumulative selection probabilities of `emitters`.
    cdf: Vec<f32>,
    /// Scene triangle -> emitter index (`u32::MAX` for none).
    emitter_of: Vec<u32>,
}

impl Lights {
    /// The ambient group of `scene` in one band: its point and spot lights, directional
    /// lights and sky; no emitters (emissive surfaces are pulsed lights).
    pub fn ambient(scene: &Scene, channel: Channel) -> Lights {
        let a = &scene.ambient;
        Lights {
            punctual: a.lights.iter().map(|l| Punctual::new(l, channel)).collect(),
            directional: a
                .directional
                .iter()
                .map(|d| Directional::new(d, channel))
                .filter(|d| d.irradiance_w_per_m2 > 0.0 && d.toward_light != Vec3::ZERO)
                .collect(),
            sky_radiance: channel.pick(a.sky_radiance).max(0.0),
            emitters: Vec::new(),
            cdf: Vec::new(),
            emitter_of: vec![u32::MAX; scene.triangles.len()],
        }
    }

    /// The pulsed lights of `scene` in one band: its punctual lights and emissive
    /// triangles (the ambient group is left out).
    pub fn new(scene: &Scene, channel: Channel) -> Lights {
        let punctual = scene
            .lights
            .iter()
            .map(|l| Punctual::new(l, channel))
            .collect();
        let mut emitters = Vec::new();
        let mut weights = Vec::new();
        let mut emitter_of = vec![u32::MAX; scene.triangles.len()];
        for (i, (t, a)) in scene.triangles.iter().zip(&scene.attrs).enumerate() {
            let Some(m) = scene.materials.get(a.material as usize) else {
                continue;
            };
            // Power per unit radiance: area x pi per emitting side. Textures are not in
            // the selection weights (an upper bound is fine for an unbiased estimator).
            let le = channel.pick(m.emissive);
            let area = t.area_m2();
            if le > 0.0 && area > 0.0 && le.is_finite() {
                let sides = if m.double_sided { 2.0 } else { 1.0 };
                emitter_of[i] = emitters.len() as u32;
                emitters.push(Emitter {
                    triangle: i as u32,
                    p0: t.p[0],
                    e1: t.p[1] - t.p[0],
                    e2: t.p[2] - t.p[0],
                    area_m2: area,
                });
                weights.push(le * area * sides);
            }
        }
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        let mut acc = 0.0f64;
        let cdf = weights
            .iter()
            .map(|&w| {
                acc += w as f64;
                (acc / total) as f32
            })
            .collect();
        Lights {
            punctual,
            directional: Vec::new(),
            sky_radiance: 0.0,
            emitters,
            cdf,
            emitter_of,
        }
    }

    pub fn has_emitters(&self) -> bool {
        !self.emitters.is_empty()
    }

    fn select_probability(&self, i: usize) -> f32 {
        let hi = self.cdf.get(i).copied().unwrap_or(0.0);
        let lo = if i == 0 {
            0.0
        } else {
            self.cdf.get(i - 1).copied().unwrap_or(0.0)
        };
        hi - lo
    }

    /// Pick an emitter by power and a uniform point on it.
    pub fn sample_emitter(&self, u_select: f32, u1: f32, u2: f32) -> Option<EmitterSample> {
        if self.emitters.is_empty() {
            return None;
        }
        let i = self
            .cdf
            .partition_point(|&c| c <= u_select)
            .min(self.emitters.len() - 1);
        let e = &self.emitters[i];
        let s = u1.sqrt();
        let (bu, bv) = (s * (1.0 - u2), s * u2);
        let p = self.select_probability(i);
        (p > 0.0).then(|| EmitterSample {
            triangle: e.triangle,
            position: e.p0 + e.e1 * bu + e.e2 * bv,
            u: bu,
            v: bv,
            pdf_area: p / e.area_m2,
        })
    }

    /// Area density with which `sample_emitter` picks a point on `triangle`, 1/m^2.
    pub fn pdf_area(&self, triangle: u32) -> f32 {
        match self.emitter_of.get(triangle as usize) {
            Some(&i) if i != u32::MAX => {
                let e = &self.emitters[i as usize];
                self.select_probability(i as usize) / e.area_m2
            }
            _ => 0.0,
        }
    }
}
