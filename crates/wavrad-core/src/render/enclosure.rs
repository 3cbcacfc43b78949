//! A hypothetical enclosure receiver (paper §6, generalising its eye): the
//! six inward faces of a box around the scene, which receive light through
//! three-point links but neither occlude nor reflect. Gathering into it once,
//! after the solve, gives every glossy surface p its directional radiance
//! L_{p→E} towards the directions that leave the scene, so that with the
//! directional structures L_{p→q} of the solve every direction leaving a
//! glossy point has a receiver: [`super::Renderer::glossy_radiance_towards`]
//! looks radiance up in any direction without a per-view gather (rendering
//! with [`super::estimator::GlossyView::Directional`]). The receivers'
//! elements are coarser in direction than the eye's single point, so
//! highlights come out softer.

use crate::geometry::hierarchy::{ElementId, ElementRef};
use crate::geometry::pair_tree::PairTree;
use crate::kernel::exposure::PairExposure;
use crate::kernel::faces_away;
use crate::progress::Progress;
use crate::render::eye::{glossy_sources, radiance_from, receiver_links};
use crate::scene::{Patch, Rgb, Scene};
use crate::solve::{push_pull::push_pull, Solution};
use glam::DVec3;
use std::collections::BTreeMap;

/// Radiance of every glossy surface towards the enclosure.
#[derive(Debug, Clone, PartialEq)]
pub struct EnclosureRadiance {
    /// The enclosure: the inward faces of the scene's bounding box grown by
    /// 1 % of its diagonal.
    pub faces: [Patch; 6],
    /// For each (glossy surface p, face k) that can exchange light: the
    /// element pairs (a on p, b on face k) and their average radiance
    /// L_{a→b} (what p's non-Lambertian lobes reflect; its element radiance
    /// adds the rest).
    pub structures: BTreeMap<(u32, u32), (PairTree, Vec<Rgb>)>,
    /// Element level to which points are located in the pair trees.
    depth: u32,
}

impl EnclosureRadiance {
    /// Radiance leaving point `y` of glossy surface `p` along the unit
    /// direction `d`, read where the ray from `y` leaves the enclosure (the
    /// enclosure does not occlude: this is radiance that leaves the scene,
    /// or reaches a surface beyond which the ray would go on). Zero where
    /// `p` has no structure towards that face.
    pub fn radiance(&self, scene: &Scene, p: u32, y: DVec3, d: DVec3) -> Rgb {
        let Some((k, z)) = exit(&self.faces, y, d) else {
            return Rgb::ZERO;
        };
        let Some((tree, values)) = self.structures.get(&(p, k)) else {
            return Rgb::ZERO;
        };
        let source = &scene.surfaces[p as usize].patch;
        let face = &self.faces[k as usize];
        let path_y = path(source, y, self.depth);
        let path_z = path(face, z, self.depth);
        values[tree.leaf_at(|l| path_y[l as usize], |l| path_z[l as usize]) as usize]
    }
}

/// The elements of `patch` containing point `x` at levels 0..=depth.
fn path(patch: &Patch, x: DVec3, depth: u32) -> Vec<ElementId> {
    ElementId::path_to(patch, patch.clamp_param(patch.param_of(x)), depth)
}

/// Face of the box `faces` (inward normals) through which the ray from `y`
/// inside it along `d` leaves, and the point where it does.
fn exit(faces: &[Patch; 6], y: DVec3, d: DVec3) -> Option<(u32, DVec3)> {
    faces
        .iter()
        .enumerate()
        .filter_map(|(k, f)| {
            let n = f.normal();
            let toward = n.dot(d);
            // Leaving through face k: moving against its inward normal.
            (toward < 0.0).then(|| (k as u32, n.dot(f.vertices()[0] - y) / toward))
        })
        .filter(|&(_, t)| t >= 0.0)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(k, t)| (k, y + t * d))
}

/// The inward faces of the box around `scene`, grown by 1 % of its diagonal.
pub fn enclosure_faces(scene: &Scene) -> [Patch; 6] {
    let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
    for s in &scene.surfaces {
        for v in s.patch.vertices() {
            (lo, hi) = (lo.min(v), hi.max(v));
        }
    }
    let pad = DVec3::splat(0.01 * (hi - lo).length().max(1e-9));
    Patch::inward_box(lo - pad, hi + pad)
}

impl EnclosureRadiance {
    /// Gather `solution` once into the enclosure (three-point links
    /// r → p → face for every glossy p and every face it sees).
    pub fn gather(solution: &Solution, progress: &dyn Progress) -> EnclosureRadiance {
        let scene = &solution.scene;
        let faces = enclosure_faces(scene);
        let n = scene.surfaces.len() as u32;
        let triples: Vec<(u32, u32, u32)> = glossy_sources(solution)
            .into_iter()
            .flat_map(|(r, p)| (0..6u32).map(move |k| (r, p, n + k)))
            .filter(|&(_, p, q)| {
                !faces_away(&scene.surfaces[p as usize].patch, &faces[(q - n) as usize])
            })
            .collect();
        let links = receiver_links(solution, &triples, |q| faces[(q - n) as usize], progress);
        let mut trees: BTreeMap<(u32, u32), PairTree> = BTreeMap::new();
        for l in &links {
            trees.entry((l.p, l.q - n)).or_default().insert(l.a, l.b);
        }
        // Radiance is averaged over the exposed part of each element pair.
        let exposure = PairExposure::new(
            &solution.kernel_context(),
            trees.iter().flat_map(|(&(p, k), tree)| {
                tree.nodes
                    .iter()
                    .map(move |node| [ElementRef::new(p, node.a), ElementRef::new(n + k, node.b)])
            }),
        );
        let mut gathered: BTreeMap<(u32, u32), Vec<Rgb>> = trees
            .iter()
            .map(|(&key, tree)| (key, vec![Rgb::ZERO; tree.nodes.len()]))
            .collect();
        for l in &links {
            let key = (l.p, l.q - n);
            let source = radiance_from(solution, l.r, l.c, l.p, l.a);
            let e = exposure.of(ElementRef::new(l.p, l.a), ElementRef::new(l.q, l.b));
            let scale = if e > 0.0 { 1.0 / e } else { 1.0 };
            let add = l.coefficient * scale * source;
            let g = gathered.get_mut(&key).expect("a tree per linked pair");
            for (node, _) in trees[&key].overlaps(l.a, l.b) {
                g[node as usize] += add;
            }
        }
        let structures = trees
            .into_iter()
            .map(|((p, k), tree)| {
                let weights: Vec<f64> = tree
                    .nodes
                    .iter()
                    .map(|node| {
                        exposure.of(ElementRef::new(p, node.a), ElementRef::new(n + k, node.b))
                    })
                    .collect();
                let values = push_pull(
                    &tree,
                    &gathered[&(p, k)],
                    Rgb::ZERO,
                    Some(&weights),
                    None,
                    None,
                );
                ((p, k), (tree, values))
            })
            .collect();
        EnclosureRadiance {
            faces,
            structures,
            depth: solution.settings.receiver_refine().receiver_max_level,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_leave_the_box_through_the_face_they_meet_first() {
        let faces = Patch::inward_box(DVec3::ZERO, DVec3::new(2.0, 1.0, 1.0));
        let centre = DVec3::new(1.0, 0.5, 0.5);
        for d in [
            DVec3::X,
            -DVec3::X,
            DVec3::Y,
            -DVec3::Z,
            DVec3::new(1.0, 0.2, 0.1).normalize(),
        ] {
            let (k, z) = exit(&faces, centre, d).expect("inside the box");
            let f = &faces[k as usize];
            // On the face's plane, within the face, and along the ray.
            assert!(f.normal().dot(z - f.vertices()[0]).abs() < 1e-12, "{d}");
            let uv = f.param_of(z);
            assert!(
                uv.min_element() >= -1e-12 && uv.max_element() <= 1.0 + 1e-12,
                "{d}"
            );
            assert!((z - centre).normalize().dot(d) > 1.0 - 1e-12, "{d}");
        }
    }
}
