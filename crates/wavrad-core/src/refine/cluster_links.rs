//! Linking from the top of the hierarchy: clusters of surfaces
//! ([`ClusterTree`]) above the surfaces, elements below them (Sillion 1995's
//! unified hierarchy; Smits, Arvo & Greenberg 1994's links between
//! clusters).
//!
//! Linking starts with the root cluster paired with itself. A pair of
//! distinct ends that are small against their distance — (r_x + r_y)/d at
//! most `ratio`, their bounding spheres apart — becomes one
//! [`ClusterLink`]; otherwise the end with the larger bounding sphere is
//! split (a cluster into its two children, an element into its four, down
//! to the maximum level), and a cluster paired with itself gives its
//! children's pairs. When both ends are elements (whole surfaces, or
//! elements a cluster's neighbourhood split), the pair is handed to the
//! paper's adaptive projection ([`crate::refine::two_point_projection`],
//! [`crate::refine::three_point_projection`]) as before. So a scene's pairs
//! of nearby surfaces are linked as the paper links them, and distant
//! groups of small surfaces exchange light through O(n log n) cluster links
//! rather than O(n²) surface pairs.
//!
//! A cluster link's transfer is evaluated with every member's own cosine
//! and area, towards the other end's centre, and one visibility fraction
//! for the pair ([`crate::solve::cluster_gather`]); its error is of order
//! `ratio` in the directions and `ratio²` in the distances.

use crate::geometry::cluster::ClusterTree;
use crate::geometry::hierarchy::ElementRef;
use crate::kernel::{faces_away, KernelContext};
use crate::progress::Progress;
use crate::sampling::hash2;
use crate::scene::Patch;
use glam::DVec3;
use rayon::prelude::*;

/// Visibility rays of one cluster link (between points picked by area on
/// its two ends).
pub const CLUSTER_LINK_RAYS: u32 = 16;

/// A pair with more members than this splits its work over threads.
const PARALLEL_MEMBERS: u32 = 64;

/// One end of a link made above the elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum End {
    /// A cluster of two or more surfaces (a node of the [`ClusterTree`]).
    Cluster(u32),
    /// One element of one surface (the root: the whole surface).
    Element(ElementRef),
}

/// Light exchanged between two ends as wholes, in both directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClusterLink {
    /// Its two ends.
    pub ends: [End; 2],
    /// Fraction of the lines between the ends' facing points that nothing
    /// blocks.
    pub visibility: f64,
}

/// What linking from the top makes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Linking {
    /// Element pairs that can exchange light (neither behind the other),
    /// for the adaptive projection, in a fixed order.
    pub element_pairs: Vec<[ElementRef; 2]>,
    /// Links between ends small against their distance.
    pub cluster_links: Vec<ClusterLink>,
}

impl Linking {
    fn append(&mut self, mut other: Linking) {
        self.element_pairs.append(&mut other.element_pairs);
        self.cluster_links.append(&mut other.cluster_links);
    }

    /// The surface pairs (p < r) of its element pairs, each once, in order.
    pub fn surface_pairs(&self) -> Vec<(u32, u32)> {
        let mut pairs: Vec<(u32, u32)> = self
            .element_pairs
            .iter()
            .map(|[a, c]| (a.surface.min(c.surface), a.surface.max(c.surface)))
            .collect();
        pairs.sort_unstable();
        pairs.dedup();
        pairs
    }
}

/// Settings of linking from the top.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClusterSettings {
    /// Largest (r_x + r_y)/d of a cluster link; 0 links no clusters (every
    /// pair of surfaces is linked as the paper links them).
    pub ratio: f64,
    /// Deepest element level a cluster's neighbourhood may split an
    /// element to.
    pub max_level: u32,
}

/// Where an end is and how large.
struct Bounds {
    center: DVec3,
    radius: f64,
}

struct Linker<'a> {
    ctx: KernelContext<'a>,
    clusters: &'a ClusterTree,
    settings: ClusterSettings,
}

/// Link `clusters` (the scene's) from the root down ([`Linking`]).
pub fn link_from_root(
    ctx: &KernelContext,
    clusters: &ClusterTree,
    settings: ClusterSettings,
    progress: &dyn Progress,
) -> Linking {
    if clusters.nodes.is_empty() {
        return Linking::default();
    }
    progress.start("linking", 1);
    let linker = Linker {
        ctx: *ctx,
        clusters,
        settings,
    };
    let linking = linker.with_itself(0);
    progress.advance(1);
    progress.finish();
    linking
}

impl Linker<'_> {
    /// The end a cluster node stands for: a leaf is its surface's root
    /// element.
    fn end_of(&self, c: u32) -> End {
        match self.clusters.nodes[c as usize].children {
            Some(_) => End::Cluster(c),
            None => End::Element(ElementRef::root(self.clusters.members_of(c)[0])),
        }
    }

    fn patch(&self, e: ElementRef) -> Patch {
        e.id.patch(&self.ctx.scene.surfaces[e.surface as usize].patch)
    }

    fn bounds(&self, end: End) -> Bounds {
        match end {
            End::Cluster(c) => {
                let node = &self.clusters.nodes[c as usize];
                Bounds {
                    center: node.center,
                    radius: node.radius,
                }
            }
            End::Element(e) => {
                let patch = self.patch(e);
                let center = patch.centroid();
                let radius = patch
                    .vertices()
                    .into_iter()
                    .map(|v| v.distance(center))
                    .fold(0.0, f64::max);
                Bounds { center, radius }
            }
        }
    }

    /// Surfaces under an end (1 for an element).
    fn weight(&self, end: End) -> u32 {
        match end {
            End::Cluster(c) => self.clusters.members_of(c).len() as u32,
            End::Element(_) => 1,
        }
    }

    /// Every pair within cluster node `c`.
    fn with_itself(&self, c: u32) -> Linking {
        let Some([a, b]) = self.clusters.nodes[c as usize].children else {
            return Linking::default();
        };
        let (mut linking, (inner_b, across)) = rayon::join(
            || self.with_itself(a),
            || {
                rayon::join(
                    || self.with_itself(b),
                    || {
                        let mut across = Linking::default();
                        self.pair(self.end_of(a), self.end_of(b), &mut across);
                        across
                    },
                )
            },
        );
        linking.append(inner_b);
        linking.append(across);
        linking
    }

    /// Link two distinct ends, or split one of them and link its parts.
    fn pair(&self, x: End, y: End, out: &mut Linking) {
        if let (End::Element(a), End::Element(c)) = (x, y) {
            if a.surface != c.surface && !faces_away(&self.patch(a), &self.patch(c)) {
                out.element_pairs.push([a, c]);
            }
            return;
        }
        let (bx, by) = (self.bounds(x), self.bounds(y));
        let (reach, d) = (bx.radius + by.radius, bx.center.distance(by.center));
        if self.settings.ratio > 0.0 && d > reach && reach <= self.settings.ratio * d {
            if let Some(link) = self.cluster_link(x, y) {
                out.cluster_links.push(link);
            }
            return;
        }
        // Split the larger end, unless it is an element that may not split
        // (with no cluster links at all, pairs of surfaces start from their
        // roots, as the paper's projection does).
        // An element splits only towards a cluster that lies wholly off
        // its plane: one resting on it or cutting through it is split into
        // its surfaces instead, whose pairs with the element the
        // projection refines where they touch.
        let splittable = |e: End, other: &Bounds| match e {
            End::Cluster(_) => true,
            End::Element(e) => {
                let patch = self.patch(e);
                let off_plane = patch.normal().dot(other.center - patch.centroid()).abs();
                self.settings.ratio > 0.0
                    && e.id.level < self.settings.max_level
                    && off_plane > other.radius
            }
        };
        let split_x = splittable(x, &by) && (bx.radius >= by.radius || !splittable(y, &bx));
        let (split, other) = if split_x { (x, y) } else { (y, x) };
        let parts: Vec<End> = match split {
            End::Cluster(c) => {
                let children = self.clusters.nodes[c as usize].children;
                children.into_iter().flatten().map(|k| self.end_of(k)).collect()
            }
            End::Element(e) => (0..4).map(|k| End::Element(e.child(k))).collect(),
        };
        if self.weight(x) + self.weight(y) > PARALLEL_MEMBERS {
            let linked: Vec<Linking> = parts
                .par_iter()
                .map(|&part| {
                    let mut linking = Linking::default();
                    self.pair(part, other, &mut linking);
                    linking
                })
                .collect();
            linked.into_iter().for_each(|l| out.append(l));
        } else {
            for part in parts {
                self.pair(part, other, out);
            }
        }
    }

    /// The members of an end as (surface, patch) pairs, for sampling: the
    /// element's own patch, or a cluster member picked by area at `u`.
    fn member_at(&self, end: End, u: f64) -> (u32, Patch) {
        match end {
            End::Element(e) => (e.surface, self.patch(e)),
            End::Cluster(c) => {
                let s = self.clusters.member_by_area(c, u);
                (s, self.ctx.scene.surfaces[s as usize].patch)
            }
        }
    }

    /// The link between `x` and `y`, or `None` when no line between their
    /// facing points is clear (they exchange no light).
    fn cluster_link(&self, x: End, y: End) -> Option<ClusterLink> {
        let seed = end_seed(x).rotate_left(17) ^ end_seed(y);
        let (mut facing, mut clear) = (0u32, 0u32);
        for j in 0..CLUSTER_LINK_RAYS {
            let pick = hash2(seed, u64::from(j));
            let (sx, px) = self.member_at(x, pick.x);
            let (sy, py) = self.member_at(y, pick.y);
            let on = |p: &Patch, salt: u64| {
                let uv = hash2(seed ^ salt, u64::from(j));
                p.point_at(p.square_to_param(uv))
            };
            let (a, b) = (on(&px, 0x51ed_270b), on(&py, 0x2f8f_8a1d));
            if px.normal().dot(b - a) <= 0.0 || py.normal().dot(a - b) <= 0.0 {
                continue;
            }
            facing += 1;
            let skip = self.ctx.skipping(sx, sy);
            if !self.ctx.tracer.occluder.occluded_except(a, b, skip) {
                clear += 1;
            }
        }
        (clear > 0).then(|| ClusterLink {
            ends: [x, y],
            visibility: f64::from(clear) / f64::from(facing),
        })
    }
}

/// A number that names an end, to seed its samples (the same for any
/// thread count).
fn end_seed(end: End) -> u64 {
    match end {
        End::Cluster(c) => 0x9e37_79b9_7f4a_7c15 ^ u64::from(c),
        End::Element(e) => {
            (u64::from(e.surface) << 32) ^ e.id.path.rotate_left(7) ^ u64::from(e.id.level)
        }
    }
}
