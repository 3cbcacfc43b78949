//! Hierarchical push–pull (paper §4.2, "2d_reconstruct_decompose"): radiance
//! gathered at any level is pushed down to the leaves, where emission is
//! added, and area-weighted averages are pulled back up, so every node holds
//! the average radiance over its element. The same holds for the element-pair
//! trees of directional radiance (the paper's 3d_reconstruct_decompose).

use crate::geometry::hierarchy::{ElementTree, Hierarchy};
use crate::scene::Rgb;
use glam::DVec3;

/// Given the radiance `gathered` at each node of `tree` and the surface's
/// emitted radiance, return the new radiance average of every node.
///
/// `exposure`, the exposed fraction of each node's area
/// ([`crate::kernel::exposure`]), makes the averages over exposed areas; without it
/// they are over whole elements. `limit`, a factor per node
/// ([`reflection_limits`]), scales the reflected light that reaches each
/// leaf (its own and its ancestors'), never the emission; so does
/// `texture`, per channel: a textured surface's leaves reflect by their
/// own average albedo ([`crate::geometry::texture::texture_scales`]).
pub fn push_pull(
    tree: &impl Hierarchy,
    gathered: &[Rgb],
    emission: Rgb,
    exposure: Option<&[f64]>,
    limit: Option<&[f64]>,
    texture: Option<&[Rgb]>,
) -> Vec<Rgb> {
    let mut radiance = vec![Rgb::ZERO; tree.node_count()];
    let mut pass = Pass {
        tree,
        gathered,
        emission,
        exposure,
        limit,
        texture,
        out: &mut radiance,
    };
    pass.visit(0, Rgb::ZERO);
    radiance
}

/// The factor that keeps each leaf of `tree` from reflecting more light
/// than reaches it, for a surface of `reflectance` (its largest channel).
/// `form_factors` holds at each node the sum of the form factors of the
/// links gathered there; ΣF, the sum over a leaf and its ancestors, is that
/// of everything the leaf receives from. ΣF is at most 1 in any scene
/// (Cohen & Wallace 1993, §2.5), but quadrature error scatters it by a few
/// per cent either side, and links that overlap (surfaces closer together
/// than their elements resolve) push it far above. Where ρ·ΣF exceeds 1
/// the leaf would give out more light than it gets, and Gauss–Seidel could
/// diverge: its factor, 1/ΣF, brings its form factors back to their bound.
/// Elsewhere it is 1 (and at inner nodes): clipping the scatter's high
/// side alone would darken closed scenes for nothing (the furnace tests).
/// Returns the factors and how many leaves needed one below 1.
pub fn reflection_limits(
    tree: &impl Hierarchy,
    form_factors: &[Rgb],
    reflectance: f64,
) -> (Vec<f64>, usize) {
    let sums = push_pull(tree, form_factors, Rgb::ZERO, None, None, None);
    let mut limited = 0;
    let limits = (0..tree.node_count())
        .map(|node| {
            let sum = sums[node][0];
            if tree.first_child(node).is_some() || reflectance * sum <= 1.0 {
                1.0
            } else {
                limited += 1;
                1.0 / sum
            }
        })
        .collect();
    (limits, limited)
}

struct Pass<'a, T> {
    tree: &'a T,
    gathered: &'a [Rgb],
    emission: Rgb,
    exposure: Option<&'a [f64]>,
    limit: Option<&'a [f64]>,
    texture: Option<&'a [Rgb]>,
    out: &'a mut [Rgb],
}

impl<T: Hierarchy> Pass<'_, T> {
    fn visit(&mut self, node: usize, above: Rgb) -> Rgb {
        let down = above + self.gathered[node];
        let value = match self.tree.first_child(node) {
            None => {
                let reflected = down * self.limit.map_or(1.0, |l| l[node]);
                self.emission + self.texture.map_or(reflected, |t| reflected * t[node])
            }
            Some(first) => {
                // Children have equal areas: weigh them by their exposed
                // fractions, or equally when none is exposed.
                let weights = self
                    .exposure
                    .map(|e| [0, 1, 2, 3].map(|k| e[first + k]))
                    .filter(|w| w.iter().sum::<f64>() > 0.0)
                    .unwrap_or([1.0; 4]);
                let total: f64 = weights.iter().sum();
                let mut sum = Rgb::ZERO;
                for (k, w) in weights.into_iter().enumerate() {
                    sum += self.visit(first + k, down) * w;
                }
                sum / total
            }
        };
        self.out[node] = value;
        value
    }
}

/// Radiance gathered at the nodes of an element tree, each a linear function
/// over its element: an average and, per channel, a gradient
/// ([`crate::kernel::form_factor::relative_gradient`]).
#[derive(Debug, Clone)]
pub struct Gathered {
    average: Vec<Rgb>,
    gradient: Vec<[DVec3; 3]>,
}

impl Gathered {
    /// Nothing gathered yet at the `nodes` nodes of a tree.
    pub fn new(nodes: usize) -> Gathered {
        Gathered {
            average: vec![Rgb::ZERO; nodes],
            gradient: Vec::new(),
        }
    }

    /// Gather `value` at `node`, varying over its element as
    /// `value · (1 + relative_gradient·(x − centroid))`.
    pub fn add(&mut self, node: usize, value: Rgb, relative_gradient: DVec3) {
        self.average[node] += value;
        if relative_gradient != DVec3::ZERO {
            if self.gradient.is_empty() {
                self.gradient = vec![[DVec3::ZERO; 3]; self.average.len()];
            }
            let g = &mut self.gradient[node];
            (0..3).for_each(|ch| g[ch] += value[ch] * relative_gradient);
        }
    }

    /// The averages to push down ([`push_pull`]), with every node's linear
    /// part moved to the leaves under it, each getting its value at the
    /// leaf's centroid (a linear function's average over the leaf).
    pub fn into_averages(mut self, tree: &ElementTree) -> Vec<Rgb> {
        if !self.gradient.is_empty() {
            self.push_linear(tree, 0, [DVec3::ZERO; 3], Rgb::ZERO);
        }
        self.average
    }

    /// Visit `node` with the ancestors' linear parts Σ g·(x − c) written as
    /// `slope·x − offset` per channel.
    fn push_linear(&mut self, tree: &ElementTree, node: usize, slope: [DVec3; 3], offset: Rgb) {
        let centroid = tree.nodes[node].patch.centroid();
        match tree.first_child(node) {
            None => {
                self.average[node] += Rgb(slope.map(|s| s.dot(centroid))) - offset;
            }
            Some(first) => {
                let g = self.gradient[node];
                let slope = [0, 1, 2].map(|ch| slope[ch] + g[ch]);
                let offset = offset + Rgb(g.map(|g| g.dot(centroid)));
                for child in first..first + 4 {
                    self.push_linear(tree, child, slope, offset);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::hierarchy::{ElementId, ElementTree};
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
        let mut gathered = vec![Rgb::ZERO; tree.nodes.len()];
        gathered[0] = Rgb([1.0, 2.0, 3.0]); // at the root: reaches every leaf
        let deep = tree.index_of(ElementId::ROOT.child(2).child(1)).unwrap() as usize;
        gathered[deep] = Rgb([16.0, 0.0, 0.0]); // 1/16 of the area
        let l = push_pull(&tree, &gathered, Rgb::splat(0.5), None, None, None);
        assert_eq!(l[deep], Rgb([17.5, 2.5, 3.5]));
        assert_eq!(l[0], Rgb([2.5, 2.5, 3.5]));
    }

    #[test]
    fn a_texture_scales_each_leafs_reflected_light_not_its_emission() {
        let root = Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X,
            edge_t: DVec3::Y,
        };
        let ids: BTreeSet<_> = [ElementId::ROOT.child(0)].into_iter().collect();
        let tree = ElementTree::build(&root, &ids);
        let mut gathered = vec![Rgb::ZERO; tree.nodes.len()];
        gathered[0] = Rgb::splat(1.0);
        // Children albedos 1.5, 0.5, 1.5, 0.5 times the surface's (mean 1).
        let mut texture = vec![Rgb::splat(1.0); tree.nodes.len()];
        for (k, scale) in [1.5, 0.5, 1.5, 0.5].into_iter().enumerate() {
            texture[1 + k] = Rgb([scale, 1.0, 0.0]);
        }
        let l = push_pull(
            &tree,
            &gathered,
            Rgb::splat(0.25),
            None,
            None,
            Some(&texture),
        );
        assert_eq!(l[1], Rgb([1.75, 1.25, 0.25]));
        assert_eq!(l[2], Rgb([0.75, 1.25, 0.25]));
        assert_eq!(l[0], Rgb([1.25, 1.25, 0.25]));
    }

    #[test]
    fn leaves_that_would_reflect_more_than_they_receive_are_limited() {
        let root = Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X,
            edge_t: DVec3::Y,
        };
        let ids: BTreeSet<_> = [ElementId::ROOT.child(1)].into_iter().collect();
        let tree = ElementTree::build(&root, &ids);
        let over = tree.index_of(ElementId::ROOT.child(1)).unwrap() as usize;
        // Form factors 0.6 at the root, 0.9 more at child 1: ΣF 1.5 there.
        let mut sums = vec![Rgb::ZERO; tree.nodes.len()];
        sums[0] = Rgb::splat(0.6);
        sums[over] = Rgb::splat(0.9);
        let (limits, limited) = reflection_limits(&tree, &sums, 0.8);
        assert_eq!(limited, 1);
        for (node, limit) in limits.iter().enumerate() {
            let expect = if node == over { 1.0 / 1.5 } else { 1.0 };
            assert!((limit - expect).abs() < 1e-12, "{node}: {limit}");
        }
        // A darker surface reflects less than it receives as it is.
        assert_eq!(reflection_limits(&tree, &sums, 0.6).1, 0);
        // The limit scales what reaches the leaf, never its emission.
        let mut gathered = vec![Rgb::ZERO; tree.nodes.len()];
        gathered[0] = Rgb::splat(3.0);
        let l = push_pull(&tree, &gathered, Rgb::splat(1.0), None, Some(&limits), None);
        assert!((l[over][0] - 3.0).abs() < 1e-12, "{l:?}");
        assert!((l[over - 1][0] - 4.0).abs() < 1e-12, "{l:?}");
    }

    #[test]
    fn gathered_gradients_reach_the_leaves_and_keep_the_average() {
        let root = Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X,
            edge_t: DVec3::Y,
        };
        let deep = ElementId::ROOT.child(3).child(0);
        let tree = ElementTree::build(&root, &[deep].into_iter().collect());
        let mut gathered = Gathered::new(tree.nodes.len());
        let g = DVec3::new(0.4, -0.2, 0.0);
        gathered.add(0, Rgb([1.0, 2.0, 0.0]), g);
        let child = tree.index_of(ElementId::ROOT.child(3)).unwrap() as usize;
        gathered.add(child, Rgb([0.0, 0.0, 4.0]), -g);
        let averages = gathered.into_averages(&tree);
        assert_eq!(averages[0], Rgb([1.0, 2.0, 0.0])); // the constant stays put
        let l = push_pull(&tree, &averages, Rgb::ZERO, None, None, None);
        // Each leaf holds the linear functions over it at its centroid.
        let leaf = tree.index_of(deep).unwrap() as usize;
        let x = DVec3::new(0.625, 0.625, 0.0);
        let (centre, quadrant) = (DVec3::new(0.5, 0.5, 0.0), DVec3::new(0.75, 0.75, 0.0));
        let expect = [
            1.0 + g.dot(x - centre),
            2.0 * (1.0 + g.dot(x - centre)),
            4.0 * (1.0 - g.dot(x - quadrant)),
        ];
        // And every element's average is what it gathered.
        for ch in 0..3 {
            assert!((l[leaf][ch] - expect[ch]).abs() < 1e-12, "{l:?}");
            assert!((l[0][ch] - [1.0, 2.0, 1.0][ch]).abs() < 1e-12, "{l:?}");
            assert!(
                (l[child][ch]
                    - [1.0, 2.0, 4.0][ch]
                    - g.dot(quadrant - centre) * [1.0, 2.0, 0.0][ch])
                    .abs()
                    < 1e-12,
                "{l:?}"
            );
        }
    }
}
