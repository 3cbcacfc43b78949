//! The exposed part of an element: the points of a surface that can exchange
//! light at all, as opposed to those buried under a box resting on it, inside
//! a closed solid, behind a coincident one-sided surface, or outside the
//! scene's walls (a box's sides reaching through the floor).
//!
//! A floor element straddling the base of a box has a buried part whose
//! radiance no path can reach or leave. Its links already carry that through
//! visibility: the throughput T(a,c) of DESIGN.md §1 is zero over the buried
//! part. Dividing T by the whole area |a| then averages radiance over a
//! region of which part is dark by construction, and a link that later
//! *reads* that diluted average darkens its receiver a second time (the
//! occlusion is counted twice; the Cornell box loses ≈0.6 % of its image
//! brightness to this, all of it near the boxes' bases). So radiance is
//! averaged over the exposed part only: a link's form factor is
//! `T(a,c) / (|a| · exposed(a))` and push–pull weighs children by their
//! exposed areas. An element with nothing exposed keeps the plain average:
//! no link reaches it and nothing sees it. Directional radiance of glossy
//! surfaces does the same over element pairs ([`PairExposure`]).

use crate::geometry::hierarchy::{ElementRef, ElementTree};
use crate::kernel::{KernelContext, KernelElement};
use glam::DVec3;
use rayon::prelude::*;
use std::collections::{BTreeMap, BTreeSet};

/// Probe directions, as (tangent, bitangent, normal) weights: the normal and
/// four directions 60° from it.
const PROBES: [(f64, f64, f64); 5] = [
    (0.0, 0.0, 1.0),
    (0.866_025_403_784_438_6, 0.0, 0.5),
    (-0.866_025_403_784_438_6, 0.0, 0.5),
    (0.0, 0.866_025_403_784_438_6, 0.5),
    (0.0, -0.866_025_403_784_438_6, 0.5),
];

/// True when the point `x` of surface `surface` (front normal `normal`) is
/// buried: no probe ray from it meets the front of another surface, and
/// some meet the back of one (it is inside a closed solid, under a
/// one-sided surface, or outside the scene's walls: the part of a box's side
/// reaching through the floor) or one within the contact distance of it (a
/// face pressed against it, [`KernelContext::contact_distance`]); or a
/// coincident surface facing the same way covers it
/// ([`SceneTracer::is_covered`](crate::geometry::tracing::SceneTracer::is_covered)). A point
/// whose probes all leave the scene is exposed: it may still see an
/// emitter the probes miss.
pub fn is_buried(ctx: &KernelContext, surface: u32, x: DVec3, normal: DVec3) -> bool {
    if ctx.tracer.is_covered(surface, x) {
        return true;
    }
    let (t, b) = tangents(normal);
    let coincident = ctx.contact_distance();
    let mut covered = false;
    for &(u, v, w) in &PROBES {
        let dir = (u * t + v * b + w * normal).normalize();
        match ctx.tracer.trace(x, dir, coincident * 1e-3, f64::INFINITY) {
            None => {}
            Some(hit) if hit.surface == surface => return false,
            Some(hit) => {
                let facing = ctx.scene.surfaces[hit.surface as usize]
                    .patch
                    .normal()
                    .dot(dir);
                if hit.distance > coincident && facing <= 0.0 {
                    return false;
                }
                covered = true;
            }
        }
    }
    covered
}

/// Exposed fraction of every node of `tree`, the element tree of `surface`,
/// as the kernel quadrature of `ctx` sees it: the weight of the node's
/// own Gauss points (those a link's throughput T samples the element at,
/// [`KernelContext::throughput_samples`]) that are not [`is_buried`]. A link
/// at the node divides T by exactly the part of the element its quadrature
/// found exposed. `previous`, an earlier tree of the same surface with its
/// fractions, lends the values of the nodes the two share.
pub fn exposed_fractions(
    ctx: &KernelContext,
    surface: u32,
    tree: &ElementTree,
    previous: Option<(&ElementTree, &[f64])>,
) -> Vec<f64> {
    tree.nodes
        .iter()
        .map(|node| {
            let lent = previous.and_then(|(t, v)| Some(v[t.index_of(node.id)? as usize]));
            lent.unwrap_or_else(|| {
                let element = KernelElement {
                    patch: &node.patch,
                    surface,
                };
                fraction(ctx, element)
            })
        })
        .collect()
}

/// Exposed fraction of `element` at the Gauss points of the quadrature of
/// `ctx`.
fn fraction(ctx: &KernelContext, element: KernelElement) -> f64 {
    let surface = element.surface;
    let normal = ctx.scene.surfaces[surface as usize].patch.normal();
    let points = element.patch.gauss_points(ctx.quadrature.points);
    let total: f64 = points.iter().map(|p| p.weight).sum();
    let exposed: f64 = points
        .iter()
        .filter(|p| !is_buried(ctx, surface, p.position, normal))
        .map(|p| p.weight)
        .sum();
    exposed / total
}

/// True when `element` straddles the boundary of the exposed part and some
/// of its Gauss points (of the quadrature of `ctx`) are buried:
/// points of a 4×4 grid over it, reaching to 1 % of its edges, are buried
/// and exposed, and not all the Gauss points are exposed. Such an element
/// straddles the base of a box: when its exposed part is a strip narrower
/// than the points' inset (0.21 of the element), all of them are buried and
/// the strip, the floor right against the box, would be lost to its links
/// and to its exposed fraction alike; when the boundary runs between its
/// points, its links average light over the few exposed ones. An element
/// whose Gauss points are all exposed, the buried part a strip along its
/// edge (a box's side reaching through the floor), is not refined for it:
/// its form factors are right for its exposed part.
///
/// Also true when another surface meets `element` along a line through its
/// interior ([`SceneTracer::is_crossed`](crate::geometry::tracing::SceneTracer::is_crossed))
/// and every point of the grid is exposed: the parts on either side are
/// separate spaces that light reaches separately (the room and the inside
/// of a `twosided` box standing on the floor, or the space below a
/// `twosided` floor that a box reaches into), and the element would average
/// the light of both.
pub fn straddles(ctx: &KernelContext, element: KernelElement) -> bool {
    const AT: [f64; 4] = [0.01, 1.0 / 3.0, 2.0 / 3.0, 0.99];
    let (surface, element) = (element.surface, element.patch);
    let normal = ctx.scene.surfaces[surface as usize].patch.normal();
    let buried = |x: DVec3| is_buried(ctx, surface, x, normal);
    // The Gauss points first: most elements have none buried.
    let gauss_buried = element
        .gauss_points(ctx.quadrature.points)
        .iter()
        .any(|p| buried(p.position));
    if !gauss_buried && !ctx.tracer.is_crossed(surface, element) {
        return false;
    }
    let mut seen = [false; 2];
    for k in 0..16 {
        let uv = glam::DVec2::new(AT[k % 4], AT[k / 4]);
        seen[usize::from(buried(element.point_at(element.square_to_param(uv))))] = true;
        if seen == [true; 2] {
            return gauss_buried;
        }
    }
    !gauss_buried && !seen[1]
}

/// Exposed fractions of the elements of the directional structures' pairs,
/// for the three-point links of glossy surfaces: a pair (a, b) averages
/// radiance over exposed points of both a and b.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PairExposure {
    of: BTreeMap<ElementRef, f64>,
}

impl PairExposure {
    /// The exposed fraction of every element of `pairs`, each pair the
    /// sending and the receiving element.
    pub fn new(ctx: &KernelContext, pairs: impl Iterator<Item = [ElementRef; 2]>) -> PairExposure {
        let wanted: BTreeSet<ElementRef> = pairs
            .flatten()
            .filter(|e| (e.surface as usize) < ctx.scene.surfaces.len())
            .collect();
        let of = wanted
            .into_par_iter()
            .map(|e| {
                let patch = e.id.patch(&ctx.scene.surfaces[e.surface as usize].patch);
                let element = KernelElement {
                    patch: &patch,
                    surface: e.surface,
                };
                (e, fraction(ctx, element))
            })
            .collect();
        PairExposure { of }
    }

    /// Exposed fraction of the pair (a, b): the product of the two (1 for
    /// an element not listed, such as a hypothetical receiver's).
    pub fn of(&self, a: ElementRef, b: ElementRef) -> f64 {
        let get = |key| self.of.get(&key).copied().unwrap_or(1.0);
        get(a) * get(b)
    }
}

/// Two unit vectors completing `n` to an orthonormal basis.
fn tangents(n: DVec3) -> (DVec3, DVec3) {
    let t = n.any_orthonormal_vector();
    (t, n.cross(t))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::hierarchy::ElementId;
    use crate::geometry::tracing::SceneTracer;
    use crate::kernel::default_context as context;
    use crate::scene::{Patch, Scene};
    use crate::testing::{grey, inward_box};
    use std::collections::BTreeSet;

    /// A 2×2 floor with a unit cube resting on [0.5, 1.5]², its faces
    /// pointing out (the bottom one down onto the floor).
    fn floor_with_a_box() -> Scene {
        let floor = Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X * 2.0,
            edge_t: DVec3::Y * 2.0,
        };
        let cube = inward_box(DVec3::new(0.5, 0.5, 0.0), DVec3::new(1.5, 1.5, 1.0));
        let mut surfaces = vec![grey(floor)];
        surfaces.extend(cube.iter().map(|f| grey(f.flipped())));
        Scene::from_surfaces(surfaces)
    }

    #[test]
    fn an_element_with_a_thin_exposed_strip_straddles_the_box() {
        let scene = floor_with_a_box();
        let tracer = SceneTracer::new(&scene);
        let ctx = context(&scene, &tracer);
        let square = |x0: f64, y0: f64, side: f64| Patch::Parallelogram {
            origin: DVec3::new(x0, y0, 0.0),
            edge_s: DVec3::X * side,
            edge_t: DVec3::Y * side,
        };
        // [0.45, 0.95]²: exposed only in strips 0.05 wide along the box's
        // base, narrower than its 2×2 Gauss points' inset (0.21 · 0.5), all
        // of which are buried.
        let thin = square(0.45, 0.45, 0.5);
        let gauss_buried = thin
            .gauss_points(2)
            .iter()
            .all(|p| is_buried(&ctx, 0, p.position, DVec3::Z));
        assert!(gauss_buried);
        let floor_straddles = |patch: Patch| {
            let element = KernelElement {
                patch: &patch,
                surface: 0,
            };
            straddles(&ctx, element)
        };
        assert!(floor_straddles(thin));
        // Half under it, with Gauss points on both sides, too.
        assert!(floor_straddles(square(0.25, 0.25, 0.5)));
        // Wholly under the box, wholly beside it: neither. Under it along
        // one edge only, its Gauss points all beside it: its exposed points
        // stand for it.
        assert!(!floor_straddles(square(0.7, 0.7, 0.5)));
        assert!(!floor_straddles(square(1.55, 0.0, 0.4)));
        assert!(!floor_straddles(square(0.0, 0.0, 0.51)));
    }

    #[test]
    fn the_floor_under_a_box_is_buried_and_the_rest_exposed() {
        let scene = floor_with_a_box();
        let tracer = SceneTracer::new(&scene);
        let ctx = context(&scene, &tracer);
        let up = DVec3::Z;
        for (x, buried) in [
            (DVec3::new(1.0, 1.0, 0.0), true),
            (DVec3::new(0.55, 1.45, 0.0), true),
            (DVec3::new(0.45, 1.0, 0.0), false),
            (DVec3::new(1.9, 0.1, 0.0), false),
        ] {
            assert_eq!(is_buried(&ctx, 0, x, up), buried, "{x}");
        }
        // The cube's top is exposed; its bottom lies on the floor.
        let top = scene.surfaces[2].patch;
        assert!(!is_buried(&ctx, 2, top.centroid(), top.normal()));
    }

    #[test]
    fn a_side_reaching_through_the_floor_is_buried_below_it() {
        // The same cube sunk 0.1 into the floor: below the floor its sides
        // meet the floor's back and the empty space under the scene.
        let floor = Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X * 2.0,
            edge_t: DVec3::Y * 2.0,
        };
        let cube = inward_box(DVec3::new(0.5, 0.5, -0.1), DVec3::new(1.5, 1.5, 1.0));
        let mut surfaces = vec![grey(floor)];
        surfaces.extend(cube.iter().map(|f| grey(f.flipped())));
        let scene = Scene::from_surfaces(surfaces);
        let tracer = SceneTracer::new(&scene);
        let ctx = context(&scene, &tracer);
        let side = 3; // y = 0.5, facing −y
        let normal = scene.surfaces[side].patch.normal();
        assert!(normal.dot(-DVec3::Y) > 0.99);
        for (z, buried) in [(-0.05, true), (0.05, false), (0.5, false)] {
            let x = DVec3::new(1.0, 0.5, z);
            assert_eq!(is_buried(&ctx, side as u32, x, normal), buried, "{z}");
        }
        // A floor with nothing on it, in the open: exposed.
        let alone = Scene::from_surfaces(vec![grey(floor)]);
        let tracer = SceneTracer::new(&alone);
        let ctx = context(&alone, &tracer);
        assert!(!is_buried(&ctx, 0, DVec3::ONE.with_z(0.0), DVec3::Z));
    }

    #[test]
    fn exposed_fractions_count_the_quadrature_points_outside_the_footprint() {
        let scene = floor_with_a_box();
        let tracer = SceneTracer::new(&scene);
        let ctx = context(&scene, &tracer);
        let root = scene.surfaces[0].patch;
        let ids: BTreeSet<_> = (0..4)
            .flat_map(|k| (0..4).map(move |j| ElementId::ROOT.child(k).child(j)))
            .collect();
        let tree = ElementTree::build(&root, &ids);
        let e = exposed_fractions(&ctx, 0, &tree, None);
        // The root's 2×2 Gauss points (at 0.42 and 1.58) all miss the
        // cube; one of each level-1 quadrant's (at 0.21 and 0.79 in it) is
        // under it.
        assert_eq!(&e[..5], &[1.0, 0.75, 0.75, 0.75, 0.75]);
        // Level 2 (0.5 wide): the four under the cube are buried, the
        // twelve around it exposed.
        let level2: Vec<f64> = (0..tree.nodes.len())
            .filter(|&i| tree.nodes[i].id.level == 2)
            .map(|i| e[i])
            .collect();
        assert_eq!(level2.len(), 16);
        assert_eq!(level2.iter().filter(|&&x| x == 0.0).count(), 4);
        assert_eq!(level2.iter().filter(|&&x| x == 1.0).count(), 12);
        // An earlier tree lends the values of the nodes it shares.
        let coarse = ElementTree::build(&root, &BTreeSet::new());
        let lent = exposed_fractions(&ctx, 0, &tree, Some((&coarse, &[0.5])));
        assert_eq!(lent[0], 0.5);
        assert_eq!(&lent[1..], &e[1..]);
    }
}
