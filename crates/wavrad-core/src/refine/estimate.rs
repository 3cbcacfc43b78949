//! What the weighted oracles ([`crate::refine::oracle::Oracle::Power`] and
//! `Importance`) expect a link to carry: the radiance L_{c→a} its source
//! sends, from the last solution of the refine–solve loop (or from the
//! emission alone before the first), and the importance of its receiver.

use super::importance::Importance;
use crate::geometry::hierarchy::{ElementRef, ElementTree};
use crate::geometry::pair_tree::PairTree;
use crate::scene::{Rgb, Scene};
use std::collections::{BTreeMap, BTreeSet};

/// Radiance (and importance) estimates for the weighted oracles, relative
/// to the brightest emitted radiance.
#[derive(Debug, Clone)]
pub struct LightEstimate {
    /// Brightest emitted radiance (largest channel); estimates are divided
    /// by it so thresholds do not depend on the scene's units.
    reference: f64,
    /// Whole-surface emission (largest channel), used where no solution is.
    emission: Vec<f64>,
    /// Element trees and their radiance (largest channel) per surface.
    trees: Vec<ElementTree>,
    radiance: Vec<Vec<f64>>,
    /// Directional radiance of glossy surfaces, by (p, q).
    directional: BTreeMap<(u32, u32), (PairTree, Vec<f64>)>,
    /// Receiver importance for the importance-driven oracle.
    importance: Option<Importance>,
}

impl LightEstimate {
    /// Before any solve: only emitters carry light.
    pub fn emission(scene: &Scene, importance: Option<Importance>) -> LightEstimate {
        let emission: Vec<f64> = scene
            .surfaces
            .iter()
            .map(|s| s.emission.max_channel())
            .collect();
        LightEstimate {
            reference: scene.brightest_radiance().max(f64::MIN_POSITIVE),
            emission,
            trees: Vec::new(),
            radiance: Vec::new(),
            directional: BTreeMap::new(),
            importance,
        }
    }

    /// From a solution: element radiance of diffuse surfaces over `trees`,
    /// directional radiance of glossy ones, by (p, q), over their pair trees.
    pub fn from_solution<'a>(
        scene: &Scene,
        trees: Vec<ElementTree>,
        radiance: &[Vec<Rgb>],
        directional: impl IntoIterator<Item = ((u32, u32), &'a PairTree, &'a [Rgb])>,
        importance: Option<Importance>,
    ) -> LightEstimate {
        let values = |v: &[Rgb]| v.iter().map(|l| l.max_channel()).collect::<Vec<f64>>();
        LightEstimate {
            trees,
            radiance: radiance.iter().map(|r| values(r)).collect(),
            directional: directional
                .into_iter()
                .map(|(pair, tree, v)| (pair, (tree.clone(), values(v))))
                .collect(),
            ..LightEstimate::emission(scene, importance)
        }
    }

    /// One step of shooting ([`crate::solve::shoot`]): only `shooter` sends light,
    /// its radiance `sent` over `tree`; the other surfaces send none in this
    /// step.
    pub fn shot(scene: &Scene, shooter: u32, tree: ElementTree, sent: &[Rgb]) -> LightEstimate {
        let mut trees = Vec::with_capacity(scene.surfaces.len());
        let mut radiance = Vec::with_capacity(scene.surfaces.len());
        for surface in &scene.surfaces {
            // The others: one element that sends nothing.
            trees.push(ElementTree::build(&surface.patch, &BTreeSet::new()));
            radiance.push(vec![0.0]);
        }
        trees[shooter as usize] = tree;
        radiance[shooter as usize] = sent.iter().map(|l| l.max_channel()).collect();
        LightEstimate {
            trees,
            radiance,
            ..LightEstimate::emission(scene, None)
        }
    }

    /// L_{c→a} (c on r, a on p) relative to the brightest emission.
    pub fn radiance(&self, source: ElementRef, receiver: ElementRef) -> f64 {
        let (ElementRef { surface: r, id: c }, ElementRef { surface: p, id: a }) =
            (source, receiver);
        let own = match self.trees.get(r as usize) {
            Some(tree) => self.radiance[r as usize][tree.node_containing(c) as usize],
            None => self.emission[r as usize],
        };
        let glossy: f64 = self.directional.get(&(r, p)).map_or(0.0, |(tree, values)| {
            (tree.overlaps(c, a).into_iter())
                .map(|(n, w)| w * values[n as usize])
                .sum()
        });
        (own + glossy) / self.reference
    }

    /// Relative importance of the `receiver` element (1 without an
    /// importance estimate).
    pub fn importance(&self, receiver: ElementRef) -> f64 {
        let i = self.importance.as_ref();
        i.map_or(1.0, |i| i.at(receiver.surface, receiver.id))
    }
}
