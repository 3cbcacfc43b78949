//! What a camera ray's radiance is estimated by ([`Estimator`]), chosen once
//! per view, and the user-facing names of the choices ([`Mode`]).
//!
//! Two things are estimated: the final gather at the visible point (direct
//! light evaluated exactly, the rest of the solution gathered; per camera
//! ray or from the view-independent [`super::cache::GatherCache`]), or the
//! solution itself read along the view ray, which the Haar projection
//! stores per element and which is shown piecewise constant or smooth
//! ([`Reconstruction`]). Only the second has a reconstruction to choose
//! (the final gather's control variate is the smooth solution), and only
//! the second needs glossy surfaces' radiance towards the eye
//! ([`GlossyView`]); the final gather evaluates their BRDF per ray.

use super::cache::GatherCache;
use super::eye::EyeRadiance;
use super::gather::{self, GatherPoint};
use super::reader::{GatherBudget, SurfacePoint};
use super::reconstruct::{radiance_at, Reconstruction};
use super::{RenderSettings, Renderer, GATHER_GRID, GATHER_RAYS, GLOSSY_GRID};
use crate::scene::brdf::{BrdfFlags, BrdfModel};
use crate::scene::Rgb;
use crate::setting::Choice;
use crate::solve::Solution;
use crate::{Error, Result};
use glam::{DVec2, DVec3};
use std::borrow::Borrow;

/// What a camera ray's radiance is estimated by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Estimator {
    /// Final gather over the solution at each visible point (the most
    /// accurate): light straight from the emitters evaluated exactly, the
    /// rest of the solution gathered ([`crate::render::gather`]); on glossy
    /// surfaces light and BRDF sampling over the solution per camera ray.
    /// With `cached`, diffuse surfaces (and the Lambertian lobes of glossy
    /// ones) read the light beyond the emitters' from the solution's
    /// view-independent final gather wherever it varies slowly
    /// ([`crate::render::cache::GatherCache`]: one gather per texel, made
    /// the first time a view reads it, then read by every view), and
    /// gather per camera ray only nearer other geometry.
    FinalGather {
        /// Read diffuse light from the gather cache.
        cached: bool,
    },
    /// The solution read along the view ray, no gathering: element radiance
    /// reconstructed as `reconstruction`, and on glossy surfaces their
    /// radiance towards the eye from `glossy`.
    Solution {
        /// How element radiance is reconstructed.
        reconstruction: Reconstruction,
        /// Where glossy surfaces' radiance towards the eye comes from.
        glossy: GlossyView,
        /// Whether diffuse surfaces (and glossy ones' Lambertian lobes) show
        /// the light straight from the emitters evaluated per camera ray
        /// (one shadow ray each, as in the final gather: shadows as sharp as
        /// the pixels) on top of the rest of the solution, reconstructed as
        /// `reconstruction`, instead of the solution's own first bounce,
        /// which its elements average.
        direct_per_point: bool,
    },
}

impl Default for Estimator {
    fn default() -> Self {
        Estimator::FinalGather { cached: true }
    }
}

/// Where glossy surfaces' radiance towards the eye comes from when the
/// solution is read directly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GlossyView {
    /// Gathered once per view into the eye as a hypothetical receiver (the
    /// paper's §6, [`crate::render::eye`]), reconstructed as given, on top
    /// of the surface's element radiance.
    Eye(Reconstruction),
    /// Read from the view-independent solution alone: the smooth element
    /// radiance plus the directional radiance towards the surface beyond
    /// the eye, or towards the enclosure receiver where there is none
    /// ([`crate::render::enclosure`]). No per-view gather, softer
    /// highlights.
    Directional,
}

/// The render modes by their user-facing names, each an [`Estimator`]
/// with its defaults ([`Mode::estimator`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// [`Estimator::FinalGather`].
    #[default]
    Gather,
    /// The solution read directly, with the light straight from the
    /// emitters evaluated per camera ray instead of the solution's first
    /// bounce (no gather: what a viewer with shadow rays over a baked
    /// solution shows), the rest smooth except across occluders
    /// ([`Reconstruction::Limited`]); glossy surfaces' radiance towards the
    /// eye per element, as stored.
    Direct,
    /// The solution alone read directly, all of it smooth (what a lightmap
    /// holds).
    Smooth,
    /// The solution read directly, all of it piecewise constant.
    Haar,
}

impl Choice for Mode {
    const KIND: &'static str = "render mode";
    const ALL: &'static [Self] = &[Mode::Gather, Mode::Direct, Mode::Smooth, Mode::Haar];
    const NAMES: &'static [&'static str] = &["gather", "direct", "smooth", "haar"];
}
crate::named_choice!(Mode);

impl Mode {
    /// The estimator of this mode, with glossy surfaces' radiance towards
    /// the eye gathered into the eye (`eye`) or read from the directional
    /// solution, and for the final gather the gather cache (`gather_cache`).
    /// Turning off an option the mode has no use for is an error: the final
    /// gather needs no eye, and only it has a cache.
    pub fn estimator(self, eye: bool, gather_cache: bool) -> Result<Estimator> {
        let reconstruction = match self {
            Mode::Gather if !eye => {
                return Err(Error::RenderOption {
                    mode: self.name(),
                    option: "glossy radiance without the eye",
                    reason: "the final gather evaluates glossy surfaces per camera ray; \
                             the eye is a choice of the direct, smooth and haar modes",
                })
            }
            Mode::Gather => {
                return Ok(Estimator::FinalGather {
                    cached: gather_cache,
                })
            }
            _ if !gather_cache => {
                return Err(Error::RenderOption {
                    mode: self.name(),
                    option: "gather_cache off",
                    reason: "only the final gather (mode gather) has a gather cache to turn off",
                })
            }
            Mode::Haar => Reconstruction::Haar,
            Mode::Direct => Reconstruction::Limited,
            Mode::Smooth => Reconstruction::Smooth,
        };
        let glossy = match (eye, self) {
            (false, _) => GlossyView::Directional,
            (true, Mode::Smooth) => GlossyView::Eye(Reconstruction::Smooth),
            (true, _) => GlossyView::Eye(Reconstruction::Haar),
        };
        Ok(Estimator::Solution {
            reconstruction,
            glossy,
            direct_per_point: self == Mode::Direct,
        })
    }
}

impl Estimator {
    /// The mode, eye and gather-cache choice that make this estimator
    /// ([`Mode::estimator`] backwards).
    pub fn choices(self) -> (Mode, bool, bool) {
        match self {
            Estimator::FinalGather { cached } => (Mode::Gather, true, cached),
            Estimator::Solution {
                direct_per_point: true,
                glossy,
                ..
            } => (Mode::Direct, glossy != GlossyView::Directional, true),
            Estimator::Solution {
                reconstruction: Reconstruction::Haar,
                glossy,
                ..
            } => (Mode::Haar, glossy != GlossyView::Directional, true),
            Estimator::Solution { glossy, .. } => {
                (Mode::Smooth, glossy != GlossyView::Directional, true)
            }
        }
    }
}

/// Where a camera ray meets the front of a surface.
pub(super) struct CameraHit {
    /// The point, drawing its samples from its pixel's block for this ray.
    pub(super) point: GatherPoint,
    /// Its surface parameter.
    pub(super) uv: DVec2,
    /// Unit direction from the point towards the eye.
    pub(super) wo: DVec3,
    /// The ray's index among its pixel's camera rays, and their number.
    pub(super) rays: (usize, usize),
}

/// An [`Estimator`] with what it gathered for one view; each estimates a
/// camera ray's radiance in its own function.
pub(super) enum ViewEstimator<'a> {
    /// [`Estimator::FinalGather`], with the gather cache if it reads one.
    FinalGather {
        /// The view-independent final gather, if read.
        cache: Option<&'a GatherCache>,
    },
    /// [`Estimator::Solution`] with [`GlossyView::Eye`]: the eye gathered
    /// for this view.
    Eye {
        /// How element radiance is reconstructed, and whether the light
        /// straight from the emitters is evaluated per point.
        own: (Reconstruction, bool),
        /// Glossy surfaces' radiance towards this view.
        eye: EyeRadiance,
        /// How that is reconstructed.
        towards_eye: Reconstruction,
    },
    /// [`Estimator::Solution`] read from the view-independent solution
    /// alone.
    Directional {
        /// How element radiance is reconstructed, and whether the light
        /// straight from the emitters is evaluated per point.
        own: (Reconstruction, bool),
    },
}

impl ViewEstimator<'_> {
    /// Radiance towards the eye at `hit`.
    pub(super) fn radiance<S: Borrow<Solution> + Sync>(
        &self,
        renderer: &Renderer<S>,
        hit: &CameraHit,
        settings: &RenderSettings,
    ) -> Rgb {
        match self {
            ViewEstimator::FinalGather { cache } => final_gather(renderer, hit, *cache, settings),
            ViewEstimator::Eye {
                own,
                eye,
                towards_eye,
            } => read_with_eye(renderer, hit, *own, (eye, *towards_eye)),
            ViewEstimator::Directional { own } => read_directional(renderer, hit, *own),
        }
    }
}

/// [`Estimator::FinalGather`] at `hit`: on a diffuse surface its
/// [`lambertian_gather`]; on a glossy one, the light its BRDF reflects
/// towards the eye gathered per camera ray ([`gather::glossy_radiance`]).
/// A BRDF with a Lambertian lobe besides others shows that lobe as a
/// diffuse surface's radiance, and the rest through every camera ray; any
/// other, all of it through every ray. Gather rays from the glossy point
/// see glossy surfaces lit per point (their highlights are finer than
/// their elements), and diffuse ones as the `cache` holds them, or as
/// their final gather.
fn final_gather<S: Borrow<Solution> + Sync>(
    renderer: &Renderer<S>,
    hit: &CameraHit,
    cache: Option<&GatherCache>,
    settings: &RenderSettings,
) -> Rgb {
    let (solution, reader) = (renderer.solution(), renderer.reader());
    let s = hit.point.surface as usize;
    let surface = &solution.scene.surfaces[s];
    if !surface.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION) {
        return lambertian_gather(renderer, hit, cache, settings);
    }
    // A texture makes the Lambertian lobe's albedo, and so the rest of
    // principled's diffuse lobe, vary over the surface.
    let textured = (surface.texture.is_some())
        .then(|| solution.scene.lambertian_at(s, hit.uv))
        .flatten()
        .map(|rho| surface.brdf.shading_rest_at(rho));
    let (brdf, base, grid) = match (&textured, &reader.non_lambertian[s]) {
        (Some(rest), Some(_)) | (None, Some(rest)) => (
            rest,
            lambertian_gather(renderer, hit, cache, settings),
            settings.glossy_lobes_grid_among(hit.rays.1),
        ),
        (_, None) => (
            &surface.brdf,
            surface.emission,
            settings.glossy_grid_among(hit.rays.1),
        ),
    };
    let seen = |q: u32, z: DVec3| {
        let source = &solution.scene.surfaces[q as usize];
        let at = || source.patch.clamp_param(source.patch.param_of(z));
        let cached = cache.filter(|_| !source.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION));
        if let Some(l) = cached.and_then(|c| c.radiance(renderer.cache_source(), q, at())) {
            return l;
        }
        let from = SurfacePoint {
            surface: q,
            position: z,
        };
        let (to, seed) = (SurfacePoint::from(&hit.point), hit.point.samples.seed());
        reader.radiance_leaving(solution, from, to, seed, GLOSSY_GRID)
    };
    let reflected = gather::glossy_radiance(
        &solution.scene,
        &solution.tracer,
        &reader.emitters,
        &hit.point,
        (brdf, hit.wo),
        grid,
        seen,
    );
    base + reflected
}

/// The light a diffuse surface, or a glossy one's Lambertian lobe, reflects
/// at `hit`: its [`direct_per_point`] part, and the rest from the
/// view-independent gather `cache` where it is read there
/// ([`GatherCache::indirect`]); or else the [`rest_of_solution`] (smooth)
/// corrected by the final gathers of some of the pixel's camera rays
/// ([`GatheringRays`]: a control variate). While the solution's links are
/// not arranged, the whole smooth element radiance is the control variate
/// of whole final gathers.
fn lambertian_gather<S: Borrow<Solution> + Sync>(
    renderer: &Renderer<S>,
    hit: &CameraHit,
    cache: Option<&GatherCache>,
    settings: &RenderSettings,
) -> Rgb {
    let (solution, reader) = (renderer.solution(), renderer.reader());
    let s = hit.point.surface as usize;
    let direct = direct_per_point(renderer, hit);
    if let Some(cache) = cache {
        // Without a rest, `direct` is only what glass adds.
        let source = renderer.cache_source();
        let cached = match reader.rest(s) {
            Some(_) => cache.indirect(source, hit.point.surface, hit.uv),
            None => cache.radiance(source, hit.point.surface, hit.uv),
        };
        if let Some(l) = cached {
            return direct + l;
        }
    }
    let control = rest_of_solution(renderer, hit, Reconstruction::Smooth);
    let (k, n) = hit.rays;
    let local = settings.on_receiver(reader.caustic[s]);
    let gathering = GatheringRays::new(n, local.gathers_among(n));
    let Some(block) = gathering.rank(k) else {
        return direct + control;
    };
    let point = GatherPoint {
        samples: hit.point.samples.final_gather(block),
        ..hit.point
    };
    let rays = gathering.rays(&local);
    let gathered = match reader.rest(s) {
        Some(_) => reader.indirect_gather(solution, &point, rays).radiance,
        None => reader.final_gather(
            solution,
            &point,
            GatherBudget {
                rays,
                shadow_grid: GATHER_GRID,
            },
        ),
    };
    direct + control + (gathered - control) * gathering.weight()
}

/// The part of the light a diffuse surface, or a glossy one's Lambertian
/// lobe, reflects at `hit` that a camera ray evaluates itself: its emission
/// and the light straight from the emitters (one shadow ray, the pixel's
/// rays drawing their points on the emitters as one stratified set, so
/// that a penumbra is sampled as finely as the pixel:
/// [`gather::direct_radiance`]), with what glass adds to that or takes
/// from it ([`super::caustics`]). Where the solution has no rest (its links
/// are not arranged), only what glass adds: the element radiance holds the
/// rest ([`rest_of_solution`]).
fn direct_per_point<S: Borrow<Solution> + Sync>(renderer: &Renderer<S>, hit: &CameraHit) -> Rgb {
    let (solution, reader) = (renderer.solution(), renderer.reader());
    let s = hit.point.surface as usize;
    let caustic = renderer.caustic_radiance(hit);
    match reader.rest(s) {
        Some(_) => {
            solution.scene.surfaces[s].emission
                + gather::direct_radiance(
                    &solution.scene,
                    &solution.tracer,
                    &reader.emitters,
                    &hit.point,
                    1,
                )
                + caustic
        }
        None => caustic,
    }
}

/// What [`direct_per_point`] leaves out of a surface's radiance at `hit`:
/// the rest of the solution
/// ([`SolutionReader::rest`](super::reader::SolutionReader::rest)),
/// reconstructed as `reconstruction`; where the solution has no rest, the
/// whole element radiance.
fn rest_of_solution<S: Borrow<Solution> + Sync>(
    renderer: &Renderer<S>,
    hit: &CameraHit,
    reconstruction: Reconstruction,
) -> Rgb {
    let s = hit.point.surface as usize;
    match renderer.reader().rest(s) {
        Some(rest) => renderer.element_values(reconstruction, s, hit.uv, (rest, Rgb::ZERO)),
        None => renderer.element_radiance(reconstruction, s, hit.uv),
    }
}

/// A surface's own radiance at `hit` read from the solution (its element
/// radiance, reconstructed as `reconstruction`), or with `per_point` its
/// [`direct_per_point`] and [`rest_of_solution`] parts together.
fn own_radiance<S: Borrow<Solution> + Sync>(
    renderer: &Renderer<S>,
    hit: &CameraHit,
    (reconstruction, per_point): (Reconstruction, bool),
) -> Rgb {
    if per_point {
        return direct_per_point(renderer, hit) + rest_of_solution(renderer, hit, reconstruction);
    }
    renderer.element_radiance(reconstruction, hit.point.surface as usize, hit.uv)
}

/// [`Estimator::Solution`] with [`GlossyView::Eye`] at `hit`: the surface's
/// [`own_radiance`], and on a glossy surface its radiance towards the `eye`
/// gathered for this view, reconstructed as given.
fn read_with_eye<S: Borrow<Solution> + Sync>(
    renderer: &Renderer<S>,
    hit: &CameraHit,
    own: (Reconstruction, bool),
    (eye, towards_eye): (&EyeRadiance, Reconstruction),
) -> Rgb {
    let s = hit.point.surface as usize;
    let own = own_radiance(renderer, hit, own);
    if !renderer.solution().scene.surfaces[s]
        .brdf
        .flags()
        .contains(BrdfFlags::GLOSSY_REFLECTION)
    {
        return own;
    }
    let glossy = (eye.surfaces[s].as_ref()).map_or(Rgb::ZERO, |(tree, l)| {
        radiance_at(tree, l, hit.uv, towards_eye)
    });
    own + glossy
}

/// [`Estimator::Solution`] with [`GlossyView::Directional`] at `hit`: the
/// surface's [`own_radiance`], and on a glossy one its directional radiance
/// towards the eye from the view-independent solution
/// ([`Renderer::glossy_radiance_towards`]).
fn read_directional<S: Borrow<Solution> + Sync>(
    renderer: &Renderer<S>,
    hit: &CameraHit,
    own: (Reconstruction, bool),
) -> Rgb {
    let GatherPoint {
        surface, position, ..
    } = hit.point;
    let own = own_radiance(renderer, hit, own);
    match renderer.solution().scene.surfaces[surface as usize]
        .brdf
        .flags()
        .contains(BrdfFlags::GLOSSY_REFLECTION)
    {
        false => own,
        true => {
            let passes = |s| hit.point.on_shape(s);
            own + renderer.directional_towards(surface, position, hit.wo, passes)
        }
    }
}

/// Which of a pixel's `n` camera rays (a √n × √n stratified grid, row by
/// row) final-gather: `gathers` of them on a rank-1 lattice over the grid
/// (the j-th in row ⌊j·√n/gathers⌋, column j·P mod √n with P coprime to √n,
/// near √n/φ), so that they spread over the whole pixel at any ratio.
/// When more gathers are asked for than the pixel has camera rays, each
/// gathering ray traces more indirect rays instead.
struct GatheringRays {
    side: usize,
    gathers: usize,
    /// Gathers asked for per gather made (≥ 1).
    excess: u32,
    step: usize,
}

impl GatheringRays {
    fn new(n: usize, wanted: u32) -> GatheringRays {
        let side = ((n as f64).sqrt().round() as usize).max(1);
        let gathers = (wanted as usize).clamp(1, side * side);
        let excess = wanted.div_ceil(gathers as u32).max(1);
        let gcd = |(mut a, mut b): (usize, usize)| {
            while b != 0 {
                (a, b) = (b, a % b);
            }
            a
        };
        let step = (((side as f64) * 0.618).round() as usize..)
            .find(|&p| gcd((p, side)) == 1)
            .unwrap_or(1);
        GatheringRays {
            side,
            gathers,
            excess,
            step,
        }
    }

    /// Which of the pixel's gathers camera ray `k` makes (0 for the first),
    /// if it gathers.
    fn rank(&self, k: usize) -> Option<u32> {
        let (row, col) = (k / self.side, k % self.side);
        let first = |r: usize| (r * self.gathers).div_ceil(self.side);
        (first(row)..first(row + 1))
            .find(|&j| (j * self.step) % self.side == col)
            .map(|j| j as u32)
    }

    /// The control variate's weight: rays per gathering ray.
    fn weight(&self) -> f64 {
        (self.side * self.side) as f64 / self.gathers as f64
    }

    /// Indirect rays per gathering ray: the pixel's share of `settings`'
    /// total for an interior pixel, and more where the pixel has fewer
    /// camera rays than gathers asked for.
    fn rays(&self, settings: &RenderSettings) -> u32 {
        let total = GATHER_RAYS * settings.gather_samples_per_pixel;
        (total / self.gathers as u32).clamp(GATHER_RAYS.min(4), GATHER_RAYS * self.excess)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each mode with the options it uses is an estimator of its own; the
    /// options a mode has no use for are errors.
    #[test]
    fn every_mode_option_combination_is_an_estimator_or_an_error() {
        let mut estimators = Vec::new();
        for &mode in Mode::ALL {
            for eye in [true, false] {
                for cache in [true, false] {
                    let unused = match mode {
                        Mode::Gather => !eye,
                        _ => !cache,
                    };
                    match mode.estimator(eye, cache) {
                        Ok(e) => {
                            assert!(!unused, "{mode} eye {eye} cache {cache}: {e:?}");
                            estimators.push(e);
                        }
                        Err(Error::RenderOption { mode: name, .. }) => {
                            assert!(unused, "{mode} eye {eye} cache {cache}");
                            assert_eq!(name, mode.name());
                        }
                        Err(e) => panic!("{e}"),
                    }
                }
            }
        }
        assert_eq!(estimators.len(), 8);
        estimators.sort_by_key(|e| format!("{e:?}"));
        estimators.dedup();
        assert_eq!(estimators.len(), 8);
        assert_eq!(
            Mode::default().estimator(true, true),
            Ok(Estimator::default())
        );
    }

    #[test]
    fn modes_are_named_as_they_parse() {
        for (&name, &mode) in Mode::NAMES.iter().zip(Mode::ALL) {
            assert_eq!(name.parse::<Mode>(), Ok(mode));
            assert_eq!(mode.to_string(), name);
        }
        assert!("phong".parse::<Mode>().is_err());
    }

    #[test]
    fn gathering_rays_are_as_many_as_asked_and_spread_over_rows_and_columns() {
        for (n, gathers) in [
            (529, 16),
            (1024, 16),
            (64, 16),
            (64, 64),
            (64, 200),
            (1, 4),
            (256, 7),
        ] {
            let g = GatheringRays::new(n, gathers);
            let chosen: Vec<usize> = (0..n).filter(|&k| g.rank(k).is_some()).collect();
            let expect = (gathers as usize).min(n);
            assert_eq!(chosen.len(), expect, "n {n} gathers {gathers}");
            // Each gather has its own rank, and together they number 0, 1, ….
            let mut ranks: Vec<u32> = chosen.iter().filter_map(|&k| g.rank(k)).collect();
            ranks.sort_unstable();
            assert!(ranks.iter().enumerate().all(|(i, &r)| r == i as u32));
            assert_eq!(g.weight() * expect as f64, n as f64);
            // No two in one column while there are columns to spare.
            let side = (n as f64).sqrt() as usize;
            let mut columns: Vec<usize> = chosen.iter().map(|k| k % side).collect();
            columns.sort_unstable();
            columns.dedup();
            assert_eq!(columns.len(), expect.min(side), "n {n} gathers {gathers}");
        }
    }

    #[test]
    fn gathers_beyond_the_camera_rays_become_indirect_rays() {
        let settings = RenderSettings::default();
        let interior = settings.interior_samples_per_pixel() as usize;
        let rays = |gather_spp: u32| {
            let local = RenderSettings {
                gather_samples_per_pixel: gather_spp,
                ..settings
            };
            let g = GatheringRays::new(interior, local.gathers_among(interior));
            (g.gathers, g.rays(&local))
        };
        // Indirect rays in all: gathers × rays per gather, as asked for.
        for gather_spp in [16, 64, 256, 1024] {
            let (gathers, per_gather) = rays(gather_spp);
            assert_eq!(gathers, (gather_spp as usize).min(interior));
            assert_eq!(
                gathers as u32 * per_gather,
                gather_spp * GATHER_RAYS,
                "gather spp {gather_spp}"
            );
        }
    }
}
