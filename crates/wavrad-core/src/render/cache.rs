//! The final gather made view-independent: on every diffuse parallelogram
//! surface, a grid of texels each holding the radiance one final gather at
//! its centre finds (emission, the light straight from the emitters, the
//! rest of the solution, as a per-pixel final gather finds it), read back with
//! bilinear interpolation between texel centres.
//!
//! A diffuse surface's radiance does not depend on the view, so a gather
//! made once serves every view of the solution: a walkthrough pays for the
//! gathers once and per view only for its camera rays and its glossy
//! surfaces (which gather per camera ray, their radiance depending on the
//! view). The price is resolution: light varying within a texel (a sharp
//! shadow's edge) is blurred over it, where a per-pixel gather resolves it
//! at any distance. Texels are one size on every surface, half the largest
//! surface's finest elements (at most 128 per side), and each gathers with
//! half the indirect rays of one interior pixel's gathers together, jointly
//! stratified (a camera ray blends four texels; on the glossy Cornell box's
//! walkthrough, half the rays built the cache in 3.9 s instead of 7.7 s for
//! a view-0 error of 1.18 % instead of 1.17 %, measured while choosing).

use super::gather::GatherPoint;
use super::sampling::Samples;
use super::{RenderSettings, SolutionReader};
use crate::exposure::is_buried;
use crate::scene::{Patch, Rgb};
use crate::solve::Solution;
use glam::DVec2;
use rayon::prelude::*;

/// Most texels per side of one surface's grid.
const MAX_SIDE: usize = 128;

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
    /// `settings.caustic_gathers` times as many.
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
            surface.is_diffuse() && matches!(surface.patch, Patch::Parallelogram { .. })
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
        let values: Vec<Option<Rgb>> = texels
            .par_iter()
            .map(|&(s, t)| {
                let surface = &scene.surfaces[s];
                let side = sides[s];
                let uv = DVec2::new(
                    ((t % side) as f64 + 0.5) / side as f64,
                    ((t / side) as f64 + 0.5) / side as f64,
                );
                let (position, normal) = (surface.patch.point_at(uv), surface.patch.normal());
                let coincident = 1e-7 * surface.patch.area().sqrt();
                let tracer = &solution.tracer;
                if is_buried(scene, tracer, s as u32, position, normal, coincident) {
                    return None;
                }
                let gathers = settings
                    .on_receiver(reader.caustic[s])
                    .gather_samples_per_pixel
                    .max(1);
                let rays = settings.gather_rays.saturating_mul(gathers) / 2;
                // As many shadow rays as the pixel's gathers, in one grid.
                let shadow_grid = (f64::from(settings.gather_grid) * f64::from(gathers).sqrt())
                    .round()
                    .max(1.0) as u32;
                let point = GatherPoint {
                    surface: s as u32,
                    position,
                    normal,
                    samples: Samples::Pixel {
                        scramble: ((s as u64) << 40 ^ t as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15),
                        block: 0,
                    },
                };
                Some(solution.final_gather(reader, &point, (rays, shadow_grid), settings))
            })
            .collect();
        let mut values = values.into_iter();
        let grids = sides
            .iter()
            .map(|&side| {
                (side > 0).then(|| Grid {
                    side,
                    texels: values.by_ref().take(side * side).collect(),
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
            let (mut sum, mut total) = ([0.0; 3], 0.0);
            for (l, w) in corners.iter().zip(weights) {
                if let Some(l) = l {
                    (0..3).for_each(|ch| sum[ch] += w * l[ch]);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::form_factor::point_to_polygon;
    use crate::solve::{solve, Silent, SolveSettings};

    /// A grey floor lit by a light that reflects nothing, 0.5 above it, is
    /// lit directly and by nothing else: the cache must give
    /// ρ·Le·F(x, light) with Lambert's closed form F, between texel centres
    /// as at them; a glossy surface is not cached.
    #[test]
    fn cached_floor_radiance_is_the_closed_form_direct_light() {
        let mut scene = crate::testing::light_over_a_corner(0.5);
        scene.surfaces[1].brdf = crate::brdf::Brdf::diffuse([0.0; 3]);
        // Off the diagonal, so that the light is not symmetric in u and v.
        scene.surfaces[1].patch = Patch::Parallelogram {
            origin: glam::DVec3::new(0.6, 0.1, 0.5),
            edge_s: glam::DVec3::Y * 0.2,
            edge_t: glam::DVec3::X * 0.2,
        };
        let solution = solve(&scene, &SolveSettings::default(), &Silent).unwrap();
        let reader = solution.reader();
        let cache = GatherCache::build(&solution, &reader, &RenderSettings::default());
        assert!(cache.texels() > 1000, "{} texels", cache.texels());
        let (floor, light) = (&scene.surfaces[0].patch, &scene.surfaces[1].patch);
        let mut worst: f64 = 0.0;
        for k in 0..400 {
            let uv = crate::render::sampling::hash2(11, k);
            let x = floor.point_at(uv);
            let expect =
                0.5 * point_to_polygon(x, floor.normal(), &light.vertices(), light.normal());
            let got = cache.radiance(0, uv).expect("cached")[0];
            worst = worst.max((got - expect).abs() / expect);
        }
        assert!(worst < 0.005, "worst relative error {worst}");
        let mut glossy = scene.clone();
        glossy.surfaces[0].brdf = crate::testing::rolled_aluminium();
        let solution = solve(&glossy, &SolveSettings::default(), &Silent).unwrap();
        let reader = solution.reader();
        let cache = GatherCache::build(&solution, &reader, &RenderSettings::default());
        assert_eq!(cache.radiance(0, DVec2::splat(0.5)), None);
    }
}
