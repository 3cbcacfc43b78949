//! Rendering a view from a solution: camera rays ([`camera`]), radiance
//! reconstruction on the surface hit ([`reconstruct`]), filtered onto the
//! film ([`film`]).

pub mod camera;
pub mod eye;
pub mod film;
pub mod gather;
pub mod reconstruct;
pub mod sampling;

use crate::hierarchy::ElementId;
use crate::scene::{Camera, Film, Rgb, Scene};
use crate::solve::Solution;
use crate::{Error, Result};
use film::{develop, Image};
use gather::GatherPoint;
use glam::{DVec2, DVec3};
use rayon::prelude::*;
use reconstruct::{radiance_at, Reconstruction, SmoothLookup};

/// How to render a view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// Reconstruction of radiance on surfaces.
    pub mode: Reconstruction,
    /// Camera rays per pixel (rounded up to a square).
    pub samples_per_pixel: u32,
    /// In [`Reconstruction::Gather`], how many of the camera rays of a pixel
    /// also gather (the others use the smooth solution, and the gathering
    /// ones carry the correction for them: a control variate, so that edges
    /// get many camera rays and the costly gather only a few).
    pub gather_samples_per_pixel: u32,
    /// Shadow rays per emitter, and area samples per glossy surface, for
    /// each gathering camera ray: a `gather_grid` × `gather_grid` jittered
    /// grid.
    pub gather_grid: u32,
    /// Indirect gather rays per gathering camera ray.
    pub gather_rays: u32,
    /// On glossy surfaces in [`Reconstruction::Gather`], where every camera
    /// ray gathers: `glossy_grid` × `glossy_grid` light samples per emitter
    /// and as many BRDF samples per ray.
    pub glossy_grid: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            mode: Reconstruction::default(),
            samples_per_pixel: 512,
            gather_samples_per_pixel: 128,
            gather_grid: 2,
            gather_rays: 4,
            glossy_grid: 1,
        }
    }
}

impl RenderSettings {
    /// The defaults for `scene`: its sampler's `sample_count`, if larger,
    /// raises the camera rays per pixel (a Mitsuba scene asking for many
    /// samples expects a clean image; fewer than the default would only add
    /// aliasing on edges).
    pub fn for_scene(scene: &Scene) -> RenderSettings {
        let default = RenderSettings::default();
        match scene.hints.samples_per_pixel {
            Some(n) if n > default.samples_per_pixel => default.with_samples_per_pixel(n),
            _ => default,
        }
    }

    /// The same settings with `n` camera rays per pixel, a quarter of which
    /// gather (the default proportion).
    pub fn with_samples_per_pixel(self, n: u32) -> RenderSettings {
        let n = n.max(1);
        RenderSettings {
            samples_per_pixel: n,
            gather_samples_per_pixel: (n / 4).max(1),
            ..self
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
        let emitters: Vec<u32> = (0..self.scene.surfaces.len() as u32)
            .filter(|&s| self.scene.surfaces[s as usize].is_emitter())
            .collect();
        // Glossy surfaces outside the gather mode show their radiance towards
        // this view, gathered once into the eye.
        let glossy: Vec<u32> = (0..self.scene.surfaces.len() as u32)
            .filter(|&s| !self.scene.surfaces[s as usize].is_diffuse())
            .collect();
        let eye = (!glossy.is_empty() && settings.mode != Reconstruction::Gather)
            .then(|| self.eye_radiance(camera, &crate::solve::Silent));
        let bright = self.secondary_sources(&glossy);
        let smooth: Vec<SmoothLookup> = self.trees.par_iter().map(SmoothLookup::new).collect();
        // Every `stride`-th camera ray gathers, weighted by `stride`.
        let total = sampling::pixel_offsets_len(settings.samples_per_pixel);
        let stride = (total / settings.gather_samples_per_pixel.clamp(1, total)).max(1) as usize;
        let mut image = develop(film, settings.samples_per_pixel, |x, y, k| {
            let ray = camera.ray(DVec2::new(x / w, y / h), aspect);
            let Some(hit) = self
                .tracer
                .trace(ray.origin, ray.direction, ray.t_min, ray.t_max)
            else {
                return [0.0; 3];
            };
            let s = hit.surface as usize;
            let surface = &self.scene.surfaces[s];
            let patch = &surface.patch;
            // One-sided surfaces are black from behind (Mitsuba's diffuse).
            if patch.normal().dot(ray.direction) >= 0.0 {
                return [0.0; 3];
            }
            let uv = patch.clamp_param(patch.param_of(hit.position));
            let point = GatherPoint {
                surface: hit.surface,
                position: hit.position,
                normal: patch.normal(),
                seed: (x.to_bits() ^ y.to_bits().rotate_left(32)).wrapping_add(k as u64),
            };
            let outgoing =
                |q: u32, y: DVec3| self.outgoing_radiance(&smooth, q, y, hit.surface, hit.position);
            if !surface.is_diffuse() {
                if let Some(eye) = &eye {
                    let mode = match settings.mode {
                        Reconstruction::Smooth => Reconstruction::Smooth,
                        _ => Reconstruction::Haar,
                    };
                    return eye.surfaces[s]
                        .as_ref()
                        .map_or([0.0; 3], |(tree, l)| radiance_at(tree, l, uv, mode));
                }
                // Every camera ray gathers through the BRDF.
                return gather::glossy_radiance(
                    &self.scene,
                    &self.tracer,
                    &emitters,
                    &point,
                    -ray.direction,
                    settings.glossy_grid,
                    outgoing,
                );
            }
            let reconstructed = match settings.mode {
                Reconstruction::Haar => {
                    radiance_at(&self.trees[s], &self.radiance[s], uv, settings.mode)
                }
                _ => smooth[s].radiance(&self.trees[s], &self.radiance[s], uv),
            };
            if settings.mode != Reconstruction::Gather || k % stride != 0 {
                return reconstructed;
            }
            let point = GatherPoint {
                seed: (x.to_bits() ^ y.to_bits().rotate_left(32)).wrapping_add(1),
                ..point
            };
            let indirect = gather::indirect_radiance(
                &self.scene,
                &self.tracer,
                &point,
                (settings.gather_rays, &bright, settings.gather_grid),
                |q, y| {
                    let source = &self.scene.surfaces[q as usize];
                    let l = if source.is_diffuse() {
                        outgoing(q, y)
                    } else {
                        // The glossy bounce before this diffuse point is
                        // evaluated per point: emitters reflected exactly
                        // (a highlight's sharp edge on a wall is finer than
                        // the pair tree's elements), the rest from the
                        // solution.
                        let at = GatherPoint {
                            surface: q,
                            position: y,
                            normal: source.patch.normal(),
                            seed: point.seed.rotate_left(17) ^ u64::from(q),
                        };
                        gather::glossy_radiance(
                            &self.scene,
                            &self.tracer,
                            &emitters,
                            &at,
                            (hit.position - y).normalize(),
                            settings.glossy_grid,
                            |h, z| self.outgoing_radiance(&smooth, h, z, q, y),
                        )
                    };
                    let e = source.emission;
                    [0, 1, 2].map(|ch| (l[ch] - e[ch]).max(0.0))
                },
            );
            let direct = gather::direct_radiance(
                &self.scene,
                &self.tracer,
                &emitters,
                &point,
                settings.gather_grid,
            );
            let gathered = [0, 1, 2].map(|ch| surface.emission[ch] + direct[ch] + indirect[ch]);
            [0, 1, 2]
                .map(|ch| reconstructed[ch] + stride as f64 * (gathered[ch] - reconstructed[ch]))
        });
        // The control variate is unbiased but, with few gathering rays in a
        // pixel, can undershoot below zero; radiance cannot, so such pixels
        // are clamped (a bias confined to those pixels, vanishing with spp).
        for v in &mut image.rgb {
            *v = v.max(0.0);
        }
        image
    }

    /// The surfaces a diffuse point's final gather samples by area besides
    /// its cosine rays: every glossy one (its reflected light is
    /// concentrated in its lobes) and every diffuse non-emitter whose
    /// average radiance is over four times the area-weighted mean of all
    /// non-emitters (a small, strongly lit surface that lights the others:
    /// cosine rays rarely find it).
    fn secondary_sources(&self, glossy: &[u32]) -> Vec<u32> {
        let lum = |l: Rgb| (l[0] + l[1] + l[2]) / 3.0;
        let lit: Vec<(u32, f64, f64)> = (0..self.scene.surfaces.len() as u32)
            .filter(|&s| {
                let surface = &self.scene.surfaces[s as usize];
                surface.is_diffuse() && !surface.is_emitter()
            })
            .map(|s| {
                let area = self.scene.surfaces[s as usize].patch.area();
                (s, lum(self.radiance[s as usize][0]), area)
            })
            .collect();
        let total_area: f64 = lit.iter().map(|l| l.2).sum();
        let mean = lit.iter().map(|l| l.1 * l.2).sum::<f64>() / total_area.max(f64::MIN_POSITIVE);
        let mut out = glossy.to_vec();
        out.extend(lit.iter().filter(|l| l.1 > 4.0 * mean).map(|l| l.0));
        out.sort_unstable();
        out
    }

    /// Radiance the solution says leaves point `y` of surface `q` towards
    /// point `x` of surface `s`: the smooth reconstruction (`smooth`, one
    /// lookup per tree) for a diffuse `q`;
    /// for a glossy one the directional radiance L_{q→s} of the element pairs
    /// (a ∋ y, b), smooth over the receiver's elements b around `x` (the
    /// gather integrates over y already, so only x needs the smoothing).
    fn outgoing_radiance(
        &self,
        smooth: &[SmoothLookup],
        q: u32,
        y: DVec3,
        s: u32,
        x: DVec3,
    ) -> Rgb {
        let surface = &self.scene.surfaces[q as usize];
        let uv_y = surface.patch.clamp_param(surface.patch.param_of(y));
        if surface.is_diffuse() {
            let q = q as usize;
            return smooth[q].radiance(&self.trees[q], &self.radiance[q], uv_y);
        }
        let Some(&index) = self.interactions.structure_of.get(&(q, s)) else {
            return surface.emission;
        };
        let receiver = &self.scene.surfaces[s as usize].patch;
        let uv_x = receiver.param_of(x);
        let depth = self.settings.three_point_max_level;
        let path_y = ElementId::path_to(&surface.patch, uv_y, depth);
        let tree = &self.interactions.directional[index as usize].tree;
        let values = &self.directional[index as usize];
        let leaf_towards = |uv: DVec2| {
            let path_x = ElementId::path_to(receiver, receiver.clamp_param(uv), depth);
            tree.leaf_at(|l| path_y[l as usize], |l| path_x[l as usize]) as usize
        };
        let level = tree.nodes[leaf_towards(uv_x)].b.level;
        let mut out = [0.0; 3];
        for (centre, w) in reconstruct::hat_stencil(uv_x, level) {
            let l = values[leaf_towards(centre)];
            (0..3).for_each(|ch| out[ch] += w * l[ch]);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_sample_count_only_raises_the_camera_rays() {
        let mut scene = Scene::from_surfaces(Vec::new());
        let default = RenderSettings::default();
        scene.hints.samples_per_pixel = Some(64);
        assert_eq!(RenderSettings::for_scene(&scene), default);
        scene.hints.samples_per_pixel = Some(4096);
        let s = RenderSettings::for_scene(&scene);
        assert_eq!(
            (s.samples_per_pixel, s.gather_samples_per_pixel),
            (4096, 1024)
        );
        assert_eq!(s.mode, default.mode);
    }
}
