//! The whole solution (paper §4.2, wavelet_radiance): compute kernels
//! ([`crate::link::refine_links`]), build the element hierarchies, then
//! Gauss–Seidel gathering with push–pull until the coarsest coefficients
//! settle.

pub mod gather;
pub mod push_pull;

use crate::directional::PairTree;
use crate::hierarchy::{ElementId, ElementTree};
use crate::link::{refine_links, RefineSettings};
use crate::scene::{Rgb, Scene};
use crate::stats::{PhaseTimes, Stats};
use crate::three_point::{refine_three_point_links, surface_triples};
use crate::tracing::SceneTracer;
use crate::{Error, Result};
use gather::{Directional, Interactions};
use std::collections::BTreeSet;
use std::time::Instant;

/// Most surfaces a scene may have: all pairs are linked (no clustering yet),
/// and 4096 surfaces already make 8.4 million surface pairs.
pub const MAX_SURFACES: usize = 4096;

/// Settings of a solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveSettings {
    /// Kernel projection (oracle threshold, maximum level, quadrature).
    pub refine: RefineSettings,
    /// Deepest element level of three-point links (each of the three
    /// elements). Their count grows with the cube of the elements per
    /// surface, so they stop coarser than two-point links by default; the
    /// paper uses 8 for both.
    pub three_point_max_level: u32,
    /// Oracle threshold of three-point links (the paper's orthonormal
    /// normalisation). Glossy lobes concentrate light that the kernel-only
    /// oracle sees as small kernel values, so it is finer than the
    /// two-point threshold by default; the paper uses 1e-4 for both.
    pub three_point_threshold: f64,
    /// Stop when no surface's coarsest radiance changes by more than this,
    /// relative to the brightest emitted radiance.
    pub tolerance: f64,
    /// Give up after this many Gauss–Seidel sweeps.
    pub max_iterations: u32,
}

/// Receives progress of the long phases (the CLI draws bars; default: none).
pub trait Progress: Sync {
    /// A phase with `total` steps starts.
    fn start(&self, _phase: &str, _total: u64) {}
    /// `steps` more steps are done.
    fn advance(&self, _steps: u64) {}
    /// The phase is over.
    fn finish(&self) {}
}

/// Progress that reports nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;
impl Progress for Silent {}

/// A view-independent radiance solution.
pub struct Solution {
    /// The scene solved.
    pub scene: Scene,
    /// Ray queries over its surfaces (shared with rendering).
    pub tracer: SceneTracer,
    /// One element hierarchy per surface.
    pub trees: Vec<ElementTree>,
    /// Average radiance of every node of every tree, `radiance[surface][node]`
    /// (diffuse surfaces; a glossy surface's entries hold its emission).
    pub radiance: Vec<Vec<Rgb>>,
    /// The links arranged for gathering, with the directional structures of
    /// glossy surfaces (`interactions.directional`).
    pub interactions: Interactions,
    /// Average radiance L_{a→b} of every node of every directional structure.
    pub directional: Vec<Vec<Rgb>>,
    /// The refinement settings of the solve (rendering reuses them for the
    /// eye receiver).
    pub settings: SolveSettings,
    /// What it took (paper §5 quantities, times, memory).
    pub stats: Stats,
}

/// Solve `scene`: diffuse surfaces through two-point links (eq. 12), glossy
/// ones through three-point links and directional radiance (eq. 13).
pub fn solve(scene: &Scene, settings: &SolveSettings, progress: &dyn Progress) -> Result<Solution> {
    settings.validate()?;
    if scene.surfaces.is_empty() {
        return Err(Error::EmptyScene);
    }
    if scene.surfaces.len() > MAX_SURFACES {
        return Err(Error::TooManySurfaces {
            surfaces: scene.surfaces.len(),
            limit: MAX_SURFACES,
        });
    }
    let mut times = PhaseTimes::default();

    // Visibility structure.
    let clock = Instant::now();
    let tracer = SceneTracer::new(scene);
    times.visibility_build_s = clock.elapsed().as_secs_f64();

    // compute_kernel(): adaptive two-point and three-point links.
    let clock = Instant::now();
    let links = refine_links(scene, &tracer, settings.refine, progress);
    let triples = surface_triples(scene);
    let three_point = refine_three_point_links(
        scene,
        &tracer,
        settings.three_point_refine(),
        &triples,
        |q| scene.surfaces[q as usize].patch,
        progress,
    );
    times.kernels_s = clock.elapsed().as_secs_f64();

    // Element hierarchies holding every linked element, and the directional
    // structures holding every linked element pair.
    let clock = Instant::now();
    let mut ids = vec![BTreeSet::from([ElementId::ROOT]); scene.surfaces.len()];
    for l in &links {
        ids[l.p as usize].insert(l.a);
        ids[l.r as usize].insert(l.c);
    }
    for l in &three_point {
        ids[l.r as usize].insert(l.c);
    }
    let trees: Vec<ElementTree> = scene
        .surfaces
        .iter()
        .zip(&ids)
        .map(|(s, ids)| ElementTree::build(&s.patch, ids))
        .collect();
    let mut pairs: BTreeSet<(u32, u32)> = triples.iter().map(|&(_, p, q)| (p, q)).collect();
    // A glossy surface lit by nothing may still emit towards what it sees.
    pairs.extend(triples.iter().map(|&(r, p, _)| (p, r)));
    let mut directional: Vec<Directional> = pairs
        .into_iter()
        .map(|(p, q)| Directional {
            p,
            q,
            tree: PairTree::default(),
        })
        .collect();
    let index: std::collections::BTreeMap<(u32, u32), usize> = directional
        .iter()
        .enumerate()
        .map(|(i, d)| ((d.p, d.q), i))
        .collect();
    for l in &three_point {
        directional[index[&(l.p, l.q)]].tree.insert(l.a, l.b);
    }
    let interactions = Interactions::new(scene, &trees, &links, &three_point, directional);
    times.hierarchy_s = clock.elapsed().as_secs_f64();

    // compute_radiance_solution(): Gauss–Seidel gathering with push–pull.
    let clock = Instant::now();
    let mut radiance: Vec<Vec<Rgb>> = scene
        .surfaces
        .iter()
        .zip(&trees)
        .map(|(s, t)| vec![s.emission; t.nodes.len()])
        .collect();
    let mut directional: Vec<Vec<Rgb>> = interactions
        .directional
        .iter()
        .map(|d| vec![scene.surfaces[d.p as usize].emission; d.tree.nodes.len()])
        .collect();
    let mut structures_of = vec![Vec::new(); scene.surfaces.len()];
    for (i, d) in interactions.directional.iter().enumerate() {
        structures_of[d.p as usize].push(i);
    }
    let brightest = scene
        .surfaces
        .iter()
        .flat_map(|s| s.emission)
        .fold(0.0f64, f64::max);
    let scale = if brightest > 0.0 { brightest } else { 1.0 };
    let change = |new: Rgb, old: Rgb| {
        (0..3)
            .map(|ch| (new[ch] - old[ch]).abs())
            .fold(0.0, f64::max)
    };
    let (mut iterations, mut residual) = (0u32, f64::INFINITY);
    progress.start("solving", u64::from(settings.max_iterations));
    while iterations < settings.max_iterations && residual > settings.tolerance {
        residual = 0.0;
        for (p, surface) in scene.surfaces.iter().enumerate() {
            if let Some(rho) = surface.brdf.diffuse_reflectance() {
                let gathered =
                    interactions.gather(p, rho, trees[p].nodes.len(), &radiance, &directional);
                let updated = push_pull::push_pull(&trees[p], &gathered, surface.emission);
                residual = residual.max(change(updated[0], radiance[p][0]) / scale);
                radiance[p] = updated;
                continue;
            }
            for &s in &structures_of[p] {
                let gathered = interactions.gather_three_point(s, &radiance, &directional);
                let tree = &interactions.directional[s].tree;
                let updated = push_pull::push_pull(tree, &gathered, surface.emission);
                residual = residual.max(change(updated[0], directional[s][0]) / scale);
                directional[s] = updated;
            }
        }
        iterations += 1;
        progress.advance(1);
    }
    progress.finish();
    times.solve_s = clock.elapsed().as_secs_f64();

    let stats = Stats::new(
        scene,
        settings,
        &trees,
        &links,
        (&interactions.directional, three_point.len()),
        (iterations, residual),
        times,
    );
    Ok(Solution {
        scene: scene.clone(),
        tracer,
        trees,
        radiance,
        interactions,
        directional,
        settings: *settings,
        stats,
    })
}

impl SolveSettings {
    /// The refinement settings of three-point links.
    pub fn three_point_refine(&self) -> RefineSettings {
        RefineSettings {
            max_level: self.three_point_max_level,
            oracle: crate::oracle::KernelSmoothness {
                threshold: self.three_point_threshold,
            },
            ..self.refine
        }
    }

    /// Check the settings make sense.
    pub fn validate(&self) -> Result<()> {
        let r = &self.refine;
        for (name, t) in [
            ("threshold", r.oracle.threshold),
            ("three-point threshold", self.three_point_threshold),
        ] {
            if !(t >= 0.0 && t.is_finite()) {
                return Err(Error::InvalidSetting(format!(
                    "{name} must be a finite number >= 0, got {t}"
                )));
            }
        }
        for (name, level) in [
            ("max level", r.max_level),
            ("three-point max level", self.three_point_max_level),
        ] {
            if level > 16 {
                return Err(Error::InvalidSetting(format!(
                    "{name} must be at most 16, got {level}"
                )));
            }
        }
        if r.quadrature.points == 0 || r.quadrature.rays == 0 {
            return Err(Error::InvalidSetting(
                "quadrature orders must be at least 1".into(),
            ));
        }
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(Error::InvalidSetting(format!(
                "tolerance must be > 0, got {}",
                self.tolerance
            )));
        }
        Ok(())
    }
}

impl Default for SolveSettings {
    /// Defaults that render the bundled Cornell box within a few per cent of
    /// a path-traced reference (see README).
    fn default() -> Self {
        SolveSettings {
            refine: RefineSettings {
                oracle: crate::oracle::KernelSmoothness { threshold: 1e-3 },
                max_level: 5,
                quadrature: crate::kernel::Quadrature::default(),
            },
            three_point_max_level: 3,
            three_point_threshold: 1e-4,
            tolerance: 1e-5,
            max_iterations: 200,
        }
    }
}
