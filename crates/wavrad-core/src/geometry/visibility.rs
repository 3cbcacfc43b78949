//! Visibility: ray and segment queries against the scene's triangles.
//!
//! This module owns the acceleration structure the solver asks "is the
//! segment between these two points blocked?" (the visibility term V of the
//! form factor kernel) and "what does this ray hit first?". It is built once
//! from the scene's triangles and is immutable and `Send + Sync`, so rayon
//! worker threads share one [`Occluder`].
//!
//! The traversal is done by [`obvhs`](https://crates.io/crates/obvhs) (a
//! compressed 8-wide BVH, "CWBVH", built with PLOC + reinsertion, SIMD node
//! tests). It was chosen by measurement among obvhs, `bvh`, `parry3d` and
//! Embree; the numbers, the machine and the command that reproduces them are in
//! `docs/bvh-choice.md` (`cargo run --release --manifest-path
//! benches/bvh-choice/Cargo.toml`).
//!
//! # Precision
//!
//! obvhs works in `f32` and the solver in `f64`. The BVH is used only to *cull*:
//! every box is padded outwards (relative 1e-5 of the scene size) and the `f32`
//! ray is started a little behind the real origin, with its far end pushed a
//! little beyond the real one, so the `f32` traversal never rejects a triangle
//! that the exact test could hit. Each candidate triangle is then tested in
//! `f64` (Möller–Trumbore, edges inclusive so the shared diagonal of a quad
//! does not leak), which alone decides hit/miss, `t`, `u` and `v`. The backing
//! off of the origin also works around obvhs' node test, which ignores boxes
//! closer than 1e-4 along the ray.
//!
//! Occlusion queries stop at the first blocking triangle (any-hit early exit).
//!
//! # Contact
//!
//! Surfaces closer than [`Occluder::contact_distance`] touch: the two sides
//! of a `twosided` surface (two coincident triangles facing opposite ways),
//! a box resting on a floor. A closest-hit query meeting several triangles
//! within that distance of each other reports the one whose front faces the
//! ray, since that is the side the ray arrives at, then the one of lower
//! index; otherwise which of two coincident triangles is reported would
//! depend on rounding and traversal order, and a ray reaching a wall from
//! inside a room could read the wall's outer side.

use crate::scene::enclosed::ray_triangle;
use glam::DVec3;
use obvhs::{aabb::Aabb, cwbvh::CwBvh, ray::Ray, BvhBuildParams};

/// Fraction of a segment excluded at each end by [`Occluder::occluded`] and
/// [`Occluder::occluded_except`]: a hit counts only for `t ∈ (ε, 1 − ε)` where
/// `t` runs from 0 at `from` to 1 at `to`. It keeps a segment that ends on a
/// surface from being blocked by that surface.
pub const SEGMENT_EPSILON: f64 = 1e-6;

/// Relative padding of the `f32` bounding boxes (times the scene's size).
pub(crate) const BOX_PAD: f64 = 1e-5;

/// Contact distance relative to the scene's size
/// ([`Occluder::contact_distance`]): far above the rounding of `f64`
/// coordinates (1e-16), far below any gap a scene models on purpose.
const CONTACT: f64 = 1e-7;

/// A closest hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit, in units of `|dir|` (the point is `origin + t·dir`).
    pub t: f64,
    /// Index of the triangle in the slice given to [`Occluder::new`].
    pub primitive: u32,
    /// Barycentric coordinate along `v1 − v0`.
    pub u: f64,
    /// Barycentric coordinate along `v2 − v0`.
    pub v: f64,
}

/// obvhs' binary BVH, which has no `Debug` of its own.
#[derive(Clone)]
struct BoxTree(obvhs::bvh2::Bvh2);

impl std::fmt::Debug for BoxTree {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "BoxTree({} nodes)", self.0.nodes.len())
    }
}

/// One triangle as the exact test wants it, in BVH order.
#[derive(Debug, Clone, Copy)]
struct Tri {
    v0: DVec3,
    e1: DVec3,
    e2: DVec3,
    id: u32,
}

impl Tri {
    /// Möller–Trumbore in f64. Returns `(t, u, v)`; `None` for a miss or a
    /// ray parallel to the triangle's plane. Edges count as inside.
    #[inline(always)]
    fn intersect(&self, origin: DVec3, dir: DVec3) -> Option<(f64, f64, f64)> {
        ray_triangle(origin, dir, self.v0, self.e1, self.e2)
    }
}

/// Most triangles whose boxes meet a shaft that
/// [`Occluder::clear_between`] tests one by one before it gives up (the
/// answer is then `false`, and rays are traced). Without a bound a shaft
/// across a mesh of a million triangles tested each of them.
pub const SHAFT_TRIANGLES: u32 = 256;

/// Acceleration structure over triangles (built once, immutable, `Send + Sync`
/// so rayon threads can query it).
#[derive(Debug, Clone)]
pub struct Occluder {
    /// `None` for an empty scene.
    bvh: Option<CwBvh>,
    /// Triangles in the order of `bvh.primitive_indices`.
    tris: Vec<Tri>,
    /// A binary BVH over the same boxes, for box queries (obvhs traverses
    /// its wide BVH with rays only), and where each triangle id is in
    /// `tris`.
    boxes: Option<BoxTree>,
    slot_of: Vec<u32>,
    /// How far apart (world units) a triangle and a shaft must be for
    /// [`Occluder::clear_between`] to call them apart: the boxes' padding.
    pad: f64,
    /// How far (world units) the f32 ray starts behind the real origin and
    /// overshoots the real end.
    slack: f64,
    /// Surfaces closer than this (world units) touch.
    contact: f64,
}

impl Occluder {
    /// Builds the BVH over `triangles`. Primitive ids in results are indices
    /// into this slice. Degenerate (zero-area) triangles are kept but never hit.
    pub fn new(triangles: &[[DVec3; 3]]) -> Self {
        if triangles.is_empty() {
            return Occluder {
                bvh: None,
                tris: Vec::new(),
                boxes: None,
                slot_of: Vec::new(),
                pad: 0.0,
                slack: 0.0,
                contact: 0.0,
            };
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for tri in triangles {
            for p in tri {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        let scale = lo
            .abs()
            .max(hi.abs())
            .max_element()
            .max((hi - lo).max_element());
        let pad = BOX_PAD * scale.max(f64::MIN_POSITIVE);
        let aabbs: Vec<Aabb> = triangles
            .iter()
            .map(|[a, b, c]| {
                let mn = a.min(*b).min(*c) - DVec3::splat(pad);
                let mx = a.max(*b).max(*c) + DVec3::splat(pad);
                f32_box(mn, mx)
            })
            .collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh(
            &aabbs,
            BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        let boxes = obvhs::bvh2::builder::build_bvh2(
            &aabbs,
            BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| {
                let [a, b, c] = triangles[i as usize];
                Tri {
                    v0: a,
                    e1: b - a,
                    e2: c - a,
                    id: i,
                }
            })
            .collect();
        let mut slot_of = vec![0; triangles.len()];
        for (slot, &i) in bvh.primitive_indices.iter().enumerate() {
            slot_of[i as usize] = slot as u32;
        }
        Occluder {
            bvh: Some(bvh),
            tris,
            boxes: Some(BoxTree(boxes)),
            slot_of,
            pad,
            slack: cull_slack(pad),
            contact: CONTACT * scale.max(f64::MIN_POSITIVE),
        }
    }

    /// The distance (world units) below which two surfaces touch: 1e-7 of
    /// the scene's size (the larger of its extent and its largest
    /// coordinate). Hits closer together along a ray than this are one
    /// contact, and the side facing the ray is reported
    /// ([`intersect`](Self::intersect)); faces closer than this are pressed
    /// together and exchange no light
    /// ([`crate::kernel::exposure`]).
    pub fn contact_distance(&self) -> f64 {
        self.contact
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True when there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// True if any triangle intersects the open segment from `from` to `to`,
    /// excluding [`SEGMENT_EPSILON`] of its length at both ends (any-hit early
    /// exit).
    pub fn occluded(&self, from: DVec3, to: DVec3) -> bool {
        self.occluded_except(from, to, |_| false)
    }

    /// Same as [`occluded`](Self::occluded) but ignoring hits on primitives
    /// for which `skip(prim)` is true (used to ignore the two surfaces whose
    /// interaction is evaluated).
    pub fn occluded_except(&self, from: DVec3, to: DVec3, skip: impl Fn(u32) -> bool) -> bool {
        let Some(bvh) = &self.bvh else { return false };
        let dir = to - from;
        let Some((ray, _)) = self.cull_ray(from, dir, 1.0) else {
            return false;
        };
        let (t0, t1) = (SEGMENT_EPSILON, 1.0 - SEGMENT_EPSILON);
        !bvh.ray_traverse_miss(ray, |_, slot| {
            let tri = &self.tris[slot];
            match tri.intersect(from, dir) {
                Some((t, _, _)) if t > t0 && t < t1 && !skip(tri.id) => 0.0,
                _ => f32::INFINITY,
            }
        })
    }

    /// True when no triangle that `skip` does not accept meets the shaft
    /// between the convex polygons `a` and `c` (the convex hull of their
    /// corners, which holds every segment from one to the other): then
    /// [`occluded_except`](Self::occluded_except) is false for every such
    /// segment, and its rays need not be traced (shaft culling, Haines &
    /// Wallace 1991). Conservative: the triangles whose boxes meet the
    /// shaft's box must each be kept apart from it along one of a few
    /// separating axes (the polygons' and the triangle's normals, and cross
    /// products of their edges and the line between the polygons' centres),
    /// else the answer is `false`; so is it when more than
    /// [`SHAFT_TRIANGLES`] triangles' boxes meet it. Apart means beyond
    /// both polygons along the axis, by more than the boxes' padding from
    /// one of them and at least touching the other (`beyond_both`): a
    /// mesh's triangle that shares an edge or a corner with `a` touches
    /// the shaft only there, and a segment leaving that corner towards the
    /// other polygon leaves the triangle's side at once.
    pub fn clear_between(&self, a: &[DVec3], c: &[DVec3], skip: impl Fn(u32) -> bool) -> bool {
        let Some(BoxTree(boxes)) = &self.boxes else {
            return true;
        };
        let hull = || a.iter().chain(c);
        let (lo, hi) = hull().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let query = f32_box(lo - DVec3::splat(self.pad), hi + DVec3::splat(self.pad));
        // Two edge directions per polygon (parallelograms have no more;
        // a triangle's third is their difference, covered by the cross
        // products below only in part, which is conservative).
        let edges = [a[1] - a[0], a[2] - a[1], c[1] - c[0], c[2] - c[1]];
        let centre = |poly: &[DVec3]| poly.iter().sum::<DVec3>() / poly.len() as f64;
        let along = centre(c) - centre(a);
        // The shaft's own axes, with the hull's extent along each, once:
        // the polygons' normals, and each edge direction crossed with the
        // lines from the corners of `a` to those of `c` (the hull's sides
        // when the polygons are alike) and between their centres.
        let sides = (0..3).map(|i| c[i.min(c.len() - 1)] - a[i.min(a.len() - 1)]);
        let lines: Vec<DVec3> = std::iter::once(along).chain(sides).collect();
        let spans = |axis: DVec3| [span(a.iter(), axis), span(c.iter(), axis)];
        let shaft_axes: Vec<(DVec3, [(f64, f64); 2])> =
            [edges[0].cross(edges[1]), edges[2].cross(edges[3])]
                .into_iter()
                .chain(lines.iter().flat_map(|l| edges.map(|e| l.cross(e))))
                .map(|axis| (axis, spans(axis)))
                .collect();
        let (pad, touch) = (self.pad, self.pad * TOUCH);
        let (mut clear, mut budget) = (true, SHAFT_TRIANGLES);
        boxes.aabb_traverse(query, |bvh, node| {
            let node = &bvh.nodes[node as usize];
            let first = node.first_index as usize;
            for &i in &bvh.primitive_indices[first..first + node.prim_count as usize] {
                let tri = &self.tris[self.slot_of[i as usize] as usize];
                if skip(tri.id) {
                    continue;
                }
                // A shaft through a fine mesh: tracing its rays is cheaper
                // than proving it clear.
                if budget == 0 {
                    clear = false;
                    return false;
                }
                budget -= 1;
                let corners = [tri.v0, tri.v0 + tri.e1, tri.v0 + tri.e2];
                let apart = |axis: DVec3, polygons: [(f64, f64); 2]| {
                    let length = axis.length();
                    let triangle = span(corners.iter(), axis);
                    beyond_both(triangle, polygons, pad * length, touch * length)
                };
                if shaft_axes.iter().any(|&(axis, h)| apart(axis, h)) {
                    continue;
                }
                let tri_edges = [tri.e1, tri.e2, tri.e2 - tri.e1];
                let mut axes = std::iter::once(tri.e1.cross(tri.e2)).chain(
                    tri_edges.into_iter().flat_map(|f| {
                        [along.cross(f)]
                            .into_iter()
                            .chain(edges.iter().map(move |e| e.cross(f)))
                    }),
                );
                if !axes.any(|axis| apart(axis, spans(axis))) {
                    clear = false;
                    return false;
                }
            }
            true
        });
        clear
    }

    /// The triangles whose bounding boxes meet the box [`lo`, `hi`] (a
    /// superset of those that meet it), in no particular order.
    pub fn near_box(&self, lo: DVec3, hi: DVec3) -> Vec<u32> {
        let Some(BoxTree(boxes)) = &self.boxes else {
            return Vec::new();
        };
        let query = f32_box(lo, hi);
        let mut found = Vec::new();
        boxes.aabb_traverse(query, |bvh, node| {
            let node = &bvh.nodes[node as usize];
            let first = node.first_index as usize;
            found.extend(&bvh.primitive_indices[first..first + node.prim_count as usize]);
            true
        });
        found
    }

    /// Closest hit along `origin + t·dir` with `t ∈ (tmin, tmax)` (open
    /// interval; `tmax` may be `f64::INFINITY`). Of triangles hit within
    /// [`contact_distance`](Self::contact_distance) of each other, one
    /// contact, the one whose front faces the ray wins, then the one of
    /// lower index (the two sides of a `twosided` surface, and one of two
    /// coincident faces facing the same way, as
    /// [`crate::geometry::tracing::SceneTracer::is_covered`] decides).
    pub fn intersect(&self, origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> Option<Hit> {
        self.intersect_except(origin, dir, tmin, tmax, |_| false)
    }

    /// Same as [`intersect`](Self::intersect) but ignoring the primitives
    /// for which `skip(prim)` is true.
    pub fn intersect_except(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: f64,
        skip: impl Fn(u32) -> bool,
    ) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        if tmin.partial_cmp(&tmax) != Some(std::cmp::Ordering::Less) {
            return None;
        }
        let (ray, len) = self.cull_ray(origin, dir, tmax)?;
        // The contact distance in units of the ray parameter.
        let band = self.contact / len;
        let mut best: Option<(Hit, bool)> = None;
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(ray, &mut hit, |_, slot| {
            let tri = &self.tris[slot];
            if skip(tri.id) {
                return f32::INFINITY;
            }
            let Some((t, u, v)) = tri.intersect(origin, dir) else {
                return f32::INFINITY;
            };
            if t <= tmin || t >= tmax {
                return f32::INFINITY;
            }
            let faces = tri.e1.cross(tri.e2).dot(dir) < 0.0;
            let wins = match best {
                None => true,
                Some((b, b_faces)) if (t - b.t).abs() <= band => {
                    (!faces, tri.id) < (!b_faces, b.primitive)
                }
                Some((b, _)) => t < b.t,
            };
            if !wins {
                return f32::INFINITY;
            }
            let found = Hit {
                t,
                primitive: tri.id,
                u,
                v,
            };
            best = Some((found, faces));
            // Shrink the f32 ray conservatively (see `cull_ray`), keeping
            // the triangles in contact with this one.
            self.cull_tmax(t + band, len)
        });
        best.map(|(hit, _)| hit)
    }

    /// The f32 ray that obvhs traverses for `origin + t·dir`, `t ≤ tmax`:
    /// unit direction, started `slack` behind `origin`, and `|dir|`. `None`
    /// for a zero or non-finite direction.
    #[inline(always)]
    fn cull_ray(&self, origin: DVec3, dir: DVec3, tmax: f64) -> Option<(Ray, f64)> {
        let len = dir.length();
        if len <= 0.0 || !len.is_finite() || !origin.is_finite() {
            return None;
        }
        let unit = dir / len;
        let ray = f32_ray(origin - unit * self.slack, unit, self.cull_tmax(tmax, len));
        Some((ray, len))
    }

    /// f32 ray parameter, rounded generously up, for parameter `t` of the
    /// f64 ray of length `len`.
    #[inline(always)]
    fn cull_tmax(&self, t: f64, len: f64) -> f32 {
        cull_distance(t * len, self.slack)
    }
}

/// How far (world units) an f32 culling ray starts behind the real start of
/// the f64 ray it stands for, around boxes padded by `pad`: beyond the
/// padding, and beyond obvhs' node test, which skips boxes closer than 1e-4
/// along the (unit) f32 ray.
pub(crate) fn cull_slack(pad: f64) -> f64 {
    2e-4 + 4.0 * pad
}

/// The f32 ray that obvhs traverses from `start` along the unit vector
/// `unit`, up to parameter `tmax`.
#[inline(always)]
pub(crate) fn f32_ray(start: DVec3, unit: DVec3, tmax: f32) -> Ray {
    // obvhs picks a child box's near and far planes from the sign bit of
    // each direction component but divides by it for the slab distances:
    // a −0.0 component makes the two disagree and the ray misses boxes it
    // lies in. Only the sign of a zero changes here.
    let positive_zero = |x: f64| if x == 0.0 { 0.0 } else { x as f32 };
    Ray::new(
        [start.x as f32, start.y as f32, start.z as f32].into(),
        unit.to_array().map(positive_zero).into(),
        0.0,
        tmax,
    )
}

/// The parameter, rounded generously up, of the f32 ray started `slack`
/// behind the real start ([`cull_slack`]) at which it has passed the point
/// `distance` (world units) along the real ray.
#[inline(always)]
pub(crate) fn cull_distance(distance: f64, slack: f64) -> f32 {
    let d = distance + 2.0 * slack;
    let d = d + d * 1e-5;
    if d.is_finite() && d < f32::MAX as f64 {
        d as f32
    } else {
        f32::INFINITY
    }
}

/// The smallest f32 box holding the box [`lo`, `hi`].
pub(crate) fn f32_box(lo: DVec3, hi: DVec3) -> Aabb {
    Aabb::new(to_f32_down(lo).into(), to_f32_up(hi).into())
}

/// How far, relative to the boxes' padding, a triangle may reach into a
/// shaft where it touches one of the shaft's polygons
/// ([`Occluder::clear_between`]): rounding of coordinates, far below the
/// [`SEGMENT_EPSILON`] part of the padding by which a segment leaving that
/// polygon has left the triangle's side.
const TOUCH: f64 = 1e-7;

/// Whether an interval `triangle` (a triangle's extent along an axis) lies
/// beyond both intervals `polygons` (the extents of a shaft's two polygons)
/// on one side: farther than `apart` from one of them and not reaching
/// more than `touch` into the other. Then no segment from one polygon to
/// the other meets the triangle at a parameter t ∈ (ε, 1 − ε)
/// ([`SEGMENT_EPSILON`]) when `touch < ε · apart`: its extent along the
/// axis stays short of the triangle's by at least ε·apart − touch.
fn beyond_both(triangle: (f64, f64), polygons: [(f64, f64); 2], apart: f64, touch: f64) -> bool {
    let (t0, t1) = triangle;
    let [(a0, a1), (c0, c1)] = polygons;
    let beyond = |ga: f64, gc: f64| ga.min(gc) >= -touch && ga.max(gc) > apart;
    beyond(t0 - a1, t0 - c1) || beyond(a0 - t1, c0 - t1)
}

/// The extent of `points` along `axis` (in units of its length).
fn span<'a>(points: impl Iterator<Item = &'a DVec3>, axis: DVec3) -> (f64, f64) {
    points.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
        let d = p.dot(axis);
        (lo.min(d), hi.max(d))
    })
}

/// Rounds each component to an f32 not above it.
fn to_f32_down(p: DVec3) -> [f32; 3] {
    p.to_array().map(|x| {
        let f = x as f32;
        if (f as f64) > x {
            f.next_down()
        } else {
            f
        }
    })
}

/// Rounds each component to an f32 not below it.
fn to_f32_up(p: DVec3) -> [f32; 3] {
    p.to_array().map(|x| {
        let f = x as f32;
        if (f as f64) < x {
            f.next_up()
        } else {
            f
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles covering the square `z = z0`, x,y ∈ [-1, 1].
    /// Triangle ids: `base`, `base + 1`; `base` has v0 = (-1,-1,z0).
    fn quad(z0: f64) -> [[DVec3; 3]; 2] {
        let a = DVec3::new(-1.0, -1.0, z0);
        let b = DVec3::new(1.0, -1.0, z0);
        let c = DVec3::new(1.0, 1.0, z0);
        let d = DVec3::new(-1.0, 1.0, z0);
        [[a, b, c], [a, c, d]]
    }

    fn assert_send_sync<T: Send + Sync>() {}

    /// A square at height `z`, centred on (`x`, `y`), of half-side `r`.
    fn square(x: f64, y: f64, z: f64, r: f64) -> [DVec3; 4] {
        [(-r, -r), (r, -r), (r, r), (-r, r)].map(|(u, v)| DVec3::new(x + u, y + v, z))
    }

    #[test]
    fn shafts_are_clear_only_when_nothing_can_block_them() {
        // A blocking square at z = 0 (triangles 0, 1), between z = -2 and
        // z = 2, and a small triangle (2) off to the side at z = 1.
        let mut tris = quad(0.0).to_vec();
        tris.push([
            DVec3::new(3.6, 3.6, 1.0),
            DVec3::new(3.9, 3.6, 1.0),
            DVec3::new(3.6, 3.9, 1.0),
        ]);
        let occ = Occluder::new(&tris);
        let none = |_: u32| false;
        // Through the blocker: not clear, unless it is skipped.
        let (low, high) = (square(0.0, 0.0, -2.0, 0.5), square(0.0, 0.0, 2.0, 0.5));
        assert!(!occ.clear_between(&low, &high, none));
        assert!(occ.clear_between(&low, &high, |p| p < 2));
        // Beside the blocker, with the side triangle inside the shaft's
        // box but outside the shaft: clear.
        let (a, c) = (square(2.5, 4.0, 0.5, 0.2), square(4.0, 2.5, 1.5, 0.2));
        assert!(occ.clear_between(&a, &c, none));
        // A shaft that only grazes the blocker's edge is not called clear.
        let (a, c) = (square(1.5, 0.0, -1.0, 0.5), square(1.5, 0.0, 1.0, 0.5));
        assert!(!occ.clear_between(&a, &c, none));
        // Wherever a shaft is called clear, no segment in it is blocked.
        let mut clear = 0;
        for i in 0..200 {
            let r = |k: u64| crate::sampling::hash2(i, k);
            let (p, q) = (r(0), r(1));
            let a = square(4.0 * p.x - 2.0, 4.0 * p.y - 2.0, -1.0 - q.x, 0.3);
            let c = square(4.0 * q.y - 2.0, 4.0 * r(2).x - 2.0, 0.5 + r(2).y, 0.3);
            if !occ.clear_between(&a, &c, none) {
                continue;
            }
            clear += 1;
            for k in 0..16 {
                let (u, v) = (r(10 + k), r(100 + k));
                let x = a[0] + (a[1] - a[0]) * u.x + (a[3] - a[0]) * u.y;
                let y = c[0] + (c[1] - c[0]) * v.x + (c[3] - c[0]) * v.y;
                assert!(!occ.occluded(x, y), "pair {i}, segment {k}");
            }
        }
        assert!(clear > 10, "{clear} clear shafts");
    }

    /// The inside of a hemisphere of radius 1 about the origin, open at
    /// the top (`rows` × `columns` quads, two triangles each), and its
    /// outside: the same triangles wound the other way, as a `twosided`
    /// bowl's two sides are. Inside triangles first.
    fn bowl(rows: usize, columns: usize) -> Vec<[DVec3; 3]> {
        let at = |i: usize, j: usize| {
            let theta = std::f64::consts::FRAC_PI_2 * (1.0 + i as f64 / rows as f64);
            let phi = std::f64::consts::TAU * j as f64 / columns as f64;
            DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            )
        };
        let mut inside = Vec::new();
        for i in 0..rows {
            for j in 0..columns {
                let [p, q, r, s] = [at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)];
                for tri in [[p, q, r], [p, r, s]] {
                    // Skip the slivers at the pole; face the centre.
                    if (tri[1] - tri[0]).cross(tri[2] - tri[0]).length() < 1e-12 {
                        continue;
                    }
                    let [a, b, c] = tri;
                    let faces_in = (b - a).cross(c - a).dot(-(a + b + c)) > 0.0;
                    inside.push(if faces_in { tri } else { [a, c, b] });
                }
            }
        }
        let outside: Vec<[DVec3; 3]> = inside.iter().map(|&[a, b, c]| [a, c, b]).collect();
        [inside, outside].concat()
    }

    #[test]
    fn shafts_inside_a_bowl_are_clear_past_the_triangles_their_ends_touch() {
        // Pairs of a two-sided bowl's inside triangles: nothing can block
        // a segment between them (it runs inside the ball), yet the
        // triangles next to each end touch the shaft along a shared edge
        // or corner. Those shafts are clear; and wherever a shaft is called
        // clear, no segment between the two triangles, from a corner, an
        // edge or the inside, is blocked.
        let tris = bowl(8, 16);
        let n = tris.len() / 2;
        let occ = Occluder::new(&tris);
        let (mut pairs, mut clear) = (0, 0);
        for i in 0..300u64 {
            let r = crate::sampling::hash2(i, 3);
            let (p, q) = ((r.x * n as f64) as usize, (r.y * n as f64) as usize);
            if p == q {
                continue;
            }
            pairs += 1;
            let skip = |t: u32| [p, q, p + n, q + n].contains(&(t as usize));
            if !occ.clear_between(&tris[p], &tris[q], skip) {
                continue;
            }
            clear += 1;
            for k in 0..24 {
                let point = |tri: &[DVec3; 3], salt: u64| {
                    let u = crate::sampling::hash2(i * 1000 + k, salt);
                    // Corners, edge midpoints and inner points alike.
                    let (s, t) = match k % 3 {
                        0 => ((k / 3 % 3) as f64 * 0.5, 0.0),
                        1 => (u.x, 0.0),
                        _ => (u.x, u.y),
                    };
                    let (s, t) = if s + t > 1.0 {
                        (1.0 - s, 1.0 - t)
                    } else {
                        (s, t)
                    };
                    tri[0] + s * (tri[1] - tri[0]) + t * (tri[2] - tri[0])
                };
                let (x, y) = (point(&tris[p], 1), point(&tris[q], 2));
                assert!(
                    !occ.occluded_except(x, y, skip),
                    "pair {p} {q}, segment {k}"
                );
            }
        }
        assert!(
            clear * 2 > pairs,
            "{clear} of {pairs} shafts inside the bowl clear"
        );
    }

    #[test]
    fn a_triangle_beyond_both_polygons_is_apart_only_past_the_one_it_touches() {
        // Along one axis: a triangle's extent, the polygons' extents, and
        // whether the triangle is apart from the shaft between them.
        let (apart, touch) = (1e-5, 1e-12);
        let cases = [
            // Touching a, well clear of c, beyond both (either side).
            ((1.0, 2.0), [(0.0, 1.0), (0.0, 0.5)], true),
            ((-2.0, 0.0), [(0.0, 1.0), (0.5, 1.0)], true),
            // Touching both (a shaft's side that the triangle lies against).
            ((1.0, 2.0), [(0.0, 1.0), (0.2, 1.0)], false),
            // Reaching into one of them.
            ((0.9, 2.0), [(0.0, 1.0), (0.0, 0.5)], false),
            // Between them: beyond each, but on opposite sides.
            ((1.0, 2.0), [(0.0, 0.5), (2.5, 3.0)], false),
            // Clear of both: apart, as without touching.
            ((3.0, 4.0), [(0.0, 1.0), (0.0, 2.0)], true),
        ];
        for (triangle, polygons, want) in cases {
            let got = beyond_both(triangle, polygons, apart, touch);
            assert_eq!(got, want, "{triangle:?} {polygons:?}");
        }
    }

    #[test]
    fn occluder_is_send_and_sync() {
        assert_send_sync::<Occluder>();
    }

    #[test]
    fn quad_occludes_segment() {
        let occ = Occluder::new(&quad(0.0));
        assert_eq!(occ.len(), 2);
        assert!(!occ.is_empty());
        assert!(occ.occluded(DVec3::new(0.2, 0.3, -1.0), DVec3::new(-0.1, 0.1, 1.0)));
        // Through the shared diagonal: must not leak.
        assert!(occ.occluded(DVec3::new(0.5, 0.5, -1.0), DVec3::new(0.5, 0.5, 1.0)));
        // Beside the quad.
        assert!(!occ.occluded(DVec3::new(1.5, 0.0, -1.0), DVec3::new(1.5, 0.0, 1.0)));
        // Segment that stops before the quad.
        assert!(!occ.occluded(DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.0, 0.0, -0.01)));
        // Very short segment right in front of the quad (obvhs' 1e-4 node cut-off).
        assert!(occ.occluded(DVec3::new(0.0, 0.0, -1e-7), DVec3::new(0.0, 0.0, 1e-7)));
        // Parallel to and in the plane of the quad: no hit.
        assert!(!occ.occluded(DVec3::new(-0.5, 0.0, 0.0), DVec3::new(0.5, 0.0, 0.0)));
    }

    #[test]
    fn a_negative_zero_direction_component_hits_like_a_positive_one() {
        // A room with a box in it, probed from a grid of binary-fraction
        // points on the floor (where child boxes' planes lie) along
        // directions with a zero component of either sign.
        let mut tris = Vec::new();
        for (lo, hi) in [
            (DVec3::ZERO, DVec3::splat(2.0)),
            (DVec3::new(0.5, 0.5, 0.0), DVec3::new(1.5, 1.25, 1.0)),
        ] {
            for f in crate::testing::inward_box(lo, hi) {
                let [a, b, c, d] = <[DVec3; 4]>::try_from(f.vertices()).unwrap();
                tris.extend([[a, b, c], [a, c, d]]);
            }
        }
        let occ = Occluder::new(&tris);
        let mut probes = 0;
        for i in 1..16 {
            for j in 1..16 {
                let origin = DVec3::new(f64::from(i) / 8.0, f64::from(j) / 8.0, 0.0);
                for (x, y) in [(0.0, 0.8), (-0.0, 0.8), (0.8, 0.0), (0.8, -0.0)] {
                    let dir = DVec3::new(x, y, 0.6);
                    let flipped = DVec3::new(
                        if x == 0.0 { -x } else { x },
                        if y == 0.0 { -y } else { y },
                        0.6,
                    );
                    let t = |d| {
                        occ.intersect(origin, d, 1e-9, f64::INFINITY)
                            .map(|h| h.primitive)
                    };
                    assert!(
                        t(dir).is_some(),
                        "{origin} {dir}: a closed room always has a hit"
                    );
                    assert_eq!(t(dir), t(flipped), "{origin} {dir}");
                    probes += 1;
                }
            }
        }
        assert_eq!(probes, 15 * 15 * 4);
    }

    #[test]
    fn segment_ending_on_surface_is_not_occluded_by_it() {
        let mut tris = quad(0.0).to_vec();
        tris.extend(quad(2.0));
        let occ = Occluder::new(&tris);
        let on0 = DVec3::new(0.123_456_789, -0.3, 0.0);
        let on2 = DVec3::new(-0.7, 0.4, 2.0);
        assert!(!occ.occluded(on0, on2));
        assert!(!occ.occluded(on2, on0));
        // Oblique, ending at an arbitrary point computed on the plane.
        let p = DVec3::new(-1.0, -1.0, 0.0)
            + 0.3137 * DVec3::new(2.0, 0.0, 0.0)
            + 0.2291 * DVec3::new(0.0, 2.0, 0.0);
        assert!(!occ.occluded(DVec3::new(0.9, 0.8, 1.3), p));
        // ... but a segment crossing the plane is occluded.
        assert!(occ.occluded(DVec3::new(0.1, 0.1, 1.0), DVec3::new(0.1, 0.1, -1.0)));
    }

    #[test]
    fn intersect_returns_nearest_with_t_u_v() {
        let mut tris = quad(3.0).to_vec(); // ids 0, 1 (far)
        tris.extend(quad(1.0)); // ids 2, 3 (near)
        let occ = Occluder::new(&tris);
        // dir of length 2: t in units of |dir|.
        let origin = DVec3::new(0.5, -0.5, 0.0);
        let dir = DVec3::new(0.0, 0.0, 2.0);
        let hit = occ.intersect(origin, dir, 0.0, f64::INFINITY).expect("hit");
        assert_eq!(hit.primitive, 2);
        assert!((hit.t - 0.5).abs() < 1e-12, "{hit:?}");
        // Triangle 2: v0 = (-1,-1,1), e1 = (2,0,0), e2 = (2,2,0);
        // (0.5,-0.5) = v0 + u e1 + v e2 → v = 0.25, u = 0.5.
        assert!((hit.u - 0.5).abs() < 1e-12, "{hit:?}");
        assert!((hit.v - 0.25).abs() < 1e-12, "{hit:?}");
        // tmin past the near quad gives the far one.
        let far = occ
            .intersect(origin, dir, 0.6, f64::INFINITY)
            .expect("far hit");
        assert_eq!(far.primitive, 0);
        assert!((far.t - 1.5).abs() < 1e-12);
        // tmax before the near quad: nothing; tmax is exclusive.
        assert_eq!(occ.intersect(origin, dir, 0.0, 0.4), None);
        assert_eq!(occ.intersect(origin, dir, 0.0, 0.5), None);
        // Backwards: nothing.
        assert_eq!(occ.intersect(origin, -dir, 0.0, f64::INFINITY), None);
    }

    #[test]
    fn of_coincident_triangles_the_ray_sees_the_side_facing_it() {
        // The two sides of a two-sided square at z = 1 (front up, front
        // down: triangulated along the other diagonal, as a flipped
        // parallelogram is), and a square facing up 1e-9 below them, within
        // the contact distance, in several orders. Pairs of ids are squares.
        let up = quad(1.0);
        let down = up.map(|[a, b, c]| [a, c, b]);
        let below = quad(1.0 - 1e-9);
        for (squares, from_below, from_above) in [
            ([up, down, below], 1, 0),
            ([down, up, below], 0, 1),
            ([below, down, up], 1, 0),
        ] {
            let tris = squares.concat();
            let occ = Occluder::new(&tris);
            assert!(occ.contact_distance() > 1e-9 && occ.contact_distance() < 1e-6);
            for k in 0..50 {
                let r = crate::sampling::hash2(k, 7);
                let origin = DVec3::new(1.8 * r.x - 0.9, 1.8 * r.y - 0.9, 0.0);
                let hit = |o: DVec3, d| occ.intersect(o, d, 0.0, f64::INFINITY).unwrap();
                let square = |o, d| hit(o, d).primitive / 2;
                assert_eq!(square(origin, DVec3::Z), from_below, "{origin}");
                let above = origin.with_z(2.0);
                assert_eq!(square(above, -DVec3::Z), from_above, "{above}");
                assert!((hit(above, -DVec3::Z).t - 1.0).abs() < 1e-8);
            }
        }
        // Farther apart than the contact distance, the nearer one is hit.
        let tris = [quad(1.0), quad(1.0 - 1e-3)].concat();
        let occ = Occluder::new(&tris);
        let hit = occ.intersect(DVec3::ZERO, DVec3::Z, 0.0, f64::INFINITY);
        assert_eq!(hit.map(|h| h.primitive / 2), Some(1));
        // Box queries find what lies in the box, and not what is far.
        let near: Vec<u32> = occ.near_box(DVec3::new(0.5, 0.5, 0.99), DVec3::new(0.9, 0.9, 0.9995));
        assert!(near.contains(&2) || near.contains(&3), "{near:?}");
        assert!(occ
            .near_box(DVec3::splat(5.0), DVec3::splat(6.0))
            .is_empty());
    }

    #[test]
    fn skip_ignores_primitives() {
        let mut tris = quad(0.0).to_vec(); // 0, 1
        tris.extend(quad(1.0)); // 2, 3
        let occ = Occluder::new(&tris);
        let (a, b) = (DVec3::new(0.5, -0.5, -1.0), DVec3::new(0.5, -0.5, 2.0));
        assert!(occ.occluded(a, b));
        assert!(occ.occluded_except(a, b, |p| p < 2));
        assert!(occ.occluded_except(a, b, |p| p >= 2));
        assert!(!occ.occluded_except(a, b, |_| true));
        // (0.5,-0.5) is in triangle 0 and triangle 2 only.
        assert!(!occ.occluded_except(a, b, |p| p == 0 || p == 2));
        // Closest hits skip them too: past the nearer quad, the farther.
        let (dir, far) = (b - a, f64::INFINITY);
        assert_eq!(
            occ.intersect(a, dir, 0.0, far).map(|h| h.primitive),
            Some(0)
        );
        let past = occ.intersect_except(a, dir, 0.0, far, |p| p < 2);
        assert_eq!(past.map(|h| h.primitive), Some(2));
        assert_eq!(occ.intersect_except(a, dir, 0.0, far, |p| p % 2 == 0), None);
    }

    #[test]
    fn empty_scene() {
        let occ = Occluder::new(&[]);
        assert!(occ.is_empty());
        assert_eq!(occ.len(), 0);
        assert!(!occ.occluded(DVec3::ZERO, DVec3::ONE));
        assert!(!occ.occluded_except(DVec3::ZERO, DVec3::ONE, |_| false));
        assert_eq!(
            occ.intersect(DVec3::ZERO, DVec3::X, 0.0, f64::INFINITY),
            None
        );
    }

    #[test]
    fn degenerate_queries_do_not_panic() {
        let occ = Occluder::new(&quad(0.0));
        assert!(!occ.occluded(DVec3::ONE, DVec3::ONE));
        assert_eq!(occ.intersect(DVec3::ONE, DVec3::ZERO, 0.0, 1.0), None);
        assert_eq!(
            occ.intersect(DVec3::new(0.0, 0.0, 1.0), -DVec3::Z, 2.0, 1.0),
            None
        );
    }

    #[test]
    fn matches_brute_force_on_random_segments() {
        // A small cluttered scene; compare with testing every triangle.
        let mut rng = 0x1234_5678_9abc_def0_u64;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let tris: Vec<[DVec3; 3]> = (0..200)
            .map(|_| {
                let c = DVec3::new(next(), next(), next());
                [
                    c,
                    c + 0.2 * DVec3::new(next(), next(), next()),
                    c + 0.2 * DVec3::new(next(), next(), next()),
                ]
            })
            .collect();
        let occ = Occluder::new(&tris);
        let brute: Vec<Tri> = tris
            .iter()
            .enumerate()
            .map(|(i, [a, b, c])| Tri {
                v0: *a,
                e1: *b - *a,
                e2: *c - *a,
                id: i as u32,
            })
            .collect();
        for _ in 0..2000 {
            let a = DVec3::new(next(), next(), next()) * 1.2;
            let b = DVec3::new(next(), next(), next()) * 1.2;
            let dir = b - a;
            let want_occ = brute.iter().any(|t| {
                matches!(t.intersect(a, dir), Some((t, _, _)) if t > SEGMENT_EPSILON && t < 1.0 - SEGMENT_EPSILON)
            });
            assert_eq!(occ.occluded(a, b), want_occ);
            let want_hit = brute
                .iter()
                .filter_map(|t| {
                    t.intersect(a, dir)
                        .filter(|h| h.0 > 0.0)
                        .map(|h| (h.0, t.id))
                })
                .min_by(|x, y| x.0.total_cmp(&y.0));
            let got = occ
                .intersect(a, dir, 0.0, f64::INFINITY)
                .map(|h| (h.t, h.primitive));
            assert_eq!(got, want_hit);
        }
    }
}
