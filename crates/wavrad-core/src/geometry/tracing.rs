//! The scene as triangles for ray queries: every surface becomes one or two
//! triangles in the [`Occluder`], and each primitive remembers its surface.

use crate::geometry::visibility::{Hit, Occluder};
use crate::scene::{Patch, Scene};
use glam::DVec3;

/// Ray-tracing view of a scene's surfaces.
#[derive(Debug)]
pub struct SceneTracer {
    /// Acceleration structure over all surfaces' triangles.
    pub occluder: Occluder,
    prim_surface: Vec<u32>,
}

/// A ray hitting a surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceHit {
    /// Index of the surface hit.
    pub surface: u32,
    /// Hit point.
    pub position: DVec3,
    /// Distance along the (unit) ray direction.
    pub distance: f64,
}

impl SceneTracer {
    /// Triangulate the scene's surfaces and build the acceleration structure.
    pub fn new(scene: &Scene) -> Self {
        let mut triangles = Vec::with_capacity(2 * scene.surfaces.len());
        let mut prim_surface = Vec::with_capacity(2 * scene.surfaces.len());
        for (i, s) in scene.surfaces.iter().enumerate() {
            match s.patch {
                Patch::Parallelogram {
                    origin,
                    edge_s,
                    edge_t,
                } => {
                    let far = origin + edge_s + edge_t;
                    triangles.push([origin, origin + edge_s, far]);
                    triangles.push([origin, far, origin + edge_t]);
                    prim_surface.extend([i as u32, i as u32]);
                }
                Patch::Triangle(v) => {
                    triangles.push(v);
                    prim_surface.push(i as u32);
                }
            }
        }
        SceneTracer {
            occluder: Occluder::new(&triangles),
            prim_surface,
        }
    }

    /// Surface that primitive `prim` belongs to.
    pub fn surface_of(&self, prim: u32) -> u32 {
        self.prim_surface[prim as usize]
    }

    /// Closest surface along `origin + t·dir` (dir unit length), t ∈ (tmin, tmax).
    pub fn trace(&self, origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> Option<SurfaceHit> {
        self.occluder
            .intersect(origin, dir, tmin, tmax)
            .map(|Hit { t, primitive, .. }| SurfaceHit {
                surface: self.surface_of(primitive),
                position: origin + t * dir,
                distance: t,
            })
    }
}
