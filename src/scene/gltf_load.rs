//! glTF 2.0 import.

use super::{Scene, SceneError};
use std::path::Path;

/// Load a `.gltf` or `.glb` file.
pub fn load_gltf(path: &Path) -> Result<Scene, SceneError> {
    Err(SceneError::Gltf {
        path: path.display().to_string(),
        message: "glTF import not built yet".into(),
    })
}
