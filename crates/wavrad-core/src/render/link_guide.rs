//! Where a point's indirect light comes from, read off the solution's links
//! (Christensen, Stollnitz, Salesin & DeRose 1996 gathered a final pass from
//! the link structure): every two-point link into the element that holds
//! the point, or into one of its ancestors, names a source element and the
//! light it brings, ρ·F·L_{c→a} (eq. 12). A final gather draws source
//! elements in proportion to F·L and points on them uniformly by area, so
//! that its samples go where its light is: onto the bright part of a glossy
//! floor that lights a ceiling, not over the whole floor.
//!
//! Emission is left out of L (the direct light is gathered by shadow
//! rays), and so are cluster links (far, dim transfers that cosine rays
//! find). A gather draws from them where glossy sources bring much of a
//! point's light ([`crate::render::GLOSSY_SHARE_LINKED`]): there the light
//! is concentrated where a glossy surface reflects it, which cosine rays
//! find by chance; where diffuse surfaces light a point, cosine rays do as
//! well for less (a link sample costs a shadow ray and its density is
//! looked up for every sample). Source elements finer than [`CELL_LEVEL`] count towards their
//! ancestor at that level, so that each receiving leaf's sources are a
//! short list, made once per solution. The samples are one strategy of the
//! gather's multiple importance sampling
//! ([`crate::render::gather::indirect_radiance`]): their density at any
//! direction is known, and where the links misjudge the light, the cosine
//! rays still find it.

use super::discrete::DiscreteDistribution;
use crate::geometry::hierarchy::{ElementId, ElementTree};
use crate::scene::{Patch, Scene};
use crate::solve::gather::Source;
use crate::solve::Solution;
use glam::{DVec2, DVec3};
use rayon::prelude::*;
use std::collections::BTreeMap;

/// The finest level of a source element in a [`LinkGuide`]: 4^3 = 64 cells
/// per source surface at most.
pub const CELL_LEVEL: u32 = 3;

/// For every leaf of every surface's element tree, the source elements of
/// the links into it and its ancestors, by the light each brings
/// (view-independent, made once per solution).
#[derive(Debug, Clone, Default)]
pub struct LinkGuide {
    /// `leaves[p][n]`: leaf `n` of surface `p`'s tree (empty for inner nodes).
    leaves: Vec<Vec<LinkedSources>>,
}

/// A source element: (surface, element of level at most [`CELL_LEVEL`]).
type Cell = (u32, ElementId);

impl LinkGuide {
    /// The links of `solution`, each weighed by the light it carries now:
    /// F · mean(L_{c→a} − emission) over the channels.
    pub fn new(solution: &Solution) -> LinkGuide {
        let interactions = &solution.interactions;
        let leaves = (0..solution.scene.surfaces.len())
            .into_par_iter()
            .map(|p| {
                let tree = &solution.trees[p];
                let incoming = interactions.incoming.get(p).map_or(&[][..], |t| &t[..]);
                // Per receiving node, its sources' weights by cell.
                let mut by_node: Vec<BTreeMap<Cell, f64>> = vec![BTreeMap::new(); tree.nodes.len()];
                // Per receiving node, the light of its links: (all, from glossy sources).
                let mut light = vec![[0.0; 2]; tree.nodes.len()];
                for t in incoming {
                    let (q, node) = t.source.element();
                    let l = interactions.read(&t.source, &solution.radiance, &solution.directional);
                    let emission = solution.scene.surfaces[q as usize].emission;
                    let weight = t.form_factor * (l - emission).map(|x| x.max(0.0)).average();
                    let mut id = solution.trees[q as usize].nodes[node as usize].id;
                    while id.level > CELL_LEVEL {
                        id = id.parent().unwrap_or(ElementId::ROOT);
                    }
                    if let (true, Some(cells)) = (
                        weight > 0.0 && weight.is_finite(),
                        by_node.get_mut(t.receiver as usize),
                    ) {
                        *cells.entry((q, id)).or_default() += weight;
                        let glossy = match t.source {
                            Source::Glossy { .. } => weight,
                            Source::Element { .. } => 0.0,
                        };
                        let m = &mut light[t.receiver as usize];
                        (m[0], m[1]) = (m[0] + weight, m[1] + glossy);
                    }
                }
                let mut leaves = vec![LinkedSources::default(); tree.nodes.len()];
                collect(
                    tree,
                    (&by_node, &light),
                    0,
                    (&BTreeMap::new(), [0.0; 2]),
                    &mut leaves,
                );
                leaves
            })
            .collect();
        LinkGuide { leaves }
    }

    /// The sources of the links into leaf `leaf` of surface `p`'s tree and
    /// into its ancestors.
    pub fn at(&self, p: u32, leaf: u32) -> &LinkedSources {
        static NONE: LinkedSources = LinkedSources {
            cells: Vec::new(),
            choice: DiscreteDistribution::EMPTY,
            density: Vec::new(),
            glossy_share: 0.0,
        };
        (self.leaves.get(p as usize))
            .and_then(|l| l.get(leaf as usize))
            .unwrap_or(&NONE)
    }
}

/// Fill `leaves` below `node` with the sources of the links into each leaf
/// and its ancestors (`above`: those of the nodes above `node`, and the
/// light they bring: all, from glossy sources).
fn collect(
    tree: &ElementTree,
    (by_node, light): (&[BTreeMap<Cell, f64>], &[[f64; 2]]),
    node: usize,
    (above, above_light): (&BTreeMap<Cell, f64>, [f64; 2]),
    leaves: &mut [LinkedSources],
) {
    let mut here = above.clone();
    for (&cell, &w) in &by_node[node] {
        *here.entry(cell).or_default() += w;
    }
    let m = [0, 1].map(|k| above_light[k] + light[node][k]);
    match tree.nodes[node].first_child {
        Some(first) => {
            for child in first as usize..first as usize + 4 {
                collect(tree, (by_node, light), child, (&here, m), leaves);
            }
        }
        None => {
            let choice = DiscreteDistribution::new(here.values().copied());
            let density = (0..here.len())
                .zip(here.keys())
                .map(|(i, (_, id))| choice.probability(i, 0..0) * 4f64.powi(id.level as i32))
                .collect();
            leaves[node] = LinkedSources {
                choice,
                density,
                glossy_share: match m[0] > 0.0 {
                    true => m[1] / m[0],
                    false => 0.0,
                },
                cells: here.into_keys().collect(),
            };
        }
    }
}

/// The source elements of one receiving leaf's links ([`LinkGuide::at`]),
/// drawn in proportion to the light each brings.
#[derive(Debug, Clone, Default)]
pub struct LinkedSources {
    /// Ordered by surface, then element.
    cells: Vec<Cell>,
    choice: DiscreteDistribution,
    /// Per cell, its probability over its share of its surface's area.
    density: Vec<f64>,
    /// The share of the light the links bring that comes from glossy
    /// sources (directional radiance).
    glossy_share: f64,
}

impl LinkedSources {
    /// Whether no link brings light.
    pub fn is_empty(&self) -> bool {
        self.choice.is_empty()
    }

    /// The share of the light the links bring that comes from glossy
    /// sources: F·L_{c→a} of the links whose source is glossy over all
    /// (0 where no link brings light).
    pub fn glossy_share(&self) -> f64 {
        self.glossy_share
    }

    /// The source element that `u` ∈ \[0,1)² picks, and a point on it
    /// uniform by area: (surface, the point), in `scene`.
    pub fn sample(&self, scene: &Scene, u: DVec2) -> Option<(u32, DVec3)> {
        let drawn = self.choice.sample(u.x, 0..0)?;
        let (q, id) = self.cells[drawn.index];
        let patch = id.patch(&scene.surfaces[q as usize].patch);
        let y = patch.point_at(patch.square_to_param(DVec2::new(drawn.u, u.y)));
        Some((q, y))
    }

    /// Solid-angle density, seen from `x`, of [`LinkedSources::sample`]
    /// picking point `y` of surface `q` (`source`):
    /// Σ P(e) · |x−y|² / (cos θ_y · |e|) over the elements e that hold `y`.
    pub fn pdf(&self, (q, source): (u32, &Patch), x: DVec3, y: DVec3) -> f64 {
        let start = self.cells.partition_point(|&(s, _)| s < q);
        let end = start + self.cells[start..].partition_point(|&(s, _)| s == q);
        if start == end {
            return 0.0;
        }
        let d = y - x;
        let r2 = d.length_squared();
        let cos_y = -source.normal().dot(d) / r2.sqrt();
        if cos_y <= 0.0 {
            return 0.0;
        }
        let cells = &self.cells[start..end];
        // y's element at CELL_LEVEL; its ancestors are the others that can hold it.
        let mut finest = ElementId::ROOT;
        let mut local = source.clamp_param(source.param_of(y));
        for _ in 0..CELL_LEVEL {
            let (k, l) = source.locate_child(local);
            (finest, local) = (finest.child(k), l);
        }
        let mut per_area = 0.0;
        for level in 0..=CELL_LEVEL {
            let id = ElementId {
                level,
                path: finest.path >> (2 * (CELL_LEVEL - level)),
            };
            if let Ok(i) = cells.binary_search_by(|&(_, e)| e.cmp(&id)) {
                per_area += self.density[start + i];
            }
        }
        per_area * r2 / (cos_y * source.area())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::tracing::SceneTracer;
    use crate::progress::Silent;
    use crate::render::discrete::SurfaceDistribution;
    use crate::render::gather::{indirect_radiance, GatherPoint, GatherSources};
    use crate::render::mirror::MirrorImages;
    use crate::sampling::Samples;
    use crate::scene::Rgb;
    use crate::solve::{solve, SolveSettings};

    /// Rolled aluminium under a light, and a grey wall beside them that the
    /// floor's reflection lights: (the solution, the wall's surface).
    fn glossy_floor_and_wall() -> (Solution, u32) {
        let mut scene = crate::testing::mirror_floor_and_light();
        scene
            .surfaces
            .push(crate::testing::grey(Patch::Parallelogram {
                origin: DVec3::new(1.2, 0.0, 0.0),
                edge_s: DVec3::Z,
                edge_t: DVec3::Y,
            }));
        let solution = solve(&scene, &SolveSettings::default(), &Silent).unwrap();
        (solution, 2)
    }

    /// A point of the wall and its leaf's sources.
    fn wall_point(solution: &Solution, guide: &LinkGuide, wall: u32) -> (DVec3, LinkedSources) {
        let patch = &solution.scene.surfaces[wall as usize].patch;
        let uv = DVec2::new(0.3, 0.55);
        let leaf = solution.trees[wall as usize].locate(uv).0;
        (patch.point_at(uv), guide.at(wall, leaf).clone())
    }

    #[test]
    fn the_density_of_link_samples_integrates_to_one_and_holds_every_sample() {
        let (solution, wall) = glossy_floor_and_wall();
        let guide = LinkGuide::new(&solution);
        let (x, sources) = wall_point(&solution, &guide, wall);
        assert!(!sources.is_empty());
        assert!(sources.glossy_share() > 0.5, "{}", sources.glossy_share());
        // ∫ pdf · cos θ_y / r² dA over every surface, by a midpoint rule
        // whose points never fall on a cell's edge (the density is constant
        // on the cells, so the rule is exact up to rounding).
        let n = 64;
        let mut total = 0.0;
        for (q, s) in solution.scene.surfaces.iter().enumerate() {
            for i in 0..n * n {
                let uv = DVec2::new((i % n) as f64 + 0.5, (i / n) as f64 + 0.5) / n as f64;
                let y = s.patch.point_at(uv);
                let d = y - x;
                let cos_y = -s.patch.normal().dot(d.normalize());
                let pdf = sources.pdf((q as u32, &s.patch), x, y);
                if pdf > 0.0 {
                    total += pdf * cos_y / d.length_squared() * s.patch.area() / (n * n) as f64;
                }
            }
        }
        assert!((total - 1.0).abs() < 1e-9, "{total}");
        for k in 0..256 {
            let u = DVec2::new((k % 16) as f64 + 0.5, (k / 16) as f64 + 0.5) / 16.0;
            let (q, y) = sources.sample(&solution.scene, u).unwrap();
            let patch = &solution.scene.surfaces[q as usize].patch;
            assert!(
                q != wall && sources.pdf((q, patch), x, y) > 0.0,
                "sample {k}"
            );
        }
    }

    #[test]
    fn link_samples_leave_the_gather_unbiased_and_cut_its_noise() {
        let (solution, wall) = glossy_floor_and_wall();
        let guide = LinkGuide::new(&solution);
        let (x, sources) = wall_point(&solution, &guide, wall);
        let tracer = SceneTracer::new(&solution.scene);
        let normal = solution.scene.surfaces[wall as usize].patch.normal();
        // What leaves the floor towards x: a bump where it mirrors the light.
        let centre = DVec3::new(0.8, 0.5, 0.0);
        let outgoing = |q: u32, y: DVec3| match q {
            0 => Rgb::splat((-(y - centre).length_squared() / 0.01).exp()),
            _ => Rgb::ZERO,
        };
        // Mean and standard error over `runs` seeds, with `linked` samples.
        let estimate = |linked: u32| {
            let none = SurfaceDistribution::default();
            let mirrors = MirrorImages::default();
            let runs = 2000;
            let (mut sum, mut sq) = (0.0, 0.0);
            for seed in 0..runs {
                let point = GatherPoint {
                    surface: wall,
                    position: x,
                    normal,
                    samples: Samples::Hashed(seed),
                    shape: None,
                };
                let gather = GatherSources {
                    bright: &none,
                    mirrors: &mirrors,
                    bright_count: 0,
                    mirror_count: 0,
                    linked: &sources,
                    linked_count: linked,
                };
                let v = indirect_radiance(&solution.scene, &tracer, &point, 16, gather, outgoing);
                (sum, sq) = (sum + v.radiance[0], sq + v.radiance[0].powi(2));
            }
            let mean = sum / runs as f64;
            (
                mean,
                ((sq / runs as f64 - mean * mean) / runs as f64).sqrt(),
            )
        };
        let (cosine, e_cosine) = estimate(0);
        let (both, e_both) = estimate(16);
        assert!(cosine > 0.0);
        assert!(
            (both - cosine).abs() < 4.0 * (e_cosine.powi(2) + e_both.powi(2)).sqrt(),
            "{both} ± {e_both} against {cosine} ± {e_cosine}"
        );
        assert!(e_both < 0.5 * e_cosine, "{e_both} against {e_cosine}");
    }
}
