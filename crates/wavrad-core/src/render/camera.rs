//! Primary rays with Mitsuba 3's sensor conventions, so that the same world
//! ray lands on the same pixel as in Mitsuba.
//!
//! Camera space looks along +z with +y up and +x to the *left*; film
//! coordinates (u,v) ∈ \[0,1\]² run right and down from the top-left corner.
//! For a perspective sensor the camera-space direction is
//! `((1−2u)·tan(fov_x/2), (1−2v)·tan(fov_x/2)/aspect, 1)`.

use crate::scene::{Camera, Projection};
use glam::{DVec2, DVec3};

/// A ray with its valid parameter interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: DVec3,
    /// Unit direction.
    pub direction: DVec3,
    /// Nearest valid distance (near clip).
    pub t_min: f64,
    /// Farthest valid distance (far clip).
    pub t_max: f64,
}

impl Camera {
    /// The ray through film position `film_uv` for a film of `aspect` =
    /// width / height.
    pub fn ray(&self, film_uv: DVec2, aspect: f64) -> Ray {
        let x = 1.0 - 2.0 * film_uv.x;
        let y = (1.0 - 2.0 * film_uv.y) / aspect;
        let m = &self.world_from_camera;
        match self.projection {
            Projection::Perspective { fov_x_degrees } => {
                let tan = (0.5 * fov_x_degrees.to_radians()).tan();
                let local = DVec3::new(x * tan, y * tan, 1.0);
                let inv_len = 1.0 / local.length();
                let world = m.transform_vector3(local);
                // Clip distances are along the view axis; convert to the ray.
                let stretch = world.length() * inv_len;
                Ray {
                    origin: m.transform_point3(DVec3::ZERO),
                    direction: world.normalize(),
                    t_min: self.near_clip * stretch / (local.z * inv_len),
                    t_max: self.far_clip * stretch / (local.z * inv_len),
                }
            }
            Projection::Orthographic => {
                let axis = m.transform_vector3(DVec3::Z);
                Ray {
                    origin: m.transform_point3(DVec3::new(x, y, self.near_clip)),
                    direction: axis.normalize(),
                    t_min: 0.0,
                    t_max: (self.far_clip - self.near_clip) * axis.length(),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DMat4;

    fn camera(projection: Projection) -> Camera {
        Camera {
            world_from_camera: DMat4::IDENTITY,
            projection,
            near_clip: 0.01,
            far_clip: 100.0,
        }
    }

    #[test]
    fn film_corners_follow_mitsuba_orientation() {
        let c = camera(Projection::Perspective {
            fov_x_degrees: 90.0,
        });
        // Left edge of the film looks towards camera +x, top towards +y.
        let left = c.ray(DVec2::new(0.0, 0.5), 2.0).direction;
        assert!((left - DVec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-12);
        let top = c.ray(DVec2::new(0.5, 0.0), 2.0).direction;
        assert!((top - DVec3::new(0.0, 0.5, 1.0).normalize()).length() < 1e-12);
        let centre = c.ray(DVec2::splat(0.5), 2.0);
        assert!((centre.t_min - 0.01).abs() < 1e-12);
    }

    #[test]
    fn orthographic_rays_are_parallel() {
        let c = camera(Projection::Orthographic);
        let a = c.ray(DVec2::new(0.0, 0.0), 1.0);
        let b = c.ray(DVec2::new(1.0, 1.0), 1.0);
        assert_eq!(a.direction, b.direction);
        assert!((a.origin - DVec3::new(1.0, 1.0, 0.01)).length() < 1e-12);
        assert!((b.origin - DVec3::new(-1.0, -1.0, 0.01)).length() < 1e-12);
    }
}
