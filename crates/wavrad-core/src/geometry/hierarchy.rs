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

/// The deepest level an [`ElementId`] can name: its path holds two bits a
/// level in a `u64`, and [`ElementId::contains`] shifts it by two bits a
/// level of difference.
pub const MAX_ELEMENT_LEVEL: u32 = 31;

/// A tree whose inner nodes have four consecutive children: element trees,
/// and the element-pair trees of directional radiance
/// ([`crate::geometry::pair_tree::PairTree`]); push–pull works on either.
pub trait Hierarchy {
    /// Number of nodes (node 0 is the root).
    fn node_count(&self) -> usize;
    /// Index of the first of the node's four children, if it has any.
    fn first_child(&self, node: usize) -> Option<usize>;
}

/// Check the shape every [`Hierarchy`] is assumed to have, for trees read
/// from outside (a solution file): a root, each inner node's four
/// children after it and within the tree, and every node but the root the
/// child of exactly one node.
pub fn check_hierarchy(tree: &impl Hierarchy) -> Result<(), String> {
    let count = tree.node_count();
    if count == 0 {
        return Err("no root".into());
    }
    let mut claimed = vec![false; count];
    for node in 0..count {
        let Some(first) = tree.first_child(node) else {
            continue;
        };
        if first <= node || first + 4 > count {
            return Err(format!(
                "node {node}'s children start at node {first}, of {count}"
            ));
        }
        for (child, claimed) in (first..).zip(&mut claimed[first..first + 4]) {
            if std::mem::replace(claimed, true) {
                return Err(format!("node {child} is the child of two nodes"));
            }
        }
    }
    match claimed[1..].iter().position(|&c| !c) {
        Some(orphan) => Err(format!("node {} is no node's child", orphan + 1)),
        None => Ok(()),
    }
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

    /// Check that the tree is the quadtree of the surface `root` that
    /// [`ElementTree::build`] (or refinement) makes: the shape of a
    /// [`Hierarchy`], the root's element the whole surface, and each
    /// child's id and patch its parent's subdivision's, down to at most
    /// [`MAX_ELEMENT_LEVEL`]. For trees read from outside (a solution
    /// file), which the renderer indexes without checks.
    pub fn check(&self, root: &Patch) -> Result<(), String> {
        check_hierarchy(self)?;
        if self.nodes[0].id != ElementId::ROOT || self.nodes[0].patch != *root {
            return Err("its root is not the whole surface".into());
        }
        // Parents come before children, so each id and patch checked
        // derives from the root's.
        for (i, node) in self.nodes.iter().enumerate() {
            let Some(first) = node.first_child else {
                continue;
            };
            if node.id.level >= MAX_ELEMENT_LEVEL {
                return Err(format!(
                    "node {i} is subdivided below level {MAX_ELEMENT_LEVEL}"
                ));
            }
            for (k, patch) in node.patch.subdivide().into_iter().enumerate() {
                let child = &self.nodes[first as usize + k];
                if child.id != node.id.child(k) || child.patch != patch {
                    return Err(format!(
                        "node {} is not child {k} of node {i}",
                        first as usize + k
                    ));
                }
            }
        }
        Ok(())
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

    #[test]
    fn built_trees_pass_their_check_and_damaged_ones_fail_it() {
        let ids = [ElementId::ROOT.child(1).child(2)].into_iter().collect();
        let tree = ElementTree::build(&square(), &ids);
        assert_eq!(tree.check(&square()), Ok(()));
        let fails = |edit: &dyn Fn(&mut ElementTree), needle: &str| {
            let mut damaged = tree.clone();
            edit(&mut damaged);
            let e = damaged.check(&square()).unwrap_err();
            assert!(e.contains(needle), "expected {needle:?} in: {e}");
        };
        fails(
            &|t| t.nodes[2].first_child = Some(0),
            "node 2's children start at node 0",
        );
        fails(
            &|t| t.nodes[2].first_child = Some(7),
            "start at node 7, of 9",
        );
        fails(&|t| t.nodes.swap(1, 2), "node 1 is not child 0 of node 0");
        fails(
            &|t| t.nodes.push(t.nodes[1].clone()),
            "node 9 is no node's child",
        );
        fails(
            &|t| t.nodes[3].patch = square(),
            "node 3 is not child 2 of node 0",
        );
        let mut deep = ElementTree::build(&square(), &BTreeSet::new());
        for level in 0..=MAX_ELEMENT_LEVEL {
            let last = deep.nodes.len() - 1;
            let (id, patch) = (deep.nodes[last].id, deep.nodes[last].patch);
            deep.nodes[last].first_child = Some(last as u32 + 1);
            deep.nodes.extend(
                patch
                    .subdivide()
                    .into_iter()
                    .enumerate()
                    .map(|(k, patch)| Node {
                        id: id.child(k),
                        patch,
                        first_child: None,
                    }),
            );
            let checked = deep.check(&square());
            assert_eq!(checked.is_ok(), level < MAX_ELEMENT_LEVEL, "{checked:?}");
        }
    }
}
