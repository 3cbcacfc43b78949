//! `obj`, `ply` and `serialized`: triangle meshes from files
//! ([`crate::mesh`]).
//!
//! | parameter         | shapes          | type          | default  |
//! |-------------------|-----------------|---------------|----------|
//! | `filename`        | all             | `<string>`    | required |
//! | `shape_index`     | serialized      | `<integer>`   | 0        |
//! | `face_normals`    | all             | `<boolean>`   | false    |
//! | `flip_tex_coords` | obj, ply        | `<boolean>`   | true (obj), false (ply) |
//!
//! ```xml
//! <shape type="serialized">
//!     <string name="filename" value="meshes/bunny.serialized"/>
//!     <integer name="shape_index" value="2"/>
//! </shape>
//! ```
//!
//! Each triangle becomes one [`Patch::Triangle`] whose front is the side
//! Mitsuba shades and emits on, that of its shading normal: where the file
//! has vertex normals and `face_normals` is false, the side they point to
//! (summed over the triangle's corners and transformed as normals, so a
//! mirroring `to_world` keeps it); otherwise the side its vertices turn
//! counter-clockwise around after `to_world` (so a mirroring transform turns
//! the mesh inside out). The vertex normals, where kept, are also the
//! triangle's shading normals ([`wavrad_core::scene::Surface::shading`]),
//! interpolated over it as Mitsuba interpolates them. A file without vertex
//! normals gets smooth ones unless `face_normals` is true, as in Mitsuba:
//! each vertex's is the angle-weighted mean of its triangles' normals
//! ([`mesh::angle_weighted_normals`], in world space). Triangles of zero area (collinear or repeated
//! vertices) are skipped, and a warning counts them; a mesh with no other
//! triangle is an error. Texture coordinates are the file's (v turned to
//! 1 − v when `flip_tex_coords`, as Mitsuba 3 does by default for OBJ), or
//! without them each triangle's barycentric ones, as Mitsuba's.

use glam::{DMat3, DMat4, DVec2, Vec2};
use wavrad_core::scene::Patch;

use super::super::document::Location;
use super::super::params::{Document, Object};
use super::{flip, shading_to_front, Placed};
use crate::error::Result;
use crate::mesh;
use wavrad_core::scene::shading::ShadingNormals;

/// The file formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Obj,
    Ply,
    /// Mitsuba's own, one shape of the file.
    Serialized {
        shape_index: u32,
    },
}

/// A mesh shape's file, its parameters read.
#[derive(Debug, Clone)]
pub(super) struct MeshFile {
    format: Format,
    filename: String,
    /// Whether the file's vertex normals are ignored.
    face_normals: bool,
    /// Whether v of the file's texture coordinates is turned to 1 − v.
    flip_tex_coords: bool,
    /// Where `filename` is written.
    at: Location,
}

impl MeshFile {
    /// Read the parameters of `obj`, a shape of plugin `obj`, `ply` or
    /// `serialized`.
    pub fn parse(obj: &mut Object) -> Result<MeshFile> {
        let format = match obj.plugin {
            "obj" => Format::Obj,
            "ply" => Format::Ply,
            _ => {
                let index = obj.integer("shape_index")?.unwrap_or(0);
                let shape_index = u32::try_from(index).map_err(|_| {
                    obj.location_of("shape_index").error(format!(
                        "shape_index of {} must be a non-negative integer, not {index}",
                        obj.describe()
                    ))
                })?;
                Format::Serialized { shape_index }
            }
        };
        let flip_tex_coords = match format {
            Format::Obj | Format::Ply => obj
                .boolean("flip_tex_coords")?
                .unwrap_or(format == Format::Obj),
            Format::Serialized { .. } => false,
        };
        let face_normals = obj.boolean("face_normals")?.unwrap_or(false);
        let filename = obj.string("filename")?.ok_or_else(|| {
            obj.at()
                .error(format!("{} needs a \"filename\" parameter", obj.describe()))
        })?;
        Ok(MeshFile {
            format,
            filename,
            face_normals,
            flip_tex_coords,
            at: obj.location_of("filename").clone(),
        })
    }

    /// The mesh's triangles in world space with their texture coordinates,
    /// less those of zero area (counted in a warning). `describe` names the shape in messages; a relative
    /// `filename` is looked up along the document's search path.
    pub fn patches(
        &self,
        world_from_local: &DMat4,
        describe: &str,
        doc: &Document,
    ) -> Result<Vec<Placed>> {
        let path = doc.search.resolve(&self.filename, &self.at.dir);
        let mesh = match self.format {
            Format::Obj => mesh::read_obj(&path),
            Format::Ply => mesh::read_ply(&path),
            Format::Serialized { shape_index } => mesh::read_serialized(&path, shape_index),
        }
        .map_err(|e| {
            self.at
                .error(format!("cannot load mesh of {describe}: {e}"))
        })?;
        let count = mesh.triangles.len();
        let world: Vec<mesh::Triangle> = (mesh.triangles.iter())
            .map(|t| t.map(|p| world_from_local.transform_point3(p)))
            .collect();
        // The shading normals at the corners in world space: the file's
        // transformed as normals, or, for a file without any, smooth ones
        // from the mesh's own triangles, as Mitsuba makes them.
        let normals = match (&mesh.normals, self.face_normals) {
            (_, true) => None,
            (Some(normals), false) => {
                let to_world = DMat3::from_mat4(*world_from_local).inverse().transpose();
                Some(normals.iter().map(|n| n.map(|n| to_world * n)).collect())
            }
            (None, false) => Some(mesh::angle_weighted_normals(&world, &mesh.corners)),
        };
        let texcoord = |uv: DVec2| {
            let v = if self.flip_tex_coords {
                1.0 - uv.y
            } else {
                uv.y
            };
            Vec2::new(uv.x as f32, v as f32)
        };
        let barycentric = [Vec2::ZERO, Vec2::X, Vec2::Y];
        let patches: Vec<Placed> = world
            .iter()
            .enumerate()
            .filter_map(|(i, &t)| {
                let p = Patch::Triangle(t);
                if p.is_degenerate() {
                    return None;
                }
                let uv = (mesh.texcoords.as_ref()).map_or(barycentric, |uv| uv[i].map(texcoord));
                let shading =
                    (normals.as_ref()).and_then(|normals| ShadingNormals::new(normals[i]));
                // A triangle whose normals point against its winding is
                // turned round (a mirroring to_world reverses the winding
                // but, transformed as normals, not the normals).
                let turn = normals.as_ref().is_some_and(|normals| {
                    let [a, b, c] = t;
                    (b - a).cross(c - a).dot(normals[i].iter().sum()) < 0.0
                });
                let placed = (p, uv, shading);
                Some(shading_to_front(if turn { flip(&placed) } else { placed }))
            })
            .collect();
        if patches.is_empty() {
            return Err(self.at.error(format!(
                "mesh \"{}\" has no usable triangles ({count} triangles, all degenerate or none)",
                path.display()
            )));
        }
        let skipped = count - patches.len();
        if skipped > 0 {
            doc.warn(self.at.warning(format!(
                "{describe}: skipped {skipped} of the {count} triangles of mesh \"{}\": they have zero area (collinear or repeated vertices)",
                path.display()
            )));
        }
        Ok(patches)
    }
}
