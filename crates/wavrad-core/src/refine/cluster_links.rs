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
//! [`crate::refine::three_point_projection`]) as before, unless the light
//! they can exchange is within the oracle's threshold however the kernel
//! varies over them ([`element_bound`]; neither emits): then one cluster
//! link carries it. Neighbouring triangles of a fine concave mesh, each
//! a little above the other's plane, are such pairs; so are two ends of
//! plain Lambertian surfaces nearer than the ratio (up to
//! [`MAX_CLUSTER_RATIO`]) whose transfer, with the cosines bounded by how
//! far each rises over the other's members' planes
//! ([`crate::geometry::cluster::height_over`]), is within the threshold:
//! neighbouring parts of such a mesh, linked whole rather than triangle by
//! triangle. A pair one of whose ends lies wholly behind the other's
//! members' planes exchanges nothing and is dropped at once (the inside
//! and the outside of a `twosided` mesh). So a scene's pairs
//! of nearby surfaces are linked as the paper links them, and distant
//! groups of small surfaces exchange light through O(n log n) cluster links
//! rather than O(n²) surface pairs.
//!
//! A cluster holding emitters and other surfaces both is split, never
//! linked whole: the emitters' light leaves through their own visibility,
//! not their neighbours'.
//!
//! A cluster link's transfer is evaluated with every member's own cosine
//! and area, towards the other end's centre, and one visibility fraction
//! for the pair ([`crate::solve::cluster_gather`]); its error is of order
//! `ratio` in the directions and `ratio²` in the distances. The visibility
//! fraction is estimated with as many rays as the light the link can carry
//! needs ([`transfer_bound`], [`rays_needed`]): a link between small ends
//! far apart, whose whole transfer is near the oracle's threshold, is
//! sampled with one ray, a large one with up to [`CLUSTER_LINK_RAYS`]
//! (Smits, Arvo & Greenberg 1994 bound a cluster link's error the same
//! way, by the transfer it could carry).
//!
//! Linking keeps to the solve's budget ([`crate::progress::Budget`]): once
//! it is spent ([`Progress::interrupted`]), a pair of ends apart by
//! [`MAX_CLUSTER_RATIO`] is linked as it stands instead of split, the
//! coarsest cluster link the settings allow; pairs closer than that are
//! still split, so every pair of surfaces stays linked exactly once and no
//! light is dropped. Each such pair is counted ([`Progress::cut_short`]).

use crate::geometry::cluster::{height_over, ClusterTree, Orientation};
use crate::geometry::hierarchy::ElementRef;
use crate::kernel::KernelContext;
use crate::progress::{Progress, LINK_COPIES};
use crate::sampling::hash2;
use crate::scene::brdf::Brdf;
use crate::scene::{Patch, Scene};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Most visibility rays of one cluster link (between points picked by area
/// on its two ends): also the most pairs of points drawn, of which only
/// those facing each other are traced.
pub const CLUSTER_LINK_RAYS: u32 = 16;

/// Largest (r_x + r_y)/d of any cluster link: the largest `cluster_ratio`
/// setting, and the ratio at which linking links the pairs left once the
/// budget is spent. Below 1, so the ends are apart and every member's
/// transfer towards the other end's centre is finite.
pub const MAX_CLUSTER_RATIO: f64 = 0.9;

/// A pair with more members than this splits its work over threads.
const PARALLEL_MEMBERS: u32 = 64;

/// One end of a link made above the elements.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
pub enum End {
    /// A cluster of two or more surfaces (a node of the [`ClusterTree`]).
    Cluster(u32),
    /// One element of one surface (the root: the whole surface).
    Element(ElementRef),
}

/// Light exchanged between two ends as wholes, in both directions.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ClusterLink {
    /// Its two ends.
    pub ends: [End; 2],
    /// Fraction of the lines between the ends' facing points that nothing
    /// blocks.
    pub visibility: f64,
}

/// What linking from the top makes.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Linking {
    /// Element pairs that can exchange light (neither behind the other nor
    /// pressed together, [`KernelContext::exchange_nothing`]),
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
    /// element of a surface with a Lambertian lobe to, on every surface:
    /// not the projection's [`KernelContext::deepest_level`], under which a
    /// small surface's elements, kept whole towards far clusters, made
    /// veach-bidir's back wall glow beside its spotlight
    /// (`docs/decisions-measurements.md`, "Elements as small as the largest
    /// surface's"). A surface without one stops at its deepest level
    /// (`Linker::split_limit`).
    pub max_level: u32,
    /// The two-point oracle's threshold, read as the largest error a
    /// link's visibility estimate may make in its receiver's radiance
    /// relative to its source's ([`rays_needed`]).
    pub threshold: f64,
    /// Bytes the solve holds per cluster link, besides the link, to gather
    /// through it: counted against the memory limit as links are made
    /// ([`Progress::holding`]).
    pub gather_bytes: u64,
}

/// Upper bound on the light a link between two ends carries, as a
/// fraction of the source's radiance reaching the receiver's radiance:
/// ρ_x·F(x←y) for either direction, with F(x←y) the form factor from any
/// point of `x` to every member of `y` (each member counted on its own, as
/// the cluster gather sums them, [`crate::solve::cluster_gather`]). Each
/// member m of y adds at most A_m/(π d²) (both cosines at most 1), and no
/// point of x is closer than d_min = |c_x − c_y| − r_x − r_y to one of y,
/// so F(x←y) ≤ A_y/(π d_min²) (eq. 12 with the kernel bounded). `reach`
/// gives each end's (bounding sphere centre, radius, area of its members,
/// largest Lambertian reflectance). Infinite for spheres that overlap.
pub fn transfer_bound(x: (DVec3, f64, f64, f64), y: (DVec3, f64, f64, f64)) -> f64 {
    let ((cx, rx, ax, rho_x), (cy, ry, ay, rho_y)) = (x, y);
    let gap = cx.distance(cy) - rx - ry;
    if gap <= 0.0 {
        return f64::INFINITY;
    }
    (rho_x * ay).max(rho_y * ax) / (std::f64::consts::PI * gap * gap)
}

/// [`transfer_bound`] for two planar elements `a` and `c`, with their
/// cosines bounded too: for x on `a` and y on `c`, r·cosθ_x = n_a·(y − x)
/// is the height of y over `a`'s plane, at most the highest corner of `c`
/// over it, H_ac (and likewise H_ca), so the kernel cosθ_x cosθ_y/(π r²)
/// is at most min(1, H_ac/d_min)·min(1, H_ca/d_min)/(π d_min²). Two
/// triangles of a smooth concave mesh, nearly in one plane, exchange
/// little however near: each lies a little above the other's plane.
pub fn element_bound(
    a: &Patch,
    c: &Patch,
    ea: (DVec3, f64, f64, f64),
    ec: (DVec3, f64, f64, f64),
) -> f64 {
    let height = |from: &Patch, to: &Patch| {
        let (n, origin) = (from.normal(), from.centroid());
        let top = to
            .vertices()
            .into_iter()
            .map(|v| n.dot(v - origin))
            .fold(f64::NEG_INFINITY, f64::max);
        top.max(0.0)
    };
    let gap = ea.0.distance(ec.0) - ea.1 - ec.1;
    if gap <= 0.0 {
        return f64::INFINITY;
    }
    let cosines = (height(a, c) / gap).min(1.0) * (height(c, a) / gap).min(1.0);
    cosines * transfer_bound(ea, ec)
}

/// Facing rays a cluster link whose transfer is at most `bound`
/// ([`transfer_bound`]) traces so that its visibility estimate errs by at
/// most `threshold` in the receiver's radiance relative to the source's:
/// the fraction of N rays that pass errs by at most 1/(2√N) (one standard
/// deviation of a binomial fraction), so N ≥ (bound / 2·threshold)²; at
/// least one, at most [`CLUSTER_LINK_RAYS`].
pub fn rays_needed(bound: f64, threshold: f64) -> u32 {
    if threshold <= 0.0 || !bound.is_finite() {
        return CLUSTER_LINK_RAYS;
    }
    let n = (bound / (2.0 * threshold)).powi(2).ceil();
    if n >= f64::from(CLUSTER_LINK_RAYS) {
        CLUSTER_LINK_RAYS
    } else {
        (n as u32).max(1)
    }
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
    /// Asks the linking to stop refining ([`Progress::interrupted`]).
    progress: &'a dyn Progress,
    /// Pairs linked at [`MAX_CLUSTER_RATIO`] because the work was asked
    /// to stop.
    coarse: AtomicU64,
    /// By cluster node: whether it holds emitters and other surfaces
    /// both. Such a cluster is never linked whole: one visibility fraction
    /// for all its members would let its other surfaces' visibility stand
    /// for the emitters' (a bulb deep in its lamp's housing, which sends
    /// light out of the housing's opening only).
    mixed: Vec<bool>,
    /// By cluster node: whether all its members are plain Lambertian
    /// surfaces that emit nothing, which may be linked whole however near
    /// when they exchange little ([`Linker::carries_little`]).
    plain: Vec<bool>,
}

/// Whether surface `s` of `scene` is a Lambertian surface that emits
/// nothing.
fn is_plain(scene: &Scene, s: u32) -> bool {
    let surface = &scene.surfaces[s as usize];
    !surface.is_emitter() && matches!(surface.brdf, Brdf::Diffuse(_))
}

/// Whether `members` (surfaces of `scene`) hold emitters and other
/// surfaces both.
fn holds_emitters_and_others(scene: &Scene, members: &[u32]) -> bool {
    let emits = |s: &u32| scene.surfaces[*s as usize].is_emitter();
    members.iter().any(emits) && !members.iter().all(emits)
}

/// Link `clusters` (the scene's) from the root down ([`Linking`]). Once
/// `progress` asks the work to stop ([`Progress::interrupted`]: a spent
/// budget), the pairs left are linked at [`MAX_CLUSTER_RATIO`] rather than
/// the settings' ratio, and counted ([`Progress::cut_short`]); their cluster
/// links are reported as held ([`Progress::holding`]).
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
    let linker = Linker::new(ctx, clusters, settings, progress);
    let mut linking = linker.with_itself(0);
    // Appending the halves' links doubled the vectors' capacity as they
    // grew: up to twice the links, held for the whole solve.
    linking.element_pairs.shrink_to_fit();
    linking.cluster_links.shrink_to_fit();
    let coarse = linker.coarse.load(Ordering::Relaxed);
    if coarse > 0 {
        progress.cut_short(coarse);
    }
    progress.advance(1);
    progress.finish();
    linking
}

impl<'a> Linker<'a> {
    fn new(
        ctx: &KernelContext<'a>,
        clusters: &'a ClusterTree,
        settings: ClusterSettings,
        progress: &'a dyn Progress,
    ) -> Self {
        let mixed = (0..clusters.nodes.len() as u32)
            .into_par_iter()
            .map(|c| holds_emitters_and_others(ctx.scene, clusters.members_of(c)))
            .collect();
        let plain = (0..clusters.nodes.len() as u32)
            .into_par_iter()
            .map(|c| (clusters.members_of(c).iter()).all(|&s| is_plain(ctx.scene, s)))
            .collect();
        Linker {
            ctx: *ctx,
            clusters,
            settings,
            progress,
            coarse: AtomicU64::new(0),
            mixed,
            plain,
        }
    }

    /// The end a cluster node stands for: a leaf is its surface's root
    /// element.
    fn end_of(&self, c: u32) -> End {
        match self.clusters.nodes[c as usize].children {
            Some(_) => End::Cluster(c),
            None => End::Element(ElementRef::root(self.clusters.members_of(c)[0])),
        }
    }

    fn patch(&self, e: ElementRef) -> Patch {
        let root = self.ctx.scene.surfaces[e.surface as usize].patch;
        if e.id.level == 0 {
            root
        } else {
            e.id.patch(&root)
        }
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
                let (center, radius) = bounding_sphere(&self.patch(e));
                Bounds { center, radius }
            }
        }
    }

    /// An end's bounding sphere, the area of its members and their
    /// largest Lambertian reflectance, as [`transfer_bound`] takes them.
    fn extent(&self, end: End) -> (DVec3, f64, f64, f64) {
        let b = self.bounds(end);
        let (area, reflectance) = match end {
            End::Cluster(c) => {
                let node = &self.clusters.nodes[c as usize];
                (node.area, node.reflectance)
            }
            End::Element(e) => {
                let surface = &self.ctx.scene.surfaces[e.surface as usize];
                let rho = surface.brdf.lambertian().map_or(0.0, |r| r.max_channel());
                (self.patch(e).area(), rho)
            }
        };
        (b.center, b.radius, area, reflectance)
    }

    /// An end's bounding sphere and [`Orientation`], as [`height_over`]
    /// takes them.
    fn placed(&self, end: End) -> (DVec3, f64, Orientation) {
        match end {
            End::Cluster(c) => {
                let node = &self.clusters.nodes[c as usize];
                (node.center, node.radius, node.orientation)
            }
            End::Element(e) => {
                let patch = self.patch(e);
                let (center, radius) = bounding_sphere(&patch);
                (center, radius, Orientation::of_patch(&patch, center))
            }
        }
    }

    /// The bounds [`height_over`] gives on the heights of each end over the
    /// other's members' planes, and the least distance between their
    /// points.
    fn heights(&self, x: End, y: End) -> (f64, f64, f64) {
        let ((cx, rx, ox), (cy, ry, oy)) = (self.placed(x), self.placed(y));
        (
            height_over((cx, rx, &ox), (cy, ry, &oy)),
            height_over((cy, ry, &oy), (cx, rx, &ox)),
            cx.distance(cy) - rx - ry,
        )
    }

    /// [`transfer_bound`] of two ends with their cosines bounded by their
    /// heights over each other ([`Linker::heights`]), as [`element_bound`]
    /// bounds them for two elements: ρ·A·min(1, H_xy/d_min)·min(1,
    /// H_yx/d_min)/(π d_min²).
    fn bound(&self, x: End, y: End, (hxy, hyx, gap): (f64, f64, f64)) -> f64 {
        let transfer = transfer_bound(self.extent(x), self.extent(y));
        if gap <= 0.0 {
            return transfer;
        }
        let cosines = (hxy / gap).clamp(0.0, 1.0) * (hyx / gap).clamp(0.0, 1.0);
        cosines * transfer
    }

    /// Whether an end's members are all plain Lambertian surfaces that
    /// emit nothing.
    fn plain(&self, end: End) -> bool {
        match end {
            End::Cluster(c) => self.plain[c as usize],
            End::Element(e) => is_plain(self.ctx.scene, e.surface),
        }
    }

    /// Whether two ends are apart and small against their distance:
    /// (r_x + r_y)/d at most `ratio` (0: never).
    fn small_against_distance(bx: &Bounds, by: &Bounds, ratio: f64) -> bool {
        let (reach, d) = (bx.radius + by.radius, bx.center.distance(by.center));
        ratio > 0.0 && d > reach && reach <= ratio * d
    }

    /// Whether `end` may be linked as a whole: not a cluster holding
    /// emitters and other surfaces both.
    fn linkable_whole(&self, end: End) -> bool {
        !matches!(end, End::Cluster(c) if self.mixed[c as usize])
    }

    /// Whether the work was asked to stop and links with clusters are made
    /// at all (a cluster ratio above 0): then the pairs left are linked at
    /// [`MAX_CLUSTER_RATIO`].
    fn coarsening(&self) -> bool {
        self.settings.ratio > 0.0 && self.progress.interrupted()
    }

    /// Push the link between `x` and `y`, if they exchange light; `bound`
    /// is their [`Linker::bound`].
    fn push_link(&self, x: End, y: End, bound: f64, out: &mut Linking) {
        if let Some(link) = self.cluster_link(x, y, bound) {
            // The link, and a share of what gathering through it holds
            // with each of the link's copies.
            let gathering = self.settings.gather_bytes.div_ceil(LINK_COPIES);
            self.progress
                .holding(std::mem::size_of::<ClusterLink>() as u64 + gathering);
            out.cluster_links.push(link);
        }
    }

    /// Whether the light elements `a` and `c` exchange is within the
    /// oracle's threshold however it varies over them ([`element_bound`]
    /// at most `threshold`): then one cluster link carries it, and the
    /// pair is not projected (whose quadrature would cost 16 rays or more
    /// to find a kernel the oracle accepts at once).
    fn carries_little(&self, a: ElementRef, c: ElementRef) -> bool {
        if self.settings.ratio <= 0.0 {
            return false;
        }
        let (pa, pc) = (self.patch(a), self.patch(c));
        let (ea, ec) = (self.extent(End::Element(a)), self.extent(End::Element(c)));
        element_bound(&pa, &pc, ea, ec) <= self.settings.threshold
    }

    /// Whether either element's surface emits: its direct light is
    /// projected as the paper does, whatever the distance.
    fn emits(&self, a: ElementRef, c: ElementRef) -> bool {
        let surfaces = &self.ctx.scene.surfaces;
        surfaces[a.surface as usize].is_emitter() || surfaces[c.surface as usize].is_emitter()
    }

    /// Deepest level an element of surface `s` is split to towards a
    /// cluster. A surface with a Lambertian lobe keeps its radiance per
    /// element, so its elements split to `max_level` where a cluster near
    /// them needs it. A surface without one (a metal, a glossy coat) keeps
    /// the light it reflects per surface, as distributions over directions
    /// ([`crate::solve::glossy_clusters`]) or in its three-point links:
    /// finer elements would sharpen only the link's geometry, which the
    /// cluster at the other end, split instead, sharpens as well. Its
    /// elements stop at [`KernelContext::deepest_level`] (A_ε), where its
    /// two-point projection stops too, rather than splitting a fine metal
    /// mesh's every triangle 4^max_level ways near its neighbours.
    fn split_limit(&self, s: u32) -> u32 {
        if self.ctx.scene.surfaces[s as usize]
            .brdf
            .lambertian()
            .is_some()
        {
            self.settings.max_level
        } else {
            self.ctx.deepest_level(s, self.settings.max_level)
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
            if a.surface == c.surface || self.ctx.exchange_nothing(&self.patch(a), &self.patch(c)) {
                return;
            }
            if !self.emits(a, c) && self.carries_little(a, c) {
                self.push_link(x, y, self.bound(x, y, self.heights(x, y)), out);
                return;
            }
            // In surface order, as the projection of every pair of
            // surfaces from their roots takes them.
            out.element_pairs.push(if a.surface < c.surface {
                [a, c]
            } else {
                [c, a]
            });
            return;
        }
        let (bx, by) = (self.bounds(x), self.bounds(y));
        let (whole_x, whole_y) = (self.linkable_whole(x), self.linkable_whole(y));
        let near_enough = Self::small_against_distance(&bx, &by, self.settings.ratio);
        let heights = self.heights(x, y);
        if heights.0 <= 0.0 || heights.1 <= 0.0 {
            // One wholly behind the other's members: no pair of their
            // members exchanges light.
            return;
        }
        if whole_x && whole_y && near_enough {
            self.push_link(x, y, self.bound(x, y, heights), out);
            return;
        }
        // Plain ends nearer than the ratio that can exchange no more than
        // the threshold (neighbouring parts of a smooth concave mesh, each
        // a little above the other's planes) are linked whole, as
        // neighbouring elements are ([`Linker::carries_little`]).
        if self.settings.ratio > 0.0
            && self.plain(x)
            && self.plain(y)
            && Self::small_against_distance(&bx, &by, MAX_CLUSTER_RATIO)
        {
            let bound = self.bound(x, y, heights);
            if bound <= self.settings.threshold {
                self.push_link(x, y, bound, out);
                return;
            }
        }
        // Once the budget is spent, ends apart by the coarsest ratio are
        // linked as they stand.
        if whole_x
            && whole_y
            && Self::small_against_distance(&bx, &by, MAX_CLUSTER_RATIO)
            && self.coarsening()
        {
            self.coarse.fetch_add(1, Ordering::Relaxed);
            self.push_link(x, y, self.bound(x, y, heights), out);
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
                    && e.id.level < self.split_limit(e.surface)
                    && off_plane > other.radius
            }
        };
        // Ends that could be linked but for a mixed cluster split it.
        let split_x = if !(whole_x && whole_y) && near_enough {
            !whole_x && (bx.radius >= by.radius || whole_y)
        } else {
            splittable(x, &by) && (bx.radius >= by.radius || !splittable(y, &bx))
        };
        let (split, other) = if split_x { (x, y) } else { (y, x) };
        let parts: Vec<End> = match split {
            End::Cluster(c) => {
                let children = self.clusters.nodes[c as usize].children;
                children
                    .into_iter()
                    .flatten()
                    .map(|k| self.end_of(k))
                    .collect()
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

    /// The link between `x` and `y` (whose [`Linker::bound`] is `bound`),
    /// or `None` when no line between their facing points is clear (they
    /// exchange no light). Of at most [`CLUSTER_LINK_RAYS`] pairs of points
    /// drawn, as many facing pairs as the link's transfer needs
    /// ([`rays_needed`]) are traced.
    fn cluster_link(&self, x: End, y: End, bound: f64) -> Option<ClusterLink> {
        let seed = end_seed(x).rotate_left(17) ^ end_seed(y);
        let needed = rays_needed(bound, self.settings.threshold);
        let (mut facing, mut clear) = (0u32, 0u32);
        for j in 0..CLUSTER_LINK_RAYS {
            if facing == needed {
                break;
            }
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

/// A sphere about a patch's centroid that holds it: (centre, radius).
fn bounding_sphere(patch: &Patch) -> (DVec3, f64) {
    let center = patch.centroid();
    let radius = patch
        .vertices()
        .into_iter()
        .map(|v| v.distance(center))
        .fold(0.0, f64::max);
    (center, radius)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::tracing::SceneTracer;
    use crate::progress::Silent;
    use crate::scene::brdf::Brdf;
    use crate::scene::Rgb;
    use crate::testing::grey;
    use std::collections::{BTreeMap, BTreeSet};

    /// A grid of `n` × `n` unit squares in the plane through `origin`
    /// spanned by `s`, `t` (facing s × t).
    fn grid(origin: DVec3, s: DVec3, t: DVec3, n: usize) -> impl Iterator<Item = Patch> {
        (0..n * n).map(move |k| Patch::Parallelogram {
            origin: origin + (k % n) as f64 * s + (k / n) as f64 * t,
            edge_s: s,
            edge_t: t,
        })
    }

    #[test]
    fn the_transfer_bound_is_never_below_the_form_factors_it_bounds() {
        // Random pairs of spheres; in one, a point with a random normal,
        // in the other, random triangles (a cluster's members): the sum of
        // their form factors from the point (Lambert's formula, both
        // cosines), times the receiver's reflectance, stays below the
        // bound, and so does the other direction's.
        use crate::kernel::form_factor::point_to_polygon;
        let mut closest = f64::INFINITY;
        for i in 0..400u64 {
            let r = |k: u64| crate::sampling::hash2(i, k);
            let unit = |k: u64| {
                let (u, v) = (r(k), r(k + 1));
                let z = 2.0 * u.x - 1.0;
                let phi = std::f64::consts::TAU * u.y;
                let s = (1.0 - z * z).sqrt();
                DVec3::new(s * phi.cos(), s * phi.sin(), z) * v.x.cbrt()
            };
            let (rx, ry) = (0.05 + r(1).x, 0.05 + r(1).y);
            let cx = DVec3::ZERO;
            let cy = unit(2).normalize() * (rx + ry) * (1.0 + 3.0 * r(3).x);
            let x = cx + 0.9 * rx * unit(4);
            let n_x = unit(6).normalize();
            let members: Vec<[DVec3; 3]> = (0..1 + (i % 5))
                .map(|m| [0, 2, 4].map(|k| cy + ry * unit(10 + 6 * m + k)))
                .collect();
            let area: f64 = members
                .iter()
                .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length())
                .sum();
            let (rho_x, rho_y) = (r(50).x, r(50).y);
            let received: f64 = members
                .iter()
                .map(|[a, b, c]| {
                    let n = (*b - *a).cross(*c - *a).normalize();
                    point_to_polygon(x, n_x, &[*a, *b, *c], n)
                })
                .sum();
            // Sent back: from a point on one member to a small patch of x.
            let [a, b, c] = members[0];
            let y = (a + b + c) / 3.0;
            let n_y = (b - a).cross(c - a).normalize();
            let side = 0.05 * rx;
            let (e1, e2) = n_x.any_orthonormal_pair();
            let patch = [x, x + side * e1, x + side * (e1 + e2), x + side * e2];
            let ax = side * side;
            let sent = point_to_polygon(y, n_y, &patch, n_x);
            let bound = transfer_bound((cx, rx, ax, rho_x), (cy, ry, area, rho_y));
            assert!(
                rho_x * received <= bound,
                "config {i}: {received} > {bound}"
            );
            assert!(rho_y * sent <= bound, "config {i}: {sent} > {bound}");
            closest = closest.min(bound / (rho_x * received).max(rho_y * sent).max(1e-300));
        }
        // Not loose everywhere: within two orders somewhere.
        assert!(closest < 100.0, "{closest}");
    }

    #[test]
    fn the_element_bound_is_never_below_the_form_factors_it_bounds() {
        // Random pairs of triangles, some nearly in one plane (as a fine
        // concave mesh's neighbours are), some facing: at points of each,
        // the form factor to the other (Lambert's formula) times the
        // receiver's reflectance stays below the bound.
        use crate::kernel::form_factor::point_to_polygon;
        let (mut tight, mut small) = (f64::INFINITY, 0);
        for i in 0..500u64 {
            let r = |k: u64| crate::sampling::hash2(i, k);
            let tilt = if i % 2 == 0 { 0.05 } else { 1.0 };
            let triangle = |centre: DVec3, k: u64| -> Patch {
                let corner = |j: u64| {
                    let u = r(k + j);
                    centre + DVec3::new(u.x - 0.5, tilt * (r(k + 7 + j).x - 0.5), u.y - 0.5)
                };
                Patch::Triangle([corner(0), corner(1), corner(2)])
            };
            let along = 1.0 + 4.0 * r(20).x;
            let (a, c) = (
                triangle(DVec3::ZERO, 30),
                triangle(DVec3::new(along, 0.0, 0.3 * r(21).y), 40),
            );
            let extent = |p: &Patch, rho: f64| {
                let (centre, radius) = bounding_sphere(p);
                (centre, radius, p.area(), rho)
            };
            let (ea, ec) = (extent(&a, r(22).x), extent(&c, r(22).y));
            let bound = element_bound(&a, &c, ea, ec);
            if !bound.is_finite() {
                continue;
            }
            let mut largest = 0.0f64;
            for (from, to, rho) in [(&a, &c, ea.3), (&c, &a, ec.3)] {
                for k in 0..16 {
                    let u = r(100 + k);
                    let (s, t) = if u.x + u.y > 1.0 {
                        (1.0 - u.x, 1.0 - u.y)
                    } else {
                        (u.x, u.y)
                    };
                    let [v0, v1, v2] = <[DVec3; 3]>::try_from(from.vertices()).unwrap();
                    let x = v0 + s * (v1 - v0) + t * (v2 - v0);
                    let f = point_to_polygon(x, from.normal(), &to.vertices(), to.normal());
                    assert!(rho * f <= bound, "config {i}: {} > {bound}", rho * f);
                    largest = largest.max(rho * f);
                }
            }
            if largest > 0.0 {
                tight = tight.min(bound / largest);
            }
            if tilt < 1.0 && bound < transfer_bound(ea, ec) / 10.0 {
                small += 1;
            }
        }
        assert!(tight < 10.0, "{tight}");
        // Nearly coplanar pairs are bounded far below the cosine-free bound.
        assert!(small > 100, "{small}");
    }

    #[test]
    fn rays_needed_keep_the_visibility_error_within_the_threshold() {
        let threshold = 1e-3;
        for k in 0..60 {
            let bound = 1e-5 * 1.3f64.powi(k);
            let n = rays_needed(bound, threshold);
            assert!((1..=CLUSTER_LINK_RAYS).contains(&n));
            if n < CLUSTER_LINK_RAYS {
                assert!(bound / (2.0 * f64::from(n).sqrt()) <= threshold * (1.0 + 1e-12));
            }
            if n > 1 {
                let fewer = f64::from(n - 1);
                assert!(bound / (2.0 * fewer.sqrt()) > threshold, "{bound}: {n}");
            }
        }
        assert_eq!(rays_needed(f64::INFINITY, threshold), CLUSTER_LINK_RAYS);
        assert_eq!(rays_needed(1e-9, threshold), 1);
    }

    /// A floor of 8 × 8 squares, a facing ceiling of 8 × 8 and a large
    /// wall between them, with the context and cluster tree to link them.
    fn floor_ceiling_and_wall() -> Scene {
        let floor = grid(DVec3::ZERO, DVec3::X, DVec3::Y, 8);
        let ceiling = grid(DVec3::new(0.0, 0.0, 12.0), DVec3::Y, DVec3::X, 8);
        let wall = Patch::Parallelogram {
            origin: DVec3::new(-1.0, -1.0, 0.5),
            edge_s: DVec3::new(0.0, 10.0, 0.0),
            edge_t: DVec3::new(0.0, 0.0, 11.0),
        };
        let patches: Vec<Patch> = floor.chain(ceiling).chain([wall]).collect();
        Scene::from_surfaces(patches.into_iter().map(grey).collect())
    }

    const SETTINGS: ClusterSettings = ClusterSettings {
        ratio: 0.25,
        max_level: 5,
        threshold: 1e-3,
        gather_bytes: 0,
    };

    /// Each pair of surfaces of `ctx`'s scene that face each other is
    /// linked exactly once by `linking` (made over `clusters`): the covered
    /// fraction of p × r, from element pairs and cluster links, sums to
    /// one (to zero for pairs that exchange nothing).
    fn assert_every_pair_covered_once(
        ctx: &KernelContext,
        clusters: &ClusterTree,
        linking: &Linking,
    ) {
        let scene = ctx.scene;
        let area = |e: ElementRef| {
            let root = &scene.surfaces[e.surface as usize].patch;
            e.id.patch(root).area() / root.area()
        };
        // (p, r) → covered fraction, from both kinds of links.
        let mut covered: BTreeMap<(u32, u32), f64> = BTreeMap::new();
        let mut cover =
            |p: u32, r: u32, f: f64| *covered.entry((p.min(r), p.max(r))).or_default() += f;
        for [a, c] in &linking.element_pairs {
            cover(a.surface, c.surface, area(*a) * area(*c));
        }
        let members = |end: End| -> Vec<(u32, f64)> {
            match end {
                End::Cluster(c) => clusters.members_of(c).iter().map(|&s| (s, 1.0)).collect(),
                End::Element(e) => vec![(e.surface, area(e))],
            }
        };
        for l in &linking.cluster_links {
            for (p, fp) in members(l.ends[0]) {
                for (r, fr) in members(l.ends[1]) {
                    assert_ne!(p, r, "a cluster link within one surface");
                    cover(p, r, fp * fr);
                }
            }
        }
        let n = scene.surfaces.len() as u32;
        for p in 0..n {
            for r in p + 1..n {
                let (sp, sr) = (&scene.surfaces[p as usize], &scene.surfaces[r as usize]);
                let c = covered.get(&(p, r)).copied().unwrap_or(0.0);
                assert!(c <= 1.0 + 1e-9, "surfaces {p} and {r} linked {c} times");
                if !ctx.exchange_nothing(&sp.patch, &sr.patch) {
                    assert!((c - 1.0).abs() < 1e-9, "surfaces {p} and {r} covered {c}");
                }
            }
        }
    }

    #[test]
    fn every_pair_of_surfaces_is_covered_once() {
        // Pairs near each other go to the projection, distant groups to
        // cluster links, and the wall's elements are split towards the
        // clusters that face them. Whatever the mix, each pair of surfaces
        // that face each other must be linked exactly once.
        let scene = floor_ceiling_and_wall();
        let tracer = SceneTracer::new(&scene);
        let ctx = crate::kernel::default_context(&scene, &tracer);
        let clusters = ClusterTree::build(&scene);
        let linking = link_from_root(&ctx, &clusters, SETTINGS, &Silent);
        assert!(!linking.cluster_links.is_empty());
        assert!(linking.cluster_links.iter().any(|l| l
            .ends
            .iter()
            .any(|e| matches!(e, End::Element(e) if e.id.level > 0))));
        assert_every_pair_covered_once(&ctx, &clusters, &linking);
    }

    #[test]
    fn near_parts_of_a_smooth_concave_mesh_are_linked_whole_and_its_two_sides_never() {
        // A fine two-sided bowl: parts of its inside nearer than the ratio
        // that exchange little are linked whole, no link joins the inside
        // to the outside (which face away from each other), and every pair
        // that exchanges light is still covered once.
        let scene = crate::testing::bowl(16, true);
        let tracer = SceneTracer::new(&scene);
        let ctx = crate::kernel::default_context(&scene, &tracer);
        let clusters = ClusterTree::build(&scene);
        let linking = link_from_root(&ctx, &clusters, SETTINGS, &Silent);
        let linker = Linker::new(&ctx, &clusters, SETTINGS, &Silent);
        let inside = |s: u32| s.is_multiple_of(2);
        let members = |end: End| match end {
            End::Cluster(c) => clusters.members_of(c).to_vec(),
            End::Element(e) => vec![e.surface],
        };
        let (mut near, mut whole) = (0, 0);
        for l in &linking.cluster_links {
            let sides: BTreeSet<bool> = (l.ends.iter())
                .flat_map(|&e| members(e))
                .map(inside)
                .collect();
            assert_eq!(sides.len(), 1, "a link across the sides: {l:?}");
            let (bx, by) = (linker.bounds(l.ends[0]), linker.bounds(l.ends[1]));
            if !Linker::small_against_distance(&bx, &by, SETTINGS.ratio) {
                near += 1;
                whole += usize::from(l.ends.iter().any(|e| matches!(e, End::Cluster(_))));
            }
        }
        assert!(whole > 0 && near > whole, "{whole} of {near}");
        assert_every_pair_covered_once(&ctx, &clusters, &linking);
    }

    /// One floor square emits: the clusters that hold it with other
    /// squares, linked whole to the ceiling without it, are split so that
    /// it is linked on its own (or in a cluster of emitters alone), and
    /// every pair is still covered once.
    #[test]
    fn a_cluster_holding_an_emitter_and_other_surfaces_is_never_linked_whole() {
        let mut scene = floor_ceiling_and_wall();
        let mixed = |scene: &Scene, clusters: &ClusterTree, end: &End| match *end {
            End::Cluster(c) => holds_emitters_and_others(scene, clusters.members_of(c)),
            End::Element(_) => false,
        };
        let holding_square_0 = |clusters: &ClusterTree, linking: &Linking| {
            (linking.cluster_links.iter())
                .flat_map(|l| l.ends)
                .filter(|e| matches!(e, End::Cluster(c) if clusters.members_of(*c).contains(&0)))
                .count()
        };
        let clusters = ClusterTree::build(&scene);
        {
            let tracer = SceneTracer::new(&scene);
            let ctx = crate::kernel::default_context(&scene, &tracer);
            let dark = link_from_root(&ctx, &clusters, SETTINGS, &Silent);
            assert!(holding_square_0(&clusters, &dark) > 0);
        }
        scene.surfaces[0].emission = Rgb::splat(10.0);
        let tracer = SceneTracer::new(&scene);
        let ctx = crate::kernel::default_context(&scene, &tracer);
        let lit = link_from_root(&ctx, &clusters, SETTINGS, &Silent);
        assert_eq!(holding_square_0(&clusters, &lit), 0);
        assert!(!lit.cluster_links.is_empty());
        for l in &lit.cluster_links {
            assert!(!l.ends.iter().any(|e| mixed(&scene, &clusters, e)), "{l:?}");
        }
        assert_every_pair_covered_once(&ctx, &clusters, &lit);
    }

    /// A glossy tile's elements stop at its deepest level (A_ε) when a
    /// cluster of small squares under it would split them finer; a diffuse
    /// tile's split further.
    #[test]
    fn a_glossy_surface_splits_towards_a_cluster_no_finer_than_its_area_allows() {
        // Floor 16 × 16 (the largest surface: A_ε = 256/4⁵ = 0.25), a unit
        // tile facing down at z = 0.5, and 4 × 4 squares of 0.1 facing up
        // at z = 0.1 under its middle.
        let floor = grid(DVec3::ZERO, 16.0 * DVec3::X, 16.0 * DVec3::Y, 1);
        let tile = Patch::Parallelogram {
            origin: DVec3::new(4.0, 4.0, 0.5),
            edge_s: DVec3::Y,
            edge_t: DVec3::X,
        };
        let squares = (0..16).map(|k| Patch::Parallelogram {
            origin: DVec3::new(4.3 + 0.1 * (k % 4) as f64, 4.3 + 0.1 * (k / 4) as f64, 0.1),
            edge_s: 0.1 * DVec3::X,
            edge_t: 0.1 * DVec3::Y,
        });
        let patches: Vec<Patch> = floor.chain([tile]).chain(squares).collect();
        let deepest_tile_element = |brdf: Brdf| {
            let mut scene = Scene::from_surfaces(patches.iter().copied().map(grey).collect());
            scene.surfaces[1].brdf = brdf;
            let tracer = SceneTracer::new(&scene);
            let ctx = crate::kernel::default_context(&scene, &tracer);
            assert_eq!(ctx.deepest_level(1, SETTINGS.max_level), 1);
            let clusters = ClusterTree::build(&scene);
            let linking = link_from_root(&ctx, &clusters, SETTINGS, &Silent);
            assert_every_pair_covered_once(&ctx, &clusters, &linking);
            let ends = (linking.element_pairs.iter().flatten().copied()).chain(
                linking.cluster_links.iter().flat_map(|l| {
                    l.ends.into_iter().filter_map(|e| match e {
                        End::Element(e) => Some(e),
                        End::Cluster(_) => None,
                    })
                }),
            );
            ends.filter(|e| e.surface == 1).map(|e| e.id.level).max()
        };
        let diffuse = deepest_tile_element(Brdf::diffuse(Rgb::splat(0.5)));
        assert!(diffuse > Some(1), "{diffuse:?}");
        let mut metal = crate::testing::rolled_aluminium();
        if let Brdf::Ward(w) = &mut metal {
            w.diffuse_reflectance = Rgb::ZERO;
        }
        assert_eq!(metal.lambertian(), None);
        assert_eq!(deepest_tile_element(metal), Some(1));
    }

    #[test]
    fn a_spent_budget_links_the_pairs_left_coarser_and_still_covers_every_pair_once() {
        use crate::progress::{Budget, Budgeted, Stop};
        use std::time::Duration;
        let scene = floor_ceiling_and_wall();
        let tracer = SceneTracer::new(&scene);
        let ctx = crate::kernel::default_context(&scene, &tracer);
        let clusters = ClusterTree::build(&scene);
        let link = |budget: &Budget| {
            let progress = Budgeted {
                progress: &Silent,
                budget,
            };
            link_from_root(&ctx, &clusters, SETTINGS, &progress)
        };
        let full = link_from_root(&ctx, &clusters, SETTINGS, &Silent);

        // A budget that is never spent changes nothing.
        let open = Budget::new(Some(Duration::from_secs(3600)), None);
        assert_eq!(link(&open), full);
        assert_eq!((open.stopped(), open.coarse_items()), (None, 0));

        // Spent from the start: the pairs apart by the coarsest ratio are
        // linked as they stand, each counted, and no pair of surfaces is
        // left out or linked twice.
        let spent = Budget::new(Some(Duration::ZERO), None);
        let cut = link(&spent);
        assert_eq!(spent.stopped(), Some(Stop::TimeLimit));
        assert!(spent.coarse_items() > 0);
        assert!(
            cut.cluster_links.len() < full.cluster_links.len(),
            "{} cluster links, {} unlimited",
            cut.cluster_links.len(),
            full.cluster_links.len()
        );
        assert!(cut.element_pairs.len() <= full.element_pairs.len());
        assert_every_pair_covered_once(&ctx, &clusters, &cut);

        // Coarser, but never closer than the coarsest ratio: ends apart,
        // so every member's transfer stays finite.
        let linker = Linker::new(&ctx, &clusters, SETTINGS, &Silent);
        let ratio = |l: &ClusterLink| {
            let [bx, by] = l.ends.map(|e| linker.bounds(e));
            (bx.radius + by.radius) / bx.center.distance(by.center)
        };
        let with_a_cluster = || {
            (cut.cluster_links.iter())
                .filter(|l| l.ends.iter().any(|e| matches!(e, End::Cluster(_))))
        };
        assert!(with_a_cluster().all(|l| ratio(l) <= MAX_CLUSTER_RATIO));
        assert!(with_a_cluster().any(|l| ratio(l) > SETTINGS.ratio));
    }
}
