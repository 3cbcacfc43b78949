//! The eye as a hypothetical receiver (paper §6, after Aupperle & Hanrahan):
//! a surface at the sensor that receives light through three-point links but
//! neither occludes nor reflects. Gathering into it once, after the solve,
//! gives every glossy surface its radiance towards this view, L_{p→eye},
//! which [`super::estimator::GlossyView::Eye`] looks up along view rays.
//!
//! The eye is a tiny square at the pinhole (for an orthographic sensor, far
//! behind it along the view axis, so that every point sees it along the view
//! direction) and is never subdivided.

use crate::geometry::hierarchy::{ElementId, ElementRef, ElementTree, Hierarchy};
use crate::kernel::exposure::PairExposure;
use crate::kernel::lights::{grid, reflected_towards};
use crate::progress::Progress;
use crate::refine::estimate::LightEstimate;
use crate::refine::light_links::SKY_GRID;
use crate::refine::three_point_projection::{refine_three_point_links, ThreePointLink};
use crate::scene::brdf::{BrdfFlags, BrdfModel};
use crate::scene::{Camera, Patch, Projection, Rgb, Scene};
use crate::solve::{push_pull::push_pull, Solution};
use glam::DVec3;
use std::collections::BTreeSet;

/// Radiance of every glossy surface towards one view, per element.
#[derive(Debug, Clone, PartialEq)]
pub struct EyeRadiance {
    /// For each surface, if glossy and facing the eye: its element tree and
    /// the average radiance L_{a→eye} of every node (what its
    /// non-Lambertian lobes reflect; its element radiance adds the rest).
    pub surfaces: Vec<Option<(ElementTree, Vec<Rgb>)>>,
}

/// Where the eye receiver sits for `camera`, as a tiny square.
pub fn eye_patch(scene: &Scene, camera: &Camera) -> Patch {
    let m = &camera.world_from_camera;
    let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
    for s in &scene.surfaces {
        for v in s.patch.vertices() {
            (lo, hi) = (lo.min(v), hi.max(v));
        }
    }
    let extent = (hi - lo).length().max(1e-9);
    let view = m.transform_vector3(DVec3::Z).normalize();
    let centre = match camera.projection {
        Projection::Perspective { .. } => m.transform_point3(DVec3::ZERO),
        Projection::Orthographic => m.transform_point3(DVec3::ZERO) - view * 1e4 * extent,
    };
    let side = 1e-6 * extent;
    let (u, v) = (
        view.any_orthonormal_vector(),
        view.cross(view.any_orthonormal_vector()),
    );
    Patch::Parallelogram {
        origin: centre - 0.5 * side * (u + v),
        edge_s: side * v,
        edge_t: side * u,
    }
}

/// The (source r, glossy p) surface pairs through which light reaches a
/// receiver from a glossy surface (of the surface pairs the solution
/// linked, [`Solution::pairs`]), in order.
pub(crate) fn glossy_sources(solution: &Solution) -> BTreeSet<(u32, u32)> {
    let glossy = |p: u32| {
        solution.scene.surfaces[p as usize]
            .brdf
            .flags()
            .contains(BrdfFlags::GLOSSY_REFLECTION)
    };
    solution
        .pairs
        .iter()
        .flat_map(|&(a, b)| [(a, b), (b, a)])
        .filter(|&(_, p)| glossy(p))
        .collect()
}

impl EyeRadiance {
    /// Gather `solution` once into the eye at `camera` (three-point links
    /// r → p → eye for every glossy p that faces it, and the light of the
    /// scene's lights that are not surfaces reflected towards it,
    /// [`reflected_towards`]).
    pub fn gather(solution: &Solution, camera: &Camera, progress: &dyn Progress) -> EyeRadiance {
        let scene = &solution.scene;
        let eye = eye_patch(scene, camera);
        let eye_index = scene.surfaces.len() as u32;
        let at = eye.centroid();
        let triples: Vec<(u32, u32, u32)> = glossy_sources(solution)
            .into_iter()
            .filter(|&(_, p)| {
                let patch = &scene.surfaces[p as usize].patch;
                patch.normal().dot(at - patch.vertices()[0]) > 0.0
            })
            .map(|(r, p)| (r, p, eye_index))
            .collect();
        let links = receiver_links(solution, &triples, |_| eye, progress);
        let mut ids = vec![BTreeSet::from([ElementId::ROOT]); scene.surfaces.len()];
        for l in &links {
            ids[l.p as usize].insert(l.a);
        }
        let mut surfaces: Vec<Option<(ElementTree, Vec<Rgb>)>> = vec![None; scene.surfaces.len()];
        let mut gathered: Vec<Vec<Rgb>> = vec![Vec::new(); scene.surfaces.len()];
        for &(_, p, _) in &triples {
            if surfaces[p as usize].is_none() {
                let tree = ElementTree::build(&scene.surfaces[p as usize].patch, &ids[p as usize]);
                gathered[p as usize] = vec![Rgb::ZERO; tree.nodes.len()];
                surfaces[p as usize] = Some((tree, Vec::new()));
            }
        }
        // Radiance is averaged over the exposed part of each element.
        let exposure = PairExposure::new(
            &solution.kernel_context(),
            surfaces.iter().enumerate().flat_map(|(p, entry)| {
                let nodes = entry.as_ref().map_or(&[][..], |(tree, _)| &tree.nodes[..]);
                nodes
                    .iter()
                    .map(move |n| [ElementRef::new(p as u32, n.id), ElementRef::root(eye_index)])
            }),
        );
        let exposed =
            |p: u32, a: ElementId| exposure.of(ElementRef::new(p, a), ElementRef::root(eye_index));
        for l in &links {
            let Some((tree, _)) = &surfaces[l.p as usize] else {
                continue;
            };
            let node = tree.index_of(l.a).expect("linked element is in the tree");
            let source = radiance_from(solution, l.r, l.c, l.p, l.a);
            let e = exposed(l.p, l.a);
            let scale = if e > 0.0 { 1.0 / e } else { 1.0 };
            gathered[l.p as usize][node as usize] += l.coefficient * scale * source;
        }
        // The lights that are not surfaces, into every leaf.
        if !scene.lights.is_empty() {
            let sky = grid(SKY_GRID / 2);
            let points = solution.settings.quadrature.points;
            for (p, entry) in surfaces.iter().enumerate() {
                let Some((tree, _)) = entry else { continue };
                let brdf = scene.surfaces[p].brdf.without_lambertian();
                for (node, n) in tree.nodes.iter().enumerate() {
                    if tree.first_child(node).is_some() {
                        continue;
                    }
                    let at = (p as u32, &brdf);
                    let l = reflected_towards(
                        scene,
                        &solution.tracer,
                        at,
                        (&n.patch, &eye),
                        (points, &sky),
                    );
                    let e = exposed(p as u32, n.id);
                    gathered[p][node] += l * if e > 0.0 { 1.0 / e } else { 1.0 };
                }
            }
        }
        for (p, entry) in surfaces.iter_mut().enumerate() {
            if let Some((tree, radiance)) = entry {
                let weights: Vec<f64> =
                    tree.nodes.iter().map(|n| exposed(p as u32, n.id)).collect();
                *radiance = push_pull(tree, &gathered[p], Rgb::ZERO, Some(&weights), None, None);
            }
        }
        EyeRadiance { surfaces }
    }
}

/// The three-point links r → p → q of `solution` into hypothetical
/// receivers q (the eye, the enclosure's faces), whose geometry
/// `receiver(q)` gives, projected after the solve; the weighted oracles
/// weigh them by the solved light.
pub(crate) fn receiver_links(
    solution: &Solution,
    triples: &[(u32, u32, u32)],
    receiver: impl Fn(u32) -> Patch + Sync,
    progress: &dyn Progress,
) -> Vec<ThreePointLink> {
    let estimate = solution.settings.oracle.is_weighted().then(|| {
        LightEstimate::from_solution(
            &solution.scene,
            solution.trees.clone(),
            &solution.radiance,
            (solution.interactions).directional_radiance(&solution.directional),
            None,
        )
    });
    refine_three_point_links(
        &solution.kernel_context(),
        solution.settings.receiver_refine(),
        estimate.as_ref(),
        triples,
        receiver,
        progress,
    )
    .into_links()
}

/// L_{c→a}: the average radiance of `solution` leaving element `c` of
/// surface `r` towards element `a` of surface `p`, at any levels: the
/// element's own and, from a glossy `r`, its directional radiance towards
/// `a`.
pub fn radiance_from(solution: &Solution, r: u32, c: ElementId, p: u32, a: ElementId) -> Rgb {
    let (r, p) = (r as usize, p as usize);
    let mut l = solution.radiance[r][solution.trees[r].node_containing(c) as usize];
    if !solution.scene.surfaces[r]
        .brdf
        .flags()
        .contains(BrdfFlags::GLOSSY_REFLECTION)
    {
        return l;
    }
    let Some(&s) = solution
        .interactions
        .structure_of
        .get(&(r as u32, p as u32))
    else {
        return l;
    };
    let values = &solution.directional[s as usize];
    for (n, w) in solution.interactions.directional[s as usize]
        .tree
        .overlaps(c, a)
    {
        l += values[n as usize] * w;
    }
    l
}
