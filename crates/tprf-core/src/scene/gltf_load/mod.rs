//! glTF 2.0 import: `.gltf` (external or `data:` buffers and images) and `.glb`.
//!
//! Loads the default scene (else scene 0, else every root node) into a [`Scene`] in world
//! space: metres, point and spot lights in W/sr, emission in W/(m^2 sr) (DESIGN.md's
//! conventions). The `gltf` crate parses, validates and decodes; this module adds the checks
//! that keep a malformed file from panicking inside that crate, and turns every problem into
//! a [`SceneError`] that names it.
//!
//! Read: triangle primitives (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN; indexed or not, sparse
//! accessors too) with POSITION, NORMAL and TEXCOORD_0; node transforms down the hierarchy;
//! metallic-roughness materials with base colour, metallic-roughness and emissive textures,
//! alpha modes and KHR_materials_{specular, transmission, ior, emissive_strength} factors;
//! the first perspective camera; KHR_lights_punctual point and spot lights (pulsed).
//!
//! The ambient group ([`super::AmbientLights`], steady light the transient render never
//! sees): KHR_lights_punctual directional lights (irradiance `color x intensity` W/m^2);
//! point and spot lights whose node has extras `{"tprf": {"ambient": true}}`; a constant
//! sky from the scene's extras `{"tprf": {"sky_radiance": L}}` (W m^-2 sr^-1, a number
//! or `[r, g, b]`).
//!
//! Not read (each noted in [`Scene::notes`] when a file has it, except samplers and
//! occlusion): points and lines, orthographic cameras, normal maps,
//! the specular and transmission extensions' textures, TEXCOORD sets other than 0, skins and
//! morph targets, samplers (wrap and filter modes), occlusion textures (a path tracer
//! computes occlusion itself).
//!
//! A file is glTF 2.0 by its `asset.version` (glTF 1.0 is refused by name, as is a
//! missing or garbled version), and a .glb's container is checked as glTF-Validator
//! checks it (header length equal to the file's, chunk lengths, alignment, order).
//!
//! Textures are decoded under the memory budget and kept at most
//! [`MAX_TEXTURE_SIDE`] pixels a side: a larger image is reduced on load (PNG row by row,
//! never holding its full-size pixels), and noted.
//!
//! In six files: `glb` splits and checks the .glb container; `validate` reads the
//! version, the JSON and the buffers and checks what the gltf crate would otherwise
//! panic on, before it sees them; `resource` reads buffers and opens images by URI
//! (regular files only, bounded); `decode` decodes and reduces images under the memory
//! budget; `build` counts the triangles after instancing against the memory budget, then walks
//! the node trees into triangles, lights and a camera; `material` converts materials and
//! their textures.

mod build;
mod decode;
mod glb;
mod material;
mod resource;
mod validate;

pub use decode::{MAX_REDUCTION, MAX_TEXTURE_SIDE, MAX_WORK_MULTIPLE};

use super::{Scene, SceneError};
use build::Builder;
use std::path::Path;

/// Load a `.gltf` or `.glb` file into a [`Scene`] (metres, W/sr, W/(m^2 sr)).
///
/// What the loader decides on its own (a framed camera, a co-located light, dropped
/// degenerate triangles, ignored features) is listed in [`Scene::notes`].
pub fn load_gltf(path: &Path) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let bytes = crate::budget::read_file(path, "the scene file").map_err(|e| match e {
        crate::budget::BudgetError::Io { source, .. } => SceneError::Io {
            path: file.clone(),
            source,
        },
        e => SceneError::Budget(e),
    })?;
    let validate::Parsed {
        document: doc,
        blob,
        notes,
    } = validate::parse(&file, &bytes)?;
    drop(bytes);
    let base = path.parent().unwrap_or(Path::new("."));
    validate::check_buffer_budget(&file, &doc)?;
    let buffers = validate::load_buffers(&file, &doc, base, blob)?;
    validate::check_views(&file, &doc, &buffers)?;
    let mut builder = Builder::new(&file, &doc, &buffers, base);
    for note in notes {
        builder.note_once(format!("{file}: {note}"));
    }
    builder.note_ignored_extensions();
    builder.add_scene()?;
    builder.read_scene_extras()?;
    builder.finish()
}
