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
use crate::solve::direction_cells::{self, CELLS};
use crate::solve::glossy_clusters::{cone, GlossyReflectors, BINS, NO_BIN};
use crate::solve::push_pull::Gathered;
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::borrow::Cow;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::ops::AddAssign;

/// A subtree with more members than this pushes its halves down in
/// parallel.
const PARALLEL_MEMBERS: usize = 2048;
/// A subtree with more glossy members than this hands their light down
/// its halves in parallel.
const PARALLEL_REFLECTORS: usize = 256;
/// A cluster of at least this many glossy members sums the fields of its
/// links, and those from above, per direction cell before handing them
/// down ([`ClusterTransfers::push_down_glossy`]); smaller ones hand their
/// links down one by one.
const MERGED_REFLECTORS: usize = 4;

/// Links whose ends' sends are worked out by one task.
const SENDING_CHUNK: usize = 1 << 14;

/// Bytes that gathering through one cluster link holds besides the link:
/// its arranged form, its two incidences, and which intensity each end
/// sends in the far field being made ([`FarField`]; one at a time; the
/// intensities themselves are one per cluster and element end, and one per
/// end whose cluster only partly faces the other).
pub const GATHER_BYTES_PER_LINK: u64 = (std::mem::size_of::<Transfer>()
    + 2 * std::mem::size_of::<(u32, u8)>()
    + std::mem::size_of::<[u32; 2]>()) as u64;

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
    /// The (key, item) pairs that `pairs` lists (each time the same)
    /// grouped by key (`keys` of them), each key's items in the order
    /// given: listed twice rather than held, as there are two per link.
    fn new<I: Iterator<Item = (u32, (u32, u8))>>(keys: usize, pairs: impl Fn() -> I) -> Incidence {
        let mut start = vec![0u32; keys + 1];
        for (k, _) in pairs() {
            start[k as usize + 1] += 1;
        }
        for k in 0..keys {
            start[k + 1] += start[k];
        }
        let mut next = start.clone();
        let mut items = vec![(0, 0); start[keys] as usize];
        for (k, item) in pairs() {
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

/// What the sides of every cluster link send towards each other. Most
/// ends send all their members' light (a cluster whose cone of normals
/// faces the other end, an element that faces it) or none, so each side
/// names one of a few shared intensity vectors instead of holding its own.
#[derive(Debug, Clone, PartialEq, Default)]
struct Sent {
    /// Per link and side, an index into `intensities`, or [`SENDS_NOTHING`].
    sides: Vec<[u32; 2]>,
    /// The intensity vectors N of Lambertian radiance, per channel
    /// (I(ω) = N·ω): every cluster node's members' (pulled up the tree),
    /// then every element end's, then those of the members of a cluster
    /// that face one link's other end where only some do.
    intensities: Vec<[DVec3; 3]>,
    /// Per link and side, the intensity its glossy members' lobes send
    /// towards the other side's centre
    /// ([`crate::solve::glossy_clusters`]); empty without glossy members.
    glossy: Vec<[Rgb; 2]>,
}

/// A side that sends nothing towards the other: its members all turn away.
const SENDS_NOTHING: u32 = u32::MAX;

impl Sent {
    /// The intensity vectors and the glossy intensity that side `side` of
    /// link `link` sends.
    fn by(&self, link: u32, side: usize) -> ([DVec3; 3], Rgb) {
        let lambertian = match self.sides[link as usize][side] {
            SENDS_NOTHING => [DVec3::ZERO; 3],
            i => self.intensities[i as usize],
        };
        let glossy = self
            .glossy
            .get(link as usize)
            .map_or(Rgb::ZERO, |g| g[side]);
        (lambertian, glossy)
    }
}

/// The glossy members of a cluster tree: (surface, reflector index) in
/// leaf order, so that a node's are one run.
struct GlossyMembers {
    members: Vec<(u32, usize)>,
    /// How many precede each position of the leaf order.
    before: Vec<u32>,
}

impl GlossyMembers {
    /// `reflectors` among the members of `clusters`.
    fn of(clusters: &ClusterTree, reflectors: &GlossyReflectors) -> GlossyMembers {
        let (mut members, mut before) = (Vec::new(), vec![0u32]);
        for &s in &clusters.members {
            if let Some(k) = reflectors.index(s) {
                members.push((s, k));
            }
            before.push(members.len() as u32);
        }
        GlossyMembers { members, before }
    }

    /// Those under node `c` of `clusters`.
    fn under(&self, clusters: &ClusterTree, c: u32) -> &[(u32, usize)] {
        let r = &clusters.nodes[c as usize].members;
        &self.members[self.before[r.start as usize] as usize..self.before[r.end as usize] as usize]
    }
}

/// What the glossy members of some clusters send per direction cell
/// ([`direction_cells`]): Σ A·cosθ·L_o(ω) over each one's members, ω the
/// cell's centre (Christensen et al. 1997's directional distribution of a
/// cluster's radiance), read by its link ends in one look-up.
struct GlossyIntensities {
    /// Each node's table in `tables`, `u32::MAX` if it has none.
    slot: Vec<u32>,
    tables: Vec<Vec<Rgb>>,
}

impl GlossyIntensities {
    /// Node `c`'s table, if it has one.
    fn of(&self, c: u32) -> Option<&[Rgb]> {
        let j = self.slot[c as usize];
        (j != u32::MAX).then(|| &self.tables[j as usize][..])
    }
}

/// The fields of cluster links arriving at a cluster, summed per
/// direction cell of their sources ([`direction_cells`]) and anchored at
/// one point: the directional distribution of incident light that
/// Christensen et al. (1997) push down to a glossy cluster's members.
struct Arriving {
    origin: DVec3,
    /// (cell, field), in order of cell, each cell once.
    cells: Vec<(usize, Field)>,
}

impl Arriving {
    /// The same fields anchored at `x`, to first order.
    fn moved_to(&self, x: DVec3) -> Arriving {
        let cells = (self.cells.iter())
            .map(|&(cell, field)| {
                let f = Anchored {
                    origin: self.origin,
                    field,
                };
                (cell, f.at(x))
            })
            .collect();
        Arriving { origin: x, cells }
    }

    /// These and `more` (anchored at the same point), each cell once.
    fn merged(self, more: Vec<Option<Field>>) -> Arriving {
        let mut cells = more;
        for (cell, field) in self.cells {
            *cells[cell].get_or_insert(Field::ZERO) += field;
        }
        let cells = (cells.into_iter().enumerate())
            .filter_map(|(cell, field)| Some((cell, field?)))
            .collect();
        Arriving {
            origin: self.origin,
            cells,
        }
    }
}

/// Fields per direction cell, `None` where none arrives.
fn add_cells(mut a: Vec<Option<Field>>, b: Vec<Option<Field>>) -> Vec<Option<Field>> {
    for (x, y) in a.iter_mut().zip(b) {
        if let Some(y) = y {
            *x.get_or_insert(Field::ZERO) += y;
        }
    }
    a
}

/// One radiance state's far field: what every link's ends send, and what
/// every surface's root gathers through the clusters above it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FarField {
    /// What each side sends towards the other.
    sent: Sent,
    /// The scene's glossy surfaces, when it has any and they were asked for.
    reflectors: Option<GlossyReflectors>,
    /// The radiance per bin of every one of them
    /// ([`crate::solve::glossy_clusters`]).
    exitant: Vec<Vec<Rgb>>,
    /// What each surface's root receives through its clusters' links
    /// (irradiance over π, before reflectance).
    at_roots: Vec<Rgb>,
    /// What each surface's element nodes receive through the links at its
    /// elements, summed per node, when worked out ahead
    /// ([`ClusterTransfers::sum_at_elements`]); empty otherwise.
    at_elements: Vec<Vec<Rgb>>,
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

/// The cone of normals of every node of `clusters`
/// ([`Orientation`](crate::geometry::cluster::Orientation)'s axis and
/// width).
fn normal_cones(clusters: &ClusterTree) -> Vec<NormalCone> {
    clusters
        .nodes
        .iter()
        .map(|node| {
            let (axis, cos) = (node.orientation.axis, node.orientation.spread_cos);
            NormalCone {
                axis,
                sin_half_angle: if axis == DVec3::ZERO || cos <= 0.0 {
                    1.0
                } else {
                    (1.0 - cos * cos).max(0.0).sqrt()
                },
            }
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
        let transfers: Vec<Transfer> = links
            .iter()
            .map(|l| {
                let sides = l.ends.map(|end| match end {
                    End::Cluster(c) => Side::Cluster(c),
                    End::Element(e) => {
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
                });
                Transfer {
                    sides,
                    visibility: l.visibility,
                }
            })
            .collect();
        drop(element_of);
        // (link, side) of every side, with its cluster or element.
        let sides = || {
            (transfers.iter().enumerate())
                .flat_map(|(i, t)| [0, 1].map(|k| (t.sides[k], (i as u32, k as u8))))
        };
        let at_cluster = Incidence::new(clusters.nodes.len(), || {
            sides().filter_map(|(side, at)| match side {
                Side::Cluster(c) => Some((c, at)),
                Side::Element(_) => None,
            })
        });
        let at_surface = Incidence::new(roots.len(), || {
            sides().filter_map(|(side, at)| match side {
                Side::Element(e) => Some((elements[e as usize].surface, at)),
                Side::Cluster(_) => None,
            })
        });
        ClusterTransfers {
            cones: if links.is_empty() {
                Vec::new()
            } else {
                normal_cones(&clusters)
            },
            at_cluster,
            at_surface,
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
        let links = self.links(trees)?;
        if ClusterTransfers::new(scene, self.clusters.clone(), trees, &links) != *self {
            return Err("the cluster links are not arranged as their ends say".into());
        }
        Ok(())
    }

    /// The cluster links these transfers arrange, in their order, with the
    /// element `trees` they were arranged with ([`ClusterTransfers::new`]
    /// of them gives these transfers); an error naming the first whose end
    /// is out of range or whose visibility is not a fraction.
    pub fn links(&self, trees: &[ElementTree]) -> Result<Vec<ClusterLink>, String> {
        let element = |e: u32| {
            let m = self.elements.get(e as usize)?;
            let tree = trees.get(m.surface as usize)?;
            let node = tree.nodes.get(m.node as usize)?;
            Some(End::Element(ElementRef::new(m.surface, node.id)))
        };
        let clusters = self.clusters.nodes.len();
        (self.links.iter().enumerate())
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
            .collect()
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

    /// How far an end reaches from its [`ClusterTransfers::center`]: a
    /// cluster's bounding sphere about its centroid, an element's
    /// half-diagonal were it square.
    fn radius(&self, side: Side) -> f64 {
        match side {
            Side::Cluster(c) => {
                let node = &self.clusters.nodes[c as usize];
                node.radius + node.center.distance(node.centroid)
            }
            Side::Element(e) => (0.5 * self.elements[e as usize].area).sqrt(),
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

    /// Which of cluster `c`'s members face unit direction `w`.
    fn facing(&self, c: u32, w: DVec3) -> Facing {
        match self.clusters.nodes[c as usize].children {
            None => match self.roots[self.clusters.members_of(c)[0] as usize]
                .normal
                .dot(w)
                > 0.0
            {
                true => Facing::All,
                false => Facing::None,
            },
            Some(_) => self.cones[c as usize].facing(w),
        }
    }

    /// N of cluster `c`'s members that face unit direction `w`: the sums
    /// `sums` of its largest clusters whose cones face it.
    fn sent_by_cluster(&self, c: u32, w: DVec3, sums: &[[DVec3; 3]]) -> [DVec3; 3] {
        match (self.facing(c, w), self.clusters.nodes[c as usize].children) {
            (Facing::All, _) => sums[c as usize],
            (Facing::Some, Some([a, b])) => sum(
                self.sent_by_cluster(a, w, sums),
                self.sent_by_cluster(b, w, sums),
            ),
            _ => [DVec3::ZERO; 3],
        }
    }

    /// What every link's sides send of `radiance` (every surface's node
    /// averages), without glossy lobes: each side's index into the
    /// intensities, `sums` (every cluster node's Σ A·L·n) then every
    /// element end's, then one for each cluster side that only partly
    /// faces the other end.
    fn send(&self, radiance: &[Vec<Rgb>], sums: Vec<[DVec3; 3]>) -> Sent {
        let mut intensities = sums;
        let elements = intensities.len();
        intensities.extend(self.elements.iter().map(|m| {
            weighted(
                m.area * m.normal,
                radiance[m.surface as usize][m.node as usize],
            )
        }));
        let partial = intensities.len();
        // Each chunk numbers its partial sends as if it came first; they
        // are then shifted past the chunks before it.
        let chunks: Vec<Sent> = (self.links.par_chunks(SENDING_CHUNK))
            .map(|chunk| {
                let mut own = Vec::new();
                let sides = (chunk.iter())
                    .map(|t| {
                        let centers = t.sides.map(|s| self.center(s));
                        [0, 1].map(|k| {
                            let towards = centers[1 - k] - centers[k];
                            match t.sides[k] {
                                Side::Cluster(c) => {
                                    let w = towards.normalize_or_zero();
                                    match self.facing(c, w) {
                                        Facing::All => c,
                                        Facing::None => SENDS_NOTHING,
                                        Facing::Some => {
                                            own.push(self.sent_by_cluster(c, w, &intensities));
                                            (partial + own.len() - 1) as u32
                                        }
                                    }
                                }
                                Side::Element(e) => {
                                    match self.elements[e as usize].normal.dot(towards) > 0.0 {
                                        true => (elements + e as usize) as u32,
                                        false => SENDS_NOTHING,
                                    }
                                }
                            }
                        })
                    })
                    .collect();
                Sent {
                    sides,
                    intensities: own,
                    glossy: Vec::new(),
                }
            })
            .collect();
        let mut sides = Vec::with_capacity(self.links.len());
        for chunk in chunks {
            let shift = (intensities.len() - partial) as u32;
            sides.extend(chunk.sides.into_iter().map(|pair| {
                pair.map(|i| match i != SENDS_NOTHING && i as usize >= partial {
                    true => i + shift,
                    false => i,
                })
            }));
            intensities.extend(chunk.intensities);
        }
        Sent {
            sides,
            intensities,
            glossy: Vec::new(),
        }
    }

    /// The field that side `side` of link `link` receives at `x` from the
    /// other side's intensities in `sent`: F = V·u·I(−u)/(π·d⁴), u = y − x
    /// towards the other side's centre y, with its Jacobian in x (the
    /// glossy members' intensity taken as constant over the directions
    /// the receiver spans).
    fn incoming(&self, at: (u32, u8), x: DVec3, sent: &Sent) -> Field {
        self.link_field::<true>(at, x, sent)
    }

    /// [`ClusterTransfers::incoming`]'s value alone (a zero Jacobian): for
    /// a receiver that reads it at `x` and no nearer.
    fn incoming_value(&self, at: (u32, u8), x: DVec3, sent: &Sent) -> Field {
        self.link_field::<false>(at, x, sent)
    }

    /// The field of [`ClusterTransfers::incoming`], with its Jacobian if
    /// `JACOBIAN`.
    fn link_field<const JACOBIAN: bool>(
        &self,
        (link, side): (u32, u8),
        x: DVec3,
        sent: &Sent,
    ) -> Field {
        let t = &self.links[link as usize];
        let u = self.center(t.sides[1 - side as usize]) - x;
        let d2 = u.length_squared();
        if d2 <= 0.0 {
            return Field::ZERO;
        }
        let scale = t.visibility / (PI * d2 * d2);
        let mut field = Field::ZERO;
        let (lambertian, glossy) = sent.by(link, 1 - side as usize);
        let d = d2.sqrt();
        for (k, n) in lambertian.iter().enumerate() {
            // I(−u)·|u|, the source's intensity towards x.
            let glossy = glossy[k];
            let s = -n.dot(u) + glossy * d;
            if s > 0.0 {
                field.value[k] = u * (s * scale);
                if !JACOBIAN {
                    continue;
                }
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
        sent: &Sent,
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
                |sum, &at| sum + self.incoming_value(at, m.point, sent).received(m.normal),
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
        let mut sent = match self.links.is_empty() {
            true => Sent::default(),
            false => self.send(radiance, self.pull(radiance)),
        };
        let mut exitant = Vec::new();
        let reflectors = glossy.map(|(reflectors, near)| {
            // Glossy light from one glossy member to another, a sweep late.
            let members = GlossyMembers::of(&self.clusters, &reflectors);
            let glossy = (&reflectors, &members);
            let tabled = self.worth_tabling(&members);
            let before = previous.map(|f| &f.exitant[..]);
            if let Some(before) = before.filter(|e| e.len() == reflectors.surfaces().len()) {
                self.send_glossy(glossy, &tabled, before, &mut sent);
            }
            exitant = self.glossy_exitant(glossy, near, &sent);
            self.send_glossy(glossy, &tabled, &exitant, &mut sent);
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
            at_elements: Vec::new(),
        }
    }

    /// Every reflector's radiance per bin: its lobes' reflection of the
    /// irradiance `near` (per reflector, per bin) and of what its cluster
    /// links bring it from `sent`, each link's from the direction of the
    /// other end's centre: exactly for the links at its elements, through
    /// [`ClusterTransfers::push_down_glossy`] for those at its clusters.
    fn glossy_exitant(
        &self,
        (reflectors, glossy): (&GlossyReflectors, &GlossyMembers),
        mut near: Vec<Vec<Rgb>>,
        sent: &Sent,
    ) -> Vec<Vec<Rgb>> {
        if !self.links.is_empty() {
            let mut above = vec![Vec::new(); glossy.members.len()];
            let none = Arriving {
                origin: DVec3::ZERO,
                cells: Vec::new(),
            };
            self.push_down_glossy(0, (&none, &[]), (reflectors, glossy), sent, &mut above);
            for (&(_, k), bins) in glossy.members.iter().zip(above) {
                for (n, b) in near[k].iter_mut().zip(bins) {
                    *n += b;
                }
            }
        }
        let other = |(link, side): (u32, u8)| {
            self.center(self.links[link as usize].sides[1 - side as usize])
        };
        (near.par_iter_mut().zip(reflectors.surfaces()).enumerate())
            .map(|(k, (bins, &s))| {
                let root = &self.roots[s as usize];
                for &at in self.at_surface.of(s) {
                    if let Side::Element(e) = self.links[at.0 as usize].sides[at.1 as usize] {
                        let m = &self.elements[e as usize];
                        let e = self.incoming_value(at, m.point, sent).received(m.normal);
                        let share = PI * m.area / root.area;
                        reflectors.receive(k, bins, other(at) - m.point, e * share);
                    }
                }
                reflectors.reflect(k, bins)
            })
            .collect()
    }

    /// Hand down, through cluster `c`, the light its glossy members
    /// receive through the cluster links above it, writing each member's
    /// irradiance per bin to `out` (its glossy members, in leaf order):
    /// `above`, the fields of the links at clusters of at least
    /// [`MERGED_REFLECTORS`] glossy members, summed per direction cell of
    /// their sources and carried to first order in the position (as
    /// [`ClusterTransfers::push_down`] carries the fields all members
    /// face); `pending`, the (link, side) of those at smaller clusters,
    /// each evaluated at each member. Each reaches a member's bin from the
    /// direction of its field there.
    fn push_down_glossy(
        &self,
        c: u32,
        (above, pending): (&Arriving, &[(u32, u8)]),
        (reflectors, glossy): (&GlossyReflectors, &GlossyMembers),
        sent: &Sent,
        out: &mut [Vec<Rgb>],
    ) {
        if out.is_empty() {
            return;
        }
        let node = &self.clusters.nodes[c as usize];
        let links = self.at_cluster.of(c);
        let Some([a, b]) = node.children else {
            let (s, k) = glossy.under(&self.clusters, c)[0];
            let m = &self.roots[s as usize];
            let mut bins = vec![Rgb::ZERO; BINS];
            let cells = (above.cells.iter()).map(|&(_, field)| {
                Anchored {
                    origin: above.origin,
                    field,
                }
                .at(m.point)
            });
            let exact =
                (pending.iter().chain(links)).map(|&at| self.incoming_value(at, m.point, sent));
            for f in cells.chain(exact) {
                let e = f.received(m.normal) * PI;
                if e != Rgb::ZERO {
                    let towards = f.value[0] + f.value[1] + f.value[2];
                    reflectors.receive(k, &mut bins, towards, e);
                }
            }
            out[0] = bins;
            return;
        };
        let (merged, listed);
        let handed = if out.len() >= MERGED_REFLECTORS {
            let x = node.centroid;
            // Summed per cell as they are made: a cluster high in the
            // tree can hold millions of links.
            let own = (links.par_iter().with_min_len(4096))
                .fold(
                    || vec![None; CELLS],
                    |mut cells, &at| {
                        let source = self.links[at.0 as usize].sides[1 - at.1 as usize];
                        let cell = direction_cells::cell_of(self.center(source) - x);
                        *cells[cell].get_or_insert(Field::ZERO) += self.incoming(at, x, sent);
                        cells
                    },
                )
                .reduce(|| vec![None; CELLS], add_cells);
            merged = above.moved_to(x).merged(own);
            (&merged, pending)
        } else if links.is_empty() {
            (above, pending)
        } else {
            listed = [pending, links].concat();
            (above, &listed[..])
        };
        let (left, right) = out.split_at_mut(glossy.under(&self.clusters, a).len());
        let reflecting = (reflectors, glossy);
        if left.len() + right.len() > PARALLEL_REFLECTORS {
            rayon::join(
                || self.push_down_glossy(a, handed, reflecting, sent, left),
                || self.push_down_glossy(b, handed, reflecting, sent, right),
            );
        } else {
            self.push_down_glossy(a, handed, reflecting, sent, left);
            self.push_down_glossy(b, handed, reflecting, sent, right);
        }
    }

    /// Add to every side of `sent` the intensity its glossy members
    /// `glossy` send towards the other side's centre, A·cosθ·L_o from each
    /// member's radiance per bin `exitant`, L_o averaged over the cone the
    /// other side fills ([`GlossyReflectors::towards_across`]): read from
    /// the cluster's [`GlossyIntensities`] where it has them (the clusters
    /// `tabled`), summed over its members otherwise.
    fn send_glossy(
        &self,
        (reflectors, glossy): (&GlossyReflectors, &GlossyMembers),
        tabled: &[bool],
        exitant: &[Vec<Rgb>],
        sent: &mut Sent,
    ) {
        let towards = |k: usize, m: &Member, w: DVec3| {
            let cos = m.normal.dot(w);
            if cos > 0.0 {
                reflectors.towards(k, &exitant[k], w) * (m.area * cos)
            } else {
                Rgb::ZERO
            }
        };
        let tables = self.glossy_intensities(glossy, tabled, &|s, k, w| {
            towards(k, &self.roots[s as usize], w)
        });
        // Each end reads its members' light averaged over the cone of
        // directions the other end fills: a member from its bins averaged
        // over cones of a few widths, a table at directions that fill the
        // cone.
        let width = |target: Side, from: DVec3| {
            self.radius(target) / self.center(target).distance(from).max(f64::MIN_POSITIVE)
        };
        let member = |target: Side, k: usize, m: &Member| {
            let w = (self.center(target) - m.point).normalize_or_zero();
            let cos = m.normal.dot(w);
            if cos > 0.0 {
                let sin_alpha = width(target, m.point);
                reflectors.towards_across(k, &exitant[k], w, sin_alpha) * (m.area * cos)
            } else {
                Rgb::ZERO
            }
        };
        sent.glossy.resize(self.links.len(), [Rgb::ZERO; 2]);
        (sent.glossy.par_iter_mut().zip(&self.links)).for_each(|(sides, t)| {
            for (k, side) in sides.iter_mut().enumerate() {
                let target = t.sides[1 - k];
                *side = match t.sides[k] {
                    Side::Cluster(c) => match tables.of(c) {
                        Some(table) => {
                            let from = self.center(t.sides[k]);
                            let directions =
                                cone(self.center(target) - from, width(target, from), 1);
                            let n = directions.len() as f64;
                            (directions.flat_map(direction_cells::bilinear))
                                .map(|(cell, weight)| table[cell] * weight)
                                .sum::<Rgb>()
                                / n
                        }
                        None => (glossy.under(&self.clusters, c).iter())
                            .map(|&(s, g)| member(target, g, &self.roots[s as usize]))
                            .sum(),
                    },
                    Side::Element(e) => {
                        let m = &self.elements[e as usize];
                        (reflectors.index(m.surface)).map_or(Rgb::ZERO, |g| member(target, g, m))
                    }
                };
            }
        });
    }

    /// Which clusters keep [`GlossyIntensities`]: those where a table
    /// costs less than summing their glossy members `glossy` for each of
    /// their link ends. Decided children first: a table is made from its
    /// children's tables where they have them, from the members under the
    /// others.
    fn worth_tabling(&self, glossy: &GlossyMembers) -> Vec<bool> {
        let nodes = &self.clusters.nodes;
        // Costs in member evaluations; a table's look-up and adding a
        // child's table cost a fraction of one per cell.
        const TABLE_OP: f64 = 0.1;
        const READ: f64 = 4.0 * TABLE_OP;
        let mut tabled = vec![false; nodes.len()];
        for c in (0..nodes.len()).rev() {
            let Some(children) = nodes[c].children else {
                continue;
            };
            let members = glossy.under(&self.clusters, c as u32).len() as f64;
            let ends = self.at_cluster.of(c as u32).len() as f64;
            let build: f64 = (children.iter())
                .map(|&a| match tabled[a as usize] {
                    true => TABLE_OP,
                    false => glossy.under(&self.clusters, a).len() as f64,
                })
                .sum::<f64>()
                * CELLS as f64;
            tabled[c] = members > 0.0 && build + ends * READ < ends * members;
        }
        tabled
    }

    /// The [`GlossyIntensities`] of the clusters `tabled`, from
    /// `intensity(s, k, ω)`, what member `s` of `glossy` (reflector `k`)
    /// sends towards unit direction ω. A table is made from its children's
    /// tables where they have them, from the members under the others.
    fn glossy_intensities(
        &self,
        glossy: &GlossyMembers,
        tabled: &[bool],
        intensity: &(dyn Fn(u32, usize, DVec3) -> Rgb + Sync),
    ) -> GlossyIntensities {
        let nodes = &self.clusters.nodes;
        let order: Vec<u32> = (0..nodes.len() as u32)
            .filter(|&c| tabled[c as usize])
            .collect();
        let mut slot = vec![u32::MAX; nodes.len()];
        for (i, &c) in order.iter().enumerate() {
            slot[c as usize] = i as u32;
        }
        let children = |c: u32| nodes[c as usize].children.into_iter().flatten();
        let mut tables: Vec<Vec<Rgb>> = (order.par_iter())
            .map(|&c| {
                let mut table = vec![Rgb::ZERO; CELLS];
                for a in children(c).filter(|&a| slot[a as usize] == u32::MAX) {
                    for &(s, k) in glossy.under(&self.clusters, a) {
                        for (cell, v) in table.iter_mut().enumerate() {
                            *v += intensity(s, k, direction_cells::center(cell));
                        }
                    }
                }
                table
            })
            .collect();
        // Children come after their parents.
        for i in (0..order.len()).rev() {
            for a in children(order[i]) {
                let j = slot[a as usize];
                if j != u32::MAX {
                    let (parent, rest) = tables.split_at_mut(j as usize);
                    for (p, v) in parent[i].iter_mut().zip(&rest[0]) {
                        *p += *v;
                    }
                }
            }
        }
        GlossyIntensities { slot, tables }
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
        let at_elements = match far.at_elements.get(p as usize) {
            Some(sums) => Cow::Borrowed(sums),
            None => Cow::Owned(self.at_elements(p, &far.sent)),
        };
        for (node, &value) in at_elements.iter().enumerate() {
            if value != Rgb::ZERO {
                gathered.add(node, reflectance * value, DVec3::ZERO);
            }
        }
    }

    /// Work out ahead, in parallel, what every surface's elements receive
    /// through the links at them in `far` (which [`Self::gather_into`]
    /// otherwise evaluates surface by surface, in Gauss–Seidel's
    /// sequential loop).
    pub fn sum_at_elements(&self, far: &mut FarField) {
        if far.at_roots.is_empty() {
            return;
        }
        far.at_elements = (0..self.roots.len() as u32)
            .into_par_iter()
            .with_min_len(256)
            .map(|p| self.at_elements(p, &far.sent))
            .collect();
    }

    /// What surface `p`'s element nodes receive through the links at its
    /// elements from `sent`, per node (up to the last node that receives).
    fn at_elements(&self, p: u32, sent: &Sent) -> Vec<Rgb> {
        let mut sums: Vec<Rgb> = Vec::new();
        for &at in self.at_surface.of(p) {
            if let Side::Element(e) = self.links[at.0 as usize].sides[at.1 as usize] {
                let m = &self.elements[e as usize];
                let value = self.incoming_value(at, m.point, sent).received(m.normal);
                let node = m.node as usize;
                if sums.len() <= node {
                    sums.resize(node + 1, Rgb::ZERO);
                }
                sums[node] += value;
            }
        }
        sums
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
        // What a checkpoint keeps of them.
        assert_eq!(transfers.links(&trees), Ok(links.to_vec()));
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

    #[test]
    fn glossy_light_through_direction_cells_matches_the_sum_over_members() {
        use crate::progress::Silent;
        use crate::scene::brdf::conductor::RoughConductor;
        use crate::scene::brdf::microfacet::{Microfacet, MicrofacetType};
        use crate::scene::brdf::Brdf;
        use crate::solve::{solve, SolveSettings};
        // A ball of 112 rough aluminium-like triangles in a lit box, solved
        // with its cluster links; three-point links of level 1 at most, for
        // time.
        let brdf = Brdf::RoughConductor(RoughConductor {
            distribution: Microfacet::isotropic(MicrofacetType::Ggx, 0.2),
            ..RoughConductor::default()
        });
        let scene = crate::testing::ball_in_a_box(8, brdf);
        let settings = SolveSettings {
            three_point_max_level: 1,
            three_point_receiver_levels: 0,
            ..SolveSettings::default()
        };
        let solution = solve(&scene, &settings, &Silent).unwrap();
        let transfers = &solution.interactions.clusters;
        let reflectors = GlossyReflectors::of(&scene).unwrap();
        let glossy = GlossyMembers::of(&transfers.clusters, &reflectors);
        let sent = transfers.far_field(&solution.radiance, None, None).sent;
        let other = |(link, side): (u32, u8)| {
            transfers.center(transfers.links[link as usize].sides[1 - side as usize])
        };

        // What the links at its clusters bring each member, per bin:
        // handed down per direction cell, and each link on its own.
        let none = Arriving {
            origin: DVec3::ZERO,
            cells: Vec::new(),
        };
        let mut pushed = vec![Vec::new(); glossy.members.len()];
        transfers.push_down_glossy(0, (&none, &[]), (&reflectors, &glossy), &sent, &mut pushed);
        let (mut total, mut misplaced, mut lit) = (0.0, 0.0, 0);
        for (&(s, k), got) in glossy.members.iter().zip(&pushed) {
            let m = &transfers.roots[s as usize];
            let leaf = transfers.clusters.leaf_of[s as usize];
            let above = std::iter::once(leaf).chain(transfers.clusters.ancestors(s));
            let mut exact = vec![Rgb::ZERO; BINS];
            for &at in above.flat_map(|c| transfers.at_cluster.of(c)) {
                let e = transfers
                    .incoming_value(at, m.point, &sent)
                    .received(m.normal)
                    * PI;
                reflectors.receive(k, &mut exact, other(at) - m.point, e);
            }
            let sum = |bins: &[Rgb]| bins.iter().map(|e| e[1]).sum::<f64>();
            let (a, b) = (sum(got), sum(&exact));
            // The fields to first order across the cluster: measured
            // within 0.71 %.
            assert!(
                (a - b).abs() <= 0.015 * b + 1e-12,
                "member {s}: {a} against {b}"
            );
            total += b;
            misplaced += (got.iter().zip(&exact))
                .map(|(x, y)| (x[1] - y[1]).abs())
                .sum::<f64>();
            lit += usize::from(b > 0.0);
        }
        assert!(lit > glossy.members.len() / 2, "{lit} lit");
        // Light summed per cell reaches a bin from its cell's mean
        // direction: little lands in a neighbouring bin (measured 0.96 %).
        assert!(misplaced < 0.02 * total, "{misplaced} of {total} misplaced");

        // What every cluster end's glossy members send towards the other
        // end, lit from every bin as well: read from tables (every cluster
        // of glossy members has one here) against each member's own.
        let exitant = transfers.glossy_exitant(
            (&reflectors, &glossy),
            vec![vec![Rgb::splat(0.1); BINS]; reflectors.surfaces().len()],
            &sent,
        );
        let towards = |k: usize, m: &Member, w: DVec3| {
            let cos = m.normal.dot(w);
            match cos > 0.0 {
                true => reflectors.towards(k, &exitant[k], w) * (m.area * cos),
                false => Rgb::ZERO,
            }
        };
        let tabled: Vec<bool> = (0..transfers.clusters.nodes.len() as u32)
            .map(|c| glossy.under(&transfers.clusters, c).len() > 1)
            .collect();
        let tables = transfers.glossy_intensities(&glossy, &tabled, &|s, k, w| {
            towards(k, &transfers.roots[s as usize], w)
        });
        let (mut total, mut error, mut read) = (0.0, 0.0, 0);
        for (i, t) in transfers.links.iter().enumerate() {
            for k in 0..2 {
                let Side::Cluster(c) = t.sides[k] else {
                    continue;
                };
                let Some(table) = tables.of(c) else {
                    continue;
                };
                let target = other((i as u32, k as u8));
                let w = target - transfers.center(t.sides[k]);
                let got: f64 = (direction_cells::bilinear(w).iter())
                    .map(|&(cell, weight)| table[cell][1] * weight)
                    .sum();
                let exact: f64 = (glossy.under(&transfers.clusters, c).iter())
                    .map(|&(s, g)| {
                        let m = &transfers.roots[s as usize];
                        towards(g, m, (target - m.point).normalize_or_zero())[1]
                    })
                    .sum();
                total += exact;
                error += (got - exact).abs();
                read += 1;
            }
        }
        assert!(read > 50 && total > 0.0, "{read} ends read, {total}");
        // Measured 1.27 % (the table is read from the cluster's centre,
        // at cells 6–7° apart).
        assert!(error < 0.025 * total, "{error} of {total}");
    }
}
