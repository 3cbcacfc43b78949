//! Camera rays through glass ([`crate::scene::glass`]): a camera ray that
//! meets a glass face before any surface is reflected or refracted there,
//! choosing one with the Fresnel reflectance's probability as Mitsuba 3's
//! path tracer does, and followed along that specular chain until it meets
//! a surface of the solution, where the radiance is estimated as for any
//! camera ray, or leaves the scene. The solve does not see glass: light
//! reaches what lies behind or under it as if it were not there, and the
//! photons of [`super::caustics`] make up the difference on diffuse
//! surfaces.

use crate::geometry::tracing::SceneTracer;
use crate::geometry::visibility::Occluder;
use crate::render::camera::Ray;
use crate::scene::glass::{Dielectric, Transport};
use crate::scene::{Rgb, Scene};
use glam::{DVec2, DVec3};

/// Most glass interfaces a camera ray passes before it is given up (as
/// black: light trapped by total internal reflection); the scene's
/// integrator may allow fewer ([`GlassTracer::interfaces_allowed`]).
pub const MAX_INTERFACES: u32 = 16;

/// Ray queries against the scene's glass: its faces, and its exact
/// spheres in place of theirs.
#[derive(Debug)]
pub struct GlassTracer {
    occluder: Occluder,
    /// For each triangle of `occluder`: its glass shape and face.
    faces: Vec<(u32, u32)>,
    /// The exact spheres: glass shape, centre, radius.
    spheres: Vec<(u32, DVec3, f64)>,
    /// [`GlassTracer::clearance`].
    clearance: f64,
}

/// Where a ray meets glass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlassHit {
    /// Distance along the (unit) ray direction.
    pub distance: f64,
    /// The point met.
    pub position: DVec3,
    /// The unit shading normal there, towards the exterior.
    pub normal: DVec3,
    /// The interface met.
    pub interface: Dielectric,
    /// The triangle met, which the ray leaving it skips ([`NO_TRIANGLE`]
    /// on an exact sphere, which the ray leaving it clears by starting
    /// [`GlassTracer::clearance`] away).
    pub triangle: u32,
}

/// [`GlassHit::triangle`] of a hit on an exact sphere.
pub const NO_TRIANGLE: u32 = u32::MAX;

/// The nearest distance t ∈ (`ray.t_min`, `t_max`) at which `ray` meets
/// the sphere (`centre`, `radius`).
fn sphere_hit(ray: &Ray, (centre, radius): (DVec3, f64), t_max: f64) -> Option<f64> {
    let to = ray.origin - centre;
    let b = to.dot(ray.direction);
    let c = to.length_squared() - radius * radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    // The root farther from 0 without cancellation, then the other.
    let q = -(b + b.signum() * disc.sqrt());
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q, c / q) };
    let (near, far) = (t0.min(t1), t0.max(t1));
    [near, far]
        .into_iter()
        .find(|&t| t > ray.t_min && t < t_max)
}

/// The end of a camera ray's specular chain through glass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChainEnd {
    /// The last segment, from the last interface (or the camera).
    pub ray: Ray,
    /// The product of the interfaces' weights along the chain.
    pub weight: Rgb,
    /// How many interfaces the chain passed.
    pub interfaces: u32,
}

impl GlassTracer {
    /// The glass faces of `scene`, ready for ray queries.
    pub fn new(scene: &Scene) -> GlassTracer {
        let mut triangles = Vec::new();
        let mut faces = Vec::new();
        let mut spheres = Vec::new();
        for (g, glass) in scene.glass.iter().enumerate() {
            if let Some((centre, radius)) = glass.sphere {
                spheres.push((g as u32, centre, radius));
                continue;
            }
            for (f, (patch, _)) in glass.faces.iter().enumerate() {
                for triangle in patch.triangles() {
                    triangles.push(triangle);
                    faces.push((g as u32, f as u32));
                }
            }
        }
        let occluder = Occluder::new(&triangles);
        // The faces' contact distance, or as much of the spheres' size.
        let size = (spheres.iter())
            .map(|&(_, centre, radius)| centre.abs().max_element() + radius)
            .fold(0.0, f64::max);
        GlassTracer {
            clearance: occluder.contact_distance().max(1e-7 * size),
            occluder,
            faces,
            spheres,
        }
    }

    /// How far a ray leaving a glass face starts from it: clear of that
    /// face, and of its neighbours where it leaves near an edge.
    pub fn clearance(&self) -> f64 {
        self.clearance
    }

    /// True when the scene has no glass.
    pub fn is_empty(&self) -> bool {
        self.faces.is_empty() && self.spheres.is_empty()
    }

    /// How many interfaces a camera ray may pass in `scene`: at most
    /// [`MAX_INTERFACES`], and one fewer than the integrator's longest
    /// path, so that the surface at the chain's end is within it.
    pub fn interfaces_allowed(scene: &Scene) -> u32 {
        scene
            .hints
            .max_depth
            .map_or(MAX_INTERFACES, |d| d.saturating_sub(1).min(MAX_INTERFACES))
    }

    /// The first glass along `ray` (other than triangle `skip`), with its
    /// interface and shading normal there.
    pub fn hit(&self, scene: &Scene, ray: &Ray, skip: Option<u32>) -> Option<GlassHit> {
        let face =
            self.occluder
                .intersect_except(ray.origin, ray.direction, ray.t_min, ray.t_max, |t| {
                    Some(t) == skip
                });
        let t_max = face.map_or(ray.t_max, |f| f.t);
        let sphere = (self.spheres.iter())
            .filter_map(|&(g, centre, radius)| {
                let t = sphere_hit(ray, (centre, radius), t_max)?;
                Some((t, g, centre))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0));
        if let Some((t, g, centre)) = sphere {
            let position = ray.origin + t * ray.direction;
            return Some(GlassHit {
                distance: t,
                position,
                normal: (position - centre).normalize(),
                interface: scene.glass[g as usize].interface,
                triangle: NO_TRIANGLE,
            });
        }
        let hit = face?;
        let (g, f) = self.faces[hit.primitive as usize];
        let glass = &scene.glass[g as usize];
        let (patch, shading) = &glass.faces[f as usize];
        let position = ray.origin + hit.t * ray.direction;
        let param = patch.param_of(position);
        let normal = shading
            .and_then(|n| n.at(param))
            .unwrap_or_else(|| patch.normal());
        Some(GlassHit {
            distance: hit.t,
            position,
            normal,
            interface: glass.interface,
            triangle: hit.primitive,
        })
    }

    /// Follow `ray`, carrying `transport` (a camera ray's radiance, a
    /// photon's power), through the glass it meets before any surface of
    /// `tracer`: at the `k`-th interface (0 the first) it is reflected when
    /// `choose(k).x` falls below the Fresnel reflectance and refracted
    /// otherwise, about the microfacet normal `choose(k).yz` draws on a
    /// rough interface ([`Dielectric::scatter`]). `None` when the chain
    /// passes more than `limit` interfaces, or ends in `emitters`.
    ///
    /// With `emitters`, a way on from an interface that meets an emitter
    /// before anything else is not left to the choice: it is split off
    /// into `emitters`, weighted by its probability, and the chain goes on
    /// the other way, weighted by its own (both ways, if both meet one).
    /// A lamp mirrored in a glass object is a highlight as bright as the
    /// lamp that the chosen reflection (a few percent of the camera rays)
    /// would find only now and then; split off, every camera ray there
    /// sees it.
    pub fn follow(
        &self,
        scene: &Scene,
        tracer: &SceneTracer,
        (ray, transport): (Ray, Transport),
        limit: u32,
        mut choose: impl FnMut(u32) -> DVec3,
        mut emitters: Option<&mut Vec<ChainEnd>>,
    ) -> Option<ChainEnd> {
        let mut end = ChainEnd {
            ray,
            weight: Rgb::splat(1.0),
            interfaces: 0,
        };
        if self.is_empty() {
            return Some(end);
        }
        let mut skip = None;
        loop {
            let ray = end.ray;
            let Some(glass) = self.hit(scene, &ray, skip) else {
                return Some(end);
            };
            let before = (ray.t_min, glass.distance);
            if (tracer)
                .trace_seen(ray.origin, ray.direction, before.0, before.1)
                .is_some()
            {
                return Some(end);
            }
            if end.interfaces == limit {
                return None;
            }
            let u = choose(end.interfaces);
            let (dir, interface) = (ray.direction, glass.interface);
            let m = interface.facet(dir, glass.normal, DVec2::new(u.y, u.z));
            let onwards = |direction| Ray {
                origin: glass.position,
                direction,
                t_min: self.clearance(),
                t_max: f64::INFINITY,
            };
            let next = |(direction, weight)| ChainEnd {
                ray: onwards(direction),
                weight: end.weight * weight,
                interfaces: end.interfaces + 1,
            };
            let (mut split, mut unlit) = (false, None);
            if let Some(lit) = emitters.as_deref_mut() {
                for branch in (interface.branches(dir, (glass.normal, m), transport)).map(next) {
                    if self.meets_emitter(scene, tracer, &branch.ray, glass.triangle) {
                        lit.push(branch);
                        split = true;
                    } else {
                        unlit = Some(branch);
                    }
                }
            }
            end = if split {
                unlit?
            } else {
                next(interface.scatter_at(dir, (glass.normal, m), u.x, transport))
            };
            skip = Some(glass.triangle);
        }
    }

    /// Whether `ray`, leaving glass triangle `skip`, meets an emitter
    /// before any other surface or glass.
    fn meets_emitter(&self, scene: &Scene, tracer: &SceneTracer, ray: &Ray, skip: u32) -> bool {
        let glass = self.hit(scene, ray, Some(skip));
        let t_max = glass.map_or(ray.t_max, |g| g.distance);
        (tracer.trace(ray.origin, ray.direction, ray.t_min, t_max))
            .is_some_and(|hit| scene.surfaces[hit.surface as usize].is_emitter())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(origin: DVec3, direction: DVec3, t_min: f64) -> Ray {
        Ray {
            origin,
            direction,
            t_min,
            t_max: f64::INFINITY,
        }
    }

    #[test]
    fn a_ray_meets_a_sphere_at_its_nearest_root_past_its_start() {
        let sphere = (DVec3::new(0.0, 0.0, 1.0), 0.5);
        let down = -DVec3::Z;
        // From outside: the near side; from its surface, inwards: the far
        // side, the start's own root (≈ 0) left behind by t_min.
        let outside = ray(DVec3::new(0.0, 0.0, 5.0), down, 0.0);
        assert_eq!(sphere_hit(&outside, sphere, f64::INFINITY), Some(3.5));
        let inside = ray(DVec3::new(0.0, 0.0, 1.5), down, 1e-9);
        assert!((sphere_hit(&inside, sphere, f64::INFINITY).unwrap() - 1.0).abs() < 1e-12);
        // Beyond t_max, beside it, and away from it: none.
        assert_eq!(sphere_hit(&outside, sphere, 3.0), None);
        let beside = ray(DVec3::new(0.6, 0.0, 5.0), down, 0.0);
        assert_eq!(sphere_hit(&beside, sphere, f64::INFINITY), None);
        let away = ray(DVec3::new(0.0, 0.0, 5.0), DVec3::Z, 0.0);
        assert_eq!(sphere_hit(&away, sphere, f64::INFINITY), None);
    }
}
