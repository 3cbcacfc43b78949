//! Shape plugins: `rectangle`, `cube` (`parallelogram.rs`), `disk`,
//! `cylinder`, `sphere` (tessellated: `tessellation.rs`), the meshes
//! `obj`, `ply`, `serialized` (`mesh_file.rs`), and `instance`s of a
//! `shapegroup` (each instance's shapes are the group's, copied and placed
//! by the instance's `to_world`: the solution is per surface, so instances
//! share nothing but their input). Each plugin's module lists its own
//! parameters; every shape takes
//!
//! | parameter      | type          | default  |
//! |----------------|---------------|----------|
//! | `to_world`     | `<transform>` | identity |
//! | `flip_normals` | `<boolean>`   | false    |
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
//! The front side is the one Mitsuba shades and emits on, that of its
//! shading normal. A mirroring `to_world` keeps it for `rectangle`, `cube`,
//! `disk`, `cylinder` and meshes with vertex normals (Mitsuba transforms
//! their normals, not their edges), while it turns a `sphere` and a mesh
//! without normals inside out, as in Mitsuba; `flip_normals` then turns any
//! shape round. Each case was checked against Mitsuba 3.9.1's emitters.

mod cylinder;
mod disk;
mod mesh_file;
mod parallelogram;
mod sphere;
mod tessellation;

use glam::{DMat4, DVec3, Vec2};
use wavrad_core::scene::analytic::{AnalyticShape, ShapeKind};
use wavrad_core::scene::enclosed::SidedShape;
use wavrad_core::scene::glass::Glass;
use wavrad_core::scene::shading::ShadingNormals;
use wavrad_core::scene::texture::{flipped_uv, TextureMapping};
use wavrad_core::scene::{Patch, Rgb, Surface};

use super::bsdfs::{parse_bsdf, Material, Side};
use super::emitters::parse_area_emitter;
use super::params::{Document, Nested, Object};
use crate::error::Result;
use mesh_file::MeshFile;

/// The shape plugins wavrad reads, for messages.
const SUPPORTED: &str =
    "rectangle, cube, disk, cylinder, sphere, obj, ply, serialized, shapegroup, instance";

/// A shape plugin with its own parameters read.
#[derive(Debug, Clone)]
enum Geometry {
    Rectangle,
    Cube,
    Disk,
    Cylinder { p0: DVec3, p1: DVec3, radius: f64 },
    Sphere { center: DVec3, radius: f64 },
    Mesh(MeshFile),
}

/// A patch of a shape in its own space and Mitsuba's texture coordinates at
/// its parameters (0,0), (1,0) and (0,1).
type Local = (Patch, [Vec2; 3]);

/// A patch in world space, Mitsuba's texture coordinates at its parameters
/// (0,0), (1,0) and (0,1), and its shading normals there where the shape is
/// curved (a sphere, a cylinder, a mesh with vertex normals).
type Placed = (Patch, [Vec2; 3], Option<ShadingNormals>);

/// The patch seen from the other side, every point keeping its texture
/// coordinates and its shading normal reversed.
fn flip(&(patch, uv, shading): &Placed) -> Placed {
    let shading = shading.map(|n| n.flipped(&patch));
    (patch.flipped(), flipped_uv(uv, &patch), shading)
}

/// `placed` with its shading normals turned to the patch's front side.
fn shading_to_front((patch, uv, shading): Placed) -> Placed {
    (patch, uv, shading.map(|n| n.facing(patch.normal())))
}

/// Which side of a shape is the front after a mirroring `to_world`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Front {
    /// The side its transformed normals point to (Mitsuba transforms them
    /// as normals): the patches are turned round when `to_world` mirrors.
    Normals,
    /// The side its transformed vertices turn counter-clockwise around.
    Winding,
}

impl Geometry {
    /// The shading normal of the shape in its own space at `p` (a point of
    /// its tessellation), `None` for a flat shape: the unit sphere's and
    /// cylinder's radial directions, which [`tessellation`]'s vertex
    /// placement keeps.
    fn local_normal(&self, p: DVec3) -> Option<DVec3> {
        match self {
            Geometry::Sphere { .. } => Some(p),
            Geometry::Cylinder { .. } => Some(DVec3::new(p.x, p.y, 0.0)),
            _ => None,
        }
    }

    /// The exact shape the camera sees where the solve sees the
    /// tessellation: the unit shape and its map onto the shape placed by
    /// `world_from_local` (as [`Geometry::patches`] places the
    /// tessellation); `None` for flat shapes and meshes.
    fn exact(&self, world_from_local: &DMat4) -> Option<(ShapeKind, DMat4)> {
        match self {
            Geometry::Disk => Some((ShapeKind::Disk, *world_from_local)),
            Geometry::Cylinder { p0, p1, radius } => Some((
                ShapeKind::Cylinder,
                *world_from_local * cylinder::local_from_cylinder(*p0, *p1, *radius)?,
            )),
            Geometry::Sphere { center, radius } => {
                let world_from_unit =
                    sphere::Placement::world_from_unit(world_from_local, *center, *radius);
                let placement = sphere::Placement::new(&world_from_unit)?;
                Some((ShapeKind::Sphere, placement.world_from_sphere))
            }
            Geometry::Rectangle | Geometry::Cube | Geometry::Mesh(_) => None,
        }
    }

    /// Read the plugin's own parameters from `obj`.
    fn parse(obj: &mut Object) -> Result<Geometry> {
        Ok(match obj.plugin {
            "rectangle" => Geometry::Rectangle,
            "cube" => Geometry::Cube,
            "disk" => Geometry::Disk,
            "cylinder" => Geometry::Cylinder {
                p0: obj.point("p0")?.unwrap_or(DVec3::ZERO),
                p1: obj.point("p1")?.unwrap_or(DVec3::Z),
                radius: obj.float("radius")?.unwrap_or(1.0),
            },
            "sphere" => Geometry::Sphere {
                center: obj.point("center")?.unwrap_or(DVec3::ZERO),
                radius: obj.float("radius")?.unwrap_or(1.0),
            },
            "obj" | "ply" | "serialized" => Geometry::Mesh(MeshFile::parse(obj)?),
            plugin => {
                return Err(obj.at().error(format!(
                    "unsupported shape plugin \"{plugin}\" (supported: {SUPPORTED})"
                )))
            }
        })
    }

    /// The shape's patches in world space, front side Mitsuba's (before
    /// `flip_normals`), with Mitsuba's texture coordinates (meshes where
    /// their files have them).
    fn patches(
        &self,
        obj: &Object,
        world_from_local: &DMat4,
        doc: &Document,
    ) -> Result<Vec<Placed>> {
        let zero_area = || {
            obj.at()
                .error(format!("{} has zero area after to_world", obj.describe()))
        };
        let too_large = || {
            obj.at().error(format!(
                "{} is too large for 64-bit floats after to_world",
                obj.describe()
            ))
        };
        let (local, world_from_local, front) = match self {
            Geometry::Rectangle => (
                vec![(parallelogram::rectangle(), parallelogram::RECTANGLE_UV)],
                *world_from_local,
                Front::Normals,
            ),
            Geometry::Cube => (
                (parallelogram::cube().into_iter())
                    .zip(parallelogram::CUBE_UV)
                    .collect(),
                *world_from_local,
                Front::Normals,
            ),
            Geometry::Disk => (
                disk::textured_unit_disk(),
                *world_from_local,
                Front::Normals,
            ),
            Geometry::Cylinder { p0, p1, radius } => {
                let local_from_cylinder = cylinder::local_from_cylinder(*p0, *p1, *radius)
                    .ok_or_else(|| {
                        obj.location_of("p1").error(format!(
                            "{} has p0 = p1 = {p0}: its axis has no direction",
                            obj.describe()
                        ))
                    })?;
                (
                    cylinder::textured_unit_cylinder(),
                    *world_from_local * local_from_cylinder,
                    Front::Normals,
                )
            }
            Geometry::Sphere { center, radius } => {
                let world_from_unit =
                    sphere::Placement::world_from_unit(world_from_local, *center, *radius);
                if !world_from_unit.is_finite() {
                    return Err(too_large());
                }
                let placement = sphere::Placement::new(&world_from_unit).ok_or_else(zero_area)?;
                if placement.replaced {
                    doc.warn(obj.location_of("to_world").warning(format!(
                        "to_world of {} shears or scales unevenly; as in Mitsuba, the shape is a sphere of radius {} (its length along the local x axis)",
                        obj.describe(),
                        placement.radius()
                    )));
                }
                (
                    sphere::textured_unit_sphere(),
                    placement.world_from_sphere,
                    Front::Winding,
                )
            }
            Geometry::Mesh(file) => return file.patches(world_from_local, &obj.describe(), doc),
        };
        let mirrored = world_from_local.determinant() < 0.0;
        local
            .iter()
            .map(|&(local, uv)| {
                let p = local.transformed(&world_from_local);
                if !p.vertices().iter().all(|v| v.is_finite()) {
                    return Err(too_large());
                }
                let normals = tessellation::parameter_points(&local).map(|q| self.local_normal(q));
                let shading = match normals {
                    [Some(a), Some(b), Some(c)] => ShadingNormals::new([a, b, c])
                        .and_then(|n| n.transformed(&world_from_local)),
                    _ => None,
                };
                match (p.is_degenerate(), front == Front::Normals && mirrored) {
                    (true, _) => Err(zero_area()),
                    (false, true) => Ok(shading_to_front(flip(&(p, uv, shading)))),
                    (false, false) => Ok(shading_to_front((p, uv, shading))),
                }
            })
            .collect()
    }
}

/// What the scene's shapes become.
#[derive(Debug, Default)]
pub(crate) struct Built {
    /// The surfaces of the solve.
    pub surfaces: Vec<Surface>,
    /// The curved shapes among them, as they are.
    pub curved: Vec<AnalyticShape>,
    /// The glass shapes, which are not surfaces.
    pub glass: Vec<Glass>,
    /// The flat shapes with a `twosided` material, whose inner sides are
    /// left out when they are closed and empty
    /// ([`wavrad_core::scene::enclosed`]).
    pub two_sided: Vec<SidedShape>,
}

/// Append the surfaces of shape `shape` to `built`, all named by the
/// shape's `id` (else its `name`, else `plugin#index`), and, for a curved
/// shape, its exact description; or, for glass, its faces; return its area
/// emitter, nested or referenced, if it has one. `world_from_parent`
/// places it (an instance's `to_world`; the identity at the top level).
pub(crate) fn build_shape<'a>(
    shape: Nested<'a>,
    doc: &'a Document<'a>,
    index: usize,
    world_from_parent: &DMat4,
    built: &mut Built,
) -> Result<Option<Nested<'a>>> {
    let mut obj = Object::parse(shape.element, doc)?;
    let plugin = obj.plugin;

    // Parameters.
    let geometry = Geometry::parse(&mut obj)?;
    let world_from_local =
        *world_from_parent * obj.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
    if !world_from_local.is_finite() {
        return Err(obj
            .location_of("to_world")
            .error(format!("to_world of {} is not finite", obj.describe())));
    }
    let flip_normals = obj.boolean("flip_normals")?.unwrap_or(false);
    obj.finish()?;

    // Nested BSDF and emitter.
    let mut material = None;
    let mut emitter = None;
    for n in &obj.nested {
        match n.tag() {
            "bsdf" if material.is_none() => material = Some(parse_bsdf(*n, doc)?),
            "emitter" if emitter.is_none() => emitter = Some(*n),
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
    let emission = match emitter {
        Some(n) => parse_area_emitter(n, doc)?,
        None => Rgb::ZERO,
    };

    // Geometry in world space.
    let mut patches = geometry.patches(&obj, &world_from_local, doc)?;
    if flip_normals {
        patches = patches.iter().map(flip).collect();
    }
    let name = shape
        .element
        .attr("id")
        .or(shape.element.attr("name"))
        .map_or_else(|| format!("{plugin}#{index}"), str::to_string);

    let (front, back) = match material {
        Material::Opaque { front, back } => (front, back),
        Material::Glass(interface) => {
            if let Some(n) = emitter {
                return Err(n.at.error(format!(
                    "{} is glass, which wavrad cannot make emit",
                    obj.describe()
                )));
            }
            let faces = patches.into_iter().map(|(p, _, n)| (p, n)).collect();
            // A sphere turned inside out keeps its faces.
            let sphere = match geometry.exact(&world_from_local) {
                Some((ShapeKind::Sphere, m)) if m.determinant() > 0.0 && !flip_normals => Some((
                    m.transform_point3(DVec3::ZERO),
                    m.transform_vector3(DVec3::X).length(),
                )),
                _ => None,
            };
            built.glass.push(Glass {
                name,
                interface,
                faces,
                sphere,
            });
            return Ok(None);
        }
    };

    // Surfaces: the front carries the emission; twosided adds the back.
    let (out, shapes) = (&mut built.surfaces, &mut built.curved);
    let first = out.len();
    let mut sided = SidedShape::default();
    for placed in patches {
        let mut surface = textured(&front, placed, doc);
        surface.name.clone_from(&name);
        surface.emission = emission;
        sided.fronts.push(out.len() as u32);
        out.push(surface);
        if let Some(back) = &back {
            let mut surface = textured(back, flip(&placed), doc);
            surface.name.clone_from(&name);
            sided.backs.push(out.len() as u32);
            out.push(surface);
        }
    }
    let range = u32::try_from(first).ok().zip(u32::try_from(out.len()).ok());
    match (geometry.exact(&world_from_local), range) {
        (Some((kind, world_from_shape)), Some((start, end))) => shapes.push(AnalyticShape {
            kind,
            world_from_shape,
            surfaces: start..end,
        }),
        _ if back.is_some() => built.two_sided.push(sided),
        _ => {}
    }
    Ok(emitter)
}

/// Append the shapes of the shape group an `instance` names to `built`,
/// placed by the instance's
/// `to_world` after each shape's own (numbered from `index` on, for their
/// names), as Mitsuba's `instance` and `shapegroup` do. As in Mitsuba, a
/// group's shapes cannot emit and a group holds no instances or groups.
pub(crate) fn build_instance<'a>(
    instance: Nested<'a>,
    doc: &'a Document<'a>,
    index: usize,
    built: &mut Built,
) -> Result<()> {
    let mut obj = Object::parse(instance.element, doc)?;
    let world_from_instance = obj.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
    if !world_from_instance.is_finite() {
        return Err(obj
            .location_of("to_world")
            .error(format!("to_world of {} is not finite", obj.describe())));
    }
    obj.finish()?;
    let group = match obj.nested.as_slice() {
        [group] if group.tag() == "shape" && group.plugin() == "shapegroup" => *group,
        [other] => return Err(obj.unexpected(other)),
        _ => {
            return Err(obj.at().error(format!(
                "{} needs one shape group (<ref id=\"…\"/> to a <shape type=\"shapegroup\">), \
                 got {}",
                obj.describe(),
                obj.nested.len()
            )))
        }
    };
    let members = Object::parse(group.element, doc)?;
    members.finish()?;
    for (k, shape) in members.nested.iter().enumerate() {
        if shape.tag() != "shape" {
            return Err(members.unexpected(shape));
        }
        if matches!(shape.plugin(), "shapegroup" | "instance") {
            return Err(shape.at.error(format!(
                "a <shape type=\"{}\"> inside a shape group: nested instancing is not \
                 supported (nor in Mitsuba)",
                shape.plugin()
            )));
        }
        if let Some(emitter) = build_shape(*shape, doc, index + k, &world_from_instance, built)? {
            return Err(emitter.at.error(format!(
                "an area emitter on a shape of the shape group at {}: instanced shapes \
                 cannot emit (nor in Mitsuba)",
                group.element.at
            )));
        }
    }
    Ok(())
}

/// A surface of `side` on `placed`. A textured side's albedo is its
/// texture's average over the patch, and the surface keeps the mapping.
fn textured(side: &Side, (patch, uv, shading): Placed, doc: &Document) -> Surface {
    let mut surface = Surface {
        name: String::new(),
        patch,
        brdf: side.brdf.clone(),
        emission: Rgb::ZERO,
        texture: None,
        shading,
    };
    if let Some(index) = side.texture {
        let mapping = TextureMapping { texture: index, uv };
        let average = doc.with_texture(index, |t| mapping.average(t, &patch, &patch));
        surface.brdf = side.brdf.with_lambertian(average);
        surface.texture = Some(mapping);
    }
    surface
}
