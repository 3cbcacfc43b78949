//! Two-point links and their adaptive projection: the paper's
//! Compute_2point_Kernel (§4.2) with virtual resolution.
//!
//! Starting from every pair of surfaces that can exchange light, the four
//! children of the *larger* element of the pair are computed by quadrature
//! ([`crate::kernel::throughput`]); if the kernel's Haar details over them
//! pass the [`crate::oracle`], one link is kept at this level with the
//! coefficient assembled from the children (hierarchical decomposition), else
//! each child pair is refined in turn. Elements never go below `max_level`.

use crate::hierarchy::ElementId;
use crate::kernel::{self, KernelElement, Quadrature};
use crate::oracle::KernelSmoothness;
use crate::scene::{Patch, Scene, Surface};
use crate::solve::Progress;
use crate::tracing::SceneTracer;
use rayon::prelude::*;

/// A two-point interaction between element `a` of surface `p` and element `c`
/// of surface `r`, used in both directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    /// First surface.
    pub p: u32,
    /// Element on `p`.
    pub a: ElementId,
    /// Second surface.
    pub r: u32,
    /// Element on `r`.
    pub c: ElementId,
    /// Geometric throughput T(a,c) = |a|·F(a,c) = |c|·F(c,a).
    pub throughput: f64,
}

/// Settings of the adaptive kernel projection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineSettings {
    /// The oracle deciding when to stop refining.
    pub oracle: KernelSmoothness,
    /// Deepest element level (paper: 8).
    pub max_level: u32,
    /// Quadrature of each kernel coefficient.
    pub quadrature: Quadrature,
}

#[derive(Clone, Copy)]
struct Side {
    surface: u32,
    id: ElementId,
    patch: Patch,
}

struct PairRefiner<'a> {
    tracer: &'a SceneTracer,
    settings: RefineSettings,
    /// max(ρ_p A_r, ρ_r A_p): the paper's kernel scale for both directions.
    scale: f64,
    links: Vec<Link>,
}

impl PairRefiner<'_> {
    fn throughput(&self, a: &Side, c: &Side) -> f64 {
        kernel::throughput(
            self.tracer,
            self.settings.quadrature,
            KernelElement {
                patch: &a.patch,
                surface: a.surface,
            },
            KernelElement {
                patch: &c.patch,
                surface: c.surface,
            },
        )
    }

    fn push(&mut self, a: &Side, c: &Side, throughput: f64) {
        if throughput > 0.0 {
            self.links.push(Link {
                p: a.surface,
                a: a.id,
                r: c.surface,
                c: c.id,
                throughput,
            });
        }
    }

    /// Compute_2point_Kernel for the pair (a, c) whose throughput is known.
    fn refine(&mut self, a: Side, c: Side, throughput: f64) {
        let max = self.settings.max_level;
        let split_a = match (a.id.level < max, c.id.level < max) {
            (false, false) => return self.push(&a, &c, throughput),
            (true, false) => true,
            (false, true) => false,
            (true, true) => a.patch.area() >= c.patch.area(),
        };
        let (split, other) = if split_a { (&a, &c) } else { (&c, &a) };
        // Children coefficients by quadrature.
        let children: Vec<Side> = split
            .patch
            .subdivide()
            .into_iter()
            .enumerate()
            .map(|(k, patch)| Side {
                surface: split.surface,
                id: split.id.child(k),
                patch,
            })
            .collect();
        let t: Vec<f64> = children
            .iter()
            .map(|child| self.throughput(child, other))
            .collect();
        let pair_area = children[0].patch.area() * other.patch.area();
        let means = [
            t[0] / pair_area,
            t[1] / pair_area,
            t[2] / pair_area,
            t[3] / pair_area,
        ];
        // Hierarchical decomposition: keep the link here if the details pass.
        if self
            .settings
            .oracle
            .accepts(means, split.id.level, other.id.level, self.scale)
        {
            return self.push(&a, &c, t.iter().sum());
        }
        let other = *other;
        for (child, tk) in children.into_iter().zip(t) {
            if split_a {
                self.refine(child, other, tk);
            } else {
                self.refine(other, child, tk);
            }
        }
    }
}

/// All two-point links of a scene (compute_kernel of §4.2 for diffuse
/// surfaces), refined in parallel over surface pairs; the result does not
/// depend on the number of threads.
pub fn refine_links(
    scene: &Scene,
    tracer: &SceneTracer,
    settings: RefineSettings,
    progress: &dyn Progress,
) -> Vec<Link> {
    let n = scene.surfaces.len();
    let pairs: Vec<(usize, usize)> = (0..n)
        .flat_map(|p| (p + 1..n).map(move |r| (p, r)))
        .filter(|&(p, r)| !kernel::faces_away(&scene.surfaces[p].patch, &scene.surfaces[r].patch))
        .collect();
    progress.start("kernels", pairs.len() as u64);
    let per_pair: Vec<Vec<Link>> = pairs
        .par_iter()
        .map(|&(p, r)| {
            let (sp, sr) = (&scene.surfaces[p], &scene.surfaces[r]);
            let rho = |s: &Surface| s.reflectance.iter().fold(0.0f64, |m, &x| m.max(x));
            let scale = (rho(sp) * sr.patch.area()).max(rho(sr) * sp.patch.area());
            let mut refiner = PairRefiner {
                tracer,
                settings,
                scale,
                links: Vec::new(),
            };
            let a = Side {
                surface: p as u32,
                id: ElementId::ROOT,
                patch: sp.patch,
            };
            let c = Side {
                surface: r as u32,
                id: ElementId::ROOT,
                patch: sr.patch,
            };
            let t = refiner.throughput(&a, &c);
            refiner.refine(a, c, t);
            progress.advance(1);
            refiner.links
        })
        .collect();
    progress.finish();
    per_pair.into_iter().flatten().collect()
}
