//! Importance for one view (Smits, Arvo & Salesin 1992): how much the
//! radiance of each part of the scene contributes to the image, the adjoint
//! of radiance. The importance-driven oracle weighs a link's error by its
//! receiver's importance, so links whose receivers the sensor never sees,
//! directly or after a few bounces, stay coarse.
//!
//! Importance is kept as a density over a fixed grid of elements (level
//! [`Importance::LEVEL`]) on every surface. Direct importance is the share
//! of primary rays landing in an element, per unit area. It spreads through
//! the two-point links like radiance in the reverse direction: a receiver a
//! of radiance from c makes c important by `ρ_a · F(c,a) · i_a`, since
//! `L_a += ρ_a · F(a,c) · L_c` and `|a| F(a,c) = |c| F(c,a)`. A glossy
//! surface passes importance on as a diffuse one of its normal-incidence
//! albedo, and glossy–glossy pairs (which have no two-point links) pass
//! none: importance only steers refinement, and this keeps it a few cheap
//! sweeps over the links.

use crate::geometry::hierarchy::ElementId;
use crate::kernel::KernelContext;
use crate::refine::two_point_projection::Link;
use crate::sampling::hash2;
use crate::scene::brdf::{BrdfFlags, BrdfModel};
use crate::scene::{Camera, Film, Rgb, Surface};
use glam::{DVec2, DVec3};

/// Importance density per element of a fixed grid on every surface,
/// relative to its area-weighted mean over the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Importance {
    /// `cells[surface][path]` at level [`Importance::LEVEL`].
    cells: Vec<Vec<f64>>,
}

impl Importance {
    /// Level of the grid importance is kept on (256 elements per surface).
    pub const LEVEL: u32 = 4;
    /// Primary rays per film axis.
    const RAYS: usize = 96;
    /// Sweeps of importance through the links (bounces).
    const BOUNCES: usize = 3;

    /// The importance of `scene` for `camera` on `film`: direct importance
    /// spread through `links` (empty before any link exists).
    pub fn new(ctx: &KernelContext, camera: &Camera, film: &Film, links: &[Link]) -> Importance {
        let scene = ctx.scene;
        let cells_per_surface = 4usize.pow(Self::LEVEL);
        let cell_area = |s: usize| scene.surfaces[s].patch.area() / cells_per_surface as f64;
        let mut direct = vec![vec![0.0; cells_per_surface]; scene.surfaces.len()];
        let aspect = f64::from(film.width) / f64::from(film.height);
        let n = Self::RAYS;
        for j in 0..n {
            for i in 0..n {
                let uv = DVec2::new((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let ray = camera.ray(uv, aspect);
                if let Some(hit) = ctx
                    .tracer
                    .trace(ray.origin, ray.direction, ray.t_min, ray.t_max)
                {
                    let s = hit.surface as usize;
                    let patch = &scene.surfaces[s].patch;
                    let cell = ElementId::path_to(patch, patch.param_of(hit.position), Self::LEVEL)
                        [Self::LEVEL as usize];
                    direct[s][cell.path as usize] += 1.0 / ((n * n) as f64 * cell_area(s));
                }
            }
        }
        let reflectance: Vec<f64> = scene.surfaces.iter().map(albedo).collect();
        let mut cells = direct.clone();
        for _ in 0..Self::BOUNCES {
            let mut next = direct.clone();
            for l in links {
                for (a_s, a, c_s, c) in [(l.p, l.a, l.r, l.c), (l.r, l.c, l.p, l.a)] {
                    let (a_s, c_s) = (a_s as usize, c_s as usize);
                    let area_c = scene.surfaces[c_s].patch.area() * 0.25f64.powi(c.level as i32);
                    let add = reflectance[a_s] * l.throughput / area_c * average(&cells[a_s], a);
                    spread(&mut next[c_s], c, add);
                }
            }
            cells = next;
        }
        let total_area: f64 = scene.surfaces.iter().map(|s| s.patch.area()).sum();
        let mean = (0..cells.len())
            .map(|s| cell_area(s) * cells[s].iter().sum::<f64>())
            .sum::<f64>()
            / total_area;
        if mean > 0.0 {
            cells.iter_mut().flatten().for_each(|x| *x /= mean);
        }
        Importance { cells }
    }

    /// Relative importance density of element `id` of `surface` (its
    /// average over the element); 1 for surfaces outside the scene
    /// (hypothetical receivers such as the eye are what the view sees).
    pub fn at(&self, surface: u32, id: ElementId) -> f64 {
        self.cells
            .get(surface as usize)
            .map_or(1.0, |cells| average(cells, id))
    }
}

/// Normal-incidence albedo (largest channel) of a surface's BRDF, by
/// stratified importance sampling.
fn albedo(surface: &Surface) -> f64 {
    let glossy = surface.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION);
    if let Some(rho) = surface.brdf.lambertian().filter(|_| !glossy) {
        return rho.max_channel();
    }
    let n = 32u32;
    let mut sum = Rgb::ZERO;
    for j in 0..n {
        for i in 0..n {
            let u = DVec2::new(
                (f64::from(i) + 0.5) / f64::from(n),
                (f64::from(j) + 0.5) / f64::from(n),
            );
            let lobe = hash2(0x1a2b, u64::from(j * n + i)).x;
            if let Some(s) = surface.brdf.sample(DVec3::Z, u, lobe) {
                sum += s.weight;
            }
        }
    }
    sum.max_channel() / f64::from(n * n)
}

/// Range of grid cells inside `id`, or the one cell containing it.
fn cell_range(id: ElementId) -> (usize, usize) {
    let level = Importance::LEVEL;
    if id.level >= level {
        let cell = (id.path >> (2 * (id.level - level))) as usize;
        (cell, cell + 1)
    } else {
        let span = 4usize.pow(level - id.level);
        let first = id.path as usize * span;
        (first, first + span)
    }
}

/// Average of the cells over element `id`.
fn average(cells: &[f64], id: ElementId) -> f64 {
    let (start, end) = cell_range(id);
    cells[start..end].iter().sum::<f64>() / (end - start) as f64
}

/// Add a density `value` over element `id` to the cells' averages.
fn spread(cells: &mut [f64], id: ElementId, value: f64) {
    let (start, end) = cell_range(id);
    // An element finer than a cell covers that share of it.
    let share = 0.25f64.powi(id.level.saturating_sub(Importance::LEVEL) as i32);
    cells[start..end]
        .iter_mut()
        .for_each(|x| *x += share * value);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::tracing::SceneTracer;
    use crate::kernel::default_context;
    use crate::progress::Silent;
    use crate::refine::two_point_projection::{refine_links, root_pairs, RefineSettings};
    use crate::scene::{FovAxis, Projection, Scene};
    use crate::testing::{grey, inward_box};

    /// A unit box seen from just under its ceiling, looking straight down
    /// at the floor through a narrow field of view.
    fn box_seen_from_above() -> Scene {
        let mut scene = Scene::from_surfaces(
            inward_box(DVec3::ZERO, DVec3::ONE)
                .into_iter()
                .map(grey)
                .collect(),
        );
        let world_from_camera = Camera::look_at(
            DVec3::new(0.5, 0.5, 0.95),
            DVec3::new(0.5, 0.5, 0.0),
            DVec3::Y,
        )
        .expect("a valid view");
        scene.camera = Some(Camera {
            world_from_camera,
            projection: Projection::Perspective {
                fov_x_degrees: 30.0,
                fov_axis: FovAxis::X,
            },
            near_clip: 1e-3,
            far_clip: 10.0,
        });
        scene
    }

    #[test]
    fn importance_starts_where_the_sensor_looks_and_spreads_through_links() {
        let scene = box_seen_from_above();
        let tracer = SceneTracer::new(&scene);
        let ctx = default_context(&scene, &tracer);
        let camera = scene.camera.as_ref().expect("set above");
        let whole = |imp: &Importance, s: u32| imp.at(s, ElementId::ROOT);
        let direct = Importance::new(&ctx, camera, &scene.film, &[]);
        // Only the floor (surface 0) is seen: 6× the mean over six equal faces.
        assert!(
            (whole(&direct, 0) - 6.0).abs() < 1e-9,
            "{}",
            whole(&direct, 0)
        );
        assert!((1..6).all(|s| whole(&direct, s) == 0.0));
        // Its centre, where the view looks, matters; its corners do not.
        let centre = ElementId::ROOT.child(0).child(3);
        assert!(
            direct.at(0, centre) > 6.0 && direct.at(0, ElementId::ROOT.child(0).child(0)) == 0.0
        );
        // Through the links, what lights the floor matters too: the ceiling
        // most, being the floor's largest form factor.
        let settings = RefineSettings {
            threshold: 1e-2,
            max_level: 3,
        };
        let links = refine_links(&ctx, settings, None, &root_pairs(&ctx), &Silent);
        let spread = Importance::new(&ctx, camera, &scene.film, &links);
        let ceiling = whole(&spread, 1);
        assert!(
            ceiling > 0.0 && (2..6).all(|s| whole(&spread, s) > 0.0 && whole(&spread, s) < ceiling)
        );
        assert!(whole(&spread, 0) > ceiling);
        // Outside the scene (the eye), importance is 1.
        assert_eq!(spread.at(6, ElementId::ROOT), 1.0);
    }
}
