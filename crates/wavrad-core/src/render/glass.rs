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
use glam::DVec3;

/// Most glass interfaces a camera ray passes before it is given up (as
/// black: light trapped by total internal reflection); the scene's
/// integrator may allow fewer ([`GlassTracer::interfaces_allowed`]).
pub const MAX_INTERFACES: u32 = 16;

/// Ray queries against the scene's glass faces.
#[derive(Debug)]
pub struct GlassTracer {
    occluder: Occluder,
    /// For each triangle of `occluder`: its glass shape and face.
    faces: Vec<(u32, u32)>,
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
    /// The triangle met, which the ray leaving it skips.
    pub triangle: u32,
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
        for (g, glass) in scene.glass.iter().enumerate() {
            for (f, (patch, _)) in glass.faces.iter().enumerate() {
                for triangle in patch.triangles() {
                    triangles.push(triangle);
                    faces.push((g as u32, f as u32));
                }
            }
        }
        GlassTracer {
            occluder: Occluder::new(&triangles),
            faces,
        }
    }

    /// How far a ray leaving a glass face starts from it: clear of that
    /// face, and of its neighbours where it leaves near an edge.
    pub fn clearance(&self) -> f64 {
        self.occluder.contact_distance()
    }

    /// True when the scene has no glass.
    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
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

    /// The first glass face along `ray` (other than triangle `skip`), with
    /// its interface and shading normal there.
    pub fn hit(&self, scene: &Scene, ray: &Ray, skip: Option<u32>) -> Option<GlassHit> {
        let hit = self.occluder.intersect_except(
            ray.origin,
            ray.direction,
            ray.t_min,
            ray.t_max,
            |t| Some(t) == skip,
        )?;
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
    /// `choose(k)` falls below the Fresnel reflectance and refracted
    /// otherwise ([`Dielectric::scatter`]). `None` when the chain passes
    /// more than `limit` interfaces.
    pub fn follow(
        &self,
        scene: &Scene,
        tracer: &SceneTracer,
        (ray, transport): (Ray, Transport),
        limit: u32,
        mut choose: impl FnMut(u32) -> f64,
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
            let (direction, weight) =
                (glass.interface).scatter(ray.direction, glass.normal, u, transport);
            end = ChainEnd {
                ray: Ray {
                    origin: glass.position,
                    direction,
                    t_min: self.clearance(),
                    t_max: f64::INFINITY,
                },
                weight: end.weight * weight,
                interfaces: end.interfaces + 1,
            };
            skip = Some(glass.triangle);
        }
    }
}
