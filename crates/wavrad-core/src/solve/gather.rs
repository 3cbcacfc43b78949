//! Gathering (paper §4.2, compute_radiance_solution): each diffuse element
//! collects ρ·F·L_{c→a} over its incoming two-point links (eq. 12), each
//! glossy element pair collects R·L_{c→a} over its three-point links
//! (eq. 13). L_{c→a} is the source element's radiance when the source is
//! diffuse, and its directional radiance towards the receiver when glossy.
//!
//! Beyond the paper's piecewise-constant push, a two-point transfer into an
//! element with children carries how its form factor varies over that
//! element ([`receiver_gradient`]), and the light it gathers reaches the
//! leaves with that slope ([`Gathered`]): the form factors of every leaf,
//! not only of every element a link names, then sum to what they should.
//!
//! A glossy surface with a Lambertian lobe ([`crate::scene::brdf::Brdf::lambertian`])
//! is both: its elements gather ρ_d·F·L_{c→a} over two-point links like a
//! diffuse surface's, and its element pairs only the light the rest of its
//! BRDF reflects (R projects f less ρ_d/π). Its radiance towards a receiver
//! is the sum: the element's own (emission and Lambertian reflection) plus
//! the pair's directional radiance. Without the split, the Lambertian lobe
//! went through three-point links, whose glossy elements stop at
//! `three_point_max_level`: a Ward floor of the glossy Cornell box (with
//! its specular lobe off, the same surface as a diffuse one) left the small
//! box's sides next to it 11–45 % off their diffuse-floor values.

use crate::geometry::hierarchy::{ElementId, ElementRef, ElementTree, Hierarchy};
use crate::geometry::pair_tree::PairTree;
use crate::geometry::texture::texture_scales;
use crate::kernel::exposure::PairExposure;
use crate::kernel::form_factor::{point_to_polygon, relative_gradient};
use crate::kernel::lights::{grid, reflected_towards};
use crate::kernel::KernelContext;
use crate::refine::light_links::{LightLink, SKY_GRID};
use crate::refine::three_point_projection::ThreePointLink;
use crate::refine::two_point_projection::Link;
use crate::scene::brdf::{BrdfFlags, BrdfModel};
use crate::scene::{Patch, Rgb, Scene};
use crate::solve::cluster_gather::{ClusterTransfers, FarField};
use crate::solve::glossy_clusters::{self, bin_of, GlossyReflectors, BINS};
use crate::solve::push_pull::{reflection_limits, Gathered};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::ops::Range;

/// Directional radiance L_{p→q} of a glossy surface p towards surface q.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Directional {
    /// The glossy surface.
    pub p: u32,
    /// The receiving surface.
    pub q: u32,
    /// Element pairs (a on p, b on q).
    pub tree: PairTree,
}

/// Where a transfer reads the radiance L_{c→a} it carries.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Source {
    /// A source element without a directional structure towards the
    /// receiver: `radiance[surface][node]`, or its children's by their
    /// `shares`; a glossy one's lobes add their light per bin towards the
    /// receiver ([`FarField::glossy`]).
    Element {
        /// Source surface.
        surface: u32,
        /// Node in its element tree.
        node: u32,
        /// How its children share the link ([`Shares`]).
        shares: Shares,
        /// On a glossy source, the range in [`Interactions::bins`] of the
        /// bins of its hemisphere the transfer passes through, each with
        /// its share ([`glossy_clusters::spread`]); empty on a diffuse one.
        towards: Range<u32>,
    },
    /// A glossy source: its element's own radiance,
    /// `radiance[surface][node]` (emission and Lambertian reflection; or
    /// its children's by their `shares`), plus the area-weighted mean of
    /// `directional[structure]` over `nodes` (node, weight) covering the
    /// pair (c, a).
    Glossy {
        /// Source surface.
        surface: u32,
        /// Node in its element tree.
        node: u32,
        /// Index of the directional structure L_{r→p}.
        structure: u32,
        /// Range in [`Interactions::covers`].
        nodes: Range<u32>,
        /// How its children share the link ([`Shares`]).
        shares: Shares,
    },
}

/// How a link's throughput divides between the four children of its
/// source element, T(child k, receiver) / T(element, receiver) in
/// [`Patch::subdivide`] order, in units of 1/[`u16::MAX`]; all zero
/// ([`Shares::NONE`]) where the element is read whole (a leaf). A
/// transfer reads the children's radiance, each weighted by its share
/// ([`Interactions::children`] finds them): the element's average would
/// weigh a bright part the receiver sees little of (the floor's lit centre
/// seen from a wall beside an open side) as much as one it sees well.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct Shares(pub [u16; 4]);

impl Shares {
    /// The element read whole.
    pub const NONE: Shares = Shares([0; 4]);

    /// Shares proportional to `weights`; [`Shares::NONE`] when they sum
    /// to nothing.
    pub fn new(weights: [f64; 4]) -> Shares {
        let total: f64 = weights.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return Shares::NONE;
        }
        Shares(weights.map(|w| (w / total * f64::from(u16::MAX)).round() as u16))
    }
}

/// The form factor of a link of throughput T(a,c) into element `node` of
/// `tree`, whose nodes have the exposed fractions `exposure`:
/// T / (|a| · exposed), the average over the exposed part (the whole
/// element when none is).
pub fn form_factor(tree: &ElementTree, exposure: &[f64], node: usize, throughput: f64) -> f64 {
    throughput / exposed_area(tree, exposure, node)
}

/// The exposed area of element `node` of `tree`, whose nodes have the
/// exposed fractions `exposure` (the whole element when none is exposed).
fn exposed_area(tree: &ElementTree, exposure: &[f64], node: usize) -> f64 {
    let (area, exposed) = (tree.nodes[node].patch.area(), exposure[node]);
    area * if exposed > 0.0 { exposed } else { 1.0 }
}

/// The radiance a diffuse element of `reflectance` reflects from a
/// transfer of form factor `form_factor` carrying `radiance`: ρ·F·L, one
/// term of eq. 12.
pub fn reflected(reflectance: Rgb, form_factor: f64, radiance: Rgb) -> Rgb {
    reflectance * form_factor * radiance
}

/// A two-point link in the direction of a diffuse receiver.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Transfer {
    /// Receiving node in the receiver's tree.
    pub receiver: u32,
    /// Source radiance.
    pub source: Source,
    /// Form factor F(receiver element, source element).
    pub form_factor: f64,
    /// How the form factor varies over the receiving element
    /// ([`relative_gradient`]), per unit length; zero for a leaf, which
    /// holds one value (single precision is ample for a shape).
    pub gradient: Vec3,
}

/// A three-point link as seen by its receiving directional structure.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ThreePointTransfer {
    /// Nodes of the receiving pair tree that tile the pair (a, b), a range in
    /// [`Interactions::covers`].
    pub receivers: Range<u32>,
    /// Source radiance L_{c→a}.
    pub source: Source,
    /// R(c, a, b) per channel.
    pub coefficient: Rgb,
}

/// Every link of a scene, arranged for gathering.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Interactions {
    /// Incoming two-point transfers of every surface that reflects (empty
    /// for those with neither a Lambertian nor a glossy lobe; a glossy
    /// surface's bring the light its lobes reflect through cluster links,
    /// [`Interactions::far_field`]), ordered by receiving node so the
    /// gather is deterministic.
    pub incoming: Vec<Vec<Transfer>>,
    /// The directional structures, ordered by (p, q).
    pub directional: Vec<Directional>,
    /// Index of the structure of each (p, q).
    pub structure_of: BTreeMap<(u32, u32), u32>,
    /// Incoming three-point transfers of every directional structure.
    pub incoming_three_point: Vec<Vec<ThreePointTransfer>>,
    /// (node, weight) lists that sources and receivers refer to.
    pub covers: Vec<(u32, f64)>,
    /// (bin, weight) lists that glossy sources without a directional
    /// structure refer to: what of each bin's radiance they read
    /// ([`Interactions::read_with_lobes`]).
    pub bins: Vec<(u8, f32)>,
    /// Exposed fraction of every node of every element tree
    /// ([`crate::kernel::exposure`]); radiance is averaged over exposed areas.
    pub exposure: Vec<Vec<f64>>,
    /// Exposed fraction of every node (a, b) of every directional
    /// structure: directional radiance is averaged over exposed pairs.
    pub pair_exposure: Vec<Vec<f64>>,
    /// The links made above the elements, between clusters of surfaces
    /// and elements ([`crate::solve::cluster_gather`]).
    pub clusters: ClusterTransfers,
    /// Factor of the reflected light reaching every node of every element
    /// tree, below 1 at leaves whose form factors sum above 1/ρ
    /// ([`Interactions::limit_reflection`]).
    pub limit: Vec<Vec<f64>>,
    /// Leaves with a factor below 1.
    pub limited_leaves: usize,
    /// The light of the scene's lights that are not surfaces
    /// ([`crate::scene::Scene::lights`]) at every surface with a Lambertian
    /// lobe: (node, E/π), E the irradiance of its light link averaged over
    /// the node's exposed part ([`crate::refine::light_links`]); a
    /// Lambertian lobe of albedo ρ reflects ρ·E/π of it.
    pub lights: Vec<Vec<(u32, Rgb)>>,
    /// What every directional structure's non-Lambertian lobes reflect of
    /// the same lights: (leaf node, L_{a→b}), averaged over the pair's
    /// exposed part.
    pub light_pairs: Vec<Vec<(u32, Rgb)>>,
    /// What the same lights bring every glossy surface per bin of its
    /// hemisphere, averaged over its exposed part: (bin, irradiance), the
    /// bins lit ([`glossy_clusters::light_bins`]); empty for the others.
    pub light_bins: Vec<Vec<(u8, Rgb)>>,
    /// Factor a texture puts on the light every node of a textured
    /// surface's tree reflects (empty for other surfaces;
    /// [`crate::geometry::texture::texture_scales`]).
    pub texture: Vec<Vec<Rgb>>,
    /// Per surface, each node's first child in its element tree
    /// ([`u32::MAX`] for a leaf): where a source read through its children
    /// ([`Shares`]) finds them.
    pub children: Vec<Vec<u32>>,
}

impl Source {
    /// The source element: (surface, node in its tree).
    pub fn element(&self) -> (u32, u32) {
        match *self {
            Source::Element { surface, node, .. } | Source::Glossy { surface, node, .. } => {
                (surface, node)
            }
        }
    }
}

/// How the form factor of a link to `source` varies over its receiving
/// element `node` of `tree` (zero for a leaf): the relative gradient
/// ([`relative_gradient`]) through its children's values, per exposed
/// area, which are `shares` of the link's throughput when refinement
/// integrated them (visibility included), else Lambert's formula at their
/// centroids. Children with nothing exposed take no part.
///
/// A link holds one form factor for its whole receiver (the Haar scaling
/// coefficient); spread evenly over the receiver's descendants, a leaf at a
/// concave corner got both its fine links to the adjacent wall and its
/// ancestors' average form factors to the far walls, too large there, and
/// the leaves a few elements in too little.
pub fn receiver_gradient(
    tree: &ElementTree,
    exposure: &[f64],
    node: usize,
    source: &Patch,
    shares: Option<[f32; 4]>,
) -> DVec3 {
    let Some(first) = tree.first_child(node) else {
        return DVec3::ZERO;
    };
    let normal = tree.nodes[node].patch.normal();
    let (mut points, mut values, mut count) = ([DVec3::ZERO; 4], [0.0; 4], 0);
    for k in 0..4 {
        let (child, exposed) = (&tree.nodes[first + k].patch, exposure[first + k]);
        if exposed <= 0.0 {
            continue;
        }
        points[count] = child.centroid();
        values[count] = match shares {
            Some(shares) => f64::from(shares[k]) / exposed,
            None => point_to_polygon(points[count], normal, &source.vertices(), source.normal()),
        };
        count += 1;
    }
    relative_gradient(&points[..count], &values[..count], normal)
}

/// Make `source`, an element of `tree` (whose nodes have the exposed
/// fractions `exposure`), read through its children where it has some
/// ([`Shares`]): weighted by `shares`, their shares of the link's
/// throughput where refinement integrated them, else by Lambert's
/// unoccluded form factor from each child's centroid to the `receiver`
/// times its exposed fraction (as [`receiver_gradient`] weighs a
/// receiver's children).
fn read_through_children(
    tree: &ElementTree,
    exposure: &[f64],
    source: &mut Source,
    receiver: &Patch,
    shares: Option<[f32; 4]>,
) {
    let (_, node) = source.element();
    let Some(first) = tree.first_child(node as usize) else {
        return;
    };
    let weights = shares.map(|s| s.map(f64::from)).unwrap_or_else(|| {
        let (vertices, n) = (receiver.vertices(), receiver.normal());
        std::array::from_fn(|k| {
            let child = &tree.nodes[first + k].patch;
            exposure[first + k] * point_to_polygon(child.centroid(), child.normal(), &vertices, n)
        })
    });
    match source {
        Source::Element { shares, .. } | Source::Glossy { shares, .. } => {
            *shares = Shares::new(weights)
        }
    }
}

impl Interactions {
    /// Each directional structure's (p, q), pair tree and the radiance
    /// `values` of its nodes, as the light estimate reads them.
    pub fn directional_radiance<'a>(
        &'a self,
        values: &'a [Vec<Rgb>],
    ) -> impl Iterator<Item = ((u32, u32), &'a PairTree, &'a [Rgb])> {
        self.directional
            .iter()
            .zip(values)
            .map(|(d, v)| ((d.p, d.q), &d.tree, &v[..]))
    }

    /// Arrange `links` and `three_point` for gathering over the element
    /// `trees`, whose nodes have the exposed fractions `exposure`;
    /// `directional` lists every (glossy p, q) pair that gets a structure,
    /// `pairs` the exposed fractions of the elements of their pairs.
    pub fn new(
        scene: &Scene,
        trees: &[ElementTree],
        exposure: Vec<Vec<f64>>,
        links: &[Link],
        three_point: &[ThreePointLink],
        pairs: &PairExposure,
        directional: Vec<Directional>,
    ) -> Interactions {
        let structure_of = directional
            .iter()
            .enumerate()
            .map(|(i, d)| ((d.p, d.q), i as u32))
            .collect();
        let mut out = Interactions {
            incoming: vec![Vec::new(); scene.surfaces.len()],
            incoming_three_point: vec![Vec::new(); directional.len()],
            directional,
            structure_of,
            covers: Vec::new(),
            bins: Vec::new(),
            exposure,
            pair_exposure: Vec::new(),
            clusters: ClusterTransfers::default(),
            limit: Vec::new(),
            limited_leaves: 0,
            lights: Vec::new(),
            light_pairs: Vec::new(),
            light_bins: Vec::new(),
            texture: Vec::new(),
            children: (trees.iter())
                .map(|t| {
                    (t.nodes.iter())
                        .map(|n| n.first_child.unwrap_or(u32::MAX))
                        .collect()
                })
                .collect(),
        };
        out.pair_exposure = out
            .directional
            .iter()
            .map(|d| {
                d.tree
                    .nodes
                    .iter()
                    .map(|n| pairs.of(ElementRef::new(d.p, n.a), ElementRef::new(d.q, n.b)))
                    .collect()
            })
            .collect();
        let node = |s: u32, id| {
            trees[s as usize]
                .index_of(id)
                .expect("link element is in its tree")
        };
        // A surface with neither lobe reflects nothing through two-point links.
        let reflects: Vec<bool> = (scene.surfaces.iter())
            .map(|s| {
                s.brdf.lambertian().is_some()
                    || s.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION)
            })
            .collect();
        // Each receiving surface's transfers, counted first: a scene's
        // millions of links fill vectors of their final sizes.
        let mut counts = vec![0usize; scene.surfaces.len()];
        for l in links {
            for p in [l.p, l.r] {
                counts[p as usize] += usize::from(reflects[p as usize]);
            }
        }
        for (incoming, &n) in out.incoming.iter_mut().zip(&counts) {
            incoming.reserve_exact(n);
        }
        // Each transfer's link and whether it is received by the link's
        // `a` (link index · 2 + 1) or `c`, beside `incoming` until the
        // gradients and the sources' children are made from the link's
        // shares: 4 bytes a transfer, where its shares would be 40.
        let mut link_of: Vec<Vec<u32>> = counts.iter().map(|&n| Vec::with_capacity(n)).collect();
        assert!(links.len() <= 1 << 31, "at most 2^31 links");
        for (k, l) in links.iter().enumerate() {
            let k = k as u32;
            for (p, a, r, c, of_a) in [(l.p, l.a, l.r, l.c, true), (l.r, l.c, l.p, l.a, false)] {
                if !reflects[p as usize] {
                    continue;
                }
                let receiver = node(p, a);
                let (tree, exposure) = (&trees[p as usize], &out.exposure[p as usize]);
                let form_factor = form_factor(tree, exposure, receiver as usize, l.throughput);
                let source = out.source(scene, trees, ElementRef::new(r, c), ElementRef::new(p, a));
                out.incoming[p as usize].push(Transfer {
                    receiver,
                    source,
                    form_factor,
                    gradient: Vec3::ZERO,
                });
                link_of[p as usize].push(2 * k + u32::from(of_a));
            }
        }
        let all_exposure = &out.exposure;
        (out.incoming.par_iter_mut().zip(link_of).enumerate())
            .with_max_len(64)
            .for_each(|(p, (incoming, link_of))| {
                let (tree, exposure) = (&trees[p], &all_exposure[p][..]);
                for (t, k) in incoming.iter_mut().zip(link_of) {
                    let (l, of_a) = (&links[k as usize / 2], k % 2 == 1);
                    let (into, from) = (l.shares_into(of_a), l.shares_into(!of_a));
                    let (r, c) = t.source.element();
                    let source = &trees[r as usize].nodes[c as usize].patch;
                    let g = receiver_gradient(tree, exposure, t.receiver as usize, source, into);
                    t.gradient = g.as_vec3();
                    let receiver = &tree.nodes[t.receiver as usize].patch;
                    let (source_tree, exposure) = (&trees[r as usize], &all_exposure[r as usize]);
                    read_through_children(source_tree, exposure, &mut t.source, receiver, from);
                }
            });
        // Only a glossy source's transfers split; without directional
        // structures there is none.
        if !out.directional.is_empty() {
            for p in 0..out.incoming.len() {
                let transfers = std::mem::take(&mut out.incoming[p]);
                let mut resolved = Vec::with_capacity(transfers.len());
                for t in transfers {
                    out.resolve_highlight(trees, p, t, &mut resolved);
                }
                out.incoming[p] = resolved;
            }
        }
        for l in three_point {
            let s = out.structure_of[&(l.p, l.q)];
            let cover = out.directional[s as usize].tree.overlaps(l.a, l.b);
            let receivers = out.push_cover(cover);
            let [from, to, _] = l.elements();
            let source = out.source(scene, trees, from, to);
            // R averages over the whole pair; radiance is the average over
            // its exposed part.
            let exposed = pairs.of(ElementRef::new(l.p, l.a), ElementRef::new(l.q, l.b));
            let scale = if exposed > 0.0 { 1.0 / exposed } else { 1.0 };
            out.incoming_three_point[s as usize].push(ThreePointTransfer {
                receivers,
                source,
                coefficient: l.coefficient.map(|k| k * scale),
            });
        }
        out.conserve_bins(trees);
        for list in &mut out.incoming {
            list.sort_by_key(|t| t.receiver);
        }
        out
    }

    /// Scale the weights in [`Interactions::bins`] so that the two-point
    /// transfers from a glossy surface never read more of a bin of its
    /// hemisphere than the bin sends: their throughputs through each bin,
    /// per unit of the surface's exposed area, sum to at most the bin's
    /// share of the projected solid angle, 1/[`BINS`], as exact form
    /// factors do. Quadrature overestimates the form factors of elements
    /// pressed together, and a sharp lobe puts all it reflects in one
    /// bin: read beyond what it holds, that bin would feed the light back
    /// larger at every bounce.
    fn conserve_bins(&mut self, trees: &[ElementTree]) {
        let mut through: Vec<Vec<f64>> = vec![Vec::new(); trees.len()];
        for (p, list) in self.incoming.iter().enumerate() {
            for t in list {
                let Source::Element {
                    surface, towards, ..
                } = &t.source
                else {
                    continue;
                };
                if towards.is_empty() {
                    continue;
                }
                let sums = &mut through[*surface as usize];
                sums.resize(BINS, 0.0);
                let receiver = t.receiver as usize;
                let throughput =
                    t.form_factor * exposed_area(&trees[p], &self.exposure[p], receiver);
                for &(b, w) in &self.bins[towards.start as usize..towards.end as usize] {
                    sums[usize::from(b)] += throughput * f64::from(w);
                }
            }
        }
        let scales: Vec<Vec<f32>> = (through.into_iter().enumerate())
            .map(|(s, sums)| {
                let area = exposed_area(&trees[s], &self.exposure[s], 0);
                (sums.into_iter())
                    .map(|t| {
                        let read = t * BINS as f64 / area;
                        if read > 1.0 {
                            (1.0 / read) as f32
                        } else {
                            1.0
                        }
                    })
                    .collect()
            })
            .collect();
        let sources = (self.incoming.iter().flatten().map(|t| &t.source)).chain(
            self.incoming_three_point
                .iter()
                .flatten()
                .map(|t| &t.source),
        );
        for source in sources {
            if let Source::Element {
                surface, towards, ..
            } = source
            {
                // A surface none of whose transfers read its bins has no scales.
                let scale = &scales[*surface as usize];
                for (b, w) in &mut self.bins[towards.start as usize..towards.end as usize] {
                    *w *= scale.get(usize::from(*b)).copied().unwrap_or(1.0);
                }
            }
        }
    }

    /// Set every leaf's reflection limit ([`reflection_limits`]) from the
    /// sum of the form factors of everything it gathers from (its gather of
    /// a unit radiance everywhere, with unit reflectance) and its surface's
    /// reflectance in `scene` (a texture's largest value on a textured
    /// surface), and the textured surfaces' factors ([`Interactions::texture`]).
    /// Cluster links count too: call it once [`Interactions::clusters`] is set.
    pub fn limit_reflection(&mut self, scene: &Scene, trees: &[ElementTree]) {
        let unit: Vec<Vec<Rgb>> = trees
            .iter()
            .map(|t| vec![Rgb::splat(1.0); t.nodes.len()])
            .collect();
        let none: Vec<Vec<Rgb>> = self
            .directional
            .iter()
            .map(|d| vec![Rgb::ZERO; d.tree.nodes.len()])
            .collect();
        let far = self.clusters.far_field(&unit, None, None);
        let limits: Vec<(Vec<f64>, usize)> = trees
            .par_iter()
            .enumerate()
            .map(|(p, tree)| {
                let sums = self.gather(p, Rgb::splat(1.0), tree, (&unit, &none), &far);
                let surface = &scene.surfaces[p];
                let rho = match (surface.brdf.lambertian(), surface.texture) {
                    (None, _) => 0.0,
                    (Some(rho), None) => rho.max_channel(),
                    (Some(_), Some(t)) => scene.textures[t.texture as usize].max().max_channel(),
                };
                reflection_limits(tree, &sums, rho)
            })
            .collect();
        self.texture = (0..trees.len())
            .into_par_iter()
            .map(|p| texture_scales(scene, p, &trees[p]).unwrap_or_default())
            .collect();
        self.limited_leaves = limits.iter().map(|(_, n)| n).sum();
        self.limit = limits.into_iter().map(|(l, _)| l).collect();
    }

    /// Arrange the `light_links` of the scene's lights over the element
    /// `trees` (which hold their elements), and project the lights' light
    /// into every leaf of every directional structure
    /// ([`crate::kernel::lights::reflected_towards`], the quadrature's
    /// order and the sky's grid of [`SKY_GRID`] directions per axis).
    pub fn link_lights(
        &mut self,
        ctx: &KernelContext,
        trees: &[ElementTree],
        light_links: &[LightLink],
    ) {
        let scene = ctx.scene;
        self.lights = vec![Vec::new(); scene.surfaces.len()];
        for l in light_links {
            let s = l.surface as usize;
            let node = (trees[s].index_of(l.element)).expect("light link element is in its tree");
            let exposed = self.exposure[s][node as usize];
            let exposed = if exposed > 0.0 { exposed } else { 1.0 };
            let e = l.irradiance / (exposed * std::f64::consts::PI);
            self.lights[s].push((node, e));
        }
        if scene.lights.iter().all(|l| l.is_dark()) {
            self.light_pairs = vec![Vec::new(); self.directional.len()];
            self.light_bins = vec![Vec::new(); scene.surfaces.len()];
            return;
        }
        let sky = grid(SKY_GRID / 2);
        self.light_bins = (scene.surfaces.par_iter().enumerate())
            .map(|(s, surface)| {
                if !surface.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION) {
                    return Vec::new();
                }
                let at = (s as u32, &trees[s].nodes[0].patch, self.exposure[s][0]);
                glossy_clusters::light_bins(scene, ctx.tracer, at, (ctx.quadrature.points, &sky))
            })
            .collect();
        self.light_pairs = (self.directional.par_iter().zip(&self.pair_exposure))
            .map(|(d, exposure)| {
                let brdf = scene.surfaces[d.p as usize].brdf.without_lambertian();
                let (p_root, q_root) = (
                    &trees[d.p as usize].nodes[0].patch,
                    &trees[d.q as usize].nodes[0].patch,
                );
                (d.tree.nodes.iter().enumerate())
                    .filter(|(_, n)| n.first_child.is_none())
                    .map(|(i, n)| {
                        let (a, b) = (n.a.patch(p_root), n.b.patch(q_root));
                        let l = reflected_towards(
                            scene,
                            ctx.tracer,
                            (d.p, &brdf),
                            (&a, &b),
                            (ctx.quadrature.points, &sky),
                        );
                        let exposed = if exposure[i] > 0.0 { exposure[i] } else { 1.0 };
                        (i as u32, l / exposed)
                    })
                    .filter(|(_, l)| l.max_channel() > 0.0)
                    .collect()
            })
            .collect();
    }

    /// Add to the radiance `gathered` at each node of surface `p` what its
    /// Lambertian lobe of albedo `reflectance` reflects of the scene's
    /// lights that are not surfaces: ρ·E/π ([`Interactions::lights`]).
    pub fn gather_lights(&self, p: usize, reflectance: Rgb, gathered: &mut [Rgb]) {
        for &(node, e) in self.lights.get(p).map_or(&[][..], |l| &l[..]) {
            gathered[node as usize] += reflectance * e;
        }
    }

    /// The factors surface `p`'s texture puts on its nodes' reflected
    /// light ([`Interactions::texture`]); `None` when it has no texture.
    pub fn texture_of(&self, p: usize) -> Option<&[Rgb]> {
        self.texture
            .get(p)
            .filter(|t| !t.is_empty())
            .map(Vec::as_slice)
    }

    /// Transfer `t` into surface `p`, split where its glossy source's
    /// directional structure resolves L_{c→a} more finely than the pair
    /// (c, a) of the link (a reflected highlight, which three-point links
    /// resolve on both the glossy surface and the receiver): one transfer
    /// per tile (g, b) of the pair ([`PairTree::tiles`]), from g towards
    /// b, each reading the directional radiance of its own tile. Its form
    /// factor is the link's, with its linear variation over a (`t.gradient`)
    /// taken at b, times g's share of Lambert's point-to-polygon form
    /// factor of c at b's centroid. Read over the whole pair, a coarse link
    /// averaged L over c and over a, and so neither showed the highlight's
    /// shape on the receiver nor weighed each part of the glossy surface by
    /// the form factor of the part that reflects it.
    fn resolve_highlight(
        &mut self,
        trees: &[ElementTree],
        p: usize,
        t: Transfer,
        out: &mut Vec<Transfer>,
    ) {
        let Source::Glossy {
            surface: r,
            node: c,
            structure,
            ..
        } = t.source
        else {
            return out.push(t);
        };
        let (tree, source_tree) = (&trees[p], &trees[r as usize]);
        let c = &source_tree.nodes[c as usize];
        let a = &tree.nodes[t.receiver as usize];
        let tiles = self.directional[structure as usize].tree.tiles(c.id, a.id);
        if tiles.len() == 1 {
            return out.push(t);
        }
        let gradient = t.gradient.as_dvec3();
        let source_root = &source_tree.nodes[0].patch;
        for (g, b) in tiles {
            let receiver = tree
                .index_of(b)
                .expect("a pair's receivers are in its tree");
            let b_patch = &tree.nodes[receiver as usize].patch;
            let x = b_patch.centroid();
            let scale = 1.0 + gradient.dot(x - a.patch.centroid());
            let lambert = |patch: &Patch| {
                point_to_polygon(x, b_patch.normal(), &patch.vertices(), patch.normal())
            };
            let whole = lambert(&c.patch);
            let share = if whole > 0.0 {
                lambert(&g.patch(source_root)) / whole
            } else {
                0.0
            };
            if scale <= 0.0 || share <= 0.0 {
                continue;
            }
            let leaf = tree.first_child(receiver as usize).is_none();
            // g's own radiance is its tree node's (the one containing it);
            // its directional radiance the tile's.
            let cover = self.directional[structure as usize].tree.overlaps(g, b);
            let source = Source::Glossy {
                surface: r,
                node: source_tree.node_containing(g),
                structure,
                nodes: self.push_cover(cover),
                shares: Shares::NONE,
            };
            out.push(Transfer {
                receiver,
                source,
                form_factor: t.form_factor * scale * share,
                gradient: if leaf {
                    Vec3::ZERO
                } else {
                    (gradient / scale).as_vec3()
                },
            });
        }
    }

    fn push_cover(&mut self, cover: Vec<(u32, f64)>) -> Range<u32> {
        let start = self.covers.len() as u32;
        self.covers.extend(cover);
        start..self.covers.len() as u32
    }

    /// Where L_{c→a} (c on r, a on p) is read.
    fn source(
        &mut self,
        scene: &Scene,
        trees: &[ElementTree],
        source: ElementRef,
        receiver: ElementRef,
    ) -> Source {
        let (ElementRef { surface: r, id: c }, ElementRef { surface: p, id: a }) =
            (source, receiver);
        let node = trees[r as usize]
            .index_of(c)
            .expect("source element is in its tree");
        let structure = self.structure_of.get(&(r, p)).copied();
        let glossy =
            (scene.surfaces[r as usize].brdf.flags()).contains(BrdfFlags::GLOSSY_REFLECTION);
        match structure {
            Some(structure) if glossy => {
                let cover = self.directional[structure as usize].tree.overlaps(c, a);
                Source::Glossy {
                    surface: r,
                    node,
                    structure,
                    nodes: self.push_cover(cover),
                    shares: Shares::NONE,
                }
            }
            _ => {
                let start = self.bins.len() as u32;
                if glossy {
                    let patch = |s: u32, id: ElementId| id.patch(&trees[s as usize].nodes[0].patch);
                    let (from, to) = (patch(r, c), patch(p, a));
                    let frame = scene.surfaces[r as usize].frame();
                    let spread = glossy_clusters::spread(&frame, &from, &to);
                    if spread.is_empty() {
                        // No point of the source faces the receiver's
                        // front: the centroids' direction stands for all.
                        let towards = frame.to_local(to.centroid() - from.centroid());
                        self.bins.extend(bin_of(towards).map(|b| (b as u8, 1.0)));
                    }
                    self.bins.extend(spread);
                }
                Source::Element {
                    surface: r,
                    node,
                    shares: Shares::NONE,
                    towards: start..self.bins.len() as u32,
                }
            }
        }
    }

    /// L_{c→a} now: `radiance[surface][node]` (or its children's by
    /// their [`Shares`]), plus for glossy sources their directional
    /// radiance `directional[structure]` over the pair.
    pub fn read(&self, source: &Source, radiance: &[Vec<Rgb>], directional: &[Vec<Rgb>]) -> Rgb {
        let own = |surface: u32, node: u32, shares: Shares| {
            let values = &radiance[surface as usize];
            if shares == Shares::NONE {
                return values[node as usize];
            }
            let first = self.children[surface as usize][node as usize] as usize;
            let sum = (shares.0.iter().zip(&values[first..first + 4]))
                .fold(Rgb::ZERO, |l, (&w, &v)| l + v * f64::from(w));
            sum / f64::from(u16::MAX)
        };
        match *source {
            Source::Element {
                surface,
                node,
                shares,
                ..
            } => own(surface, node, shares),
            Source::Glossy {
                surface,
                node,
                structure,
                ref nodes,
                shares,
            } => {
                let values = &directional[structure as usize];
                let mut l = own(surface, node, shares);
                for &(n, w) in &self.covers[nodes.start as usize..nodes.end as usize] {
                    l += values[n as usize] * w;
                }
                l
            }
        }
    }

    /// [`Interactions::read`], plus on a glossy source without a
    /// directional structure towards the receiver the light its lobes send
    /// that way in `far` ([`FarField::glossy`]).
    pub fn read_with_lobes(
        &self,
        source: &Source,
        (radiance, directional): (&[Vec<Rgb>], &[Vec<Rgb>]),
        far: Option<&FarField>,
    ) -> Rgb {
        let l = self.read(source, radiance, directional);
        match (source, far) {
            (
                Source::Element {
                    surface, towards, ..
                },
                Some(far),
            ) => {
                let bins = &self.bins[towards.start as usize..towards.end as usize];
                (bins.iter()).fold(l, |l, &(b, w)| l + far.glossy(*surface, b) * f64::from(w))
            }
            _ => l,
        }
    }

    /// The far field of cluster links ([`ClusterTransfers::far_field`]) of
    /// the elements' `radiance` and the directional structures'
    /// `directional`, with the scene's glossy surfaces' light per bin: their
    /// lobes reflect the light their two-point transfers bring (each from
    /// its source element's direction) and their cluster links', these
    /// with the glossy surfaces' light per bin of `previous` (the sweep
    /// before's far field, if any).
    pub fn far_field(
        &self,
        scene: &Scene,
        trees: &[ElementTree],
        state: (&[Vec<Rgb>], &[Vec<Rgb>]),
        previous: Option<&FarField>,
    ) -> FarField {
        let glossy = GlossyReflectors::of(scene).map(|g| {
            let near = (g.surfaces().par_iter().enumerate())
                .map(|(k, &p)| self.near_incident(&g, k, trees, p, state, previous))
                .collect();
            (g, near)
        });
        self.clusters.far_field(state.0, glossy, previous)
    }

    /// The irradiance surface `p` (reflector `k` of `reflectors`), whose
    /// tree is `trees[p]`, receives per bin through its two-point transfers,
    /// averaged over its exposed area: π·T·L/A, each from the direction of
    /// its source element's centroid.
    fn near_incident(
        &self,
        reflectors: &GlossyReflectors,
        k: usize,
        trees: &[ElementTree],
        p: u32,
        state: (&[Vec<Rgb>], &[Vec<Rgb>]),
        previous: Option<&FarField>,
    ) -> Vec<Rgb> {
        let (tree, exposure) = (&trees[p as usize], &self.exposure[p as usize]);
        let whole = exposed_area(tree, exposure, 0);
        let mut bins = vec![Rgb::ZERO; BINS];
        for &(b, e) in self.light_bins.get(p as usize).map_or(&[][..], |l| &l[..]) {
            bins[usize::from(b)] += e;
        }
        for t in &self.incoming[p as usize] {
            let (r, c) = t.source.element();
            let receiver = t.receiver as usize;
            let from = trees[r as usize].nodes[c as usize].patch.centroid();
            let towards = from - tree.nodes[receiver].patch.centroid();
            let throughput = t.form_factor * exposed_area(tree, exposure, receiver);
            let l = self.read_with_lobes(&t.source, state, previous);
            reflectors.receive(k, &mut bins, towards, l * (PI * throughput / whole));
        }
        bins
    }

    /// Radiance reflected at each node of diffuse surface `p` (whose tree
    /// is `tree`) from the current solution: `ρ · Σ F · L_{c→a}` (eq. 12,
    /// before push–pull), each term spread over its receiver with the
    /// transfer's gradient, and what its cluster links bring from `far`
    /// ([`ClusterTransfers::far_field`] of the same solution).
    pub fn gather(
        &self,
        p: usize,
        reflectance: Rgb,
        tree: &ElementTree,
        state: (&[Vec<Rgb>], &[Vec<Rgb>]),
        far: &FarField,
    ) -> Vec<Rgb> {
        let mut gathered = Gathered::new(tree.nodes.len());
        for t in &self.incoming[p] {
            let l = self.read_with_lobes(&t.source, state, Some(far));
            let value = reflected(reflectance, t.form_factor, l);
            gathered.add(t.receiver as usize, value, t.gradient.as_dvec3());
        }
        self.clusters
            .gather_into(p as u32, reflectance, far, &mut gathered);
        gathered.into_averages(tree)
    }

    /// Radiance reflected at each node of directional structure `s`:
    /// `Σ R · L_{c→a}` (eq. 13, before push–pull), and the light of the
    /// scene's lights ([`Interactions::light_pairs`]); glossy sources
    /// without a structure towards the pair's glossy surface read their
    /// lobes' light in `far`.
    pub fn gather_three_point(
        &self,
        s: usize,
        state: (&[Vec<Rgb>], &[Vec<Rgb>]),
        far: &FarField,
    ) -> Vec<Rgb> {
        let mut gathered = vec![Rgb::ZERO; self.directional[s].tree.nodes.len()];
        for &(node, l) in self.light_pairs.get(s).map_or(&[][..], |l| &l[..]) {
            gathered[node as usize] += l;
        }
        for t in &self.incoming_three_point[s] {
            let l = self.read_with_lobes(&t.source, state, Some(far));
            let add = t.coefficient * l;
            for &(n, _) in &self.covers[t.receivers.start as usize..t.receivers.end as usize] {
                gathered[n as usize] += add;
            }
        }
        gathered
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::hierarchy::ElementId;

    #[test]
    fn receiver_gradient_follows_the_childrens_shares_per_exposed_area() {
        let root = Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X,
            edge_t: DVec3::Y,
        };
        let ids = [ElementId::ROOT.child(0)].into_iter().collect();
        let tree = ElementTree::build(&root, &ids);
        let source = Patch::Parallelogram {
            origin: DVec3::new(0.0, 0.0, 1.0),
            edge_s: DVec3::Y,
            edge_t: DVec3::X,
        };
        // Children 1 and 3 (x > 0.5) get twice the share of 0 and 2: the
        // form factor rises along x, g·(x − x̄) = ±1/3 at their centroids.
        let exposed = vec![1.0; tree.nodes.len()];
        let shares = Some([1.0 / 6.0, 2.0 / 6.0, 1.0 / 6.0, 2.0 / 6.0]);
        let g = receiver_gradient(&tree, &exposed, 0, &source, shares);
        assert!((g - DVec3::new(4.0 / 3.0, 0.0, 0.0)).length() < 1e-6, "{g}");
        // Child 1 half buried: per exposed area it gets as much as 3.
        let mut half = exposed.clone();
        half[2] = 0.5; // node 2 is child 1
        let shares = Some([1.0 / 5.0, 1.0 / 5.0, 1.0 / 5.0, 2.0 / 5.0]);
        let g = receiver_gradient(&tree, &half, 0, &source, shares);
        assert!((g - DVec3::new(4.0 / 3.0, 0.0, 0.0)).length() < 1e-6, "{g}");
        // Without shares, Lambert's formula: the square straight above is
        // symmetric about the receiver's centre.
        let g = receiver_gradient(&tree, &exposed, 0, &source, None);
        assert!(g.length() < 1e-9, "{g}");
        // A leaf has none.
        let leaf = tree.index_of(ElementId::ROOT.child(1)).unwrap() as usize;
        assert_eq!(
            receiver_gradient(&tree, &exposed, leaf, &source, shares),
            DVec3::ZERO
        );
    }
}
