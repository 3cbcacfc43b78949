//! Helpers shared by the scene-reading tests.

// Each test crate compiles this module and uses part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use wavrad_io::{load_scene_with_options, LoadOptions, Loaded};

/// The repository's root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `body` in a scene file of `version` beside `wall.png` (the textured
/// Cornell box's texture), loaded as `approximate` says.
pub fn load_beside_wall(version: &str, body: &str, approximate: bool) -> wavrad_io::Result<Loaded> {
    let dir = tempfile::tempdir().unwrap();
    let wall = repo().join("scenes/textured-cornell-box/wall.png");
    std::fs::copy(wall, dir.path().join("wall.png")).unwrap();
    let path = dir.path().join("scene.xml");
    std::fs::write(
        &path,
        format!("<scene version=\"{version}\">\n{body}\n</scene>"),
    )
    .unwrap();
    load_scene_with_options(&path, &[], LoadOptions { approximate })
}
