//! `obj`, `ply` and `serialized`: triangle meshes from files
//! ([`crate::mesh`]).
//!
//! | parameter         | shapes          | type          | default  |
//! |-------------------|-----------------|---------------|----------|
//! | `filename`        | all             | `<string>`    | required |
//! | `shape_index`     | serialized      | `<integer>`   | 0        |
//! | `face_normals`    | all             | (ignored)     |          |
//! | `flip_tex_coords` | obj, ply        | (ignored)     |          |
//!
//! ```xml
//! <shape type="serialized">
//!     <string name="filename" value="meshes/bunny.serialized"/>
//!     <integer name="shape_index" value="2"/>
//! </shape>
//! ```
//!
//! Each triangle becomes one [`Patch::Triangle`], oriented by its winding
//! after `to_world` (so a mirroring transform turns the mesh inside out, as
//! in Mitsuba). Triangles of zero area (collinear or repeated vertices) are
//! skipped, and a warning counts them; a mesh with no other triangle is an
//! error. `face_normals` changes nothing: the solver's triangles are flat.

use std::path::Path;

use glam::DMat4;
use wavrad_core::scene::Patch;

use super::super::document::{resolve_path, Location};
use super::super::params::Object;
use super::super::Warning;
use crate::error::Result;
use crate::mesh;

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
        match format {
            Format::Serialized { .. } => obj.ignore(&["face_normals"]),
            _ => obj.ignore(&["face_normals", "flip_tex_coords"]),
        }
        let filename = obj.string("filename")?.ok_or_else(|| {
            obj.at()
                .error(format!("{} needs a \"filename\" parameter", obj.describe()))
        })?;
        Ok(MeshFile {
            format,
            filename,
            at: obj.location_of("filename").clone(),
        })
    }

    /// The mesh's triangles in world space, less those of zero area (counted
    /// in a warning). `describe` names the shape in messages; `scene_dir` is
    /// the fallback for a relative `filename`.
    pub fn patches(
        &self,
        world_from_local: &DMat4,
        describe: &str,
        scene_dir: &Path,
        warnings: &mut Vec<Warning>,
    ) -> Result<Vec<Patch>> {
        let path = resolve_path(&self.filename, &self.at.dir, scene_dir);
        let triangles = match self.format {
            Format::Obj => mesh::read_obj(&path),
            Format::Ply => mesh::read_ply(&path),
            Format::Serialized { shape_index } => mesh::read_serialized(&path, shape_index),
        }
        .map_err(|e| {
            self.at
                .error(format!("cannot load mesh of {describe}: {e}"))
        })?;
        let count = triangles.len();
        let patches: Vec<Patch> = triangles
            .into_iter()
            .map(|t| Patch::Triangle(t).transformed(world_from_local))
            .filter(|p| !p.is_degenerate())
            .collect();
        if patches.is_empty() {
            return Err(self.at.error(format!(
                "mesh \"{}\" has no usable triangles ({count} triangles, all degenerate or none)",
                path.display()
            )));
        }
        let skipped = count - patches.len();
        if skipped > 0 {
            warnings.push(self.at.warning(format!(
                "{describe}: skipped {skipped} of the {count} triangles of mesh \"{}\": they have zero area (collinear or repeated vertices)",
                path.display()
            )));
        }
        Ok(patches)
    }
}
