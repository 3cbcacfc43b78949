//! Rendering a view from a solution: camera rays ([`camera`]), radiance
//! reconstruction on the surface hit ([`reconstruct`]), filtered onto the
//! film ([`film`]).

pub mod camera;
pub mod film;
pub mod reconstruct;

use crate::scene::{Camera, Film};
use crate::solve::Solution;
use crate::{Error, Result};
use film::{develop, Image};
use glam::DVec2;
use reconstruct::{radiance_at, Reconstruction};

/// How to render a view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// Reconstruction of radiance on surfaces.
    pub mode: Reconstruction,
    /// Camera rays per pixel (rounded up to a square).
    pub samples_per_pixel: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            mode: Reconstruction::default(),
            samples_per_pixel: 16,
        }
    }
}

impl Solution {
    /// Render the scene's own sensor at its film size.
    pub fn render(&self, settings: &RenderSettings) -> Result<Image> {
        let camera = self.scene.camera.as_ref().ok_or(Error::NoSensor)?;
        Ok(self.render_view(camera, &self.scene.film, settings))
    }

    /// Render any view of the solution (it is view-independent).
    pub fn render_view(&self, camera: &Camera, film: &Film, settings: &RenderSettings) -> Image {
        let (w, h) = (film.width as f64, film.height as f64);
        let aspect = w / h;
        develop(film, settings.samples_per_pixel, |x, y| {
            let ray = camera.ray(DVec2::new(x / w, y / h), aspect);
            let Some(hit) = self.tracer.trace(ray.origin, ray.direction, ray.t_min, ray.t_max) else {
                return [0.0; 3];
            };
            let s = hit.surface as usize;
            let patch = &self.scene.surfaces[s].patch;
            // One-sided surfaces are black from behind (Mitsuba's diffuse).
            if patch.normal().dot(ray.direction) >= 0.0 {
                return [0.0; 3];
            }
            let uv = patch.clamp_param(patch.param_of(hit.position));
            radiance_at(&self.trees[s], &self.radiance[s], uv, settings.mode)
        })
    }
}
