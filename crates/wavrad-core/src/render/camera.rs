//! Primary rays with Mitsuba 3's sensor conventions, so that the same world
//! ray lands on the same pixel as in Mitsuba.
//!
//! Camera space looks along +z with +y up and +x to the *left*; film
//! coordinates (u,v) ∈ \[0,1\]² run right and down from the top-left corner.
//! For a perspective sensor the camera-space direction is
//! `((1−2u)·tan(fov_x/2), (1−2v)·tan(fov_x/2)/aspect, 1)`.
//!
//! A solution is view-independent, so a view need not be the scene's own:
//!
//! ```
//! use glam::DVec3;
//! use wavrad_core::scene::{Camera, FovAxis, Projection};
//!
//! // Mitsuba's <lookat origin="0, 0, 3.9" target="0, 0, 0" up="0, 1, 0"/>.
//! let world_from_camera = Camera::look_at(DVec3::new(0.0, 0.0, 3.9), DVec3::ZERO, DVec3::Y)
//!     .expect("origin ≠ target, up not along the view");
//! let projection = Projection::Perspective { fov_x_degrees: 39.3077, fov_axis: FovAxis::X };
//! let camera = Camera { world_from_camera, projection, near_clip: 0.001, far_clip: 100.0 };
//! let wide = camera.with_fov(60.0, 1.0).expect("a perspective camera, 0 < fov < 180");
//! let centre = wide.ray(glam::DVec2::splat(0.5), 1.0);
//! assert!((centre.direction - DVec3::NEG_Z).length() < 1e-12);
//! ```

use crate::scene::{Camera, FovAxis, Projection};
use glam::{DMat4, DVec2, DVec3, DVec4};

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

impl FovAxis {
    /// The horizontal field of view of a `fov_degrees` field of view along
    /// this axis, on a film of `aspect` = width / height (Mitsuba's
    /// `parse_fov`).
    pub fn fov_x_degrees(self, fov_degrees: f64, aspect: f64) -> f64 {
        let tan_half = (0.5 * fov_degrees.to_radians()).tan();
        let tan_half_x = match self {
            FovAxis::X => tan_half,
            FovAxis::Y => tan_half * aspect,
            FovAxis::Diagonal => tan_half / (1.0 + 1.0 / (aspect * aspect)).sqrt(),
        };
        2.0 * tan_half_x.atan().to_degrees()
    }
}

impl Camera {
    /// Mitsuba's `look_at`: the `world_from_camera` of a sensor at `origin`
    /// looking towards `target`, camera +y as close to `up` as the view
    /// direction allows and +x to the left. `None` when `origin` and
    /// `target` coincide or `up` is zero or along the view direction.
    pub fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
        let dir = (target - origin).try_normalize()?;
        let left = up.cross(dir).try_normalize()?;
        let new_up = dir.cross(left);
        Some(DMat4::from_cols(
            left.extend(0.0),
            new_up.extend(0.0),
            dir.extend(0.0),
            DVec4::new(origin.x, origin.y, origin.z, 1.0),
        ))
    }

    /// This camera re-aimed by [`Camera::look_at`] with any of `origin`,
    /// `target` and `up` replaced. Unset, `origin` keeps the camera's
    /// position, `target` its view direction (a point ahead of the origin)
    /// and `up` its +y axis; an orthographic camera keeps its scale. `None`
    /// where `look_at` is.
    pub fn with_look_at(
        self,
        origin: Option<DVec3>,
        target: Option<DVec3>,
        up: Option<DVec3>,
    ) -> Option<Camera> {
        let m = &self.world_from_camera;
        let origin = origin.unwrap_or_else(|| m.transform_point3(DVec3::ZERO));
        let target = target.unwrap_or_else(|| origin + m.z_axis.truncate().normalize());
        let up = up.unwrap_or_else(|| m.y_axis.truncate().normalize());
        let mut world_from_camera = Camera::look_at(origin, target, up)?;
        if self.projection == Projection::Orthographic {
            let scale = DVec3::new(
                m.x_axis.truncate().length(),
                m.y_axis.truncate().length(),
                m.z_axis.truncate().length(),
            );
            world_from_camera *= DMat4::from_scale(scale);
        }
        Some(Camera {
            world_from_camera,
            ..self
        })
    }

    /// This camera with a perspective field of view of `fov_degrees` along
    /// the axis the scene gave its own along, on a film of `aspect` = width /
    /// height. `None` for an orthographic camera or a field of view outside
    /// (0°, 180°).
    pub fn with_fov(self, fov_degrees: f64, aspect: f64) -> Option<Camera> {
        let Projection::Perspective { fov_axis, .. } = self.projection else {
            return None;
        };
        if !(fov_degrees > 0.0 && fov_degrees < 180.0) {
            return None;
        }
        Some(Camera {
            projection: Projection::Perspective {
                fov_x_degrees: fov_axis.fov_x_degrees(fov_degrees, aspect),
                fov_axis,
            },
            ..self
        })
    }

    /// The ray through film position `film_uv` for a film of `aspect` =
    /// width / height.
    pub fn ray(&self, film_uv: DVec2, aspect: f64) -> Ray {
        let x = 1.0 - 2.0 * film_uv.x;
        let y = (1.0 - 2.0 * film_uv.y) / aspect;
        let m = &self.world_from_camera;
        match self.projection {
            Projection::Perspective { fov_x_degrees, .. } => {
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
            fov_axis: FovAxis::X,
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
    fn look_at_aims_the_centre_ray_at_the_target() {
        // The Cornell box's sensor, as Mitsuba builds it: +x left, +y up.
        let m = Camera::look_at(DVec3::new(0.0, 0.0, 3.9), DVec3::ZERO, DVec3::Y).unwrap();
        let expected = DMat4::from_cols_array_2d(&[
            [-1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0, 0.0],
            [0.0, 0.0, 3.9, 1.0],
        ]);
        assert!(m.abs_diff_eq(expected, 1e-15), "{m}");
        // Any view: the centre ray goes from origin to target, the top of the
        // film leans towards `up`, and the frame is orthonormal.
        let (origin, target) = (DVec3::new(0.3, -0.2, 2.5), DVec3::new(-0.4, 0.1, -0.5));
        let c = Camera {
            world_from_camera: Camera::look_at(origin, target, DVec3::new(0.1, 1.0, 0.0)).unwrap(),
            ..camera(Projection::Perspective {
                fov_x_degrees: 40.0,
                fov_axis: FovAxis::X,
            })
        };
        let centre = c.ray(DVec2::splat(0.5), 1.0);
        assert!((centre.origin - origin).length() < 1e-12);
        assert!((centre.direction - (target - origin).normalize()).length() < 1e-12);
        let top = c.ray(DVec2::new(0.5, 0.0), 1.0).direction;
        assert!(top.y > centre.direction.y);
        let linear = c.world_from_camera.transpose() * c.world_from_camera;
        let upper = glam::DMat3::from_mat4(linear);
        assert!(upper.abs_diff_eq(glam::DMat3::IDENTITY, 1e-12));
        // Degenerate views.
        assert_eq!(Camera::look_at(origin, origin, DVec3::Y), None);
        assert_eq!(Camera::look_at(DVec3::ZERO, DVec3::Y, DVec3::Y), None);
        assert_eq!(Camera::look_at(DVec3::ZERO, DVec3::Z, DVec3::ZERO), None);
    }

    #[test]
    fn with_look_at_keeps_what_is_not_given() {
        let origin = DVec3::new(0.0, 0.0, 3.9);
        let c = Camera {
            world_from_camera: Camera::look_at(origin, DVec3::ZERO, DVec3::Y).unwrap(),
            ..camera(Projection::Perspective {
                fov_x_degrees: 40.0,
                fov_axis: FovAxis::X,
            })
        };
        // The scene's own look_at gives the scene's own matrix, bit for bit.
        let same = c.with_look_at(Some(origin), Some(DVec3::ZERO), Some(DVec3::Y));
        assert_eq!(same, Some(c));
        assert_eq!(c.with_look_at(None, None, None), Some(c));
        // A new origin alone translates the camera (same view direction).
        let moved = c
            .with_look_at(Some(DVec3::new(0.5, 0.2, 3.0)), None, None)
            .unwrap();
        let (a, b) = (moved.world_from_camera, c.world_from_camera);
        assert!(a.x_axis.abs_diff_eq(b.x_axis, 1e-15) && a.z_axis.abs_diff_eq(b.z_axis, 1e-15));
        assert!(a.w_axis.abs_diff_eq(DVec4::new(0.5, 0.2, 3.0, 1.0), 1e-15));
        assert_eq!(c.with_look_at(None, Some(origin), None), None);
        // An orthographic camera keeps its scale (its view size).
        let ortho = Camera {
            world_from_camera: b * DMat4::from_scale(DVec3::new(2.0, 2.0, 1.0)),
            ..camera(Projection::Orthographic)
        };
        let turned = ortho.with_look_at(None, Some(DVec3::X), None).unwrap();
        assert!((turned.world_from_camera.x_axis.length() - 2.0).abs() < 1e-12);
        assert!((turned.world_from_camera.z_axis.length() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn field_of_view_keeps_its_axis() {
        // Along y on a 2:1 film: tan(fov_x/2) = 2·tan(fov_y/2).
        let fx = FovAxis::Y.fov_x_degrees(40.0, 2.0);
        assert!(((0.5 * fx.to_radians()).tan() - 2.0 * 20f64.to_radians().tan()).abs() < 1e-12);
        assert_eq!(FovAxis::X.fov_x_degrees(40.0, 2.0), 40.0);
        let d = FovAxis::Diagonal.fov_x_degrees(40.0, 2.0);
        let tan_d = (0.5 * d.to_radians()).tan() * 1.25f64.sqrt();
        assert!((tan_d - 20f64.to_radians().tan()).abs() < 1e-12);
        let c = camera(Projection::Perspective {
            fov_x_degrees: 10.0,
            fov_axis: FovAxis::Y,
        });
        let wide = c.with_fov(40.0, 2.0).unwrap();
        assert_eq!(
            wide.projection,
            Projection::Perspective {
                fov_x_degrees: fx,
                fov_axis: FovAxis::Y
            }
        );
        assert_eq!(wide.world_from_camera, c.world_from_camera);
        for bad in [0.0, 180.0, -5.0, f64::NAN] {
            assert_eq!(c.with_fov(bad, 2.0), None, "{bad}");
        }
        assert_eq!(camera(Projection::Orthographic).with_fov(40.0, 1.0), None);
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
