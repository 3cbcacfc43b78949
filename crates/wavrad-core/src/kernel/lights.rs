//! The light of the scene's [`Light`]s (point, spot, directional, the sky)
//! at a point of a surface, occlusion included: what the point-to-element
//! kernels of these lights integrate over an element
//! ([`crate::refine::light_links`]), and what a final gather evaluates per
//! point ([`crate::render::gather`]).

use crate::geometry::tracing::SceneTracer;
use crate::scene::brdf::{Brdf, BrdfModel};
use crate::scene::light::{Incident, Light};
use crate::scene::{Patch, Rgb, Scene};
use glam::{DVec2, DVec3};

/// Call `f` with the light reaching point `x` of `surface` unoccluded from
/// each of `scene`'s lights: once per delta light (its exact irradiance),
/// and once per direction of `sky` for the sky, each sample's irradiance
/// divided by their number (so the calls' irradiances sum to the point's
/// irradiance, the sky's estimated). `sky` holds points of \[0,1)², the
/// directions drawn in proportion to the cosine ([`Light::incident`]).
/// The surface itself and those in its plane never occlude.
pub fn visible_incidents(
    scene: &Scene,
    tracer: &SceneTracer,
    (surface, x): (u32, DVec3),
    sky: &[DVec2],
    f: impl FnMut(&Light, Incident),
) {
    let normal = scene.surfaces[surface as usize].patch.normal();
    let leaving = (normal, |_| false);
    visible_incidents_shaded(scene, tracer, (surface, x, normal), leaving, sky, f);
}

/// [`visible_incidents`] at a point whose shading normal is `normal`
/// ([`crate::scene::Surface::shading_normal`]): irradiance and the sky's
/// directions are taken about it, and light from below the surface's own
/// plane is left out (Mitsuba's convention for shading normals: nothing
/// reaches a surface from behind it). `leaving` is the point's geometric
/// normal, `front` (the surface's, or the exact curved shape's where `x`
/// lies on one), and the surfaces `passes` names, through which its
/// shadow rays pass (those of that shape's tessellation:
/// [`crate::render::gather::GatherPoint::on_shape`]).
pub fn visible_incidents_shaded(
    scene: &Scene,
    tracer: &SceneTracer,
    (surface, x, normal): (u32, DVec3, DVec3),
    (front, passes): (DVec3, impl Fn(u32) -> bool),
    sky: &[DVec2],
    mut f: impl FnMut(&Light, Incident),
) {
    for light in scene.lights.iter().filter(|l| !l.is_dark()) {
        let (samples, share) = match light.is_delta() {
            true => (&[DVec2::ZERO][..], 1.0),
            false => (sky, 1.0 / sky.len().max(1) as f64),
        };
        for &u in samples {
            let Some(incident) = light.incident(x, normal, u) else {
                continue;
            };
            if front.dot(incident.direction) <= 0.0 {
                continue;
            }
            if sees(tracer, (surface, &passes), x, &incident) {
                f(
                    light,
                    Incident {
                        irradiance: incident.irradiance * share,
                        ..incident
                    },
                );
            }
        }
    }
}

/// The irradiance at point `x` of `surface`, whose shading normal there is
/// `normal`, from `scene`'s lights, its shadow rays leaving as `leaving`
/// says ([`visible_incidents_shaded`]).
pub fn irradiance(
    scene: &Scene,
    tracer: &SceneTracer,
    at: (u32, DVec3, DVec3),
    leaving: (DVec3, impl Fn(u32) -> bool),
    sky: &[DVec2],
) -> Rgb {
    let mut e = Rgb::ZERO;
    visible_incidents_shaded(scene, tracer, at, leaving, sky, |_, incident| {
        e += incident.irradiance
    });
    e
}

/// Radiance L_{a→b} that `brdf` (the glossy surface `surface`'s, or some of
/// its lobes) reflects from `scene`'s lights out of element `a` towards
/// element `b` of another surface, averaged over both (Gauss–Legendre
/// points of order `points` per axis on each): the three-point kernel of
/// eq. 13 with a light instead of a source element, times the light.
pub fn reflected_towards(
    scene: &Scene,
    tracer: &SceneTracer,
    (surface, brdf): (u32, &Brdf),
    (a, b): (&Patch, &Patch),
    (points, sky): (usize, &[DVec2]),
) -> Rgb {
    let frame = scene.surfaces[surface as usize].frame();
    let targets = b.gauss_points(points);
    let mut sum = Rgb::ZERO;
    for x in a.gauss_points(points) {
        visible_incidents(scene, tracer, (surface, x.position), sky, |_, incident| {
            let wi = frame.to_local(incident.direction);
            for y in &targets {
                let wo = frame.to_local((y.position - x.position).normalize_or_zero());
                if wo.z > 0.0 {
                    let w = x.weight * y.weight;
                    sum += brdf.eval(wo, wi) * incident.irradiance * w;
                }
            }
        });
    }
    sum / (a.area() * b.area())
}

/// True when nothing but `surface`, the surfaces in its plane and those
/// that `passes` names lies between `x` and the light of `incident`.
fn sees(
    tracer: &SceneTracer,
    (surface, passes): (u32, &impl Fn(u32) -> bool),
    x: DVec3,
    incident: &Incident,
) -> bool {
    let coplanar = tracer.coplanar(surface);
    let skip = |s: u32| s == surface || coplanar.contains(&s) || passes(s);
    if incident.distance.is_finite() {
        let to = x + incident.direction * incident.distance;
        return !(tracer.occluder).occluded_except(x, to, |prim| skip(tracer.surface_of(prim)));
    }
    let (mut origin, mut t_min) = (x, 1e-7);
    loop {
        match tracer.trace(origin, incident.direction, t_min, f64::INFINITY) {
            None => return true,
            Some(hit) if skip(hit.surface) => (origin, t_min) = (hit.position, 1e-7),
            Some(_) => return false,
        }
    }
}

/// The points of a `n` × `n` grid of cell centres over \[0,1)²: the sky's
/// directions where the same ones serve every point (a kernel's quadrature,
/// whose variation over an element must not be noise).
pub fn grid(n: u32) -> Vec<DVec2> {
    let n = n.max(1);
    let step = 1.0 / f64::from(n);
    (0..n * n)
        .map(|k| DVec2::new(f64::from(k % n) + 0.5, f64::from(k / n) + 0.5) * step)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    /// A point light over the corner of the floor that the light square
    /// (surface 1) hangs over: a floor point under the square is in its
    /// shadow, one beside it is lit by I·cosθ/r²; the square's own side
    /// facing away gets nothing.
    #[test]
    fn occluders_cast_shadows_of_point_lights() {
        let mut scene: Scene = crate::testing::light_over_a_corner(0.3);
        let square = scene.surfaces[1].patch.vertices();
        let centre = square.iter().sum::<DVec3>() / square.len() as f64;
        let position = centre + DVec3::Z * 0.5;
        scene.lights.push(Light::Point {
            position,
            intensity: Rgb::splat(1.0),
        });
        let tracer = SceneTracer::new(&scene);
        let under = DVec3::new(centre.x, centre.y, 0.0);
        assert_eq!(
            irradiance(
                &scene,
                &tracer,
                (0, under, DVec3::Z),
                (DVec3::Z, |_| false),
                &[]
            ),
            Rgb::ZERO
        );
        let beside = DVec3::new(0.9, 0.9, 0.0);
        let d = position - beside;
        let expected = d.z / d.length().powi(3);
        let e = irradiance(
            &scene,
            &tracer,
            (0, beside, DVec3::Z),
            (DVec3::Z, |_| false),
            &[],
        );
        assert!((e[0] - expected).abs() < 1e-12, "{e} vs {expected}");
    }

    /// The sky over an open floor gives πL; a square above hides part of it.
    #[test]
    fn the_sky_lights_what_sees_it() {
        let mut scene = crate::testing::light_over_a_corner(0.3);
        scene.lights.push(Light::Constant {
            radiance: Rgb::splat(1.0),
        });
        let tracer = SceneTracer::new(&scene);
        let sky = grid(16);
        let far = irradiance(
            &scene,
            &tracer,
            (0, DVec3::new(0.95, 0.95, 0.0), DVec3::Z),
            (DVec3::Z, |_| false),
            &sky,
        );
        let near = irradiance(
            &scene,
            &tracer,
            (0, DVec3::new(0.1, 0.1, 0.0), DVec3::Z),
            (DVec3::Z, |_| false),
            &sky,
        );
        assert!(far[0] > near[0] && near[0] > 0.0, "{far} {near}");
        assert!(far[0] <= std::f64::consts::PI + 1e-12);
    }
}
