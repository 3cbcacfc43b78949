//! Wavefront OBJ through `tobj`: all objects and groups of the file merged
//! into one mesh (as Mitsuba's `obj` shape does); materials are not read.
//! Vertex normals (`vn`) and texture coordinates (`vt`) are each kept when
//! every face vertex of the file has one. Mitsuba makes one vertex of the
//! face vertices with the same `v/vt` indices ([`Mesh::corners`]; `vn` too,
//! but the vertices matter only without normals). tobj renumbers the
//! vertices of each object (`o`, `g`, `usemtl`), so vertices are told apart
//! by their numbers within an object and matched by value across objects:
//! the k-th of an object's vertices at one position and texture coordinate
//! is the k-th of another's (one, unless the file repeats a vertex).

use std::collections::HashMap;
use std::path::Path;

use glam::{DVec2, DVec3};

use super::{fan, push_fan, Mesh};
use crate::error::{Error, Result};

/// Read every face of an OBJ file as triangles (polygons fan-triangulated),
/// with their corners' normals and texture coordinates.
///
/// Lines and points are ignored; `mtllib` files are not opened.
pub fn read_obj(path: &Path) -> Result<Mesh> {
    super::check_mesh_file(path)?;
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    check_indices(&bytes).map_err(|(line, message)| Error::mesh(path, Some(line), message))?;
    // `..Default::default()` covers the fields tobj's optional features add.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        triangulate: false,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let (models, _materials) = tobj::load_obj_buf(&mut &bytes[..], &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| Error::mesh(path, None, format!("invalid OBJ file: {e}")))?;

    let mut triangles = Vec::new();
    let mut corners = Vec::new();
    let mut welder = Welder::default();
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
        let mut object_corners = Vec::new();
        for len in arities {
            let range = start..start + len;
            start += len;
            let polygon = |indices: &[u32]| -> Result<Vec<usize>> {
                indices
                    .get(range.clone())
                    .map(|ix| ix.iter().map(|&i| i as usize).collect())
                    .ok_or_else(|| Error::mesh(path, None, "face list shorter than its arities"))
            };
            let vertices = polygon(&mesh.indices)?;
            push_fan(&positions, &vertices, &mut triangles)
                .map_err(|i| out_of_range(i, "vertex", positions.len(), "vertices"))?;
            let uvs = (mesh.texcoord_indices.len() == mesh.indices.len())
                .then(|| polygon(&mesh.texcoord_indices))
                .transpose()?;
            let keyed: Vec<_> = (0..len)
                .map(|k| (vertices[k], uvs.as_ref().map(|uvs| uvs[k])))
                .collect();
            object_corners.extend(fan(&keyed));
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
        corners.extend(
            welder
                .object(&positions, &model_texcoords, &object_corners)
                .ok_or_else(|| Error::mesh(path, None, "more than 2^32 distinct vertices"))?,
        );
    }
    Ok(Mesh {
        triangles,
        normals,
        texcoords,
        corners,
    })
}

/// Numbers the vertices of an OBJ file as Mitsuba welds them, from one
/// object at a time (see the module's documentation).
#[derive(Default)]
struct Welder {
    /// The vertex of each (position, texture coordinate) value and how many
    /// times an object has repeated it.
    vertices: HashMap<([u64; 5], u32), u32>,
}

impl Welder {
    /// The vertices of `corners`, given as an object's position and
    /// texture coordinate indices (`None` without texture coordinates):
    /// `positions[c.0]` (in range) and `texcoords[c.1]`. `None` past 2^32
    /// vertices.
    fn object(
        &mut self,
        positions: &[DVec3],
        texcoords: &[DVec2],
        corners: &[[(usize, Option<usize>); 3]],
    ) -> Option<Vec<[u32; 3]>> {
        // Which repeat of its value each of the object's vertices is.
        let mut repeats: HashMap<(usize, Option<usize>), u32> = HashMap::new();
        let mut seen: HashMap<[u64; 5], u32> = HashMap::new();
        let mut vertex = |(p, t): (usize, Option<usize>)| -> Option<u32> {
            let uv = t
                .and_then(|t| texcoords.get(t))
                .copied()
                .unwrap_or_default();
            let key =
                [positions[p].x, positions[p].y, positions[p].z, uv.x, uv.y].map(f64::to_bits);
            let repeat = *repeats.entry((p, t)).or_insert_with(|| {
                let count = seen.entry(key).or_default();
                *count += 1;
                *count - 1
            });
            let next = u32::try_from(self.vertices.len()).ok()?;
            Some(*self.vertices.entry((key, repeat)).or_insert(next))
        };
        corners
            .iter()
            .map(|c| Some([vertex(c[0])?, vertex(c[1])?, vertex(c[2])?]))
            .collect()
    }
}

/// What a face's vertex refers to: `v/vt/vn`.
const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];

/// Check that every index of every face (`f`) and line (`l`) of the OBJ
/// text `bytes` names a vertex, texture coordinate or normal of the file,
/// read as tobj reads it (statements by their first word; a relative index
/// counts back from the elements before its statement). tobj 4.0.5 turns
/// an index before the first element, or past `usize::MAX / 3`, into an
/// offset whose arithmetic overflows (`add_vertex_multi_index`): a panic
/// where overflow is checked. The error has the 1-based line.
fn check_indices(bytes: &[u8]) -> std::result::Result<(), (u32, String)> {
    let mut counts = [0usize; 3];
    let mut largest = [(0usize, 0u32); 3];
    for (line, text) in (1u32..).zip(bytes.split(|&b| b == b'\n')) {
        let Ok(text) = std::str::from_utf8(text) else {
            continue; // tobj refuses it
        };
        let mut words = text.split_whitespace();
        match words.next() {
            Some("v") => counts[0] += 1,
            Some("vt") => counts[1] += 1,
            Some("vn") => counts[2] += 1,
            Some("f" | "l") => {
                for (kind, index) in words.flat_map(|w| w.split('/').enumerate()) {
                    let (Some(count), Ok(index)) = (counts.get(kind), index.parse::<i64>()) else {
                        continue; // empty, or tobj refuses it
                    };
                    let out_of_range = || {
                        (
                            line,
                            format!(
                                "{} index {index} out of range ({count} before it)",
                                KINDS[kind]
                            ),
                        )
                    };
                    match usize::try_from(index) {
                        Ok(0) => return Err(out_of_range()),
                        Ok(i) => largest[kind] = largest[kind].max((i, line)),
                        Err(_) if index.unsigned_abs() > *count as u64 => {
                            return Err(out_of_range())
                        }
                        Err(_) => {}
                    }
                }
            }
            _ => {}
        }
    }
    for kind in 0..3 {
        let (index, line) = largest[kind];
        if index > counts[kind] {
            return Err((
                line,
                format!(
                    "{} index {index} out of range ({} in the file)",
                    KINDS[kind], counts[kind]
                ),
            ));
        }
    }
    Ok(())
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
    fn corners_are_welded_by_position_and_texture_coordinate() {
        // Two objects sharing the edge (1 0 0)-(0 1 0), each with its own
        // copies of its vertices; the second's third vertex has two
        // texture coordinates, so it is two vertices.
        let f = obj_file(
            "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n\
             o b\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 4 5 6\n",
        );
        let mesh = read_obj(f.path()).unwrap();
        assert_eq!(mesh.corners, vec![[0, 1, 2], [1, 3, 2]]);
        // A vertex repeated within one object stays two, as in Mitsuba: a
        // triangle soup is flat.
        let f =
            obj_file("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 4 6 5\n");
        let mesh = read_obj(f.path()).unwrap();
        assert_eq!(mesh.corners, vec![[0, 1, 2], [3, 4, 5]]);
        let f = obj_file(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\n\
             f 1/1 2/1 3/1\nf 2/1 4/1 3/2\n",
        );
        let mesh = read_obj(f.path()).unwrap();
        assert_eq!(mesh.corners, vec![[0, 1, 2], [1, 3, 4]]);
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
    fn indices_before_the_first_element_or_past_the_last_are_errors_with_their_line() {
        // Found by fuzzing (docs/fuzzing.md): tobj overflowed on the first.
        for (text, needle) in [
            (
                "v 0 0 0\nvt 0 0\nf 1/1 1/-11 1/1\n",
                ":3: texture coordinate index -11 out of range (1 before it)",
            ),
            ("v 0 0 0\nf 1 1 0\n", "vertex index 0 out of range"),
            ("v 0 0 0\nvn 0 0 1\nf 1//1 1//-2 1//1\n", "normal index -2"),
            (
                "v 0 0 0\nf 1/9223372036854775807 1 1\n",
                "texture coordinate index 9223372036854775807 out of range (0 in the file)",
            ),
        ] {
            let f = obj_file(text);
            let e = read_obj(f.path()).unwrap_err().to_string();
            assert!(e.contains(needle), "expected {needle:?} in: {e}");
        }
    }

    #[test]
    fn missing_file_names_the_path() {
        let e = read_obj(Path::new("/nonexistent/x.obj"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/x.obj"), "{e}");
    }
}
