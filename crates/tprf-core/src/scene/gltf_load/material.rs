//! glTF materials as scene [`Material`]s: metallic-roughness factors and textures, the
//! KHR_materials_{specular, transmission, ior, emissive_strength} factors, alpha modes,
//! and images decoded to RGBA8 once each (once per encoding where reduced on load).

use super::build::{Builder, name_or_index};
use super::decode::{Decoded, Encoded, Encoding, MAX_TEXTURE_SIDE, decode_texture};
use super::resource::open_image;
use super::validate::{invalid, uri_label};
use crate::scene::{AlphaMode, Material, SceneError, TextureRef};

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
            ior: m.ior().unwrap_or(1.5),
            alpha_mode: match m.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Mask => AlphaMode::Mask {
                    cutoff: m.alpha_cutoff().unwrap_or(0.5),
                },
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
            },
            emissive: m.emissive_factor().map(|e| e * strength),
            emissive_texture: self.texture(m.emissive_texture(), Encoding::Srgb)?,
            double_sided: m.double_sided(),
        })
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
