//! Hierarchical push–pull (paper §4.2, "2d_reconstruct_decompose"): radiance
//! gathered at any level is pushed down to the leaves, where emission is
//! added, and area-weighted averages are pulled back up, so every node holds
//! the average radiance over its element. The same holds for the element-pair
//! trees of directional radiance (the paper's 3d_reconstruct_decompose).

use crate::hierarchy::Hierarchy;
use crate::scene::Rgb;

/// Given the radiance `gathered` at each node of `tree` and the surface's
/// emitted radiance, return the new radiance average of every node.
///
/// `exposure`, the exposed fraction of each node's area
/// ([`crate::exposure`]), makes the averages over exposed areas; without it
/// they are over whole elements.
pub fn push_pull(
    tree: &impl Hierarchy,
    gathered: &[Rgb],
    emission: Rgb,
    exposure: Option<&[f64]>,
) -> Vec<Rgb> {
    let mut radiance = vec![[0.0; 3]; tree.node_count()];
    let mut pass = Pass {
        tree,
        gathered,
        emission,
        exposure,
        out: &mut radiance,
    };
    pass.visit(0, [0.0; 3]);
    radiance
}

struct Pass<'a, T> {
    tree: &'a T,
    gathered: &'a [Rgb],
    emission: Rgb,
    exposure: Option<&'a [f64]>,
    out: &'a mut [Rgb],
}

impl<T: Hierarchy> Pass<'_, T> {
    fn visit(&mut self, node: usize, above: Rgb) -> Rgb {
        let down = add(above, self.gathered[node]);
        let value = match self.tree.first_child(node) {
            None => add(self.emission, down),
            Some(first) => {
                // Children have equal areas: weigh them by their exposed
                // fractions, or equally when none is exposed.
                let weights = self
                    .exposure
                    .map(|e| [0, 1, 2, 3].map(|k| e[first + k]))
                    .filter(|w| w.iter().sum::<f64>() > 0.0)
                    .unwrap_or([1.0; 4]);
                let total: f64 = weights.iter().sum();
                let mut sum = [0.0; 3];
                for (k, w) in weights.into_iter().enumerate() {
                    let child = self.visit(first + k, down);
                    (0..3).for_each(|ch| sum[ch] += w * child[ch]);
                }
                sum.map(|x| x / total)
            }
        };
        self.out[node] = value;
        value
    }
}

fn add(a: Rgb, b: Rgb) -> Rgb {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hierarchy::{ElementId, ElementTree};
    use crate::scene::Patch;
    use glam::DVec3;
    use std::collections::BTreeSet;

    #[test]
    fn push_pull_conserves_the_area_average() {
        let root = Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X,
            edge_t: DVec3::Y,
        };
        let ids: BTreeSet<_> = [ElementId::ROOT.child(2).child(1)].into_iter().collect();
        let tree = ElementTree::build(&root, &ids);
        let mut gathered = vec![[0.0; 3]; tree.nodes.len()];
        gathered[0] = [1.0, 2.0, 3.0]; // at the root: reaches every leaf
        let deep = tree.index_of(ElementId::ROOT.child(2).child(1)).unwrap() as usize;
        gathered[deep] = [16.0, 0.0, 0.0]; // 1/16 of the area
        let l = push_pull(&tree, &gathered, [0.5, 0.5, 0.5], None);
        assert_eq!(l[deep], [17.5, 2.5, 3.5]);
        assert_eq!(l[0], [2.5, 2.5, 3.5]);
    }
}
