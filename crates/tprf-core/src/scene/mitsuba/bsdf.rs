//! Mitsuba BSDFs and textures as tprf materials (glTF's metallic-roughness model with
//! the specular, transmission and IOR factors; see `transport::bsdf`).
//!
//! Exact (the same scattering as Mitsuba's plugin):
//! - `diffuse`: Lambertian, `reflectance` the base colour (specular factor 0);
//! - `dielectric`: smooth Fresnel reflection and refraction, `int_ior / ext_ior` the
//!   relative index (named indices from Mitsuba's table: `water`, `bk7`...), light inside
//!   at c / n;
//! - `conductor` with the default `material="none"`: a perfect mirror;
//! - `twosided` around an exact BSDF; `null`: no surface (coverage 0).
//!
//! Approximate (each noted where a scene uses it):
//! - every one-sided BSDF is rendered two-sided: tprf's BSDFs scatter on both sides,
//!   Mitsuba's are black from behind (a scene that shows a back face differs);
//! - `conductor` (other than `none`) and `roughconductor`: a metal whose reflectance at
//!   normal incidence, `((n - 1)^2 + k^2) / ((n + 1)^2 + k^2)` per channel (times
//!   `specular_reflectance`), follows Schlick's Fresnel; named `material`s from a small
//!   table of linear-sRGB normal-incidence reflectances;
//! - rough BSDFs use GGX with roughness `sqrt(alpha)` (Mitsuba's `beckmann`, the default,
//!   has a different tail; an anisotropic `alpha_u`, `alpha_v` is averaged);
//! - `roughdielectric`: a smooth dielectric;
//! - `plastic`, `roughplastic`: a dielectric base colour `diffuse_reflectance` under a
//!   Schlick specular coat of the given IOR (Mitsuba also accounts for light reflected
//!   back inside the coat);
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

use super::emitters::AreaEmitter;
use super::shapes::uv_transform;
use super::xml::{Color, Object, err};
use super::{Builder, MaterialKey, MaterialSlot};
use crate::budget;
use crate::scene::{AlphaMode, Material, SceneError, Texture, TextureRef};
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

/// Normal-incidence reflectance (linear sRGB) of the conductors a `material` string may
/// name that tprf knows (Real-Time Rendering, 4th ed., table 9.2); others are refused.
const CONDUCTORS: [(&str, [f64; 3]); 6] = [
    ("Ag", [0.972, 0.960, 0.915]),
    ("Al", [0.913, 0.922, 0.924]),
    ("Au", [1.000, 0.782, 0.344]),
    ("Cr", [0.549, 0.556, 0.554]),
    ("Cu", [0.955, 0.638, 0.538]),
    ("Ni_palik", [0.660, 0.609, 0.526]),
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

    /// GGX roughness `sqrt(alpha)` of a rough BSDF (`alpha`, or the mean of `alpha_u`
    /// and `alpha_v`), with a note when the distribution or anisotropy is approximated.
    fn roughness(&mut self, o: &Object) -> Result<f32, SceneError> {
        let alpha = match (o.prop("alpha_u").is_some(), o.prop("alpha_v").is_some()) {
            (true, true) | (true, false) | (false, true) => {
                let (u, v) = (o.float("alpha_u", 0.1)?, o.float("alpha_v", 0.1)?);
                if u != v {
                    self.note_at(&o.loc, format!("<bsdf type=\"{}\">: anisotropic roughness averaged (tprf's GGX is isotropic)", o.plugin));
                }
                0.5 * (u + v)
            }
            (false, false) => o.float("alpha", 0.1)?,
        };
        if o.prop("alpha").is_some()
            && o.props
                .iter()
                .any(|p| p.name == "alpha" && matches!(p.value, super::xml::Value::Object(_)))
        {
            return Err(err(
                &o.loc,
                format!(
                    "{}: a textured alpha is not supported (give a number)",
                    o.describe()
                ),
            ));
        }
        let dist = o.string("distribution")?.unwrap_or("beckmann").to_string();
        if dist != "ggx" {
            self.note_at(&o.loc, format!("<bsdf type=\"{}\"> with the {dist} distribution rendered with GGX of the same alpha", o.plugin));
        }
        if !(alpha.is_finite() && alpha >= 0.0) {
            return Err(err(
                &o.loc,
                format!("{}: alpha {alpha} must be >= 0", o.describe()),
            ));
        }
        Ok(alpha.sqrt().min(1.0) as f32)
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
                if o.plugin == "mask" {
                    let opacity = self.constant(o, "opacity", 0.5)?;
                    let a = (opacity[0] + opacity[1] + opacity[2]) / 3.0;
                    c.material.base_color[3] *= a as f32;
                    c.material.alpha_mode = AlphaMode::Blend;
                }
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
                    let _ = self.roughness(o)?;
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
                let material = o.string("material")?.map(str::to_string);
                let f0 = match (material.as_deref(), o.prop("eta").is_some() || o.prop("k").is_some()) {
                    (_, true) => {
                        let eta = self.constant(o, "eta", 0.0)?;
                        let kk = self.constant(o, "k", 1.0)?;
                        std::array::from_fn(|i| {
                            let (n, k) = (eta[i], kk[i]);
                            ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k)
                        })
                    }
                    (None | Some("none"), false) => [1.0; 3],
                    (Some(name), false) => CONDUCTORS
                        .iter()
                        .find(|(n, _)| *n == name)
                        .map(|(_, c)| *c)
                        .ok_or_else(|| {
                            let known: Vec<&str> = CONDUCTORS.iter().map(|(n, _)| *n).collect();
                            err(&o.loc, format!("{}: material \"{name}\" is not one tprf knows ({}, none): give eta and k", o.describe(), known.join(", ")))
                        })?,
                };
                let spec = self.constant(o, "specular_reflectance", 1.0)?;
                let c: [f64; 3] = std::array::from_fn(|i| f0[i] * spec[i]);
                m.base_color = [c[0] as f32, c[1] as f32, c[2] as f32, 1.0];
                m.metallic = 1.0;
                m.roughness = 0.0;
                if o.plugin == "roughconductor" {
                    m.roughness = self.roughness(o)?;
                }
                if f0 != [1.0; 3] {
                    approx(
                        self,
                        "Schlick's Fresnel from the reflectance at normal incidence",
                    );
                }
            }
            "plastic" | "roughplastic" => {
                let (c, t) = self.base(o, "diffuse_reflectance", 0.5)?;
                m.base_color = [c[0] as f32, c[1] as f32, c[2] as f32, 1.0];
                texture = t;
                m.ior = self.ior(o, 1.49, 1.000277)? as f32;
                m.specular_factor = 1.0;
                m.specular_color = f(self.constant(o, "specular_reflectance", 1.0)?);
                m.roughness = 0.0;
                let _ = o.boolean("nonlinear", false)?;
                if o.plugin == "roughplastic" {
                    m.roughness = self.roughness(o)?;
                }
                approx(
                    self,
                    "a diffuse base under a Schlick specular coat (no light reflected back inside the coat)",
                );
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
    fn texture(&mut self, k: usize) -> Result<(u32, Option<glam::DAffine2>), SceneError> {
        let o = self.object(k);
        let m = o.transform("to_uv")?;
        let to_uv = (m != glam::DMat4::IDENTITY).then(|| uv_transform(&m));
        if let Some(&index) = self.texture_of.get(&k) {
            return Ok((index, to_uv));
        }
        let texture = match o.plugin.as_str() {
            "bitmap" => {
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
                let path = super::xml::resolve_in(dir, &[main], &name);
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
                decode_bitmap(&path, &format!("{} at {}", o.describe(), o.loc), raw)?
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

/// Linear [0, 1] to 8-bit sRGB.
fn to_srgb8(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
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

/// Decode an image file into an sRGB-encoded RGBA8 [`Texture`]: 8-bit files as stored
/// (`raw`: their values are linear, encoded to sRGB), 16-bit and floating-point ones
/// (OpenEXR) from linear values. The decoded size is budgeted before any pixel is read.
fn decode_bitmap(path: &Path, what: &str, raw: bool) -> Result<Texture, SceneError> {
    use image::{DynamicImage, ImageDecoder};
    let bytes = budget::read_file(path, what).map_err(|e| match e {
        budget::BudgetError::Io { path, source } => SceneError::Io {
            path: format!("{} ({what})", path.display()),
            source,
        },
        e => SceneError::Budget(e),
    })?;
    let bad = |m: String| SceneError::Invalid(format!("{} ({what}): {m}", path.display()));
    let mut reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(|e| bad(e.to_string()))?;
    reader.no_limits();
    let decoder = reader.into_decoder().map_err(|e| {
        bad(format!(
            "cannot read the image (tprf reads PNG, JPEG and OpenEXR textures): {e}"
        ))
    })?;
    let (w, h) = decoder.dimensions();
    if w == 0 || h == 0 {
        return Err(bad(format!("the image is {w} x {h} pixels")));
    }
    let pixels = u64::from(w) * u64::from(h);
    budget::check(
        decoder
            .total_bytes()
            .saturating_add(pixels.saturating_mul(8)),
        what,
        format_args!("decoding {w} x {h} pixels"),
    )?;
    let image =
        DynamicImage::from_decoder(decoder).map_err(|e| bad(format!("cannot decode: {e}")))?;
    let eight_bit = matches!(
        image,
        DynamicImage::ImageLuma8(_)
            | DynamicImage::ImageLumaA8(_)
            | DynamicImage::ImageRgb8(_)
            | DynamicImage::ImageRgba8(_)
    );
    let rgba8: Vec<[u8; 4]> = if eight_bit && !raw {
        image.into_rgba8().pixels().map(|p| p.0).collect()
    } else {
        // Linear values: 8-bit raw data as v / 255, 16-bit and float data as they are.
        image
            .into_rgba32f()
            .pixels()
            .map(|p| {
                let [r, g, b, a] = p.0;
                [
                    to_srgb8(r),
                    to_srgb8(g),
                    to_srgb8(b),
                    (a.clamp(0.0, 1.0) * 255.0 + 0.5) as u8,
                ]
            })
            .collect()
    };
    Ok(Texture {
        width: w,
        height: h,
        rgba8,
    })
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
