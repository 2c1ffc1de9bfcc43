//! Built-in scenes, by name.

use super::{Scene, SceneError};

/// Names accepted after `builtin:`.
pub const NAMES: &[&str] = &["cornell", "canopy"];

/// Build a built-in scene.
pub fn load(name: &str) -> Result<Scene, SceneError> {
    Err(SceneError::UnknownBuiltin(name.to_string()))
}
