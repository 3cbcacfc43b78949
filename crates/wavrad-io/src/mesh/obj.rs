//! Wavefront OBJ through `tobj`: all objects and groups of the file merged
//! into one triangle list (as Mitsuba's `obj` shape does); materials are not
//! read.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use glam::DVec3;

use super::{push_fan, Triangle};
use crate::error::{Error, Result};

/// Read every face of an OBJ file as triangles (polygons fan-triangulated).
///
/// Lines and points are ignored; `mtllib` files are not opened.
pub fn read_obj(path: &Path) -> Result<Vec<Triangle>> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    // `..Default::default()` covers the fields tobj's optional features add.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        triangulate: false,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let (models, _materials) = tobj::load_obj_buf(&mut BufReader::new(file), &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| Error::mesh(path, None, format!("invalid OBJ file: {e}")))?;

    let mut triangles = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        let positions: Vec<DVec3> = mesh
            .positions
            .chunks_exact(3)
            .map(DVec3::from_slice) // f64 positions: tobj's `use_f64` feature
            .collect();
        if let Some(bad) = positions.iter().find(|p| !p.is_finite()) {
            return Err(Error::mesh(
                path,
                None,
                format!("vertex {bad} is not finite"),
            ));
        }
        // Without triangulation tobj reports polygon sizes in `face_arities`
        // (empty when every face is a triangle).
        let mut start = 0usize;
        let mut polygon = |len: usize, triangles: &mut Vec<Triangle>| -> Result<()> {
            let indices: Option<Vec<usize>> = mesh
                .indices
                .get(start..start + len)
                .map(|ix| ix.iter().map(|&i| i as usize).collect());
            start += len;
            let indices = indices
                .ok_or_else(|| Error::mesh(path, None, "face list shorter than its arities"))?;
            push_fan(&positions, &indices, triangles).map_err(|i| {
                Error::mesh(
                    path,
                    None,
                    format!(
                        "object \"{}\": vertex index {} out of range ({} vertices)",
                        model.name,
                        i + 1,
                        positions.len()
                    ),
                )
            })
        };
        if mesh.face_arities.is_empty() {
            for _ in 0..mesh.indices.len() / 3 {
                polygon(3, &mut triangles)?;
            }
        } else {
            for &arity in &mesh.face_arities {
                polygon(arity as usize, &mut triangles)?;
            }
        }
    }
    Ok(triangles)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn obj_file(text: &str) -> tempfile::NamedTempFile {
        let mut f = tempfile::Builder::new().suffix(".obj").tempfile().unwrap();
        f.write_all(text.as_bytes()).unwrap();
        f
    }

    #[test]
    fn quad_becomes_two_triangles_with_same_winding() {
        let f = obj_file("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 -1\nf 1//1 2//1 3//1 4//1\n");
        let tris = read_obj(f.path()).unwrap();
        assert_eq!(tris.len(), 2);
        for t in &tris {
            assert!((t[1] - t[0]).cross(t[2] - t[0]).z > 0.0, "winding kept");
        }
    }

    #[test]
    fn objects_are_merged_and_negative_indices_work() {
        let f = obj_file(
            "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf -3 -2 -1\n",
        );
        let tris = read_obj(f.path()).unwrap();
        assert_eq!(tris.len(), 2);
        assert_eq!(tris[1][0], DVec3::new(0.0, 0.0, 1.0));
    }

    #[test]
    fn bad_index_is_an_error_not_a_panic() {
        let f = obj_file("v 0 0 0\nv 1 0 0\nf 1 2 7\n");
        let e = read_obj(f.path()).unwrap_err().to_string();
        assert!(e.contains(".obj"), "{e}");
    }

    #[test]
    fn missing_file_names_the_path() {
        let e = read_obj(Path::new("/nonexistent/x.obj"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/x.obj"), "{e}");
    }
}
