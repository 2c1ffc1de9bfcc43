//! What the transport needs to know at a hit point: position, normals, and the material
//! evaluated there (textures looked up, colours reduced to the rendered band).

use crate::accel::Hit;
use crate::scene::{AlphaMode, AngularFalloff, Channel, Material, Scene, Texture, TextureRef};
use glam::{Vec2, Vec3};
use std::sync::{Arc, OnceLock};

use super::bsdf::{BandModel, Bsdf, BsdfParams};
use super::luminescence::BandLuminescence;

pub mod derivative;

/// sRGB 8-bit code -> linear value.
fn srgb_to_linear_lut() -> &'static [f32; 256] {
    static LUT: OnceLock<[f32; 256]> = OnceLock::new();
    LUT.get_or_init(|| {
        let mut t = [0.0f32; 256];
        for (i, v) in t.iter_mut().enumerate() {
            let c = i as f32 / 255.0;
            *v = if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            };
        }
        t
    })
}

/// Bilinear lookup with repeat wrapping; returns RGBA in [0, 1], RGB decoded from sRGB
/// when `srgb`, alpha always linear.
pub fn sample_texture(tex: &Texture, uv: Vec2, srgb: bool) -> [f32; 4] {
    if tex.width == 0 || tex.height == 0 || tex.rgba8.len() < (tex.width * tex.height) as usize {
        return [1.0; 4];
    }
    let lut = srgb_to_linear_lut();
    let (w, h) = (tex.width as i64, tex.height as i64);
    let x = uv.x * tex.width as f32 - 0.5;
    let y = uv.y * tex.height as f32 - 0.5;
    if !x.is_finite() || !y.is_finite() {
        return [1.0; 4];
    }
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    // The four texels' rows and columns wrapped once (two divisions, not eight).
    let (x0, y0) = ((x0 as i64).rem_euclid(w), (y0 as i64).rem_euclid(h));
    let (x1, y1) = (
        if x0 + 1 == w { 0 } else { x0 + 1 },
        if y0 + 1 == h { 0 } else { y0 + 1 },
    );
    let texel = |xi: i64, yi: i64| -> [f32; 4] {
        let p = tex.rgba8[(yi * w + xi) as usize];
        let c = |v: u8| {
            if srgb {
                lut[v as usize]
            } else {
                v as f32 / 255.0
            }
        };
        [c(p[0]), c(p[1]), c(p[2]), p[3] as f32 / 255.0]
    };
    let (a, b, c, d) = (texel(x0, y0), texel(x1, y0), texel(x0, y1), texel(x1, y1));
    let mut out = [0.0; 4];
    for i in 0..4 {
        let top = a[i] + (b[i] - a[i]) * fx;
        let bottom = c[i] + (d[i] - c[i]) * fx;
        out[i] = top + (bottom - top) * fy;
    }
    out
}

/// A surface point with its material, one band.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub position: Vec3,
    /// Unit geometric normal, on the side the ray came from.
    pub n_face: Vec3,
    /// Unit shading normal, on the same side as `n_face`.
    pub n_shading: Vec3,
    /// Whether the ray hit the front face (counter-clockwise side).
    pub front: bool,
    /// Coverage in [0, 1]; the rest passes straight through.
    pub coverage: f32,
    /// Emitted radiance toward the ray, W / (m^2 sr), this band (0 from a single-sided
    /// emitter's back).
    pub emission: f32,
    /// The BSDF for light leaving toward the ray's side (its relative index set for
    /// that side).
    pub bsdf: Bsdf,
    /// Refractive index of the material's inside in this band (its phase index: what
    /// refraction reads).
    pub ior: f32,
    /// The inside's group index in this band: a path inside takes `ior_group d / c`
    /// (`ior` itself unless the material is dispersive).
    pub ior_group: f32,
}

/// A material reduced to one band, with what does not vary over the surface computed once.
#[derive(Clone, Debug)]
struct BandMaterial {
    /// Parameters without textures.
    params: BsdfParams,
    /// The inside's group index in this band ([`SurfacePoint::ior_group`]).
    ior_group: f32,
    /// The scattering model in this band.
    model: BandModel,
    /// The untextured BSDF seen from the front (eta = 1 / ior) and from the back (ior).
    bsdf_front: Bsdf,
    bsdf_back: Bsdf,
    /// The back face absorbs all light ([`crate::scene::Material::one_sided`]).
    one_sided: bool,
    /// Emitted radiance without texture, this band, W / (m^2 sr), at least 0.
    emission: f32,
    /// The emission's angular profile (an angular area light), if any.
    falloff: Option<AngularFalloff>,
    double_sided: bool,
    /// Fully covering everywhere (alpha mode opaque).
    opaque: bool,
    /// Transmissive: refracts, so it blocks straight shadow rays.
    blocks_shadow_rays: bool,
    /// A texture changes the BSDF or the emission somewhere.
    textured: bool,
}

/// What a hit needs of its triangle, 16 bytes.
#[derive(Clone, Copy, Debug)]
struct TriangleRecord {
    /// Unit geometric normal.
    normal: Vec3,
    /// Index into `Surfaces::materials`; the top bit is set when the triangle has vertex
    /// normals.
    material_and_flags: u32,
}

const HAS_VERTEX_NORMALS: u32 = 1 << 31;

/// The scene reduced to what surfaces look like in one band.
pub struct Surfaces {
    scene: Arc<Scene>,
    channel: Channel,
    /// Per triangle: normal, material, flags.
    triangles: Vec<TriangleRecord>,
    /// The scene's materials in this band, then the default material (for triangles
    /// without a valid material).
    materials: Vec<BandMaterial>,
    /// Per entry of `materials`, its luminescence in this band; empty when no material
    /// is luminescent in it.
    luminescence: Vec<Option<BandLuminescence>>,
}

/// `m`'s index in the band of `channel`: its dispersion's phase index at the band's
/// wavelength ([`Channel::index_wavelength_um`]), else its `ior` (1.5 when that is not a
/// finite number >= 1).
pub(crate) fn band_ior(m: &Material, channel: Channel) -> f32 {
    match &m.dispersion {
        Some(d) => d.n(channel.index_wavelength_um()) as f32,
        None if m.ior.is_finite() && m.ior >= 1.0 => m.ior,
        None => 1.5,
    }
}

/// `m`'s group index in the band of `channel`: `n_g = n - lambda dn/dlambda` of its
/// dispersion there, else [`band_ior`] (no dispersion: the phase index).
pub(crate) fn band_group_ior(m: &Material, channel: Channel) -> f32 {
    match &m.dispersion {
        Some(d) => d.group_index(channel.index_wavelength_um()) as f32,
        None => band_ior(m, channel),
    }
}

impl BandMaterial {
    fn new(m: &Material, channel: Channel) -> BandMaterial {
        let params = BsdfParams {
            base: channel
                .pick([m.base_color[0], m.base_color[1], m.base_color[2]])
                .clamp(0.0, 1.0),
            metallic: m.metallic.clamp(0.0, 1.0),
            roughness: m.roughness.clamp(0.0, 1.0),
            specular_factor: m.specular_factor.clamp(0.0, 1.0),
            specular_color: channel.pick(m.specular_color).max(0.0),
            transmission: m.transmission.clamp(0.0, 1.0),
            ior: band_ior(m, channel),
        };
        let model = BandModel::new(
            &m.model,
            |c| channel.pick(c),
            params.base,
            params.specular_color,
        );
        BandMaterial {
            params,
            ior_group: band_group_ior(m, channel),
            model,
            bsdf_front: Bsdf::build(&model, &params, true),
            bsdf_back: Bsdf::build(&model, &params, false),
            one_sided: m.one_sided,
            emission: if m.is_emissive() {
                channel.pick(m.emissive).max(0.0)
            } else {
                0.0
            },
            falloff: m.emission_falloff,
            double_sided: m.double_sided,
            opaque: m.alpha_mode == AlphaMode::Opaque,
            blocks_shadow_rays: m.transmission > 0.0,
            textured: m.base_color_texture.is_some()
                || m.metallic_roughness_texture.is_some()
                || (m.emissive_texture.is_some() && m.is_emissive()),
        }
    }
}

impl Surfaces {
    pub fn new(scene: Arc<Scene>, channel: Channel) -> Surfaces {
        let mut materials: Vec<BandMaterial> = scene
            .materials
            .iter()
            .map(|m| BandMaterial::new(m, channel))
            .collect();
        let default_material = materials.len() as u32;
        materials.push(BandMaterial::new(&Material::default(), channel));
        let triangles = scene
            .triangles
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let attrs = scene.attrs.get(i);
                let material = attrs
                    .map(|a| a.material)
                    .filter(|&m| (m as usize) < scene.materials.len())
                    .unwrap_or(default_material);
                let normals = attrs.is_some_and(|a| a.normals.is_some());
                TriangleRecord {
                    normal: (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).normalize_or_zero(),
                    material_and_flags: material | if normals { HAS_VERTEX_NORMALS } else { 0 },
                }
            })
            .collect();
        let mut luminescence: Vec<Option<BandLuminescence>> = scene
            .materials
            .iter()
            .map(|m| BandLuminescence::new(m, channel))
            .collect();
        if luminescence.iter().all(Option::is_none) {
            luminescence.clear();
        } else {
            luminescence.push(None); // the default material
        }
        Surfaces {
            scene,
            channel,
            triangles,
            materials,
            luminescence,
        }
    }

    /// Whether any material is luminescent in this band.
    #[inline(always)]
    pub fn any_luminescent(&self) -> bool {
        !self.luminescence.is_empty()
    }

    /// The luminescence of `triangle`'s material in this band, seen from the `front` or
    /// the back (none from the back of a one-sided material, which absorbs).
    #[inline]
    pub fn luminescence(&self, triangle: u32, front: bool) -> Option<&BandLuminescence> {
        let rec = self.record(triangle);
        let i = (rec.material_and_flags & !HAS_VERTEX_NORMALS) as usize;
        if !front && self.band_material(rec).one_sided {
            return None;
        }
        self.luminescence.get(i)?.as_ref()
    }

    #[inline]
    fn record(&self, triangle: u32) -> TriangleRecord {
        self.triangles
            .get(triangle as usize)
            .copied()
            .unwrap_or(TriangleRecord {
                normal: Vec3::Z,
                material_and_flags: (self.materials.len() - 1) as u32,
            })
    }

    #[inline]
    fn band_material(&self, record: TriangleRecord) -> &BandMaterial {
        let i = (record.material_and_flags & !HAS_VERTEX_NORMALS) as usize;
        // The last entry is the default material; `materials` is never empty.
        &self.materials[i.min(self.materials.len() - 1)]
    }

    pub fn geometric_normal(&self, triangle: u32) -> Vec3 {
        self.record(triangle).normal
    }

    pub fn scene(&self) -> &Arc<Scene> {
        &self.scene
    }

    fn texture(&self, r: Option<TextureRef>) -> Option<&Texture> {
        r.and_then(|r| self.scene.textures.get(r.texture as usize))
    }

    pub fn material(&self, triangle: u32) -> &Material {
        static DEFAULT: OnceLock<Material> = OnceLock::new();
        self.scene
            .attrs
            .get(triangle as usize)
            .and_then(|a| self.scene.materials.get(a.material as usize))
            .unwrap_or_else(|| DEFAULT.get_or_init(Material::default))
    }

    fn uv(&self, triangle: u32, u: f32, v: f32) -> Vec2 {
        match self.scene.attrs.get(triangle as usize) {
            Some(a) => a.uv[0] * (1.0 - u - v) + a.uv[1] * u + a.uv[2] * v,
            None => Vec2::ZERO,
        }
    }

    /// Coverage (alpha) of `triangle` at barycentrics `(u, v)`.
    pub fn coverage(&self, triangle: u32, u: f32, v: f32) -> f32 {
        if self.band_material(self.record(triangle)).opaque {
            return 1.0;
        }
        let m = self.material(triangle);
        let mut alpha = m.base_color[3];
        if let Some(t) = self.texture(m.base_color_texture) {
            alpha *= sample_texture(t, self.uv(triangle, u, v), true)[3];
        }
        match m.alpha_mode {
            AlphaMode::Opaque => 1.0,
            AlphaMode::Mask { cutoff } => {
                if alpha >= cutoff {
                    1.0
                } else {
                    0.0
                }
            }
            AlphaMode::Blend => alpha.clamp(0.0, 1.0),
        }
    }

    /// Fraction of a shadow ray's light that passes `triangle` at `(u, v)`: 0 for an
    /// opaque or refracting surface, `1 - coverage` for a partly covered one.
    #[inline]
    pub fn shadow_transmission(&self, triangle: u32, u: f32, v: f32) -> f32 {
        let m = self.band_material(self.record(triangle));
        if m.blocks_shadow_rays || m.opaque {
            0.0
        } else {
            1.0 - self.coverage(triangle, u, v)
        }
    }

    /// Emitted radiance of `triangle` at `(u, v)` toward direction `toward` (unit, away
    /// from the surface), W / (m^2 sr), this band: the material's radiance (times its
    /// texture) times its angular profile at the angle between `toward` and the
    /// triangle's normal (on the side it emits from).
    pub fn emission(&self, triangle: u32, u: f32, v: f32, toward: Vec3) -> f32 {
        let rec = self.record(triangle);
        let bm = self.band_material(rec);
        let cos = rec.normal.dot(toward);
        if bm.emission <= 0.0 || (!bm.double_sided && cos <= 0.0) {
            return 0.0;
        }
        let profile = bm.falloff.map_or(1.0, |f| f.factor(cos.abs()));
        if !bm.textured {
            return bm.emission * profile;
        }
        let m = self.material(triangle);
        let mut e = m.emissive;
        if let Some(t) = self.texture(m.emissive_texture) {
            let c = sample_texture(t, self.uv(triangle, u, v), true);
            e = [e[0] * c[0], e[1] * c[1], e[2] * c[2]];
        }
        self.channel.pick_texel(e).max(0.0) * profile
    }

    /// The BSDF parameters of a textured material at `(u, v)`.
    fn textured_params(&self, triangle: u32, u: f32, v: f32, bm: &BandMaterial) -> BsdfParams {
        let m = self.material(triangle);
        let uv = self.uv(triangle, u, v);
        let mut base = [m.base_color[0], m.base_color[1], m.base_color[2]];
        if let Some(t) = self.texture(m.base_color_texture) {
            let c = sample_texture(t, uv, true);
            base = [base[0] * c[0], base[1] * c[1], base[2] * c[2]];
        }
        let (mut metallic, mut roughness) = (m.metallic, m.roughness);
        if let Some(t) = self.texture(m.metallic_roughness_texture) {
            let c = sample_texture(t, uv, false);
            roughness *= c[1];
            metallic *= c[2];
        }
        BsdfParams {
            base: self.channel.pick_texel(base).clamp(0.0, 1.0),
            metallic: metallic.clamp(0.0, 1.0),
            roughness: roughness.clamp(0.0, 1.0),
            ..bm.params
        }
    }

    /// Everything at a hit of a ray travelling along `dir` (unit).
    #[inline(always)]
    pub fn at(&self, hit: &Hit, origin: Vec3, dir: Vec3) -> SurfacePoint {
        let tri = hit.triangle;
        let (u, v) = (hit.u, hit.v);
        let rec = self.record(tri);
        let bm = self.band_material(rec);
        let ng = rec.normal;
        let front = ng.dot(dir) < 0.0;
        let n_face = if front { ng } else { -ng };
        let mut n_shading = n_face;
        // Seen from behind, as Mitsuba's shading frame decides for a one-sided BSDF: by
        // the interpolated normal where the mesh has one, else by the winding.
        let mut behind = !front;
        if rec.material_and_flags & HAS_VERTEX_NORMALS != 0
            && let Some(ns) = self.scene.attrs.get(tri as usize).and_then(|a| a.normals)
        {
            let n = (ns[0] * (1.0 - u - v) + ns[1] * u + ns[2] * v).normalize_or_zero();
            if n != Vec3::ZERO {
                n_shading = if n.dot(n_face) < 0.0 { -n } else { n };
                behind = n.dot(dir) > 0.0;
            }
        }
        let bsdf = if bm.one_sided && behind {
            Bsdf::BLACK
        } else if bm.textured {
            let p = self.textured_params(tri, u, v, bm);
            Bsdf::build(&bm.model, &p, front)
        } else if front {
            bm.bsdf_front
        } else {
            bm.bsdf_back
        };
        SurfacePoint {
            position: match self.scene.triangles.get(tri as usize) {
                Some(t) => t.p[0] * (1.0 - u - v) + t.p[1] * u + t.p[2] * v,
                None => origin + dir * hit.t_m,
            },
            n_face,
            n_shading,
            front,
            coverage: if bm.opaque {
                1.0
            } else {
                self.coverage(tri, u, v)
            },
            emission: if bm.emission > 0.0 {
                self.emission(tri, u, v, -dir)
            } else {
                0.0
            },
            bsdf,
            ior: bm.params.ior,
            ior_group: bm.ior_group,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3 x 2 texture whose texel `(x, y)` holds red `10 x + 100 y`, blue 255 and alpha
    /// `50 + x`: lookups that wrap across both edges and land on texel centres, worked
    /// out by hand (uv `(0, 0)` is the corner between texels (2, 1), (0, 1), (2, 0) and
    /// (0, 0); uv `(1, 1/2)` the same corner seen from the other side).
    #[test]
    fn bilinear_lookups_wrap_at_both_edges() {
        let (w, h) = (3u32, 2u32);
        let rgba8 = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                [(10 * x + 100 * y) as u8, 0, 255, (50 + x) as u8]
            })
            .collect();
        let tex = Texture {
            width: w,
            height: h,
            rgba8,
        };
        let at = |u: f32, v: f32| sample_texture(&tex, Vec2::new(u, v), false);
        let close = |got: [f32; 4], red: f32, alpha: f32| {
            (got[0] * 255.0 - red).abs() < 1e-3
                && got[1] == 0.0
                && (got[2] - 1.0).abs() < 1e-6
                && (got[3] * 255.0 - alpha).abs() < 1e-3
        };
        // The four corners' mean: red (20 + 0 + 120 + 100) / 4, alpha (52 + 50) / 2.
        for (u, v) in [(0.0, 0.0), (1.0, 0.5), (-1.0, 2.0)] {
            assert!(close(at(u, v), 60.0, 51.0), "({u}, {v}): {:?}", at(u, v));
        }
        // Texel centres far outside [0, 1): (1, 1) and (2, 0).
        assert!(close(at(-1.5, 0.75), 110.0, 51.0), "{:?}", at(-1.5, 0.75));
        assert!(
            close(at(3.0 + 2.5 / 3.0, -0.75), 20.0, 52.0),
            "{:?}",
            at(3.0 + 2.5 / 3.0, -0.75)
        );
        // Half way between the centres of (1, 0) and (1, 1).
        assert!(close(at(0.5, 0.5), 60.0, 51.0), "{:?}", at(0.5, 0.5));
        // sRGB decoding: code 255 is 1, 0 is 0.
        let s = sample_texture(&tex, Vec2::new(-1.5, 0.75), true);
        assert!((s[2] - 1.0).abs() < 1e-6 && s[1] == 0.0, "{s:?}");
    }
}
