//! Three-point links and their adaptive projection: the paper's
//! Compute_3point_Kernel (§4.2) with virtual resolution.
//!
//! For every glossy surface p, every surface r that can light it and every
//! surface q it can light, the triple of whole surfaces is refined: the four
//! children of the *largest* of the three elements are integrated
//! ([`crate::kernel::three_point::coefficient`]); if the kernel's Haar
//! details over them pass the oracle the link is kept at this level with the
//! coefficient assembled from the children, else each child triple is
//! refined in turn. Elements never go below `max_level`.

use crate::brdf::Frame;
use crate::hierarchy::ElementId;
use crate::kernel::three_point::{coefficient, GlossyElement};
use crate::kernel::{faces_away, KernelElement};
use crate::link::RefineSettings;
use crate::scene::{Patch, Rgb, Scene};
use crate::solve::Progress;
use crate::tracing::SceneTracer;
use rayon::prelude::*;

/// A three-point interaction r → p → q: `L_{a→b} += coefficient · L_{c→a}`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThreePointLink {
    /// Source surface.
    pub r: u32,
    /// Element on `r`.
    pub c: ElementId,
    /// Glossy surface.
    pub p: u32,
    /// Element on `p`.
    pub a: ElementId,
    /// Receiving surface (an index past the scene's surfaces names a
    /// hypothetical receiver, such as the eye).
    pub q: u32,
    /// Element on `q`.
    pub b: ElementId,
    /// R(c, a, b) per channel (element-average form of eq. 13).
    pub coefficient: Rgb,
}

/// One element of a triple being refined.
#[derive(Debug, Clone, Copy)]
struct Part {
    id: ElementId,
    patch: Patch,
}

impl Part {
    fn children(&self) -> [Part; 4] {
        let patches = self.patch.subdivide();
        [0, 1, 2, 3].map(|k| Part {
            id: self.id.child(k),
            patch: patches[k],
        })
    }
}

/// The surfaces of one triple and what the kernel needs of them.
struct TripleRefiner<'a> {
    tracer: &'a SceneTracer,
    scene: &'a Scene,
    settings: RefineSettings,
    r: u32,
    p: u32,
    q: u32,
    frame: Frame,
    links: Vec<ThreePointLink>,
}

impl TripleRefiner<'_> {
    fn coefficient(&self, c: &Part, a: &Part, b: &Part) -> Rgb {
        coefficient(
            self.tracer,
            self.settings.quadrature,
            KernelElement {
                patch: &c.patch,
                surface: self.r,
            },
            GlossyElement {
                element: KernelElement {
                    patch: &a.patch,
                    surface: self.p,
                },
                brdf: &self.scene.surfaces[self.p as usize].brdf,
                frame: self.frame,
            },
            &b.patch,
        )
    }

    fn push(&mut self, c: &Part, a: &Part, b: &Part, coefficient: Rgb) {
        if coefficient.iter().any(|&x| x > 0.0) {
            self.links.push(ThreePointLink {
                r: self.r,
                c: c.id,
                p: self.p,
                a: a.id,
                q: self.q,
                b: b.id,
                coefficient,
            });
        }
    }

    /// Compute_3point_Kernel for the triple (c, a, b) whose coefficient is
    /// known.
    ///
    /// Virtual resolution splits one element at a time, largest first. The
    /// details over the children of one element are blind to variation
    /// along the others (a Lambertian p's kernel does not depend on b at
    /// all), so when the largest element's details pass, the next one's are
    /// tested too; the first element whose details fail is subdivided. The
    /// link is kept only when every refinable element passes.
    fn refine(&mut self, c: Part, a: Part, b: Part, known: Rgb) {
        let max = self.settings.max_level;
        // A hypothetical receiver (the eye) is a point: never split.
        let point_receiver = self.q as usize >= self.scene.surfaces.len();
        let parts = [c, a, b];
        let mut order: Vec<usize> = (0..3)
            .filter(|&i| parts[i].id.level < max && !(i == 2 && point_receiver))
            .collect();
        order.sort_by(|&i, &j| parts[j].patch.area().total_cmp(&parts[i].patch.area()));
        let mut kept = None;
        for split in order {
            let children = parts[split].children();
            let coefficients = children.map(|child| {
                let mut t = parts;
                t[split] = child;
                self.coefficient(&t[0], &t[1], &t[2])
            });
            if !self.smooth(&parts, split, &children, &coefficients) {
                for (child, k) in children.into_iter().zip(coefficients) {
                    let mut t = parts;
                    t[split] = child;
                    self.refine(t[0], t[1], t[2], k);
                }
                return;
            }
            // Hierarchical decomposition: the coefficient from the children
            // (R integrates over c and averages over a and b).
            let weight = if split == 0 { 1.0 } else { 0.25 };
            kept.get_or_insert_with(|| {
                [0, 1, 2].map(|ch| weight * coefficients.iter().map(|k| k[ch]).sum::<f64>())
            });
        }
        self.push(&c, &a, &b, kept.unwrap_or(known));
    }

    /// The paper's oracle on the children of `parts[split]`: the kernel in
    /// its parametrisation, K = f·G·V·A_r, averaged over each child triple,
    /// has Haar details at most the threshold.
    fn smooth(&self, parts: &[Part; 3], split: usize, children: &[Part; 4], k: &[Rgb; 4]) -> bool {
        let area_c = if split == 0 {
            children[0].patch.area()
        } else {
            parts[0].patch.area()
        };
        let means = k.map(|k| k.iter().fold(0.0f64, |m, &x| m.max(x)) / area_c);
        let other_levels: u32 = (0..3)
            .filter(|&i| i != split)
            .map(|i| parts[i].id.level)
            .sum();
        let r_area = self.scene.surfaces[self.r as usize].patch.area();
        self.settings
            .oracle
            .accepts(means, parts[split].id.level, other_levels, r_area)
    }
}

/// Every (r, p, q) of whole surfaces that needs three-point links: p glossy,
/// r able to light p, q able to receive from p (r may be q).
pub fn surface_triples(scene: &Scene) -> Vec<(u32, u32, u32)> {
    let n = scene.surfaces.len() as u32;
    let sees = |x: u32, y: u32| {
        x != y
            && !faces_away(
                &scene.surfaces[x as usize].patch,
                &scene.surfaces[y as usize].patch,
            )
    };
    (0..n)
        .filter(|&p| !scene.surfaces[p as usize].is_diffuse())
        .flat_map(|p| {
            (0..n)
                .filter(move |&r| sees(r, p))
                .flat_map(move |r| (0..n).filter(move |&q| sees(p, q)).map(move |q| (r, p, q)))
        })
        .collect()
}

/// The three-point links of the triples `(r, p, q)` (compute_kernel of §4.2
/// for glossy surfaces), refined in parallel over triples; the result does
/// not depend on the number of threads. `receiver(q)` gives the geometry of
/// receiver `q`, which may be a hypothetical surface outside the scene.
pub fn refine_three_point_links(
    scene: &Scene,
    tracer: &SceneTracer,
    settings: RefineSettings,
    triples: &[(u32, u32, u32)],
    receiver: impl Fn(u32) -> Patch + Sync,
    progress: &dyn Progress,
) -> Vec<ThreePointLink> {
    progress.start("3-point kernels", triples.len() as u64);
    let per_triple: Vec<Vec<ThreePointLink>> = triples
        .par_iter()
        .map(|&(r, p, q)| {
            let root = |patch: Patch| Part {
                id: ElementId::ROOT,
                patch,
            };
            let mut refiner = TripleRefiner {
                tracer,
                scene,
                settings,
                r,
                p,
                q,
                frame: scene.surfaces[p as usize].frame(),
                links: Vec::new(),
            };
            let (c, a, b) = (
                root(scene.surfaces[r as usize].patch),
                root(scene.surfaces[p as usize].patch),
                root(receiver(q)),
            );
            let k = refiner.coefficient(&c, &a, &b);
            refiner.refine(c, a, b, k);
            progress.advance(1);
            refiner.links
        })
        .collect();
    progress.finish();
    per_triple.into_iter().flatten().collect()
}
