//! The directional radiance structure of a glossy surface (paper §4.1 and its
//! Figure 2): for a glossy surface p and each surface q it sends light to, the
//! radiance L_{a→b} leaving element a of p towards element b of q, stored as
//! averages over element pairs (the Haar scaling coefficients of the 4D
//! function L_pq up to the factor of [`crate::geometry::haar`]).
//!
//! Three-point links refine with *virtual resolution*: each step subdivides
//! only one of the elements, so the pairs a link writes to are (a, b) with
//! any combination of levels. A [`PairTree`] holds them as a tree over the
//! product domain in which every inner node splits either its a (four
//! children (a_k, b)) or its b ((a, b_k)); a pair that cuts across an earlier
//! split is represented by the nodes that tile it. Push–pull then works as on
//! a surface's quadtree ([`crate::solve::push_pull`]).

use crate::geometry::hierarchy::{check_hierarchy, ElementId, Hierarchy, MAX_ELEMENT_LEVEL};

/// A node of a [`PairTree`]: the pair of elements (a on p, b on q).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PairNode {
    /// Element of the sending (glossy) surface.
    pub a: ElementId,
    /// Element of the receiving surface.
    pub b: ElementId,
    /// First of the four consecutive children, if subdivided.
    pub first_child: Option<u32>,
}

/// The tree of element pairs over which L_{p→q} is stored; node 0 is the
/// pair of whole surfaces.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PairTree {
    /// Nodes, parents before children.
    pub nodes: Vec<PairNode>,
}

impl Default for PairTree {
    fn default() -> Self {
        PairTree {
            nodes: vec![PairNode {
                a: ElementId::ROOT,
                b: ElementId::ROOT,
                first_child: None,
            }],
        }
    }
}

impl Hierarchy for PairTree {
    fn node_count(&self) -> usize {
        self.nodes.len()
    }
    fn first_child(&self, node: usize) -> Option<usize> {
        self.nodes[node].first_child.map(|c| c as usize)
    }
}

fn intersects(x: ElementId, y: ElementId) -> bool {
    x.contains(y) || y.contains(x)
}

impl PairTree {
    /// Subdivide the tree until the pair (a, b) is exactly a union of nodes.
    /// Where both elements of a leaf are coarser than the pair's, the
    /// coarser one is split first (ties: a).
    pub fn insert(&mut self, a: ElementId, b: ElementId) {
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let PairNode { a: x, b: y, .. } = self.nodes[i];
            if a.contains(x) && b.contains(y) {
                continue; // this node lies inside the pair
            }
            let first = match self.nodes[i].first_child {
                Some(first) => first as usize,
                None => {
                    // The node meets the pair without lying inside it, so
                    // a ⊊ x or b ⊊ y.
                    let can_split_a = x != a && x.contains(a);
                    let can_split_b = y != b && y.contains(b);
                    let split_a = can_split_a && (!can_split_b || x.level <= y.level);
                    let first = self.nodes.len();
                    for k in 0..4 {
                        let (ca, cb) = if split_a {
                            (x.child(k), y)
                        } else {
                            (x, y.child(k))
                        };
                        self.nodes.push(PairNode {
                            a: ca,
                            b: cb,
                            first_child: None,
                        });
                    }
                    self.nodes[i].first_child = Some(first as u32);
                    first
                }
            };
            for c in first..first + 4 {
                if intersects(self.nodes[c].a, a) && intersects(self.nodes[c].b, b) {
                    stack.push(c);
                }
            }
        }
    }

    /// The nodes that meet the pair (a, b), each with the fraction of the
    /// pair's area it covers: nodes inside the pair, and leaves that reach
    /// beyond it. The average of a function stored as node averages over the
    /// pair is Σ weight · value; after [`PairTree::insert`] of the pair every
    /// node returned lies inside it. Sorted by node, so sums are
    /// deterministic.
    pub fn overlaps(&self, a: ElementId, b: ElementId) -> Vec<(u32, f64)> {
        let mut out = Vec::new();
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = self.nodes[i];
            match n.first_child {
                Some(first) if !(a.contains(n.a) && b.contains(n.b)) => {
                    for c in first as usize..first as usize + 4 {
                        if intersects(self.nodes[c].a, a) && intersects(self.nodes[c].b, b) {
                            stack.push(c);
                        }
                    }
                }
                _ => out.push((i as u32, n.a.overlap_fraction(a) * n.b.overlap_fraction(b))),
            }
        }
        out.sort_by_key(|&(i, _)| i);
        out
    }

    /// The partition of the pair (a, b) by the tree's leaves: each leaf
    /// that meets it, cut to the pair (its elements, or the pair's where
    /// the pair's are finer), in node order. A single (a, b) where the
    /// structure resolves L_{a→b} no more finely than the pair itself.
    pub fn tiles(&self, a: ElementId, b: ElementId) -> Vec<(ElementId, ElementId)> {
        let finer = |x: ElementId, y: ElementId| if x.contains(y) { y } else { x };
        let mut out = Vec::new();
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = self.nodes[i];
            match n.first_child {
                Some(first) => {
                    stack.extend((first as usize..first as usize + 4).rev().filter(|&c| {
                        intersects(self.nodes[c].a, a) && intersects(self.nodes[c].b, b)
                    }))
                }
                None => out.push((finer(n.a, a), finer(n.b, b))),
            }
        }
        out
    }

    /// The leaf containing the point pair whose elements at every level are
    /// given by `a_at(level)` and `b_at(level)` (the elements of p and q
    /// containing the two points).
    pub fn leaf_at(&self, a_at: impl Fn(u32) -> ElementId, b_at: impl Fn(u32) -> ElementId) -> u32 {
        let mut i = 0usize;
        while let Some(first) = self.nodes[i].first_child {
            let first = first as usize;
            i = (first..first + 4)
                .find(|&c| {
                    let c = &self.nodes[c];
                    c.a == a_at(c.a.level) && c.b == b_at(c.b.level)
                })
                .unwrap_or(first);
        }
        i as u32
    }

    /// Check that the tree is one [`PairTree::insert`] makes: the shape of
    /// a [`Hierarchy`], the root the pair of whole surfaces, and each inner
    /// node's children the four children of its a or of its b, down to at
    /// most [`MAX_ELEMENT_LEVEL`]. For trees read from outside (a solution
    /// file), which the renderer indexes without checks.
    pub fn check(&self) -> Result<(), String> {
        check_hierarchy(self)?;
        let root = &self.nodes[0];
        if (root.a, root.b) != (ElementId::ROOT, ElementId::ROOT) {
            return Err("its root is not the pair of whole surfaces".into());
        }
        // Parents come before children, so each pair checked derives from
        // the root's.
        for (i, node) in self.nodes.iter().enumerate() {
            let Some(first) = node.first_child else {
                continue;
            };
            let children = &self.nodes[first as usize..first as usize + 4];
            let split = |deeper: &dyn Fn(ElementId) -> (ElementId, ElementId), e: ElementId| {
                e.level < MAX_ELEMENT_LEVEL
                    && (0..4).all(|k| {
                        let (a, b) = deeper(e.child(k));
                        (children[k].a, children[k].b) == (a, b)
                    })
            };
            if !split(&|a| (a, node.b), node.a) && !split(&|b| (node.a, b), node.b) {
                return Err(format!(
                    "the children of node {i} split neither of its elements"
                ));
            }
        }
        Ok(())
    }

    /// Number of nodes on each level of a (index = level of a + level of b).
    pub fn count_per_level(&self) -> Vec<usize> {
        let mut counts = Vec::new();
        for n in &self.nodes {
            let l = (n.a.level + n.b.level) as usize;
            if counts.len() <= l {
                counts.resize(l + 1, 0);
            }
            counts[l] += 1;
        }
        counts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: ElementId = ElementId::ROOT;

    #[test]
    fn inserted_pairs_are_tiled_exactly() {
        let mut t = PairTree::default();
        let a = R.child(1).child(2);
        let b = R.child(3);
        t.insert(a, b);
        let cover = t.overlaps(a, b);
        assert_eq!(cover.len(), 1, "{cover:?}");
        let n = t.nodes[cover[0].0 as usize];
        assert_eq!((n.a, n.b, cover[0].1), (a, b, 1.0));
        // A pair cutting across the a-splits: coarse a, fine b.
        let (a2, b2) = (R, R.child(0).child(0));
        t.insert(a2, b2);
        let cover = t.overlaps(a2, b2);
        assert!(cover.len() > 1);
        let total: f64 = cover.iter().map(|c| c.1).sum();
        assert!((total - 1.0).abs() < 1e-12, "{total}");
        for (i, _) in &cover {
            let n = t.nodes[*i as usize];
            assert!(a2.contains(n.a) && b2.contains(n.b));
        }
        // The first pair is still exactly represented.
        let total: f64 = t.overlaps(a, b).iter().map(|c| c.1).sum();
        assert!((total - 1.0).abs() < 1e-12);
    }

    #[test]
    fn the_tiles_of_a_pair_partition_it_by_the_leaves() {
        let mut t = PairTree::default();
        let fine = R.child(3).child(1);
        t.insert(R.child(0), fine);
        let area = |tiles: &[(ElementId, ElementId)], a: ElementId, b: ElementId| {
            tiles.iter().fold(0.0, |sum, &(x, y)| {
                assert!(a.contains(x) && b.contains(y), "{x:?} {y:?} outside");
                sum + x.overlap_fraction(a) * y.overlap_fraction(b)
            })
        };
        // The whole pair: every leaf, the fine pair among them.
        let tiles = t.tiles(R, R);
        assert!(tiles.contains(&(R.child(0), fine)), "{tiles:?}");
        assert_eq!(
            tiles.len(),
            t.nodes.iter().filter(|n| n.first_child.is_none()).count()
        );
        assert!((area(&tiles, R, R) - 1.0).abs() < 1e-12);
        // A receiver the fine pair lies in, from its glossy element.
        let tiles = t.tiles(R.child(0), R.child(3));
        assert_eq!(tiles.len(), 4, "{tiles:?}");
        assert!((area(&tiles, R.child(0), R.child(3)) - 1.0).abs() < 1e-12);
        // Finer than any leaf, or where the fine pair is not: the pair.
        assert_eq!(
            t.tiles(R.child(0).child(2), fine),
            [(R.child(0).child(2), fine)]
        );
        assert_eq!(t.tiles(R.child(1), R), [(R.child(1), R)]);
    }

    #[test]
    fn averages_over_a_finer_pair_come_from_the_leaf_containing_it() {
        let mut t = PairTree::default();
        t.insert(R.child(2), R);
        let cover = t.overlaps(R.child(2).child(1), R.child(3));
        assert_eq!(cover.len(), 1);
        let n = t.nodes[cover[0].0 as usize];
        assert_eq!((n.a, n.b), (R.child(2), R));
        // The query lies wholly in that leaf: it carries its whole weight.
        assert_eq!(cover[0].1, 1.0);
    }

    #[test]
    fn leaf_lookup_follows_the_point_pair() {
        let mut t = PairTree::default();
        t.insert(R.child(1), R.child(2).child(0));
        let path_a = [R, R.child(1), R.child(1).child(3)];
        let path_b = [R, R.child(2), R.child(2).child(0)];
        let leaf = t.leaf_at(|l| path_a[l as usize], |l| path_b[l as usize]);
        let n = t.nodes[leaf as usize];
        assert!(n.first_child.is_none());
        assert!(n.a.contains(path_a[2]) && n.b.contains(path_b[2]));
    }

    #[test]
    fn inserted_trees_pass_their_check_and_damaged_ones_fail_it() {
        let mut t = PairTree::default();
        t.insert(R.child(1).child(2), R.child(3));
        assert_eq!(t.check(), Ok(()));
        let mut mixed = t.clone();
        mixed.nodes[2].b = R.child(0);
        let e = mixed.check().unwrap_err();
        assert!(e.contains("the children of node 0 split neither"), "{e}");
        let mut orphan = t.clone();
        orphan.nodes.push(orphan.nodes[1]);
        assert!(orphan.check().unwrap_err().contains("no node's child"));
    }
}
