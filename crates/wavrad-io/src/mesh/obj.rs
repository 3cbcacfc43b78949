//! Wavefront OBJ through `tobj`: all objects and groups of the file merged
//! into one mesh (as Mitsuba's `obj` shape does); materials are not read.
//! Vertex normals (`vn`) and texture coordinates (`vt`) are each kept when
//! every face vertex of the file has one.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use glam::{DVec2, DVec3};

use super::{push_fan, Mesh};
use crate::error::{Error, Result};

/// Read every face of an OBJ file as triangles (polygons fan-triangulated),
/// with their corners' normals and texture coordinates.
///
/// Lines and points are ignored; `mtllib` files are not opened.
pub fn read_obj(path: &Path) -> Result<Mesh> {
    super::check_mesh_file(path)?;
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
    let mut normals = Some(Vec::new());
    let mut texcoords = Some(Vec::new());
    for model in &models {
        let mesh = &model.mesh;
        // f64 values: tobj's `use_f64` feature.
        let vectors = |flat: &[f64]| -> Result<Vec<DVec3>> {
            let vectors: Vec<DVec3> = flat.chunks_exact(3).map(DVec3::from_slice).collect();
            match vectors.iter().find(|v| !v.is_finite()) {
                Some(bad) => Err(Error::mesh(
                    path,
                    None,
                    format!("object \"{}\": {bad} is not finite", model.name),
                )),
                None => Ok(vectors),
            }
        };
        let positions = vectors(&mesh.positions)?;
        // tobj makes up the normal index of a face vertex without one when
        // the file has other normals; a model without any has none.
        let model_normals = vectors(&mesh.normals)?;
        if mesh.normal_indices.len() != mesh.indices.len() {
            normals = None;
        }
        let model_texcoords: Vec<DVec2> = mesh
            .texcoords
            .chunks_exact(2)
            .map(DVec2::from_slice)
            .collect();
        if let Some(bad) = model_texcoords.iter().find(|v| !v.is_finite()) {
            return Err(Error::mesh(
                path,
                None,
                format!(
                    "object \"{}\": texture coordinates {bad} are not finite",
                    model.name
                ),
            ));
        }
        if mesh.texcoord_indices.len() != mesh.indices.len() {
            texcoords = None;
        }
        let out_of_range = |i: usize, what: &str, count: usize, plural: &str| {
            Error::mesh(
                path,
                None,
                format!(
                    "object \"{}\": {what} index {} out of range ({count} {plural})",
                    model.name,
                    i + 1
                ),
            )
        };
        // Without triangulation tobj reports polygon sizes in `face_arities`
        // (empty when every face is a triangle).
        let arities: Vec<usize> = if mesh.face_arities.is_empty() {
            vec![3; mesh.indices.len() / 3]
        } else {
            mesh.face_arities.iter().map(|&a| a as usize).collect()
        };
        let mut start = 0usize;
        for len in arities {
            let range = start..start + len;
            start += len;
            let polygon = |indices: &[u32]| -> Result<Vec<usize>> {
                indices
                    .get(range.clone())
                    .map(|ix| ix.iter().map(|&i| i as usize).collect())
                    .ok_or_else(|| Error::mesh(path, None, "face list shorter than its arities"))
            };
            push_fan(&positions, &polygon(&mesh.indices)?, &mut triangles)
                .map_err(|i| out_of_range(i, "vertex", positions.len(), "vertices"))?;
            if let Some(normals) = &mut normals {
                push_fan(&model_normals, &polygon(&mesh.normal_indices)?, normals)
                    .map_err(|i| out_of_range(i, "normal", model_normals.len(), "normals"))?;
            }
            if let Some(texcoords) = &mut texcoords {
                let (count, indices) = (model_texcoords.len(), &mesh.texcoord_indices);
                push_fan(&model_texcoords, &polygon(indices)?, texcoords)
                    .map_err(|i| out_of_range(i, "texture coordinate", count, "of them"))?;
            }
        }
    }
    Ok(Mesh {
        triangles,
        normals,
        texcoords,
    })
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
        let mesh = read_obj(f.path()).unwrap();
        assert_eq!(mesh.triangles.len(), 2);
        for t in &mesh.triangles {
            assert!((t[1] - t[0]).cross(t[2] - t[0]).z > 0.0, "winding kept");
        }
        // The normal is read as written, against the winding.
        assert_eq!(mesh.normals, Some(vec![[-DVec3::Z; 3]; 2]));
    }

    #[test]
    fn objects_are_merged_and_negative_indices_work() {
        let f = obj_file(
            "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf -3 -2 -1\n",
        );
        let mesh = read_obj(f.path()).unwrap();
        assert_eq!(mesh.triangles.len(), 2);
        assert_eq!(mesh.triangles[1][0], DVec3::new(0.0, 0.0, 1.0));
        assert_eq!(mesh.normals, None);
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
