//! The inner sides of closed two-sided meshes, which no light reaches.
//!
//! A `twosided` material gives every face two surfaces, one per side. On a
//! closed mesh (every edge shared by exactly two faces, in opposite
//! directions: a watertight, consistently oriented surface) one of them
//! faces the inside, and when nothing else is inside (no other surface, no
//! light), no light ever reaches it: Mitsuba renders it black. Solving it
//! is pure waste, and a large one: the inside faces of a finely tessellated
//! pole all see one another, n² pairs that clustering cannot merge (they are
//! as near as they are small). [`enclosed_sides`] finds those surfaces and
//! [`Scene::without_surfaces`] takes them out.

use crate::scene::{Light, Patch, Scene};
use glam::DVec3;
use std::collections::{HashMap, HashSet};
use std::ops::Range;

/// The surfaces of one two-sided shape: `fronts[k]` and `backs[k]` are the
/// two sides of its face k.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SidedShape {
    /// The surfaces of its faces as the mesh orients them.
    pub fronts: Vec<u32>,
    /// The surfaces of their other sides.
    pub backs: Vec<u32>,
}

/// The surfaces of `scene` that face the inside of a closed shape of
/// `shapes` with nothing inside it: no other surface's centroid, no light
/// with a position. An emitting side is kept (its light stays inside, but
/// it is the scene's). Shapes that are not closed, or whose faces are not
/// consistently oriented, keep both sides. Sorted.
pub fn enclosed_sides(scene: &Scene, shapes: &[SidedShape]) -> Vec<u32> {
    let mut out = Vec::new();
    if shapes.is_empty() {
        return out;
    }
    let points = Points::of(scene);
    for shape in shapes {
        let patches: Vec<Patch> = (shape.fronts.iter())
            .map(|&s| scene.surfaces[s as usize].patch)
            .collect();
        let Some(volume) = closed_volume(&patches) else {
            continue;
        };
        // Fronts pointing outwards enclose a positive volume.
        let inner = if volume > 0.0 {
            &shape.backs
        } else {
            &shape.fronts
        };
        if inner
            .iter()
            .any(|&s| scene.surfaces[s as usize].is_emitter())
            || points.inside_any(shape, &patches)
        {
            continue;
        }
        out.extend_from_slice(inner);
    }
    out.sort_unstable();
    out
}

/// The signed volume the polygons enclose (positive when their normals
/// point out), or `None` unless every edge joins exactly two of them in
/// opposite directions. Corners are matched exactly: a mesh's faces share
/// their vertices bit for bit.
fn closed_volume(patches: &[Patch]) -> Option<f64> {
    if patches.len() < 4 {
        return None;
    }
    let key = |v: DVec3| v.to_array().map(f64::to_bits);
    // Directed edge → how many faces use it.
    let mut edges: HashMap<([u64; 3], [u64; 3]), u32> = HashMap::new();
    let mut volume = 0.0;
    for patch in patches {
        let v = patch.vertices();
        for i in 0..v.len() {
            let (a, b) = (key(v[i]), key(v[(i + 1) % v.len()]));
            if a == b {
                return None;
            }
            *edges.entry((a, b)).or_default() += 1;
        }
        for i in 1..v.len() - 1 {
            volume += v[0].dot(v[i].cross(v[i + 1])) / 6.0;
        }
    }
    let closed = edges
        .iter()
        .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1));
    (closed && volume != 0.0).then_some(volume)
}

/// What may lie inside a closed shape: the lights with a position (no
/// surface) and every surface's centroid (with its surface), by x, so that
/// a shape looks only at those within its box's x-range.
struct Points(Vec<(DVec3, Option<u32>)>);

impl Points {
    fn of(scene: &Scene) -> Points {
        let lights = scene.lights.iter().filter_map(|l| match *l {
            Light::Point { position, .. } | Light::Spot { position, .. } => Some((position, None)),
            _ => None,
        });
        let surfaces = (scene.surfaces.iter().zip(0u32..))
            .map(|(surface, s)| (surface.patch.centroid(), Some(s)));
        let mut points: Vec<_> = lights.chain(surfaces).collect();
        points.sort_unstable_by(|a, b| a.0.x.total_cmp(&b.0.x));
        Points(points)
    }

    /// Whether any point not of `shape` lies inside its closed surface
    /// `patches`.
    fn inside_any(&self, shape: &SidedShape, patches: &[Patch]) -> bool {
        let (lo, hi) = patches.iter().flat_map(Patch::vertices).fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), v| (lo.min(v), hi.max(v)),
        );
        let first = self.0.partition_point(|(p, _)| p.x < lo.x);
        let own: HashSet<u32> = shape.fronts.iter().chain(&shape.backs).copied().collect();
        let own = |s: u32| own.contains(&s);
        self.0[first..]
            .iter()
            .take_while(|(p, _)| p.x <= hi.x)
            .filter(|(p, s)| p.cmpge(lo).all() && p.cmple(hi).all() && !s.is_some_and(own))
            .any(|(p, _)| inside(*p, patches))
    }
}

/// Whether point `p` is inside the closed surface `patches`: a ray from it
/// crosses the surface an odd number of times. The ray's direction is
/// skewed so that it meets no edge of an axis-aligned mesh exactly.
fn inside(p: DVec3, patches: &[Patch]) -> bool {
    let dir = DVec3::new(0.5773, 0.5779, 0.5771).normalize();
    let crossings = patches
        .iter()
        .flat_map(|patch| fan(patch.vertices()))
        .filter(|t| crosses(p, dir, t))
        .count();
    crossings % 2 == 1
}

/// A convex polygon as the triangles of a fan from its first corner.
fn fan(v: Vec<DVec3>) -> impl Iterator<Item = [DVec3; 3]> {
    (1..v.len() - 1).map(move |i| [v[0], v[i], v[i + 1]])
}

/// Whether the ray from `p` along `dir` meets triangle `t` ahead of `p`.
fn crosses(p: DVec3, dir: DVec3, [a, b, c]: &[DVec3; 3]) -> bool {
    ray_triangle(p, dir, *a, *b - *a, *c - *a).is_some_and(|(t, _, _)| t > 0.0)
}

/// Möller–Trumbore in f64 for the triangle at `v0` with edges `e1`, `e2`:
/// `(t, u, v)` of the ray `origin + t·dir`; `None` for a miss or a ray
/// parallel to the triangle's plane. Edges count as inside.
#[inline(always)]
pub(crate) fn ray_triangle(
    origin: DVec3,
    dir: DVec3,
    v0: DVec3,
    e1: DVec3,
    e2: DVec3,
) -> Option<(f64, f64, f64)> {
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - v0;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some((e2.dot(q) * inv, u, v))
}

impl Scene {
    /// The scene without the surfaces `drop` (sorted): the others keep their
    /// order, and the curved shapes' ranges of surfaces follow them.
    pub fn without_surfaces(mut self, drop: &[u32]) -> Scene {
        if drop.is_empty() {
            return self;
        }
        // New index of old index i: i less the dropped surfaces before it.
        let shift = |i: u32| i - drop.partition_point(|&d| d < i) as u32;
        let remap = |r: &Range<u32>| shift(r.start)..shift(r.end);
        for shape in &mut self.shapes {
            shape.surfaces = remap(&shape.surfaces);
        }
        let mut k = 0;
        let mut index = 0u32;
        self.surfaces.retain(|_| {
            let keep = drop.get(k) != Some(&index);
            if !keep {
                k += 1;
            }
            index += 1;
            keep
        });
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Surface;
    use crate::testing::grey;

    /// A unit cube's faces as two triangles each, outward, every corner
    /// shared bit for bit.
    fn cube(at: DVec3, size: f64) -> Vec<Patch> {
        let c = |x: f64, y: f64, z: f64| at + size * DVec3::new(x, y, z);
        let quads = [
            [c(0., 0., 0.), c(0., 1., 0.), c(1., 1., 0.), c(1., 0., 0.)],
            [c(0., 0., 1.), c(1., 0., 1.), c(1., 1., 1.), c(0., 1., 1.)],
            [c(0., 0., 0.), c(1., 0., 0.), c(1., 0., 1.), c(0., 0., 1.)],
            [c(0., 1., 0.), c(0., 1., 1.), c(1., 1., 1.), c(1., 1., 0.)],
            [c(0., 0., 0.), c(0., 0., 1.), c(0., 1., 1.), c(0., 1., 0.)],
            [c(1., 0., 0.), c(1., 1., 0.), c(1., 1., 1.), c(1., 0., 1.)],
        ];
        quads
            .iter()
            .flat_map(|q| {
                [
                    Patch::Triangle([q[0], q[1], q[2]]),
                    Patch::Triangle([q[0], q[2], q[3]]),
                ]
            })
            .collect()
    }

    fn flipped(p: &Patch) -> Patch {
        match *p {
            Patch::Triangle([a, b, c]) => Patch::Triangle([a, c, b]),
            _ => unreachable!("triangles only"),
        }
    }

    /// `patches` as a two-sided shape appended to `surfaces`.
    fn two_sided(surfaces: &mut Vec<Surface>, patches: &[Patch]) -> SidedShape {
        let mut shape = SidedShape::default();
        for p in patches {
            shape.fronts.push(surfaces.len() as u32);
            surfaces.push(grey(*p));
            shape.backs.push(surfaces.len() as u32);
            surfaces.push(grey(flipped(p)));
        }
        shape
    }

    #[test]
    fn an_empty_closed_mesh_loses_its_inner_sides_whichever_way_it_faces() {
        for outward in [true, false] {
            let mut patches = cube(DVec3::ZERO, 1.0);
            if !outward {
                patches = patches.iter().map(flipped).collect();
            }
            let mut surfaces = Vec::new();
            let shape = two_sided(&mut surfaces, &patches);
            let scene = Scene::from_surfaces(surfaces);
            let inner = if outward { &shape.backs } else { &shape.fronts };
            assert_eq!(&enclosed_sides(&scene, std::slice::from_ref(&shape)), inner);
            // Each inner side faces the cube's centre.
            for &s in inner {
                let p = &scene.surfaces[s as usize].patch;
                let to_centre = DVec3::splat(0.5) - p.centroid();
                assert!(p.normal().dot(to_centre) > 0.0);
            }
        }
    }

    #[test]
    fn a_closed_mesh_with_something_inside_or_an_open_one_keeps_both_sides() {
        // A small cube inside a large one: the large one keeps both sides,
        // the small one (empty) loses its inner ones.
        let mut surfaces = Vec::new();
        let outer = two_sided(&mut surfaces, &cube(DVec3::ZERO, 4.0));
        let inner = two_sided(&mut surfaces, &cube(DVec3::ONE, 1.0));
        let scene = Scene::from_surfaces(surfaces.clone());
        assert_eq!(
            enclosed_sides(&scene, &[outer.clone(), inner.clone()]),
            inner.backs
        );
        // A point light inside the small one keeps it too.
        let mut lit = scene.clone();
        lit.lights.push(Light::Point {
            position: DVec3::splat(1.5),
            intensity: crate::scene::Rgb::splat(1.0),
        });
        assert!(enclosed_sides(&lit, &[outer, inner]).is_empty());
        // A cube with one triangle missing is open.
        let mut open = cube(DVec3::ZERO, 1.0);
        open.pop();
        let mut surfaces = Vec::new();
        let shape = two_sided(&mut surfaces, &open);
        assert!(enclosed_sides(&Scene::from_surfaces(surfaces), &[shape]).is_empty());
        // So is one whose faces disagree on their orientation.
        let mut twisted = cube(DVec3::ZERO, 1.0);
        twisted[0] = flipped(&twisted[0]);
        let mut surfaces = Vec::new();
        let shape = two_sided(&mut surfaces, &twisted);
        assert!(enclosed_sides(&Scene::from_surfaces(surfaces), &[shape]).is_empty());
    }

    #[test]
    fn without_surfaces_keeps_the_others_in_order() {
        let mut surfaces = Vec::new();
        two_sided(&mut surfaces, &cube(DVec3::ZERO, 1.0));
        let scene = Scene::from_surfaces(surfaces.clone());
        let kept = scene.without_surfaces(&[0, 5, 23]);
        let expected: Vec<Surface> = (surfaces.into_iter().enumerate())
            .filter(|(i, _)| ![0, 5, 23].contains(i))
            .map(|(_, s)| s)
            .collect();
        assert_eq!(kept.surfaces, expected);
    }
}
