//! Links from the lights that are not surfaces (point, spot and directional
//! lights, the sky: [`crate::scene::Light`]) to the elements of every
//! surface with a Lambertian lobe.
//!
//! A light's kernel into an element is its irradiance averaged over the
//! element, E_a = (1/|a|) ∫_a Σ_lights E(x) V(x) dA (for a point light
//! E = I(ω)·cosθ/r², [`crate::kernel::lights`]): the element's Haar scaling
//! coefficient up to the factor 2^J, and the element reflects ρ·E_a/π. As
//! for area emitters' links ([`crate::refine::emitter_links`]), each
//! surface's link starts whole and is carried down to the children wherever
//! the light varies over them by more than [`EMITTER_LINK_VARIATION`] of its
//! mean: shadow edges, a spot's falloff, the 1/r² near a light.

use crate::geometry::hierarchy::ElementId;
use crate::kernel::lights::{grid, irradiance};
use crate::kernel::KernelContext;
use crate::progress::Progress;
use crate::refine::emitter_links::EMITTER_LINK_VARIATION;
use crate::refine::oracle::average_detail;
use crate::refine::project_each;
use crate::scene::{Light, Patch, Rgb};

/// The light of the scene's [`crate::scene::Scene::lights`] reaching one
/// element.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LightLink {
    /// The receiving surface.
    pub surface: u32,
    /// The receiving element.
    pub element: ElementId,
    /// Irradiance averaged over the element (whole, buried parts counting
    /// as dark).
    pub irradiance: Rgb,
}

/// Directions per axis of the grid over which a light link's quadrature
/// integrates the sky, the same at every point.
pub const SKY_GRID: u32 = 8;

/// Level down to which every light link is carried whatever its
/// variation: at level 0 a surface's few quadrature points can all miss a
/// spot's cone, or a shadow, entirely.
pub const MIN_LIGHT_LEVEL: u32 = 2;

/// The light links of every surface with a Lambertian lobe, carried down
/// its element tree as far as its deepest level under `max_level`
/// ([`KernelContext::deepest_level`]; to [`MIN_LIGHT_LEVEL`] at least, within
/// it) wherever their irradiance varies over the children by more than
/// [`EMITTER_LINK_VARIATION`] of its mean, and to the element holding a
/// spot's axis while the beam is narrower than the element. Elements that
/// no light reaches get none. Empty without lights.
pub fn link_lights(ctx: &KernelContext, max_level: u32, progress: &dyn Progress) -> Vec<LightLink> {
    let scene = ctx.scene;
    if scene.lights.iter().all(Light::is_dark) {
        return Vec::new();
    }
    let sky = grid(SKY_GRID);
    let receivers: Vec<u32> = (0..scene.surfaces.len() as u32)
        .filter(|&s| scene.surfaces[s as usize].brdf.lambertian().is_some())
        .collect();
    let points = ctx.quadrature.points.max(1);
    let mean = |surface: u32, patch: &Patch| -> Rgb {
        let mut sum = Rgb::ZERO;
        // The solve is on the patches: their own normal, not the shading one.
        let normal = patch.normal();
        for sample in patch.gauss_points(points) {
            let e = irradiance(
                scene,
                ctx.tracer,
                (surface, sample.position, normal),
                (normal, |_| false),
                &sky,
            );
            sum += e * sample.weight;
        }
        sum / patch.area()
    };
    let per_surface = project_each("light links", &receivers, progress, |&surface, refine| {
        let root = scene.surfaces[surface as usize].patch;
        let mut out = Vec::new();
        let deepest = ctx.deepest_level(surface, max_level);
        let mut stack = vec![(ElementId::ROOT, root, mean(surface, &root))];
        while let Some((element, patch, e)) = stack.pop() {
            let link = LightLink {
                surface,
                element,
                irradiance: e,
            };
            if !refine || element.level >= deepest {
                out.extend((e.max_channel() > 0.0).then_some(link));
                continue;
            }
            let children = patch.subdivide();
            let e_k = children.map(|c| mean(surface, &c));
            let means = e_k.map(|e| e.average());
            let mean = means.iter().sum::<f64>() / 4.0;
            let even = average_detail(means) <= EMITTER_LINK_VARIATION * mean;
            let coarse =
                element.level < MIN_LIGHT_LEVEL || holds_a_narrow_beam(&scene.lights, &patch);
            if even && !coarse {
                out.extend((e.max_channel() > 0.0).then_some(link));
                continue;
            }
            // Children in reverse so the links come out in tree order.
            for k in (0..4).rev() {
                stack.push((element.child(k), children[k], e_k[k]));
            }
        }
        out
    });
    per_surface.into_links()
}

/// True when a spot's axis meets `patch`, and its beam there is narrower
/// than the patch: the quadrature points of its children could all miss
/// the cone.
fn holds_a_narrow_beam(lights: &[Light], patch: &Patch) -> bool {
    let normal = patch.normal();
    let origin = patch.vertices()[0];
    let size = patch.area().sqrt();
    lights.iter().any(|light| {
        let Light::Spot {
            position,
            axis,
            cutoff,
            ..
        } = *light
        else {
            return false;
        };
        let along = axis.dot(normal);
        if along >= 0.0 {
            return false; // the axis does not reach the front
        }
        let t = (origin - position).dot(normal) / along;
        let hit = position + axis * t;
        t > 0.0 && t * cutoff.tan() < size && patch.contains_param(patch.param_of(hit))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::tracing::SceneTracer;
    use crate::kernel::default_context as context;
    use crate::progress::Silent;
    use glam::DVec3;

    /// A point light over the floor of `light_over_a_corner` (the square
    /// light made dark, an occluder): its links tile the floor, down to the
    /// deepest level where the shadow and the 1/r² change the light, and add
    /// up to the irradiance integrated on a fine grid.
    #[test]
    fn light_links_tile_the_floor_and_resolve_the_shadow() {
        let mut scene = crate::testing::light_over_a_corner(0.3);
        scene.surfaces[1].emission = Rgb::ZERO;
        let position = DVec3::new(0.1, 0.1, 0.8);
        scene.lights.push(Light::Point {
            position,
            intensity: Rgb::splat(1.0),
        });
        let tracer = SceneTracer::new(&scene);
        let ctx = context(&scene, &tracer);
        let links = link_lights(&ctx, 5, &Silent);
        let floor: Vec<&LightLink> = links.iter().filter(|l| l.surface == 0).collect();
        let deepest = floor.iter().map(|l| l.element.level).max().unwrap();
        let shallowest = floor.iter().map(|l| l.element.level).min().unwrap();
        assert_eq!(deepest, 5, "{floor:?}");
        assert!(shallowest >= MIN_LIGHT_LEVEL, "{floor:?}");
        // The square's back (surface 1 faces down, away from the light) gets none.
        assert!(links.iter().all(|l| l.surface == 0));
        // Power into the floor: Σ E_a·|a| against a 200² midpoint sum.
        let root = scene.surfaces[0].patch;
        let total: f64 = floor
            .iter()
            .map(|l| l.irradiance[0] * l.element.patch(&root).area())
            .sum();
        let n = 200;
        let reference: f64 = crate::testing::unit_square_midpoints(n)
            .map(|x| {
                irradiance(
                    &scene,
                    &tracer,
                    (0, x, DVec3::Z),
                    (DVec3::Z, |_| false),
                    &[],
                )[0]
            })
            .sum::<f64>()
            / (n * n) as f64;
        assert!(
            (total - reference).abs() < 0.01 * reference,
            "{total} vs {reference}"
        );
    }

    #[test]
    fn a_narrow_spot_is_found_on_a_large_floor() {
        let mut scene = crate::testing::light_over_a_corner(0.3);
        scene.surfaces[1].emission = Rgb::ZERO;
        scene.lights.push(Light::Spot {
            position: DVec3::new(0.7, 0.7, 1.0),
            axis: -DVec3::Z,
            intensity: Rgb::splat(1.0),
            cutoff: 2f64.to_radians(),
            beam_width: 1f64.to_radians(),
        });
        let tracer = SceneTracer::new(&scene);
        let ctx = context(&scene, &tracer);
        let links = link_lights(&ctx, 6, &Silent);
        let root = scene.surfaces[0].patch;
        let total: f64 = links
            .iter()
            .map(|l| l.irradiance[0] * l.element.patch(&root).area())
            .sum();
        // The beam's flux: ∫ I·falloff dω over the cone, about I·π·θ² for
        // small angles (θ between beam width and cutoff, here ≈ 1.56°).
        let flux = std::f64::consts::PI * (1.56f64.to_radians()).powi(2);
        assert!(
            total > 0.7 * flux && total < 1.3 * flux,
            "{total} vs {flux}"
        );
    }
}
