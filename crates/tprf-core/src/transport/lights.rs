//! Light sources for next-event estimation: punctual lights (delta in position) and
//! emissive triangles (area lights, sampled by emitted power) for the pulsed render
//! ([`Lights::new`]); for the steady ambient image ([`Lights::ambient`]) the scene's
//! ambient group instead: its point and spot lights, directional lights (delta in
//! direction) and a constant sky.

use super::bsdf::{Frame, turn_cos_sin};
use crate::scene::{Channel, DirectionalLight, ImageWrap, IrradianceImage, PunctualLight, Scene};
use glam::Vec3;
use std::sync::Arc;

/// A point or spot light reduced to one band.
#[derive(Clone, Debug)]
pub struct Punctual {
    pub position: Vec3,
    /// Radiant intensity in this band, W/sr.
    pub intensity_w_per_sr: f32,
    /// Spot lights: axis, falloff scale and offset (`a = axis . dir scale + offset`).
    spot: Option<(Vec3, f32, f32)>,
    /// Projectors: the frustum's frame (z its axis) and half-angle tangents.
    projector: Option<ProjectorBeam>,
    /// The cone holding all emission: its axis and the cosine of its half-angle (the
    /// whole sphere, cosine -1 around +Z, for a point light; the outer cone for a spot).
    cone_axis: Vec3,
    cos_cone: f32,
}

/// A projector's frustum: directions `d` with `|d_x / d_z| <= tan_x`, `|d_y / d_z| <=
/// tan_y` in its frame (x the image's left, y its up, z the axis), intensity `I_0
/// E(u, v) / cos^3 theta` (irradiance `I_0 E` across the axis at unit distance, `E` the
/// image's value at the direction's image point, 1 without an image), sampled on the
/// plane `z = 1`: uniformly without an image (density `1 / (4 tan_x tan_y cos^3 theta)`
/// per steradian, proportional to the intensity), by the image's texels with one.
#[derive(Clone, Debug)]
struct ProjectorBeam {
    frame: Frame,
    tan_x: f32,
    tan_y: f32,
    image: Option<Arc<BandImage>>,
}

/// A projector's image in one band, with the table that samples it: each texel cell
/// (the square between four texel centres' neighbours, `[i, i + 1] / width` across)
/// drawn with probability proportional to the largest of the 3 x 3 texels around it,
/// which bounds the bilinear value anywhere in the cell (so a cell with light is never
/// left out), then uniformly inside it.
#[derive(Debug)]
struct BandImage {
    width: usize,
    height: usize,
    wrap: ImageWrap,
    values: Vec<f32>,
    /// Cumulative cell probabilities, the last 1.
    cdf: Vec<f32>,
    /// Sum over cells of the sampling weights over the cell count: at least the image's
    /// mean value (the power bound's factor).
    mean_bound: f32,
}

impl BandImage {
    fn new(im: &IrradianceImage, channel: Channel) -> Option<BandImage> {
        let (width, height) = (im.width as usize, im.height as usize);
        let values: Vec<f32> = im
            .rgb
            .iter()
            .map(|c| channel.pick_texel(*c).max(0.0))
            .collect();
        if width == 0 || height == 0 || values.len() != width * height {
            return None;
        }
        let mut b = BandImage {
            width,
            height,
            wrap: im.wrap,
            values,
            cdf: Vec::new(),
            mean_bound: 0.0,
        };
        let mut sum = 0.0f64;
        let mut cdf = Vec::with_capacity(width * height);
        for j in 0..height as i64 {
            for i in 0..width as i64 {
                let mut m = 0.0f32;
                for dj in -1..=1 {
                    for di in -1..=1 {
                        m = m.max(b.texel(i + di, j + dj));
                    }
                }
                sum += f64::from(m);
                cdf.push(sum);
            }
        }
        if !(sum > 0.0 && sum.is_finite()) {
            return None;
        }
        b.cdf = cdf.iter().map(|c| (c / sum) as f32).collect();
        b.mean_bound = (sum / (width * height) as f64) as f32;
        Some(b)
    }

    /// Texel `(i, j)` with the image's wrap mode applied.
    #[inline]
    fn texel(&self, i: i64, j: i64) -> f32 {
        let (w, h) = (self.width as i64, self.height as i64);
        let (i, j) = match self.wrap {
            ImageWrap::Repeat => (i.rem_euclid(w), j.rem_euclid(h)),
            ImageWrap::Clamp => (i.clamp(0, w - 1), j.clamp(0, h - 1)),
        };
        self.values[(j * w + i) as usize]
    }

    /// The bilinear value at image point `(u, v)` in [0, 1]^2 (texel centres at
    /// `(i + 1/2) / width`), as Mitsuba's `bitmap` texture.
    fn value(&self, u: f32, v: f32) -> f32 {
        let x = u * self.width as f32 - 0.5;
        let y = v * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (i, j) = (x0 as i64, y0 as i64);
        let top = self.texel(i, j) * (1.0 - fx) + self.texel(i + 1, j) * fx;
        let bottom = self.texel(i, j + 1) * (1.0 - fx) + self.texel(i + 1, j + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Probability of the cell holding `(u, v)`.
    fn cell_probability(&self, u: f32, v: f32) -> f32 {
        let i = ((u * self.width as f32) as usize).min(self.width - 1);
        let j = ((v * self.height as f32) as usize).min(self.height - 1);
        let k = j * self.width + i;
        self.cdf[k] - if k == 0 { 0.0 } else { self.cdf[k - 1] }
    }

    /// An image point `(u, v)` drawn by the table for `(u1, u2)` in [0, 1)^2; its
    /// density over the unit square is `cells * cell_probability`.
    fn sample(&self, (u1, u2): (f32, f32)) -> (f32, f32) {
        let k = self
            .cdf
            .partition_point(|&c| c <= u1)
            .min(self.cdf.len() - 1);
        let lo = if k == 0 { 0.0 } else { self.cdf[k - 1] };
        let p = self.cdf[k] - lo;
        let fx = if p > 0.0 {
            ((u1 - lo) / p).clamp(0.0, 0.999_999)
        } else {
            0.5
        };
        let (i, j) = (k % self.width, k / self.width);
        (
            (i as f32 + fx) / self.width as f32,
            (j as f32 + u2) / self.height as f32,
        )
    }
}

impl ProjectorBeam {
    /// `cos theta` of unit `dir` (world) and its image point `(u, v)` (row 0 the top,
    /// column 0 the left as seen from behind the projector) when it is inside the
    /// frustum.
    #[inline]
    fn inside(&self, dir: Vec3) -> Option<(f32, f32, f32)> {
        let d = self.frame.to_local(dir);
        if !(d.z > 0.0 && d.x.abs() <= self.tan_x * d.z && d.y.abs() <= self.tan_y * d.z) {
            return None;
        }
        let u = 0.5 - 0.5 * d.x / (d.z * self.tan_x);
        let v = 0.5 - 0.5 * d.y / (d.z * self.tan_y);
        Some((d.z, u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)))
    }

    /// Area of the frustum's cross-section at unit distance along the axis.
    fn plane_area(&self) -> f32 {
        4.0 * self.tan_x * self.tan_y
    }

    /// The image's value toward image point `(u, v)` (1 without an image).
    #[inline]
    fn value(&self, u: f32, v: f32) -> f32 {
        self.image.as_ref().map_or(1.0, |im| im.value(u, v))
    }

    /// Density of [`ProjectorBeam::sample`] over the plane `z = 1` at image point `(u,
    /// v)`, 1/m^2.
    fn plane_pdf(&self, u: f32, v: f32) -> f32 {
        match &self.image {
            None => 1.0 / self.plane_area(),
            Some(im) => {
                (im.width * im.height) as f32 * im.cell_probability(u, v) / self.plane_area()
            }
        }
    }

    /// A direction (local frame, on the plane `z = 1`) for `(u1, u2)` in [0, 1)^2.
    fn sample(&self, (u1, u2): (f32, f32)) -> Vec3 {
        let (u, v) = match &self.image {
            None => (u1, u2),
            Some(im) => im.sample((u1, u2)),
        };
        Vec3::new(
            (1.0 - 2.0 * u) * self.tan_x,
            (1.0 - 2.0 * v) * self.tan_y,
            1.0,
        )
    }
}

impl Punctual {
    fn new(l: &PunctualLight, channel: Channel) -> Punctual {
        let spot = l.spot.map(|s| {
            let cos_outer = s.outer_cone_rad.cos();
            let cos_inner = s.inner_cone_rad.cos();
            let scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
            (s.direction.normalize_or_zero(), scale, -cos_outer * scale)
        });
        let (cone_axis, cos_cone) = match (l.spot, spot) {
            (Some(s), Some((axis, _, _))) if axis != Vec3::ZERO => (axis, s.outer_cone_rad.cos()),
            _ => (Vec3::Z, -1.0),
        };
        let mut dark = false;
        let projector = l.projector.as_ref().map(|p| {
            let z = p.direction.normalize_or_zero();
            let y = p.up.normalize_or_zero();
            let image = p.image.as_ref().map(|im| BandImage::new(im, channel));
            // An image with no light in this band: a dark projector.
            dark = matches!(image, Some(None));
            ProjectorBeam {
                frame: Frame {
                    t: y.cross(z),
                    b: y,
                    n: z,
                },
                tan_x: p.tan_half_x,
                tan_y: p.tan_half_y,
                image: image.flatten().map(Arc::new),
            }
        });
        // A projector's bounding cone: through the frustum's corners.
        let (cone_axis, cos_cone) = match &projector {
            Some(b) => (
                b.frame.n,
                1.0 / (1.0 + b.tan_x * b.tan_x + b.tan_y * b.tan_y).sqrt(),
            ),
            None => (cone_axis, cos_cone),
        };
        Punctual {
            position: l.position,
            intensity_w_per_sr: if dark {
                0.0
            } else {
                channel.pick(l.intensity_w_per_sr).max(0.0)
            },
            spot,
            projector,
            cone_axis,
            cos_cone,
        }
    }

    /// A point light of 1 W/sr at `position` (for tests).
    #[cfg(test)]
    pub(crate) fn point_at(position: Vec3) -> Punctual {
        Punctual {
            position,
            intensity_w_per_sr: 1.0,
            spot: None,
            projector: None,
            cone_axis: Vec3::Z,
            cos_cone: -1.0,
        }
    }

    /// Whether this light is a projector (it lights only its frustum).
    pub fn is_projector(&self) -> bool {
        self.projector.is_some()
    }

    /// Solid angle of the cone holding the emission, sr: 4 pi for a point light.
    fn cone_sr(&self) -> f32 {
        2.0 * std::f32::consts::PI * (1.0 - self.cos_cone)
    }

    /// An upper bound on the emitted power, W (intensity times the cone's solid angle; a
    /// projector's exact power, `I_0` times its cross-section at unit distance): what
    /// [`Lights::sample_emission`] picks lights by.
    fn power_bound_w(&self) -> f32 {
        match &self.projector {
            Some(b) => {
                let mean = b.image.as_ref().map_or(1.0, |im| im.mean_bound);
                self.intensity_w_per_sr * b.plane_area() * mean
            }
            None => self.intensity_w_per_sr * self.cone_sr(),
        }
    }

    /// A direction uniform in the emission cone for `(u1, u2)` in [0, 1)^2 (the whole
    /// sphere for a point light; a projector's uniform on its cross-section); its
    /// density is [`Punctual::pdf_direction`].
    fn sample_direction(&self, (u1, u2): (f32, f32)) -> Vec3 {
        if let Some(b) = &self.projector {
            return b.frame.to_world(b.sample((u1, u2)).normalize());
        }
        let cos_t = 1.0 - u1 * (1.0 - self.cos_cone);
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let (cos_phi, sin_phi) = turn_cos_sin(u2);
        Frame::new(self.cone_axis).to_world(Vec3::new(sin_t * cos_phi, sin_t * sin_phi, cos_t))
    }

    /// Solid-angle density of [`Punctual::sample_direction`] at unit `dir`, 1/sr.
    fn pdf_direction(&self, dir: Vec3) -> f32 {
        if let Some(b) = &self.projector {
            return b
                .inside(dir)
                .map_or(0.0, |(c, u, v)| b.plane_pdf(u, v) / (c * c * c));
        }
        let inside = self.cos_cone <= -1.0 || self.cone_axis.dot(dir) >= self.cos_cone;
        if inside { 1.0 / self.cone_sr() } else { 0.0 }
    }

    /// Radiant intensity toward unit direction `dir` (from the light), W/sr. Spot lights
    /// use KHR_lights_punctual's recommended smooth falloff between the cone angles.
    pub fn intensity_toward(&self, dir: Vec3) -> f32 {
        if let Some(b) = &self.projector {
            return b.inside(dir).map_or(0.0, |(c, u, v)| {
                self.intensity_w_per_sr * b.value(u, v) / (c * c * c)
            });
        }
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
    /// Cumulative probabilities with which [`Lights::sample_emission`] picks each
    /// punctual light (by [`Punctual::power_bound_w`]).
    punctual_cdf: Vec<f32>,
}

/// A ray leaving a punctual light, for a light vertex (`connect`).
#[derive(Clone, Copy, Debug)]
pub struct EmissionSample {
    pub light: usize,
    /// Unit direction from the light.
    pub dir: Vec3,
    /// Radiant intensity along `dir`, W/sr.
    pub intensity_w_per_sr: f32,
    /// Density of picking this light and `dir`, 1/sr.
    pub pdf: f32,
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
            punctual_cdf: Vec::new(),
        }
    }

    /// The pulsed lights of `scene` in one band: its punctual lights and emissive
    /// triangles (the ambient group is left out).
    pub fn new(scene: &Scene, channel: Channel) -> Lights {
        let punctual: Vec<Punctual> = scene
            .lights
            .iter()
            .map(|l| Punctual::new(l, channel))
            .collect();
        let punctual_cdf = cumulative(punctual.iter().map(|l| l.power_bound_w()));
        let mut emitters = Vec::new();
        let mut weights = Vec::new();
        let mut emitter_of = vec![u32::MAX; scene.triangles.len()];
        // Each material's radiance in the band, once (a wavelength's is a spectral fit).
        let le_of: Vec<f32> = scene
            .materials
            .iter()
            .map(|m| channel.pick(m.emissive))
            .collect();
        for (i, (t, a)) in scene.triangles.iter().zip(&scene.attrs).enumerate() {
            let Some(m) = scene.materials.get(a.material as usize) else {
                continue;
            };
            // Power per unit radiance: area x pi per emitting side. Textures are not in
            // the selection weights (an upper bound is fine for an unbiased estimator).
            let le = le_of[a.material as usize];
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
        let cdf = cumulative(weights.into_iter());
        Lights {
            punctual,
            directional: Vec::new(),
            sky_radiance: 0.0,
            emitters,
            cdf,
            emitter_of,
            punctual_cdf,
        }
    }

    /// A light vertex's first ray: a punctual light picked by emitted power (`u`), then
    /// a direction uniform in its emission cone (`u2`). `None` when no punctual light
    /// emits, or toward a direction where the spot's falloff is 0.
    #[inline(always)]
    pub fn sample_emission(&self, u: f32, u2: (f32, f32)) -> Option<EmissionSample> {
        let total = self.punctual_cdf.last().copied().unwrap_or(0.0);
        if !(total > 0.0) {
            return None;
        }
        let i = pick(&self.punctual_cdf, u);
        let light = &self.punctual[i];
        let dir = light.sample_direction(u2);
        let intensity_w_per_sr = light.intensity_toward(dir);
        let pdf = self.emission_pdf(i, dir);
        (intensity_w_per_sr > 0.0 && pdf > 0.0).then_some(EmissionSample {
            light: i,
            dir,
            intensity_w_per_sr,
            pdf,
        })
    }

    /// Density with which [`Lights::sample_emission`] picks punctual light `i` and unit
    /// direction `dir` from it, 1/sr.
    pub fn emission_pdf(&self, i: usize, dir: Vec3) -> f32 {
        probability(&self.punctual_cdf, i)
            * self.punctual.get(i).map_or(0.0, |l| l.pdf_direction(dir))
    }
}

/// The index `u` in [0, 1) picks from cumulative probabilities `cdf` (not empty).
fn pick(cdf: &[f32], u: f32) -> usize {
    cdf.partition_point(|&c| c <= u).min(cdf.len() - 1)
}

/// The probability of index `i` under cumulative probabilities `cdf` (0 past its end).
fn probability(cdf: &[f32], i: usize) -> f32 {
    let hi = cdf.get(i).copied().unwrap_or(0.0);
    let lo = match i {
        0 => 0.0,
        _ => cdf.get(i - 1).copied().unwrap_or(0.0),
    };
    hi - lo
}

/// Cumulative probabilities in proportion to `weights` (all 0 when they sum to 0).
fn cumulative(weights: impl Iterator<Item = f32>) -> Vec<f32> {
    let weights: Vec<f64> = weights.map(|w| w.max(0.0) as f64).collect();
    let total: f64 = weights.iter().sum();
    let mut acc = 0.0f64;
    weights
        .iter()
        .map(|&w| {
            acc += w;
            if total > 0.0 {
                (acc / total) as f32
            } else {
                0.0
            }
        })
        .collect()
}

impl Lights {
    pub fn has_emitters(&self) -> bool {
        !self.emitters.is_empty()
    }

    /// Pick an emitter by power and a uniform point on it.
    pub fn sample_emitter(&self, u_select: f32, u1: f32, u2: f32) -> Option<EmitterSample> {
        if self.emitters.is_empty() {
            return None;
        }
        let i = pick(&self.cdf, u_select);
        let e = &self.emitters[i];
        let s = u1.sqrt();
        let (bu, bv) = (s * (1.0 - u2), s * u2);
        let p = probability(&self.cdf, i);
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
                probability(&self.cdf, i as usize) / e.area_m2
            }
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Spot, builtin};

    /// Two punctual lights, a point light of 1 W/sr (4 pi W) and a spot of 3 W/sr with a
    /// 60 degree outer cone (3 pi W): picked in proportion 4 : 3, directions uniform in
    /// each one's cone, and the density `emission_pdf` gives is the one sampled.
    #[test]
    fn emission_picks_lights_by_power_and_directions_in_their_cones() {
        let mut scene = builtin::load("cornell").unwrap();
        let light = scene.lights[0].clone();
        let axis = Vec3::new(0.0, -1.0, 0.0);
        scene.lights = vec![
            PunctualLight {
                intensity_w_per_sr: [1.0; 3],
                ..light.clone()
            },
            PunctualLight {
                intensity_w_per_sr: [3.0; 3],
                spot: Some(Spot {
                    direction: axis,
                    inner_cone_rad: 0.5,
                    outer_cone_rad: std::f32::consts::FRAC_PI_3,
                }),
                ..light
            },
        ];
        let lights = Lights::new(&scene, Channel::Gray);
        let n = 4000;
        let mut picked = [0usize; 2];
        for k in 0..n {
            let u = (k as f32 + 0.5) / n as f32;
            let u2 = (
                (k as f32 * 0.618_034).fract(),
                (k as f32 * 0.754_878).fract(),
            );
            let Some(e) = lights.sample_emission(u, u2) else {
                // Only where the spot's smooth falloff is 0: its outer edge.
                continue;
            };
            picked[e.light] += 1;
            assert!((e.dir.length() - 1.0).abs() < 1e-5);
            let (p_pick, cone_sr) = match e.light {
                0 => (4.0 / 7.0, 4.0 * std::f32::consts::PI),
                _ => {
                    assert!(
                        e.dir.dot(axis) >= 0.5 - 1e-5,
                        "outside the cone: {:?}",
                        e.dir
                    );
                    (3.0 / 7.0, std::f32::consts::PI)
                }
            };
            assert!((e.pdf - p_pick / cone_sr).abs() < 1e-5 * e.pdf);
            assert_eq!(e.pdf, lights.emission_pdf(e.light, e.dir));
        }
        let share = picked[0] as f64 / n as f64;
        assert!((share - 4.0 / 7.0).abs() < 1e-3, "{picked:?}");
        // Outside the spot's cone the density is 0.
        assert_eq!(lights.emission_pdf(1, -axis), 0.0);
    }

    /// A projector 2 W/sr on its axis through a frustum of half-angle tangents 1 and 0.7
    /// about -Y: directions sampled inside it, intensity over density the same for all
    /// (the power, I_0 4 tan_x tan_y), and the density a density: its integral over the
    /// sphere, estimated from uniform directions, is 1.
    #[test]
    fn a_projector_emits_and_samples_in_its_frustum() {
        use crate::scene::Projector;
        let mut scene = builtin::load("cornell").unwrap();
        let mut light = scene.lights[0].clone();
        light.intensity_w_per_sr = [2.0; 3];
        light.projector = Some(Projector {
            direction: Vec3::NEG_Y,
            up: Vec3::Z,
            tan_half_x: 1.0,
            tan_half_y: 0.7,
            image: None,
        });
        scene.lights = vec![light];
        let lights = Lights::new(&scene, Channel::Gray);
        let power = 2.0 * 4.0 * 1.0 * 0.7;
        for k in 0..4000 {
            let u2 = (
                (k as f32 * 0.618_034).fract(),
                (k as f32 * 0.754_878).fract(),
            );
            let e = lights.sample_emission(0.5, u2).expect("inside the frustum");
            let local = Vec3::new(e.dir.dot(Vec3::Z.cross(Vec3::NEG_Y)), e.dir.z, -e.dir.y);
            assert!(local.z > 0.0 && local.x.abs() <= local.z * 1.0001);
            assert!(local.y.abs() <= 0.7001 * local.z, "{local}");
            assert!((e.intensity_w_per_sr / e.pdf - power).abs() < 1e-3 * power);
            // The intensity: I_0 / cos^3 theta.
            let cos = local.z;
            assert!(
                (e.intensity_w_per_sr - 2.0 / (cos * cos * cos)).abs()
                    < 1e-4 * e.intensity_w_per_sr
            );
        }
        // Outside: nothing.
        assert_eq!(lights.emission_pdf(0, Vec3::Y), 0.0);
        assert_eq!(lights.punctual[0].intensity_toward(Vec3::X), 0.0);
        // The density integrates to 1: the mean of 4 pi pdf over uniform directions.
        let n = 400_000;
        let mut sum = 0.0f64;
        for k in 0..n {
            let z = 1.0 - 2.0 * ((k as f64 + 0.5) / n as f64);
            let phi = 2.0 * std::f64::consts::PI * (k as f64 * 0.618_033_988_749).fract();
            let r = (1.0 - z * z).sqrt();
            let d = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
            sum += f64::from(lights.emission_pdf(0, d));
        }
        let integral = 4.0 * std::f64::consts::PI * sum / n as f64;
        assert!((integral - 1.0).abs() < 0.01, "{integral}");
    }

    /// A projector with a 5 x 4 image, dark but for two texels: sampled directions land
    /// only where the image can be lit, the density integrates to 1 over the sphere, and
    /// the mean of intensity over density is the projector's power, `I_0` times the
    /// image's integral over the frustum's cross-section (the mean texel value with
    /// repeat wrapping, where each texel's bilinear tent integrates to one texel's area).
    #[test]
    fn a_projectors_image_is_sampled_where_it_is_lit() {
        use crate::scene::{ImageWrap, IrradianceImage, Projector};
        let mut scene = builtin::load("cornell").unwrap();
        let mut light = scene.lights[0].clone();
        light.intensity_w_per_sr = [2.0; 3];
        let mut texels = vec![[0.0f32; 3]; 20];
        texels[6] = [1.0; 3];
        texels[13] = [0.25; 3];
        light.projector = Some(Projector {
            direction: Vec3::NEG_Y,
            up: Vec3::Z,
            tan_half_x: 1.0,
            tan_half_y: 0.7,
            image: Some(Arc::new(IrradianceImage {
                width: 5,
                height: 4,
                rgb: texels,
                wrap: ImageWrap::Repeat,
            })),
        });
        scene.lights = vec![light];
        let lights = Lights::new(&scene, Channel::Gray);
        let power = 2.0 * 4.0 * 1.0 * 0.7 * (1.25 / 20.0);
        let n = 200_000;
        let mut sum = 0.0f64;
        for k in 0..n {
            let u2 = (
                ((k as f64 + 0.5) / n as f64) as f32,
                (k as f32 * 0.618_034).fract(),
            );
            // None: a direction of the drawn cell where the bilinear image is 0 (no
            // light, nothing added).
            if let Some(e) = lights.sample_emission(0.5, u2) {
                sum += f64::from(e.intensity_w_per_sr / e.pdf);
            }
        }
        let mean = sum / n as f64;
        assert!((mean - power).abs() < 0.01 * power, "{mean} vs {power}");
        let n = 800_000;
        let mut integral = 0.0f64;
        for k in 0..n {
            let z = 1.0 - 2.0 * ((k as f64 + 0.5) / n as f64);
            let phi = 2.0 * std::f64::consts::PI * (k as f64 * 0.618_033_988_749).fract();
            let r = (1.0 - z * z).sqrt();
            let d = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
            integral += f64::from(lights.emission_pdf(0, d));
        }
        let integral = 4.0 * std::f64::consts::PI * integral / n as f64;
        assert!((integral - 1.0).abs() < 0.01, "{integral}");
    }
}
