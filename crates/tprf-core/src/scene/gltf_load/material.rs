//! glTF materials as scene [`Material`]s: metallic-roughness factors and textures, the
//! KHR_materials_{specular, transmission, ior, emissive_strength} factors, alpha modes,
//! and images decoded to RGBA8 once each (once per encoding where reduced on load), and
//! the medium inside (KHR_materials_volume's absorption, the extras' scattering).

use super::build::{Builder, name_or_index, tprf_extras};
use super::decode::{Decoded, Encoded, Encoding, MAX_TEXTURE_SIDE, decode_texture};
use super::resource::open_image;
use super::validate::{invalid, uri_label};
use crate::scene::medium::volume_absorption_per_m;
use crate::scene::{
    AlphaMode, AngularFalloff, Luminescence, Material, Medium, SceneError, TextureRef,
};

impl Builder<'_> {
    /// The scene material for a glTF material (converted on first use); the glTF default
    /// material (`index() == None`) becomes [`Material::default`].
    pub(super) fn material_index(&mut self, m: &gltf::Material) -> Result<u32, SceneError> {
        if let Some(&k) = self.material_of.get(&m.index()) {
            return Ok(k);
        }
        let material = match m.index() {
            Some(_) => self.convert_material(m)?,
            None => Material::default(),
        };
        let k = self.materials.len() as u32;
        self.materials.push(material);
        self.material_of.insert(m.index(), k);
        Ok(k)
    }

    /// A glTF material with its textures; factors are linear, emission in W/(m^2 sr).
    fn convert_material(&mut self, m: &gltf::Material) -> Result<Material, SceneError> {
        let pbr = m.pbr_metallic_roughness();
        let specular = m.specular();
        let transmission = m.transmission();
        if m.normal_texture().is_some() {
            self.note_once("normal maps ignored: shading uses the mesh normals".into());
        }
        let ext_textures = specular.as_ref().is_some_and(|s| {
            s.specular_texture().is_some() || s.specular_color_texture().is_some()
        }) || transmission
            .as_ref()
            .is_some_and(|t| t.transmission_texture().is_some());
        if ext_textures {
            self.note_once(
                "specular and transmission textures ignored: their factors are used".into(),
            );
        }
        let strength = m.emissive_strength().unwrap_or(1.0);
        let medium = self.medium_of(m)?;
        let emission_falloff = self.emission_falloff_of(m)?;
        let one_sided = self.one_sided_of(m)?;
        let luminescence = self.luminescence_of(m)?;
        let dispersion = self.dispersion_of(m)?;
        Ok(Material {
            name: name_or_index(m.name(), "materials", m.index().unwrap_or_default()),
            base_color: pbr.base_color_factor(),
            base_color_texture: self.texture(pbr.base_color_texture(), Encoding::Srgb)?,
            metallic: pbr.metallic_factor(),
            roughness: pbr.roughness_factor(),
            metallic_roughness_texture: self
                .texture(pbr.metallic_roughness_texture(), Encoding::Linear)?,
            specular_factor: specular.as_ref().map_or(1.0, |s| s.specular_factor()),
            specular_color: specular
                .as_ref()
                .map_or([1.0; 3], |s| s.specular_color_factor()),
            transmission: transmission.map_or(0.0, |t| t.transmission_factor()),
            ior: dispersion.as_ref().map_or(m.ior().unwrap_or(1.5), |d| {
                d.n(crate::scene::spectrum::D_LINE_NM * 1e-3) as f32
            }),
            dispersion,
            alpha_mode: match m.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Mask => AlphaMode::Mask {
                    cutoff: m.alpha_cutoff().unwrap_or(0.5),
                },
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
            },
            emissive: m.emissive_factor().map(|e| e * strength),
            emissive_texture: self.texture(m.emissive_texture(), Encoding::Srgb)?,
            emission_falloff,
            double_sided: m.double_sided(),
            one_sided,
            medium,
            model: crate::scene::SurfaceModel::MetallicRoughness,
            luminescence,
        })
    }

    /// A material's index as a function of wavelength, from its extras `{"tprf": {"n":
    /// {"cauchy": [A, B_um2]}}}` (or `{"sellmeier": [...]}`, or a name such as `"bk7"`:
    /// [`crate::scene::dispersion::Dispersion::from_json`]); it replaces
    /// `KHR_materials_ior`'s constant index.
    fn dispersion_of(
        &mut self,
        m: &gltf::Material,
    ) -> Result<Option<crate::scene::dispersion::Dispersion>, SceneError> {
        let what = format!("material '{}'", m.name().unwrap_or("(unnamed)"));
        let extras = tprf_extras(m.extras(), self.file, &what)?;
        let Some(v) = extras.as_ref().and_then(|t| t.get("n")) else {
            return Ok(None);
        };
        crate::scene::dispersion::Dispersion::from_json(v, &format!("{what} extras tprf.n"))
            .map(Some)
            .map_err(|e| invalid(self.file, e))
    }

    /// A material's luminescence, from its extras `{"tprf": {"luminescence": {...}}}`
    /// ([`Luminescence::from_json`]; ranges checked with the scene).
    fn luminescence_of(&mut self, m: &gltf::Material) -> Result<Option<Luminescence>, SceneError> {
        let what = format!("materials[{}]", m.index().unwrap_or_default());
        let extras = tprf_extras(m.extras(), self.file, &what)?;
        let Some(v) = extras.as_ref().and_then(|t| t.get("luminescence")) else {
            return Ok(None);
        };
        let what = format!("{what} extras tprf.luminescence");
        Luminescence::from_json(v, &what)
            .map(Some)
            .map_err(|e| invalid(self.file, e))
    }

    /// Whether the material's back face absorbs all light, from its extras
    /// `{"tprf": {"one_sided": true}}` (a Mitsuba one-sided BSDF saved as glTF).
    fn one_sided_of(&mut self, m: &gltf::Material) -> Result<bool, SceneError> {
        let what = format!("materials[{}]", m.index().unwrap_or_default());
        let extras = tprf_extras(m.extras(), self.file, &what)?;
        match extras.as_ref().and_then(|t| t.get("one_sided")) {
            None => Ok(false),
            Some(v) => v.as_bool().ok_or_else(|| {
                invalid(
                    self.file,
                    format!("{what} extras tprf.one_sided = {v}: true or false"),
                )
            }),
        }
    }

    /// An emissive material's angular profile, from its extras
    /// `{"tprf": {"emission_falloff": {"beam_width_deg": 20, "cutoff_deg": 35}}}`
    /// (mitransient's `angulararea`: full radiance within the beam width, falling
    /// linearly in angle to 0 at the cutoff; the beam width defaults to the cutoff).
    fn emission_falloff_of(
        &mut self,
        m: &gltf::Material,
    ) -> Result<Option<AngularFalloff>, SceneError> {
        let what = format!("materials[{}]", m.index().unwrap_or_default());
        let extras = tprf_extras(m.extras(), self.file, &what)?;
        let Some(v) = extras.as_ref().and_then(|t| t.get("emission_falloff")) else {
            return Ok(None);
        };
        let what = format!("{what} extras tprf.emission_falloff");
        let angle = |name: &str| -> Result<Option<f64>, SceneError> {
            match v.get(name) {
                None => Ok(None),
                Some(x) => x.as_f64().map(Some).ok_or_else(|| {
                    invalid(self.file, format!("{what}: {name} = {x} is not a number"))
                }),
            }
        };
        let Some(cutoff) = angle("cutoff_deg")? else {
            return Err(invalid(
                self.file,
                format!("{what}: give cutoff_deg (and beam_width_deg, which defaults to it)"),
            ));
        };
        if let Some(extra) = v.as_object().and_then(|o| {
            o.keys()
                .find(|k| *k != "cutoff_deg" && *k != "beam_width_deg")
        }) {
            return Err(invalid(
                self.file,
                format!("{what}: unknown field '{extra}' (cutoff_deg, beam_width_deg)"),
            ));
        }
        let beam = angle("beam_width_deg")?.unwrap_or(cutoff);
        let f = AngularFalloff {
            beam_width_rad: beam.to_radians() as f32,
            cutoff_rad: cutoff.to_radians() as f32,
        };
        f.check()
            .map_err(|e| invalid(self.file, format!("{what}: {e}")))?;
        Ok(Some(f))
    }

    /// The medium inside a material: `KHR_materials_volume`'s absorption on a
    /// transmissive material (`sigma_a = -ln(attenuationColor) / attenuationDistance`,
    /// `n` its ior), with the scattering, phase and index of the extras
    /// `{"tprf": {"medium": {...}}}` (which win where both give absorption). `None`
    /// without either, or with a volume that absorbs nothing on an untransmissive
    /// material (the extension does nothing there).
    fn medium_of(&mut self, m: &gltf::Material) -> Result<Option<Medium>, SceneError> {
        let index = m.index().unwrap_or_default();
        let what = format!("materials[{index}]");
        let transmissive = m
            .transmission()
            .is_some_and(|t| t.transmission_factor() > 0.0);
        let ior = m.ior().unwrap_or(1.5);
        let volume = match m.volume() {
            Some(v) if transmissive => {
                let (color, d) = (v.attenuation_color(), v.attenuation_distance());
                let sigma_a = volume_absorption_per_m(color, d).ok_or_else(|| {
                    invalid(
                        self.file,
                        format!(
                            "{what} KHR_materials_volume: attenuationColor {color:?} must be in \
                             (0, 1] and attenuationDistance {d} > 0"
                        ),
                    )
                })?;
                Some(sigma_a)
            }
            Some(_) => {
                self.note_once(
                    "KHR_materials_volume on a material without transmission ignored (light \
                     cannot enter it)"
                        .into(),
                );
                None
            }
            None => None,
        };
        let extras = tprf_extras(m.extras(), self.file, &what)?;
        let extra = extras.as_ref().and_then(|t| t.get("medium"));
        let medium = match (volume, extra) {
            (None, None) => return Ok(None),
            (Some(sigma_a), None) => Medium {
                sigma_s_per_m: [0.0; 3],
                sigma_a_per_m: sigma_a,
                g: 0.0,
                n: ior,
                dispersion: None,
                density: None,
            },
            (sigma_a, Some(v)) => {
                let what = format!("{what} extras tprf.medium");
                let mut medium =
                    Medium::from_json(v, sigma_a.unwrap_or([0.0; 3]), Some(self.base), &what)
                        .map_err(|e| invalid(self.file, e))?;
                // A mesh medium's grid spans the mesh unless the extras give its box (a
                // .vol file's own box is not used here: Mitsuba maps a grid to its shape).
                let density = v.get("density");
                if density.and_then(|d| d.get("bbox_min_m")).is_none()
                    && let Some(d) = medium.density.as_mut()
                {
                    d.bbox_m = None;
                }
                let n_given = v.get("n").is_some();
                if transmissive && !n_given {
                    medium.n = ior;
                }
                medium
            }
        };
        Ok(Some(medium))
    }

    /// The scene texture of a texture reference, decoding its image on first use (reduced
    /// on load when larger than [`MAX_TEXTURE_SIDE`], noted).
    fn texture(
        &mut self,
        info: Option<gltf::texture::Info>,
        encoding: Encoding,
    ) -> Result<Option<TextureRef>, SceneError> {
        let Some(info) = info else {
            return Ok(None);
        };
        if info.tex_coord() != 0 {
            self.note_once(format!(
                "textures on TEXCOORD_{} read with TEXCOORD_0: only set 0 is loaded",
                info.tex_coord()
            ));
        }
        let image = info.texture().source();
        let index = image.index();
        let cached = [None, Some(encoding)]
            .into_iter()
            .find_map(|e| self.texture_of_image.get(&(index, e)).copied());
        if let Some(k) = cached {
            return Ok(Some(TextureRef { texture: k }));
        }
        let (what, decoded) = self.decode_image(&image, encoding)?;
        let Decoded {
            texture,
            source: (w, h),
            factor,
        } = decoded;
        let key = if factor > 1 {
            let light = match encoding {
                Encoding::Srgb => "colour averaged in linear light",
                Encoding::Linear => "values averaged as stored",
            };
            self.note_once(format!(
                "{what}: {w} x {h} pixels reduced to {} x {} on load (each texel the mean of a \
                 {factor} x {factor} block, {light}; textures are kept at most \
                 {MAX_TEXTURE_SIDE} pixels a side)",
                texture.width, texture.height
            ));
            (index, Some(encoding))
        } else {
            (index, None)
        };
        let k = self.textures.len() as u32;
        self.textures.push(texture);
        self.texture_of_image.insert(key, k);
        Ok(Some(TextureRef { texture: k }))
    }

    /// Decode an image (external file, `data:` URI or buffer view) to RGBA8 under the
    /// memory budget, reduced on load if larger than [`MAX_TEXTURE_SIDE`]; with the
    /// image's name for messages.
    fn decode_image(
        &self,
        image: &gltf::Image,
        encoding: Encoding,
    ) -> Result<(String, Decoded), SceneError> {
        match image.source() {
            gltf::image::Source::Uri { uri, mime_type } => {
                let what = format!("images[{}] '{}'", image.index(), uri_label(uri));
                let encoded = open_image(self.file, self.base, &what, uri)?;
                let mime = mime_type.or_else(|| match super::resource::locate(self.base, uri) {
                    Ok(super::resource::Location::Data { mime, .. }) => mime,
                    _ => None,
                });
                let decoded = decode_texture(self.file, &what, mime, encoded, encoding)?;
                Ok((what, decoded))
            }
            gltf::image::Source::View { view, mime_type } => {
                let what = format!(
                    "images[{}] (in bufferViews[{}])",
                    image.index(),
                    view.index()
                );
                // Inside its buffer: checked by `validate::check_views`.
                let bytes = self
                    .buffers
                    .get(view.buffer().index())
                    .and_then(|b| b.0.get(view.offset()..view.offset() + view.length()))
                    .ok_or_else(|| invalid(self.file, format!("{what}: outside its buffer")))?;
                let encoded = Encoded::Bytes(bytes.into());
                let decoded = decode_texture(self.file, &what, Some(mime_type), encoded, encoding)?;
                Ok((what, decoded))
            }
        }
    }
}
