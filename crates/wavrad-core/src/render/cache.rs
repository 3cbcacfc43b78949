//! The final gather made view-independent: on every parallelogram surface
//! with a Lambertian lobe (diffuse ones, and the Lambertian lobe of glossy
//! ones such as Ward's), a grid of texels each holding the radiance one
//! final gather at its centre finds for that lobe (emission, the light
//! straight from the emitters, the rest of the solution, as a per-pixel
//! final gather finds it), read back with bilinear interpolation between
//! texel centres.
//!
//! Light a Lambertian lobe reflects does not depend on the view, so a
//! gather made once serves every view of the solution: a walkthrough pays
//! for the gathers once and per view only for its camera rays and the
//! other lobes of glossy surfaces (gathered per camera ray, their radiance
//! depending on the view). The price is resolution: light varying within a
//! texel (a sharp shadow's edge) is blurred over it, where a per-pixel
//! gather resolves it at any distance. Texels are one size on every
//! surface, half the largest surface's finest elements (at most 128 per
//! side), and each gathers with half the indirect rays of one interior
//! pixel's gathers together, jointly stratified (a camera ray blends four
//! texels, so each needs fewer).
//!
//! A view close to a surface shows each texel over many pixels, and the
//! noise of its gather as a blotch. The indirect part of the gathers,
//! which varies slowly except near other geometry, is therefore averaged
//! over each texel's 3 × 3 neighbours where they lie well within the
//! gathers' reach ([`super::gather::Indirect::reach`]); the direct part
//! stays sharp. A larger window, or one ignoring the reach (which blurs the
//! ceiling's strip beside the light, which hangs 1 cm below it), does worse.

use super::gather::GatherPoint;
use super::reader::{FinalGather, GatherBudget, SolutionReader};
use super::{RenderSettings, GATHER_GRID, GATHER_RAYS};
use crate::kernel::exposure::is_buried;
use crate::sampling::{seeded, Samples};
use crate::scene::{Patch, Rgb};
use crate::solve::Solution;
use glam::DVec2;
use rayon::prelude::*;

/// Most texels per side of one surface's grid.
const MAX_SIDE: usize = 128;

/// Texels on either side whose indirect light each texel's averages.
const INDIRECT_RADIUS: usize = 1;

/// Fraction of a gather's reach within which its indirect light is
/// averaged with a neighbour's.
const INDIRECT_REACH: f64 = 0.1;

/// Gathered radiance at texel centres of each diffuse parallelogram.
#[derive(Debug, Clone, Default)]
pub struct GatherCache {
    /// Per surface: `None` where not cached (glossy surfaces, triangles).
    grids: Vec<Option<Grid>>,
}

/// A `side` × `side` grid of texels over a surface's parameter square,
/// row by row; `None` for a texel whose centre is buried (under a box
/// standing on the floor), which interpolation leaves out.
#[derive(Debug, Clone)]
struct Grid {
    side: usize,
    texels: Vec<Option<Rgb>>,
}

impl GatherCache {
    /// Gather at every texel centre of every diffuse parallelogram of
    /// `solution`, in parallel (the result does not depend on the number
    /// of threads: each texel's samples are its own). Each texel takes half
    /// the indirect rays and as many shadow rays as an interior pixel's
    /// gathers of `settings` do together, and caustic receivers
    /// [`CAUSTIC_GATHERS`](super::CAUSTIC_GATHERS) times as many.
    pub(super) fn build(
        solution: &Solution,
        reader: &SolutionReader,
        settings: &RenderSettings,
    ) -> GatherCache {
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
            width(s) / (2usize << solution.trees[s].depth()).min(MAX_SIDE) as f64
        });
        let sides: Vec<usize> = (0..scene.surfaces.len())
            .map(|s| match cached(s) {
                true => ((width(s) / texel).ceil() as usize).clamp(1, MAX_SIDE),
                false => 0,
            })
            .collect();
        let texels: Vec<(usize, usize)> = (0..sides.len())
            .flat_map(|s| (0..sides[s] * sides[s]).map(move |t| (s, t)))
            .collect();
        let values: Vec<Option<FinalGather>> = texels
            .par_iter()
            .map(|&(s, t)| {
                let surface = &scene.surfaces[s];
                let side = sides[s];
                let uv = DVec2::new(
                    ((t % side) as f64 + 0.5) / side as f64,
                    ((t / side) as f64 + 0.5) / side as f64,
                );
                let position = surface.patch.point_at(uv);
                let ctx = solution.kernel_context();
                if is_buried(&ctx, s as u32, position, surface.patch.normal()) {
                    return None;
                }
                let gathers = settings
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
                    samples: Samples::pixel(seeded((s as u64) << 40 ^ t as u64, settings.seed), 0),
                    shape: None,
                };
                let budget = GatherBudget { rays, shadow_grid };
                Some(reader.final_gather_parts(solution, &point, budget))
            })
            .collect();
        let mut values = values.into_iter();
        let grids = (sides.iter().zip(&scene.surfaces))
            .map(|(&side, surface)| {
                (side > 0).then(|| {
                    let gathered: Vec<_> = values.by_ref().take(side * side).collect();
                    Grid {
                        side,
                        texels: smooth_indirect(&gathered, side, &surface.patch),
                    }
                })
            })
            .collect();
        GatherCache { grids }
    }

    /// Radiance of `surface` at parameter `uv`, bilinear between the four
    /// nearest texel centres (linear extrapolation in the half texel beyond
    /// the outermost ones, as the smooth reconstruction does at edges);
    /// where some of the four are buried, a blend of the others. `None`
    /// where the surface is not cached or all four are buried.
    pub fn radiance(&self, surface: u32, uv: DVec2) -> Option<Rgb> {
        let grid = self.grids.get(surface as usize)?.as_ref()?;
        let n = grid.side;
        let at = |x: f64| {
            let x = (x * n as f64 - 0.5).clamp(-0.5, n as f64 - 0.5);
            let i = (x.max(0.0).floor() as usize).min(n.saturating_sub(2));
            (i, x - i as f64)
        };
        let ((i, fx), (j, fy)) = (at(uv.x), at(uv.y));
        let corners = [(0, 0), (1, 0), (0, 1), (1, 1)]
            .map(|(di, dj)| grid.texels[(j + dj).min(n - 1) * n + (i + di).min(n - 1)]);
        let blend = |fx: f64, fy: f64| {
            let weights = [
                (1.0 - fx) * (1.0 - fy),
                fx * (1.0 - fy),
                (1.0 - fx) * fy,
                fx * fy,
            ];
            let (mut sum, mut total) = (Rgb::ZERO, 0.0);
            for (l, w) in corners.iter().zip(weights) {
                if let Some(l) = l {
                    sum += *l * w;
                    total += w;
                }
            }
            (total > 0.0).then(|| sum.map(|x| (x / total).max(0.0)))
        };
        match corners.iter().all(Option::is_some) {
            true => blend(fx, fy),
            false => blend(fx.clamp(0.0, 1.0), fy.clamp(0.0, 1.0)),
        }
    }

    /// Texels gathered (buried ones excluded).
    pub fn texels(&self) -> usize {
        self.grids
            .iter()
            .flatten()
            .map(|g| g.texels.iter().flatten().count())
            .sum()
    }
}

/// Texel radiances from the gathers of a `side` × `side` grid over
/// `patch`: each texel's direct light as gathered, its indirect light
/// averaged over the texels within [`INDIRECT_RADIUS`] of it that lie
/// within [`INDIRECT_REACH`] of both gathers' reach
/// ([`gather::Indirect::reach`]: nearby geometry, a corner or an occluder
/// just above, keeps the average local), fewer towards the grid's edges so
/// that the window stays centred on the texel and a linear variation keeps
/// its value; buried texels left out.
fn smooth_indirect(
    gathered: &[Option<FinalGather>],
    side: usize,
    patch: &Patch,
) -> Vec<Option<Rgb>> {
    let centre = |i: usize, j: usize| {
        let uv = DVec2::new(
            (i as f64 + 0.5) / side as f64,
            (j as f64 + 0.5) / side as f64,
        );
        patch.point_at(uv)
    };
    (0..side * side)
        .map(|t| {
            let own = gathered[t]?;
            let (i, j) = (t % side, t / side);
            let (ri, rj) = (
                INDIRECT_RADIUS.min(i).min(side - 1 - i),
                INDIRECT_RADIUS.min(j).min(side - 1 - j),
            );
            let here = centre(i, j);
            let (mut sum, mut count) = (Rgb::ZERO, 0.0);
            for y in j - rj..=j + rj {
                for x in i - ri..=i + ri {
                    let Some(g) = gathered[y * side + x] else {
                        continue;
                    };
                    let near = INDIRECT_REACH * own.indirect.reach.min(g.indirect.reach);
                    if (centre(x, y) - here).length() <= near {
                        sum += g.indirect.radiance;
                        count += 1.0;
                    }
                }
            }
            Some(own.direct + sum / count)
        })
        .collect()
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
        let cache_with = |brdf: crate::scene::brdf::Brdf| {
            let mut scene = scene.clone();
            scene.surfaces[0].brdf = brdf;
            let solution = solve(&scene, &SolveSettings::default(), &Silent).unwrap();
            let reader = SolutionReader::new(&solution);
            GatherCache::build(&solution, &reader, &RenderSettings::default())
        };
        let (floor, light) = (&scene.surfaces[0].patch, &scene.surfaces[1].patch);
        for (brdf, rho) in [
            (crate::scene::brdf::Brdf::diffuse(Rgb::splat(0.5)), 0.5),
            (crate::testing::rolled_aluminium(), 0.1),
        ] {
            let cache = cache_with(brdf);
            assert!(cache.texels() > 1000, "{} texels", cache.texels());
            let mut worst: f64 = 0.0;
            for k in 0..400 {
                let uv = crate::sampling::hash2(11, k);
                let x = floor.point_at(uv);
                let expect =
                    rho * point_to_polygon(x, floor.normal(), &light.vertices(), light.normal());
                let got = cache.radiance(0, uv).expect("cached")[0];
                worst = worst.max((got - expect).abs() / expect);
            }
            assert!(worst < 0.005, "ρ {rho}: worst relative error {worst}");
        }
        let conductor = crate::scene::brdf::Brdf::RoughConductor(Default::default());
        assert_eq!(cache_with(conductor).radiance(0, DVec2::splat(0.5)), None);
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
        for (t, out) in smooth_indirect(&ramp, side, &patch).iter().enumerate() {
            let expect = ramp[t].unwrap().indirect.radiance[0];
            assert!((out.unwrap()[0] - expect).abs() < 1e-12, "texel {t}");
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
        let out = smooth_indirect(&noisy, side, &patch);
        let (i, j) = (8, 9);
        let interior = out[j * side + i].unwrap()[0] - (j % 2) as f64;
        assert!((interior - (5.0 - 1.0 / 9.0)).abs() < 1e-12, "{interior}");
        assert_eq!(out[5 * side + 5].unwrap()[0], 1.0 + 6.0);
        // Its neighbours leave it out: (6, 5) averages its other 8 texels,
        // five at −1 (itself and the corners) and three at +1.
        assert!((out[5 * side + 6].unwrap()[0] - (1.0 + 5.0 - 2.0 / 8.0)).abs() < 1e-12);
    }
}
