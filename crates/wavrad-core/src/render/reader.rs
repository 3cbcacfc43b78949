//! What final gathers read from a solution ([`SolutionReader`]), built once
//! per solution by its [`super::Renderer`], and the final gather over it.

use super::discrete::SurfaceDistribution;
use super::emitters::Emitters;
use super::gather::{self, GatherPoint};
use super::link_guide::LinkGuide;
use super::mirror::MirrorImages;
use super::reconstruct::{directional_radiance, TreeLookup};
use super::{BRIGHT_SHARE, GATHER_GRID, GATHER_RAYS, GLOSSY_GRID, GLOSSY_SHARE_LINKED};
use crate::sampling::Samples;
use crate::scene::brdf::Brdf;
use crate::scene::brdf::{BrdfFlags, BrdfModel};
use crate::scene::Rgb;
use crate::solve::cluster_gather::FarField;
use crate::solve::glossy_clusters::{bin_of, NO_BIN};
use crate::solve::{bounces, Solution};
use glam::DVec3;
use rayon::prelude::*;

/// What gather rays read from a solution on diffuse surfaces: the radiance
/// of the element they hit (piecewise constant; the bilinear reconstruction
/// is what camera rays show; both through each tree's `lookup`); on a
/// surface marked `per_point`, that element's value of `rest` (the
/// solution's radiance less its first bounce, [`Solution::first_bounce`],
/// and emission) plus its emission and the light reflected straight from
/// the `emitters` evaluated at the point hit.
///
/// A gather averages what it reads over many elements, so the smooth
/// reconstruction gains it nothing, and near a concave edge, where the
/// nearby surface fills much of a gather's hemisphere, its linear
/// extrapolation at the boundary overshoots.
///
/// A final gather's bias is the error of what its rays read. On a strongly
/// lit diffuse surface ([`secondary_sources`]) that reflects over half of
/// the scene's light, that is the first bounce, which its elements average
/// over (Figure 3's reflector, which alone lights the receiver); so it is
/// wherever a ray meets a surface within [`NEAR_ELEMENTS`] element widths
/// of its start. Elsewhere evaluating the first bounce per point changes
/// nothing measurable and costs a shadow ray per gather sample.
///
/// `non_lambertian` is, for a glossy surface whose BRDF has a Lambertian
/// lobe besides others (Ward's), the rest of its BRDF: camera rays meeting
/// it in the final gather see the Lambertian lobe's light as a diffuse
/// surface's (cached or gathered by some of the pixel's rays, its element
/// radiance the control variate) and gather only the rest per ray.
///
/// It also knows where a gather looks for concentrated light besides its
/// cosine rays ([`gather::GatherSources`]): the `bright` surfaces, the
/// emitters' `mirrors` images, and the `caustic` receivers they light; and
/// the `emitters`, by power (emission, the mean of the channels, times
/// area), from which shadow rays and glossy points' light samples draw.
///
/// `rest` is, per surface with a Lambertian lobe, its elements' radiance
/// less their emission and first bounce ([`Solution::first_bounce`]): what
/// a camera ray's final gather estimates beyond the light straight from the
/// emitters, smooth where the solution is, its control variate. Where the
/// scene limits the path length ([`bounces`]), it is the elements'
/// reflection of the solution ([`Solution::reflection_of`]) less their
/// first bounce: what that gather then estimates; and `hit_rest` is then
/// the elements' radiance less their emission and first bounce, what a
/// gather ray reads beyond the first bounce it evaluates per point.
///
/// On a textured surface, what a gather ray reads of an element's
/// reflected light is scaled by the texture where it lands
/// ([`super::texture_factor`]), and a glossy one reflects with its
/// Lambertian lobe's albedo there.
pub(super) struct SolutionReader {
    pub(super) lookup: Vec<TreeLookup>,
    pub(super) non_lambertian: Vec<Option<Brdf>>,
    per_point: Vec<bool>,
    pub(super) emitters: Emitters,
    pub(super) bright: SurfaceDistribution,
    mirrors: MirrorImages,
    pub(super) caustic: Vec<bool>,
    links: LinkGuide,
    rest: Vec<Option<Vec<Rgb>>>,
    /// Where the scene limits the path length ([`bounces`]), `rest` as
    /// gather rays read it; `None` where that is `rest` itself.
    hit_rest: Option<Vec<Option<Vec<Rgb>>>>,
    /// The glossy surfaces' light per bin ([`crate::solve::glossy_clusters`]),
    /// read towards receivers they have no directional structure for.
    lobes: FarField,
}

/// What a final gather finds at a point, in two parts: light that varies as
/// sharply as shadows do, and light that varies smoothly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct FinalGather {
    /// Emission and the light straight from the emitters.
    pub(super) direct: Rgb,
    /// Light from the rest of the solution.
    pub(super) indirect: gather::Indirect,
}

/// A point of a surface: either end of a gather ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SurfacePoint {
    /// Surface the point is on.
    pub(super) surface: u32,
    /// The point.
    pub(super) position: DVec3,
}

impl From<&GatherPoint> for SurfacePoint {
    fn from(point: &GatherPoint) -> SurfacePoint {
        SurfacePoint {
            surface: point.surface,
            position: point.position,
        }
    }
}

/// The rays a final gather casts: `rays` cosine rays' worth of indirect
/// samples, and `shadow_grid` × `shadow_grid` shadow rays to the emitters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct GatherBudget {
    pub(super) rays: u32,
    pub(super) shadow_grid: u32,
}

impl FinalGather {
    pub(super) fn total(&self) -> Rgb {
        self.direct + self.indirect.radiance
    }
}

/// Per diffuse surface, the light each emitter brings it through the
/// solution's two-point links (visibility included): (emitter surface,
/// Le · F · |a| summed over the links into its elements a), for
/// [`Emitters::with_received`]. None for a glossy surface, whose light
/// samples go where its lobe reflects the emitters, which the links'
/// diffuse transfer does not say (`docs/decisions-measurements.md`,
/// "Shadow rays drawn by the light the links bring").
fn received_from_emitters(solution: &Solution) -> Vec<Vec<(u32, f64)>> {
    let surfaces = &solution.scene.surfaces;
    (0..surfaces.len())
        .map(|p| {
            let glossy = surfaces[p]
                .brdf
                .flags()
                .contains(BrdfFlags::GLOSSY_REFLECTION);
            if glossy {
                return Vec::new();
            }
            let mut by_emitter = std::collections::BTreeMap::<u32, f64>::new();
            let incoming = solution.interactions.incoming.get(p);
            for t in incoming.map_or(&[][..], |t| &t[..]) {
                let (e, _) = t.source.element();
                let emitter = &surfaces[e as usize];
                if emitter.is_emitter() {
                    let area = solution.trees[p].nodes[t.receiver as usize].patch.area();
                    *by_emitter.entry(e).or_default() +=
                        emitter.emission.average() * t.form_factor * area;
                }
            }
            by_emitter.into_iter().collect()
        })
        .collect()
}

impl SolutionReader {
    /// What final gathers read from `solution` (view-independent).
    pub(super) fn new(solution: &Solution) -> SolutionReader {
        let surfaces = &solution.scene.surfaces;
        // Emitters by power: emission (mean of the channels) times area;
        // for a point on a surface, mostly by the light they bring it.
        let emitters = Emitters::new(
            &solution.scene,
            (surfaces.iter().enumerate())
                .filter(|(_, s)| s.is_emitter())
                .map(|(e, s)| (e as u32, s.emission.average() * s.patch.area()))
                .collect(),
        )
        .with_received(received_from_emitters(solution));
        let glossy: Vec<u32> = (0..surfaces.len() as u32)
            .filter(|&s| {
                surfaces[s as usize]
                    .brdf
                    .flags()
                    .contains(BrdfFlags::GLOSSY_REFLECTION)
            })
            .collect();
        let bright = secondary_sources(solution, &glossy);
        let mirrors = MirrorImages::of_scene(&solution.scene, &glossy, emitters.surfaces());
        let caustic = (0..surfaces.len())
            .map(|s| (mirrors.images().iter()).any(|m| m.lights(&solution.scene, s as u32)))
            .collect();
        // A strongly lit diffuse surface that reflects most of the scene's
        // light shows gather rays its first bounce per point.
        let power = reflected_power(solution);
        let total: f64 = power.iter().sum();
        let mut per_point = vec![false; surfaces.len()];
        for s in (bright.surfaces().iter().map(|&s| s as usize)).filter(|&s| power[s] > 0.5 * total)
        {
            per_point[s] = true;
        }
        // The glossy surfaces' light per bin, from the solution (twice:
        // glossy light through cluster links between glossy surfaces
        // arrives a far field late).
        let state = (&solution.radiance[..], &solution.directional[..]);
        let (interactions, trees) = (&solution.interactions, &solution.trees);
        let once = interactions
            .far_field(&solution.scene, trees, state, None)
            .lobes();
        let lobes = (interactions.far_field(&solution.scene, trees, state, Some(&once))).lobes();
        let first = solution.first_bounce();
        let non_lambertian = surfaces
            .iter()
            .map(|s| {
                match (
                    !s.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION),
                    s.brdf.lambertian(),
                ) {
                    (false, Some(_)) => Some(s.brdf.shading_rest()),
                    _ => None,
                }
            })
            .collect();
        // With a bounce limit the solution holds the light that reaches the
        // visible points' gathers, and what they gather is one reflection
        // of it: the elements' share of that is the rest's.
        let reflected = match bounces(&solution.scene) {
            Some(_) => solution.reflection_of(&solution.radiance, &solution.directional),
            None => None,
        };
        // Each surface's `radiance` (emission included when `emitting`)
        // less its first bounce, where it has one.
        let less_first = |radiance: &[Vec<Rgb>], emitting: bool| -> Vec<Option<Vec<Rgb>>> {
            match &first {
                Some(first) => (first.par_iter().enumerate())
                    .map(|(s, first)| {
                        let emission = match emitting {
                            true => surfaces[s].emission,
                            false => Rgb::ZERO,
                        };
                        (!first.is_empty()).then(|| {
                            (radiance[s].iter().zip(first))
                                .map(|(&l, &f)| l - f - emission)
                                .collect()
                        })
                    })
                    .collect(),
                None => vec![None; surfaces.len()],
            }
        };
        let (rest, hit_rest) = match &reflected {
            Some(reflected) => (
                less_first(reflected, false),
                Some(less_first(&solution.radiance, true)),
            ),
            None => (less_first(&solution.radiance, true), None),
        };
        SolutionReader {
            lookup: solution.trees.par_iter().map(TreeLookup::new).collect(),
            non_lambertian,
            per_point,
            emitters,
            bright,
            mirrors,
            caustic,
            // Only glossy sources make a gather draw from the links.
            links: match glossy.is_empty() {
                true => LinkGuide::default(),
                false => LinkGuide::new(solution),
            },
            rest,
            hit_rest,
            lobes,
        }
    }

    /// Surface `s`'s elements' radiance beyond its emission and first
    /// bounce (see [`SolutionReader`]); `None` for a surface without a
    /// Lambertian lobe, or while the solution's links are not arranged.
    pub(super) fn rest(&self, s: usize) -> Option<&[Rgb]> {
        self.rest[s].as_deref()
    }

    /// Radiance leaving the diffuse `point` (view-independent): its emission,
    /// the light straight from the emitters (the `budget`'s shadow rays,
    /// [`gather::direct_radiance`]) and its cosine rays' worth of the rest of
    /// the solution, with a square grid of about a [`BRIGHT_SHARE`]-th as
    /// many samples of the bright surfaces together, and as many as it has
    /// cosine rays of the mirror images together
    /// ([`gather::indirect_radiance`]; each costs a shadow ray and, on a
    /// glossy surface, a glossy evaluation), or where that is fewer, a
    /// [`GATHER_GRID`]² grid's worth for each of a few bright surfaces, up
    /// to [`GATHER_RAYS`] (what cosine rays miss is concentrated: a gather
    /// with few cosine rays still needs a few samples of each such surface);
    /// and where glossy sources bring much of its light, as many samples of
    /// its links' source elements as it has cosine rays ([`LinkGuide`]).
    pub(super) fn final_gather(
        &self,
        solution: &Solution,
        point: &GatherPoint,
        budget: GatherBudget,
    ) -> Rgb {
        self.final_gather_parts(solution, point, budget).total()
    }

    /// [`SolutionReader::final_gather`] in its two parts.
    pub(super) fn final_gather_parts(
        &self,
        solution: &Solution,
        point: &GatherPoint,
        GatherBudget { rays, shadow_grid }: GatherBudget,
    ) -> FinalGather {
        let (scene, tracer) = (&solution.scene, &solution.tracer);
        let indirect = self.indirect_gather(solution, point, rays);
        let direct = gather::direct_radiance(scene, tracer, &self.emitters, point, shadow_grid);
        FinalGather {
            direct: scene.surfaces[point.surface as usize].emission + direct,
            indirect,
        }
    }

    /// The indirect part of [`SolutionReader::final_gather`]: `rays` cosine
    /// rays' worth of the solution's light less emission, with the samples
    /// of its bright surfaces, mirror images and links.
    pub(super) fn indirect_gather(
        &self,
        solution: &Solution,
        point: &GatherPoint,
        rays: u32,
    ) -> gather::Indirect {
        let (scene, tracer) = (&solution.scene, &solution.tracer);
        let grid = f64::from(rays).sqrt().round() as u32;
        let bright = self.bright.surfaces().len() as u32;
        let few = (GATHER_GRID * GATHER_GRID).saturating_mul(bright);
        let surface = &scene.surfaces[point.surface as usize];
        let uv = surface
            .patch
            .clamp_param(surface.patch.param_of(point.position));
        let i = point.surface as usize;
        let linked = self.links.at(
            point.surface,
            self.lookup[i].locate(&solution.trees[i], uv).0,
        );
        let sources = gather::GatherSources {
            bright: &self.bright,
            mirrors: &self.mirrors,
            bright_count: (grid * grid / BRIGHT_SHARE).max(few.min(GATHER_RAYS)),
            mirror_count: (grid * grid).max(few.min(GATHER_RAYS)),
            linked,
            linked_count: match linked.glossy_share() >= GLOSSY_SHARE_LINKED {
                true => grid * grid,
                false => 0,
            },
        };
        let to = SurfacePoint::from(point);
        let seed = point.samples.seed();
        gather::indirect_radiance(scene, tracer, point, rays, sources, |q, y| {
            let from = SurfacePoint {
                surface: q,
                position: y,
            };
            let l = self.radiance_leaving(solution, from, to, seed, GLOSSY_GRID);
            (l - scene.surfaces[q as usize].emission).map(|x| x.max(0.0))
        })
    }

    /// Radiance leaving point `from` towards point `to`, as a gather ray
    /// from `to` sees it: the solution's on a diffuse surface; on a glossy
    /// one, the light its BRDF reflects there evaluated per point (emitters
    /// exactly, the rest from the solution, `grid` × `grid` samples of
    /// each; [`gather::glossy_radiance`]), because a highlight's
    /// sharp edge, and the light near a contact line, are finer than the
    /// pair tree's elements; under a bounce limit ([`bounces`]) only where
    /// the solution holds one reflection, the source then reflecting only
    /// the emitters, and elsewhere the solution's, as on a diffuse surface.
    /// `seed`, the gather's, is decorrelated per point `from`.
    pub(super) fn radiance_leaving(
        &self,
        solution: &Solution,
        from: SurfacePoint,
        to: SurfacePoint,
        seed: u64,
        grid: u32,
    ) -> Rgb {
        let (q, y) = (from.surface, from.position);
        let source = &solution.scene.surfaces[q as usize];
        // Decorrelated per point y: every ray of one gather has its own.
        let bits = y.x.to_bits() ^ y.y.to_bits().rotate_left(21) ^ y.z.to_bits().rotate_left(42);
        let seed = seed.rotate_left(17) ^ u64::from(q) ^ bits;
        // Under a bounce limit, a glossy source's light evaluated per point
        // is its reflection of the solution, one more than the solution
        // holds: exact where the solution holds one reflection (then the
        // source reflects only the emitters), the solution's own elsewhere.
        let limit = bounces(&solution.scene);
        let glossy = source.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION);
        if !glossy || limit.is_some_and(|b| b != 1) {
            return self.outgoing_radiance(solution, from, to, seed);
        }
        let at = GatherPoint::on(&solution.scene, q, y, Samples::Hashed(seed));
        // A texture makes the Lambertian lobe's albedo vary over the surface.
        let uv = source.patch.clamp_param(source.patch.param_of(y));
        let textured = (source.texture.is_some())
            .then(|| solution.scene.lambertian_at(q as usize, uv))
            .flatten()
            .map(|rho| source.brdf.with_lambertian(rho));
        let reflected = gather::glossy_radiance(
            &solution.scene,
            &solution.tracer,
            &self.emitters,
            &at,
            (
                textured.as_ref().unwrap_or(&source.brdf),
                (to.position - y).normalize(),
            ),
            grid,
            |h, z| {
                let hit = SurfacePoint {
                    surface: h,
                    position: z,
                };
                match limit {
                    Some(_) => solution.scene.surfaces[h as usize].emission,
                    None => self.outgoing_radiance(solution, hit, from, seed ^ u64::from(h) << 40),
                }
            },
        );
        source.emission + reflected
    }

    /// Radiance the solution says leaves point `from` towards point `to`:
    /// the radiance of the element at `from`, plus on a glossy surface its
    /// directional radiance towards `to` ([`directional_radiance`]); `seed`
    /// draws the shadow rays of a first bounce evaluated per point.
    fn outgoing_radiance(
        &self,
        solution: &Solution,
        from: SurfacePoint,
        to: SurfacePoint,
        seed: u64,
    ) -> Rgb {
        let (q, y) = (from.surface, from.position);
        let surface = &solution.scene.surfaces[q as usize];
        let uv_y = surface.patch.clamp_param(surface.patch.param_of(y));
        let (i, tree) = (q as usize, &solution.trees[q as usize]);
        let leaf = self.lookup[i].locate(tree, uv_y).0 as usize;
        // The leaf's value of `values` (of which `emission` is not
        // reflected light), scaled by the texture at y.
        let texture = super::texture_factor(solution, i, uv_y);
        let element = |values: &[Rgb], emission: Rgb| match texture {
            Some(factor) => emission + (values[leaf] - emission) * factor,
            None => values[leaf],
        };
        if surface.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION) {
            let own = element(&solution.radiance[i], surface.emission);
            let structured = (solution.interactions.structure_of).contains_key(&(q, to.surface));
            let glossy = match structured {
                true => directional_radiance(solution, q, y, to.surface, to.position),
                false => {
                    let w = surface.frame().to_local(to.position - y);
                    self.lobes.glossy(q, bin_of(w).map_or(NO_BIN, |b| b as u8))
                }
            };
            return own + glossy;
        }
        let near = (to.position - y).length_squared()
            < NEAR_ELEMENTS * NEAR_ELEMENTS * tree.nodes[leaf].patch.area();
        let hit_rest = match &self.hit_rest {
            Some(hit_rest) => hit_rest[i].as_deref(),
            None => self.rest(i),
        };
        // Under a bounce limit of no reflection (`max_depth` 2) the
        // gathered point's light is its emission alone: its first bounce
        // would be a reflection beyond the path's last.
        let reflects = bounces(&solution.scene) != Some(0);
        let (true, Some(rest)) = (reflects && (self.per_point[i] || near), hit_rest) else {
            return element(&solution.radiance[i], surface.emission);
        };
        let solved = element(rest, Rgb::ZERO) + surface.emission;
        let at = GatherPoint::on(&solution.scene, q, y, Samples::Hashed(seed));
        let first =
            gather::direct_radiance(&solution.scene, &solution.tracer, &self.emitters, &at, 1);
        solved.map(|x| x.max(0.0)) + first
    }
}

/// A gather ray that meets a diffuse surface within this many element
/// widths of where it starts reads the first bounce there per point (see
/// [`SolutionReader`]): that close, the gather's kernel varies across the
/// element it hits, which its average then misweighs (the floor at the
/// foot of a box, where the box's shadow begins).
const NEAR_ELEMENTS: f64 = 3.0;

/// Per surface, the light its diffuse solution reflects: average radiance
/// (mean of the channels) times area, zero for emitters and glossy
/// surfaces.
fn reflected_power(solution: &Solution) -> Vec<f64> {
    (solution.scene.surfaces.iter().enumerate())
        .map(|(s, surface)| {
            match !surface.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION)
                && !surface.is_emitter()
            {
                // Never below zero, even from a crafted solution file.
                true => solution.radiance[s][0].average().max(0.0) * surface.patch.area(),
                false => 0.0,
            }
        })
        .collect()
}

/// The surfaces a diffuse point's final gather samples by area besides its
/// cosine rays: every `glossy` one (its reflected light is concentrated in
/// its lobes) and every diffuse non-emitter whose average radiance is over
/// four times the area-weighted mean of all non-emitters (a small, strongly
/// lit surface that lights the others: cosine rays rarely find it).
///
/// Each weighs alike, a diffuse one times the ratio of its average radiance
/// to that threshold: what cosine rays miss is small, so sampling the
/// surfaces alike rather than by area samples the small ones densest (by
/// area, the glossy Cornell box's floor, which cosine rays find anyway,
/// took most of the samples and the image was noisier).
fn secondary_sources(solution: &Solution, glossy: &[u32]) -> SurfaceDistribution {
    let surfaces = &solution.scene.surfaces;
    let power = reflected_power(solution);
    let lit = |s: usize| {
        !surfaces[s]
            .brdf
            .flags()
            .contains(BrdfFlags::GLOSSY_REFLECTION)
            && !surfaces[s].is_emitter()
    };
    let area = |s: usize| surfaces[s].patch.area();
    let n = surfaces.len();
    let total_area: f64 = (0..n).filter(|&s| lit(s)).map(area).sum();
    let threshold = 4.0 * power.iter().sum::<f64>() / total_area.max(f64::MIN_POSITIVE);
    let mut weighted: Vec<(u32, f64)> = glossy.iter().map(|&s| (s, 1.0)).collect();
    weighted.extend(
        (0..n)
            .filter(|&s| lit(s) && power[s] > threshold * area(s))
            .map(|s| (s as u32, power[s] / (threshold * area(s)))),
    );
    SurfaceDistribution::new(weighted)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Silent;
    use crate::scene::{Patch, Scene};
    use crate::solve::{solve, SolveSettings};
    use crate::testing::{grey, light_over_a_corner};

    /// A grey unit floor under a low light over its corner, and a grey
    /// wall standing on the floor beside the light, facing it, solved under
    /// the bounce limit `max_depth`; and a gather ray from the wall's foot
    /// to a floor point close by: (from, to).
    fn wall_on_a_lit_floor(max_depth: u32) -> (Solution, SurfacePoint, SurfacePoint) {
        let mut surfaces = light_over_a_corner(0.1).surfaces;
        surfaces.push(grey(Patch::Parallelogram {
            origin: DVec3::new(0.3, 0.0, 0.0),
            edge_s: DVec3::Z * 0.5,
            edge_t: DVec3::Y,
        }));
        let mut scene = Scene::from_surfaces(surfaces);
        scene.hints.max_depth = Some(max_depth);
        let solution = solve(&scene, &SolveSettings::default(), &Silent).unwrap();
        let from = SurfacePoint {
            surface: 0,
            position: DVec3::new(0.25, 0.1, 0.0),
        };
        let to = SurfacePoint {
            surface: 2,
            position: DVec3::new(0.3, 0.1, 0.03),
        };
        (solution, from, to)
    }

    #[test]
    fn under_a_bounce_limit_gather_rays_read_the_first_bounce_per_point_close_by() {
        // Paths of three segments: the wall's gathers see the floor's first
        // bounce, which is all the floor's elements hold, and which
        // varies steeply within each of them here.
        let (solution, from, to) = wall_on_a_lit_floor(3);
        let reader = SolutionReader::new(&solution);
        let floor = from.position;
        let at = |seed| GatherPoint::on(&solution.scene, 0, floor, Samples::Hashed(seed));
        let (scene, tracer) = (&solution.scene, &solution.tracer);
        let exact = gather::direct_radiance(scene, tracer, &reader.emitters, &at(1), 64)[0];
        let n = 16u32;
        let read = (0..n)
            .map(|seed| reader.radiance_leaving(&solution, from, to, seed.into(), GLOSSY_GRID)[0])
            .sum::<f64>()
            / f64::from(n);
        let tree = &solution.trees[0];
        let leaf = reader.lookup[0]
            .locate(tree, tree.nodes[0].patch.param_of(floor))
            .0;
        let element = solution.radiance[0][leaf as usize][0];
        eprintln!("exact {exact}, read {read}, element {element}");
        assert!(
            (read - exact).abs() < 0.01 * exact,
            "read {read}, exact {exact}"
        );
        assert!(
            (element - exact).abs() > 0.05 * exact,
            "element {element}, exact {exact}"
        );
    }

    #[test]
    fn with_no_reflection_allowed_gather_rays_read_emission_alone() {
        // Paths of two segments (`max_depth` 2, Mitsuba's `direct`): a
        // camera ray's point reflects the emitters and nothing else, so
        // what its gather rays meet sends it nothing, however close by
        // and however brightly lit.
        let (solution, from, to) = wall_on_a_lit_floor(2);
        let reader = SolutionReader::new(&solution);
        for seed in 0..8u64 {
            let read = reader.radiance_leaving(&solution, from, to, seed, GLOSSY_GRID);
            assert_eq!(read, Rgb::ZERO, "seed {seed}");
        }
        // The floor is lit there: under a limit of three segments, the same
        // ray reads its first bounce.
        let (solution, from, to) = wall_on_a_lit_floor(3);
        let reader = SolutionReader::new(&solution);
        assert!(reader.radiance_leaving(&solution, from, to, 0, GLOSSY_GRID)[0] > 0.0);
    }
}
