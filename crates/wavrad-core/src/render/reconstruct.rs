//! Radiance at a point of a surface from its Haar solution.
//!
//! * [`Reconstruction::Haar`]: the element average of the leaf containing the
//!   point — the projection itself, piecewise constant (for inspection).
//! * [`Reconstruction::Smooth`]: the paper (§6) proposes reconstructing with a
//!   basis bi-orthogonal to Haar. wavrad uses the lowest-order such pairing:
//!   Haar averages at the leaf level read as samples at element centres and
//!   interpolated with the linear B-spline (bilinear "hat") basis. A constant
//!   or linear radiance is reproduced exactly, and the result is continuous
//!   within a surface. Near a level change the neighbours are looked up
//!   through the tree, so mixed resolutions blend without seams. Within half
//!   an element of a parallelogram's boundary there is no centre beyond the
//!   point to interpolate towards, so [`TreeLookup`] extrapolates the
//!   line through the two nearest centres (clamped at zero): a radiance
//!   that falls off towards an edge, as it does across a directly lit
//!   floor or towards a contact line, keeps its slope up to the edge instead
//!   of flattening to the boundary element's average.
//! * [`Reconstruction::Limited`]: the smooth reconstruction of light that
//!   is smooth except across occluders (light that is not straight from
//!   the emitters: where that is evaluated per point, what is left). A
//!   neighbouring element whose value differs from the point's own by more
//!   than [`JUMP_RATIO`] is across such an edge, which the elements resolve
//!   no finer, and is blended as if it were that ratio away: a lit element
//!   beside a dark one is not darkened towards it, nor the dark one
//!   brightened (the ceiling beside a light hung just below it, above
//!   which the ceiling is hidden from the room).

use crate::geometry::hierarchy::{ElementId, ElementTree};
use crate::scene::{Patch, Rgb};
use crate::solve::Solution;
use glam::{DVec2, DVec3};

/// How radiance stored per element is reconstructed between elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reconstruction {
    /// Piecewise-constant Haar projection.
    Haar,
    /// Bilinear interpolation of leaf averages (dual linear-spline basis).
    Smooth,
    /// [`Reconstruction::Smooth`] with jumps between neighbouring elements
    /// beyond [`JUMP_RATIO`] limited to it.
    Limited,
}

/// Largest ratio, per channel, between a neighbouring element's value and
/// the point's own element's that [`Reconstruction::Limited`] blends as it
/// is (chosen by measurement: docs/decisions-measurements.md).
pub const JUMP_RATIO: f64 = 1.5;

/// A neighbouring element's value `v`, each channel limited to within
/// [`JUMP_RATIO`] of the `own` element's.
fn limit_jump(v: Rgb, own: Rgb) -> Rgb {
    Rgb([0, 1, 2].map(|c| {
        let (a, b) = (own[c] / JUMP_RATIO, own[c] * JUMP_RATIO);
        v[c].max(a.min(b)).min(a.max(b))
    }))
}

/// Radiance of `tree` at surface parameter `uv`.
pub fn radiance_at(tree: &ElementTree, radiance: &[Rgb], uv: DVec2, mode: Reconstruction) -> Rgb {
    let (leaf, _) = tree.locate(uv);
    let own = radiance[leaf as usize];
    if mode == Reconstruction::Haar {
        return own;
    }
    let root = &tree.nodes[0].patch;
    let mut out = Rgb::ZERO;
    for (centre, w) in hat_stencil(uv, tree.nodes[leaf as usize].id.level) {
        let v = radiance[tree.locate(root.clamp_param(centre)).0 as usize];
        out += match mode {
            Reconstruction::Limited => limit_jump(v, own),
            _ => v,
        } * w;
    }
    out
}

/// Most levels of an element tree that a [`TreeLookup`] indexes with a
/// grid (4⁶ cells, 32 KiB); a deeper tree is descended from the grid's
/// cells.
const GRID_LEVELS: u32 = 6;

/// One element tree's lookups done once: where each point lies (a grid of
/// the nodes at its finest levels, so that locating a point reads one cell
/// instead of descending the tree), and for the smooth reconstruction, for
/// each quadrant of each leaf of a parallelogram the four nodes the hat
/// stencil blends there (they are the same everywhere in the quadrant), so
/// that a smooth lookup also locates the point once instead of five times.
/// At the boundary the stencil is moved inwards by one element and blends
/// with weights beyond [0, 1]: linear extrapolation. Triangle trees, whose
/// leaves do not follow a square grid, are descended and looked up as
/// [`radiance_at`] does.
#[derive(Debug, Clone, Default)]
pub struct TreeLookup {
    /// For a parallelogram's tree, the node containing each cell.
    grid: Option<NodeGrid>,
    /// Per node (leaves only; empty for triangles): per quadrant
    /// (x ≥ ½) + 2·(y ≥ ½) of the leaf, the stencil.
    neighbours: Vec<[Stencil; 4]>,
}

/// The `side` × `side` cells of a parallelogram's parameter square, row by
/// row, each with the deepest node of at most the grid's level that
/// contains it.
#[derive(Debug, Clone)]
struct NodeGrid {
    side: usize,
    cells: Vec<Cell>,
    /// Some nodes of the grid have children (the tree is deeper than it).
    deeper: bool,
}

/// A grid cell's node and that node's level.
#[derive(Debug, Clone, Copy)]
struct Cell {
    node: u32,
    level: u32,
}

/// The four nodes a quadrant of a leaf blends, at offsets (0,0), (1,0),
/// (0,1), (1,1) of the stencil, and how many elements the stencil was moved
/// inwards along each axis (+1 at the lower boundary, −1 at the upper).
#[derive(Debug, Clone, Copy, Default)]
struct Stencil {
    nodes: [u32; 4],
    shift: [i8; 2],
}

impl NodeGrid {
    fn new(tree: &ElementTree) -> NodeGrid {
        let root = &tree.nodes[0].patch;
        let level = tree.depth().min(GRID_LEVELS);
        let side = 1usize << level;
        let cells = (0..side * side)
            .map(|c| {
                let centre = DVec2::new((c % side) as f64 + 0.5, (c / side) as f64 + 0.5);
                let path = ElementId::path_to(root, centre / side as f64, level);
                let node = tree.node_containing(path[level as usize]);
                let level = tree.nodes[node as usize].id.level;
                Cell { node, level }
            })
            .collect();
        NodeGrid {
            side,
            cells,
            deeper: tree.depth() > level,
        }
    }

    /// [`ElementTree::locate`] of `tree`, the tree this grid was made for:
    /// the same leaf and local parameter, bit for bit (scaling by a power
    /// of two and taking the integer part off are exact, as the descent's
    /// halvings are), also outside the unit square.
    fn locate(&self, tree: &ElementTree, uv: DVec2) -> (u32, DVec2) {
        let index = |v: f64, side: usize| v.floor().clamp(0.0, (side - 1) as f64);
        let cell = |v: f64| index(v * self.side as f64, self.side) as usize;
        let Cell { node, level } = self.cells[cell(uv.y) * self.side + cell(uv.x)];
        let side = 1usize << level;
        let at = uv * side as f64;
        let local = at - DVec2::new(index(at.x, side), index(at.y, side));
        match self.deeper {
            true => tree.locate_from(node, local),
            false => (node, local),
        }
    }
}

impl TreeLookup {
    /// Index the leaves of `tree` and look up the stencil neighbours of
    /// every leaf.
    pub fn new(tree: &ElementTree) -> TreeLookup {
        let root = tree.nodes[0].patch;
        if !matches!(root, Patch::Parallelogram { .. }) {
            return TreeLookup::default();
        }
        let neighbours = tree
            .nodes
            .iter()
            .map(|node| {
                if node.first_child.is_some() {
                    return [Stencil::default(); 4];
                }
                let level = node.id.level;
                let h = 0.5f64.powi(level as i32);
                [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)].map(|(s, t)| {
                    let uv = root.param_of(node.patch.point_at(DVec2::new(s, t)));
                    // Centres beyond the boundary: move the stencil inwards
                    // (a level-0 tree has no second centre to move to).
                    let lower = stencil_centres(uv, level)[0].0;
                    let shift = [lower.x, lower.y].map(|c| match () {
                        _ if level == 0 => 0,
                        _ if c < 0.0 => 1,
                        _ if c + h > 1.0 => -1,
                        _ => 0,
                    });
                    let moved = uv + h * DVec2::new(f64::from(shift[0]), f64::from(shift[1]));
                    let nodes = stencil_centres(moved, level)
                        .map(|(centre, _)| tree.locate(root.clamp_param(centre)).0);
                    Stencil { nodes, shift }
                })
            })
            .collect();
        TreeLookup {
            grid: Some(NodeGrid::new(tree)),
            neighbours,
        }
    }

    /// The leaf of `tree` (the tree this lookup was made for) containing
    /// `uv`, and `uv` in that leaf: [`ElementTree::locate`].
    pub fn locate(&self, tree: &ElementTree, uv: DVec2) -> (u32, DVec2) {
        match &self.grid {
            Some(grid) => grid.locate(tree, uv),
            None => tree.locate(uv),
        }
    }

    /// The piecewise-constant radiance of `tree` at `uv`: [`radiance_at`]
    /// with [`Reconstruction::Haar`].
    pub fn haar(&self, tree: &ElementTree, radiance: &[Rgb], uv: DVec2) -> Rgb {
        radiance[self.locate(tree, uv).0 as usize]
    }

    /// The smooth radiance of `tree` at `uv`: [`radiance_at`] with `mode`,
    /// [`Reconstruction::Smooth`] or [`Reconstruction::Limited`].
    fn smooth(&self, tree: &ElementTree, radiance: &[Rgb], uv: DVec2, mode: Reconstruction) -> Rgb {
        if self.neighbours.is_empty() {
            return radiance_at(tree, radiance, uv, mode);
        }
        let (leaf, local) = self.locate(tree, uv);
        let (qx, qy) = (local.x >= 0.5, local.y >= 0.5);
        let stencil = self.neighbours[leaf as usize][usize::from(qx) + 2 * usize::from(qy)];
        // Position within the stencil: half an element past the quadrant's
        // lower-left centre, less the inward move (outside [0, 1] there).
        let f = DVec2::new(
            local.x + 0.5 - f64::from(u8::from(qx)) - f64::from(stencil.shift[0]),
            local.y + 0.5 - f64::from(u8::from(qy)) - f64::from(stencil.shift[1]),
        )
        .clamp(DVec2::splat(-0.5), DVec2::splat(1.5));
        let values = stencil.nodes.map(|n| radiance[n as usize]);
        let values = match mode {
            Reconstruction::Limited => values.map(|v| limit_jump(v, radiance[leaf as usize])),
            _ => values,
        };
        blend(values, f).map(|v| v.max(0.0))
    }

    /// The radiance of `tree` at `uv` reconstructed as `mode`.
    pub fn radiance(
        &self,
        tree: &ElementTree,
        radiance: &[Rgb],
        uv: DVec2,
        mode: Reconstruction,
    ) -> Rgb {
        match mode {
            Reconstruction::Haar => self.haar(tree, radiance, uv),
            smooth => self.smooth(tree, radiance, uv, smooth),
        }
    }
}

/// Bilinear blend of the values at stencil offsets (0,0), (1,0), (0,1),
/// (1,1) at fractional position `f`.
fn blend(values: [Rgb; 4], f: DVec2) -> Rgb {
    let w = hat_weights(f);
    let mut out = Rgb::ZERO;
    for (v, w) in values.into_iter().zip(w) {
        out += v * w;
    }
    out
}

fn hat_weights(f: DVec2) -> [f64; 4] {
    [
        (1.0 - f.x) * (1.0 - f.y),
        f.x * (1.0 - f.y),
        (1.0 - f.x) * f.y,
        f.x * f.y,
    ]
}

/// The centres of the four elements of `level`'s grid around `uv` (offsets
/// (0,0), (1,0), (0,1), (1,1) from the lower-left one) and the fractional
/// position of `uv` between them.
fn stencil_centres(uv: DVec2, level: u32) -> [(DVec2, f64); 4] {
    let h = 0.5f64.powi(level as i32);
    let g = uv / h - DVec2::splat(0.5);
    let base = g.floor();
    let f = (g - base).clamp(DVec2::ZERO, DVec2::ONE);
    let w = hat_weights(f);
    let centre = |k: usize| {
        let offset = DVec2::new((k & 1) as f64, (k >> 1) as f64);
        ((base + offset + DVec2::splat(0.5)) * h, w[k])
    };
    [centre(0), centre(1), centre(2), centre(3)]
}

/// The bilinear ("hat") reconstruction at parameter `uv` from element
/// averages at `level`: the centres of the four elements of that level's
/// grid around `uv`, with their weights (zero-weight centres left out).
pub fn hat_stencil(uv: DVec2, level: u32) -> impl Iterator<Item = (DVec2, f64)> {
    stencil_centres(uv, level)
        .into_iter()
        .filter(|&(_, w)| w > 0.0)
}

/// The directional radiance L_{q→s} that glossy surface `q` of `solution`
/// sends from its point `y` towards point `x` of surface `s`, on top of its
/// element radiance (the light its non-Lambertian lobes reflect): the
/// values of the element pairs (a ∋ y, b), smooth over the receiver's
/// elements b around `x` (a gather integrates over y already, so only x
/// needs the smoothing); zero where the solve made no structure (q, s).
pub fn directional_radiance(solution: &Solution, q: u32, y: DVec3, s: u32, x: DVec3) -> Rgb {
    let surface = &solution.scene.surfaces[q as usize];
    let uv_y = surface.patch.clamp_param(surface.patch.param_of(y));
    let Some(&index) = solution.interactions.structure_of.get(&(q, s)) else {
        return Rgb::ZERO;
    };
    let receiver = &solution.scene.surfaces[s as usize].patch;
    let uv_x = receiver.param_of(x);
    let depth = solution.settings.three_point_refine().receiver_max_level;
    let path_y = ElementId::path_to(&surface.patch, uv_y, depth);
    let tree = &solution.interactions.directional[index as usize].tree;
    let values = &solution.directional[index as usize];
    let leaf_towards = |uv: DVec2| {
        let path_x = ElementId::path_to(receiver, receiver.clamp_param(uv), depth);
        tree.leaf_at(|l| path_y[l as usize], |l| path_x[l as usize]) as usize
    };
    let level = tree.nodes[leaf_towards(uv_x)].b.level;
    let mut out = Rgb::ZERO;
    for (centre, w) in hat_stencil(uv_x, level) {
        out += values[leaf_towards(centre)] * w;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// The unit floor's tree with every element at level 3.
    fn uniform_level_3_tree() -> ElementTree {
        let ids: BTreeSet<ElementId> = (0..64u64)
            .map(|path| ElementId { level: 3, path })
            .collect();
        ElementTree::build(&crate::testing::unit_floor(), &ids)
    }

    #[test]
    fn smooth_reproduces_a_linear_ramp_and_haar_is_piecewise_constant() {
        let tree = uniform_level_3_tree();
        // Radiance = element-average of f(s,t) = s (linear in s).
        let radiance: Vec<Rgb> = tree
            .nodes
            .iter()
            .map(|n| Rgb::splat(n.patch.centroid().x))
            .collect();
        for &(s, t) in &[(0.3, 0.4), (0.5, 0.5), (0.61, 0.2)] {
            let uv = DVec2::new(s, t);
            let smooth = radiance_at(&tree, &radiance, uv, Reconstruction::Smooth)[0];
            assert!((smooth - s).abs() < 1e-12, "{smooth} vs {s}");
            let haar = radiance_at(&tree, &radiance, uv, Reconstruction::Haar)[0];
            assert!((haar - ((s * 8.0).floor() + 0.5) / 8.0).abs() < 1e-12);
        }
    }

    /// Light that steps down across an occluder's edge between two
    /// elements: the smooth reconstruction darkens the lit element towards
    /// the dark one, the limited one only by as much as a neighbour
    /// [`JUMP_RATIO`] darker would; a gentle ramp it reproduces exactly, as
    /// the smooth one does.
    #[test]
    fn limited_reconstruction_keeps_a_step_from_spreading_and_a_ramp_exact() {
        let tree = uniform_level_3_tree();
        let lookup = TreeLookup::new(&tree);
        let step: Vec<Rgb> = (tree.nodes.iter())
            .map(|n| Rgb::splat(if n.patch.centroid().x < 0.5 { 1.0 } else { 0.0 }))
            .collect();
        // In the lit element [0.375, 0.5], nearer the dark one than its centre.
        let uv = DVec2::new(0.49, 0.3);
        let f = (0.49 - 0.4375) / 0.125;
        for read in [
            lookup.radiance(&tree, &step, uv, Reconstruction::Limited)[0],
            radiance_at(&tree, &step, uv, Reconstruction::Limited)[0],
        ] {
            assert!((read - (1.0 - f + f / JUMP_RATIO)).abs() < 1e-12, "{read}");
        }
        let smooth = lookup.radiance(&tree, &step, uv, Reconstruction::Smooth)[0];
        assert!((smooth - (1.0 - f)).abs() < 1e-12, "{smooth}");
        // The dark element stays dark.
        let dark = DVec2::new(0.51, 0.3);
        assert_eq!(
            lookup.radiance(&tree, &step, dark, Reconstruction::Limited)[0],
            0.0
        );
        // Neighbours within the ratio of each other: blended as they are.
        let ramp: Vec<Rgb> = (tree.nodes.iter())
            .map(|n| Rgb::splat(2.0 + n.patch.centroid().x - 0.5 * n.patch.centroid().y))
            .collect();
        for &(s, t) in &[(0.3, 0.4), (0.02, 0.97), (0.61, 0.2)] {
            let uv = DVec2::new(s, t);
            let limited = lookup.radiance(&tree, &ramp, uv, Reconstruction::Limited)[0];
            assert!(
                (limited - (2.0 + s - 0.5 * t)).abs() < 1e-12,
                "at ({s}, {t}): {limited}"
            );
        }
    }

    /// A tree refined unevenly, down to two levels below the lookup's
    /// grid in one corner: locating through the grid finds the leaf and
    /// local parameter the tree's descent finds, to the bit, on cell
    /// boundaries and outside the unit square too.
    #[test]
    fn tree_lookup_locates_as_the_tree_descent_does() {
        let root = crate::testing::unit_floor();
        let deep = GRID_LEVELS + 2;
        let mut ids = BTreeSet::new();
        ids.insert(ElementId {
            level: deep,
            path: 0,
        });
        ids.insert(ElementId { level: 3, path: 63 });
        ids.insert(ElementId { level: 2, path: 6 });
        let tree = ElementTree::build(&root, &ids);
        assert_eq!(tree.depth(), deep);
        let lookup = TreeLookup::new(&tree);
        let n = 97;
        let edges = [0.0, 0.5, 1.0, 1.0 / 256.0, -0.25, 1.5, 0.999_999_999];
        let coords: Vec<f64> = (0..=n).map(|i| i as f64 / n as f64).chain(edges).collect();
        for &s in &coords {
            for &t in &coords {
                let uv = DVec2::new(s, t);
                let (want, got) = (tree.locate(uv), lookup.locate(&tree, uv));
                assert_eq!(want.0, got.0, "leaf at {uv}");
                assert_eq!(
                    want.1.to_array().map(f64::to_bits),
                    got.1.to_array().map(f64::to_bits)
                );
            }
        }
    }

    #[test]
    fn smooth_lookup_keeps_a_ramps_slope_up_to_the_boundary() {
        let root = crate::testing::unit_floor();
        // Level 2 everywhere, one quadrant refined to level 3 (a level
        // change at the boundary too).
        let mut ids = BTreeSet::new();
        for path in 0..16u64 {
            if path == 0 {
                (0..4).for_each(|c| _ = ids.insert(ElementId { level: 3, path: c }));
            } else {
                ids.insert(ElementId { level: 2, path });
            }
        }
        let tree = ElementTree::build(&root, &ids);
        let ramp = |p: DVec3| 1.0 + 2.0 * p.x - 0.5 * p.y;
        let radiance: Vec<Rgb> = tree
            .nodes
            .iter()
            .map(|n| Rgb::splat(ramp(n.patch.centroid())))
            .collect();
        let lookup = TreeLookup::new(&tree);
        for &(s, t) in &[
            (0.01, 0.5),
            (0.99, 0.02),
            (0.5, 0.999),
            (0.0, 0.0),
            (0.03, 0.04),
            (1.0, 1.0),
        ] {
            let uv = DVec2::new(s, t);
            let got = lookup.smooth(&tree, &radiance, uv, Reconstruction::Smooth)[0];
            let want = ramp(DVec3::new(s, t, 0.0));
            assert!((got - want).abs() < 1e-12, "at ({s}, {t}): {got} vs {want}");
        }
        // A ramp that crosses zero inside the boundary element stops at
        // zero instead of going below it.
        let steep: Vec<Rgb> = tree
            .nodes
            .iter()
            .map(|n| Rgb::splat(4.0 * n.patch.centroid().x - 0.2))
            .collect();
        assert_eq!(
            lookup.smooth(&tree, &steep, DVec2::new(0.0, 0.5), Reconstruction::Smooth)[0],
            0.0
        );
    }
}
