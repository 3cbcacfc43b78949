//! Rendering a view from a solution: a [`Renderer`] made once per solution
//! holds what every view reads (what final gathers read, the gather cache,
//! the enclosure receiver); per view it picks its [`Estimator`] once, then
//! traces camera rays ([`camera`]) and estimates radiance where they meet a
//! surface ([`estimator`]: a final gather, or the solution read and
//! [`reconstruct`]ed), filtered onto the film ([`film`]).

pub mod cache;
pub mod camera;
pub mod caustics;
pub mod discrete;
pub mod emitters;
pub mod enclosure;
pub mod estimator;
pub mod eye;
pub mod film;
pub mod gather;
pub mod glass;
pub mod link_guide;
pub mod mirror;
mod reader;
pub mod reconstruct;
pub mod settings;

use crate::geometry::analytic::SeenHit;
use crate::geometry::tracing::SurfaceHit;
use crate::progress::{Progress, Silent};
use crate::sampling::{seeded, Samples};
use crate::scene::brdf::{BrdfFlags, BrdfModel};
use crate::scene::glass::Transport::Radiance;
use crate::scene::{Camera, Film, RenderHints, Rgb, Scene};
use crate::solve::{bounces, Solution};
use crate::{Error, Result};
use cache::GatherCache;
use camera::Ray;
use caustics::CausticMap;
use enclosure::EnclosureRadiance;
use estimator::{CameraHit, Estimator, GlossyView, ViewEstimator};
use eye::EyeRadiance;
use film::{develop, Image};
use gather::{EmittersSeen, GatherPoint};
use glam::{DVec2, DVec3};
use glass::GlassTracer;
use rayon::prelude::*;
use reader::SolutionReader;
use reconstruct::{radiance_at, Reconstruction};
use std::borrow::Borrow;
use std::sync::OnceLock;

/// Camera rays per pixel in the others, whose 4×4 probe rays all meet one
/// surface, as do their neighbours': radiance varies smoothly there, and the
/// final gather, not the camera rays, resolves its shadows (on a glossy
/// surface, each camera ray takes proportionally more light and BRDF
/// samples). A quarter of an edge pixel's.
pub const INTERIOR_SHARE: u32 = 4;

/// Camera rays per pixel in the interior pixels whose light straight from
/// the emitters is uniform, relative to an interior pixel's: where the
/// probes of the pixel and of its neighbours see every emitter whole, or
/// none ([`gather::emitters_seen`]), the final gather's direct light is
/// Lambert's closed form exactly (or nothing), the rest of the solution is
/// smooth, and the camera rays only average smooth light over the pixel.
/// Such pixels gather as often as an interior pixel, and on a glossy
/// surface (not a sharp one, whose reflections have edges) take as many
/// BRDF samples in all, more per ray.
pub const QUIET_SHARE: u32 = 4;

/// Camera rays per pixel at the outline of an emitter, or of a diffuse
/// surface lit strongly enough to light others as one does, relative to an
/// edge pixel's: an emitter outshines what surrounds it a hundredfold
/// (Figure 3's lit reflector fiftyfold), so the sampling noise of its
/// coverage of a pixel dominates an image's error; the extra rays cost a
/// lookup each, because these pixels gather no more often than any other
/// edge pixel.
pub const EMITTER_EDGE_FACTOR: u32 = 16;

/// Of an edge pixel's camera rays, the share that also gathers by default.
pub const GATHER_SHARE: u32 = 32;

/// How many times as many camera rays gather on a caustic's receiver: a
/// diffuse surface that sees a sharp glossy surface mirror an emitter
/// ([`mirror::is_sharp`]). All of that light reaches it through its
/// gathers, each sample of which evaluates the glossy reflection at one
/// point, so its gathers are noisier than any other surface's (Figure 3's
/// receiver gets nothing else).
pub const CAUSTIC_GATHERS: u32 = 16;

/// Shadow rays for each gathering camera ray, `GATHER_GRID` ×
/// `GATHER_GRID`, each to an emitter drawn by power (a lone emitter gets a
/// jittered grid). Bright surfaces (glossy ones and strongly lit diffuse
/// ones) get about as many area samples in all as the gathering ray has
/// indirect rays, and at least this many each while they are few.
pub const GATHER_GRID: u32 = 2;

/// A final gather draws a square grid of samples of the bright surfaces
/// together ([`gather::GatherSources`]) with a `BRIGHT_SHARE`-th as many
/// points as it has cosine rays: combined with those by multiple importance
/// sampling, that many already take out the variance of a small bright
/// surface that cosine rays find now and then, and more cost a shadow ray
/// each for little.
pub const BRIGHT_SHARE: u32 = 4;

/// A final gather also samples the source elements of its point's links
/// ([`link_guide`]), as many as it has cosine rays, where glossy sources
/// bring at least this share of the light the links bring.
pub const GLOSSY_SHARE_LINKED: f64 = 0.3;

/// Indirect gather rays per gathering camera ray of an interior pixel; in a
/// pixel with more gathering rays, as many indirect rays in total (at least
/// 4 per gathering ray).
pub const GATHER_RAYS: u32 = 32;

/// On glossy surfaces in [`Estimator::FinalGather`], where every camera ray
/// gathers through the BRDF: `GLOSSY_GRID` × `GLOSSY_GRID` light samples
/// (each on an emitter drawn by power) and as many BRDF samples per ray. A BRDF without a Lambertian
/// lobe gets that many per ray of a pixel with all its camera rays, and
/// more in interior pixels (in proportion, the same in all); one with a
/// Lambertian lobe gathers only its other lobes per ray, that lobe's light
/// coming as a diffuse surface's, and gets that many in every pixel with
/// an interior pixel's camera rays or more, and in proportion more in one
/// with fewer ([`QUIET_SHARE`]).
pub const GLOSSY_GRID: u32 = 1;

/// How to render a view: what users choose ([`settings`] describes it); the
/// rest are the constants above.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// What a camera ray's radiance is estimated by.
    pub estimator: Estimator,
    /// Camera rays per pixel (rounded up to a square) where a pixel needs
    /// them: where it shows more than one surface (an edge, the outline of a
    /// light). Multi-jittered, an outline's coverage error falls as 1/spp.
    /// Interior pixels get a quarter, emitters' outlines sixteen times.
    pub samples_per_pixel: u32,
    /// In [`Estimator::FinalGather`], how many of the camera rays of an
    /// interior pixel also gather (the others use the smooth solution, and
    /// the gathering ones carry the correction for them: a control variate,
    /// so that the costly gather runs only for a few rays). Pixels with
    /// more camera rays gather in the same proportion: at an edge the
    /// correction jumps, and its coverage needs as many rays as the
    /// solution's.
    pub gather_samples_per_pixel: u32,
    /// Scrambles every pixel's sample sequences (Mitsuba's sampler
    /// `seed`): renders with different seeds have independent noise.
    pub seed: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            estimator: Estimator::default(),
            samples_per_pixel: 256,
            gather_samples_per_pixel: 256 / GATHER_SHARE,
            seed: 0,
        }
    }
}

impl RenderSettings {
    /// The defaults for `scene`: its sampler's `sample_count`, if larger,
    /// raises the camera rays per pixel (a Mitsuba scene asking for many
    /// samples expects a clean image; fewer than the default would only add
    /// aliasing on edges).
    pub fn for_scene(scene: &Scene) -> RenderSettings {
        RenderSettings::for_hints(&scene.hints)
    }

    /// The defaults for a sensor whose sampler asked for `hints`
    /// ([`RenderSettings::for_scene`]).
    pub fn for_hints(hints: &RenderHints) -> RenderSettings {
        let default = RenderSettings::default();
        match hints.samples_per_pixel {
            Some(n) if n > default.samples_per_pixel => default.with_samples_per_pixel(n),
            _ => default,
        }
    }

    /// Camera rays per pixel where a pixel shows one surface, as do its
    /// neighbours ([`INTERIOR_SHARE`]).
    pub fn interior_samples_per_pixel(&self) -> u32 {
        (self.samples_per_pixel / INTERIOR_SHARE).max(1)
    }

    /// Camera rays per pixel in an interior pixel whose direct light is
    /// uniform ([`QUIET_SHARE`]).
    pub fn quiet_samples_per_pixel(&self) -> u32 {
        (self.interior_samples_per_pixel() / QUIET_SHARE).max(1)
    }

    /// Camera rays per pixel at an emitter's outline ([`EMITTER_EDGE_FACTOR`]).
    pub fn emitter_edge_samples_per_pixel(&self) -> u32 {
        self.samples_per_pixel.saturating_mul(EMITTER_EDGE_FACTOR)
    }

    /// How many of a pixel's `n` camera rays gather: in proportion to `n`,
    /// as in an interior pixel, up to as many as an edge pixel's, and as
    /// many as an interior pixel's where it has fewer rays ([`QUIET_SHARE`]).
    pub(super) fn gathers_among(&self, n: usize) -> u32 {
        let interior =
            crate::sampling::pixel_offsets_len(self.interior_samples_per_pixel()) as usize;
        let n = n.clamp(
            interior,
            crate::sampling::pixel_offsets_len(self.samples_per_pixel) as usize,
        );
        let share = self.gather_samples_per_pixel as f64 / interior as f64;
        ((n as f64 * share).round() as u32).max(1)
    }

    /// The settings a diffuse surface gathers with: these, or on a caustic's
    /// receiver `caustic_gathers` times as many gathers.
    pub(super) fn on_receiver(&self, caustic: bool) -> RenderSettings {
        let factor = if caustic { CAUSTIC_GATHERS } else { 1 };
        RenderSettings {
            gather_samples_per_pixel: self.gather_samples_per_pixel.saturating_mul(factor),
            ..*self
        }
    }

    /// BRDF samples per side of the grid of a glossy point among a pixel's
    /// `n` camera rays: a pixel with fewer camera rays takes as many glossy
    /// samples in all as one with all of them.
    pub(super) fn glossy_grid_among(&self, n: usize) -> u32 {
        grid_for(self.samples_per_pixel as usize, n)
    }

    /// The same for the lobes besides a Lambertian one: as many glossy
    /// samples in all as an interior pixel's in a pixel with fewer camera
    /// rays (a quiet one, [`QUIET_SHARE`]), [`GLOSSY_GRID`] per ray in
    /// the others.
    pub(super) fn glossy_lobes_grid_among(&self, n: usize) -> u32 {
        let interior =
            crate::sampling::pixel_offsets_len(self.interior_samples_per_pixel()) as usize;
        grid_for(interior, n)
    }

    /// The same settings with `n` camera rays per pixel where an edge shows
    /// and the default share of them gathering.
    pub fn with_samples_per_pixel(self, n: u32) -> RenderSettings {
        let n = n.max(1);
        RenderSettings {
            samples_per_pixel: n,
            gather_samples_per_pixel: (n / GATHER_SHARE).max(1),
            ..self
        }
    }
}

/// [`GLOSSY_GRID`] scaled so that `n` camera rays take as many BRDF samples
/// in all as `full` rays with [`GLOSSY_GRID`] each, or that many each where
/// `n` is larger.
fn grid_for(full: usize, n: usize) -> u32 {
    let ratio = (full as f64 / n as f64).max(1.0);
    ((f64::from(GLOSSY_GRID) * ratio.sqrt()).round() as u32).max(1)
}

/// Renders views of one solution (owned, or borrowed as `&Solution` for a
/// single image). What every view reads is made once, the first time a view
/// needs it: what final gathers read from the solution, the
/// view-independent final gather ([`GatherCache`], built with the settings
/// of the first view that asks for it) and the enclosure receiver's
/// radiance ([`EnclosureRadiance`]).
pub struct Renderer<S = Solution> {
    solution: S,
    reader: OnceLock<SolutionReader>,
    gather_cache: OnceLock<GatherCache>,
    enclosure: OnceLock<EnclosureRadiance>,
    glass: OnceLock<GlassTracer>,
    caustics: OnceLock<Option<CausticMap>>,
}

impl<S: Borrow<Solution> + Sync> Renderer<S> {
    /// A renderer of `solution`; nothing is computed until a view asks.
    pub fn new(solution: S) -> Renderer<S> {
        Renderer {
            solution,
            reader: OnceLock::new(),
            gather_cache: OnceLock::new(),
            enclosure: OnceLock::new(),
            glass: OnceLock::new(),
            caustics: OnceLock::new(),
        }
    }

    /// The solution rendered.
    pub fn solution(&self) -> &Solution {
        self.solution.borrow()
    }

    /// The solution back, what was made for its views dropped.
    pub fn into_solution(self) -> S {
        self.solution
    }

    /// Render the scene's own sensor at its film size.
    pub fn render(&self, settings: &RenderSettings) -> Result<Image> {
        let scene = &self.solution().scene;
        let camera = scene.camera.as_ref().ok_or(Error::NoSensor)?;
        self.render_view(camera, &scene.film, settings, &Silent)
    }

    /// A quick image of the scene's sensor: the smooth reconstruction with 4
    /// camera rays per pixel (what a progressive solve shows after each
    /// step).
    pub fn preview(&self) -> Result<Image> {
        let smooth = Reconstruction::Smooth;
        self.render(&RenderSettings {
            estimator: Estimator::Solution {
                reconstruction: smooth,
                glossy: GlossyView::Eye(smooth),
                direct_per_point: false,
            },
            ..RenderSettings::default().with_samples_per_pixel(4)
        })
    }

    /// Render any view of the solution (it is view-independent), reporting
    /// to `progress` (the eye's links, when the view gathers into it, then
    /// the image's rows: [`develop`]).
    ///
    /// # Errors
    /// [`Error::NonFinitePixels`] when a pixel is infinite or NaN: no image
    /// is better than a wrong one; [`Error::InvalidSetting`] when the film's
    /// filter is ([`crate::scene::PixelFilter::validate`]);
    /// [`Error::Interrupted`] when `progress` asks the work to stop
    /// ([`Progress::interrupted`]).
    pub fn render_view(
        &self,
        camera: &Camera,
        film: &Film,
        settings: &RenderSettings,
        progress: &dyn Progress,
    ) -> Result<Image> {
        film.filter.validate()?;
        if bounces(&self.solution().scene).is_some()
            && matches!(
                settings.estimator,
                Estimator::Solution {
                    direct_per_point: false,
                    ..
                }
            )
        {
            progress.warn(
                "the scene's integrator limits the path length: this mode shows the solution as \
                 solved, which holds one reflection fewer than the longest path (modes gather \
                 and direct make the last one per point)",
            );
        }
        let estimator = self.estimator_for(camera, settings, progress);
        // Shot once, before the rows that read them.
        self.caustics();
        // Pixels showing one surface, as do their eight neighbours
        // (an edge slipping between a pixel's probes shows in a neighbour's),
        // get fewer camera rays; those near an emitter's outline, more.
        let quiet = matches!(
            settings.estimator,
            Estimator::FinalGather { .. }
                | Estimator::Solution {
                    direct_per_point: true,
                    ..
                }
        );
        let probes = &self.probe(camera, film, quiet);
        let samples = |px: usize, py: usize| camera_rays(probes, film, (px, py), settings);
        let seed = settings.seed;
        let (w, h) = (f64::from(film.width), f64::from(film.height));
        let scene = &self.solution().scene;
        let interfaces = GlassTracer::interfaces_allowed(scene);
        let radiance = |x: f64, y: f64, k, n| {
            // The pixel's estimates of one kind stratify their samples
            // jointly: each takes its own block of the pixel's sequences.
            let pixel = (y.floor() * w + x.floor()) as u64;
            let samples = Samples::pixel(seeded(pixel, seed), k as u32);
            let ray = camera.ray(DVec2::new(x / w, y / h), w / h);
            let tracer = &self.solution().tracer;
            let choose = |depth| samples.interface(depth);
            let chain = (ray, Radiance);
            let mut lit = Vec::new();
            let end =
                (self.glass()).follow(scene, tracer, chain, interfaces, choose, Some(&mut lit));
            (end.iter().chain(&lit))
                .map(|end| {
                    end.weight
                        * match self.camera_hit(&end.ray, samples, (k, n)) {
                            Some(hit) => estimator.radiance(self, &hit, settings),
                            None => self.background(&end.ray),
                        }
                })
                .fold(Rgb::ZERO, |sum, l| sum + l)
        };
        let mut image =
            develop(film, samples, radiance, seed, progress).ok_or(Error::Interrupted)?;
        let count = image
            .rgb
            .chunks(3)
            .filter(|px| px.iter().any(|v| !v.is_finite()))
            .count();
        if count > 0 {
            return Err(Error::NonFinitePixels {
                count,
                total: image.rgb.len() / 3,
            });
        }
        // The control variate is unbiased but, with few gathering rays in a
        // pixel, can undershoot below zero; radiance cannot, so such pixels
        // are clamped (a bias confined to those pixels, vanishing with spp).
        for v in &mut image.rgb {
            *v = v.max(0.0);
        }
        Ok(image)
    }

    /// The enclosure receiver's radiance, gathered on first use.
    pub fn enclosure(&self) -> &EnclosureRadiance {
        self.enclosure
            .get_or_init(|| EnclosureRadiance::gather(self.solution(), &Silent))
    }

    /// Radiance leaving point `y` of glossy surface `p` in the unit
    /// direction `d`, from the view-independent solution alone: its element
    /// radiance (smooth) plus the directional radiance L_{p→q} towards the
    /// surface q the direction meets, or the [`Renderer::enclosure`]'s
    /// where it meets none.
    pub fn glossy_radiance_towards(&self, p: u32, y: DVec3, d: DVec3) -> Rgb {
        let solution = self.solution();
        let patch = &solution.scene.surfaces[p as usize].patch;
        let uv = patch.clamp_param(patch.param_of(y));
        let (tree, radiance) = (&solution.trees[p as usize], &solution.radiance[p as usize]);
        let own = radiance_at(tree, radiance, uv, Reconstruction::Smooth);
        own + self.directional_towards(p, y, d, |_| false)
    }

    /// The directional part of [`Renderer::glossy_radiance_towards`]: the
    /// radiance L_{p→q} towards the surface q that `d` meets from `y`, or
    /// the enclosure's; the ray passes through the surfaces `passes` names
    /// ([`GatherPoint::on_shape`]).
    fn directional_towards(&self, p: u32, y: DVec3, d: DVec3, passes: impl Fn(u32) -> bool) -> Rgb {
        let solution = self.solution();
        match solution
            .tracer
            .trace_through(y, d, (1e-7, f64::INFINITY), passes)
        {
            Some(hit) if hit.surface != p => {
                reconstruct::directional_radiance(solution, p, y, hit.surface, hit.position)
            }
            _ => self.enclosure().radiance(&solution.scene, p, y, d),
        }
    }

    /// The scene's glass, ready for camera rays, made on first use.
    fn glass(&self) -> &GlassTracer {
        self.glass
            .get_or_init(|| GlassTracer::new(&self.solution().scene))
    }

    /// The photons of the scene's glass, shot on first use; `None`
    /// without glass.
    fn caustics(&self) -> Option<&CausticMap> {
        self.caustics
            .get_or_init(|| {
                let solution = self.solution();
                CausticMap::shoot(&solution.scene, &solution.tracer, self.glass())
            })
            .as_ref()
    }

    /// The light that glass adds to (or takes from) the light straight
    /// from the emitters at `hit`, reflected by its Lambertian lobe
    /// ([`CausticMap`]).
    fn caustic_radiance(&self, hit: &CameraHit) -> Rgb {
        let Some(caustics) = self.caustics() else {
            return Rgb::ZERO;
        };
        let scene = &self.solution().scene;
        let s = hit.point.surface as usize;
        let Some(albedo) = scene
            .lambertian_at(s, hit.uv)
            .filter(|a| a.max_channel() > 0.0)
        else {
            return Rgb::ZERO;
        };
        let normal = scene.surfaces[s].patch.normal();
        albedo * caustics.irradiance(hit.point.position, normal) / std::f64::consts::PI
    }

    /// What final gathers read from the solution, made on first use.
    fn reader(&self) -> &SolutionReader {
        self.reader
            .get_or_init(|| SolutionReader::new(self.solution()))
    }

    /// The view-independent final gather, made the first time a view asks
    /// for it, with that view's `settings` (its texels are gathered as
    /// views read them).
    fn gather_cache(&self, settings: &RenderSettings) -> &GatherCache {
        self.gather_cache
            .get_or_init(|| GatherCache::new(self.solution(), settings))
    }

    /// What the gather cache's texels are gathered from.
    fn cache_source(&self) -> cache::Source<'_> {
        cache::Source {
            solution: self.solution(),
            reader: self.reader(),
        }
    }

    /// The estimator of `settings` for the view from `camera`, with what it
    /// gathers once per view.
    fn estimator_for(
        &self,
        camera: &Camera,
        settings: &RenderSettings,
        progress: &dyn Progress,
    ) -> ViewEstimator<'_> {
        let solution = self.solution();
        let any_glossy = solution
            .scene
            .surfaces
            .iter()
            .any(|s| s.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION));
        match settings.estimator {
            Estimator::FinalGather { cached } => ViewEstimator::FinalGather {
                cache: cached.then(|| self.gather_cache(settings)),
            },
            Estimator::Solution {
                reconstruction,
                glossy: GlossyView::Eye(towards_eye),
                direct_per_point,
            } if any_glossy => ViewEstimator::Eye {
                own: (reconstruction, direct_per_point),
                eye: EyeRadiance::gather(solution, camera, progress),
                towards_eye,
            },
            // Without glossy surfaces there is nothing to gather into the
            // eye: the solution is read alone.
            Estimator::Solution {
                reconstruction,
                direct_per_point,
                ..
            } => ViewEstimator::Directional {
                own: (reconstruction, direct_per_point),
            },
        }
    }

    /// Where the camera ray `ray`, the `k`-th of the `n` of its pixel
    /// (past the glass it passed: [`GlassTracer::follow`]), meets the front
    /// of a surface (a one-sided surface is black from behind, as
    /// Mitsuba's diffuse is).
    /// Where it meets a curved shape ([`crate::geometry::tracing::SceneTracer::trace_seen`]), the
    /// solution is read on the tessellation's surface under the exact
    /// point, and the shading normal is the exact shape's; gathers and
    /// shadow rays start at the exact point where the side seen is convex
    /// ([`crate::geometry::analytic::ExactHit::convex_side`]), so that
    /// shadows and the terminator are the shape's, else at the point under
    /// it (a ray from the concave side of a cylinder would meet its
    /// tessellation at once). Its estimate draws on `samples`.
    fn camera_hit(&self, ray: &Ray, samples: Samples, (k, n): (usize, usize)) -> Option<CameraHit> {
        let solution = self.solution();
        let seen = (solution.tracer).trace_seen(ray.origin, ray.direction, ray.t_min, ray.t_max)?;
        let surfaces = &solution.scene.surfaces;
        // The surface and point where the solution is read, and the
        // exact point rays start from and its normal, on a curved shape.
        let (s, position, exact) = match seen {
            SeenHit::Surface(hit) => {
                let front = surfaces[hit.surface as usize].patch.normal();
                if front.dot(ray.direction) >= 0.0 {
                    return None;
                }
                (hit.surface, hit.position, None)
            }
            // The covering surface's front is the side seen.
            SeenHit::Exact {
                hit,
                covering,
                surfaces,
            } => {
                let (s, position) = covering?;
                (s, position, Some((hit, surfaces)))
            }
        };
        let surface = &surfaces[s as usize];
        let patch = &surface.patch;
        let uv = patch.clamp_param(patch.param_of(position));
        // Rays leave the convex side of a curved shape from its exact point.
        let (position, shape) = match exact {
            Some((hit, shape)) if hit.convex_side => (hit.position, Some(shape)),
            _ => (position, None),
        };
        Some(CameraHit {
            point: GatherPoint {
                surface: s,
                position,
                normal: exact.map_or_else(|| surface.shading_normal(uv), |(hit, _)| hit.normal),
                samples,
                shape,
            },
            uv,
            wo: -ray.direction,
            rays: (k, n),
        })
    }

    /// What a camera ray that meets the front of no surface sees: the sky
    /// where it leaves the scene, black where it meets the back of a
    /// one-sided surface or without a sky.
    fn background(&self, ray: &Ray) -> Rgb {
        let scene = &self.solution().scene;
        if scene.lights.iter().all(|l| l.is_delta()) {
            return Rgb::ZERO;
        }
        match (self.solution().tracer).trace_seen(ray.origin, ray.direction, ray.t_min, ray.t_max) {
            Some(_) => Rgb::ZERO,
            None => scene.sky_radiance(ray.direction),
        }
    }

    /// The element radiance of surface `s` at parameter `uv`, reconstructed
    /// as `reconstruction`.
    /// On a textured surface the reflected part is scaled by the texture
    /// at `uv` over its average over the leaf there (the solve's albedo),
    /// so detail finer than the elements shows.
    fn element_radiance(&self, reconstruction: Reconstruction, s: usize, uv: DVec2) -> Rgb {
        let solution = self.solution();
        let emission = solution.scene.surfaces[s].emission;
        self.element_values(reconstruction, s, uv, (&solution.radiance[s], emission))
    }

    /// As [`Renderer::element_radiance`], of `values` per node of surface
    /// `s`'s element tree, of which `emission` is not reflected light.
    fn element_values(
        &self,
        reconstruction: Reconstruction,
        s: usize,
        uv: DVec2,
        (values, emission): (&[Rgb], Rgb),
    ) -> Rgb {
        let solution = self.solution();
        let l = self.reader().lookup[s].radiance(&solution.trees[s], values, uv, reconstruction);
        match texture_factor(solution, s, uv) {
            Some(factor) => emission + (l - emission) * factor,
            None => l,
        }
    }

    /// How much of the emitters the camera ray's `hit` sees
    /// ([`gather::emitters_seen`]), where it is on an untextured surface
    /// that is not sharply glossy (elsewhere the camera rays resolve more
    /// than direct light: a texture's detail, the edges a sharp lobe
    /// reflects).
    fn emitters_seen(&self, hit: &SurfaceHit) -> Option<EmittersSeen> {
        let solution = self.solution();
        let surface = &solution.scene.surfaces[hit.surface as usize];
        if surface.brdf.is_sharp() || surface.texture.is_some() {
            return None;
        }
        let point = GatherPoint::on(
            &solution.scene,
            hit.surface,
            hit.position,
            Samples::Hashed(0),
        );
        gather::emitters_seen(
            &solution.scene,
            &solution.tracer,
            &self.reader().emitters,
            &point,
        )
    }

    /// Whether the probe ray along `dir` that meets `hit` sees an emitter
    /// mirrored there: where `hit` is on a sharply glossy surface
    /// ([`Brdf::is_sharp`](crate::scene::brdf::Brdf::is_sharp)) and the
    /// ray's mirror direction about its shading normal meets an emitter.
    /// Such a reflection is as sharp and as bright as the emitter, so its
    /// outline needs an emitter outline's camera rays, though the probes
    /// all meet the one glossy surface.
    fn mirrors_an_emitter(&self, hit: &SeenHit, dir: DVec3) -> bool {
        let solution = self.solution();
        let surface = &solution.scene.surfaces[hit.surface() as usize];
        if !surface.brdf.is_sharp() {
            return false;
        }
        let (position, normal) = match *hit {
            SeenHit::Surface(h) => {
                let param = surface.patch.param_of(h.position);
                (h.position, surface.shading_normal(param))
            }
            SeenHit::Exact { hit, .. } => (hit.position, hit.normal),
        };
        let mirror = dir - 2.0 * dir.dot(normal) * normal;
        (solution.tracer)
            .trace(position, mirror, 1e-7, f64::INFINITY)
            .is_some_and(|h| solution.scene.surfaces[h.surface as usize].is_emitter())
    }

    /// What 4×4 probe rays through each pixel of `film` meet, past any
    /// glass (a pixel that shows glass is an edge, and glaring where the
    /// glass mirrors an emitter); `glaring`
    /// per surface: emitters, and diffuse surfaces among the bright ones
    /// (the final gather's secondary sources). With `direct`, also how much
    /// of the emitters the point nearest the pixel's centre sees, where
    /// that point is on an untextured surface that is not sharply glossy.
    fn probe(&self, camera: &Camera, film: &Film, direct: bool) -> Vec<PixelProbe> {
        let solution = self.solution();
        let bright = &self.reader().bright;
        let glaring: Vec<bool> = (solution.scene.surfaces.iter().enumerate())
            .map(|(s, surface)| {
                surface.is_emitter()
                    || (!surface.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION)
                        && bright.contains(s as u32))
            })
            .collect();
        let (w, h) = (film.width as usize, film.height as usize);
        let aspect = w as f64 / h as f64;
        let (scene, glass) = (&solution.scene, self.glass());
        let interfaces = GlassTracer::interfaces_allowed(scene);
        (0..w * h)
            .into_par_iter()
            .map(|pixel| {
                let (px, py) = ((pixel % w) as f64, (pixel / w) as f64);
                let rays: Vec<_> = (0..16)
                    .map(|k| {
                        let at = DVec2::new(
                            (px + (f64::from(k % 4) + 0.5) / 4.0) / w as f64,
                            (py + (f64::from(k / 4) + 0.5) / 4.0) / h as f64,
                        );
                        // Past the glass, following its likelier branch
                        // (about a rough interface's median facet); and
                        // whether the glass mirrors an emitter.
                        let ray = camera.ray(at, aspect);
                        let tracer = &solution.tracer;
                        let end = glass.follow(
                            scene,
                            tracer,
                            (ray, Radiance),
                            interfaces,
                            |_| DVec3::splat(0.5),
                            None,
                        );
                        let through = end.is_none_or(|end| end.interfaces > 0);
                        let mirrors = through
                            && glass
                                .follow(
                                    scene,
                                    tracer,
                                    (ray, Radiance),
                                    interfaces,
                                    |_| DVec3::new(0.0, 0.5, 0.5),
                                    None,
                                )
                                .and_then(|end| {
                                    let ray = end.ray;
                                    tracer.trace(ray.origin, ray.direction, ray.t_min, ray.t_max)
                                })
                                .is_some_and(|h| scene.surfaces[h.surface as usize].is_emitter());
                        (end.map_or(ray, |end| end.ray), through, mirrors)
                    })
                    .collect();
                let through_glass = rays.iter().any(|&(_, through, _)| through);
                let glass_mirrors = rays.iter().any(|&(_, _, mirrors)| mirrors);
                let rays: Vec<Ray> = rays.into_iter().map(|(ray, _, _)| ray).collect();
                let seen: Vec<Option<SeenHit>> = (rays.iter())
                    .map(|ray| {
                        (solution.tracer).trace_seen(
                            ray.origin,
                            ray.direction,
                            ray.t_min,
                            ray.t_max,
                        )
                    })
                    .collect();
                let hits: Vec<Option<u32>> = seen.iter().map(|h| h.map(|h| h.surface())).collect();
                let mirrored: Vec<bool> = (seen.iter().zip(&rays))
                    .map(|(hit, ray)| {
                        hit.is_some_and(|hit| self.mirrors_an_emitter(&hit, ray.direction))
                    })
                    .collect();
                // What glass shows is as sharp as its refraction bends it.
                let one = !through_glass
                    && (hits.iter().zip(&mirrored)).all(|p| p == (&hits[0], &mirrored[0]));
                PixelProbe {
                    surface: if one { hits[0] } else { None },
                    glaring: hits.iter().any(|s| s.is_some_and(|s| glaring[s as usize]))
                        || mirrored.iter().any(|&m| m)
                        || glass_mirrors,
                    emitters: match seen[10] {
                        Some(SeenHit::Surface(hit)) if direct => self.emitters_seen(&hit),
                        _ => None,
                    },
                }
            })
            .collect()
    }
}

/// What the probe rays through a pixel meet.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PixelProbe {
    /// The surface all of them meet, if they meet one and all or none of
    /// them see an emitter mirrored there.
    surface: Option<u32>,
    /// Some meet an emitter or a strongly lit diffuse surface, or see an
    /// emitter mirrored in a sharply glossy one.
    glaring: bool,
    /// How much of the emitters the point nearest the centre sees, where
    /// it is on an untextured surface, not a sharply glossy one, and that is known
    /// ([`gather::emitters_seen`]).
    emitters: Option<EmittersSeen>,
}

/// Camera rays for pixel `(px, py)` of `film`, from what the `probes` of it
/// and its eight neighbours meet: few where all of them show one surface,
/// many at an edge, most at an emitter's outline.
fn camera_rays(
    probes: &[PixelProbe],
    film: &Film,
    (px, py): (usize, usize),
    settings: &RenderSettings,
) -> u32 {
    let (w, h) = (film.width as usize, film.height as usize);
    let centre = probes[py * w + px].surface;
    let neighbours = (py.saturating_sub(1)..(py + 2).min(h))
        .flat_map(|qy| (px.saturating_sub(1)..(px + 2).min(w)).map(move |qx| &probes[qy * w + qx]));
    // An edge pixel is at an emitter's outline when it or a neighbour sees
    // the emitter: the outline may run along a pixel boundary, between the
    // probes of the pixels on either side.
    let lit = probes[py * w + px].emitters;
    let mut uniform = centre.is_some();
    let mut quiet = matches!(lit, Some(EmittersSeen::Whole | EmittersSeen::Nothing));
    let mut emitter_edge = false;
    for p in neighbours {
        uniform &= p.surface == centre;
        quiet &= p.emitters == lit;
        emitter_edge |= p.glaring;
    }
    if uniform && quiet {
        settings.quiet_samples_per_pixel()
    } else if uniform {
        settings.interior_samples_per_pixel()
    } else if emitter_edge {
        settings.emitter_edge_samples_per_pixel()
    } else {
        settings.samples_per_pixel
    }
}

/// On a textured surface `s`, the texture's albedo at `uv` over its
/// average over the leaf element there (the albedo the solve gave that
/// leaf), per channel: what scales the leaf's reflected light at `uv`, so
/// detail finer than the elements shows. `None` on an untextured surface.
pub(super) fn texture_factor(solution: &Solution, s: usize, uv: DVec2) -> Option<Rgb> {
    let scales = solution.interactions.texture_of(s)?;
    let (scene, surface) = (&solution.scene, &solution.scene.surfaces[s]);
    let (rho, here) = (surface.brdf.lambertian()?, scene.lambertian_at(s, uv)?);
    let leaf = scales[solution.trees[s].locate(uv).0 as usize];
    Some(Rgb([0, 1, 2].map(|c| {
        let average = leaf[c] * rho[c];
        if average > 0.0 {
            here[c] / average
        } else {
            0.0
        }
    })))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_emitter_outline_on_a_pixel_boundary_gets_the_most_rays() {
        // A 3×3 film whose top row shows an emitter (surface 1) and the rest
        // a wall (surface 0): the outline runs between rows, so every probe
        // of a pixel meets one surface, yet both rows are at the outline.
        let film = Film {
            width: 3,
            height: 3,
            filter: crate::scene::PixelFilter::Box,
        };
        let probe = |surface: u32| PixelProbe {
            surface: Some(surface),
            glaring: surface == 1,
            emitters: None,
        };
        let probes: Vec<PixelProbe> = (0..9).map(|i| probe(u32::from(i < 3))).collect();
        let settings = RenderSettings::default();
        let rays = |px, py| camera_rays(&probes, &film, (px, py), &settings);
        for px in 0..3 {
            assert_eq!(rays(px, 0), settings.emitter_edge_samples_per_pixel());
            assert_eq!(rays(px, 1), settings.emitter_edge_samples_per_pixel());
            assert_eq!(rays(px, 2), settings.interior_samples_per_pixel());
        }
        // The same outline between two walls is an ordinary edge.
        let walls: Vec<PixelProbe> = (0..9)
            .map(|i| PixelProbe {
                glaring: false,
                ..probe(u32::from(i < 3))
            })
            .collect();
        assert_eq!(
            camera_rays(&walls, &film, (1, 1), &settings),
            settings.samples_per_pixel
        );
    }

    #[test]
    fn interior_pixels_whose_direct_light_is_uniform_get_fewest_rays() {
        // A 3×3 film of one wall that sees the emitters whole, but for the
        // bottom row's probes, which see them in part or not at all.
        let film = Film {
            width: 3,
            height: 3,
            filter: crate::scene::PixelFilter::Box,
        };
        let probes: Vec<PixelProbe> = (0..9)
            .map(|i| PixelProbe {
                surface: Some(0),
                glaring: false,
                emitters: Some(match i {
                    6 => EmittersSeen::Part,
                    7 | 8 => EmittersSeen::Nothing,
                    _ => EmittersSeen::Whole,
                }),
            })
            .collect();
        let settings = RenderSettings::default();
        let rays = |px, py| camera_rays(&probes, &film, (px, py), &settings);
        assert_eq!(rays(2, 0), settings.quiet_samples_per_pixel());
        assert!(settings.quiet_samples_per_pixel() < settings.interior_samples_per_pixel());
        // Beside a differently lit neighbour, or not known: interior.
        assert_eq!(rays(1, 1), settings.interior_samples_per_pixel());
        assert_eq!(rays(2, 2), settings.interior_samples_per_pixel());
        let unknown: Vec<PixelProbe> = (probes.iter())
            .map(|p| PixelProbe {
                emitters: None,
                ..*p
            })
            .collect();
        let rays = |px, py| camera_rays(&unknown, &film, (px, py), &settings);
        assert_eq!(rays(2, 0), settings.interior_samples_per_pixel());
        // They gather as often as an interior pixel.
        assert_eq!(
            settings.gathers_among(settings.quiet_samples_per_pixel() as usize),
            settings.gather_samples_per_pixel
        );
    }

    /// A broad glossy lobe's pixels may be quiet (they take the interior
    /// pixels' BRDF samples in all, more per ray); a sharp lobe's may not,
    /// as the edges it reflects need camera rays.
    #[test]
    fn a_broad_glossy_surface_is_probed_for_its_emitters_and_a_sharp_one_is_not() {
        let probed = |brdf: crate::scene::brdf::Brdf| {
            let mut scene = crate::testing::mirror_floor_and_light();
            scene.surfaces[0].brdf = brdf;
            scene.film = Film {
                width: 8,
                height: 8,
                filter: crate::scene::PixelFilter::Box,
            };
            let camera = camera_at(DVec3::new(0.45, 0.1, 0.5), DVec3::new(0.45, 0.5, 0.0));
            let solution =
                crate::solve::solve(&scene, &Default::default(), &crate::progress::Silent).unwrap();
            let probes = Renderer::new(&solution).probe(&camera, &scene.film, true);
            let on_floor = probes.iter().filter(|p| p.surface == Some(0)).count();
            let known = probes.iter().filter(|p| p.emitters.is_some()).count();
            (on_floor, known)
        };
        let sharp = crate::testing::rolled_aluminium();
        assert!(sharp.is_sharp());
        let broad = crate::scene::brdf::Brdf::Ward(crate::scene::brdf::ward::Ward {
            alpha_u: 0.3,
            alpha_v: 0.3,
            ..crate::scene::brdf::ward::Ward::default()
        });
        assert!(!broad.is_sharp());
        let (on_floor, known) = probed(broad);
        assert!(on_floor > 32 && known >= on_floor, "{known} of {on_floor}");
        assert_eq!(probed(sharp).1, 0);
        // A quiet pixel's glossy lobes take an interior pixel's samples in
        // all; an interior or edge pixel, GLOSSY_GRID² per ray.
        let settings = RenderSettings::default();
        let samples = |n: u32| n * settings.glossy_lobes_grid_among(n as usize).pow(2);
        let interior = settings.interior_samples_per_pixel();
        assert_eq!(
            samples(settings.quiet_samples_per_pixel()),
            samples(interior)
        );
        assert_eq!(
            settings.glossy_lobes_grid_among(interior as usize),
            GLOSSY_GRID
        );
        let edge = settings.samples_per_pixel as usize;
        assert_eq!(settings.glossy_lobes_grid_among(edge), GLOSSY_GRID);
    }

    /// A near-mirror floor under a square light, seen from under the light
    /// looking down at the light's mirror image: the probes see only the
    /// floor, but the pixels at the image's outline get an emitter
    /// outline's camera rays; the same floor made diffuse has no such
    /// pixels.
    #[test]
    fn an_emitter_mirrored_in_a_sharp_surface_has_an_outline() {
        let outline = |sharp: bool| {
            let mut scene = crate::testing::mirror_floor_and_light();
            if !sharp {
                scene.surfaces[0].brdf = crate::scene::brdf::Brdf::diffuse(Rgb::splat(0.5));
            }
            scene.film = Film {
                width: 16,
                height: 16,
                filter: crate::scene::PixelFilter::Box,
            };
            let camera = camera_at(DVec3::new(0.45, 0.1, 0.5), DVec3::new(0.45, 0.5, -1.0));
            let solution =
                crate::solve::solve(&scene, &Default::default(), &crate::progress::Silent).unwrap();
            let probes = Renderer::new(&solution).probe(&camera, &scene.film, false);
            let settings = RenderSettings::default();
            let rays: Vec<u32> = (0..16 * 16)
                .map(|p| camera_rays(&probes, &scene.film, (p % 16, p / 16), &settings))
                .collect();
            let edge = settings.emitter_edge_samples_per_pixel();
            let split = probes.iter().filter(|p| p.surface.is_none()).count();
            (rays.iter().filter(|&&r| r == edge).count(), split)
        };
        let (mirrored, split) = outline(true);
        assert!(
            mirrored > 16 && split > 8,
            "{mirrored} outline pixels, {split} split"
        );
        assert_eq!(outline(false), (0, 0));
    }

    /// A lit floor seen from above on a `side`² film, solved.
    fn lit_floor_from_above(side: u32) -> Solution {
        let mut scene = crate::testing::light_over_a_corner(0.5);
        scene.film = Film {
            width: side,
            height: side,
            filter: crate::scene::PixelFilter::Box,
        };
        scene.camera = Some(camera_at(
            DVec3::new(0.5, 0.5, 2.0),
            DVec3::new(0.5, 0.5, 0.0),
        ));
        crate::solve::solve(&scene, &Default::default(), &crate::progress::Silent).unwrap()
    }

    /// A pinhole camera at `origin` looking at `target`, 30° wide.
    fn camera_at(origin: DVec3, target: DVec3) -> Camera {
        Camera {
            world_from_camera: Camera::look_at(origin, target, DVec3::Y).unwrap(),
            projection: crate::scene::Projection::Perspective {
                fov_x_degrees: 30.0,
                fov_axis: crate::scene::FovAxis::X,
            },
            near_clip: 1e-3,
            far_clip: 100.0,
        }
    }

    #[test]
    fn an_image_with_pixels_that_are_not_finite_is_an_error() {
        // A lit floor seen from above, solved, then its radiance spoilt.
        let mut solution = lit_floor_from_above(4);
        let smooth = RenderSettings {
            estimator: Estimator::Solution {
                reconstruction: Reconstruction::Smooth,
                glossy: GlossyView::Eye(Reconstruction::Smooth),
                direct_per_point: false,
            },
            ..RenderSettings::default().with_samples_per_pixel(4)
        };
        assert!(Renderer::new(&solution).render(&smooth).is_ok());
        solution.radiance[0].fill(Rgb::splat(f64::INFINITY));
        let error = Renderer::new(&solution).render(&smooth).err();
        assert_eq!(
            error,
            Some(Error::NonFinitePixels {
                count: 16,
                total: 16
            })
        );
    }

    #[test]
    fn renders_with_different_seeds_differ_only_by_their_noise() {
        let solution = lit_floor_from_above(8);
        let renderer = Renderer::new(&solution);
        for cached in [false, true] {
            let render = |seed| {
                let settings = RenderSettings {
                    estimator: Estimator::FinalGather { cached },
                    seed,
                    ..RenderSettings::default().with_samples_per_pixel(4)
                };
                renderer.render(&settings).unwrap().rgb
            };
            let (a, again, b) = (render(0), render(0), render(7));
            assert_eq!(a, again, "cached {cached}");
            assert_ne!(a, b, "cached {cached}");
            let mean = |v: &[f32]| v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len() as f64;
            let (ma, mb) = (mean(&a), mean(&b));
            assert!(
                (ma - mb).abs() < 0.05 * ma,
                "cached {cached}: {ma} against {mb}"
            );
        }
    }

    #[test]
    fn scene_sample_count_only_raises_the_camera_rays() {
        let mut scene = Scene::from_surfaces(Vec::new());
        let default = RenderSettings::default();
        scene.hints.samples_per_pixel = Some(64);
        assert_eq!(RenderSettings::for_scene(&scene), default);
        scene.hints.samples_per_pixel = Some(4096);
        let s = RenderSettings::for_scene(&scene);
        assert_eq!(
            (
                s.samples_per_pixel,
                s.interior_samples_per_pixel(),
                s.gather_samples_per_pixel
            ),
            (4096, 1024, 128)
        );
        assert_eq!(s.estimator, default.estimator);
    }
}
