//! Mitsuba BSDFs and textures as tprf materials: glTF's metallic-roughness model with
//! the specular, transmission and IOR factors, or one of Mitsuba's own models
//! ([`SurfaceModel`]: `plastic`, `conductor`; see `transport::bsdf`).
//!
//! Exact (the same scattering as Mitsuba's plugin):
//! - `diffuse`: Lambertian, `reflectance` the base colour (specular factor 0);
//! - `dielectric`: smooth Fresnel reflection and refraction, `int_ior / ext_ior` the
//!   relative index (named indices from Mitsuba's table: `water`, `bk7`...), light inside
//!   at c / n;
//! - `plastic`, `roughplastic`: Mitsuba's coat over a diffuse base (`nonlinear`, internal
//!   reflectance and transmittance as Mitsuba computes them; a rough coat's two
//!   integrals by tprf's own quadrature, within 0.25 % of Mitsuba's values; its lobe
//!   sampling weights as Mitsuba's, the specular one from the diffuse colour factor, not
//!   a texture's mean: that changes only the noise);
//! - `conductor`, `roughconductor`: the conductor's Fresnel reflectance of complex index
//!   `eta + i k` (given, or a named `material` from Mitsuba's own table: the RGB values
//!   of its variants, the grey band their luminance as its mono variants), Beckmann (the
//!   default) or GGX of the given `alpha`, `specular_reflectance`; `material="none"` (the
//!   default) a perfect mirror;
//! - `twosided` around an exact BSDF; `null`: no surface (coverage 0);
//! - tprf's own `tprf_luminescent` around one BSDF: that BSDF's reflection plus
//!   luminescence (`yield`, `lifetime` in seconds, or `yield_k` / `lifetime_k` for up to
//!   three components, `rise_time`, `emission_color`; `scene::luminescence`). Mitsuba has
//!   no such plugin: a file using it renders only in tprf;
//! - one-sided BSDFs (`diffuse`, `plastic`, `conductor` and their rough kinds outside a
//!   `twosided`) black from behind, as Mitsuba's (`Material::one_sided`).
//!
//! Sampling differs from Mitsuba's where that changes only the noise: microfacet normals
//! are drawn from `D cos` (Mitsuba: the visible normals, `sample_visible`).
//!
//! Approximate (each noted where a scene uses it):
//! - an anisotropic `alpha_u`, `alpha_v` is averaged (tprf's distributions are
//!   isotropic); a textured alpha is refused;
//! - `roughdielectric`: a smooth dielectric;
//! - `thindielectric`: a mirror covering the fraction `2R / (1 + R)` of the surface (the
//!   slab's reflectance at normal incidence, R = ((n - 1) / (n + 1))^2), the rest letting
//!   light through unchanged and undelayed;
//! - `principled`: base colour, metallic, roughness, `spec_trans` as transmission and
//!   the IOR from `eta` (or from `specular`, F0 = 0.08 specular); sheen, clearcoat and
//!   the rest are noted as ignored;
//! - `mask`: a constant `opacity` as coverage; `bumpmap`, `normalmap`: their maps ignored.
//!
//! Textures: `bitmap` (PNG and JPEG, 8-bit or 16-bit; sRGB unless `raw`, and OpenEXR
//! as linear; `to_uv` applied to the texture coordinates of the triangles using it;
//! bilinear and repeating, as Mitsuba's defaults), `checkerboard` (baked into a
//! texture), `uniform` and `srgb` spectra; only the base colour slot takes a texture.

use super::bitmap::{decode_bitmap, decode_linear_rgb, to_srgb8};
use super::emitters::AreaEmitter;
use super::prefetch::{self, Job};
use super::shapes::uv_transform;
use super::xml::{Color, Object, err};
use super::{Builder, MaterialKey, MaterialSlot};
use crate::scene::{
    AlphaMode, DecayComponent, ImageWrap, IrradianceImage, Luminescence, Material, Microfacet,
    MicrofacetDistribution, SceneError, SurfaceModel, Texture, TextureRef,
};
use std::path::Path;

/// Deepest chain of nested or referenced BSDFs followed.
const MAX_NESTING: usize = 32;

/// Mitsuba's table of named refractive indices (`include/mitsuba/render/ior.h`).
const IOR_TABLE: [(&str, f64); 23] = [
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// Mitsuba 3.9's named conductors (`data/ior/NAME.eta.spd`, `.k.spd`): the complex index
/// `eta + i k` as Mitsuba's RGB variants hold it, each spectrum reduced to linear sRGB
/// (`spectrum_list_to_srgb`, negative values clamped to 0), read from Mitsuba itself. A
/// band takes its channel of these (the grey band their luminance, as Mitsuba's mono
/// variants do).
#[rustfmt::skip]
const CONDUCTORS: [(&str, [f64; 3], [f64; 3]); 59] = [
    ("Ag", [0.155276, 0.116728, 0.138388], [4.82835, 3.12222, 2.1469]),
    ("Al", [1.6575, 0.880405, 0.521244], [9.22381, 6.2695, 4.837]),
    ("Au", [0.143036, 0.375307, 1.44205], [3.983, 2.38556, 1.60336]),
    ("Be", [4.18501, 3.18503, 2.78406], [3.83547, 3.01012, 2.86899]),
    ("Be_palik", [4.18501, 3.18503, 2.78406], [3.83547, 3.01012, 2.86899]),
    ("Cr", [4.36967, 2.91651, 1.6549], [5.20655, 4.23131, 3.7547]),
    ("CsI", [2.1449, 1.70232, 1.66243], [0.0, 0.0, 0.0]),
    ("CsI_palik", [2.1449, 1.70232, 1.66243], [0.0, 0.0, 0.0]),
    ("Cu", [0.201005, 0.92375, 1.10222], [3.91326, 2.45305, 2.14209]),
    ("Cu2O", [3.55177, 2.94987, 2.75188], [0.114207, 0.193897, 0.606134]),
    ("Cu2O_palik", [3.55177, 2.94987, 2.75188], [0.114207, 0.193897, 0.606134]),
    ("CuO", [3.24754, 2.44781, 2.21022], [0.52109, 0.570031, 0.722179]),
    ("CuO_palik", [3.24754, 2.44781, 2.21022], [0.52109, 0.570031, 0.722179]),
    ("Cu_palik", [0.213229, 0.919715, 1.10241], [3.92187, 2.45733, 2.13658]),
    ("Hg", [2.39894, 1.44003, 0.90957], [6.32759, 4.37192, 3.42176]),
    ("HgTe", [4.77904, 3.2312, 2.6599], [1.63161, 1.58081, 1.72929]),
    ("HgTe_palik", [4.77904, 3.2312, 2.6599], [1.63161, 1.58081, 1.72929]),
    ("Hg_palik", [2.39894, 1.44003, 0.90957], [6.32759, 4.37192, 3.42176]),
    ("Ir", [3.0863, 2.08219, 1.61791], [5.59215, 4.06709, 3.26731]),
    ("Ir_palik", [3.0863, 2.08219, 1.61791], [5.59215, 4.06709, 3.26731]),
    ("K", [0.0640432, 0.0464098, 0.0381849], [2.1042, 1.34894, 0.913126]),
    ("K_palik", [0.0640432, 0.0464098, 0.0381849], [2.1042, 1.34894, 0.913126]),
    ("Li", [0.265791, 0.195618, 0.220949], [3.54015, 2.31112, 1.66861]),
    ("Li_palik", [0.265791, 0.195618, 0.220949], [3.54015, 2.31112, 1.66861]),
    ("Mo", [4.48397, 3.52513, 2.77631], [4.11144, 3.42083, 3.15061]),
    ("Mo_palik", [4.48397, 3.52513, 2.77631], [4.11144, 3.42083, 3.15061]),
    ("Na_palik", [0.0602694, 0.0561409, 0.0619884], [3.17927, 2.11249, 1.57904]),
    ("Nb", [3.42007, 2.79009, 2.39563], [3.44139, 2.73767, 2.57975]),
    ("Nb_palik", [3.42007, 2.79009, 2.39563], [3.44139, 2.73767, 2.57975]),
    ("Ni_palik", [2.3673, 1.66337, 1.46708], [4.49881, 3.05015, 2.34544]),
    ("Rh", [2.58579, 1.86022, 1.55426], [6.78226, 4.70299, 3.97607]),
    ("Rh_palik", [2.58579, 1.86022, 1.55426], [6.78226, 4.70299, 3.97607]),
    ("Se", [4.05831, 2.84294, 2.82085], [0.75405, 0.638444, 0.521808]),
    ("Se-e", [5.72285, 4.16574, 4.08134], [0.871136, 1.10516, 1.56532]),
    ("Se-e_palik", [5.72285, 4.16574, 4.08134], [0.871136, 1.10516, 1.56532]),
    ("Se_palik", [4.05831, 2.84294, 2.82085], [0.75405, 0.638444, 0.521808]),
    ("SnTe", [4.52425, 1.98164, 1.28159], [0.0, 0.0, 0.0]),
    ("SnTe_palik", [4.52425, 1.98164, 1.28159], [0.0, 0.0, 0.0]),
    ("Ta", [2.06272, 2.39294, 2.62793], [2.40836, 1.74149, 1.94703]),
    ("Ta_palik", [2.06272, 2.39294, 2.62793], [2.40836, 1.74149, 1.94703]),
    ("Te", [7.39023, 4.4821, 2.63711], [3.25602, 3.52706, 3.29205]),
    ("Te-e", [7.50891, 4.29643, 2.36999], [5.58393, 4.94721, 3.99759]),
    ("Te-e_palik", [7.50891, 4.29643, 2.36999], [5.58393, 4.94721, 3.99759]),
    ("Te_palik", [7.39023, 4.4821, 2.63711], [3.25602, 3.52706, 3.29205]),
    ("ThF4", [1.83071, 1.44223, 1.38765], [0.0, 0.0, 0.0]),
    ("ThF4_palik", [1.83071, 1.44223, 1.38765], [0.0, 0.0, 0.0]),
    ("TiC", [3.70053, 2.83742, 2.58229], [3.26564, 2.35159, 2.17279]),
    ("TiC_palik", [3.70053, 2.83742, 2.58229], [3.26564, 2.35159, 2.17279]),
    ("TiN", [1.64845, 1.15052, 1.37982], [3.36833, 1.9435, 1.10207]),
    ("TiN_palik", [1.64845, 1.15052, 1.37982], [3.36833, 1.9435, 1.10207]),
    ("VC", [3.65757, 2.75274, 2.53267], [3.0683, 2.19869, 1.96319]),
    ("VC_palik", [3.65757, 2.75274, 2.53267], [3.0683, 2.19869, 1.96319]),
    ("VN", [2.8656, 2.11919, 1.94009], [3.03224, 2.05612, 1.61631]),
    ("VN_palik", [2.8656, 2.11919, 1.94009], [3.03224, 2.05612, 1.61631]),
    ("V_palik", [4.27758, 3.51295, 2.76107], [3.4913, 2.88945, 3.11152]),
    ("W", [4.37082, 3.30025, 2.99841], [3.50064, 2.60487, 2.27323]),
    ("a-C", [2.94405, 2.22714, 1.96816], [0.887465, 0.799299, 0.81529]),
    ("d-C", [2.70872, 2.31883, 2.2289], [0.0, 0.0, 0.0]),
    ("d-C_palik", [2.70872, 2.31883, 2.2289], [0.0, 0.0, 0.0]),
];

/// What a BSDF becomes before it is stored: the material and its base colour's texture
/// object (converted once, with its `to_uv`).
struct Converted {
    material: Material,
    texture: Option<usize>,
}

impl Builder<'_> {
    /// The material of a shape with BSDF object `bsdf` (`None`: Mitsuba's default, a
    /// diffuse of reflectance 0.5) and, for an area light, `radiance` (W m^-2 sr^-1,
    /// emitted from the front side only, as Mitsuba's area emitter).
    pub(super) fn material(
        &mut self,
        bsdf: Option<usize>,
        emitter: Option<AreaEmitter>,
        medium: Option<usize>,
    ) -> Result<MaterialSlot, SceneError> {
        let key = MaterialKey {
            bsdf,
            radiance_bits: emitter.map(|e| e.radiance.map(f64::to_bits)),
            falloff_bits: emitter
                .and_then(|e| e.falloff)
                .map(|f| [f.beam_width_rad.to_bits(), f.cutoff_rad.to_bits()]),
            medium,
        };
        if let Some(slot) = self.material_of.get(&key) {
            return Ok(*slot);
        }
        let mut c = match bsdf {
            Some(k) => {
                self.depth = 0;
                self.convert(k)?
            }
            None => Converted {
                material: Material::lambertian("default diffuse 0.5", [0.5; 3]),
                texture: None,
            },
        };
        let mut to_uv = None;
        if let Some(t) = c.texture {
            let (index, uv) = self.texture(t)?;
            c.material.base_color_texture = Some(TextureRef { texture: index });
            to_uv = uv;
        }
        if let Some(k) = medium {
            // Mitsuba keeps the index on the boundary: a dielectric's, else index-matched.
            let n = if c.material.transmission > 0.0 {
                c.material.ior
            } else {
                1.0
            };
            c.material.medium = Some(self.medium(k, n)?);
        }
        if let Some(e) = emitter {
            c.material.emissive = e.radiance.map(|v| v as f32);
            c.material.emission_falloff = e.falloff;
            c.material.double_sided = false;
            c.material.name = format!("{} (area light)", c.material.name);
        }
        let slot = MaterialSlot {
            index: self.materials.len() as u32,
            to_uv,
        };
        self.materials.push(c.material);
        self.material_of.insert(key, slot);
        Ok(slot)
    }

    /// The luminescence of a `tprf_luminescent` wrapper (docs/mitsuba.md): `yield` and
    /// `lifetime` (seconds), or `yield_1`/`lifetime_1` ... `yield_3`/`lifetime_3` for
    /// two or three exponential components; `rise_time` (seconds) and `emission_color`
    /// optional. Ranges are checked with the scene ([`Luminescence::check`]).
    fn luminescence(&self, o: &Object) -> Result<Luminescence, SceneError> {
        let mut components = Vec::new();
        if o.prop("lifetime").is_some() || o.prop("yield").is_some() {
            if o.prop("lifetime_1").is_some() {
                return Err(err(
                    &o.loc,
                    format!(
                        "{}: give yield and lifetime, or yield_1, lifetime_1, ... (not both)",
                        o.describe()
                    ),
                ));
            }
            components.push(DecayComponent {
                yield_: o.float("yield", f64::NAN)? as f32,
                lifetime_s: o.float("lifetime", f64::NAN)?,
            });
        }
        for k in 1..=3 {
            let (y, t) = (format!("yield_{k}"), format!("lifetime_{k}"));
            if o.prop(&y).is_some() || o.prop(&t).is_some() {
                components.push(DecayComponent {
                    yield_: o.float(&y, f64::NAN)? as f32,
                    lifetime_s: o.float(&t, f64::NAN)?,
                });
            }
        }
        if components.is_empty() {
            return Err(err(
                &o.loc,
                format!(
                    "{} needs <float name=\"yield\"> and <float name=\"lifetime\"> (seconds)",
                    o.describe()
                ),
            ));
        }
        let rise_s = match o.prop("rise_time") {
            Some(_) => Some(o.float("rise_time", f64::NAN)?),
            None => None,
        };
        let emission_color = match o.color("emission_color", Some([1.0; 3]))? {
            Some(Color::Rgb(c)) => c.map(|v| v as f32),
            Some(Color::Texture(_)) => {
                return Err(err(
                    &o.loc,
                    format!("{}: emission_color must be a constant colour", o.describe()),
                ));
            }
            None => [1.0; 3],
        };
        let l = Luminescence {
            components,
            rise_s,
            emission_color,
        };
        // Checked here too, so the error names the line (the scene's check repeats it
        // against the base colour the nested BSDF gives).
        for (k, c) in l.components.iter().enumerate() {
            if !(c.yield_.is_finite() && c.lifetime_s.is_finite() && c.lifetime_s > 0.0) {
                return Err(err(
                    &o.loc,
                    format!(
                        "{}: component {} has yield {} and lifetime {} s: give both, the \
                         lifetime finite and > 0 seconds",
                        o.describe(),
                        k + 1,
                        c.yield_,
                        c.lifetime_s
                    ),
                ));
            }
        }
        Ok(l)
    }

    /// A constant colour, or a texture object for the base colour slot only (`slot`
    /// names the property for the refusal).
    fn constant(&self, o: &Object, name: &str, default: f64) -> Result<[f64; 3], SceneError> {
        match o.color(name, Some([default; 3]))? {
            Some(Color::Rgb(c)) => Ok(c),
            Some(Color::Texture(k)) => {
                let t = self.object(k);
                match t.plugin.as_str() {
                    "uniform" => Ok([t.float("value", 1.0)?; 3]),
                    "srgb" => match t.color("color", Some([1.0; 3]))? {
                        Some(Color::Rgb(c)) => Ok(c),
                        _ => Err(err(
                            &t.loc,
                            "<texture type=\"srgb\"> needs <rgb name=\"color\">",
                        )),
                    },
                    _ => Err(err(
                        &t.loc,
                        format!(
                            "{} for \"{name}\" of {} is not supported: tprf takes a texture for the base colour only (give a number)",
                            t.describe(),
                            o.describe()
                        ),
                    )),
                }
            }
            None => Ok([default; 3]),
        }
    }

    /// A colour for the base colour slot: a constant, or a texture to convert.
    fn base(
        &self,
        o: &Object,
        name: &str,
        default: f64,
    ) -> Result<([f64; 3], Option<usize>), SceneError> {
        if let Some(Color::Texture(k)) = o.color(name, None)? {
            let t = self.object(k);
            if matches!(t.plugin.as_str(), "bitmap" | "checkerboard") {
                return Ok(([1.0; 3], Some(k)));
            }
        }
        Ok((self.constant(o, name, default)?, None))
    }

    /// A relative index of refraction `int_ior / ext_ior` (numbers or names).
    fn ior(&self, o: &Object, int_default: f64, ext_default: f64) -> Result<f64, SceneError> {
        let read = |name: &str, default: f64| -> Result<f64, SceneError> {
            let Some(p) = o.prop(name) else {
                return Ok(default);
            };
            match &p.value {
                super::xml::Value::String(s) => IOR_TABLE
                    .iter()
                    .find(|(n, _)| n.eq_ignore_ascii_case(s.trim()))
                    .map(|(_, v)| *v)
                    .ok_or_else(|| {
                        let known: Vec<&str> = IOR_TABLE.iter().map(|(n, _)| *n).collect();
                        err(
                            &p.loc,
                            format!(
                                "{name} \"{s}\": no such named index (known: {})",
                                known.join(", ")
                            ),
                        )
                    }),
                _ => o.float(name, default),
            }
        };
        let (int, ext) = (read("int_ior", int_default)?, read("ext_ior", ext_default)?);
        if !(int > 0.0 && ext > 0.0) {
            return Err(err(
                &o.loc,
                format!(
                    "{}: int_ior {int} and ext_ior {ext} must be > 0",
                    o.describe()
                ),
            ));
        }
        Ok(int / ext)
    }

    /// The microfacet distribution of a rough BSDF: `distribution` (`beckmann`, the
    /// default, or `ggx`) and `alpha` (or the mean of `alpha_u` and `alpha_v`, noted: tprf's
    /// distributions are isotropic).
    fn microfacet(&mut self, o: &Object) -> Result<Microfacet, SceneError> {
        if o.props
            .iter()
            .any(|p| p.name.starts_with("alpha") && matches!(p.value, super::xml::Value::Object(_)))
        {
            return Err(err(
                &o.loc,
                format!(
                    "{}: a textured alpha is not supported (give a number)",
                    o.describe()
                ),
            ));
        }
        let alpha = match (o.prop("alpha_u").is_some(), o.prop("alpha_v").is_some()) {
            (true, true) | (true, false) | (false, true) => {
                let (u, v) = (o.float("alpha_u", 0.1)?, o.float("alpha_v", 0.1)?);
                if u != v {
                    self.note_at(&o.loc, format!("<bsdf type=\"{}\">: anisotropic roughness averaged, alpha {} (tprf's microfacet distributions are isotropic)", o.plugin, 0.5 * (u + v)));
                }
                0.5 * (u + v)
            }
            (false, false) => o.float("alpha", 0.1)?,
        };
        if !(alpha.is_finite() && alpha >= 0.0) {
            return Err(err(
                &o.loc,
                format!("{}: alpha {alpha} must be >= 0", o.describe()),
            ));
        }
        let distribution = match o.string("distribution")?.map(str::to_ascii_lowercase) {
            None => MicrofacetDistribution::Beckmann,
            Some(d) if d == "beckmann" => MicrofacetDistribution::Beckmann,
            Some(d) if d == "ggx" => MicrofacetDistribution::Ggx,
            Some(d) => {
                return Err(err(
                    &o.loc,
                    format!(
                        "{}: distribution \"{d}\" is not one Mitsuba 3 knows (beckmann, ggx)",
                        o.describe()
                    ),
                ));
            }
        };
        Ok(Microfacet {
            distribution,
            alpha: alpha as f32,
        })
    }

    /// GGX roughness `sqrt(alpha)` of a microfacet distribution: the metallic-roughness
    /// material nearest it.
    fn roughness(mf: &Microfacet) -> f32 {
        mf.alpha.sqrt().min(1.0)
    }

    /// Convert BSDF object `k` (wrappers followed, at most [`MAX_NESTING`] deep).
    fn convert(&mut self, k: usize) -> Result<Converted, SceneError> {
        let o = self.object(k);
        if o.tag != "bsdf" {
            return Err(err(
                &o.loc,
                format!("{} where a <bsdf> is expected", o.describe()),
            ));
        }
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(err(
                &o.loc,
                format!("BSDFs nested deeper than {MAX_NESTING}"),
            ));
        }
        let name =
            o.id.clone()
                .unwrap_or_else(|| format!("{} at {}", o.plugin, o.loc));
        let f = |c: [f64; 3]| c.map(|v| v as f32);
        let mut m = Material {
            name: name.clone(),
            metallic: 0.0,
            roughness: 1.0,
            specular_factor: 0.0,
            ..Material::default()
        };
        let mut texture = None;
        let approx = |b: &mut Self, how: &str| {
            b.note_at(
                &o.loc,
                format!("<bsdf type=\"{}\"> approximated: {how}", o.plugin),
            );
        };
        match o.plugin.as_str() {
            "diffuse" => {
                m.one_sided = true;
                let (c, t) = self.base(o, "reflectance", 0.5)?;
                m.base_color = [c[0] as f32, c[1] as f32, c[2] as f32, 1.0];
                texture = t;
            }
            "twosided" | "bumpmap" | "normalmap" | "mask" => {
                let inner: Vec<usize> = o
                    .children()
                    .filter(|(_, c)| self.parsed.objects[*c].tag == "bsdf")
                    .map(|(p, c)| {
                        p.used.set(true);
                        c
                    })
                    .collect();
                let Some(&first) = inner.first() else {
                    return Err(err(
                        &o.loc,
                        format!("{} has no nested <bsdf>", o.describe()),
                    ));
                };
                if inner.len() > 1 {
                    approx(
                        self,
                        "a different BSDF on the back side is not supported: the front one is used on both",
                    );
                }
                match o.plugin.as_str() {
                    "bumpmap" | "normalmap" => {
                        for (p, _) in o
                            .children()
                            .filter(|(_, c)| self.parsed.objects[*c].tag == "texture")
                        {
                            p.used.set(true);
                        }
                        if let Some(p) = o.prop("normalmap") {
                            let _ = p;
                        }
                        approx(self, "its map is ignored (shading uses the mesh normals)");
                    }
                    _ => {}
                }
                let mut c = self.convert(first)?;
                if o.plugin == "twosided" {
                    c.material.one_sided = false;
                }
                if o.plugin == "mask" {
                    let opacity = self.constant(o, "opacity", 0.5)?;
                    let a = (opacity[0] + opacity[1] + opacity[2]) / 3.0;
                    c.material.base_color[3] *= a as f32;
                    c.material.alpha_mode = AlphaMode::Blend;
                }
                self.depth -= 1;
                return Ok(c);
            }
            "tprf_luminescent" => {
                let luminescence = self.luminescence(o)?;
                let inner: Vec<usize> = o
                    .children()
                    .filter(|(_, c)| self.parsed.objects[*c].tag == "bsdf")
                    .map(|(p, c)| {
                        p.used.set(true);
                        c
                    })
                    .collect();
                let [first] = inner[..] else {
                    return Err(err(
                        &o.loc,
                        format!(
                            "{} needs exactly one nested <bsdf> (the reflection), has {}",
                            o.describe(),
                            inner.len()
                        ),
                    ));
                };
                let mut c = self.convert(first)?;
                c.material.luminescence = Some(luminescence);
                self.depth -= 1;
                return Ok(c);
            }
            "null" => {
                m.base_color = [1.0, 1.0, 1.0, 0.0];
                m.alpha_mode = AlphaMode::Blend;
            }
            "dielectric" | "roughdielectric" => {
                m.ior = self.ior(o, 1.5046, 1.000277)? as f32;
                m.transmission = 1.0;
                m.specular_factor = 1.0;
                m.roughness = 0.0;
                m.base_color = [1.0; 4];
                if o.plugin == "roughdielectric" {
                    let _ = self.microfacet(o)?;
                    approx(
                        self,
                        "rendered as a smooth dielectric (tprf has no rough refraction)",
                    );
                }
                for k in ["specular_reflectance", "specular_transmission"] {
                    let c = self.constant(o, k, 1.0)?;
                    if c != [1.0; 3] {
                        approx(self, &format!("{k} other than 1 ignored"));
                    }
                }
            }
            "thindielectric" => {
                let n = self.ior(o, 1.5046, 1.000277)?;
                let r = ((n - 1.0) / (n + 1.0)).powi(2);
                let cover = 2.0 * r / (1.0 + r);
                m.metallic = 1.0;
                m.roughness = 0.0;
                m.base_color = [1.0, 1.0, 1.0, cover as f32];
                m.alpha_mode = AlphaMode::Blend;
                approx(
                    self,
                    &format!(
                        "a mirror covering {:.2} % of the surface (the slab's reflectance at normal incidence), the rest open",
                        100.0 * cover
                    ),
                );
            }
            "conductor" | "roughconductor" => {
                m.one_sided = true;
                let material = o.string("material")?.map(str::to_string);
                let explicit = o.prop("eta").is_some() || o.prop("k").is_some();
                let (eta, k) = match (material.as_deref(), explicit) {
                    (None | Some("none"), _) => {
                        (self.constant(o, "eta", 0.0)?, self.constant(o, "k", 1.0)?)
                    }
                    (Some(name), false) => CONDUCTORS
                        .iter()
                        .find(|(n, _, _)| *n == name)
                        .map(|(_, eta, k)| (*eta, *k))
                        .ok_or_else(|| {
                            let known: Vec<&str> = CONDUCTORS.iter().map(|(n, _, _)| *n).collect();
                            err(&o.loc, format!("{}: material \"{name}\" is not one of Mitsuba's named conductors ({}, none): give eta and k", o.describe(), known.join(", ")))
                        })?,
                    (Some(name), true) => {
                        return Err(err(
                            &o.loc,
                            format!(
                                "{}: give either material \"{name}\" or eta and k, not both (as Mitsuba)",
                                o.describe()
                            ),
                        ));
                    }
                };
                let spec = self.constant(o, "specular_reflectance", 1.0)?;
                let microfacet = if o.plugin == "roughconductor" {
                    Some(self.microfacet(o)?)
                } else {
                    None
                };
                // The nearest metallic-roughness material (a glTF export writes it): the
                // reflectance at normal incidence as the base colour.
                let f0: [f64; 3] = std::array::from_fn(|i| {
                    let (n, k) = (eta[i], k[i]);
                    spec[i] * ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k)
                });
                m.base_color = [f0[0] as f32, f0[1] as f32, f0[2] as f32, 1.0];
                m.metallic = 1.0;
                m.roughness = microfacet.as_ref().map_or(0.0, Self::roughness);
                m.model = SurfaceModel::Conductor {
                    eta: f(eta),
                    k: f(k),
                    specular_reflectance: f(spec),
                    microfacet,
                };
            }
            "plastic" | "roughplastic" => {
                m.one_sided = true;
                let (c, t) = self.base(o, "diffuse_reflectance", 0.5)?;
                m.base_color = [c[0] as f32, c[1] as f32, c[2] as f32, 1.0];
                texture = t;
                let eta = self.ior(o, 1.49, 1.000277)?;
                m.ior = eta as f32;
                m.specular_factor = 1.0;
                m.specular_color = f(self.constant(o, "specular_reflectance", 1.0)?);
                let microfacet = if o.plugin == "roughplastic" {
                    Some(self.microfacet(o)?)
                } else {
                    None
                };
                m.roughness = microfacet.as_ref().map_or(0.0, Self::roughness);
                m.model = SurfaceModel::Plastic {
                    eta: eta as f32,
                    microfacet,
                    nonlinear: o.boolean("nonlinear", false)?,
                };
            }
            "principled" => {
                let (c, t) = self.base(o, "base_color", 0.5)?;
                m.base_color = [c[0] as f32, c[1] as f32, c[2] as f32, 1.0];
                texture = t;
                m.metallic = self.constant(o, "metallic", 0.0)?[0] as f32;
                m.roughness = self.constant(o, "roughness", 0.5)?[0] as f32;
                m.transmission = self.constant(o, "spec_trans", 0.0)?[0] as f32;
                m.specular_factor = 1.0;
                m.ior = match o.prop("eta") {
                    Some(_) => o.float("eta", 1.5)?,
                    None => {
                        let f0 = (0.08 * self.constant(o, "specular", 0.5)?[0]).clamp(0.0, 0.999);
                        (1.0 + f0.sqrt()) / (1.0 - f0.sqrt())
                    }
                } as f32;
                approx(
                    self,
                    "base colour, metallic, roughness, spec_trans and the index on tprf's metallic-roughness material",
                );
            }
            _ => return Err(Builder::unsupported(o, "")),
        }
        self.depth -= 1;
        Ok(Converted {
            material: m,
            texture,
        })
    }

    /// The scene texture of texture object `k` (converted once) and its `to_uv`.
    /// The file a `bitmap` texture `o` reads (its `filename`, relative to the XML file
    /// that names it, then to the scene's).
    fn bitmap_path(&self, o: &Object) -> Result<std::path::PathBuf, SceneError> {
        let p = o.prop("filename").ok_or_else(|| {
            err(
                &o.loc,
                "<texture type=\"bitmap\"> needs <string name=\"filename\">",
            )
        })?;
        let name = o.string("filename")?.unwrap_or_default().to_string();
        let dir = Path::new(&*p.loc.file).parent().unwrap_or(Path::new(""));
        let main = Path::new(&self.file)
            .parent()
            .unwrap_or(Path::new(""))
            .to_path_buf();
        Ok(super::xml::resolve_in(dir, &[main], &name))
    }

    /// A projector's `irradiance` bitmap `k` as linear RGB (Mitsuba's `bitmap`: sRGB
    /// decoded unless `raw`; a `to_uv` or a filter other than bilinear refused, a wrap
    /// mode not read: the projector looks up only inside the image).
    pub(super) fn irradiance_image(&mut self, k: usize) -> Result<IrradianceImage, SceneError> {
        let o = self.object(k);
        if o.plugin != "bitmap" {
            return Err(err(
                &o.loc,
                format!(
                    "{} as a projector's irradiance: tprf projects a bitmap or a constant",
                    o.describe()
                ),
            ));
        }
        if o.transform("to_uv")? != glam::DMat4::IDENTITY {
            return Err(err(
                &o.loc,
                format!(
                    "{}: to_uv on a projector's image is not supported",
                    o.describe()
                ),
            ));
        }
        if let Some(f) = o.string("filter_type")?
            && f != "bilinear"
        {
            return Err(err(
                &o.loc,
                format!(
                    "{}: filter_type \"{f}\" on a projector's image is not supported (bilinear is)",
                    o.describe()
                ),
            ));
        }
        let wrap = match o.string("wrap_mode")? {
            None | Some("repeat") => ImageWrap::Repeat,
            Some("clamp") => ImageWrap::Clamp,
            Some(w) => {
                return Err(err(
                    &o.loc,
                    format!(
                        "{}: wrap_mode \"{w}\" on a projector's image is not supported (repeat and clamp are)",
                        o.describe()
                    ),
                ));
            }
        };
        let path = self.bitmap_path(o)?;
        let raw = o.boolean("raw", false)?;
        let mut image = decode_linear_rgb(&path, &format!("{} at {}", o.describe(), o.loc), raw)?;
        image.wrap = wrap;
        Ok(image)
    }

    fn texture(&mut self, k: usize) -> Result<(u32, Option<glam::DAffine2>), SceneError> {
        let o = self.object(k);
        let m = o.transform("to_uv")?;
        let to_uv = (m != glam::DMat4::IDENTITY).then(|| uv_transform(&m));
        if let Some(&index) = self.texture_of.get(&k) {
            return Ok((index, to_uv));
        }
        let texture = match o.plugin.as_str() {
            "bitmap" => {
                let path = self.bitmap_path(o)?;
                let raw = o.boolean("raw", false)?;
                if let Some(f) = o.string("filter_type")?
                    && f != "bilinear"
                {
                    self.note_at(
                        &o.loc,
                        format!("<texture type=\"bitmap\"> filter_type \"{f}\" read as bilinear"),
                    );
                }
                if let Some(w) = o.string("wrap_mode")?
                    && w != "repeat"
                {
                    self.note_at(
                        &o.loc,
                        format!("<texture type=\"bitmap\"> wrap_mode \"{w}\" read as repeat"),
                    );
                }
                let job = Job::Bitmap(path, raw);
                match self.prefetched.take_texture(k, &job) {
                    Some(texture) => texture?,
                    None => decode_bitmap(job.path(), &prefetch::what(o), raw)?,
                }
            }
            "checkerboard" => {
                let c0 = self.constant(o, "color0", 0.4)?;
                let c1 = self.constant(o, "color1", 0.2)?;
                checkerboard(c0, c1)
            }
            _ => return Err(Builder::unsupported(o, "")),
        };
        let index = self.textures.len() as u32;
        self.textures.push(texture);
        self.texture_of.insert(k, index);
        Ok((index, to_uv))
    }
}

/// Side of a baked checkerboard, texels (a quarter of it a square; bilinear lookup
/// blurs only the half texel at each edge).
const CHECKER_TEXELS: u32 = 64;

/// Mitsuba's checkerboard over one unit of uv: `color0` where both fractions of (u, v)
/// are on the same side of 1/2, `color1` elsewhere.
fn checkerboard(c0: [f64; 3], c1: [f64; 3]) -> Texture {
    let n = CHECKER_TEXELS;
    let px = |c: [f64; 3]| {
        [
            to_srgb8(c[0] as f32),
            to_srgb8(c[1] as f32),
            to_srgb8(c[2] as f32),
            255,
        ]
    };
    let rgba8 = (0..n * n)
        .map(|i| {
            let (x, y) = (i % n, i / n);
            if (x >= n / 2) == (y >= n / 2) {
                px(c0)
            } else {
                px(c1)
            }
        })
        .collect();
    Texture {
        width: n,
        height: n,
        rgba8,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkerboard_follows_mitsubas_rule() {
        let t = checkerboard([1.0; 3], [0.0; 3]);
        let at = |u: f32, v: f32| {
            let (x, y) = ((u * t.width as f32) as u32, (v * t.height as f32) as u32);
            t.rgba8[(y * t.width + x) as usize][0]
        };
        assert_eq!(at(0.25, 0.25), 255);
        assert_eq!(at(0.75, 0.75), 255);
        assert_eq!(at(0.75, 0.25), 0);
        // sRGB 128/255 is linear ((128/255 + 0.055) / 1.055)^2.4 = 0.21586; 127/255 is 0.21223.
        assert_eq!(to_srgb8(0.2159), 128);
        assert_eq!(to_srgb8(0.2122), 127);
    }
}
