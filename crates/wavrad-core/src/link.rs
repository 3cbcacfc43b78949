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
use crate::kernel::{self, KernelElement, OuterSamples, Quadrature};
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
    fn samples(&self, a: &Side, c: &Side) -> OuterSamples {
        kernel::throughput_samples(
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

    fn throughput(&self, a: &Side, c: &Side) -> f64 {
        self.samples(a, c).total()
    }

    /// Mean kernel over each quadrant of `outer` times the whole `inner`
    /// element, read off quadrature that sampled `outer` with one Gauss point
    /// per quadrant (2×2 rule on a parallelogram); `None` otherwise.
    /// `contributions` are the outer samples, summed over several inner
    /// elements that together make `inner`.
    fn quadrant_means(
        &self,
        contributions: [f64; 4],
        outer: &Side,
        inner: &Side,
    ) -> Option<[f64; 4]> {
        let two_by_two = self.settings.quadrature.points == 2;
        if !two_by_two || !matches!(outer.patch, Patch::Parallelogram { .. }) {
            return None;
        }
        let weight = outer.patch.area() / 4.0;
        let mut means = [0.0; 4];
        // Gauss point (ix, iy) is point 2·ix + iy and lies in quadrant ix + 2·iy.
        for (point, quadrant) in [0usize, 2, 1, 3].into_iter().enumerate() {
            means[quadrant] = contributions[point] / (weight * inner.patch.area());
        }
        Some(means)
    }

    /// The kernel's details one level below those the paper's oracle sees,
    /// wherever the quadrature already sampled them: over the quadrants of
    /// each child of `split` (when the child was the point-sampled element),
    /// and over the quadrants of `other` (when it was, for every child).
    /// Returns (children smooth, other smooth). A kernel symmetric over the
    /// four children (two facing walls) has zero details at the children's
    /// level however much it varies inside them; this catches it.
    fn look_ahead(
        &self,
        samples: &[OuterSamples],
        children: &[Side],
        split: &Side,
        other: &Side,
    ) -> (bool, bool) {
        let oracle = self.settings.oracle;
        let max = self.settings.max_level;
        let four = |s: &OuterSamples| <[f64; 4]>::try_from(&s.contributions[..]).ok();
        let children_smooth = samples.iter().zip(children).all(|(s, child)| {
            if !s.outer_is_a || child.id.level >= max {
                return true;
            }
            four(s)
                .and_then(|c| self.quadrant_means(c, child, other))
                .is_none_or(|m| oracle.accepts(m, child.id.level, other.id.level, self.scale))
        });
        let other_smooth = other.id.level >= max || samples.iter().any(|s| s.outer_is_a) || {
            let mut sum = [0.0; 4];
            let mut complete = true;
            for s in samples {
                match four(s) {
                    Some(c) => (0..4).for_each(|i| sum[i] += c[i]),
                    None => complete = false,
                }
            }
            !complete
                || self
                    .quadrant_means(sum, other, split)
                    .is_none_or(|m| oracle.accepts(m, other.id.level, split.id.level, self.scale))
        };
        (children_smooth, other_smooth)
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
        let samples: Vec<OuterSamples> = children
            .iter()
            .map(|child| self.samples(child, other))
            .collect();
        let t: Vec<f64> = samples.iter().map(OuterSamples::total).collect();
        let pair_area = children[0].patch.area() * other.patch.area();
        let means = [
            t[0] / pair_area,
            t[1] / pair_area,
            t[2] / pair_area,
            t[3] / pair_area,
        ];
        let (children_smooth, other_smooth) = self.look_ahead(&samples, &children, split, other);
        let split_smooth = children_smooth
            && self
                .settings
                .oracle
                .accepts(means, split.id.level, other.id.level, self.scale);
        // Hierarchical decomposition: keep the link here if the details pass;
        // if only the unsplit element's fail, refine it instead.
        if split_smooth && other_smooth {
            return self.push(&a, &c, t.iter().sum());
        }
        if split_smooth {
            let (split, other) = (*other, *split);
            for (k, patch) in split.patch.subdivide().into_iter().enumerate() {
                let child = Side {
                    surface: split.surface,
                    id: split.id.child(k),
                    patch,
                };
                let tk = self.throughput(&child, &other);
                if split_a {
                    self.refine(other, child, tk);
                } else {
                    self.refine(child, other, tk);
                }
            }
            return;
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

/// All two-point links of a scene (compute_kernel of §4.2 for pairs with a
/// diffuse surface), refined in parallel over surface pairs; the result does not
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
        // Glossy receivers gather through three-point links instead.
        .filter(|&(p, r)| scene.surfaces[p].is_diffuse() || scene.surfaces[r].is_diffuse())
        .collect();
    progress.start("kernels", pairs.len() as u64);
    let per_pair: Vec<Vec<Link>> = pairs
        .par_iter()
        .map(|&(p, r)| {
            let (sp, sr) = (&scene.surfaces[p], &scene.surfaces[r]);
            let rho = |s: &Surface| {
                s.brdf
                    .diffuse_reflectance()
                    .map_or(0.0, |r| r.iter().fold(0.0f64, |m, &x| m.max(x)))
            };
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oracle::KernelSmoothness;
    use crate::scene::Surface;
    use crate::solve::Silent;
    use glam::DVec3;

    /// Two directly facing squares: the kernel over the four children of one
    /// against the whole other is the same by symmetry, so the paper's
    /// children-only details vanish at the root although the kernel varies
    /// five-fold across each child. The look-ahead must refine.
    #[test]
    fn symmetric_facing_squares_are_refined_below_the_root() {
        let square = |z: f64, flip: bool| Surface {
            name: String::new(),
            patch: Patch::Parallelogram {
                origin: DVec3::new(0.0, 0.0, z),
                edge_s: if flip { DVec3::Y } else { DVec3::X },
                edge_t: if flip { DVec3::X } else { DVec3::Y },
            },
            brdf: crate::brdf::Brdf::diffuse([0.8; 3]),
            emission: [0.0; 3],
        };
        let scene = Scene::from_surfaces(vec![square(0.0, false), square(0.3, true)]);
        let tracer = SceneTracer::new(&scene);
        let settings = RefineSettings {
            oracle: KernelSmoothness { threshold: 1e-3 },
            max_level: 4,
            quadrature: Quadrature::default(),
        };
        let links = refine_links(&scene, &tracer, settings, &Silent);
        assert!(links.len() > 16, "{} links", links.len());
        assert!(links.iter().all(|l| l.a.level + l.c.level >= 2));
        // The links partition the pair: they add up to Howell's closed form
        // for parallel unit squares at distance 0.3.
        let t: f64 = links.iter().map(|l| l.throughput).sum();
        assert!((t - 0.579_530_8).abs() < 1e-4, "{t}");
    }
}
