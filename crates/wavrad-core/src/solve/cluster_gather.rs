//! Gathering through cluster links ([`crate::refine::cluster_links`]).
//!
//! An end's members m (a cluster's surfaces, read as their average
//! radiance, or one element) that face the other end send, in direction ω,
//! the intensity I(ω) = Σ_m A_m (n_m·ω) L_m = N·ω, with N = Σ_m A_m L_m n_m
//! a vector per channel: each member's own cosine, as Sillion 1995's
//! anisotropic clusters and Smits et al. 1994's α-links evaluate them. A
//! receiving member at x gathers ρ·V·max(0, n·u)·I(−u) / (π·d²), u and d the
//! direction and distance from x to the source's area-weighted centroid and
//! V the link's visibility: eq. 12 with the point-to-point form factor
//! between the member and each source member, to second order in the ends'
//! size over their distance.
//!
//! Per sweep this costs O(n + links) plus the links' horizons, not
//! O(Σ_links |cluster|), through each cluster's cone of normals (its
//! members' normals all lie within a half angle of their mean; Shirman &
//! Abi-Ezzi 1993 cull back faces with such cones):
//! - *Sending.* Every cluster's Σ A·L·n is pulled up the tree once, and
//!   an end's N sums the largest clusters under it whose cones all face
//!   the other end, descending only into those that straddle the plane
//!   facing it (a cluster's radiance read as the directional distribution
//!   Christensen, Lischinski, Stollnitz & Salesin 1997 keep at clusters,
//!   and exact: the same members as summing them one by one).
//! - *Receiving.* One pass down the tree carries, for each cluster, the sum
//!   of the fields of the links above it that all its members face, as the
//!   vector F per channel with n·F a member's irradiance over π, and F's
//!   Jacobian J in the receiver's position; a member reads F + J·(x − c)
//!   about the centroid c where it was summed, so its own 1/d² and cosine
//!   are exact to first order in its offset, as a fast multipole method's
//!   local expansion is (Greengard & Rokhlin 1987). Hierarchical
//!   radiosity's push–pull hands down a constant (Hanrahan, Salzman &
//!   Aupperle 1991), which at the cluster ratio 0.25 misses up to half of
//!   a member's irradiance from the 1/d² alone, and measurably darkened
//!   or brightened the members of clusters that receive. A link whose
//!   horizon crosses a cluster's cone is handed down on its own until a
//!   cluster's members all face it or all turn away, or a member
//!   evaluates it exactly; so no member gathers light from behind.
//!
//! [`ClusterTransfers::far_field`] evaluates all of it from one radiance
//! state (a Jacobi step over cluster links; the surfaces' own links stay
//! Gauss–Seidel), and each surface then gathers its root's share and its
//! elements' links.

use crate::geometry::cluster::ClusterTree;
use crate::geometry::hierarchy::{ElementRef, ElementTree};
use crate::refine::cluster_links::{ClusterLink, End};
use crate::scene::{Rgb, Scene};
use crate::solve::glossy_clusters::{GlossyReflectors, NO_BIN};
use crate::solve::push_pull::Gathered;
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::ops::AddAssign;

/// A subtree with more members than this pushes its halves down in
/// parallel.
const PARALLEL_MEMBERS: usize = 2048;

/// A member of a cluster link's end: where it is, which way it faces, how
/// large it is.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
struct Member {
    surface: u32,
    node: u32,
    point: DVec3,
    normal: DVec3,
    area: f64,
}

/// One end of a cluster link, ready for gathering.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
enum Side {
    /// A node of the cluster tree (its members' roots).
    Cluster(u32),
    /// One element, an index into [`ClusterTransfers::elements`].
    Element(u32),
}

/// A cluster link ready for gathering.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
struct Transfer {
    sides: [Side; 2],
    visibility: f64,
}

/// The (link, side) pairs at each of a set of keys, stored flat.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
struct Incidence {
    start: Vec<u32>,
    items: Vec<(u32, u8)>,
}

impl Incidence {
    /// `pairs` (key, item) grouped by key (`keys` of them), each key's
    /// items in the order given.
    fn new(keys: usize, pairs: &[(u32, (u32, u8))]) -> Incidence {
        let mut start = vec![0u32; keys + 1];
        for &(k, _) in pairs {
            start[k as usize + 1] += 1;
        }
        for k in 0..keys {
            start[k + 1] += start[k];
        }
        let mut next = start.clone();
        let mut items = vec![(0, 0); pairs.len()];
        for &(k, item) in pairs {
            items[next[k as usize] as usize] = item;
            next[k as usize] += 1;
        }
        Incidence { start, items }
    }

    fn of(&self, key: u32) -> &[(u32, u8)] {
        let k = key as usize;
        &self.items[self.start[k] as usize..self.start[k + 1] as usize]
    }
}

/// The normals of a cluster's members: all within a half angle of `axis`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
struct NormalCone {
    axis: DVec3,
    /// sin of the half angle; 1 from a right angle on (every direction is
    /// then behind some member's horizon and in front of another's).
    sin_half_angle: f64,
}

/// Where a direction lies for a cone of normals.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Facing {
    /// In front of every normal's horizon.
    All,
    /// Behind every normal's horizon.
    None,
    /// In front of some, behind others.
    Some,
}

impl NormalCone {
    /// Where unit direction `w` lies for this cone's normals.
    fn facing(&self, w: DVec3) -> Facing {
        let a = self.axis.dot(w);
        if a > self.sin_half_angle {
            Facing::All
        } else if a < -self.sin_half_angle {
            Facing::None
        } else {
            Facing::Some
        }
    }
}

/// The cluster links of a solution, arranged for gathering.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct ClusterTransfers {
    /// The scene's cluster tree.
    pub clusters: ClusterTree,
    links: Vec<Transfer>,
    /// Every surface's root as a member (centroid, normal, area).
    roots: Vec<Member>,
    /// The element ends of links, each once.
    elements: Vec<Member>,
    /// The cone of normals of each cluster node's members (none without
    /// links).
    cones: Vec<NormalCone>,
    /// (link, side) of the links at each cluster node.
    at_cluster: Incidence,
    /// (link, side) of the links at an element of each surface.
    at_surface: Incidence,
}

/// The field of cluster links at a receiver, per channel: the vector F with
/// n·F the irradiance over π of a receiver of normal n (before clipping),
/// and its Jacobian in the receiver's position.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Field {
    value: [DVec3; 3],
    jacobian: [DMat3; 3],
}

impl Field {
    const ZERO: Field = Field {
        value: [DVec3::ZERO; 3],
        jacobian: [DMat3::ZERO; 3],
    };

    /// What a receiver of unit normal `normal` gathers: irradiance over π.
    fn received(&self, normal: DVec3) -> Rgb {
        Rgb(self.value.map(|f| normal.dot(f).max(0.0)))
    }
}

impl AddAssign for Field {
    fn add_assign(&mut self, other: Field) {
        for k in 0..3 {
            self.value[k] += other.value[k];
            self.jacobian[k] += other.jacobian[k];
        }
    }
}

/// A field and the point it was evaluated at.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Anchored {
    origin: DVec3,
    field: Field,
}

impl Anchored {
    /// The field at `x`, to first order.
    fn at(&self, x: DVec3) -> Field {
        let offset = x - self.origin;
        let f = &self.field;
        Field {
            value: [0, 1, 2].map(|k| f.value[k] + f.jacobian[k] * offset),
            jacobian: f.jacobian,
        }
    }
}

/// What one side of a cluster link sends towards the other.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sent {
    /// The intensity vectors N of its members' Lambertian radiance, per
    /// channel: I(ω) = N·ω.
    lambertian: [DVec3; 3],
    /// The intensity its glossy members' lobes send towards the other
    /// side's centre ([`crate::solve::glossy_clusters`]).
    glossy: Rgb,
}

impl Sent {
    const ZERO: Sent = Sent {
        lambertian: [DVec3::ZERO; 3],
        glossy: Rgb::ZERO,
    };
}

/// One radiance state's far field: what every link's ends send, and what
/// every surface's root gathers through the clusters above it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FarField {
    /// What each side sends towards the other.
    sent: Vec<[Sent; 2]>,
    /// The scene's glossy surfaces, when it has any and they were asked for.
    reflectors: Option<GlossyReflectors>,
    /// The radiance per bin of every one of them
    /// ([`crate::solve::glossy_clusters`]).
    exitant: Vec<Vec<Rgb>>,
    /// What each surface's root receives through its clusters' links
    /// (irradiance over π, before reflectance).
    at_roots: Vec<Rgb>,
}

impl FarField {
    /// Only its glossy surfaces' light per bin ([`FarField::glossy`]).
    pub fn lobes(self) -> FarField {
        FarField {
            reflectors: self.reflectors,
            exitant: self.exitant,
            ..FarField::default()
        }
    }

    /// The radiance glossy surface `s`'s lobes send into bin `bin` of its
    /// hemisphere; zero for other surfaces, [`NO_BIN`], or a far field
    /// made without its glossy surfaces.
    pub fn glossy(&self, s: u32, bin: u8) -> Rgb {
        match &self.reflectors {
            Some(reflectors) if bin != NO_BIN => (reflectors.index(s))
                .and_then(|k| self.exitant.get(k))
                .map_or(Rgb::ZERO, |e| e[bin as usize]),
            _ => Rgb::ZERO,
        }
    }
}

/// The cone of normals of every node of `clusters`, whose members are
/// `roots`: about their area-weighted mean normal, as wide as the farthest.
fn normal_cones(clusters: &ClusterTree, roots: &[Member]) -> Vec<NormalCone> {
    let nodes = clusters.nodes.len();
    let mut moment = vec![DVec3::ZERO; nodes];
    for c in (0..nodes).rev() {
        moment[c] = match clusters.nodes[c].children {
            Some([a, b]) => moment[a as usize] + moment[b as usize],
            None => {
                let m = &roots[clusters.members_of(c as u32)[0] as usize];
                m.area * m.normal
            }
        };
    }
    let axes: Vec<DVec3> = moment.iter().map(|m| m.normalize_or_zero()).collect();
    let mut nearest = vec![1.0f64; nodes];
    for (s, &leaf) in clusters.leaf_of.iter().enumerate() {
        for c in std::iter::once(leaf).chain(clusters.ancestors(s as u32)) {
            let cos = axes[c as usize].dot(roots[s].normal);
            nearest[c as usize] = nearest[c as usize].min(cos);
        }
    }
    axes.into_iter()
        .zip(nearest)
        .map(|(axis, cos)| NormalCone {
            axis,
            sin_half_angle: if axis == DVec3::ZERO || cos <= 0.0 {
                1.0
            } else {
                (1.0 - cos * cos).max(0.0).sqrt()
            },
        })
        .collect()
}

/// `A·n·L` per channel.
fn weighted(area_normal: DVec3, radiance: Rgb) -> [DVec3; 3] {
    radiance.0.map(|l| area_normal * l)
}

fn sum(a: [DVec3; 3], b: [DVec3; 3]) -> [DVec3; 3] {
    [0, 1, 2].map(|k| a[k] + b[k])
}

impl ClusterTransfers {
    /// Arrange `links` of `scene`, whose surfaces have the element trees
    /// `trees` (holding every element end) and the cluster tree `clusters`.
    pub fn new(
        scene: &Scene,
        clusters: ClusterTree,
        trees: &[ElementTree],
        links: &[ClusterLink],
    ) -> ClusterTransfers {
        let roots: Vec<Member> = scene
            .surfaces
            .iter()
            .enumerate()
            .map(|(s, surface)| Member {
                surface: s as u32,
                node: 0,
                point: surface.patch.centroid(),
                normal: surface.patch.normal(),
                area: surface.patch.area(),
            })
            .collect();
        let mut elements = Vec::new();
        let mut element_of = HashMap::new();
        let mut incident = (Vec::new(), Vec::new());
        let transfers = links
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let mut k = 0;
                let sides = l.ends.map(|end| {
                    let at = (i as u32, k);
                    k += 1;
                    match end {
                        End::Cluster(c) => {
                            incident.0.push((c, at));
                            Side::Cluster(c)
                        }
                        End::Element(e) => {
                            incident.1.push((e.surface, at));
                            let tree = &trees[e.surface as usize];
                            let node = tree
                                .index_of(e.id)
                                .expect("element ends are in their trees");
                            let index = *element_of.entry((e.surface, node)).or_insert_with(|| {
                                let patch = &tree.nodes[node as usize].patch;
                                elements.push(Member {
                                    node,
                                    point: patch.centroid(),
                                    area: patch.area(),
                                    ..roots[e.surface as usize]
                                });
                                elements.len() as u32 - 1
                            });
                            Side::Element(index)
                        }
                    }
                });
                Transfer {
                    sides,
                    visibility: l.visibility,
                }
            })
            .collect();
        ClusterTransfers {
            cones: if links.is_empty() {
                Vec::new()
            } else {
                normal_cones(&clusters, &roots)
            },
            at_cluster: Incidence::new(clusters.nodes.len(), &incident.0),
            at_surface: Incidence::new(roots.len(), &incident.1),
            clusters,
            links: transfers,
            roots,
            elements,
        }
    }

    /// Check that these transfers are what [`ClusterTransfers::new`]
    /// arranges for `scene` (with its cluster tree, or none), its element
    /// `trees` (already checked) and their own links, or none arranged:
    /// for transfers read from outside
    /// (a solution file), which gathering indexes without checks.
    pub fn check(&self, scene: &Scene, trees: &[ElementTree]) -> Result<(), String> {
        if *self == ClusterTransfers::default() {
            return Ok(());
        }
        // The shooting solver arranges its links without a cluster tree.
        if self.clusters != ClusterTree::default() && self.clusters != ClusterTree::build(scene) {
            return Err("the cluster tree is not the scene's".into());
        }
        let element = |e: u32| {
            let m = self.elements.get(e as usize)?;
            let tree = trees.get(m.surface as usize)?;
            let node = tree.nodes.get(m.node as usize)?;
            Some(End::Element(ElementRef::new(m.surface, node.id)))
        };
        let clusters = self.clusters.nodes.len();
        let links = (self.links.iter().enumerate())
            .map(|(i, t)| {
                let ends = t.sides.map(|side| match side {
                    Side::Cluster(c) => ((c as usize) < clusters).then_some(End::Cluster(c)),
                    Side::Element(e) => element(e),
                });
                match ends {
                    [Some(a), Some(b)] if (0.0..=1.0).contains(&t.visibility) => Ok(ClusterLink {
                        ends: [a, b],
                        visibility: t.visibility,
                    }),
                    _ => Err(format!(
                        "cluster link {i}: an end out of range, or visibility {}",
                        t.visibility
                    )),
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        if ClusterTransfers::new(scene, self.clusters.clone(), trees, &links) != *self {
            return Err("the cluster links are not arranged as their ends say".into());
        }
        Ok(())
    }

    /// Number of cluster links.
    pub fn len(&self) -> usize {
        self.links.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.links.is_empty()
    }

    /// Where a side is: a cluster's area-weighted centroid, an element's
    /// centroid.
    fn center(&self, side: Side) -> DVec3 {
        match side {
            Side::Cluster(c) => self.clusters.nodes[c as usize].centroid,
            Side::Element(e) => self.elements[e as usize].point,
        }
    }

    /// Σ A·L·n over every cluster node's members from `radiance` (their
    /// roots' averages), children (later nodes) first.
    fn pull(&self, radiance: &[Vec<Rgb>]) -> Vec<[DVec3; 3]> {
        let nodes = &self.clusters.nodes;
        let mut sums = vec![[DVec3::ZERO; 3]; nodes.len()];
        for c in (0..nodes.len()).rev() {
            sums[c] = match nodes[c].children {
                Some([a, b]) => sum(sums[a as usize], sums[b as usize]),
                None => {
                    let m = &self.roots[self.clusters.members_of(c as u32)[0] as usize];
                    weighted(m.area * m.normal, radiance[m.surface as usize][0])
                }
            };
        }
        sums
    }

    /// N of cluster `c`'s members that face unit direction `w`: the sums
    /// `sums` of its largest clusters whose cones face it.
    fn sent_by_cluster(&self, c: u32, w: DVec3, sums: &[[DVec3; 3]]) -> [DVec3; 3] {
        let facing = match self.clusters.nodes[c as usize].children {
            None => {
                self.roots[self.clusters.members_of(c)[0] as usize]
                    .normal
                    .dot(w)
                    > 0.0
            }
            Some([a, b]) => match self.cones[c as usize].facing(w) {
                Facing::All => true,
                Facing::None => false,
                Facing::Some => {
                    return sum(
                        self.sent_by_cluster(a, w, sums),
                        self.sent_by_cluster(b, w, sums),
                    )
                }
            },
        };
        if facing {
            sums[c as usize]
        } else {
            [DVec3::ZERO; 3]
        }
    }

    /// The field that side `side` of link `link` receives at `x` from the
    /// other side's intensities in `sent`: F = V·u·I(−u)/(π·d⁴), u = y − x
    /// towards the other side's centre y, with its Jacobian in x (the
    /// glossy members' intensity taken as constant over the directions
    /// the receiver spans).
    fn incoming(&self, (link, side): (u32, u8), x: DVec3, sent: &[[Sent; 2]]) -> Field {
        let t = &self.links[link as usize];
        let u = self.center(t.sides[1 - side as usize]) - x;
        let d2 = u.length_squared();
        if d2 <= 0.0 {
            return Field::ZERO;
        }
        let scale = t.visibility / (PI * d2 * d2);
        let mut field = Field::ZERO;
        let from = &sent[link as usize][1 - side as usize];
        let d = d2.sqrt();
        for (k, n) in from.lambertian.iter().enumerate() {
            // I(−u)·|u|, the source's intensity towards x.
            let glossy = from.glossy[k];
            let s = -n.dot(u) + glossy * d;
            if s > 0.0 {
                field.value[k] = u * (s * scale);
                // ∂F/∂x = −∂F/∂u, with ∂s/∂u = −N + I_g·u/|u| and
                // ∂d⁻⁴/∂u = −4u/d⁶.
                let g = *n - u * (glossy / d) + u * (4.0 * s / d2);
                let outer = DMat3::from_cols(u * g.x, u * g.y, u * g.z);
                field.jacobian[k] = (outer - DMat3::from_diagonal(DVec3::splat(s))) * scale;
            }
        }
        field
    }

    /// Hand down, through cluster `c`, the fields of the links above it to
    /// its members, writing what each receives to `out` (its members, in
    /// leaf order): `folded`, the sum of the fields that all its members
    /// face, and `pending`, the (link, side) whose field only some face,
    /// with its own links added to either.
    fn push_down(
        &self,
        c: u32,
        (folded, pending): (Option<&Anchored>, &[(u32, u8)]),
        sent: &[[Sent; 2]],
        out: &mut [Rgb],
    ) {
        let node = &self.clusters.nodes[c as usize];
        let links = self.at_cluster.of(c);
        let Some([a, b]) = node.children else {
            // A member: the folded field to first order, the others exact.
            let m = &self.roots[self.clusters.members_of(c)[0] as usize];
            let exact = pending.iter().chain(links);
            out[0] = exact.fold(
                folded.map_or(Rgb::ZERO, |f| f.at(m.point).received(m.normal)),
                |sum, &at| sum + self.incoming(at, m.point, sent).received(m.normal),
            );
            return;
        };
        // Fold in the fields that all of this cluster's members face.
        let (own, kept);
        let handed = if links.is_empty() && pending.is_empty() {
            (folded, pending)
        } else {
            let x = node.centroid;
            let cone = &self.cones[c as usize];
            let mut sum = folded.map(|f| f.at(x));
            let mut still = Vec::new();
            for &at in pending.iter().chain(links) {
                let source = self.links[at.0 as usize].sides[1 - at.1 as usize];
                match cone.facing((self.center(source) - x).normalize_or_zero()) {
                    Facing::All => *sum.get_or_insert(Field::ZERO) += self.incoming(at, x, sent),
                    Facing::None => {}
                    Facing::Some => still.push(at),
                }
            }
            own = sum.map(|field| Anchored { origin: x, field });
            kept = still;
            (own.as_ref(), &kept[..])
        };
        let members = out.len();
        let (left, right) = out.split_at_mut(self.clusters.members_of(a).len());
        if members > PARALLEL_MEMBERS {
            rayon::join(
                || self.push_down(a, handed, sent, left),
                || self.push_down(b, handed, sent, right),
            );
        } else {
            self.push_down(a, handed, sent, left);
            self.push_down(b, handed, sent, right);
        }
    }

    /// The far field of `radiance` (every surface's node averages): what
    /// every link's ends send, and what every surface's root receives
    /// through the clusters above it. With `glossy`, the scene's glossy
    /// surfaces and the irradiance per bin their two-point transfers bring
    /// each: their lobes reflect it, with what their cluster links bring
    /// from `radiance` and from the glossy surfaces' radiance per bin in
    /// `previous` (the far field of the sweep before, if any), into every
    /// bin ([`FarField::glossy`]) and towards the other ends of their
    /// cluster links ([`crate::solve::glossy_clusters`]).
    pub fn far_field(
        &self,
        radiance: &[Vec<Rgb>],
        glossy: Option<(GlossyReflectors, Vec<Vec<Rgb>>)>,
        previous: Option<&FarField>,
    ) -> FarField {
        let sums = match self.links.is_empty() {
            true => Vec::new(),
            false => self.pull(radiance),
        };
        let mut sent: Vec<[Sent; 2]> = self
            .links
            .par_iter()
            .map(|t| {
                let centers = t.sides.map(|s| self.center(s));
                [0, 1].map(|k| {
                    let towards = centers[1 - k] - centers[k];
                    let lambertian = match t.sides[k] {
                        Side::Cluster(c) => {
                            self.sent_by_cluster(c, towards.normalize_or_zero(), &sums)
                        }
                        Side::Element(e) => {
                            let m = &self.elements[e as usize];
                            if m.normal.dot(towards) > 0.0 {
                                let l = radiance[m.surface as usize][m.node as usize];
                                weighted(m.area * m.normal, l)
                            } else {
                                [DVec3::ZERO; 3]
                            }
                        }
                    };
                    Sent {
                        lambertian,
                        ..Sent::ZERO
                    }
                })
            })
            .collect();
        let mut exitant = Vec::new();
        let reflectors = glossy.map(|(reflectors, near)| {
            // Glossy light from one glossy member to another, a sweep late.
            let before = previous.map(|f| &f.exitant[..]);
            if let Some(before) = before.filter(|e| e.len() == reflectors.surfaces().len()) {
                self.send_glossy(&reflectors, before, &mut sent);
            }
            exitant = self.glossy_exitant(&reflectors, near, &sent);
            self.send_glossy(&reflectors, &exitant, &mut sent);
            reflectors
        });
        if self.links.is_empty() {
            return FarField {
                reflectors,
                exitant,
                ..FarField::default()
            };
        }
        let mut in_leaf_order = vec![Rgb::ZERO; self.clusters.members.len()];
        self.push_down(0, (None, &[]), &sent, &mut in_leaf_order);
        let mut at_roots = vec![Rgb::ZERO; self.roots.len()];
        for (&s, r) in self.clusters.members.iter().zip(in_leaf_order) {
            at_roots[s as usize] = r;
        }
        FarField {
            sent,
            reflectors,
            exitant,
            at_roots,
        }
    }

    /// Every reflector's radiance per bin: its lobes' reflection of the
    /// irradiance `near` (per reflector, per bin) and of what its cluster
    /// links bring it from `sent`, each link's from the direction of the
    /// other end's centre.
    fn glossy_exitant(
        &self,
        reflectors: &GlossyReflectors,
        mut near: Vec<Vec<Rgb>>,
        sent: &[[Sent; 2]],
    ) -> Vec<Vec<Rgb>> {
        let other = |(link, side): (u32, u8)| {
            self.center(self.links[link as usize].sides[1 - side as usize])
        };
        (near.par_iter_mut().zip(reflectors.surfaces()).enumerate())
            .map(|(k, (bins, &s))| {
                if self.links.is_empty() {
                    return reflectors.reflect(k, bins);
                }
                let root = &self.roots[s as usize];
                let leaf = self.clusters.leaf_of[s as usize];
                let above = std::iter::once(leaf).chain(self.clusters.ancestors(s));
                for &at in above.flat_map(|c| self.at_cluster.of(c)) {
                    let e = self.incoming(at, root.point, sent).received(root.normal) * PI;
                    reflectors.receive(k, bins, other(at) - root.point, e);
                }
                for &at in self.at_surface.of(s) {
                    if let Side::Element(e) = self.links[at.0 as usize].sides[at.1 as usize] {
                        let m = &self.elements[e as usize];
                        let e = self.incoming(at, m.point, sent).received(m.normal);
                        let share = PI * m.area / root.area;
                        reflectors.receive(k, bins, other(at) - m.point, e * share);
                    }
                }
                reflectors.reflect(k, bins)
            })
            .collect()
    }

    /// Add to every side of `sent` the intensity its glossy members send
    /// towards the other side's centre, A·cosθ·L_o from each member's
    /// radiance per bin `exitant`.
    fn send_glossy(
        &self,
        reflectors: &GlossyReflectors,
        exitant: &[Vec<Rgb>],
        sent: &mut [[Sent; 2]],
    ) {
        // The reflectors in leaf order, and how many precede each position.
        let (mut glossy, mut before) = (Vec::new(), vec![0u32]);
        for &s in &self.clusters.members {
            if let Some(k) = reflectors.index(s) {
                glossy.push((s, k));
            }
            before.push(glossy.len() as u32);
        }
        let towards = |k: usize, m: &Member, target: DVec3| {
            let w = (target - m.point).normalize_or_zero();
            let cos = m.normal.dot(w);
            if cos > 0.0 {
                reflectors.towards(k, &exitant[k], w) * (m.area * cos)
            } else {
                Rgb::ZERO
            }
        };
        (sent.par_iter_mut().zip(&self.links)).for_each(|(sides, t)| {
            let centers = t.sides.map(|s| self.center(s));
            for (k, side) in sides.iter_mut().enumerate() {
                let target = centers[1 - k];
                side.glossy = match t.sides[k] {
                    Side::Cluster(c) => {
                        let r = &self.clusters.nodes[c as usize].members;
                        let under =
                            before[r.start as usize] as usize..before[r.end as usize] as usize;
                        (glossy[under].iter())
                            .map(|&(s, g)| towards(g, &self.roots[s as usize], target))
                            .sum()
                    }
                    Side::Element(e) => {
                        let m = &self.elements[e as usize];
                        reflectors
                            .index(m.surface)
                            .map_or(Rgb::ZERO, |g| towards(g, m, target))
                    }
                };
            }
        });
    }

    /// Add to `gathered` (surface `p`'s tree) the light of reflectance
    /// `reflectance` it gathers through cluster links from `far`.
    pub fn gather_into(&self, p: u32, reflectance: Rgb, far: &FarField, gathered: &mut Gathered) {
        if far.at_roots.is_empty() {
            return;
        }
        let root = far.at_roots[p as usize];
        if root != Rgb::ZERO {
            gathered.add(0, reflectance * root, DVec3::ZERO);
        }
        for &at in self.at_surface.of(p) {
            if let Side::Element(e) = self.links[at.0 as usize].sides[at.1 as usize] {
                let m = &self.elements[e as usize];
                let value = self.incoming(at, m.point, &far.sent).received(m.normal);
                gathered.add(m.node as usize, reflectance * value, DVec3::ZERO);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::hierarchy::{ElementId, ElementRef};
    use crate::scene::{Patch, Scene};
    use crate::testing::grey;
    use std::collections::BTreeSet;

    /// A square of side 0.04 centred at `center`, facing `normal`.
    fn square(center: DVec3, normal: DVec3) -> Patch {
        let (s, t) = normal.normalize().any_orthonormal_pair();
        let (edge_s, edge_t) = (0.04 * s, 0.04 * t);
        Patch::Parallelogram {
            origin: center - 0.5 * (edge_s + edge_t),
            edge_s,
            edge_t,
        }
    }

    /// Eight squares about the origin facing every way (a cap, surfaces
    /// 0–7), four within 0.15 of (3, 0, 0) all but one facing it (8–11),
    /// and four within 0.15 of (0.5, 2.8, 0) facing it (12–15).
    fn three_groups() -> Scene {
        let squares = [
            (DVec3::new(0.0, 0.05, 0.0), DVec3::new(1.0, 0.3, 0.3)),
            (DVec3::new(0.02, -0.05, 0.0), DVec3::new(1.0, -0.5, 0.2)),
            (DVec3::new(-0.03, 0.0, 0.06), DVec3::new(0.8, 0.1, -0.6)),
            (DVec3::new(0.0, 0.0, -0.06), DVec3::new(1.0, 0.0, 0.0)),
            (DVec3::new(-0.05, 0.04, 0.03), DVec3::new(-1.0, 0.3, 0.3)),
            (DVec3::new(0.04, 0.0, 0.05), DVec3::new(0.0, 1.0, 0.0)),
            (DVec3::new(-0.02, -0.04, -0.04), DVec3::new(0.6, -0.8, -0.4)),
            (DVec3::new(0.01, 0.07, -0.02), DVec3::new(0.7, 0.2, 0.9)),
            (DVec3::new(2.88, 0.0, 0.05), DVec3::new(-1.0, 0.1, 0.0)),
            (DVec3::new(3.12, 0.05, 0.0), DVec3::new(-1.0, -0.4, 0.2)),
            (DVec3::new(3.0, 0.1, -0.1), DVec3::new(1.0, 0.2, 0.0)),
            (DVec3::new(3.0, -0.1, 0.1), DVec3::new(-0.7, 0.0, 0.7)),
            (DVec3::new(0.45, 2.9, 0.05), DVec3::new(0.0, -1.0, 0.1)),
            (DVec3::new(0.55, 2.7, -0.05), DVec3::new(-0.3, -1.0, 0.0)),
            (DVec3::new(0.5, 2.8, 0.12), DVec3::new(0.2, -1.0, -0.5)),
            (DVec3::new(0.52, 2.82, -0.12), DVec3::new(-0.6, -0.8, 0.3)),
        ];
        let surfaces = squares.map(|(c, n)| grey(square(c, n)));
        Scene::from_surfaces(surfaces.into())
    }

    /// Every surface's tree of one element, its root.
    fn root_trees(scene: &Scene) -> Vec<ElementTree> {
        let root = BTreeSet::from([ElementId::ROOT]);
        scene
            .surfaces
            .iter()
            .map(|s| ElementTree::build(&s.patch, &root))
            .collect()
    }

    /// The members of an end and the point it sends from or receives at.
    fn end_members(clusters: &ClusterTree, scene: &Scene, end: End) -> (Vec<u32>, DVec3) {
        match end {
            End::Cluster(c) => (
                clusters.members_of(c).to_vec(),
                clusters.nodes[c as usize].centroid,
            ),
            End::Element(e) => (
                vec![e.surface],
                scene.surfaces[e.surface as usize].patch.centroid(),
            ),
        }
    }

    #[test]
    fn far_field_matches_the_sum_over_members() {
        let scene = three_groups();
        let clusters = ClusterTree::build(&scene);
        let group = |c: u32| clusters.members_of(c)[0] / 4;
        // Median splits: the cap, then the two groups of four.
        let [cap, rest] = clusters.nodes[0].children.unwrap();
        let [x, y] = clusters.nodes[rest as usize].children.unwrap();
        assert_eq!(
            (clusters.members_of(cap).len(), group(x), group(y)),
            (8, 2, 3)
        );
        let [cap_half, _] = clusters.nodes[cap as usize].children.unwrap();
        let links = [
            (End::Cluster(cap), End::Cluster(x), 1.0),
            (End::Cluster(cap), End::Cluster(y), 0.8),
            (
                End::Cluster(cap_half),
                End::Element(ElementRef::root(9)),
                0.5,
            ),
            (End::Element(ElementRef::root(3)), End::Cluster(y), 0.75),
        ]
        .map(|(x, y, visibility)| ClusterLink {
            ends: [x, y],
            visibility,
        });
        let trees = root_trees(&scene);
        let radiance: Vec<Vec<Rgb>> = (0..16)
            .map(|s| {
                vec![Rgb([
                    1.0 + (s % 3) as f64,
                    2.0 - 0.1 * s as f64,
                    0.5 + 0.2 * s as f64,
                ])]
            })
            .collect();
        let transfers = ClusterTransfers::new(&scene, clusters.clone(), &trees, &links);
        let far_field = transfers.far_field(&radiance, None, None);

        // Each member of each end on its own: the sources that face the
        // other end's centre, seen from the receiver's own point.
        // What members receive as elements (exact) and in clusters (to
        // first order in their offset from the cluster's centroid).
        let mut expected = vec![[Rgb::ZERO; 2]; 16];
        for l in &links {
            for k in 0..2 {
                let (sources, y) = end_members(&clusters, &scene, l.ends[k]);
                let (receivers, c) = end_members(&clusters, &scene, l.ends[1 - k]);
                let mut n = [DVec3::ZERO; 3];
                for &m in &sources {
                    let p = &scene.surfaces[m as usize].patch;
                    if p.normal().dot(c - y) > 0.0 {
                        n = sum(n, weighted(p.area() * p.normal(), radiance[m as usize][0]));
                    }
                }
                for &r in &receivers {
                    let p = &scene.surfaces[r as usize].patch;
                    let u = y - p.centroid();
                    let cos = p.normal().dot(u).max(0.0);
                    let d4 = u.length_squared().powi(2);
                    let clustered = matches!(l.ends[1 - k], End::Cluster(_));
                    expected[r as usize][usize::from(clustered)] +=
                        Rgb(n.map(|n| l.visibility * cos * (-n.dot(u)).max(0.0) / (PI * d4)));
                }
            }
        }
        for (s, tree) in trees.iter().enumerate() {
            let mut gathered = Gathered::new(tree.nodes.len());
            transfers.gather_into(s as u32, Rgb::splat(1.0), &far_field, &mut gathered);
            let got = gathered.into_averages(tree)[0];
            let [exact, clustered] = expected[s];
            for ch in 0..3 {
                let e = exact[ch] + clustered[ch];
                assert!(
                    (got[ch] - e).abs() <= 1e-12 * exact[ch] + 0.01 * clustered[ch],
                    "surface {s} channel {ch}: {} against {e}",
                    got[ch]
                );
            }
        }
        // Members facing away gather nothing, the others something.
        let lit: Vec<usize> = (0..16)
            .filter(|&s| expected[s][1].max_channel() > 0.0)
            .collect();
        assert_eq!(lit, [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14, 15]);
    }

    #[test]
    fn normal_cones_hold_their_members_normals_and_no_more() {
        let scene = three_groups();
        let clusters = ClusterTree::build(&scene);
        let trees = root_trees(&scene);
        let [cap, rest] = clusters.nodes[0].children.unwrap();
        let link = ClusterLink {
            ends: [End::Cluster(cap), End::Cluster(rest)],
            visibility: 1.0,
        };
        let transfers = ClusterTransfers::new(&scene, clusters.clone(), &trees, &[link]);
        assert_eq!(transfers.cones.len(), clusters.nodes.len());
        let normals = |c: usize| {
            clusters
                .members_of(c as u32)
                .iter()
                .map(|&s| scene.surfaces[s as usize].patch.normal())
        };
        for (c, cone) in transfers.cones.iter().enumerate() {
            // As wide as its widest member (a leaf: no width).
            let nearest = normals(c).map(|n| cone.axis.dot(n)).fold(1.0, f64::min);
            let sin = if nearest > 0.0 {
                (1.0 - nearest * nearest).sqrt()
            } else {
                1.0
            };
            assert!((cone.sin_half_angle - sin).abs() < 1e-9, "node {c}");
        }
        let directions = crate::testing::unit_square_midpoints(8).map(|p| {
            let (z, phi) = (2.0 * p.x - 1.0, 2.0 * PI * p.y);
            let r = (1.0 - z * z).sqrt();
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        });
        let mut seen = [false; 3];
        for w in directions {
            for (c, cone) in transfers.cones.iter().enumerate() {
                let cosines = normals(c).map(|n| n.dot(w));
                let (lo, hi) =
                    cosines.fold((1.0f64, -1.0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
                let facing = cone.facing(w);
                match facing {
                    Facing::All => assert!(lo > 0.0, "node {c}: {lo}"),
                    Facing::None => assert!(hi < 0.0, "node {c}: {hi}"),
                    Facing::Some => assert!(clusters.nodes[c].children.is_some(), "leaf {c}"),
                }
                seen[facing as usize] = true;
            }
        }
        assert_eq!(seen, [true; 3]);
    }
}
