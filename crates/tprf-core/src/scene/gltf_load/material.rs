//! glTF materials as scene [`Material`]s: metallic-roughness factors and textures, the
//! KHR_materials_{specular, transmission, ior, emissive_strength} factors, alpha modes,
//! and images decoded to RGBA8 once each.

use super::build::{Builder, name_or_index};
use super::validate::{check_uri, invalid, resource_error, uri_label};
use crate::scene::{AlphaMode, Material, SceneError, Texture, TextureRef};

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
            base_color_texture: self.texture(pbr.base_color_texture())?,
            metallic: pbr.metallic_factor(),
            roughness: pbr.roughness_factor(),
            metallic_roughness_texture: self.texture(pbr.metallic_roughness_texture())?,
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
            emissive_texture: self.texture(m.emissive_texture())?,
            double_sided: m.double_sided(),
        })
    }

    /// The scene texture of a texture reference, decoding its image on first use.
    fn texture(
        &mut self,
        info: Option<gltf::texture::Info>,
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
        if let Some(&k) = self.texture_of_image.get(&image.index()) {
            return Ok(Some(TextureRef { texture: k }));
        }
        let texture = self.decode_image(&image)?;
        let k = self.textures.len() as u32;
        self.textures.push(texture);
        self.texture_of_image.insert(image.index(), k);
        Ok(Some(TextureRef { texture: k }))
    }

    /// Decode an image (external file, `data:` URI or buffer view) to RGBA8.
    fn decode_image(&self, image: &gltf::Image) -> Result<Texture, SceneError> {
        let source = image.source();
        let uri = match source {
            gltf::image::Source::Uri { uri, .. } => Some(uri),
            gltf::image::Source::View { .. } => None,
        };
        let what = match uri {
            Some(uri) => format!("images[{}] '{}'", image.index(), uri_label(uri)),
            None => format!("images[{}] (in a buffer view)", image.index()),
        };
        if let Some(uri) = uri {
            check_uri(uri).map_err(|m| invalid(self.file, format!("{what}: {m}")))?;
        }
        let data = gltf::image::Data::from_source(source, Some(self.base), self.buffers)
            .map_err(|e| resource_error(self.file, self.base, &what, uri, e))?;
        to_texture(data).ok_or_else(|| {
            invalid(
                self.file,
                format!("{what}: pixel data does not match its size"),
            )
        })
    }
}

/// Decoded image bytes (any format the gltf crate produces) as an RGBA8 [`Texture`], values
/// as stored (sRGB decoding happens at lookup). `None` if the bytes do not match the size.
fn to_texture(data: gltf::image::Data) -> Option<Texture> {
    use gltf::image::Format as F;
    use image::{DynamicImage as D, ImageBuffer as B};
    let (w, h, px) = (data.width, data.height, data.pixels);
    let u16s = |px: &[u8]| -> Vec<u16> {
        px.as_chunks::<2>()
            .0
            .iter()
            .map(|&b| u16::from_ne_bytes(b))
            .collect()
    };
    let f32s = |px: &[u8]| -> Vec<f32> {
        px.as_chunks::<4>()
            .0
            .iter()
            .map(|&b| f32::from_ne_bytes(b))
            .collect()
    };
    let image = match data.format {
        F::R8 => D::ImageLuma8(B::from_raw(w, h, px)?),
        F::R8G8 => D::ImageLumaA8(B::from_raw(w, h, px)?),
        F::R8G8B8 => D::ImageRgb8(B::from_raw(w, h, px)?),
        F::R8G8B8A8 => D::ImageRgba8(B::from_raw(w, h, px)?),
        F::R16 => D::ImageLuma16(B::from_raw(w, h, u16s(&px))?),
        F::R16G16 => D::ImageLumaA16(B::from_raw(w, h, u16s(&px))?),
        F::R16G16B16 => D::ImageRgb16(B::from_raw(w, h, u16s(&px))?),
        F::R16G16B16A16 => D::ImageRgba16(B::from_raw(w, h, u16s(&px))?),
        F::R32G32B32FLOAT => D::ImageRgb32F(B::from_raw(w, h, f32s(&px))?),
        F::R32G32B32A32FLOAT => D::ImageRgba32F(B::from_raw(w, h, f32s(&px))?),
    };
    let rgba = image.into_rgba8();
    Some(Texture {
        width: w,
        height: h,
        rgba8: rgba.pixels().map(|p| p.0).collect(),
    })
}
