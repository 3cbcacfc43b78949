//! Triangle meshes from Wavefront OBJ, Stanford PLY and Mitsuba's
//! `serialized` files.
//!
//! The readers return a [`Mesh`]: the triangles in file order, polygons
//! fan-triangulated, vertex order (winding) kept: the front side is the one
//! the vertices turn counter-clockwise around, as in
//! [`wavrad_core::scene::Patch::Triangle`]; and the file's vertex normals
//! and texture coordinates at each triangle's corners when it gives them
//! (as stored: an OBJ file's v is not flipped here). Every other attribute
//! is ignored. Degenerate triangles are kept; callers decide what to do
//! with them.

mod obj;
mod ply;
mod serialized;

pub use obj::read_obj;
pub use ply::read_ply;
pub use serialized::read_serialized;

use crate::error::{Error, Result};
use glam::{DVec2, DVec3};
use std::path::Path;

/// Largest mesh file wavrad reads, in bytes (16 GiB): far above any mesh
/// that fits in memory once solved, and a clear error instead of reading a
/// device or a runaway file until memory runs out.
pub const MAX_MESH_FILE_BYTES: u64 = 16 << 30;

/// Check that `path` is a regular file of at most [`MAX_MESH_FILE_BYTES`]
/// before it is read.
fn check_mesh_file(path: &Path) -> Result<()> {
    let metadata = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !metadata.is_file() {
        return Err(Error::mesh(path, None, "not a regular file"));
    }
    if metadata.len() > MAX_MESH_FILE_BYTES {
        return Err(Error::mesh(
            path,
            None,
            format!(
                "{} bytes: wavrad reads mesh files of at most {MAX_MESH_FILE_BYTES} bytes",
                metadata.len()
            ),
        ));
    }
    Ok(())
}

/// Three vertices, counter-clockwise seen from the front.
pub type Triangle = [DVec3; 3];

/// A triangle mesh as a file gives it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// The triangles, in file order.
    pub triangles: Vec<Triangle>,
    /// The vertex normals at each triangle's corners, in the triangles'
    /// order, as stored (not normalised); `None` when the file has none.
    pub normals: Option<Vec<[DVec3; 3]>>,
    /// The texture coordinates at each triangle's corners, in the
    /// triangles' order, as stored; `None` when the file has none.
    pub texcoords: Option<Vec<[DVec2; 3]>>,
}

/// Fan-triangulate one polygon given as indices into `values` (positions,
/// normals or texture coordinates), appending to `out`. Fails with the offending index when one
/// is out of range.
fn push_fan<T: Copy>(
    values: &[T],
    polygon: &[usize],
    out: &mut Vec<[T; 3]>,
) -> std::result::Result<(), usize> {
    let value = |i: usize| values.get(i).copied().ok_or(i);
    if polygon.len() < 3 {
        return Ok(());
    }
    let first = value(polygon[0])?;
    for pair in polygon[1..].windows(2) {
        out.push([first, value(pair[0])?, value(pair[1])?]);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fan_of_a_quad_keeps_winding() {
        let p = [DVec3::ZERO, DVec3::X, DVec3::X + DVec3::Y, DVec3::Y];
        let mut out = Vec::new();
        push_fan(&p, &[0, 1, 2, 3], &mut out).unwrap();
        assert_eq!(out.len(), 2);
        for t in &out {
            assert!((t[1] - t[0]).cross(t[2] - t[0]).z > 0.0);
        }
        assert_eq!(push_fan(&p, &[0, 1, 9], &mut out), Err(9));
    }

    #[test]
    fn devices_and_directories_are_not_read_as_meshes() {
        let dir = tempfile::tempdir().unwrap();
        for (path, read) in [
            (
                Path::new("/dev/zero"),
                read_obj as fn(&Path) -> Result<Mesh>,
            ),
            (Path::new("/dev/zero"), read_ply),
            (dir.path(), read_obj),
        ] {
            let message = read(path).unwrap_err().to_string();
            assert!(message.contains("not a regular file"), "{message}");
        }
        let message = read_serialized(Path::new("/dev/zero"), 0)
            .unwrap_err()
            .to_string();
        assert!(message.contains("not a regular file"), "{message}");
    }
}
