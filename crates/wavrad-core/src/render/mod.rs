//! Rendering a view from a solution: camera rays ([`camera`]), radiance
//! reconstruction on the surface hit ([`reconstruct`]), filtered onto the
//! film ([`film`]).

pub mod cache;
pub mod camera;
pub mod enclosure;
pub mod eye;
pub mod film;
pub mod gather;
pub mod mirror;
pub mod reconstruct;

use crate::geometry::hierarchy::ElementId;
use crate::sampling::Samples;
use crate::scene::brdf::{Brdf, BrdfFlags, BrdfModel};
use crate::scene::{Camera, Film, Rgb, Scene};
use crate::solve::Solution;
use crate::{Error, Result};
use film::{develop, Image};
use gather::GatherPoint;
use glam::{DVec2, DVec3};
use mirror::MirrorImage;
use rayon::prelude::*;
use reconstruct::{radiance_at, Reconstruction, SmoothLookup};

/// How to render a view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// Reconstruction of radiance on surfaces.
    pub mode: Reconstruction,
    /// Camera rays per pixel (rounded up to a square) where a pixel needs
    /// them: where it shows more than one surface (an edge, the outline of a
    /// light). Multi-jittered, an outline's coverage error falls as 1/spp:
    /// 512 instead of the default 256 left the bundled scenes' errors as
    /// they were (glossy box, cached final gather 0.732 % instead of
    /// 0.735 %, per-pixel 0.838 % instead of 0.845 %; Cornell box
    /// 0.716 % instead of 0.715 %) and took 15–50 % more render time
    /// (measured while choosing).
    pub samples_per_pixel: u32,
    /// Camera rays per pixel in the others, whose 4×4 probe rays all meet
    /// one surface, as do their neighbours': radiance varies smoothly there,
    /// and the final gather, not the camera rays, resolves its shadows (on
    /// a glossy surface, each camera ray takes proportionally more light and
    /// BRDF samples).
    pub interior_samples_per_pixel: u32,
    /// Camera rays per pixel at the outline of an emitter, or of a diffuse
    /// surface lit strongly enough to light others as one does (a pixel
    /// that shows more than one surface, in its probe rays or its
    /// neighbours', where some of them meet such a surface).
    /// An emitter outshines what surrounds it a hundredfold (Figure 3's lit
    /// reflector fiftyfold), so the sampling noise of its coverage of a
    /// pixel dominates an image's error; the extra rays cost a lookup each,
    /// because these pixels gather no more often than any other edge pixel.
    pub emitter_edge_samples_per_pixel: u32,
    /// In [`Reconstruction::Gather`], how many of the camera rays of an
    /// interior pixel also gather (the others use the smooth solution, and
    /// the gathering ones carry the correction for them: a control variate,
    /// so that the costly gather runs only for a few rays). Pixels with
    /// more camera rays gather in the same proportion: at an edge the
    /// correction jumps, and its coverage needs as many rays as the
    /// solution's.
    pub gather_samples_per_pixel: u32,
    /// How many times as many camera rays gather on a caustic's receiver: a
    /// diffuse surface that sees a sharp glossy surface mirror an emitter
    /// ([`mirror::is_sharp`]). All of that light reaches it through its
    /// gathers, each sample of which evaluates the glossy reflection at one
    /// point, so its gathers are noisier than any other surface's (Figure
    /// 3's receiver gets nothing else).
    pub caustic_gathers: u32,
    /// Shadow rays per emitter for each gathering camera ray: a
    /// `gather_grid` × `gather_grid` jittered grid. Bright surfaces (glossy
    /// ones and strongly lit diffuse ones) get grids of about as many area
    /// samples in all as the gathering ray has indirect rays, and each at
    /// least this.
    pub gather_grid: u32,
    /// Indirect gather rays per gathering camera ray of an interior pixel;
    /// in a pixel with more gathering rays, as many indirect rays in total
    /// (at least 4 per gathering ray).
    pub gather_rays: u32,
    /// Outside [`Reconstruction::Gather`], glossy surfaces show their
    /// radiance towards the eye, gathered once per view into the eye as a
    /// hypothetical receiver (the paper's §6; `true`), or read from the
    /// view-independent solution alone: the directional radiance towards the
    /// surface beyond the eye, or towards the enclosure receiver where there
    /// is none ([`enclosure`]; `false`, no per-view gather, softer
    /// highlights).
    pub eye: bool,
    /// On glossy surfaces in [`Reconstruction::Gather`], where every camera
    /// ray gathers through the BRDF: `glossy_grid` × `glossy_grid` light
    /// samples per emitter and as many BRDF samples per ray. A BRDF without
    /// a Lambertian lobe gets that many per ray of a pixel with all its
    /// camera rays, and more in interior pixels (in proportion, the same
    /// in all); one with a Lambertian lobe gathers only its other lobes
    /// per ray, that lobe's light coming as a diffuse surface's, and gets
    /// that many in every pixel (on the glossy box's walkthrough, ten times
    /// fewer per interior pixel left the error unchanged and halved the
    /// time per view, measured while choosing).
    pub glossy_grid: u32,
    /// In [`Reconstruction::Gather`], diffuse surfaces show the solution's
    /// view-independent final gather ([`cache::GatherCache`]: one gather
    /// per texel, built once per solution, the first time a view asks for
    /// it, and then read by every view) instead of gathering per camera
    /// ray: for many views of one solution (`false` by default).
    pub gather_cache: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            mode: Reconstruction::default(),
            samples_per_pixel: 256,
            interior_samples_per_pixel: 64,
            emitter_edge_samples_per_pixel: 4096,
            gather_samples_per_pixel: 8,
            caustic_gathers: 16,
            gather_grid: 2,
            gather_rays: 32,
            glossy_grid: 1,
            eye: true,
            gather_cache: false,
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

    /// How many of a pixel's `n` camera rays gather: in proportion to `n`,
    /// as in an interior pixel, up to as many as an edge pixel's.
    fn gathers_among(&self, n: usize) -> u32 {
        let n = n.min(crate::sampling::pixel_offsets_len(self.samples_per_pixel) as usize);
        let interior = crate::sampling::pixel_offsets_len(self.interior_samples_per_pixel) as usize;
        let share = self.gather_samples_per_pixel as f64 / interior as f64;
        ((n as f64 * share).round() as u32).max(1)
    }

    /// The settings a diffuse surface gathers with: these, or on a caustic's
    /// receiver `caustic_gathers` times as many gathers.
    fn on_receiver(&self, caustic: bool) -> RenderSettings {
        let factor = if caustic { self.caustic_gathers } else { 1 };
        RenderSettings {
            gather_samples_per_pixel: self.gather_samples_per_pixel.saturating_mul(factor),
            ..*self
        }
    }

    /// The same settings with `n` camera rays per pixel, a quarter of them
    /// in interior pixels, a thirty-second gathering and sixteen times as
    /// many at an emitter's outline (the default proportions).
    pub fn with_samples_per_pixel(self, n: u32) -> RenderSettings {
        let n = n.max(1);
        RenderSettings {
            samples_per_pixel: n,
            interior_samples_per_pixel: (n / 4).max(1),
            emitter_edge_samples_per_pixel: n.saturating_mul(16),
            gather_samples_per_pixel: (n / 32).max(1),
            ..self
        }
    }
}

/// What gather rays read from a solution on diffuse surfaces: the radiance
/// of the element they hit (piecewise constant; `smooth`, the bilinear
/// reconstruction, is what camera rays show); on a surface with an entry in
/// `beyond_first` (the solution's radiance less its first bounce,
/// [`Solution::first_bounce`]), that element's value of it plus the light
/// reflected straight from the `emitters` evaluated at the point hit.
///
/// A gather averages what it reads over many elements, so the smooth
/// reconstruction gains it nothing, and near a concave edge, where the
/// nearby surface fills much of a gather's hemisphere, its linear
/// extrapolation at the boundary overshoots: reading element values took
/// the reference test's Cornell box from 0.97 % to 0.93 %, the glossy box
/// from 0.98 % to 0.95 %, Figure 3 unchanged.
///
/// A final gather's bias is the error of what its rays read. On a strongly
/// lit diffuse surface ([`Solution::secondary_sources`]) that reflects over
/// half of the scene's light, that is the first bounce, which its elements
/// average over (Figure 3's reflector, which alone lights the receiver).
/// Elsewhere it changed nothing measurable and cost a shadow ray per gather
/// sample that meets the surface (the Cornell box's tall box top: render
/// 2.1 s → 2.8 s for the same error).
///
/// `non_lambertian` is, for a glossy surface whose BRDF has a Lambertian
/// lobe besides others (Ward's), the rest of its BRDF: camera rays meeting
/// it in the gather mode see the Lambertian lobe's light as a diffuse
/// surface's (cached or gathered by some of the pixel's rays, its element
/// radiance the control variate) and gather only the rest per ray.
///
/// It also knows where a gather looks for concentrated light besides its
/// cosine rays ([`gather::GatherSources`]): the `bright` surfaces, the
/// emitters' `mirrors` images, and the `caustic` receivers they light.
struct SolutionReader {
    smooth: Vec<SmoothLookup>,
    non_lambertian: Vec<Option<Brdf>>,
    beyond_first: Vec<Option<Vec<Rgb>>>,
    emitters: Vec<u32>,
    bright: Vec<u32>,
    mirrors: Vec<MirrorImage>,
    caustic: Vec<bool>,
}

/// What a final gather finds at a point, in two parts: light that varies as
/// sharply as shadows do, and light that varies smoothly.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FinalGather {
    /// Emission and the light straight from the emitters.
    direct: Rgb,
    /// Light from the rest of the solution.
    indirect: gather::Indirect,
}

impl FinalGather {
    fn total(&self) -> Rgb {
        [0, 1, 2].map(|ch| self.direct[ch] + self.indirect.radiance[ch])
    }
}

/// What the probe rays through a pixel meet.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PixelProbe {
    /// The surface all of them meet, if they meet one.
    surface: Option<u32>,
    /// Some meet an emitter or a strongly lit diffuse surface.
    glaring: bool,
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
    let mut uniform = centre.is_some();
    let mut emitter_edge = false;
    for p in neighbours {
        uniform &= p.surface == centre;
        emitter_edge |= p.glaring;
    }
    if uniform {
        settings.interior_samples_per_pixel
    } else if emitter_edge {
        settings.emitter_edge_samples_per_pixel
    } else {
        settings.samples_per_pixel
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
        let coprime = |p: usize| {
            (1..=p.min(side))
                .rev()
                .all(|d| d == 1 || !p.is_multiple_of(d) || !side.is_multiple_of(d))
        };
        let step = (((side as f64) * 0.618).round() as usize..)
            .find(|&p| coprime(p))
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
        let total = settings.gather_rays * settings.gather_samples_per_pixel;
        (total / self.gathers as u32).clamp(
            settings.gather_rays.min(4),
            settings.gather_rays * self.excess,
        )
    }
}

impl Solution {
    /// Render the scene's own sensor at its film size.
    pub fn render(&self, settings: &RenderSettings) -> Result<Image> {
        let camera = self.scene.camera.as_ref().ok_or(Error::NoSensor)?;
        Ok(self.render_view(camera, &self.scene.film, settings))
    }

    /// A quick image of the scene's sensor: the smooth reconstruction with 4
    /// camera rays per pixel (what a progressive solve shows after each
    /// step).
    pub fn preview(&self) -> Result<Image> {
        self.render(&RenderSettings {
            mode: Reconstruction::Smooth,
            ..RenderSettings::default().with_samples_per_pixel(4)
        })
    }

    /// Render any view of the solution (it is view-independent).
    pub fn render_view(&self, camera: &Camera, film: &Film, settings: &RenderSettings) -> Image {
        let (w, h) = (film.width as f64, film.height as f64);
        let aspect = w / h;
        let reader = self.reader();
        // Glossy surfaces outside the gather mode show their radiance towards
        // this view, gathered once into the eye.
        let any_glossy = self
            .scene
            .surfaces
            .iter()
            .any(|s| s.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION));
        let eye = (settings.eye && any_glossy && settings.mode != Reconstruction::Gather)
            .then(|| self.eye_radiance(camera, &crate::progress::Silent));
        let cache = (settings.mode == Reconstruction::Gather && settings.gather_cache)
            .then(|| self.gather_cache(&reader, settings));
        // Pixels showing one surface, as do their eight neighbours
        // (an edge slipping between a pixel's probes shows in a neighbour's),
        // get fewer camera rays; those near an emitter's outline, more.
        let probes = &self.probe(camera, film, &reader.bright);
        let samples = |px: usize, py: usize| camera_rays(probes, film, (px, py), settings);
        // A pixel with fewer camera rays takes as many glossy samples in all.
        let glossy_grid = |n: usize| {
            let ratio = (settings.samples_per_pixel as f64 / n as f64).max(1.0);
            ((f64::from(settings.glossy_grid) * ratio.sqrt()).round() as u32).max(1)
        };
        let mut image = develop(film, samples, |x, y, k, n| {
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
            // The pixel's estimates of one kind stratify their samples
            // jointly: each takes its own block of the pixel's sequences.
            let pixel = (y.floor() * w + x.floor()) as u64;
            let scramble = pixel.wrapping_mul(0x9e37_79b9_7f4a_7c15);
            let point = GatherPoint {
                surface: hit.surface,
                position: hit.position,
                normal: patch.normal(),
                samples: Samples::Pixel {
                    scramble,
                    block: k as u32,
                },
            };
            // What a gather ray from this point finds: glossy surfaces lit
            // per point (their highlights are finer than their elements),
            // diffuse ones the cache holds, their final gather.
            let seen = |q: u32, z: DVec3| {
                let source = &self.scene.surfaces[q as usize];
                let at = || source.patch.clamp_param(source.patch.param_of(z));
                let cached =
                    cache.filter(|_| !source.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION));
                if let Some(l) = cached.and_then(|c| c.radiance(q, at())) {
                    return l;
                }
                let to = (hit.surface, hit.position);
                let seed = point.samples.seed();
                self.radiance_leaving(&reader, (q, z), to, (seed, settings.glossy_grid))
            };
            // The element radiance camera rays show: piecewise constant in
            // Haar mode, else the smooth reconstruction.
            let element = || match settings.mode {
                Reconstruction::Haar => {
                    radiance_at(&self.trees[s], &self.radiance[s], uv, settings.mode)
                }
                _ => reader.smooth[s].radiance(&self.trees[s], &self.radiance[s], uv),
            };
            // A diffuse surface's radiance, or a glossy one's Lambertian
            // lobe's: the view-independent gather cache's, or the element
            // radiance corrected by the gathers of some camera rays (a
            // control variate).
            let diffuse = || {
                if let Some(l) = cache.and_then(|c| c.radiance(hit.surface, uv)) {
                    return l;
                }
                let reconstructed = element();
                let local = settings.on_receiver(reader.caustic[s]);
                let gathering = GatheringRays::new(n, local.gathers_among(n));
                let rank = gathering.rank(k);
                let Some(block) = rank.filter(|_| settings.mode == Reconstruction::Gather) else {
                    return reconstructed;
                };
                let point = GatherPoint {
                    samples: Samples::Pixel {
                        scramble: scramble ^ 0x243f_6a88_85a3_08d3,
                        block,
                    },
                    ..point
                };
                let rays = gathering.rays(&local);
                let gathered =
                    self.final_gather(&reader, &point, (rays, settings.gather_grid), settings);
                let weight = gathering.weight();
                [0, 1, 2].map(|ch| reconstructed[ch] + weight * (gathered[ch] - reconstructed[ch]))
            };
            if surface.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION) {
                if !settings.eye && settings.mode != Reconstruction::Gather {
                    return self.glossy_radiance_towards(hit.surface, hit.position, -ray.direction);
                }
                if let Some(eye) = &eye {
                    let mode = match settings.mode {
                        Reconstruction::Smooth => Reconstruction::Smooth,
                        _ => Reconstruction::Haar,
                    };
                    // Its element radiance as a diffuse surface's is shown.
                    let own = element();
                    let towards_eye = (eye.surfaces[s].as_ref())
                        .map_or([0.0; 3], |(tree, l)| radiance_at(tree, l, uv, mode));
                    return [0, 1, 2].map(|ch| own[ch] + towards_eye[ch]);
                }
                // A BRDF with a Lambertian lobe besides others shows that
                // lobe as a diffuse surface's radiance, and the rest through
                // every camera ray; any other, all of it through every ray.
                let (brdf, base, grid) = match &reader.non_lambertian[s] {
                    Some(rest) => (rest, diffuse(), settings.glossy_grid),
                    None => (&surface.brdf, surface.emission, glossy_grid(n)),
                };
                let reflected = gather::glossy_radiance(
                    &self.scene,
                    &self.tracer,
                    &reader.emitters,
                    &point,
                    (brdf, -ray.direction),
                    grid,
                    seen,
                );
                return [0, 1, 2].map(|ch| base[ch] + reflected[ch]);
            }
            diffuse()
        });
        // The control variate is unbiased but, with few gathering rays in a
        // pixel, can undershoot below zero; radiance cannot, so such pixels
        // are clamped (a bias confined to those pixels, vanishing with spp).
        for v in &mut image.rgb {
            *v = v.max(0.0);
        }
        image
    }

    /// What final gathers read from this solution (view-independent).
    fn reader(&self) -> SolutionReader {
        let surfaces = &self.scene.surfaces;
        let emitters: Vec<u32> = (0..surfaces.len() as u32)
            .filter(|&s| surfaces[s as usize].is_emitter())
            .collect();
        let glossy: Vec<u32> = (0..surfaces.len() as u32)
            .filter(|&s| {
                surfaces[s as usize]
                    .brdf
                    .flags()
                    .contains(BrdfFlags::GLOSSY_REFLECTION)
            })
            .collect();
        let bright = self.secondary_sources(&glossy);
        let mirrors = MirrorImage::of_scene(&self.scene, &glossy, &emitters);
        let caustic = (0..surfaces.len())
            .map(|s| mirrors.iter().any(|m| m.lights(&self.scene, s as u32)))
            .collect();
        // A strongly lit diffuse surface that reflects most of the scene's
        // light shows gather rays its first bounce per point.
        let power = self.reflected_power();
        let total: f64 = power.iter().sum();
        let per_point: Vec<usize> = (bright.iter().map(|&s| s as usize))
            .filter(|&s| power[s] > 0.5 * total)
            .collect();
        let mut beyond_first = vec![None; surfaces.len()];
        if let (false, Some(first)) = (per_point.is_empty(), self.first_bounce()) {
            for s in per_point.into_iter().filter(|&s| !first[s].is_empty()) {
                let less = |(b, f): (&Rgb, &Rgb)| [0, 1, 2].map(|ch| b[ch] - f[ch]);
                beyond_first[s] = Some(self.radiance[s].iter().zip(&first[s]).map(less).collect());
            }
        }
        let non_lambertian = surfaces
            .iter()
            .map(|s| {
                match (
                    s.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION),
                    s.brdf.lambertian(),
                ) {
                    (true, Some(_)) => Some(s.brdf.without_lambertian()),
                    _ => None,
                }
            })
            .collect();
        SolutionReader {
            smooth: self.trees.par_iter().map(SmoothLookup::new).collect(),
            non_lambertian,
            beyond_first,
            emitters,
            bright,
            mirrors,
            caustic,
        }
    }

    /// Radiance leaving the diffuse `point` (view-independent): its emission,
    /// the light straight from the emitters (`shadow_grid` × `shadow_grid`
    /// shadow rays to each) and `rays` cosine rays' worth of the rest of
    /// the solution, with about as many samples of the bright surfaces
    /// together, and of each mirror image ([`gather::indirect_radiance`]).
    /// The bright surfaces share their samples: each glossy face of a box
    /// counts as one, and area samples each cost a shadow ray and a glossy
    /// evaluation (on the glossy Cornell box, as many per face as cosine
    /// rays took the gather cache's build from 1.4 s to 3.8 s for a view-0
    /// error of 0.79 % instead of 0.80 %, and per-pixel gathers from 0.94 s
    /// to 1.63 s for 0.84 % instead of 0.90 %, measured while choosing).
    fn final_gather(
        &self,
        reader: &SolutionReader,
        point: &GatherPoint,
        rays: (u32, u32),
        settings: &RenderSettings,
    ) -> Rgb {
        self.final_gather_parts(reader, point, rays, settings)
            .total()
    }

    /// [`Solution::final_gather`] in its two parts.
    fn final_gather_parts(
        &self,
        reader: &SolutionReader,
        point: &GatherPoint,
        (rays, shadow_grid): (u32, u32),
        settings: &RenderSettings,
    ) -> FinalGather {
        let sources = gather::GatherSources {
            bright: &reader.bright,
            mirrors: &reader.mirrors,
            grid: ((f64::from(rays) / reader.bright.len().max(1) as f64)
                .sqrt()
                .round() as u32)
                .max(settings.gather_grid),
        };
        let to = (point.surface, point.position);
        let seed = point.samples.seed();
        let indirect =
            gather::indirect_radiance(&self.scene, &self.tracer, point, rays, sources, |q, y| {
                let l = self.radiance_leaving(reader, (q, y), to, (seed, settings.glossy_grid));
                let e = self.scene.surfaces[q as usize].emission;
                [0, 1, 2].map(|ch| (l[ch] - e[ch]).max(0.0))
            });
        let direct = gather::direct_radiance(
            &self.scene,
            &self.tracer,
            &reader.emitters,
            point,
            shadow_grid,
        );
        let emission = self.scene.surfaces[point.surface as usize].emission;
        FinalGather {
            direct: [0, 1, 2].map(|ch| emission[ch] + direct[ch]),
            indirect,
        }
    }

    /// The view-independent final gather ([`cache::GatherCache`]), built the
    /// first time a view asks for it, with that view's `settings`.
    fn gather_cache(
        &self,
        reader: &SolutionReader,
        settings: &RenderSettings,
    ) -> &cache::GatherCache {
        self.gather_cache
            .get_or_init(|| cache::GatherCache::build(self, reader, settings))
    }

    /// What 4×4 probe rays through each pixel of `film` meet; `glaring`
    /// per surface: emitters, and diffuse surfaces among the `bright` ones
    /// ([`Solution::secondary_sources`]).
    fn probe(&self, camera: &Camera, film: &Film, bright: &[u32]) -> Vec<PixelProbe> {
        let glaring: Vec<bool> = (self.scene.surfaces.iter().enumerate())
            .map(|(s, surface)| {
                surface.is_emitter()
                    || (!surface.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION)
                        && bright.contains(&(s as u32)))
            })
            .collect();
        let (w, h) = (film.width as usize, film.height as usize);
        let aspect = w as f64 / h as f64;
        (0..w * h)
            .into_par_iter()
            .map(|pixel| {
                let (px, py) = ((pixel % w) as f64, (pixel / w) as f64);
                let hits = (0..16).map(|k| {
                    let at = DVec2::new(
                        (px + (f64::from(k % 4) + 0.5) / 4.0) / w as f64,
                        (py + (f64::from(k / 4) + 0.5) / 4.0) / h as f64,
                    );
                    let ray = camera.ray(at, aspect);
                    self.tracer
                        .trace(ray.origin, ray.direction, ray.t_min, ray.t_max)
                        .map(|hit| hit.surface)
                });
                let hits: Vec<Option<u32>> = hits.collect();
                let one = hits.iter().all(|&s| s == hits[0]);
                PixelProbe {
                    surface: if one { hits[0] } else { None },
                    glaring: hits.iter().any(|s| s.is_some_and(|s| glaring[s as usize])),
                }
            })
            .collect()
    }

    /// Per surface, the light its diffuse solution reflects: average
    /// radiance (mean of the channels) times area, zero for emitters and
    /// glossy surfaces.
    fn reflected_power(&self) -> Vec<f64> {
        let lum = |l: Rgb| (l[0] + l[1] + l[2]) / 3.0;
        (self.scene.surfaces.iter().enumerate())
            .map(|(s, surface)| {
                match !surface.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION)
                    && !surface.is_emitter()
                {
                    true => lum(self.radiance[s][0]) * surface.patch.area(),
                    false => 0.0,
                }
            })
            .collect()
    }

    /// The surfaces a diffuse point's final gather samples by area besides
    /// its cosine rays: every glossy one (its reflected light is
    /// concentrated in its lobes) and every diffuse non-emitter whose
    /// average radiance is over four times the area-weighted mean of all
    /// non-emitters (a small, strongly lit surface that lights the others:
    /// cosine rays rarely find it).
    fn secondary_sources(&self, glossy: &[u32]) -> Vec<u32> {
        let power = self.reflected_power();
        let lit = |s: usize| {
            let surface = &self.scene.surfaces[s];
            !surface.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION) && !surface.is_emitter()
        };
        let area = |s: usize| self.scene.surfaces[s].patch.area();
        let n = self.scene.surfaces.len();
        let total_area: f64 = (0..n).filter(|&s| lit(s)).map(area).sum();
        let mean = power.iter().sum::<f64>() / total_area.max(f64::MIN_POSITIVE);
        let mut out = glossy.to_vec();
        out.extend((0..n as u32).filter(|&s| {
            let s = s as usize;
            lit(s) && power[s] > 4.0 * mean * area(s)
        }));
        out.sort_unstable();
        out
    }

    /// Radiance leaving point `y` of surface `q` towards point `x` of surface
    /// `s`, as a gather ray from `x` sees it: the solution's for a diffuse
    /// `q`; for a glossy one, the light its BRDF reflects there evaluated per
    /// point (emitters exactly, the rest from the solution, `grid` × `grid`
    /// samples of each; [`gather::glossy_radiance`]), because a highlight's
    /// sharp edge, and the light near a contact line, are finer than the
    /// pair tree's elements.
    fn radiance_leaving(
        &self,
        reader: &SolutionReader,
        (q, y): (u32, DVec3),
        (s, x): (u32, DVec3),
        (seed, grid): (u64, u32),
    ) -> Rgb {
        let source = &self.scene.surfaces[q as usize];
        // Decorrelated per point y: every ray of one gather has its own.
        let bits = y.x.to_bits() ^ y.y.to_bits().rotate_left(21) ^ y.z.to_bits().rotate_left(42);
        let seed = seed.rotate_left(17) ^ u64::from(q) ^ bits;
        if !source.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION) {
            return self.outgoing_radiance(reader, (q, y, seed), s, x);
        }
        let at = GatherPoint {
            surface: q,
            position: y,
            normal: source.patch.normal(),
            samples: Samples::Hashed(seed),
        };
        let reflected = gather::glossy_radiance(
            &self.scene,
            &self.tracer,
            &reader.emitters,
            &at,
            (&source.brdf, (x - y).normalize()),
            grid,
            |h, z| self.outgoing_radiance(reader, (h, z, seed ^ u64::from(h) << 40), q, y),
        );
        [0, 1, 2].map(|ch| source.emission[ch] + reflected[ch])
    }

    /// Radiance the solution says leaves point `y` of surface `q` towards
    /// point `x` of surface `s` ([`SolutionReader`]): the radiance of `q`'s
    /// element at `y`, plus for a glossy `q` its directional radiance
    /// towards `x` ([`Solution::directional_radiance`]).
    fn outgoing_radiance(
        &self,
        reader: &SolutionReader,
        (q, y, seed): (u32, DVec3, u64),
        s: u32,
        x: DVec3,
    ) -> Rgb {
        let surface = &self.scene.surfaces[q as usize];
        let uv_y = surface.patch.clamp_param(surface.patch.param_of(y));
        let i = q as usize;
        let element =
            |radiance: &[Rgb]| radiance_at(&self.trees[i], radiance, uv_y, Reconstruction::Haar);
        if surface.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION) {
            let own = element(&self.radiance[i]);
            let glossy = self.directional_radiance(q, y, s, x);
            return [0, 1, 2].map(|ch| own[ch] + glossy[ch]);
        }
        let Some(beyond_first) = &reader.beyond_first[i] else {
            return element(&self.radiance[i]);
        };
        let solved = element(beyond_first);
        let at = GatherPoint {
            surface: q,
            position: y,
            normal: surface.patch.normal(),
            samples: Samples::Hashed(seed),
        };
        let first = gather::direct_radiance(&self.scene, &self.tracer, &reader.emitters, &at, 1);
        [0, 1, 2].map(|ch| solved[ch].max(0.0) + first[ch])
    }

    /// The directional radiance L_{q→s} that glossy surface `q` sends from
    /// its point `y` towards point `x` of surface `s`, on top of its element
    /// radiance (the light its non-Lambertian lobes reflect): the values of
    /// the element pairs (a ∋ y, b), smooth over the receiver's elements b
    /// around `x` (a gather integrates over y already, so only x needs the
    /// smoothing); zero where the solve made no structure (q, s).
    pub fn directional_radiance(&self, q: u32, y: DVec3, s: u32, x: DVec3) -> Rgb {
        let surface = &self.scene.surfaces[q as usize];
        let uv_y = surface.patch.clamp_param(surface.patch.param_of(y));
        let Some(&index) = self.interactions.structure_of.get(&(q, s)) else {
            return [0.0; 3];
        };
        let receiver = &self.scene.surfaces[s as usize].patch;
        let uv_x = receiver.param_of(x);
        let depth = self.settings.three_point_refine().receiver_max_level;
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
        };
        let probes: Vec<PixelProbe> = (0..9).map(|i| probe(u32::from(i < 3))).collect();
        let settings = RenderSettings::default();
        let rays = |px, py| camera_rays(&probes, &film, (px, py), &settings);
        for px in 0..3 {
            assert_eq!(rays(px, 0), settings.emitter_edge_samples_per_pixel);
            assert_eq!(rays(px, 1), settings.emitter_edge_samples_per_pixel);
            assert_eq!(rays(px, 2), settings.interior_samples_per_pixel);
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
        let interior = settings.interior_samples_per_pixel as usize;
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
                gather_spp * settings.gather_rays,
                "gather spp {gather_spp}"
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
                s.interior_samples_per_pixel,
                s.gather_samples_per_pixel
            ),
            (4096, 1024, 128)
        );
        assert_eq!(s.mode, default.mode);
    }
}
