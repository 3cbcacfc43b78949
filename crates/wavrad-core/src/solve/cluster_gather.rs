//! Gathering through cluster links ([`crate::refine::cluster_links`]).
//!
//! An end's members m (a cluster's surfaces, read as their average
//! radiance, or one element) that face the other end send, in direction ω,
//! the intensity I(ω) = Σ_m A_m (n_m·ω) L_m = N·ω, with N = Σ_m A_m L_m n_m
//! a vector per channel: each member's own cosine, as Sillion 1995's
//! anisotropic clusters and Smits et al. 1994's α-links evaluate them, and
//! exact for every direction in which those members face forward. A
//! receiving member at x gathers ρ·V·max(0, n·u)·I(−u) / (π·d²), u and d the
//! direction and distance from x to the source's area-weighted centroid and
//! V the link's visibility: eq. 12 with the point-to-point form factor
//! between the member and each source member, to second order in the ends'
//! size over their distance. A cluster's members gather at their roots
//! (push–pull spreads it), an element at its node.
//!
//! Per sweep, [`ClusterTransfers::far_field`] evaluates every end's N once
//! from the current radiance (a Jacobi step over cluster links; the
//! surfaces' own links stay Gauss–Seidel), and each surface then gathers
//! over the links of the clusters above it.

use crate::geometry::cluster::ClusterTree;
use crate::geometry::hierarchy::ElementTree;
use crate::refine::cluster_links::{ClusterLink, End};
use crate::scene::{Rgb, Scene};
use crate::solve::push_pull::Gathered;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

/// A member of a cluster link's end: where it is, which way it faces, how
/// large it is.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Member {
    surface: u32,
    node: u32,
    point: DVec3,
    normal: DVec3,
    area: f64,
}

/// One end of a cluster link, ready for gathering.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Side {
    /// A node of the cluster tree (its members' roots).
    Cluster(u32),
    /// One element.
    Element(Member),
}

/// A cluster link ready for gathering.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Transfer {
    sides: [Side; 2],
    centers: [DVec3; 2],
    visibility: f64,
}

/// The cluster links of a solution, arranged for gathering.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ClusterTransfers {
    /// The scene's cluster tree.
    pub clusters: ClusterTree,
    links: Vec<Transfer>,
    /// Every surface's root as a member (centroid, normal, area).
    roots: Vec<Member>,
    /// (link, side) of the links at each cluster node.
    at_cluster: Vec<Vec<(u32, u8)>>,
    /// (link, side) of the links at an element of each surface.
    at_surface: Vec<Vec<(u32, u8)>>,
}

/// Every end's intensity vector N (one per channel) towards the other end,
/// from one radiance state, per link and side.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FarField {
    sent: Vec<[[DVec3; 3]; 2]>,
    /// What each surface's root receives through its clusters' links
    /// (irradiance over π, before reflectance).
    at_roots: Vec<Rgb>,
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
        let mut at_cluster = vec![Vec::new(); clusters.nodes.len()];
        let mut at_surface = vec![Vec::new(); scene.surfaces.len()];
        let side = |end: End| match end {
            End::Cluster(c) => (Side::Cluster(c), clusters.nodes[c as usize].centroid),
            End::Element(e) => {
                let tree = &trees[e.surface as usize];
                let node = tree
                    .index_of(e.id)
                    .expect("element ends are in their trees");
                let patch = &tree.nodes[node as usize].patch;
                let member = Member {
                    node,
                    point: patch.centroid(),
                    area: patch.area(),
                    ..roots[e.surface as usize]
                };
                (Side::Element(member), member.point)
            }
        };
        let transfers = links
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let [(s0, c0), (s1, c1)] = l.ends.map(side);
                for (k, s) in [s0, s1].iter().enumerate() {
                    match s {
                        Side::Cluster(c) => at_cluster[*c as usize].push((i as u32, k as u8)),
                        Side::Element(m) => {
                            at_surface[m.surface as usize].push((i as u32, k as u8))
                        }
                    }
                }
                Transfer {
                    sides: [s0, s1],
                    centers: [c0, c1],
                    visibility: l.visibility,
                }
            })
            .collect();
        ClusterTransfers {
            clusters,
            links: transfers,
            roots,
            at_cluster,
            at_surface,
        }
    }

    /// Number of cluster links.
    pub fn len(&self) -> usize {
        self.links.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.links.is_empty()
    }

    /// Each end's intensity vectors N towards the other from `radiance`
    /// (every surface's node averages): over its members that face the
    /// other end's centroid.
    pub fn far_field(&self, radiance: &[Vec<Rgb>]) -> FarField {
        let sent: Vec<[[DVec3; 3]; 2]> = self
            .links
            .par_iter()
            .map(|t| {
                [0, 1].map(|k| {
                    let towards = t.centers[1 - k] - t.centers[k];
                    let mut n = [DVec3::ZERO; 3];
                    let mut send = |m: &Member| {
                        if m.normal.dot(towards) > 0.0 {
                            let l = radiance[m.surface as usize][m.node as usize];
                            let v = m.normal * m.area;
                            for (n, l) in n.iter_mut().zip(l.0) {
                                *n += v * l;
                            }
                        }
                    };
                    match &t.sides[k] {
                        Side::Element(m) => send(m),
                        Side::Cluster(c) => self
                            .clusters
                            .members_of(*c)
                            .iter()
                            .for_each(|&s| send(&self.roots[s as usize])),
                    }
                    n
                })
            })
            .collect();
        // What every surface's root receives through the links of the
        // clusters above it, in parallel (this sweep's far field is fixed).
        let surfaces = if self.clusters.nodes.is_empty() {
            0
        } else {
            self.roots.len()
        };
        let at_roots = (0..surfaces)
            .into_par_iter()
            .map(|p| {
                let root = &self.roots[p];
                let ancestors = self.clusters.ancestors(p as u32);
                ancestors
                    .flat_map(|c| &self.at_cluster[c as usize])
                    .map(|&at| self.received(root, at, &sent))
                    .fold(Rgb::ZERO, |a, b| a + b)
            })
            .collect();
        FarField { sent, at_roots }
    }

    /// The irradiance over π that `member` receives through side `side` of
    /// link `link` from the intensities `sent`: V·cos·I(−u)/(π·d²).
    fn received(&self, member: &Member, (link, side): (u32, u8), sent: &[[[DVec3; 3]; 2]]) -> Rgb {
        let t = &self.links[link as usize];
        let to = t.centers[1 - side as usize] - member.point;
        let d2 = to.length_squared();
        let cos = member.normal.dot(to);
        if cos <= 0.0 || d2 <= 0.0 {
            return Rgb::ZERO;
        }
        // I(−u)·|u|: the source's intensity towards the member.
        let intensity = Rgb(sent[link as usize][1 - side as usize].map(|n| (-n.dot(to)).max(0.0)));
        intensity * (t.visibility * cos / (PI * d2 * d2))
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
        for &at in &self.at_surface[p as usize] {
            if let Side::Element(m) = self.links[at.0 as usize].sides[at.1 as usize] {
                let value = reflectance * self.received(&m, at, &far.sent);
                gathered.add(m.node as usize, value, DVec3::ZERO);
            }
        }
    }
}
