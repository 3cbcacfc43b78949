//! Clusters of surfaces: a binary hierarchy above the surfaces' element
//! trees (Smits, Arvo & Greenberg 1994; Sillion 1995), so that linking can
//! start at the whole scene and let groups of surfaces that are small
//! against their distance exchange light as wholes
//! ([`crate::refine::cluster_links`]).
//!
//! The tree is built top-down by median splits (a bounding-volume
//! hierarchy with one surface per leaf), so it is balanced whatever the
//! scene: depth ⌈log₂ n⌉. A node is split at the median along the longest
//! axis of its members' centroids, or along that of their normals where
//! only that split leaves both halves facing one way (cones of normals
//! narrower than [`NARROW_CONE_COS`]) and they are at most [`TURN_GROWTH`]
//! times as large. So the two sides of a `twosided`
//! mesh, at the same places, part where the mesh is flat within a node
//! instead of pairing up at the leaves, and so do a thin box's top and
//! bottom; surfaces that face many ways part by place. Each node keeps its
//! members' cone of normals and the slab they fill about it, so that links
//! between nodes can bound the cosines between them ([`height_over`]), as
//! Shirman & Abi-Ezzi 1993 cull back faces with such cones.

use crate::scene::{Patch, Scene};
use glam::DVec3;
use std::ops::Range;

/// A node of the cluster tree: a set of surfaces with its bounding sphere.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Cluster {
    /// Centre of its bounding box.
    pub center: DVec3,
    /// Half the bounding box's diagonal: every member lies within this
    /// distance of `center`.
    pub radius: f64,
    /// Area-weighted centroid of its members.
    pub centroid: DVec3,
    /// Total area of its members.
    pub area: f64,
    /// Largest Lambertian reflectance (largest channel) of its members.
    pub reflectance: f64,
    /// Which way its members face, and the slab they fill.
    pub orientation: Orientation,
    /// Its members, a range of [`ClusterTree::members`].
    pub members: Range<u32>,
    /// Its two children; `None` for a leaf (one surface).
    pub children: Option<[u32; 2]>,
    /// Its parent; `None` for the root.
    pub parent: Option<u32>,
}

/// Which way a set of planar surfaces faces and where it lies along that
/// way, about a centre: its cone of normals and the slab its vertices fill.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Orientation {
    /// The members' area-weighted mean normal, unit length (zero when
    /// they cancel).
    pub axis: DVec3,
    /// Cosine of the cone of normals' half angle: the least `axis · n` of
    /// the members' normals n (at most 0 when the cone is a hemisphere or
    /// wider).
    pub spread_cos: f64,
    /// Height of the highest vertex over the plane through the centre
    /// normal to `axis`.
    pub above: f64,
    /// Depth of the lowest vertex under that plane.
    pub below: f64,
}

impl Orientation {
    /// Of one planar patch, about `center`.
    pub fn of_patch(patch: &Patch, center: DVec3) -> Orientation {
        let axis = patch.normal();
        let (above, below) = (patch.vertices().iter()).fold((0.0f64, 0.0f64), |(up, down), &v| {
            let h = axis.dot(v - center);
            (up.max(h), down.max(-h))
        });
        Orientation {
            axis,
            spread_cos: 1.0,
            above,
            below,
        }
    }
}

/// Where a set of planar surfaces lies and faces: its bounding sphere's
/// centre and radius, and its [`Orientation`] about that centre.
pub type Extent<'a> = (DVec3, f64, &'a Orientation);

/// Upper bound on n·(y − x) over every point x of a member of `x` (n that
/// member's normal) and every point y of a member of `y`: the height of
/// `y` over the planes of `x`'s members, so that cosθ_x ≤ this over |y − x|
/// (at most 0: `y` lies wholly behind every member of `x`). With `x`'s
/// members' normals n within its cone about axis a (|n − a| ≤
/// √(2 − 2 cos), the cone's half angle), n·(y − x) = a·(c_y − c_x) +
/// a·(y − c_y) + a·(c_x − x) + (n − a)·(y − x), bounded in turn by `y`'s
/// slab tilted by |a − a_y| over its radius (or its radius), `x`'s depth
/// under its own slab, and the cone's width over the ends' farthest
/// reach. Infinite when `x`'s cone is a hemisphere or wider.
pub fn height_over(x: Extent, y: Extent) -> f64 {
    let ((cx, rx, ox), (cy, ry, oy)) = (x, y);
    if ox.spread_cos <= 0.0 || ox.axis == DVec3::ZERO {
        return f64::INFINITY;
    }
    let a = ox.axis;
    let tilt = (2.0 - 2.0 * ox.spread_cos).max(0.0).sqrt();
    let y_along = ry.min(oy.above + (a - oy.axis).length() * ry);
    a.dot(cy - cx) + y_along + ox.below + tilt * (cx.distance(cy) + rx + ry)
}

/// Cosine of the widest angle a node's normals make with their
/// area-weighted mean, below which a node's normals count as facing many
/// ways: a split by orientation is taken only where it leaves both halves
/// within it and a split by place does not ([`ClusterTree::build`]).
pub const NARROW_CONE_COS: f64 = 0.5;

/// How much larger than a split by place's halves (their larger bounding
/// radius) a split by orientation's may be: the two sides of a flat patch
/// parted by orientation are each as large as the patch, √2 times its
/// halves by place.
pub const TURN_GROWTH: f64 = 2.0;

/// Per surface, its normal, area and bounding box, to choose splits.
struct Shapes {
    normals: Vec<DVec3>,
    areas: Vec<f64>,
    boxes: Vec<(DVec3, DVec3)>,
}

impl Shapes {
    /// The least cosine between the normals of `part` and their
    /// area-weighted mean (its cone of normals' half angle), and half its
    /// bounding box's diagonal.
    fn cone_and_radius(&self, part: &[u32]) -> (f64, f64) {
        let (mut lo, mut hi, mut area_normal) = (DVec3::INFINITY, DVec3::NEG_INFINITY, DVec3::ZERO);
        for &s in part {
            let s = s as usize;
            lo = lo.min(self.boxes[s].0);
            hi = hi.max(self.boxes[s].1);
            area_normal += self.areas[s] * self.normals[s];
        }
        let axis = area_normal.normalize_or_zero();
        let cos = part
            .iter()
            .map(|&s| axis.dot(self.normals[s as usize]))
            .fold(1.0, f64::min);
        (cos, 0.5 * (hi - lo).length())
    }
}

/// The cluster hierarchy of a scene's surfaces; node 0 is the root.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct ClusterTree {
    /// Every cluster, parents before children.
    pub nodes: Vec<Cluster>,
    /// Surface indices in leaf order: each cluster's members are a range.
    pub members: Vec<u32>,
    /// The leaf of every surface.
    pub leaf_of: Vec<u32>,
    /// Running sum of the members' areas (`members.len() + 1` entries), to
    /// pick a member with probability proportional to its area.
    area_prefix: Vec<f64>,
}

impl ClusterTree {
    /// The cluster tree of `scene`'s surfaces (empty for an empty scene).
    pub fn build(scene: &Scene) -> ClusterTree {
        let n = scene.surfaces.len();
        let mut tree = ClusterTree {
            members: (0..n as u32).collect(),
            leaf_of: vec![0; n],
            ..ClusterTree::default()
        };
        if n == 0 {
            return tree;
        }
        let centroids: Vec<DVec3> = scene.surfaces.iter().map(|s| s.patch.centroid()).collect();
        let shapes = Shapes {
            normals: scene.surfaces.iter().map(|s| s.patch.normal()).collect(),
            areas: scene.surfaces.iter().map(|s| s.patch.area()).collect(),
            boxes: (scene.surfaces.iter())
                .map(|s| {
                    let v = s.patch.vertices();
                    let lo = v.iter().fold(DVec3::INFINITY, |a, &b| a.min(b));
                    (lo, v.iter().fold(DVec3::NEG_INFINITY, |a, &b| a.max(b)))
                })
                .collect(),
        };
        let mut stack = vec![(0..n as u32, None)];
        while let Some((range, parent)) = stack.pop() {
            let index = tree.nodes.len() as u32;
            let slice = &mut tree.members[range.start as usize..range.end as usize];
            let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            let (mut area, mut reflectance, mut moment) = (0.0, 0.0f64, DVec3::ZERO);
            let mut area_normal = DVec3::ZERO;
            for &s in slice.iter() {
                let surface = &scene.surfaces[s as usize];
                moment += surface.patch.area() * centroids[s as usize];
                area_normal += surface.patch.area() * shapes.normals[s as usize];
                for v in surface.patch.vertices() {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
                area += surface.patch.area();
                let rho = surface.brdf.lambertian().map_or(0.0, |r| r.max_channel());
                reflectance = reflectance.max(rho);
            }
            if let Some(parent) = parent {
                let node: &mut Cluster = &mut tree.nodes[parent as usize];
                let children = node.children.get_or_insert([index, index]);
                children[1] = index;
            }
            let (center, axis) = (0.5 * (lo + hi), area_normal.normalize_or_zero());
            let (mut spread_cos, mut above, mut below) = (1.0f64, 0.0f64, 0.0f64);
            for &s in slice.iter() {
                spread_cos = spread_cos.min(axis.dot(shapes.normals[s as usize]));
                for v in scene.surfaces[s as usize].patch.vertices() {
                    above = above.max(axis.dot(v - center));
                    below = below.max(-axis.dot(v - center));
                }
            }
            let orientation = Orientation {
                axis,
                spread_cos,
                above,
                below,
            };
            tree.nodes.push(Cluster {
                center,
                radius: 0.5 * (hi - lo).length(),
                centroid: if area > 0.0 {
                    moment / area
                } else {
                    0.5 * (lo + hi)
                },
                area,
                reflectance,
                orientation,
                members: range.clone(),
                children: None,
                parent,
            });
            if slice.len() == 1 {
                tree.leaf_of[slice[0] as usize] = index;
                continue;
            }
            let (mut clo, mut chi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            let (mut nlo, mut nhi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            for &s in slice.iter() {
                clo = clo.min(centroids[s as usize]);
                chi = chi.max(centroids[s as usize]);
                nlo = nlo.min(shapes.normals[s as usize]);
                nhi = nhi.max(shapes.normals[s as usize]);
            }
            let mid = slice.len() / 2;
            // Split at the median along `axis` of `keys`: whether both
            // halves' cones of normals are narrow, and their larger radius.
            let split = |slice: &mut [u32], keys: &[DVec3], axis: usize| {
                slice.select_nth_unstable_by(mid, |&a, &b| {
                    let (a, b) = (keys[a as usize][axis], keys[b as usize][axis]);
                    a.total_cmp(&b)
                });
                let (first, second) = slice.split_at(mid);
                let ((c1, r1), (c2, r2)) = (
                    shapes.cone_and_radius(first),
                    shapes.cone_and_radius(second),
                );
                (c1.min(c2) > NARROW_CONE_COS, r1.max(r2))
            };
            let (turn, place) = ((nhi - nlo).max_position(), (chi - clo).max_position());
            let (turn_narrow, turn_radius) = split(slice, &shapes.normals, turn);
            // Made last, the split by place stands unless only the one by
            // orientation leaves both halves facing one way, and they are
            // not much larger.
            let (place_narrow, place_radius) = split(slice, &centroids, place);
            if turn_narrow && !place_narrow && turn_radius <= TURN_GROWTH * place_radius {
                split(slice, &shapes.normals, turn);
            }
            let split = range.start + mid as u32;
            // Pushed second, popped first: the first child gets the lower
            // index, so `children` is [first half, second half].
            stack.push((split..range.end, Some(index)));
            stack.push((range.start..split, Some(index)));
        }
        let mut sum = 0.0;
        tree.area_prefix = std::iter::once(0.0)
            .chain(tree.members.iter().map(|&s| {
                sum += scene.surfaces[s as usize].patch.area();
                sum
            }))
            .collect();
        tree
    }

    /// The surfaces of cluster `c`.
    pub fn members_of(&self, c: u32) -> &[u32] {
        let r = &self.nodes[c as usize].members;
        &self.members[r.start as usize..r.end as usize]
    }

    /// The member of cluster `c` at fraction `u` ∈ [0, 1) of its area: a
    /// member picked with probability proportional to its area.
    pub fn member_by_area(&self, c: u32, u: f64) -> u32 {
        let r = &self.nodes[c as usize].members;
        let (start, end) = (r.start as usize, r.end as usize);
        let (a0, a1) = (self.area_prefix[start], self.area_prefix[end]);
        let target = a0 + u.clamp(0.0, 1.0) * (a1 - a0);
        let prefix = &self.area_prefix[start + 1..end];
        let k = prefix
            .partition_point(|&a| a <= target)
            .min(end - start - 1);
        self.members[start + k]
    }

    /// The clusters above surface `s`'s leaf, nearest first (the leaf itself
    /// excluded).
    pub fn ancestors(&self, s: u32) -> impl Iterator<Item = u32> + '_ {
        let mut at = self.nodes[self.leaf_of[s as usize] as usize].parent;
        std::iter::from_fn(move || {
            let c = at?;
            at = self.nodes[c as usize].parent;
            Some(c)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{bowl, grey};

    /// The largest n·(y − x) over the members of `x` (n a member's normal,
    /// x a point of it) and the vertices of the members of `y`.
    fn highest(tree: &ClusterTree, scene: &Scene, x: u32, y: u32) -> f64 {
        let mut top = f64::NEG_INFINITY;
        for &m in tree.members_of(x) {
            let patch = &scene.surfaces[m as usize].patch;
            let (n, o) = (patch.normal(), patch.vertices()[0]);
            for &k in tree.members_of(y) {
                for v in scene.surfaces[k as usize].patch.vertices() {
                    top = top.max(n.dot(v - o));
                }
            }
        }
        top
    }

    #[test]
    fn the_two_sides_of_a_mesh_part_where_it_is_flat() {
        // A node holding a triangle and its twin faces every way; the two
        // sides of the bowl part once a node's part of it curves by less
        // than its cones allow, far above the leaves (where median splits
        // by place alone pair each triangle with its twin).
        let scene = bowl(12, true);
        let tree = ClusterTree::build(&scene);
        let twins = |s: u32| s ^ 1;
        let mut largest_parted = 0;
        for (c, node) in tree.nodes.iter().enumerate() {
            let members = tree.members_of(c as u32);
            if members.iter().any(|&s| members.contains(&twins(s))) {
                assert!(node.orientation.spread_cos <= 0.0, "node {c}");
                assert!(members.len() > 64, "node {c}: {} members", members.len());
            } else {
                largest_parted = largest_parted.max(members.len());
            }
        }
        assert!(largest_parted >= 64, "{largest_parted}");
    }

    #[test]
    fn cones_and_slabs_hold_their_members() {
        let scene = bowl(8, true);
        let tree = ClusterTree::build(&scene);
        for (c, node) in tree.nodes.iter().enumerate() {
            let o = &node.orientation;
            for &s in tree.members_of(c as u32) {
                let patch = &scene.surfaces[s as usize].patch;
                assert!(o.axis.dot(patch.normal()) >= o.spread_cos - 1e-12);
                for v in patch.vertices() {
                    let h = o.axis.dot(v - node.center);
                    assert!(h <= o.above + 1e-12 && -h <= o.below + 1e-12);
                }
            }
        }
    }

    #[test]
    fn heights_over_a_node_bound_its_members_and_find_what_lies_behind() {
        // Every pair of nodes of a one-sided bowl: the bound holds the
        // highest vertex of one over the planes of the other's members,
        // and is finite for most (their cones are narrower than a
        // hemisphere). The two halves of a flat sheet lie in each other's
        // planes: at most 0, they exchange nothing.
        let scene = bowl(8, false);
        let tree = ClusterTree::build(&scene);
        let extent = |c: u32| {
            let node = &tree.nodes[c as usize];
            (node.center, node.radius, node.orientation)
        };
        let mut finite = 0;
        for x in 0..tree.nodes.len() as u32 {
            for y in 0..tree.nodes.len() as u32 {
                let ((cx, rx, ox), (cy, ry, oy)) = (extent(x), extent(y));
                let bound = height_over((cx, rx, &ox), (cy, ry, &oy));
                let top = highest(&tree, &scene, x, y);
                assert!(bound >= top - 1e-12, "{x} over {y}: {bound} < {top}");
                finite += usize::from(bound.is_finite());
            }
        }
        assert!(finite > tree.nodes.len().pow(2) / 2, "{finite}");
        // A flat sheet: every node's members lie in every other's planes.
        let sheet = Scene::from_surfaces(
            (0..64)
                .map(|k| {
                    grey(Patch::Parallelogram {
                        origin: DVec3::new((k % 8) as f64, 0.0, (k / 8) as f64),
                        edge_s: DVec3::Z,
                        edge_t: DVec3::X,
                    })
                })
                .collect(),
        );
        let tree = ClusterTree::build(&sheet);
        let [a, b] = tree.nodes[0].children.unwrap();
        let (na, nb) = (&tree.nodes[a as usize], &tree.nodes[b as usize]);
        let height = height_over(
            (na.center, na.radius, &na.orientation),
            (nb.center, nb.radius, &nb.orientation),
        );
        assert!(height <= 1e-12, "{height}");
    }

    fn row_of_squares(n: usize) -> Scene {
        let surfaces = (0..n)
            .map(|i| {
                let patch = Patch::Parallelogram {
                    origin: DVec3::new(2.0 * i as f64, 0.0, 0.0),
                    edge_s: DVec3::X,
                    edge_t: DVec3::Y,
                };
                grey(patch)
            })
            .collect();
        Scene::from_surfaces(surfaces)
    }

    #[test]
    fn every_surface_is_one_leaf_and_clusters_bound_their_members() {
        let scene = row_of_squares(13);
        let tree = ClusterTree::build(&scene);
        assert_eq!(tree.nodes.len(), 2 * 13 - 1);
        let mut leaves: Vec<u32> = tree.leaf_of.clone();
        leaves.sort();
        leaves.dedup();
        assert_eq!(leaves.len(), 13);
        for (c, node) in tree.nodes.iter().enumerate() {
            let members = tree.members_of(c as u32);
            let area: f64 = members
                .iter()
                .map(|&s| scene.surfaces[s as usize].patch.area())
                .sum();
            assert!((area - node.area).abs() < 1e-12);
            assert!(node.centroid.distance(node.center) <= node.radius);
            for &s in members {
                for v in scene.surfaces[s as usize].patch.vertices() {
                    assert!(v.distance(node.center) <= node.radius + 1e-12);
                }
            }
            if let Some([a, b]) = node.children {
                let (ra, rb) = (
                    &tree.nodes[a as usize].members,
                    &tree.nodes[b as usize].members,
                );
                assert_eq!(
                    (ra.start, ra.end, rb.end),
                    (node.members.start, rb.start, node.members.end)
                );
                assert_eq!(tree.nodes[a as usize].parent, Some(c as u32));
            }
        }
        // Balanced: depth ⌈log₂ 13⌉ = 4.
        let depth = (0..13).map(|s| tree.ancestors(s).count()).max().unwrap();
        assert_eq!(depth, 4);
        assert!(tree.ancestors(0).last() == Some(0));
    }

    #[test]
    fn members_are_picked_in_proportion_to_their_area() {
        let mut scene = row_of_squares(2);
        scene.surfaces[1].patch = Patch::Parallelogram {
            origin: DVec3::new(2.0, 0.0, 0.0),
            edge_s: 3.0 * DVec3::X,
            edge_t: DVec3::Y,
        };
        let tree = ClusterTree::build(&scene);
        let picks = (0..100).map(|i| tree.member_by_area(0, (i as f64 + 0.5) / 100.0));
        assert_eq!(picks.filter(|&s| s == 1).count(), 75);
    }
}
