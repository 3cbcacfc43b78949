//! The final gather made view-independent (Ward, Rubinstein & Clear's
//! irradiance cache, SIGGRAPH 1988, on a grid): on every parallelogram
//! surface with a Lambertian lobe (diffuse ones, and the Lambertian lobe of
//! glossy ones such as Ward's), a grid of texels each holding what one
//! final gather at its centre finds for that lobe (emission and the light
//! straight from the emitters; the rest of the solution), read back with
//! bilinear interpolation between texel centres.
//!
//! Light a Lambertian lobe reflects does not depend on the view, so a
//! gather made once serves every pixel that shows the texel and every view
//! of the solution. A texel is gathered the first time a camera ray reads
//! it, so that a view pays only for the texels it shows (and a walkthrough
//! once for each). The price is resolution: light varying within a texel
//! is blurred over it, where a per-pixel gather resolves it at any
//! distance. So camera rays read only the indirect part from the texels,
//! and only where the texels' gathers reach ten texels or more
//! (the indirect light varies slowly there, as the irradiance cache's
//! validity radius says); they evaluate the light straight from the
//! emitters themselves, and gather per camera ray near other geometry (a
//! corner, a box standing on the floor, the ceiling beside a light that
//! hangs below it). Texels are one size on every surface, half the largest
//! surface's finest elements (32 to 128 per side), and each gathers with
//! half the indirect rays of one interior pixel's gathers together, jointly
//! stratified (a camera ray blends four texels, so each needs fewer).
//!
//! A view close to a surface shows each texel over many pixels, and the
//! noise of its gather as a blotch. The indirect part of the gathers is
//! therefore averaged over each texel's 3 × 3 neighbours where they lie
//! well within the gathers' reach ([`super::gather::Indirect::reach`]); the
//! direct part stays sharp. A larger window, or one ignoring the reach
//! (which blurs the ceiling's strip beside the light), does worse.

use super::gather::GatherPoint;
use super::reader::{FinalGather, GatherBudget, SolutionReader};
use super::{RenderSettings, GATHER_GRID, GATHER_RAYS};
use crate::kernel::exposure::is_buried;
use crate::sampling::{seeded, Samples};
use crate::scene::{Patch, Rgb};
use crate::solve::Solution;
use glam::DVec2;
use std::sync::OnceLock;

/// Most texels per side of one surface's grid.
const MAX_SIDE: usize = 128;

/// Fewest texels per side of the largest surface's grid: where the
/// solution's elements are coarse (light varying slowly), bilinear
/// interpolation between texels half their width bends too little to
/// follow the light's curvature.
const MIN_SIDE: usize = 32;

/// Texels on either side whose indirect light each texel's averages.
const INDIRECT_RADIUS: usize = 1;

/// Fraction of a gather's reach within which its indirect light is
/// averaged with a neighbour's.
const INDIRECT_REACH: f64 = 0.1;

/// Texels that the gathers around a point must reach for a camera ray to
/// read the point's indirect light from them ([`GatherCache::indirect`]):
/// closer geometry makes the light vary within a few texels
/// (`docs/decisions-measurements.md` has how it was chosen).
const FAR: f64 = 10.0;

/// The view-independent final gather over the diffuse parallelograms of a
/// solution, its texels gathered when first read.
#[derive(Debug)]
pub struct GatherCache {
    /// Per surface: its grid, `None` where not cached (glossy surfaces,
    /// triangles).
    grids: Vec<Option<Grid>>,
    /// Width of a texel (the same on every surface).
    texel: f64,
    /// The settings whose gathers' budget and seed the texels take.
    settings: RenderSettings,
}

/// A `side` × `side` grid of texels over a surface's parameter square,
/// row by row, made when first read.
#[derive(Debug)]
struct Grid {
    side: usize,
    /// Each texel's own gather; `None` for a texel whose centre is buried
    /// (under a box standing on the floor), which interpolation leaves out.
    gathered: OnceLock<Box<[OnceLock<Option<FinalGather>>]>>,
    /// Each texel as read ([`smoothed`]).
    texels: OnceLock<Box<[OnceLock<Option<Texel>>]>>,
}

/// What one texel's gather found, in its two parts.
#[derive(Debug, Clone, Copy)]
struct Texel {
    /// Emission and the light straight from the emitters.
    direct: Rgb,
    /// The rest per unit of albedo ([`super::gather::Indirect::per_albedo`]),
    /// averaged with the neighbours' ([`smoothed`]): a camera ray applies
    /// the albedo where it lands, which a texture varies within a texel.
    indirect: Rgb,
    /// The gather's reach ([`super::gather::Indirect::reach`]).
    reach: f64,
}

/// What a texel is gathered from.
#[derive(Clone, Copy)]
pub(super) struct Source<'a> {
    /// The solution gathered.
    pub(super) solution: &'a Solution,
    /// What final gathers read from it.
    pub(super) reader: &'a SolutionReader,
}

impl GatherCache {
    /// The cache of every diffuse parallelogram of `solution`, nothing
    /// gathered yet. Each texel will take half the indirect rays and as
    /// many shadow rays as an interior pixel's gathers of `settings` do
    /// together, and caustic receivers
    /// [`CAUSTIC_GATHERS`](super::CAUSTIC_GATHERS) times as many; its
    /// samples are its own, so that what it holds depends neither on the
    /// threads nor on the order of the reads.
    pub(super) fn new(solution: &Solution, settings: &RenderSettings) -> GatherCache {
        let scene = &solution.scene;
        // Texels of one size everywhere: half the finest elements of the
        // largest surface.
        let cached = |s: usize| {
            let surface = &scene.surfaces[s];
            surface.brdf.lambertian().is_some()
                && matches!(surface.patch, Patch::Parallelogram { .. })
        };
        let width = |s: usize| scene.surfaces[s].patch.area().sqrt();
        let largest = (0..scene.surfaces.len())
            .filter(|&s| cached(s))
            .max_by(|&a, &b| width(a).total_cmp(&width(b)));
        let texel = largest.map_or(1.0, |s| {
            width(s) / (2usize << solution.trees[s].depth()).clamp(MIN_SIDE, MAX_SIDE) as f64
        });
        let grids = (0..scene.surfaces.len())
            .map(|s| {
                cached(s).then(|| Grid {
                    side: ((width(s) / texel).ceil() as usize).clamp(1, MAX_SIDE),
                    gathered: OnceLock::new(),
                    texels: OnceLock::new(),
                })
            })
            .collect();
        GatherCache {
            grids,
            texel,
            settings: *settings,
        }
    }

    /// Radiance of `surface` at parameter `uv`, bilinear between the four
    /// nearest texel centres (linear extrapolation in the half texel beyond
    /// the outermost ones, as the smooth reconstruction does at edges);
    /// where some of the four are buried, a blend of the others. `None`
    /// where the surface is not cached or all four are buried.
    pub(super) fn radiance(&self, source: Source, surface: u32, uv: DVec2) -> Option<Rgb> {
        let ([direct, indirect], _) =
            self.interpolate(source, surface, uv, |t| [t.direct, t.indirect])?;
        Some(direct + albedo(source, surface, uv) * indirect)
    }

    /// The indirect part of [`GatherCache::radiance`] (the light gathered
    /// from the solution beyond emission and the light straight from the
    /// emitters, which a camera ray evaluates itself), where the texels'
    /// gathers reach [`FAR`] texels (their reaches' bilinear blend, of
    /// their inverses as each is a harmonic mean); `None` nearer
    /// other geometry, and where [`GatherCache::radiance`] is.
    pub(super) fn indirect(&self, source: Source, surface: u32, uv: DVec2) -> Option<Rgb> {
        // The reaches blended harmonically, as each is of distances, and a
        // buried texel counting as geometry at no distance: a texel whose
        // gather met geometry close by (the edge of a light hanging just
        // below the ceiling), or that lies under it, keeps its neighbours'
        // light from being read across it.
        let ([indirect, inverse_reach], buried) = self.interpolate(source, surface, uv, |t| {
            [t.indirect, Rgb::splat(1.0 / t.reach.max(f64::MIN_POSITIVE))]
        })?;
        (!buried && inverse_reach[0] * FAR * self.texel <= 1.0)
            .then(|| albedo(source, surface, uv) * indirect)
    }

    /// Parts of the texels around `uv`, blended as [`GatherCache::radiance`]
    /// says, and whether a buried texel had a share of the blend.
    fn interpolate(
        &self,
        source: Source,
        surface: u32,
        uv: DVec2,
        parts: impl Fn(&Texel) -> [Rgb; 2],
    ) -> Option<([Rgb; 2], bool)> {
        let grid = self.grids.get(surface as usize)?.as_ref()?;
        let n = grid.side;
        let at = |x: f64| {
            let x = (x * n as f64 - 0.5).clamp(-0.5, n as f64 - 0.5);
            let i = (x.max(0.0).floor() as usize).min(n.saturating_sub(2));
            (i, x - i as f64)
        };
        let ((i, fx), (j, fy)) = (at(uv.x), at(uv.y));
        let corners = [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(di, dj)| {
            let t = (j + dj).min(n - 1) * n + (i + di).min(n - 1);
            self.texel(source, surface as usize, grid, t)
                .as_ref()
                .map(&parts)
        });
        let blend = |fx: f64, fy: f64| {
            let weights = [
                (1.0 - fx) * (1.0 - fy),
                fx * (1.0 - fy),
                (1.0 - fx) * fy,
                fx * fy,
            ];
            let (mut sum, mut total, mut buried) = ([Rgb::ZERO; 2], 0.0, false);
            for (l, w) in corners.iter().zip(weights) {
                match l {
                    Some(l) => {
                        sum[0] += l[0] * w;
                        sum[1] += l[1] * w;
                        total += w;
                    }
                    None => buried |= w > 0.0,
                }
            }
            (total > 0.0).then(|| (sum.map(|l| l.map(|x| (x / total).max(0.0))), buried))
        };
        match corners.iter().all(Option::is_some) {
            true => blend(fx, fy),
            false => blend(fx.clamp(0.0, 1.0), fy.clamp(0.0, 1.0)),
        }
    }

    /// Texel `t` of `surface`'s `grid`, its neighbours' indirect light
    /// averaged in ([`smoothed`]), gathered when first read.
    fn texel(&self, source: Source, surface: usize, grid: &Grid, t: usize) -> Option<Texel> {
        let cells = grid.texels.get_or_init(|| cells(grid.side));
        *cells[t].get_or_init(|| {
            let patch = &source.solution.scene.surfaces[surface].patch;
            smoothed(
                |t| self.gathered(source, surface, grid, t),
                t,
                grid.side,
                patch,
            )
        })
    }

    /// The final gather at texel `t`'s centre, made when first asked for.
    fn gathered(&self, source: Source, s: usize, grid: &Grid, t: usize) -> Option<FinalGather> {
        let cells = grid.gathered.get_or_init(|| cells(grid.side));
        *cells[t].get_or_init(|| {
            let Source { solution, reader } = source;
            let surface = &solution.scene.surfaces[s];
            let side = grid.side;
            let uv = DVec2::new(
                ((t % side) as f64 + 0.5) / side as f64,
                ((t / side) as f64 + 0.5) / side as f64,
            );
            let position = surface.patch.point_at(uv);
            let ctx = solution.kernel_context();
            if is_buried(&ctx, s as u32, position, surface.patch.normal()) {
                return None;
            }
            let gathers = (self.settings)
                .on_receiver(reader.caustic[s])
                .gather_samples_per_pixel
                .max(1);
            let rays = GATHER_RAYS.saturating_mul(gathers) / 2;
            // As many shadow rays as the pixel's gathers, in one grid.
            let shadow_grid = (f64::from(GATHER_GRID) * f64::from(gathers).sqrt())
                .round()
                .max(1.0) as u32;
            let point = GatherPoint {
                surface: s as u32,
                position,
                normal: surface.shading_normal(uv),
                samples: Samples::pixel(seeded((s as u64) << 40 ^ t as u64, self.settings.seed), 0),
                shape: None,
            };
            let budget = GatherBudget { rays, shadow_grid };
            Some(reader.final_gather_parts(solution, &point, budget))
        })
    }

    /// Texels of the cached surfaces (buried ones included).
    pub fn texels(&self) -> usize {
        self.grids.iter().flatten().map(|g| g.side * g.side).sum()
    }
}

/// The Lambertian albedo of `surface` at `uv` (its texture's there).
fn albedo(source: Source, surface: u32, uv: DVec2) -> Rgb {
    let scene = &source.solution.scene;
    scene
        .lambertian_at(surface as usize, uv)
        .unwrap_or(Rgb::ZERO)
}

/// `side` × `side` cells, none filled.
fn cells<T>(side: usize) -> Box<[OnceLock<T>]> {
    (0..side * side).map(|_| OnceLock::new()).collect()
}

/// Texel `t` of a `side` × `side` grid over `patch`, from the `gathered`
/// texels: its direct light as gathered, its indirect light averaged over
/// the texels within [`INDIRECT_RADIUS`] of it that lie within
/// [`INDIRECT_REACH`] of both gathers' reach ([`super::gather::Indirect::reach`]:
/// nearby geometry, a corner or an occluder just above, keeps the average
/// local), fewer towards the grid's edges so that the window stays centred
/// on the texel and a linear variation keeps its value; buried texels left
/// out.
fn smoothed(
    gathered: impl Fn(usize) -> Option<FinalGather>,
    t: usize,
    side: usize,
    patch: &Patch,
) -> Option<Texel> {
    let centre = |i: usize, j: usize| {
        let uv = DVec2::new(
            (i as f64 + 0.5) / side as f64,
            (j as f64 + 0.5) / side as f64,
        );
        patch.point_at(uv)
    };
    let own = gathered(t)?;
    let (i, j) = (t % side, t / side);
    let (ri, rj) = (
        INDIRECT_RADIUS.min(i).min(side - 1 - i),
        INDIRECT_RADIUS.min(j).min(side - 1 - j),
    );
    let here = centre(i, j);
    let (mut sum, mut count) = (Rgb::ZERO, 0.0);
    for y in j - rj..=j + rj {
        for x in i - ri..=i + ri {
            let Some(g) = gathered(y * side + x) else {
                continue;
            };
            let near = INDIRECT_REACH * own.indirect.reach.min(g.indirect.reach);
            if (centre(x, y) - here).length() <= near {
                sum += g.indirect.per_albedo;
                count += 1.0;
            }
        }
    }
    Some(Texel {
        direct: own.direct,
        indirect: sum / count,
        reach: own.indirect.reach,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::form_factor::point_to_polygon;
    use crate::progress::Silent;
    use crate::solve::{solve, SolveSettings};

    /// A floor lit by a light that reflects nothing, 0.5 above it, is lit
    /// directly and by nothing else: the cache must give ρ·Le·F(x, light)
    /// with Lambert's closed form F and ρ the albedo of the floor's
    /// Lambertian lobe (a diffuse floor's, or a Ward floor's ρ_d), between
    /// texel centres as at them; a BRDF without a Lambertian lobe is not
    /// cached.
    #[test]
    fn cached_floor_radiance_is_the_closed_form_direct_light() {
        let mut scene = crate::testing::light_over_a_corner(0.5);
        scene.surfaces[1].brdf = crate::scene::brdf::Brdf::diffuse(Rgb::ZERO);
        // Off the diagonal, so that the light is not symmetric in u and v.
        scene.surfaces[1].patch = Patch::Parallelogram {
            origin: glam::DVec3::new(0.6, 0.1, 0.5),
            edge_s: glam::DVec3::Y * 0.2,
            edge_t: glam::DVec3::X * 0.2,
        };
        let with_brdf = |brdf: crate::scene::brdf::Brdf| {
            let mut scene = scene.clone();
            scene.surfaces[0].brdf = brdf;
            scene
        };
        let (floor, light) = (&scene.surfaces[0].patch, &scene.surfaces[1].patch);
        for (brdf, rho) in [
            (crate::scene::brdf::Brdf::diffuse(Rgb::splat(0.5)), 0.5),
            (crate::testing::rolled_aluminium(), 0.1),
        ] {
            with_cache(&with_brdf(brdf), |cache, source| {
                assert!(cache.texels() > 1000, "{} texels", cache.texels());
                let mut worst: f64 = 0.0;
                for k in 0..400 {
                    let uv = crate::sampling::hash2(11, k);
                    let x = floor.point_at(uv);
                    let expect = rho
                        * point_to_polygon(x, floor.normal(), &light.vertices(), light.normal());
                    let got = cache.radiance(source, 0, uv).expect("cached")[0];
                    worst = worst.max((got - expect).abs() / expect);
                    // Nothing else is lit: no indirect light, wherever it is read.
                    let indirect = cache.indirect(source, 0, uv);
                    assert!(indirect.is_none_or(|l| l == Rgb::ZERO), "{indirect:?}");
                }
                assert!(worst < 0.005, "ρ {rho}: worst relative error {worst}");
            });
        }
        let conductor = crate::scene::brdf::Brdf::RoughConductor(Default::default());
        with_cache(&with_brdf(conductor), |cache, source| {
            assert_eq!(cache.radiance(source, 0, DVec2::splat(0.5)), None);
        });
    }

    /// `check` of the gather cache of `scene`'s default solution, with
    /// what it gathers from.
    fn with_cache(scene: &crate::scene::Scene, check: impl FnOnce(&GatherCache, Source)) {
        let solution = solve(scene, &SolveSettings::default(), &Silent).unwrap();
        let reader = SolutionReader::new(&solution);
        let cache = GatherCache::new(&solution, &RenderSettings::default());
        check(
            &cache,
            Source {
                solution: &solution,
                reader: &reader,
            },
        );
    }

    /// [`crate::testing::light_over_a_corner`]'s floor and light, with a
    /// grey wall standing on the floor's far edge (x = 1), facing it.
    fn floor_beside_a_wall() -> crate::scene::Scene {
        let scene = crate::testing::light_over_a_corner(0.5);
        let wall = crate::scene::Surface {
            patch: Patch::Parallelogram {
                origin: glam::DVec3::X,
                edge_s: glam::DVec3::Z,
                edge_t: glam::DVec3::Y,
            },
            ..scene.surfaces[0].clone()
        };
        assert!(wall.patch.normal().x < 0.0);
        let mut surfaces = scene.surfaces;
        surfaces.push(wall);
        crate::scene::Scene::from_surfaces(surfaces)
    }

    /// A floor lit by a wall standing on its far edge: camera rays read its
    /// indirect light from the cache far from the wall, where it varies
    /// slowly, and gather themselves near it (a few texels away), where
    /// it does not.
    #[test]
    fn indirect_light_is_read_only_where_the_gathers_reach_far() {
        let scene = floor_beside_a_wall();
        with_cache(&scene, |cache, source| {
            let far = cache.indirect(source, 0, DVec2::new(0.1, 0.5));
            assert!(far.is_some_and(|l| l[0] > 0.0), "{far:?}");
            let total = cache.radiance(source, 0, DVec2::new(0.1, 0.5)).unwrap();
            assert!(total[0] > far.unwrap()[0]);
            let near = DVec2::new(1.0 - 1.5 * cache.texel, 0.5);
            assert_eq!(cache.indirect(source, 0, near), None);
            assert!(cache.radiance(source, 0, near).is_some());
        });
    }

    /// A floor half under a grey panel hung a tenth of a texel above it (as
    /// the light hangs below the ceiling of a Cornell box): between a texel
    /// under the panel, buried, and one beside it, camera rays do not read
    /// the cache (the texel beside alone would give the dark under the
    /// panel its light); away from the panel they do.
    #[test]
    fn a_gather_that_met_geometry_close_by_is_not_read_across() {
        let mut texel = 0.0;
        with_cache(&crate::testing::light_over_a_corner(0.5), |cache, _| {
            texel = cache.texel;
        });
        let scene = crate::testing::light_over_a_corner(0.5);
        let panel = crate::scene::Surface {
            patch: Patch::Parallelogram {
                origin: glam::DVec3::new(0.5, 0.0, 0.1 * texel),
                edge_s: glam::DVec3::X * 0.5,
                edge_t: glam::DVec3::Y,
            },
            ..scene.surfaces[0].clone()
        };
        assert!(panel.patch.normal().z > 0.0);
        let mut surfaces = scene.surfaces;
        surfaces.push(panel);
        let scene = crate::scene::Scene::from_surfaces(surfaces);
        with_cache(&scene, |cache, source| {
            assert_eq!(cache.texel, texel);
            let grid = cache.grids[0].as_ref().unwrap();
            let texel_at = |uv: DVec2| {
                let side = grid.side as f64;
                let t = (uv.y * side).floor() * side + (uv.x * side).floor();
                cache.texel(source, 0, grid, t as usize)
            };
            // Under the panel, a texel is buried; beside it, its gather
            // reaches far.
            assert!(texel_at(DVec2::new(0.5 + texel / 2.0, 0.6)).is_none());
            let beside = texel_at(DVec2::new(0.5 - texel / 2.0, 0.6)).unwrap();
            assert!(
                beside.reach > FAR * texel,
                "{} texels",
                beside.reach / texel
            );
            assert_eq!(cache.indirect(source, 0, DVec2::new(0.5, 0.6)), None);
            assert!(cache.indirect(source, 0, DVec2::new(0.1, 0.6)).is_some());
        });
    }

    /// A checkerboard finer than the texels on that floor: two points of
    /// one texel on squares of different colours read the same light, each
    /// reflected with its own albedo.
    #[test]
    fn cached_indirect_light_takes_the_albedo_where_it_is_read() {
        use crate::scene::texture::{Texture, TextureMapping, UvTransform};
        let mut scene = floor_beside_a_wall();
        let (dark, light) = (Rgb::splat(0.2), Rgb::splat(0.6));
        scene.textures.push(Texture::Checkerboard {
            color0: light,
            color1: dark,
            to_uv: UvTransform::scale(512.0, 512.0),
        });
        scene.surfaces[0].texture = Some(TextureMapping {
            texture: 0,
            uv: [glam::Vec2::ZERO, glam::Vec2::X, glam::Vec2::Y],
        });
        // Neighbouring squares, a 1024th apart: one texel.
        let a = DVec2::new(0.1 + 0.25 / 512.0, 0.5 + 0.25 / 512.0);
        let b = a + DVec2::X / 1024.0;
        let (rho_a, rho_b) = (scene.lambertian_at(0, a), scene.lambertian_at(0, b));
        assert_eq!((rho_a, rho_b), (Some(light), Some(dark)));
        with_cache(&scene, |cache, source| {
            let at = |uv: DVec2| cache.indirect(source, 0, uv).unwrap()[0];
            let ratio = at(a) / at(b);
            assert!((ratio - 3.0).abs() < 0.05, "{ratio}");
        });
    }

    /// Indirect light varying linearly over a grid keeps its values (the
    /// windows are centred, shrinking at the edges); noise on a constant
    /// shrinks; a texel whose gather met geometry close by keeps its own
    /// value; direct light is never averaged.
    #[test]
    fn indirect_light_is_averaged_only_within_the_reach() {
        let side = 16;
        let patch = crate::testing::unit_floor();
        let texel = |direct: f64, indirect: f64, reach: f64| {
            Some(FinalGather {
                direct: Rgb::splat(direct),
                indirect: crate::render::gather::Indirect {
                    radiance: Rgb::splat(indirect),
                    per_albedo: Rgb::splat(indirect),
                    reach,
                },
            })
        };
        let ramp: Vec<_> = (0..side * side)
            .map(|t| {
                texel(
                    0.0,
                    1.0 + 0.1 * (t % side) as f64 + 0.03 * (t / side) as f64,
                    10.0,
                )
            })
            .collect();
        let total = |t: &Option<Texel>| t.map(|t| (t.direct + t.indirect)[0]).unwrap();
        for t in 0..side * side {
            let out = smoothed(|t| ramp[t], t, side, &patch);
            let expect = ramp[t].unwrap().indirect.radiance[0];
            assert!((total(&out) - expect).abs() < 1e-12, "texel {t}");
        }
        // ±1 noise in a checkerboard on a constant 5, direct light
        // alternating between rows; one texel's gather reached only 1 mm.
        let noisy: Vec<_> = (0..side * side)
            .map(|t| {
                let (i, j) = (t % side, t / side);
                let noise = if (i + j) % 2 == 0 { 1.0 } else { -1.0 };
                let reach = if t == 5 * side + 5 { 1e-3 } else { 10.0 };
                texel((j % 2) as f64, 5.0 + noise, reach)
            })
            .collect();
        let out: Vec<_> = (0..side * side)
            .map(|t| smoothed(|t| noisy[t], t, side, &patch))
            .collect();
        let (i, j) = (8, 9);
        let interior = total(&out[j * side + i]) - (j % 2) as f64;
        assert!((interior - (5.0 - 1.0 / 9.0)).abs() < 1e-12, "{interior}");
        assert_eq!(total(&out[5 * side + 5]), 1.0 + 6.0);
        // Its neighbours leave it out: (6, 5) averages its other 8 texels,
        // five at −1 (itself and the corners) and three at +1.
        assert!((total(&out[5 * side + 6]) - (1.0 + 5.0 - 2.0 / 8.0)).abs() < 1e-12);
    }
}
