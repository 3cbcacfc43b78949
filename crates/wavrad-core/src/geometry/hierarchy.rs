//! Element hierarchies: one quadtree of [`crate::geometry::element`]s per surface, the
//! multiresolution structure over which radiance is stored as element averages
//! (Haar scaling coefficients up to the factor of [`crate::geometry::haar`]).
//!
//! Refinement works on [`ElementId`]s (a level and a path of child indices),
//! so surface pairs can be refined independently and in parallel; the trees
//! are then built once from every element a link mentions.

use crate::scene::Patch;
use glam::DVec2;
use std::collections::BTreeSet;

/// An element named by its level and the child indices leading to it from the
/// surface's root, two bits per level (most significant = first step).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
pub struct ElementId {
    /// Subdivision level J (root = 0).
    pub level: u32,
    /// Child indices, `path = Σ k_i · 4^{level−1−i}`.
    pub path: u64,
}

impl ElementId {
    /// The whole surface.
    pub const ROOT: ElementId = ElementId { level: 0, path: 0 };

    /// The `k`-th child.
    pub fn child(self, k: usize) -> ElementId {
        ElementId {
            level: self.level + 1,
            path: self.path * 4 + k as u64,
        }
    }

    /// The parent, or `None` for the root.
    pub fn parent(self) -> Option<ElementId> {
        (self.level > 0).then(|| ElementId {
            level: self.level - 1,
            path: self.path / 4,
        })
    }

    /// True when `other` is this element or lies inside it.
    pub fn contains(self, other: ElementId) -> bool {
        other.level >= self.level && other.path >> (2 * (other.level - self.level)) == self.path
    }

    /// The fraction of `other`'s area that lies in this element: 1 if
    /// `other` is inside it, 4^{-Δlevel} if it is inside `other`, else 0.
    pub fn overlap_fraction(self, other: ElementId) -> f64 {
        if self.contains(other) {
            1.0
        } else if other.contains(self) {
            0.25f64.powi((self.level - other.level) as i32)
        } else {
            0.0
        }
    }

    /// The elements of surface `root` containing its parameter `uv`, from
    /// the root (index 0) down to level `depth`.
    pub fn path_to(root: &Patch, uv: DVec2, depth: u32) -> Vec<ElementId> {
        let mut path = vec![ElementId::ROOT];
        let mut local = uv;
        for _ in 0..depth {
            let (k, child_uv) = root.locate_child(local);
            path.push(path[path.len() - 1].child(k));
            local = child_uv;
        }
        path
    }

    /// Geometry of this element of the surface `root`.
    pub fn patch(self, root: &Patch) -> Patch {
        let mut p = *root;
        for i in (0..self.level).rev() {
            p = p.subdivide()[((self.path >> (2 * i)) & 3) as usize];
        }
        p
    }
}

/// One element of one surface: how links, exposure and light estimates
/// name an element.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
pub struct ElementRef {
    /// Index of the surface.
    pub surface: u32,
    /// The element in the surface's hierarchy.
    pub id: ElementId,
}

impl ElementRef {
    /// Element `id` of `surface`.
    pub fn new(surface: u32, id: ElementId) -> ElementRef {
        ElementRef { surface, id }
    }

    /// The whole of `surface`.
    pub fn root(surface: u32) -> ElementRef {
        ElementRef::new(surface, ElementId::ROOT)
    }

    /// The `k`-th child.
    pub fn child(self, k: usize) -> ElementRef {
        ElementRef {
            id: self.id.child(k),
            ..self
        }
    }
}

/// A tree whose inner nodes have four consecutive children: element trees,
/// and the element-pair trees of directional radiance
/// ([`crate::geometry::pair_tree::PairTree`]); push–pull works on either.
pub trait Hierarchy {
    /// Number of nodes (node 0 is the root).
    fn node_count(&self) -> usize;
    /// Index of the first of the node's four children, if it has any.
    fn first_child(&self, node: usize) -> Option<usize>;
}

impl Hierarchy for ElementTree {
    fn node_count(&self) -> usize {
        self.nodes.len()
    }
    fn first_child(&self, node: usize) -> Option<usize> {
        self.nodes[node].first_child.map(|c| c as usize)
    }
}

/// A node of an [`ElementTree`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Node {
    /// Which element it is.
    pub id: ElementId,
    /// Its geometry.
    pub patch: Patch,
    /// Index of the first of its four consecutive children, if subdivided.
    pub first_child: Option<u32>,
}

/// The quadtree of one surface; node 0 is the root, children of a node are
/// consecutive and every inner node has exactly four.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ElementTree {
    /// Nodes, parents before children.
    pub nodes: Vec<Node>,
}

impl ElementTree {
    /// The smallest tree over `root` that contains every element in `ids`
    /// (with all their ancestors and the siblings that make each inner node
    /// complete).
    pub fn build(root: &Patch, ids: &BTreeSet<ElementId>) -> ElementTree {
        // Every element listed, and every ancestor, is subdivided if it has a
        // listed descendant.
        let mut inner = BTreeSet::new();
        for id in ids {
            let mut cur = *id;
            while let Some(p) = cur.parent() {
                if !inner.insert(p) {
                    break;
                }
                cur = p;
            }
        }
        let mut nodes = vec![Node {
            id: ElementId::ROOT,
            patch: *root,
            first_child: None,
        }];
        let mut i = 0;
        while i < nodes.len() {
            let id = nodes[i].id;
            if inner.contains(&id) {
                let first = nodes.len() as u32;
                let children = nodes[i].patch.subdivide();
                nodes[i].first_child = Some(first);
                for (k, patch) in children.into_iter().enumerate() {
                    nodes.push(Node {
                        id: id.child(k),
                        patch,
                        first_child: None,
                    });
                }
            }
            i += 1;
        }
        ElementTree { nodes }
    }

    /// Index of the node for `id`, which must be in the tree.
    pub fn index_of(&self, id: ElementId) -> Option<u32> {
        let mut node = 0u32;
        for i in (0..id.level).rev() {
            let k = (id.path >> (2 * i)) & 3;
            node = self.nodes[node as usize].first_child? + k as u32;
        }
        Some(node)
    }

    /// The deepest node whose element contains `id` (`id` itself if it is
    /// in the tree, else the leaf it lies in).
    pub fn node_containing(&self, id: ElementId) -> u32 {
        let mut node = 0u32;
        for i in (0..id.level).rev() {
            let Some(first) = self.nodes[node as usize].first_child else {
                break;
            };
            node = first + ((id.path >> (2 * i)) & 3) as u32;
        }
        node
    }

    /// Leaf containing parameter `uv` of the surface, and `uv` in that leaf.
    pub fn locate(&self, uv: DVec2) -> (u32, DVec2) {
        self.locate_from(0, uv)
    }

    /// Leaf below `node` containing parameter `local` of that node's
    /// element, and the parameter of the same point in that leaf.
    pub fn locate_from(&self, node: u32, local: DVec2) -> (u32, DVec2) {
        let (mut node, mut local) = (node, local);
        while let Some(first) = self.nodes[node as usize].first_child {
            let (k, child_uv) = self.nodes[node as usize].patch.locate_child(local);
            node = first + k as u32;
            local = child_uv;
        }
        (node, local)
    }

    /// Number of nodes on each level (index = level).
    pub fn count_per_level(&self) -> Vec<usize> {
        let mut counts = Vec::new();
        for n in &self.nodes {
            let l = n.id.level as usize;
            if counts.len() <= l {
                counts.resize(l + 1, 0);
            }
            counts[l] += 1;
        }
        counts
    }

    /// Deepest level in the tree.
    pub fn depth(&self) -> u32 {
        self.nodes.iter().map(|n| n.id.level).max().unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn square() -> Patch {
        Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X,
            edge_t: DVec3::Y,
        }
    }

    #[test]
    fn tree_holds_every_listed_element_and_locates_points() {
        let deep = ElementId::ROOT.child(3).child(1).child(2);
        let ids: BTreeSet<_> = [deep, ElementId::ROOT.child(0)].into_iter().collect();
        let tree = ElementTree::build(&square(), &ids);
        // Root + 4 + 4 + 4 nodes.
        assert_eq!(tree.nodes.len(), 13);
        let idx = tree.index_of(deep).unwrap() as usize;
        assert_eq!(tree.nodes[idx].id, deep);
        let expected = deep.patch(&square());
        assert_eq!(tree.nodes[idx].patch, expected);
        // The centre of `deep` is located in it.
        let uv = square().param_of(expected.centroid());
        assert_eq!(tree.locate(uv).0 as usize, idx);
        assert_eq!(tree.count_per_level(), vec![1, 4, 4, 4]);
        assert_eq!(
            deep.parent().unwrap().parent().unwrap().parent(),
            Some(ElementId::ROOT)
        );
    }

    #[test]
    fn containment_and_overlap_follow_the_paths() {
        let a = ElementId::ROOT.child(2);
        let deep = a.child(1).child(3);
        assert!(ElementId::ROOT.contains(deep) && a.contains(deep) && a.contains(a));
        assert!(!deep.contains(a) && !ElementId::ROOT.child(1).contains(deep));
        assert_eq!(a.overlap_fraction(deep), 1.0);
        assert_eq!(deep.overlap_fraction(a), 1.0 / 16.0);
        assert_eq!(ElementId::ROOT.child(0).overlap_fraction(a), 0.0);
    }
}
