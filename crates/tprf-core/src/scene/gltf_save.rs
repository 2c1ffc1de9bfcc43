//! glTF 2.0 export: one self-contained `.gltf` file (JSON, with the binary buffer and
//! any textures embedded as base64 `data:` URIs) that Blender, three.js and tprf's own
//! loader open.
//!
//! What is written, faithful to the [`Scene`] (lengths in metres, as in glTF):
//! - one mesh per material (named after it), one node each, identity transform; its
//!   triangles in scene order, one primitive per run of triangles that do / do not
//!   carry vertex normals. Vertices are shared where position, normal and UV are
//!   bit-identical; `POSITION` (with min/max), `NORMAL` where the triangles have shading
//!   normals, `TEXCOORD_0` where the material has a texture or any UV is non-zero;
//!   `u32` indices.
//! - materials: pbrMetallicRoughness factors and textures, alphaMode / alphaCutoff,
//!   doubleSided, emissive (`emissiveFactor` in [0, 1] times
//!   `KHR_materials_emissive_strength` when the emitted radiance, W/(m^2 sr), exceeds 1),
//!   `KHR_materials_specular` when the specular factor or colour is not the default,
//!   `KHR_materials_transmission` and `KHR_materials_ior` when used; a material's medium
//!   as its extras `{"tprf": {"medium": {...}}}` (every field, what tprf reads back) and,
//!   on a transmissive material that absorbs, its absorption also as
//!   `KHR_materials_volume` (`attenuationColor` after `attenuationDistance`, for other
//!   tools; `thicknessFactor` 1 marks it a volume, tprf does not read it).
//! - the camera: a node (its `matrix` is `world_from_camera`) with a perspective camera
//!   (no aspect ratio: the image decides).
//! - lights: `KHR_lights_punctual` point / spot lights, `intensity` = the largest channel
//!   of the radiant intensity (W/sr, tprf's convention: no 683 lm/W), `color` = RGB
//!   divided by it. The ambient group: point / spot lights tagged with node extras
//!   `{"tprf": {"ambient": true}}`, directional lights (`intensity` = the largest channel
//!   of the irradiance, W/m^2; the node rotated so its -Z is the light's direction), and
//!   the sky as the scene's extras `{"tprf": {"sky_radiance": [r, g, b]}}`.
//! - the scene-wide medium as the scene's extras `{"tprf": {"medium": {...}}}`.
//! - a material's dispersive index as its extras `{"tprf": {"n": {"cauchy": [A, B]}}}`
//!   (or Sellmeier's, or a name);
//! - a material's luminescence as its extras `{"tprf": {"luminescence": {...}}}`
//!   (components, rise time and emission colour: what the loader reads back).

use super::{AlphaMode, Material, Scene, SceneError, Texture, TextureRef, TriangleAttrs};
use glam::{Mat4, Quat, Vec3};
use gltf::json;
use json::validation::{Checked::Valid, USize64};
use std::collections::{BTreeSet, HashMap};
use std::io::Write;
use std::path::Path;

/// Write `scene` to `path` as a self-contained `.gltf` file.
pub fn save_gltf(scene: &Scene, path: &Path) -> Result<(), SceneError> {
    let root = to_gltf_json(scene)?;
    let io_err = |source: std::io::Error| SceneError::Io {
        path: path.display().to_string(),
        source,
    };
    let file = std::fs::File::create(path).map_err(io_err)?;
    let mut w = std::io::BufWriter::new(file);
    json::serialize::to_writer_pretty(&mut w, &root)
        .map_err(|e| io_err(std::io::Error::other(e)))?;
    w.write_all(b"\n").map_err(io_err)?;
    w.flush().map_err(io_err)
}

/// The glTF document for `scene`, buffer and images embedded as data URIs.
#[allow(
    clippy::needless_update,
    reason = "the extension structs gain an `others` field with gltf's `extensions` feature"
)]
pub fn to_gltf_json(scene: &Scene) -> Result<json::Root, SceneError> {
    scene.validate()?;
    let mut w = Writer::default();
    w.root.asset = json::Asset {
        generator: Some(format!("tprf {}", env!("CARGO_PKG_VERSION"))),
        ..Default::default()
    };

    for (i, t) in scene.textures.iter().enumerate() {
        w.texture(i, t)?;
    }
    for m in &scene.materials {
        w.material(m, scene.textures.len())?;
    }

    let mut nodes = Vec::new();
    // Each material's triangles, in order, from one pass over them (a pass per material
    // was quadratic: 10 000 Mitsuba shapes with 1000 BSDFs of their own took seconds).
    let mut by_material: Vec<Vec<usize>> = vec![Vec::new(); scene.materials.len()];
    for (i, a) in scene.attrs.iter().enumerate() {
        if let Some(tris) = by_material.get_mut(a.material as usize) {
            tris.push(i);
        }
    }
    for ((m, material), tris) in scene.materials.iter().enumerate().zip(by_material) {
        if tris.is_empty() {
            continue;
        }
        let textured = material.base_color_texture.is_some()
            || material.metallic_roughness_texture.is_some()
            || material.emissive_texture.is_some();
        let mut primitives = Vec::new();
        // Runs of triangles with / without vertex normals, in order.
        for run in tris
            .chunk_by(|&a, &b| scene.attrs[a].normals.is_some() == scene.attrs[b].normals.is_some())
        {
            primitives.push(w.primitive(scene, run, m as u32, textured));
        }
        let mesh = w.root.push(json::Mesh {
            extensions: None,
            extras: Default::default(),
            name: Some(material.name.clone()),
            primitives,
            weights: None,
        });
        nodes.push(w.root.push(json::Node {
            mesh: Some(mesh),
            name: Some(material.name.clone()),
            ..Default::default()
        }));
    }

    // Camera: far from the scene's size, so viewers do not clip it.
    let diag = scene.bounds().diagonal_m().max(1e-6);
    let camera = w.root.push(json::Camera {
        name: Some("camera".into()),
        orthographic: None,
        perspective: Some(json::camera::Perspective {
            aspect_ratio: None,
            // glTF's field of view is vertical: another axis's (a Mitsuba file's `fov`
            // along x) is written as the vertical one of a square image.
            yfov: scene.camera.yfov_rad(1.0),
            zfar: Some(4.0 * diag),
            // The camera's near plane (where a near-plane time origin counts from); glTF
            // needs it above 0.
            znear: if scene.camera.near_m > 0.0 {
                scene.camera.near_m
            } else {
                1e-3 * diag
            },
            extensions: None,
            extras: Default::default(),
        }),
        type_: Valid(json::camera::Type::Perspective),
        extensions: None,
        extras: Default::default(),
    });
    nodes.push(w.root.push(json::Node {
        camera: Some(camera),
        matrix: Some(Mat4::from(scene.camera.world_from_camera).to_cols_array()),
        name: Some("camera".into()),
        ..Default::default()
    }));

    // Lights: the pulsed ones, then the ambient group's.
    use json::extensions::scene::khr_lights_punctual as klp;
    let tagged = extras(&serde_json::json!({"tprf": {"ambient": true}}))?;
    let punctual = scene
        .lights
        .iter()
        .map(|l| (l, None))
        .chain(scene.ambient.lights.iter().map(|l| (l, tagged.clone())));
    for (l, node_extras) in punctual {
        let (color, intensity) = color_and_intensity(l.intensity_w_per_sr);
        let (type_, spot, rotation) = match &l.spot {
            None => (klp::Type::Point, None, None),
            Some(s) => (
                klp::Type::Spot,
                Some(klp::Spot {
                    inner_cone_angle: s.inner_cone_rad,
                    outer_cone_angle: s.outer_cone_rad,
                }),
                Some(json::scene::UnitQuaternion(
                    Quat::from_rotation_arc(Vec3::NEG_Z, s.direction.normalize()).to_array(),
                )),
            ),
        };
        let light = w.root.push(klp::Light {
            color,
            extensions: None,
            extras: Default::default(),
            intensity,
            name: Some(l.name.clone()),
            range: None,
            spot,
            type_: Valid(type_),
        });
        w.used.insert("KHR_lights_punctual");
        nodes.push(w.root.push(json::Node {
            name: Some(l.name.clone()),
            translation: Some(l.position.to_array()),
            rotation,
            extensions: Some(json::extensions::scene::Node {
                khr_lights_punctual: Some(klp::KhrLightsPunctual { light }),
                ..Default::default()
            }),
            extras: node_extras,
            ..Default::default()
        }));
    }
    for d in &scene.ambient.directional {
        let (color, intensity) = color_and_intensity(d.irradiance_w_per_m2);
        let light = w.root.push(klp::Light {
            color,
            extensions: None,
            extras: Default::default(),
            intensity,
            name: Some(d.name.clone()),
            range: None,
            spot: None,
            type_: Valid(klp::Type::Directional),
        });
        w.used.insert("KHR_lights_punctual");
        let rotation = Quat::from_rotation_arc(Vec3::NEG_Z, d.direction.normalize());
        nodes.push(w.root.push(json::Node {
            name: Some(d.name.clone()),
            rotation: Some(json::scene::UnitQuaternion(rotation.to_array())),
            extensions: Some(json::extensions::scene::Node {
                khr_lights_punctual: Some(klp::KhrLightsPunctual { light }),
                ..Default::default()
            }),
            ..Default::default()
        }));
    }
    let mut tprf = serde_json::Map::new();
    if scene.ambient.sky_radiance.iter().any(|&v| v != 0.0) {
        tprf.insert(
            "sky_radiance".into(),
            serde_json::json!(scene.ambient.sky_radiance),
        );
    }
    if let Some(m) = &scene.medium {
        tprf.insert("medium".into(), m.to_json());
    }
    let scene_extras = if tprf.is_empty() {
        None
    } else {
        extras(&serde_json::json!({ "tprf": tprf }))?
    };

    let scene_index = w.root.push(json::Scene {
        extensions: None,
        extras: scene_extras,
        name: Some(scene.name.clone()),
        nodes,
    });
    w.root.scene = Some(scene_index);

    // The one buffer, embedded.
    if !w.bin.is_empty() {
        let byte_length = USize64::from(w.bin.len());
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64_encode(&w.bin)
        );
        let buffer = json::Buffer {
            byte_length,
            name: None,
            uri: Some(uri),
            extensions: None,
            extras: Default::default(),
        };
        w.root.buffers.push(buffer);
    }
    w.root.extensions_used = w.used.iter().map(|s| s.to_string()).collect();
    Ok(w.root)
}

/// A light's `color` (RGB over its largest channel) and `intensity` (that channel) for an
/// RGB power (W/sr or W/m^2).
fn color_and_intensity(rgb: [f32; 3]) -> ([f32; 3], f32) {
    let max = rgb.iter().copied().fold(0.0f32, f32::max);
    if max > 0.0 {
        (rgb.map(|c| c / max), max)
    } else {
        ([1.0; 3], max)
    }
}

/// `value` as glTF extras.
fn extras(value: &serde_json::Value) -> Result<json::Extras, SceneError> {
    serde_json::value::to_raw_value(value)
        .map(Some)
        .map_err(|e| SceneError::Invalid(format!("glTF extras {value}: {e}")))
}

/// Document under construction and its binary buffer.
#[derive(Default)]
struct Writer {
    root: json::Root,
    bin: Vec<u8>,
    used: BTreeSet<&'static str>,
}

/// A vertex's identity for sharing: the bits of its position, normal and UV.
type VertexKey = ([u32; 3], Option<[u32; 3]>, [u32; 2]);

impl Writer {
    /// Append `data` to the buffer (4-byte aligned) as a new buffer view.
    fn view(
        &mut self,
        data: &[u8],
        target: json::buffer::Target,
    ) -> json::Index<json::buffer::View> {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(data);
        self.root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(data.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            name: None,
            target: Some(Valid(target)),
            extensions: None,
            extras: Default::default(),
        })
    }

    /// An accessor over a new buffer view of `count` elements.
    fn accessor(
        &mut self,
        data: &[u8],
        count: usize,
        component: json::accessor::ComponentType,
        type_: json::accessor::Type,
        target: json::buffer::Target,
        min_max: Option<(json::Value, json::Value)>,
    ) -> json::Index<json::Accessor> {
        let view = self.view(data, target);
        let (min, max) = match min_max {
            Some((a, b)) => (Some(a), Some(b)),
            None => (None, None),
        };
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(component)),
            extensions: None,
            extras: Default::default(),
            type_: Valid(type_),
            min,
            max,
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    /// One triangle-list primitive of the triangles `tris` (all of material `material`,
    /// all with or all without vertex normals).
    fn primitive(
        &mut self,
        scene: &Scene,
        tris: &[usize],
        material: u32,
        textured: bool,
    ) -> json::mesh::Primitive {
        let with_normals = scene.attrs[tris[0]].normals.is_some();
        let with_uv = textured
            || tris
                .iter()
                .any(|&i| scene.attrs[i].uv.iter().any(|uv| *uv != glam::Vec2::ZERO));
        let mut keys: HashMap<VertexKey, u32> = HashMap::new();
        let (mut pos, mut nrm, mut uvs, mut idx) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &i in tris {
            let t = &scene.triangles[i];
            let a: &TriangleAttrs = &scene.attrs[i];
            for k in 0..3 {
                let p = t.p[k];
                let n = a.normals.map(|n| n[k]);
                let uv = if with_uv { a.uv[k] } else { glam::Vec2::ZERO };
                let key = (
                    p.to_array().map(f32::to_bits),
                    n.map(|n| n.to_array().map(f32::to_bits)),
                    uv.to_array().map(f32::to_bits),
                );
                let next = keys.len() as u32;
                let v = *keys.entry(key).or_insert_with(|| {
                    pos.extend(p.to_array());
                    lo = lo.min(p);
                    hi = hi.max(p);
                    if let Some(n) = n {
                        nrm.extend(n.to_array());
                    }
                    uvs.extend(uv.to_array());
                    next
                });
                idx.push(v);
            }
        }
        use json::accessor::{ComponentType, Type};
        use json::buffer::Target;
        let count = keys.len();
        let bytes = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let mut attributes = std::collections::BTreeMap::new();
        let min_max = (
            json::Value::from(lo.to_array().to_vec()),
            json::Value::from(hi.to_array().to_vec()),
        );
        let p = self.accessor(
            &bytes(&pos),
            count,
            ComponentType::F32,
            Type::Vec3,
            Target::ArrayBuffer,
            Some(min_max),
        );
        attributes.insert(Valid(json::mesh::Semantic::Positions), p);
        if with_normals {
            let n = self.accessor(
                &bytes(&nrm),
                count,
                ComponentType::F32,
                Type::Vec3,
                Target::ArrayBuffer,
                None,
            );
            attributes.insert(Valid(json::mesh::Semantic::Normals), n);
        }
        if with_uv {
            let t = self.accessor(
                &bytes(&uvs),
                count,
                ComponentType::F32,
                Type::Vec2,
                Target::ArrayBuffer,
                None,
            );
            attributes.insert(Valid(json::mesh::Semantic::TexCoords(0)), t);
        }
        let idx_bytes: Vec<u8> = idx.iter().flat_map(|x| x.to_le_bytes()).collect();
        let indices = self.accessor(
            &idx_bytes,
            idx.len(),
            ComponentType::U32,
            Type::Scalar,
            Target::ElementArrayBuffer,
            None,
        );
        json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material: Some(json::Index::new(material)),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        }
    }

    /// Texture `i` as an embedded PNG image and a glTF texture of the same index.
    fn texture(&mut self, i: usize, t: &Texture) -> Result<(), SceneError> {
        let raw: Vec<u8> = t.rgba8.iter().flatten().copied().collect();
        let img = image::RgbaImage::from_raw(t.width, t.height, raw).ok_or_else(|| {
            SceneError::Invalid(format!(
                "texture {i}: {} pixels for {} x {}",
                t.rgba8.len(),
                t.width,
                t.height
            ))
        })?;
        let mut png = std::io::Cursor::new(Vec::new());
        img.write_to(&mut png, image::ImageFormat::Png)
            .map_err(|e| SceneError::Invalid(format!("texture {i}: cannot encode PNG: {e}")))?;
        let image = self.root.push(json::Image {
            buffer_view: None,
            mime_type: None,
            name: Some(format!("texture{i}")),
            uri: Some(format!(
                "data:image/png;base64,{}",
                base64_encode(png.get_ref())
            )),
            extensions: None,
            extras: Default::default(),
        });
        self.root.push(json::Texture {
            name: Some(format!("texture{i}")),
            sampler: None,
            source: image,
            extensions: None,
            extras: Default::default(),
        });
        Ok(())
    }

    #[allow(
        clippy::needless_update,
        reason = "the extension structs gain an `others` field with gltf's `extensions` feature"
    )]
    fn material(&mut self, m: &Material, texture_count: usize) -> Result<(), SceneError> {
        let info = |r: &Option<TextureRef>| -> Result<Option<json::texture::Info>, SceneError> {
            match r {
                None => Ok(None),
                Some(r) if (r.texture as usize) < texture_count => Ok(Some(json::texture::Info {
                    index: json::Index::new(r.texture),
                    tex_coord: 0,
                    extensions: None,
                    extras: Default::default(),
                })),
                Some(r) => Err(SceneError::Invalid(format!(
                    "material '{}' uses texture {} of {}",
                    m.name, r.texture, texture_count
                ))),
            }
        };
        use json::material as jm;
        let (alpha_mode, alpha_cutoff) = match m.alpha_mode {
            AlphaMode::Opaque => (jm::AlphaMode::Opaque, None),
            AlphaMode::Mask { cutoff } => (jm::AlphaMode::Mask, Some(jm::AlphaCutoff(cutoff))),
            AlphaMode::Blend => (jm::AlphaMode::Blend, None),
        };
        let strength = m.emissive.iter().copied().fold(0.0f32, f32::max);
        let (emissive_factor, emissive_strength) = if strength > 1.0 {
            self.used.insert("KHR_materials_emissive_strength");
            (
                m.emissive.map(|e| e / strength),
                Some(json::extensions::material::EmissiveStrength {
                    emissive_strength: json::extensions::material::EmissiveStrengthFactor(strength),
                }),
            )
        } else {
            (m.emissive, None)
        };
        let specular = if m.specular_factor != 1.0 || m.specular_color != [1.0; 3] {
            self.used.insert("KHR_materials_specular");
            Some(json::extensions::material::Specular {
                specular_factor: json::extensions::material::SpecularFactor(m.specular_factor),
                specular_color_factor: json::extensions::material::SpecularColorFactor(
                    m.specular_color,
                ),
                ..Default::default()
            })
        } else {
            None
        };
        let transmission = if m.transmission != 0.0 {
            self.used.insert("KHR_materials_transmission");
            Some(json::extensions::material::Transmission {
                transmission_factor: json::extensions::material::TransmissionFactor(m.transmission),
                ..Default::default()
            })
        } else {
            None
        };
        let ior = if m.ior != 1.5 {
            self.used.insert("KHR_materials_ior");
            Some(json::extensions::material::Ior {
                ior: json::extensions::material::IndexOfRefraction(m.ior),
                ..Default::default()
            })
        } else {
            None
        };
        let absorbs = m
            .medium
            .as_ref()
            .is_some_and(|md| md.sigma_a_per_m.iter().any(|&s| s > 0.0));
        let volume = match &m.medium {
            Some(md) if m.transmission > 0.0 && absorbs => {
                self.used.insert("KHR_materials_volume");
                let (color, distance_m) = super::medium::volume_attenuation(md.sigma_a_per_m);
                Some(json::extensions::material::Volume {
                    thickness_factor: json::extensions::material::ThicknessFactor(1.0),
                    thickness_texture: None,
                    attenuation_distance: json::extensions::material::AttenuationDistance(
                        distance_m,
                    ),
                    attenuation_color: json::extensions::material::AttenuationColor(color),
                    extras: Default::default(),
                })
            }
            _ => None,
        };
        let extensions = json::extensions::material::Material {
            transmission,
            specular,
            ior,
            emissive_strength,
            volume,
            ..Default::default()
        };
        let any_extension = extensions.transmission.is_some()
            || extensions.specular.is_some()
            || extensions.ior.is_some()
            || extensions.emissive_strength.is_some()
            || extensions.volume.is_some();
        let mut tprf = serde_json::Map::new();
        if let Some(md) = &m.medium {
            tprf.insert("medium".into(), md.to_json());
        }
        if let Some(f) = &m.emission_falloff {
            tprf.insert(
                "emission_falloff".into(),
                serde_json::json!({
                    "beam_width_deg": f.beam_width_rad.to_degrees(),
                    "cutoff_deg": f.cutoff_rad.to_degrees(),
                }),
            );
        }
        if m.one_sided {
            tprf.insert("one_sided".into(), serde_json::Value::Bool(true));
        }
        if let Some(d) = &m.dispersion {
            tprf.insert("n".into(), d.to_json());
        }
        if let Some(l) = &m.luminescence {
            tprf.insert("luminescence".into(), l.to_json());
        }
        let material_extras = if tprf.is_empty() {
            None
        } else {
            extras(&serde_json::json!({ "tprf": tprf }))?
        };
        let material = json::Material {
            alpha_cutoff,
            alpha_mode: Valid(alpha_mode),
            double_sided: m.double_sided,
            name: Some(m.name.clone()),
            pbr_metallic_roughness: jm::PbrMetallicRoughness {
                base_color_factor: jm::PbrBaseColorFactor(m.base_color),
                base_color_texture: info(&m.base_color_texture)?,
                metallic_factor: jm::StrengthFactor(m.metallic),
                roughness_factor: jm::StrengthFactor(m.roughness),
                metallic_roughness_texture: info(&m.metallic_roughness_texture)?,
                ..Default::default()
            },
            emissive_texture: info(&m.emissive_texture)?,
            emissive_factor: jm::EmissiveFactor(emissive_factor),
            extensions: any_extension.then_some(extensions),
            extras: material_extras,
            ..Default::default()
        };
        self.root.push(material);
        Ok(())
    }
}

/// Standard base64 (RFC 4648, with `=` padding).
fn base64_encode(data: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    for chunk in data.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Camera, PunctualLight, Spot, Triangle};
    use glam::Vec2;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (plain, encoded) in cases {
            assert_eq!(base64_encode(plain.as_bytes()), encoded);
        }
        assert_eq!(base64_encode(&[0xfb, 0xff, 0xbf]), "+/+/");
    }

    /// A scene exercising everything the writer does: textures, normals, UVs, every
    /// extension, a spot light.
    fn kitchen_sink() -> Scene {
        let tri = |z: f32| Triangle {
            p: [
                Vec3::new(0.0, 0.0, z),
                Vec3::new(1.0, 0.0, z),
                Vec3::new(0.0, 1.0, z),
            ],
        };
        let plain = TriangleAttrs {
            normals: None,
            uv: [Vec2::ZERO; 3],
            material: 0,
        };
        let fancy = TriangleAttrs {
            normals: Some([Vec3::Z; 3]),
            uv: [
                Vec2::new(0.0, 1.0),
                Vec2::new(1.0, 1.0),
                Vec2::new(0.0, 0.0),
            ],
            material: 1,
        };
        let glass = Material {
            name: "glass".into(),
            base_color: [0.9, 0.8, 0.7, 0.5],
            base_color_texture: Some(TextureRef { texture: 0 }),
            specular_factor: 0.5,
            specular_color: [1.0, 0.9, 0.8],
            transmission: 0.75,
            ior: 1.33,
            alpha_mode: AlphaMode::Mask { cutoff: 0.25 },
            emissive: [20.0, 10.0, 0.0],
            double_sided: false,
            ..Material::default()
        };
        Scene {
            name: "sink".into(),
            triangles: vec![tri(0.0), tri(1.0), tri(2.0), tri(3.0)],
            attrs: vec![plain, plain, fancy, fancy],
            materials: vec![Material::lambertian("grey", [0.5; 3]), glass],
            textures: vec![Texture {
                width: 2,
                height: 1,
                rgba8: vec![[255, 0, 0, 255], [0, 0, 255, 128]],
            }],
            lights: vec![PunctualLight {
                name: "spot".into(),
                position: Vec3::new(1.0, 2.0, 3.0),
                intensity_w_per_sr: [2.0, 4.0, 1.0],
                spot: Some(Spot {
                    direction: Vec3::new(0.0, -1.0, 0.0),
                    inner_cone_rad: 0.2,
                    outer_cone_rad: 0.4,
                }),
                projector: None,
            }],
            camera: Camera::look_at(Vec3::new(0.5, 0.5, 5.0), Vec3::new(0.5, 0.5, 0.0), 0.7),
            ambient: Default::default(),
            objects: Vec::new(),
            medium: None,
            notes: Vec::new(),
        }
    }

    #[test]
    fn writes_a_valid_gltf_that_reads_back() {
        let scene = kitchen_sink();
        let dir = std::env::temp_dir().join(format!("tprf-gltf-save-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("sink.gltf");
        save_gltf(&scene, &path).unwrap();
        let (doc, buffers, images) = gltf::import(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();

        let used: Vec<&str> = doc.extensions_used().collect();
        for e in [
            "KHR_lights_punctual",
            "KHR_materials_emissive_strength",
            "KHR_materials_ior",
            "KHR_materials_specular",
            "KHR_materials_transmission",
        ] {
            assert!(used.contains(&e), "{e} not in extensionsUsed: {used:?}");
        }
        assert_eq!(doc.meshes().count(), 2);
        assert_eq!(images.len(), 1);
        assert_eq!((images[0].width, images[0].height), (2, 1));
        assert_eq!(&images[0].pixels[4..8], &[0, 0, 255, 128]);

        // Geometry back, in order, with normals and UVs.
        let mut tris = Vec::new();
        for mesh in doc.meshes() {
            for prim in mesh.primitives() {
                let r = prim.reader(|b| Some(&buffers[b.index()]));
                let p: Vec<[f32; 3]> = r.read_positions().unwrap().collect();
                let n: Option<Vec<[f32; 3]>> = r.read_normals().map(|n| n.collect());
                let uv: Option<Vec<[f32; 2]>> =
                    r.read_tex_coords(0).map(|t| t.into_f32().collect());
                let idx: Vec<u32> = r.read_indices().unwrap().into_u32().collect();
                for t in idx.chunks(3) {
                    let v = |k: usize| Vec3::from(p[t[k] as usize]);
                    tris.push((
                        [v(0), v(1), v(2)],
                        n.as_ref().map(|n| {
                            t.iter()
                                .map(|&k| Vec3::from(n[k as usize]))
                                .collect::<Vec<_>>()
                        }),
                        uv.as_ref().map(|u| {
                            t.iter()
                                .map(|&k| Vec2::from(u[k as usize]))
                                .collect::<Vec<_>>()
                        }),
                        prim.material().index().unwrap(),
                    ));
                }
            }
        }
        assert_eq!(tris.len(), scene.triangles.len());
        for (i, (p, n, uv, m)) in tris.iter().enumerate() {
            assert_eq!(*p, scene.triangles[i].p);
            let a = scene.attrs[i];
            assert_eq!(*m, a.material as usize);
            assert_eq!(n.clone(), a.normals.map(|n| n.to_vec()));
            if let Some(uv) = uv {
                assert_eq!(*uv, a.uv.to_vec());
            }
        }

        // Materials.
        let g = doc.materials().nth(1).unwrap();
        let src = &scene.materials[1];
        assert_eq!(g.name(), Some("glass"));
        assert_eq!(
            g.pbr_metallic_roughness().base_color_factor(),
            src.base_color
        );
        assert!(g.pbr_metallic_roughness().base_color_texture().is_some());
        assert_eq!(g.alpha_mode(), gltf::material::AlphaMode::Mask);
        assert_eq!(g.alpha_cutoff(), Some(0.25));
        assert!(!g.double_sided());
        let strength = g.emissive_strength().unwrap();
        let e = g.emissive_factor().map(|f| f * strength);
        assert_eq!(e, src.emissive);
        let s = g.specular().unwrap();
        assert_eq!(s.specular_factor(), 0.5);
        assert_eq!(s.specular_color_factor(), [1.0, 0.9, 0.8]);
        assert_eq!(g.transmission().unwrap().transmission_factor(), 0.75);
        assert_eq!(g.ior(), Some(1.33));
        let grey = doc.materials().next().unwrap();
        assert_eq!(grey.specular().unwrap().specular_factor(), 0.0);
        assert!(grey.emissive_strength().is_none() && grey.transmission().is_none());

        // Camera and light nodes.
        let cam = doc.nodes().find(|n| n.camera().is_some()).unwrap();
        let m = Mat4::from_cols_array_2d(&cam.transform().matrix());
        assert!(m.abs_diff_eq(Mat4::from(scene.camera.world_from_camera), 1e-6));
        match cam.camera().unwrap().projection() {
            gltf::camera::Projection::Perspective(p) => assert_eq!(p.yfov(), 0.7),
            _ => panic!("not perspective"),
        }
        let ln = doc.nodes().find(|n| n.light().is_some()).unwrap();
        let light = ln.light().unwrap();
        assert_eq!(light.intensity(), 4.0);
        assert_eq!(light.color(), [0.5, 1.0, 0.25]);
        let (t, r, _) = ln.transform().decomposed();
        assert_eq!(Vec3::from(t), Vec3::new(1.0, 2.0, 3.0));
        let dir = Quat::from_array(r) * Vec3::NEG_Z;
        assert!((dir - Vec3::NEG_Y).length() < 1e-6);
        match light.kind() {
            gltf::khr_lights_punctual::Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => assert_eq!((inner_cone_angle, outer_cone_angle), (0.2, 0.4)),
            _ => panic!("not a spot light"),
        }
    }

    /// The kitchen sink with media: fog in the air, an absorbing and scattering glass
    /// (its medium's `n` its ior) and an index-matched box of smoke whose density is a
    /// grid.
    fn with_media() -> Scene {
        let mut s = kitchen_sink();
        s.medium = Some(crate::scene::Medium::grey(0.05, 0.001, 0.9, 1.0));
        s.materials[1].medium = Some(crate::scene::Medium {
            sigma_s_per_m: [0.5, 0.25, 0.125],
            sigma_a_per_m: [2.0, 0.0, 1e-3],
            g: -0.25,
            n: 1.33,
            density: None,
            dispersion: None,
        });
        let smoke = crate::scene::DensityGrid::new(
            [3, 2, 1],
            vec![0.0, 0.5, 1.0, 2.0, 0.25, 4.0],
            Some([[-1.0, 0.0, -1.0], [1.0, 2.0, 0.5]]),
            None,
            "smoke",
        )
        .unwrap();
        s.materials[0].medium = Some(crate::scene::Medium {
            density: Some(smoke),
            ..crate::scene::Medium::grey(3.0, 0.0, 0.5, 1.0)
        });
        s
    }

    fn save_and_load(scene: &Scene, edit: impl Fn(&mut serde_json::Value)) -> Scene {
        let dir = std::env::temp_dir().join(format!(
            "tprf-gltf-media-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("media.gltf");
        save_gltf(scene, &path).unwrap();
        let mut v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        edit(&mut v);
        std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
        let back = crate::scene::gltf_load::load_gltf(&path);
        std::fs::remove_dir_all(&dir).unwrap();
        back.unwrap()
    }

    #[test]
    fn media_read_back_exactly() {
        let scene = with_media();
        let back = save_and_load(&scene, |_| {});
        assert_eq!(back.medium, scene.medium);
        for (a, b) in back.materials.iter().zip(&scene.materials) {
            assert_eq!(a.medium, b.medium, "material '{}'", a.name);
        }
    }

    /// A reader that knows only KHR_materials_volume (the extras dropped) gets the glass's
    /// absorption from `attenuationColor` and `attenuationDistance`, and `n` from its ior.
    #[test]
    fn volume_extension_alone_gives_the_absorption() {
        let scene = with_media();
        let back = save_and_load(&scene, |v| {
            for m in v["materials"].as_array_mut().unwrap() {
                m.as_object_mut().unwrap().remove("extras");
            }
            assert!(
                v["extensionsUsed"]
                    .to_string()
                    .contains("KHR_materials_volume")
            );
        });
        let glass = back.materials[1].medium.clone().unwrap();
        let want = scene.materials[1].medium.as_ref().unwrap().sigma_a_per_m;
        // The colours are f32: a channel is known to a few ulps of the largest's 1/e.
        let max = want.into_iter().fold(0.0f32, f32::max);
        for c in 0..3 {
            assert!(
                (glass.sigma_a_per_m[c] - want[c]).abs() <= 1e-6 * max,
                "{:?} vs {want:?}",
                glass.sigma_a_per_m
            );
        }
        assert_eq!(
            (glass.sigma_s_per_m, glass.g, glass.n),
            ([0.0; 3], 0.0, 1.33)
        );
        // The untransmissive box has no volume extension: without extras, no medium.
        assert_eq!(back.materials[0].medium, None);
    }

    #[test]
    fn bad_media_are_refused_naming_the_field() {
        let scene = with_media();
        let dir = std::env::temp_dir().join(format!("tprf-gltf-badmedia-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("bad.gltf");
        save_gltf(&scene, &path).unwrap();
        let good: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        let cases: [(&str, serde_json::Value, &str); 6] = [
            (
                "/scenes/0/extras/tprf/medium/g",
                serde_json::json!(1.0),
                "g = 1",
            ),
            (
                "/scenes/0/extras/tprf/medium/sigma_s_per_m",
                serde_json::json!(-0.5),
                "sigma_s_per_m",
            ),
            (
                "/scenes/0/extras/tprf/medium/n",
                serde_json::json!(0.5),
                "n = 0.5",
            ),
            (
                "/materials/0/extras/tprf/medium/sigma_a_per_m",
                serde_json::json!([0.1, -1, 0]),
                "material 'grey' medium: sigma_a_per_m",
            ),
            (
                "/materials/1/extras/tprf/medium/n",
                serde_json::json!(1.1),
                "differs from its ior",
            ),
            (
                "/materials/0/extras/tprf/medium/sigma",
                serde_json::json!(1),
                "unknown key 'sigma'",
            ),
        ];
        for (pointer, value, needle) in cases {
            let mut v = good.clone();
            let (parent, key) = pointer.rsplit_once('/').unwrap();
            v.pointer_mut(parent).unwrap()[key] = value;
            std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
            let e = crate::scene::gltf_load::load_gltf(&path)
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle), "{pointer}: {e}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn rejects_a_dangling_texture_reference() {
        let mut s = kitchen_sink();
        s.textures.clear();
        assert!(matches!(to_gltf_json(&s), Err(SceneError::Invalid(_))));
    }
}
