//! Shape plugins: `rectangle`, `cube`, `obj`, `ply`.
//!
//! | parameter      | shapes     | type          | default  |
//! |----------------|------------|---------------|----------|
//! | `to_world`     | all        | `<transform>` | identity |
//! | `flip_normals` | all        | `<boolean>`   | false    |
//! | `filename`     | obj, ply   | `<string>`    | required |
//! | `face_normals`, `flip_tex_coords` | obj, ply | (ignored) |  |
//!
//! plus at most one nested (or referenced) `<bsdf>` and one `<emitter
//! type="area">`.
//!
//! ```xml
//! <shape type="rectangle">
//!     <transform name="to_world">
//!         <translate y="-1"/>
//!     </transform>
//!     <ref id="white"/>
//! </shape>
//! ```
//!
//! `rectangle` is [-1,1]² at z = 0 with normal +z, uv (0,0) at (-1,-1) and
//! (1,0) at (1,-1); `cube` is [-1,1]³ as six outward-facing parallelograms.
//! Both stay [`Patch::Parallelogram`]s under `to_world` (an affine map keeps
//! parallelograms); a mirroring `to_world` keeps their normals on the side
//! Mitsuba puts them (it transforms normals, not edges). Mesh triangles
//! become one [`Patch::Triangle`] each, oriented by their winding;
//! degenerate ones are dropped.

use std::path::Path;

use glam::{DMat4, DVec3};
use wavrad_core::scene::{Patch, Rgb, Surface};

use super::bsdfs::{parse_bsdf, Material};
use super::document::resolve_path;
use super::emitters::parse_area_emitter;
use super::params::{Ids, Nested, Object};
use crate::error::Result;
use crate::mesh;

/// Append the surfaces of shape `shape` to `out`, all named by the shape's
/// `id` (else its `name`, else `plugin#index`). `scene_dir` is the fallback
/// for relative mesh paths.
pub(crate) fn build_shape(
    shape: Nested,
    ids: &Ids,
    index: usize,
    scene_dir: &Path,
    out: &mut Vec<Surface>,
) -> Result<()> {
    let mut obj = Object::parse(shape.element, ids)?;
    let plugin = obj.plugin;
    if !["rectangle", "cube", "obj", "ply"].contains(&plugin) {
        return Err(obj.at().error(format!(
            "unsupported shape plugin \"{plugin}\" (supported: rectangle, cube, obj, ply)"
        )));
    }

    // Parameters.
    let world_from_local = obj.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
    if !world_from_local.is_finite() {
        return Err(obj
            .location_of("to_world")
            .error(format!("to_world of {} is not finite", obj.describe())));
    }
    let flip_normals = obj.boolean("flip_normals")?.unwrap_or(false);
    let filename = if matches!(plugin, "obj" | "ply") {
        obj.ignore(&["face_normals", "flip_tex_coords"]);
        Some(obj.string("filename")?.ok_or_else(|| {
            obj.at()
                .error(format!("{} needs a \"filename\" parameter", obj.describe()))
        })?)
    } else {
        None
    };
    obj.finish()?;

    // Nested BSDF and emitter.
    let mut material = None;
    let mut emission = None;
    for n in &obj.nested {
        match n.tag() {
            "bsdf" if material.is_none() => material = Some(parse_bsdf(*n, ids)?),
            "emitter" if emission.is_none() => emission = Some(parse_area_emitter(*n, ids)?),
            "bsdf" | "emitter" => {
                return Err(n.at.error(format!(
                    "{} has more than one <{}>",
                    obj.describe(),
                    n.tag()
                )))
            }
            _ => return Err(obj.unexpected(n)),
        }
    }
    let material: Material = material.unwrap_or_default();
    let emission = emission.unwrap_or(Rgb::ZERO);

    // Geometry in world space.
    let mut patches: Vec<Patch> = match filename {
        None => {
            let mirrored = world_from_local.determinant() < 0.0;
            let local = if plugin == "rectangle" {
                vec![rectangle()]
            } else {
                cube().to_vec()
            };
            let mut patches = Vec::with_capacity(local.len());
            for p in local {
                let p = p.transformed(&world_from_local);
                if p.is_degenerate() {
                    return Err(obj
                        .at()
                        .error(format!("{} has zero area after to_world", obj.describe())));
                }
                patches.push(if mirrored { p.flipped() } else { p });
            }
            patches
        }
        Some(filename) => {
            let at = obj.location_of("filename");
            let path = resolve_path(&filename, &at.dir, scene_dir);
            let triangles = match plugin {
                "obj" => mesh::read_obj(&path),
                _ => mesh::read_ply(&path),
            }
            .map_err(|e| at.error(format!("cannot load mesh of {}: {e}", obj.describe())))?;
            let count = triangles.len();
            let patches: Vec<Patch> = triangles
                .into_iter()
                .map(|t| Patch::Triangle(t).transformed(&world_from_local))
                .filter(|p| !p.is_degenerate())
                .collect();
            if patches.is_empty() {
                return Err(at.error(format!(
                    "mesh \"{}\" has no usable triangles ({count} triangles, all degenerate or none)",
                    path.display()
                )));
            }
            patches
        }
    };
    if flip_normals {
        patches = patches.iter().map(Patch::flipped).collect();
    }

    // Surfaces: the front carries the emission; twosided adds the back.
    let name = shape
        .element
        .attr("id")
        .or(shape.element.attr("name"))
        .map_or_else(|| format!("{plugin}#{index}"), str::to_string);
    for patch in patches {
        out.push(Surface {
            name: name.clone(),
            patch,
            brdf: material.front.clone(),
            emission,
        });
        if let Some(back) = &material.back {
            out.push(Surface {
                name: name.clone(),
                patch: patch.flipped(),
                brdf: back.clone(),
                emission: Rgb::ZERO,
            });
        }
    }
    Ok(())
}

/// Mitsuba's rectangle: [-1,1]² at z = 0, normal +z.
fn rectangle() -> Patch {
    Patch::Parallelogram {
        origin: DVec3::new(-1.0, -1.0, 0.0),
        edge_s: DVec3::new(2.0, 0.0, 0.0),
        edge_t: DVec3::new(0.0, 2.0, 0.0),
    }
}

/// Mitsuba's cube: [-1,1]³, faces +x, −x, +y, −y, +z, −z facing outwards.
fn cube() -> [Patch; 6] {
    let face = |origin: [f64; 3], s: [f64; 3], t: [f64; 3]| Patch::Parallelogram {
        origin: DVec3::from(origin),
        edge_s: DVec3::from(s),
        edge_t: DVec3::from(t),
    };
    // Edge s runs along Mitsuba 3's dp/du of each face (probed with rays:
    // ±y on the ±x and ±z faces, −x on +y, +z on −y), so anisotropic BRDFs
    // get the same tangent frame.
    [
        face([1.0, -1.0, -1.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]),
        face([-1.0, -1.0, 1.0], [0.0, 2.0, 0.0], [0.0, 0.0, -2.0]),
        face([1.0, 1.0, -1.0], [-2.0, 0.0, 0.0], [0.0, 0.0, 2.0]),
        face([1.0, -1.0, -1.0], [0.0, 0.0, 2.0], [-2.0, 0.0, 0.0]),
        face([1.0, -1.0, 1.0], [0.0, 2.0, 0.0], [-2.0, 0.0, 0.0]),
        face([-1.0, -1.0, -1.0], [0.0, 2.0, 0.0], [2.0, 0.0, 0.0]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rectangle_is_mitsubas() {
        let r = rectangle();
        assert_eq!(r.area(), 4.0);
        assert_eq!(r.normal(), DVec3::Z);
        assert_eq!(r.vertices()[0], DVec3::new(-1.0, -1.0, 0.0));
        assert_eq!(r.vertices()[1], DVec3::new(1.0, -1.0, 0.0));
    }

    #[test]
    fn cube_faces_point_outwards() {
        let expected = [
            DVec3::X,
            -DVec3::X,
            DVec3::Y,
            -DVec3::Y,
            DVec3::Z,
            -DVec3::Z,
        ];
        for (face, n) in cube().iter().zip(expected) {
            assert_eq!(face.area(), 4.0);
            assert_eq!(face.normal(), n);
            let centre = face.vertices().iter().sum::<DVec3>() / 4.0;
            assert_eq!(centre, n, "face centred on its side");
        }
    }

    #[test]
    fn cube_tangents_follow_mitsubas_dp_du() {
        let axes = [DVec3::Y, DVec3::Y, DVec3::X, DVec3::Z, DVec3::Y, DVec3::Y];
        for (face, axis) in cube().iter().zip(axes) {
            assert_eq!(face.tangent().dot(axis).abs(), 1.0, "{face:?}");
        }
    }
}
