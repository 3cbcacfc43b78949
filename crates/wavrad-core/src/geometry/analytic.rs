//! Camera rays against the scene's curved shapes as they are
//! ([`crate::scene::analytic`]): a sphere's outline is a circle, not a
//! polygon. A ray is traced through the triangles without those that
//! tessellate a curved shape, and against each curved shape whose box it
//! crosses; where a curved shape is nearest, the ray sees its exact point
//! and exact normal, and the solution is read on the surface of the
//! tessellation that covers the point: the one the point projects onto
//! (from the centre of a sphere, from the axis of a cylinder, along the
//! normal of a disk), on the side the ray sees. A ray that meets the
//! tessellation but not the shape (the tessellation reaches outside the
//! shape at its vertices) passes on, and one that meets the shape where the
//! tessellation falls inside (mid-face) sees the shape.
//!
//! Only camera rays see the exact shapes. The gathers and shadow rays of a
//! camera ray's point on the convex side of one ([`ExactHit::convex_side`])
//! start at the exact point and pass through the shape's own
//! tessellation; every other shape occludes them as its tessellation, the
//! geometry of the solve.
//!
//! Of more than a few shapes, a ray tests only those whose boxes it
//! crosses, found by an obvhs BVH over the boxes (`ShapeTree`); like the
//! triangles' ([`crate::geometry::visibility`]), its `f32` tree only
//! culls, and the `f64` test of each candidate decides, so the shape seen
//! and its hit are the ones a test of every shape in turn finds.

use crate::geometry::visibility::{cull_distance, cull_slack, f32_box, f32_ray, Occluder, BOX_PAD};
use crate::scene::analytic::{AnalyticShape, ShapeKind};
use crate::scene::{Patch, Scene};
use glam::{DMat3, DMat4, DVec3};
use obvhs::cwbvh::CwBvh;
use obvhs::BvhBuildParams;
use std::ops::Range;

/// Fewest shapes for which rays find theirs through a [`ShapeTree`]: below
/// it, testing each shape's box in turn is as fast.
const TREE_FROM: usize = 8;

/// A curved shape prepared for ray queries.
#[derive(Debug, Clone)]
struct ExactShape {
    kind: ShapeKind,
    world_from_shape: DMat4,
    shape_from_world: DMat4,
    /// Maps the unit shape's normals to world space (the inverse transpose
    /// of the linear part of `world_from_shape`).
    world_from_shape_normals: DMat3,
    /// Its world-space bounding box, padded.
    lo: DVec3,
    hi: DVec3,
    /// The surfaces of its tessellation, with their patches and normals.
    surfaces: Range<u32>,
    patches: Vec<Patch>,
    normals: Vec<DVec3>,
}

/// Where a ray meets a curved shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExactHit {
    /// Ray parameter of the hit (the point is `origin + t·dir`).
    pub t: f64,
    /// The point on the exact shape.
    pub position: DVec3,
    /// The exact shape's unit normal there, turned towards the ray's
    /// origin.
    pub normal: DVec3,
    /// Whether the side seen bulges towards the ray (a sphere or a
    /// cylinder seen from outside): a ray leaving the point into that side
    /// never meets the shape again, nor its tessellation, which lies within
    /// it, so rays may start at the exact point.
    pub convex_side: bool,
    /// The point in the unit shape's space.
    local: DVec3,
}

/// What a camera ray sees first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SeenHit {
    /// A surface that tessellates no curved shape.
    Surface(super::tracing::SurfaceHit),
    /// A curved shape.
    Exact {
        /// The point and normal on the exact shape.
        hit: ExactHit,
        /// The surface of its tessellation whose front is the side seen,
        /// and the point of it under `hit`; `None` when no surface is on
        /// that side (a one-sided shape seen from behind).
        covering: Option<(u32, DVec3)>,
        /// The surfaces of its tessellation, first and past the last (the
        /// first names the shape).
        surfaces: (u32, u32),
    },
}

impl SeenHit {
    /// The surface seen: the covering one on a curved shape (its first
    /// surface when seen from behind).
    pub fn surface(&self) -> u32 {
        match *self {
            SeenHit::Surface(hit) => hit.surface,
            SeenHit::Exact {
                covering, surfaces, ..
            } => covering.map_or(surfaces.0, |(s, _)| s),
        }
    }
}

/// The scene's curved shapes, for camera rays.
#[derive(Debug, Clone, Default)]
pub struct ExactShapes {
    shapes: Vec<ExactShape>,
    /// A BVH over their boxes, from [`TREE_FROM`] shapes on.
    tree: Option<ShapeTree>,
    /// Per surface, whether it tessellates one of them (empty without
    /// shapes).
    tessellates: Vec<bool>,
}

impl ExactShapes {
    /// The curved shapes of `scene`, each with its tessellation's surfaces.
    /// A shape whose surfaces are not the scene's, or whose transform is
    /// singular, is left out (its tessellation is then what camera rays
    /// see); [`Scene::check_bounds`] refuses such a scene.
    pub fn new(scene: &Scene) -> ExactShapes {
        let n = scene.surfaces.len();
        let shapes: Vec<ExactShape> = (scene.shapes.iter())
            .filter_map(|shape| ExactShape::new(shape, scene))
            .collect();
        let mut tessellates = vec![false; if shapes.is_empty() { 0 } else { n }];
        for shape in &shapes {
            for s in shape.surfaces.clone() {
                tessellates[s as usize] = true;
            }
        }
        ExactShapes {
            tree: (shapes.len() >= TREE_FROM).then(|| ShapeTree::new(&shapes)),
            shapes,
            tessellates,
        }
    }

    /// True when the scene has no curved shapes.
    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// True when surface `s` tessellates a curved shape.
    pub fn tessellates(&self, s: u32) -> bool {
        self.tessellates.get(s as usize).copied().unwrap_or(false)
    }

    /// The nearest curved shape along `origin + t·dir`, t ∈ (tmin, tmax):
    /// its index and the hit; of shapes hit at the same t, the first.
    fn nearest(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: f64,
    ) -> Option<(usize, ExactHit)> {
        match &self.tree {
            Some(tree) => tree.nearest(&self.shapes, origin, dir, tmin, tmax),
            None => nearest_in_turn(&self.shapes, origin, dir, tmin, tmax),
        }
    }

    /// What the ray `origin + t·dir`, t ∈ (tmin, tmax), sees first among
    /// the curved shapes and the triangles of `occluder` (whose primitive
    /// `prim` is on surface `surface_of(prim)`) that tessellate none.
    pub fn trace(
        &self,
        occluder: &Occluder,
        surface_of: impl Fn(u32) -> u32,
        (origin, dir): (DVec3, DVec3),
        (tmin, tmax): (f64, f64),
    ) -> Option<SeenHit> {
        let triangle = occluder.intersect_except(origin, dir, tmin, tmax, |prim| {
            self.tessellates(surface_of(prim))
        });
        let far = triangle.map_or(tmax, |h| h.t);
        match self.nearest(origin, dir, tmin, far) {
            Some((k, hit)) => {
                let shape = &self.shapes[k];
                Some(SeenHit::Exact {
                    hit,
                    covering: shape.covering(&hit, occluder, &surface_of),
                    surfaces: (shape.surfaces.start, shape.surfaces.end),
                })
            }
            None => triangle.map(|h| {
                SeenHit::Surface(super::tracing::SurfaceHit {
                    surface: surface_of(h.primitive),
                    position: origin + h.t * dir,
                    distance: h.t,
                })
            }),
        }
    }
}

/// [`ExactShapes::nearest`] among `shapes`, testing each in turn.
fn nearest_in_turn(
    shapes: &[ExactShape],
    origin: DVec3,
    dir: DVec3,
    tmin: f64,
    tmax: f64,
) -> Option<(usize, ExactHit)> {
    let mut best: Option<(usize, ExactHit)> = None;
    for (k, shape) in shapes.iter().enumerate() {
        let far = best.map_or(tmax, |(_, b)| b.t);
        if let Some(hit) = shape.intersect(origin, dir, tmin, far) {
            best = Some((k, hit));
        }
    }
    best
}

/// A BVH over the curved shapes' boxes (obvhs' compressed wide BVH, as
/// for the triangles in [`crate::geometry::visibility`]), in `f32`: it
/// only culls. Each box is padded by [`BOX_PAD`] of the shapes' extent and
/// rounded outwards; a ray is first clipped, in `f64`, to the box around
/// all shapes, and its `f32` ray starts a slack behind that and overshoots
/// its far end, so the `f32` traversal reaches every shape the exact test
/// can hit, however far away the ray starts.
#[derive(Debug, Clone)]
struct ShapeTree {
    bvh: CwBvh,
    /// The box around all shapes' boxes.
    lo: DVec3,
    hi: DVec3,
    /// How far (world units) the f32 ray starts behind the clipped ray.
    slack: f64,
}

impl ShapeTree {
    /// The tree over `shapes` (not empty).
    fn new(shapes: &[ExactShape]) -> ShapeTree {
        let (lo, hi) = (shapes.iter()).fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), s| (lo.min(s.lo), hi.max(s.hi)),
        );
        let scale = (lo.abs().max(hi.abs()).max_element()).max((hi - lo).max_element());
        let pad = DVec3::splat(BOX_PAD * scale.max(f64::MIN_POSITIVE));
        let boxes: Vec<_> = (shapes.iter())
            .map(|s| f32_box(s.lo - pad, s.hi + pad))
            .collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh(
            &boxes,
            BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        ShapeTree {
            bvh,
            lo,
            hi,
            slack: cull_slack(pad.x),
        }
    }

    /// [`ExactShapes::nearest`] among `shapes`, the ones the tree was
    /// built over: the same shape and hit as testing each in turn.
    fn nearest(
        &self,
        shapes: &[ExactShape],
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: f64,
    ) -> Option<(usize, ExactHit)> {
        let len = dir.length();
        if len == 0.0 || !len.is_finite() || !origin.is_finite() {
            return nearest_in_turn(shapes, origin, dir, tmin, tmax);
        }
        // The part of the ray within the box around all shapes: every
        // shape's box is inside it, so a ray that misses it meets none.
        let (near, far) = box_span((self.lo, self.hi), origin, dir, (tmin, tmax))?;
        let unit = dir / len;
        let start = origin + near * dir - self.slack * unit;
        let ray = f32_ray(start, unit, cull_distance((far - near) * len, self.slack));
        let mut best: Option<(usize, ExactHit)> = None;
        let mut found = obvhs::ray::RayHit::none();
        self.bvh.ray_traverse(ray, &mut found, |_, slot| {
            let k = self.bvh.primitive_indices[slot] as usize;
            // Up to the best hit so far, included: of two shapes hit at
            // the same t the first wins, whichever the tree reaches first.
            let reach = best.map_or(tmax, |(_, b)| b.t.next_up());
            if let Some(hit) = shapes[k].intersect(origin, dir, tmin, reach) {
                if best.is_none_or(|(j, b)| (hit.t, k) < (b.t, j)) {
                    best = Some((k, hit));
                }
            }
            best.map_or(f32::INFINITY, |(_, b)| {
                cull_distance((b.t - near) * len, self.slack)
            })
        });
        best
    }
}

impl ExactShape {
    /// `shape` of `scene` prepared, `None` when its surfaces are not the
    /// scene's or its transform is singular.
    fn new(shape: &AnalyticShape, scene: &Scene) -> Option<ExactShape> {
        let range = shape.surfaces.clone();
        if range.start > range.end || range.end as usize > scene.surfaces.len() {
            return None;
        }
        let m = shape.world_from_shape;
        let linear = DMat3::from_mat4(m);
        let det = linear.determinant();
        let inverse = m.inverse();
        if !m.is_finite() || det == 0.0 || !det.is_finite() || !inverse.is_finite() {
            return None;
        }
        let (lo, hi) = shape.bounds();
        let pad = 1e-9 * (hi - lo).max_element().max(f64::MIN_POSITIVE);
        let surfaces = &scene.surfaces[range.start as usize..range.end as usize];
        Some(ExactShape {
            kind: shape.kind,
            world_from_shape: m,
            shape_from_world: inverse,
            world_from_shape_normals: linear.inverse().transpose(),
            lo: lo - DVec3::splat(pad),
            hi: hi + DVec3::splat(pad),
            surfaces: range,
            patches: surfaces.iter().map(|s| s.patch).collect(),
            normals: surfaces.iter().map(|s| s.patch.normal()).collect(),
        })
    }

    /// Where `origin + t·dir`, t ∈ (tmin, tmax), first meets the shape.
    fn intersect(&self, origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> Option<ExactHit> {
        if !crosses_box((self.lo, self.hi), origin, dir, (tmin, tmax)) {
            return None;
        }
        let o = self.shape_from_world.transform_point3(origin);
        let d = self.shape_from_world.transform_vector3(dir);
        let within = |t: f64| t > tmin && t < tmax;
        let t = match self.kind {
            ShapeKind::Sphere => {
                (quadratic_roots(d.length_squared(), o.dot(d), o.length_squared() - 1.0))
                    .into_iter()
                    .flatten()
                    .find(|&t| within(t))
            }
            ShapeKind::Cylinder => {
                let (ox, dx) = (o.truncate(), d.truncate());
                (quadratic_roots(dx.length_squared(), ox.dot(dx), ox.length_squared() - 1.0))
                    .into_iter()
                    .flatten()
                    .find(|&t| within(t) && (0.0..=1.0).contains(&(o.z + t * d.z)))
            }
            ShapeKind::Disk => {
                let t = -o.z / d.z;
                (within(t) && (o + t * d).truncate().length_squared() <= 1.0).then_some(t)
            }
        }?;
        let local = o + t * d;
        let local_normal = match self.kind {
            ShapeKind::Sphere => local,
            ShapeKind::Cylinder => DVec3::new(local.x, local.y, 0.0),
            ShapeKind::Disk => DVec3::Z,
        };
        let normal = (self.world_from_shape_normals * local_normal).normalize_or_zero();
        if normal == DVec3::ZERO {
            return None;
        }
        let outward = normal.dot(dir) <= 0.0;
        Some(ExactHit {
            t,
            position: origin + t * dir,
            normal: if outward { normal } else { -normal },
            convex_side: outward && self.kind != ShapeKind::Disk,
            local,
        })
    }

    /// The surface of the tessellation whose front faces the way
    /// `hit.normal` does and that covers `hit`, and the point of it under
    /// `hit`: where the line from the shape's centre (a sphere), from its
    /// axis (a cylinder) or along its normal (a disk) through the hit meets
    /// it, or where none is met (past a disk's polygonal rim), the nearest
    /// point of such a surface to that line's crossing of its plane.
    fn covering(
        &self,
        hit: &ExactHit,
        occluder: &Occluder,
        surface_of: impl Fn(u32) -> u32,
    ) -> Option<(u32, DVec3)> {
        let p = hit.local;
        let from = match self.kind {
            ShapeKind::Sphere => DVec3::ZERO,
            ShapeKind::Cylinder => DVec3::new(0.0, 0.0, p.z),
            ShapeKind::Disk => p - DVec3::Z,
        };
        let origin = self.world_from_shape.transform_point3(from);
        let dir = self.world_from_shape.transform_vector3(p - from);
        let start = self.surfaces.start;
        let facing = |s: u32| {
            s >= start
                && s < self.surfaces.end
                && self.normals[(s - start) as usize].dot(hit.normal) > 0.0
        };
        // The tessellation lies within a percent of the shape: t near 1.
        let (near, far) = (0.5, 1.5);
        let skip = |prim| !facing(surface_of(prim));
        if let Some(h) = occluder.intersect_except(origin, dir, near, far, skip) {
            return Some((surface_of(h.primitive), origin + h.t * dir));
        }
        let mut best: Option<(f64, u32, DVec3)> = None;
        for (k, patch) in self.patches.iter().enumerate() {
            let s = start + k as u32;
            let normal = self.normals[k];
            if !facing(s) || normal.dot(dir) == 0.0 {
                continue;
            }
            let t = normal.dot(patch.vertices()[0] - origin) / normal.dot(dir);
            if !(near..far).contains(&t) {
                continue;
            }
            let crossing = origin + t * dir;
            let nearest = patch.point_at(patch.clamp_param(patch.param_of(crossing)));
            let distance = (nearest - crossing).length();
            if best.is_none_or(|(d, _, _)| distance < d) {
                best = Some((distance, s, nearest));
            }
        }
        best.map(|(_, s, q)| (s, q))
    }
}

/// The real roots of a·t² + 2b·t + c = 0 in increasing order, computed
/// without cancellation; `None` for each when there are none.
fn quadratic_roots(a: f64, b: f64, c: f64) -> [Option<f64>; 2] {
    let discriminant = b * b - a * c;
    if a == 0.0 || discriminant.is_nan() || discriminant < 0.0 {
        return [None, None];
    }
    let q = -(b + discriminant.sqrt().copysign(b));
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
    [Some(t0.min(t1)), Some(t0.max(t1))]
}

/// Whether `origin + t·dir`, t ∈ (tmin, tmax), crosses the box [lo, hi]
/// (slab test).
fn crosses_box(bounds: (DVec3, DVec3), origin: DVec3, dir: DVec3, range: (f64, f64)) -> bool {
    box_span(bounds, origin, dir, range).is_some()
}

/// The parameters `(near, far)` between which `origin + t·dir`, t ∈ (tmin,
/// tmax), is in the box [lo, hi] (slab test); `None` when it is not.
fn box_span(
    (lo, hi): (DVec3, DVec3),
    origin: DVec3,
    dir: DVec3,
    (tmin, tmax): (f64, f64),
) -> Option<(f64, f64)> {
    let (mut near, mut far) = (tmin, tmax);
    for axis in 0..3 {
        let (o, d) = (origin[axis], dir[axis]);
        if d == 0.0 {
            if o < lo[axis] || o > hi[axis] {
                return None;
            }
            continue;
        }
        let (a, b) = ((lo[axis] - o) / d, (hi[axis] - o) / d);
        near = near.max(a.min(b));
        far = far.min(a.max(b));
    }
    (near <= far).then_some((near, far))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::tracing::SceneTracer;
    use crate::sampling::hash2;
    use crate::testing::{grey, scattered_shapes};

    fn shape(kind: ShapeKind, world_from_shape: DMat4, surfaces: Range<u32>) -> AnalyticShape {
        AnalyticShape {
            kind,
            world_from_shape,
            surfaces,
        }
    }

    fn prepared(kind: ShapeKind, world_from_shape: DMat4) -> ExactShape {
        let scene = Scene::from_surfaces(Vec::new());
        ExactShape::new(&shape(kind, world_from_shape, 0..0), &scene).unwrap()
    }

    #[test]
    fn rays_meet_each_shape_where_its_equation_says() {
        let far = f64::INFINITY;
        // A sphere of radius 2 at (1, 0, 0): a ray along +z at distance b
        // from its centre meets it at depth √(4 − b²) before the centre.
        let m = DMat4::from_translation(DVec3::X) * DMat4::from_scale(DVec3::splat(2.0));
        let sphere = prepared(ShapeKind::Sphere, m);
        let origin = DVec3::new(1.0 + 1.2, 0.0, -10.0);
        let hit = sphere.intersect(origin, DVec3::Z, 0.0, far).unwrap();
        assert!(
            (hit.t - (10.0 - (4.0f64 - 1.44).sqrt())).abs() < 1e-12,
            "{hit:?}"
        );
        let radial = (hit.position - DVec3::X) / 2.0;
        assert!(
            (hit.normal - radial).length() < 1e-12,
            "exact outward normal"
        );
        assert!(sphere.intersect(origin, DVec3::Z, 0.0, hit.t).is_none());
        let beside = DVec3::new(1.0 + 2.001, 0.0, -10.0);
        assert!(sphere.intersect(beside, DVec3::Z, 0.0, far).is_none());
        // From inside, the far side, its normal turned inwards.
        let inside = sphere.intersect(DVec3::X, DVec3::Z, 0.0, far).unwrap();
        assert!((inside.t - 2.0).abs() < 1e-12 && (inside.normal + DVec3::Z).length() < 1e-12);

        // A disk squashed into an ellipse of semi-axes 3 (x) and 1 (y),
        // tilted about x: the normal is the tilted z, whichever side.
        let m = DMat4::from_rotation_x(0.5) * DMat4::from_scale(DVec3::new(3.0, 1.0, 1.0));
        let disk = prepared(ShapeKind::Disk, m);
        let tilted = m.transform_vector3(DVec3::Z).normalize();
        for (x, y, meets) in [
            (2.9, 0.0, true),
            (3.1, 0.0, false),
            (0.0, 0.9, true),
            (2.0, 0.8, false),
        ] {
            let target = m.transform_point3(DVec3::new(x / 3.0, y, 0.0));
            let from = target + 5.0 * DVec3::new(0.1, 0.2, 1.0).normalize();
            let hit = disk.intersect(from, (target - from).normalize(), 0.0, far);
            assert_eq!(hit.is_some(), meets, "({x}, {y})");
            if let Some(hit) = hit {
                assert!((hit.position - target).length() < 1e-12);
                assert!((hit.normal.dot(tilted).abs() - 1.0).abs() < 1e-12);
                assert!(hit.normal.dot(target - from) < 0.0, "turned to the ray");
            }
        }

        // The open cylinder of radius 0.5 from z = 0 to 2: seen from the
        // side, its near wall; through the open end, its inner wall, or
        // nothing when the ray leaves by the other end.
        let m = DMat4::from_scale(DVec3::new(0.5, 0.5, 2.0));
        let cylinder = prepared(ShapeKind::Cylinder, m);
        let hit = cylinder
            .intersect(DVec3::new(-5.0, 0.3, 1.0), DVec3::X, 0.0, far)
            .unwrap();
        assert!((hit.position - DVec3::new(-0.4, 0.3, 1.0)).length() < 1e-12);
        assert!((hit.normal - DVec3::new(-0.8, 0.6, 0.0)).length() < 1e-12);
        let down = DVec3::new(0.2, 0.0, -1.0).normalize();
        let hit = cylinder
            .intersect(DVec3::new(0.0, 0.0, 3.0), down, 0.0, far)
            .unwrap();
        assert!((hit.position.x - 0.5).abs() < 1e-12 && (hit.normal + DVec3::X).length() < 1e-12);
        let steep = DVec3::new(0.05, 0.0, -1.0).normalize();
        assert!(cylinder
            .intersect(DVec3::new(0.0, 0.0, 3.0), steep, 0.0, far)
            .is_none());
    }

    /// The unit sphere "tessellated" by the cube [-1, 1]³ (six outward
    /// faces: surfaces 0–5) in front of a wall (surface 6).
    fn sphere_in_a_cube() -> Scene {
        let mut surfaces: Vec<_> = (Patch::inward_box(DVec3::splat(-1.0), DVec3::ONE).iter())
            .map(|p| grey(p.flipped()))
            .collect();
        surfaces.push(grey(Patch::Parallelogram {
            origin: DVec3::new(-5.0, -5.0, -3.0),
            edge_s: DVec3::X * 10.0,
            edge_t: DVec3::Y * 10.0,
        }));
        let mut scene = Scene::from_surfaces(surfaces);
        scene
            .shapes
            .push(shape(ShapeKind::Sphere, DMat4::IDENTITY, 0..6));
        scene
    }

    #[test]
    fn camera_rays_see_the_exact_shape_and_read_the_face_under_it() {
        let scene = sphere_in_a_cube();
        let tracer = SceneTracer::new(&scene);
        let down = -DVec3::Z;
        // Through the cube's corner, outside the sphere: the wall behind.
        let corner = DVec3::new(0.9, 0.9, 5.0);
        assert_eq!(
            tracer
                .trace(corner, down, 0.0, f64::INFINITY)
                .unwrap()
                .surface,
            1
        );
        match tracer.trace_seen(corner, down, 0.0, f64::INFINITY) {
            Some(SeenHit::Surface(hit)) => assert_eq!(hit.surface, 6),
            other => panic!("{other:?}"),
        }
        // Off-centre onto the sphere: the exact point and normal, read on
        // the top face (the cube's +z face) where the radius through it
        // meets that face.
        let origin = DVec3::new(0.3, -0.4, 5.0);
        let Some(SeenHit::Exact { hit, covering, .. }) = tracer.trace_seen(origin, down, 0.0, 9.0)
        else {
            panic!()
        };
        let expected = DVec3::new(0.3, -0.4, (1.0f64 - 0.25).sqrt());
        assert!((hit.position - expected).length() < 1e-12);
        assert!((hit.normal - expected).length() < 1e-12);
        let (s, q) = covering.unwrap();
        assert!((scene.surfaces[s as usize].patch.normal() - DVec3::Z).length() < 1e-12);
        assert!((q - expected / expected.z).length() < 1e-12, "{q}");
        // From inside, the one-sided cube shows no face: the exact hit is
        // reported, covered by nothing.
        match tracer.trace_seen(DVec3::ZERO, DVec3::X, 0.0, f64::INFINITY) {
            Some(SeenHit::Exact {
                covering: None,
                hit,
                ..
            }) => {
                assert!((hit.position - DVec3::X).length() < 1e-12)
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_shape_that_does_not_fit_its_scene_is_left_to_its_tessellation() {
        let mut scene = sphere_in_a_cube();
        scene.shapes[0].surfaces = 0..99;
        scene.shapes.push(shape(ShapeKind::Disk, DMat4::ZERO, 0..1));
        let exact = ExactShapes::new(&scene);
        assert!(exact.is_empty() && !exact.tessellates(0));
        let tracer = SceneTracer::new(&scene);
        let corner = DVec3::new(0.9, 0.9, 5.0);
        let seen = tracer.trace_seen(corner, -DVec3::Z, 0.0, f64::INFINITY);
        assert!(matches!(seen, Some(SeenHit::Surface(h)) if h.surface != 6));
    }

    /// A uniform unit vector from two uniform numbers.
    fn direction(u: glam::DVec2) -> DVec3 {
        let (z, phi) = (2.0 * u.x - 1.0, std::f64::consts::TAU * u.y);
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// Rays of every kind against `exact`'s shapes, placed by
    /// `world_from_field` (a uniform scale and a translation) with the cube
    /// [-1, 1]³ they are scattered over: from anywhere in and around the
    /// cube (many from inside a shape) and from far away, of any length;
    /// from each sphere's centre; grazing each sphere, just inside, on and
    /// just outside its outline, from near and far; along the axes, with components ±0; each
    /// between limits (random, or none), and again between limits at its
    /// own nearest hit, which leave that hit out.
    fn rays_of_every_kind(
        exact: &ExactShapes,
        world_from_field: DMat4,
    ) -> Vec<(DVec3, DVec3, f64, f64)> {
        let mut rays = Vec::new();
        for i in 0..3000u64 {
            let [a, b, c] = [0, 1, 2].map(|j| hash2(7, 3 * i + j));
            let inside = DVec3::new(a.x, a.y, b.x) * 2.6 - DVec3::splat(1.3);
            let length = [1.0, 0.01, 37.0][i as usize % 3];
            // One in ten from far away (where f32 directions stray by more
            // than the boxes' padding), aimed into the cube.
            let (origin, dir) = if i % 10 == 0 {
                let origin = 1e4 * inside;
                (origin, (direction(c) - origin).normalize() * length)
            } else {
                (inside, direction(c) * length)
            };
            let limits = match i % 4 {
                0 => (0.0, f64::INFINITY),
                1 => (-0.5 * b.y, f64::INFINITY),
                2 => (b.y, b.y + 3.0 * c.x),
                _ => (0.0, 2.0 * c.x),
            };
            let (tmin, tmax) = (limits.0 / length, limits.1 / length);
            rays.push((world_from_field.transform_point3(origin), dir, tmin, tmax));
        }
        for (i, shape) in exact.shapes.iter().enumerate() {
            if shape.kind != ShapeKind::Sphere {
                continue;
            }
            let centre = shape.world_from_shape.transform_point3(DVec3::ZERO);
            let radius = shape.world_from_shape.transform_vector3(DVec3::X).length();
            let [a, b] = [0, 1].map(|j| hash2(11, 2 * i as u64 + j));
            let (dir, across) = (direction(a), direction(b));
            let across = (across - across.dot(dir) * dir).normalize();
            rays.push((centre, dir, 0.0, f64::INFINITY));
            // Grazing it at a point of its outline, and at its pole +x
            // where its box touches it, from near and from far.
            let pole_dir = (dir - dir.x * DVec3::X).normalize();
            for (dir, across) in [(dir, across), (pole_dir, DVec3::X)] {
                for distance in [3.0 * radius, 1e4] {
                    for factor in [1.0 - 1e-12, 1.0, 1.0 + 1e-12, 1.0 - 1e-6] {
                        let origin = centre + factor * radius * across - distance * dir;
                        rays.push((origin, dir, 0.0, f64::INFINITY));
                    }
                }
            }
        }
        let axes = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::new(-0.0, 0.0, -1.0)];
        for i in 0..400u64 {
            let [a, b] = [0, 1].map(|j| hash2(13, 2 * i + j));
            let origin = DVec3::new(a.x, a.y, b.x) * 2.6 - DVec3::splat(1.3);
            let dir = axes[i as usize % 4] * if b.y < 0.5 { 1.0 } else { -1.0 };
            rays.push((
                world_from_field.transform_point3(origin),
                dir,
                0.0,
                f64::INFINITY,
            ));
        }
        // Limits at the nearest hit: just past it, and just short of it.
        let at_hits: Vec<_> = (rays.iter())
            .filter_map(|&(o, d, tmin, tmax)| {
                let (_, hit) = nearest_in_turn(&exact.shapes, o, d, tmin, tmax)?;
                Some([(o, d, hit.t, tmax), (o, d, tmin, hit.t)])
            })
            .flatten()
            .collect();
        rays.extend(at_hits);
        rays
    }

    #[test]
    fn the_tree_finds_the_shape_and_hit_that_testing_each_in_turn_finds() {
        let kinds = [ShapeKind::Sphere, ShapeKind::Disk, ShapeKind::Cylinder];
        let fields = [
            DMat4::IDENTITY,
            // Small and far from the origin: the f32 tree's rounding is
            // coarse next to the shapes.
            DMat4::from_translation(DVec3::new(1e4, -3e3, 50.0))
                * DMat4::from_scale(DVec3::splat(1e-2)),
        ];
        for world_from_field in fields {
            let mut scene = scattered_shapes(400, &kinds, 3);
            for shape in &mut scene.shapes {
                shape.world_from_shape = world_from_field * shape.world_from_shape;
            }
            // Twins: a shape twice is hit twice at the same t, and the
            // first is seen.
            let twinned = [3, 4, 5, 200];
            for k in twinned {
                scene.shapes.push(scene.shapes[k].clone());
            }
            let exact = ExactShapes::new(&scene);
            let tree = exact.tree.as_ref().expect("a tree over 404 shapes");
            let rays = rays_of_every_kind(&exact, world_from_field);
            let (mut hits, mut twins_hit) = (0, 0);
            for &(origin, dir, tmin, tmax) in &rays {
                let expected = nearest_in_turn(&exact.shapes, origin, dir, tmin, tmax);
                let found = tree.nearest(&exact.shapes, origin, dir, tmin, tmax);
                assert_eq!(found, expected, "{origin} {dir} ({tmin}, {tmax})");
                hits += usize::from(found.is_some());
                twins_hit += usize::from(found.is_some_and(|(k, _)| twinned.contains(&k)));
            }
            assert!(hits > rays.len() / 5, "{hits} hits of {} rays", rays.len());
            assert!(twins_hit > 10, "{twins_hit}");
        }
    }

    #[test]
    fn a_few_shapes_are_tested_in_turn_and_many_through_the_tree() {
        let kinds = [ShapeKind::Sphere];
        for count in [0, 1, TREE_FROM - 1, TREE_FROM] {
            let exact = ExactShapes::new(&scattered_shapes(count, &kinds, 5));
            assert_eq!(exact.tree.is_some(), count >= TREE_FROM, "{count}");
        }
    }

    #[test]
    fn roots_are_ordered_and_stable() {
        assert_eq!(quadratic_roots(1.0, 0.0, -4.0), [Some(-2.0), Some(2.0)]);
        assert_eq!(quadratic_roots(1.0, 0.0, 4.0), [None, None]);
        assert_eq!(quadratic_roots(0.0, 1.0, 1.0), [None, None]);
        // t² − 2e8·t + 1: the small root 5e-9 without cancellation.
        let [small, large] = quadratic_roots(1.0, -1e8, 1.0);
        assert!((small.unwrap() - 5e-9).abs() < 1e-22 && (large.unwrap() - 2e8).abs() < 1e-6);
    }
}
