//! Gathering (paper §4.2, compute_radiance_solution, eq. 12 for a diffuse
//! receiver): each element collects ρ·F·L over its incoming links.

use crate::hierarchy::ElementTree;
use crate::link::Link;
use crate::scene::{Rgb, Scene};

/// One direction of a link, as seen by its receiving surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transfer {
    /// Receiving node in the receiver's tree.
    pub receiver: u32,
    /// Source surface.
    pub source_surface: u32,
    /// Source node in the source's tree.
    pub source: u32,
    /// Form factor F(receiver element, source element).
    pub form_factor: f64,
}

/// Incoming transfers of every surface, ordered by receiving node (so the
/// gather is deterministic).
pub fn incoming_transfers(
    scene: &Scene,
    trees: &[ElementTree],
    links: &[Link],
) -> Vec<Vec<Transfer>> {
    let mut incoming = vec![Vec::new(); scene.surfaces.len()];
    let node = |s: u32, id| {
        trees[s as usize]
            .index_of(id)
            .expect("link element is in its tree")
    };
    for l in links {
        let (a, c) = (node(l.p, l.a), node(l.r, l.c));
        let area_a = trees[l.p as usize].nodes[a as usize].patch.area();
        let area_c = trees[l.r as usize].nodes[c as usize].patch.area();
        incoming[l.p as usize].push(Transfer {
            receiver: a,
            source_surface: l.r,
            source: c,
            form_factor: l.throughput / area_a,
        });
        incoming[l.r as usize].push(Transfer {
            receiver: c,
            source_surface: l.p,
            source: a,
            form_factor: l.throughput / area_c,
        });
    }
    for list in &mut incoming {
        list.sort_by_key(|t| (t.receiver, t.source_surface, t.source));
    }
    incoming
}

/// Radiance reflected at each node of the receiving surface from the current
/// radiance of its sources: `ρ · Σ F · L_source` (before push–pull).
pub fn gather(
    incoming: &[Transfer],
    reflectance: Rgb,
    nodes: usize,
    radiance: &[Vec<Rgb>],
) -> Vec<Rgb> {
    let mut gathered = vec![[0.0; 3]; nodes];
    for t in incoming {
        let l = radiance[t.source_surface as usize][t.source as usize];
        let g = &mut gathered[t.receiver as usize];
        for ch in 0..3 {
            g[ch] += reflectance[ch] * t.form_factor * l[ch];
        }
    }
    gathered
}
