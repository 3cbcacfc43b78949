//! Clusters of surfaces: a binary hierarchy above the surfaces' element
//! trees (Smits, Arvo & Greenberg 1994; Sillion 1995), so that linking can
//! start at the whole scene and let groups of surfaces that are small
//! against their distance exchange light as wholes
//! ([`crate::refine::cluster_links`]).
//!
//! The tree is built top-down by median splits along the longest axis of
//! the members' centroids (a bounding-volume hierarchy with one surface per
//! leaf), so it is balanced whatever the scene: depth ⌈log₂ n⌉.

use crate::scene::Scene;
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
    /// Its members, a range of [`ClusterTree::members`].
    pub members: Range<u32>,
    /// Its two children; `None` for a leaf (one surface).
    pub children: Option<[u32; 2]>,
    /// Its parent; `None` for the root.
    pub parent: Option<u32>,
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
        let mut stack = vec![(0..n as u32, None)];
        while let Some((range, parent)) = stack.pop() {
            let index = tree.nodes.len() as u32;
            let slice = &mut tree.members[range.start as usize..range.end as usize];
            let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            let (mut area, mut reflectance, mut moment) = (0.0, 0.0f64, DVec3::ZERO);
            for &s in slice.iter() {
                let surface = &scene.surfaces[s as usize];
                moment += surface.patch.area() * centroids[s as usize];
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
            tree.nodes.push(Cluster {
                center: 0.5 * (lo + hi),
                radius: 0.5 * (hi - lo).length(),
                centroid: if area > 0.0 {
                    moment / area
                } else {
                    0.5 * (lo + hi)
                },
                area,
                reflectance,
                members: range.clone(),
                children: None,
                parent,
            });
            if slice.len() == 1 {
                tree.leaf_of[slice[0] as usize] = index;
                continue;
            }
            let (mut clo, mut chi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            for &s in slice.iter() {
                clo = clo.min(centroids[s as usize]);
                chi = chi.max(centroids[s as usize]);
            }
            let axis = (chi - clo).max_position();
            let mid = slice.len() / 2;
            slice.select_nth_unstable_by(mid, |&a, &b| {
                let (a, b) = (centroids[a as usize][axis], centroids[b as usize][axis]);
                a.total_cmp(&b)
            });
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
    use crate::scene::{Patch, Scene};
    use crate::testing::grey;

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
