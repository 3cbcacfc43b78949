//! The scene as triangles for ray queries: every surface becomes one or two
//! triangles in the [`Occluder`], and each primitive remembers its surface.
//!
//! It also knows where surfaces meet (within the
//! [contact distance](Occluder::contact_distance)):
//! * Two surfaces facing the same way in one plane overlap: a wall inside a
//!   wall, the inner side of a `twosided` box's base on the floor it rests
//!   on. Where they overlap only one can be seen, the one of lower index, as
//!   ray queries report it; the other is covered there
//!   ([`SceneTracer::is_covered`]), buried like a floor under a box, and
//!   exchanges no light.
//! * A surface meeting another along a line through its interior (a box's
//!   side standing on the floor, or reaching through it) divides it into
//!   parts that light reaches separately ([`SceneTracer::is_crossed`]); an
//!   element of the floor astride that line averages the light of both.

use crate::geometry::analytic::{ExactShapes, SeenHit};
use crate::geometry::visibility::{Hit, Occluder};
use crate::scene::{Patch, Scene};
use glam::DVec3;
use std::collections::BTreeMap;

/// Ray-tracing view of a scene's surfaces.
#[derive(Debug)]
pub struct SceneTracer {
    /// Acceleration structure over all surfaces' triangles.
    pub occluder: Occluder,
    prim_surface: Vec<u32>,
    /// Where other surfaces meet each surface, for the few that any does.
    contacts: BTreeMap<u32, Contacts>,
    /// The curved shapes as they are, for camera rays.
    exact: ExactShapes,
    /// Area of the largest surface.
    largest_area: f64,
}

/// Where other surfaces meet one surface.
#[derive(Debug, Default)]
struct Contacts {
    /// The surfaces lying in its plane (facing either way: the other side
    /// of a `twosided` surface is one), in order.
    coplanar: Vec<u32>,
    /// The coplanar surfaces of lower index facing the same way that
    /// overlap it.
    covering: Vec<Patch>,
    /// The segments along which other surfaces meet it through its
    /// interior (their sections by its plane).
    crossing: Vec<[DVec3; 2]>,
}

/// A ray hitting a surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceHit {
    /// Index of the surface hit.
    pub surface: u32,
    /// Hit point.
    pub position: DVec3,
    /// Distance along the (unit) ray direction.
    pub distance: f64,
}

impl SceneTracer {
    /// Triangulate the scene's surfaces and build the acceleration structure.
    pub fn new(scene: &Scene) -> Self {
        let mut triangles = Vec::with_capacity(2 * scene.surfaces.len());
        let mut prim_surface = Vec::with_capacity(2 * scene.surfaces.len());
        for (i, s) in scene.surfaces.iter().enumerate() {
            for triangle in s.patch.triangles() {
                triangles.push(triangle);
                prim_surface.push(i as u32);
            }
        }
        let occluder = Occluder::new(&triangles);
        let contacts = contacts(scene, &occluder, &prim_surface);
        SceneTracer {
            occluder,
            prim_surface,
            contacts,
            exact: ExactShapes::new(scene),
            largest_area: (scene.surfaces.iter())
                .map(|s| s.patch.area())
                .fold(0.0, f64::max),
        }
    }

    /// Area of the scene's largest surface, found once: the scale element
    /// levels count against (the kernel context's `deepest_level`).
    pub fn largest_area(&self) -> f64 {
        self.largest_area
    }

    /// True when the point `x` of surface `surface` lies under a coplanar
    /// surface of lower index facing the same way: that one is seen there,
    /// and `x` is covered.
    pub fn is_covered(&self, surface: u32, x: DVec3) -> bool {
        self.contacts
            .get(&surface)
            .is_some_and(|c| c.covering.iter().any(|p| p.contains_param(p.param_of(x))))
    }

    /// The surfaces lying in the plane of surface `surface` (within the
    /// contact distance), facing either way: a segment leaving it towards
    /// a surface in front of it cannot cross them.
    pub fn coplanar(&self, surface: u32) -> &[u32] {
        self.contacts.get(&surface).map_or(&[], |c| &c.coplanar[..])
    }

    /// True when another surface meets `element`, a part of surface
    /// `surface`, along a line through its interior.
    pub fn is_crossed(&self, surface: u32, element: &Patch) -> bool {
        let contact = self.occluder.contact_distance();
        let (normal, vertices) = (element.normal(), element.vertices());
        self.contacts.get(&surface).is_some_and(|c| {
            c.crossing
                .iter()
                .any(|segment| cuts(segment, &vertices, normal, contact))
        })
    }

    /// Surface that primitive `prim` belongs to.
    pub fn surface_of(&self, prim: u32) -> u32 {
        self.prim_surface[prim as usize]
    }

    /// What a camera ray `origin + t·dir` (dir unit length), t ∈ (tmin,
    /// tmax), sees first: the curved shapes as they are, not their
    /// tessellation ([`crate::geometry::analytic`]), and every other surface
    /// as [`SceneTracer::trace`] finds it.
    pub fn trace_seen(&self, origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> Option<SeenHit> {
        if self.exact.is_empty() {
            return self.trace(origin, dir, tmin, tmax).map(SeenHit::Surface);
        }
        let surface_of = |prim: u32| self.surface_of(prim);
        (self.exact).trace(&self.occluder, surface_of, (origin, dir), (tmin, tmax))
    }

    /// Closest surface along `origin + t·dir` (dir unit length), t ∈ (tmin,
    /// tmax); of surfaces in contact, the one facing the ray, then the one
    /// of lower index ([`Occluder::intersect`]).
    pub fn trace(&self, origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> Option<SurfaceHit> {
        self.trace_through(origin, dir, (tmin, tmax), |_| false)
    }

    /// [`SceneTracer::trace`] through the surfaces `passes` says a ray
    /// passes (those of a curved shape it leaves from the exact shape's
    /// convex side).
    pub fn trace_through(
        &self,
        origin: DVec3,
        dir: DVec3,
        (tmin, tmax): (f64, f64),
        passes: impl Fn(u32) -> bool,
    ) -> Option<SurfaceHit> {
        self.occluder
            .intersect_except(origin, dir, tmin, tmax, |prim| {
                passes(self.surface_of(prim))
            })
            .map(|Hit { t, primitive, .. }| SurfaceHit {
                surface: self.surface_of(primitive),
                position: origin + t * dir,
                distance: t,
            })
    }
}

/// Where the other surfaces of `scene` meet each of its surfaces, found
/// among those whose boxes meet its own; surfaces that none meets are left
/// out.
fn contacts(scene: &Scene, occluder: &Occluder, prim_surface: &[u32]) -> BTreeMap<u32, Contacts> {
    let contact = occluder.contact_distance();
    let mut out = BTreeMap::new();
    for (s, surface) in scene.surfaces.iter().enumerate() {
        let patch = &surface.patch;
        let (normal, vertices) = (patch.normal(), patch.vertices());
        let (lo, hi) = vertices.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), v| (lo.min(*v), hi.max(*v)),
        );
        let pad = DVec3::splat(contact);
        let mut near: Vec<u32> = occluder
            .near_box(lo - pad, hi + pad)
            .into_iter()
            .map(|prim| prim_surface[prim as usize])
            .filter(|&r| r as usize != s)
            .collect();
        near.sort_unstable();
        near.dedup();
        let mut found = Contacts::default();
        for r in near {
            let other = &scene.surfaces[r as usize].patch;
            let others = other.vertices();
            let heights: Vec<f64> = others
                .iter()
                .map(|v| normal.dot(*v - vertices[0]))
                .map(|h| if h.abs() <= contact { 0.0 } else { h })
                .collect();
            if heights.iter().all(|&h| h == 0.0) {
                found.coplanar.push(r);
                if (r as usize) < s
                    && other.normal().dot(normal) > 0.0
                    && overlap(&vertices, &others, normal, contact)
                {
                    found.covering.push(*other);
                }
            } else if let Some(segment) = section(&others, &heights) {
                if cuts(&segment, &vertices, normal, contact) {
                    found.crossing.push(segment);
                }
            }
        }
        if !found.coplanar.is_empty() || !found.crossing.is_empty() {
            out.insert(s as u32, found);
        }
    }
    out
}

/// The section of the convex polygon `vertices` by a plane, given the
/// vertices' `heights` above it (zero within the contact distance): the
/// segment between its two extreme points, when it is one.
fn section(vertices: &[DVec3], heights: &[f64]) -> Option<[DVec3; 2]> {
    let n = vertices.len();
    let mut points = Vec::new();
    for i in 0..n {
        let (j, hi, hj) = ((i + 1) % n, heights[i], heights[(i + 1) % n]);
        if hi == 0.0 {
            points.push(vertices[i]);
        } else if hi * hj < 0.0 {
            points.push(vertices[i] + (vertices[j] - vertices[i]) * (hi / (hi - hj)));
        }
    }
    let first = *points.first()?;
    let far = |from: DVec3| {
        points.iter().copied().max_by(|p, q| {
            p.distance_squared(from)
                .total_cmp(&q.distance_squared(from))
        })
    };
    let a = far(first)?;
    let b = far(a)?;
    (a != b).then_some([a, b])
}

/// True when `segment` passes through the interior of the convex polygon
/// `polygon` (counter-clockwise about its unit normal `normal`, the segment
/// in its plane): its part inside (clipped against each edge, Cyrus & Beck
/// 1978) is longer than `margin` and its midpoint is farther than `margin`
/// from every edge. A segment along the polygon's edge does not.
fn cuts(segment: &[DVec3; 2], polygon: &[DVec3], normal: DVec3, margin: f64) -> bool {
    let [p, q] = *segment;
    let (d, length) = ((q - p).normalize_or_zero(), p.distance(q));
    // Inward normals of the edges, with their first vertices.
    let sides: Vec<(DVec3, DVec3)> = polygon
        .iter()
        .zip(edges(polygon))
        .map(|(v, e)| (normal.cross(e).normalize_or_zero(), *v))
        .collect();
    let (mut t0, mut t1) = (0.0f64, length);
    for &(m, v) in &sides {
        let (h, slope) = (m.dot(p - v), m.dot(d));
        if slope.abs() < 1e-15 {
            if h < 0.0 {
                return false;
            }
        } else if slope > 0.0 {
            t0 = t0.max(-h / slope);
        } else {
            t1 = t1.min(-h / slope);
        }
    }
    let mid = p + d * (0.5 * (t0 + t1));
    t1 - t0 > margin && sides.iter().all(|&(m, v)| m.dot(mid - v) > margin)
}

/// True when the convex polygons `a` and `b`, lying in one plane of unit
/// normal `normal`, overlap by more than `contact` across every edge of
/// either (separating axes): polygons that only touch along an edge, as
/// neighbouring triangles of a mesh do, do not.
fn overlap(a: &[DVec3], b: &[DVec3], normal: DVec3, contact: f64) -> bool {
    edges(a).chain(edges(b)).all(|e| {
        let axis = normal.cross(e).normalize_or_zero();
        let ((a0, a1), (b0, b1)) = (span(a, axis), span(b, axis));
        a1.min(b1) - a0.max(b0) > contact
    })
}

/// The extent of `points` along `axis`.
fn span(points: &[DVec3], axis: DVec3) -> (f64, f64) {
    points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(axis.dot(*v)), hi.max(axis.dot(*v)))
        })
}

/// The edge vectors of the polygon `poly`, in order.
fn edges(poly: &[DVec3]) -> impl Iterator<Item = DVec3> + '_ {
    let n = poly.len();
    (0..n).map(move |i| poly[(i + 1) % n] - poly[i])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{grey, inward_box};

    /// The square [x0, x0 + side] × [y0, y0 + side] at height z, facing up
    /// or down.
    fn square(x0: f64, y0: f64, z: f64, side: f64, up: bool) -> Patch {
        let p = Patch::Parallelogram {
            origin: DVec3::new(x0, y0, z),
            edge_s: DVec3::X * side,
            edge_t: DVec3::Y * side,
        };
        if up {
            p
        } else {
            p.flipped()
        }
    }

    #[test]
    fn a_coincident_surface_facing_the_same_way_covers_the_later_one() {
        // A 2×2 floor (0); on it a unit square facing up (1), one facing
        // down (2), one 1e-9 above it facing up (3); and a square beside
        // the floor, touching it along its edge (4).
        let scene = Scene::from_surfaces(
            [
                square(0.0, 0.0, 0.0, 2.0, true),
                square(0.5, 0.5, 0.0, 1.0, true),
                square(0.5, 0.5, 0.0, 1.0, false),
                square(0.5, 0.5, 1e-9, 1.0, true),
                square(2.0, 0.0, 0.0, 2.0, true),
            ]
            .map(grey)
            .to_vec(),
        );
        let tracer = SceneTracer::new(&scene);
        let (inside, outside) = (DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.2, 1.0, 0.0));
        assert!(!tracer.is_covered(0, inside) && !tracer.is_covered(0, outside));
        assert!(tracer.is_covered(1, inside) && tracer.is_covered(3, inside));
        assert!(!tracer.is_covered(2, inside), "it faces the other way");
        assert!(
            !tracer.is_covered(4, DVec3::new(2.0, 1.0, 0.0)),
            "it only touches"
        );
        // All lie in one plane, whichever way they face.
        assert_eq!(tracer.coplanar(2), &[0, 1, 3, 4]);
        // What a ray arriving from above sees is what covers the others.
        let hit = tracer.trace(inside + DVec3::Z, -DVec3::Z, 0.0, f64::INFINITY);
        assert_eq!(hit.map(|h| h.surface), Some(0));
        let hit = tracer.trace(inside - DVec3::Z, DVec3::Z, 0.0, f64::INFINITY);
        assert_eq!(hit.map(|h| h.surface), Some(2));
    }

    #[test]
    fn a_box_standing_on_a_floor_crosses_the_floor_along_its_base() {
        // A 2×2 floor and a unit cube's faces on [0.5, 1.5]², pointing out,
        // standing on it (`lift` 0) or reaching 0.1 through it.
        for lift in [0.0, -0.1] {
            let floor = square(0.0, 0.0, 0.0, 2.0, true);
            let cube = inward_box(DVec3::new(0.5, 0.5, lift), DVec3::new(1.5, 1.5, 1.0));
            let mut surfaces = vec![grey(floor)];
            surfaces.extend(cube.iter().map(|f| grey(f.flipped())));
            let scene = Scene::from_surfaces(surfaces);
            let tracer = SceneTracer::new(&scene);
            let crossed = |s: u32, p: Patch| tracer.is_crossed(s, &p);
            // Elements of the floor across the base, wholly under it,
            // wholly beside it.
            assert!(crossed(0, square(0.25, 0.25, 0.0, 0.5, true)));
            assert!(crossed(0, square(1.25, 0.8, 0.0, 0.5, true)));
            assert!(!crossed(0, square(0.7, 0.7, 0.0, 0.5, true)));
            assert!(!crossed(0, square(0.0, 0.0, 0.0, 0.4, true)));
            // A side (y = 0.5, facing −y) is crossed by the floor only
            // when it reaches through it.
            let side = scene.surfaces[3].patch;
            assert!(side.normal().dot(-DVec3::Y) > 0.99);
            let low = Patch::Parallelogram {
                origin: DVec3::new(0.75, 0.5, lift),
                edge_s: DVec3::X * 0.5,
                edge_t: DVec3::Z * 0.3,
            };
            assert_eq!(crossed(3, low), lift < 0.0, "{lift}");
        }
    }
}
