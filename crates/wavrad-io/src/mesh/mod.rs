//! Triangle meshes from Wavefront OBJ, Stanford PLY and Mitsuba's
//! `serialized` files.
//!
//! The readers return a [`Mesh`]: the triangles in file order, polygons
//! fan-triangulated, vertex order (winding) kept: the front side is the one
//! the vertices turn counter-clockwise around, as in
//! [`wavrad_core::scene::Patch::Triangle`]; and the file's vertex normals
//! and texture coordinates at each triangle's corners when it gives them
//! (as stored: an OBJ file's v is not flipped here), and which of the
//! file's vertices each corner is, so that a file without normals can be
//! given smooth ones ([`angle_weighted_normals`]). Every other attribute is
//! ignored. Degenerate triangles are kept; callers decide what to do with
//! them.

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
    /// The vertex at each triangle's corners, in the triangles' order: two
    /// corners are one vertex of the mesh exactly when their indices here
    /// are equal (as Mitsuba's loaders weld them: a PLY or serialized
    /// file's vertex; in an OBJ file, one position with one texture
    /// coordinate).
    pub corners: Vec<[u32; 3]>,
}

/// Smooth vertex normals for a mesh whose file gives none, computed as
/// Mitsuba's loaders do (Thürmer & Wüthrich, "Computing vertex normals from
/// polygonal facets", JGT 1998): a vertex's normal is the sum of the unit
/// normals of the non-degenerate triangles around it, each weighted by the
/// triangle's interior angle at that vertex, normalised. `triangles` are the
/// mesh's triangles where the normals are wanted (Mitsuba computes them in
/// world space) and `corners` their vertices ([`Mesh::corners`]); the
/// result is the normal at each corner, zero at a vertex whose triangles'
/// normals cancel or that has only degenerate ones.
pub fn angle_weighted_normals(triangles: &[Triangle], corners: &[[u32; 3]]) -> Vec<[DVec3; 3]> {
    let count = corners
        .iter()
        .flatten()
        .max()
        .map_or(0, |&v| v as usize + 1);
    let mut sums = vec![DVec3::ZERO; count];
    for (t, vertices) in triangles.iter().zip(corners) {
        let Some(n) = (t[1] - t[0]).cross(t[2] - t[0]).try_normalize() else {
            continue;
        };
        for k in 0..3 {
            let (a, b) = (t[(k + 1) % 3] - t[k], t[(k + 2) % 3] - t[k]);
            // A corner where two vertices coincide has no angle; the
            // triangle then has zero area and was skipped above.
            let angle = a.normalize().angle_between(b.normalize());
            sums[vertices[k] as usize] += n * angle;
        }
    }
    corners
        .iter()
        .map(|vertices| vertices.map(|v| sums[v as usize].normalize_or_zero()))
        .collect()
}

/// One polygon's fan triangulation, from its corners in order: the
/// triangles `[0, i, i + 1]` of them, each keeping the polygon's winding.
fn fan<T: Copy>(polygon: &[T]) -> impl Iterator<Item = [T; 3]> + '_ {
    let rest = polygon.get(1..).unwrap_or_default();
    (polygon.first().copied().into_iter())
        .flat_map(move |first| rest.windows(2).map(move |pair| [first, pair[0], pair[1]]))
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
    for [a, b, c] in fan(polygon) {
        out.push([value(a)?, value(b)?, value(c)?]);
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

    /// The corner of a unit cube at the origin, its three faces as two
    /// triangles each (facing outwards), the shared corner vertex 0.
    fn cube_corner() -> (Vec<Triangle>, Vec<[u32; 3]>) {
        let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
        let o = DVec3::ZERO;
        // Vertices: 0 origin, 1 x, 2 y, 3 z, 4 x+y, 5 y+z, 6 x+z.
        let faces = [
            ([o, y, x + y, x], [0, 2, 4, 1]), // z = 0, facing -z
            ([o, z, y + z, y], [0, 3, 5, 2]), // x = 0, facing -x
            ([o, x, x + z, z], [0, 1, 6, 3]), // y = 0, facing -y
        ];
        let mut triangles = Vec::new();
        let mut corners = Vec::new();
        for (p, v) in faces {
            push_fan(&p, &[0, 1, 2, 3], &mut triangles).unwrap();
            corners.extend(fan(&[0, 1, 2, 3]).map(|c| c.map(|i| v[i])));
        }
        (triangles, corners)
    }

    #[test]
    fn angle_weighted_normals_at_a_cube_corner_are_its_diagonal() {
        let (triangles, corners) = cube_corner();
        let normals = angle_weighted_normals(&triangles, &corners);
        let diagonal = -DVec3::ONE.normalize();
        for (vertices, normals) in corners.iter().zip(&normals) {
            for (&v, n) in vertices.iter().zip(normals) {
                assert!((n.length() - 1.0).abs() < 1e-12);
                match v {
                    // Each face meets the corner at a right angle, split
                    // 45/45 between its triangles: equal weights.
                    0 => assert!(n.distance(diagonal) < 1e-12, "{n}"),
                    // On an edge between two faces: halfway between them.
                    1 => assert!(
                        n.distance(-(DVec3::Y + DVec3::Z).normalize()) < 1e-12,
                        "{n}"
                    ),
                    // Inside one face: its normal.
                    4 => assert!(n.distance(-DVec3::Z) < 1e-12, "{n}"),
                    _ => {}
                }
            }
        }
    }

    #[test]
    fn angle_weights_not_triangle_counts() {
        // One face split into many thin triangles around a vertex counts no
        // more than one whole face there: the weights are angles.
        let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
        let mut fine = vec![[DVec3::ZERO, y, x]]; // facing -z, 90°
        let mut corners = vec![[0, 1, 2]];
        // The face x = 0 (facing -x) as a fan of 8 triangles around 0.
        let arc = |k: u32| {
            let a = f64::from(k) / 8.0 * std::f64::consts::FRAC_PI_2;
            a.cos() * z + a.sin() * y
        };
        for k in 0..8 {
            fine.push([DVec3::ZERO, arc(k), arc(k + 1)]);
            corners.push([0, 10 + k, 11 + k]);
        }
        let n = angle_weighted_normals(&fine, &corners)[0][0];
        assert!(n.distance(-(x + z).normalize()) < 1e-9, "{n}");
    }

    #[test]
    fn degenerate_triangles_add_nothing_and_lone_vertices_get_zero() {
        let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let line = [DVec3::ZERO, DVec3::X, 2.0 * DVec3::X];
        let normals = angle_weighted_normals(&[t, line], &[[0, 1, 2], [0, 1, 3]]);
        assert!(normals[0].iter().all(|n| n.distance(DVec3::Z) < 1e-12));
        assert_eq!(normals[1][2], DVec3::ZERO);
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
