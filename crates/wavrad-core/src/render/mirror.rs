//! Mirror images of emitters through planar glossy surfaces: a sampling
//! strategy for the final gather at a diffuse point x (after the "virtual
//! light" of planar mirrors).
//!
//! Light that an emitter e sends to x by way of a planar glossy surface q is
//! concentrated where q reflects e towards x near-specularly: around the
//! points where the line from x to e's mirror image e* (through q's plane)
//! crosses q. A small, sharp reflector lighting a wall (the paper's Figure 3)
//! shows that region to few cosine rays and to few uniform points on q, so
//! the wall's caustic is noisy; a uniform point on e, mirrored, gives a
//! direction from x straight through it. Every surface here is planar, so
//! the image is exact and its density in solid angle is closed-form, and the
//! strategy joins the gather's others through the balance heuristic. A
//! gather draws its points from all images at once ([`MirrorImages`]), so
//! that its cost does not grow with the number of glossy surfaces and
//! emitters.
//! Written here because it is a few lines of plane geometry on wavrad's own
//! patches.

use super::discrete::DiscreteDistribution;
use crate::kernel::faces_away;
use crate::scene::brdf::{BrdfFlags, BrdfModel};
use crate::scene::{Patch, Scene, Surface};
use glam::{DMat3, DMat4, DVec2, DVec3};
use std::ops::Range;

/// The image of emitter `emitter` mirrored through the plane of the glossy
/// surface `surface`.
#[derive(Debug, Clone, PartialEq)]
pub struct MirrorImage {
    /// The glossy surface that reflects.
    pub surface: u32,
    /// The emitter reflected.
    pub emitter: u32,
    /// The emitter mirrored through `surface`'s plane.
    image: Patch,
    /// The emitter's area (the image's).
    area: f64,
}

/// The images of every emitter through every sharp glossy surface that it
/// faces ([`is_sharp`]; no other pair reflects light), ordered by glossy
/// surface, and a distribution over them by their emitters' power
/// (emission averaged over the channels, times area): a final gather draws
/// each of its points from one image picked by it, and weighs a direction
/// that meets a glossy surface with the density of the images through
/// that surface alone.
#[derive(Debug, Clone, Default)]
pub struct MirrorImages {
    images: Vec<MirrorImage>,
    choice: DiscreteDistribution,
}

impl MirrorImages {
    /// The images of `emitters` through the sharp ones among `glossy`.
    pub fn of_scene(scene: &Scene, glossy: &[u32], emitters: &[u32]) -> MirrorImages {
        let mut images = Vec::new();
        for &q in glossy
            .iter()
            .filter(|&&q| is_sharp(&scene.surfaces[q as usize]))
        {
            let plane = &scene.surfaces[q as usize].patch;
            for &e in emitters {
                let light = &scene.surfaces[e as usize];
                if e == q || faces_away(plane, &light.patch) {
                    continue;
                }
                images.push(MirrorImage {
                    surface: q,
                    emitter: e,
                    image: light.patch.transformed(&reflection(plane)),
                    area: light.patch.area(),
                });
            }
        }
        images.sort_by_key(|m| m.surface);
        let power =
            |m: &MirrorImage| scene.surfaces[m.emitter as usize].emission.average() * m.area;
        MirrorImages {
            choice: DiscreteDistribution::new(images.iter().map(power)),
            images,
        }
    }

    /// The images, ordered by glossy surface.
    pub fn images(&self) -> &[MirrorImage] {
        &self.images
    }

    /// The image that `u` ∈ \[0,1\)² picks among those through surfaces
    /// other than `excluded` (the gather's own), with the point of
    /// \[0,1\)² it then samples and the probability it had: `None` where
    /// there is no such image.
    pub fn sample(&self, u: DVec2, excluded: u32) -> Option<(&MirrorImage, DVec2, f64)> {
        let drawn = self.choice.sample(u.x, self.through(excluded))?;
        let image = &self.images[drawn.index];
        Some((image, DVec2::new(drawn.u, u.y), drawn.probability))
    }

    /// Solid-angle density with which [`MirrorImages::sample`] (leaving out
    /// the images through `excluded`) and then [`MirrorImage::sample`] pick
    /// the direction `wi` from `x`, whose ray first meets the glossy
    /// surface `q` at distance `t`: a sum over the images through `q` only.
    pub fn pdf(&self, excluded: u32, x: DVec3, (wi, q, t): (DVec3, u32, f64)) -> f64 {
        let left_out = self.through(excluded);
        self.through(q)
            .map(|i| self.choice.probability(i, left_out.clone()) * self.images[i].pdf(x, wi, t))
            .sum()
    }

    /// The positions of the images through surface `q`.
    fn through(&self, q: u32) -> Range<usize> {
        let start = self.images.partition_point(|m| m.surface < q);
        start..start + self.images[start..].partition_point(|m| m.surface == q)
    }
}

impl MirrorImage {
    /// Whether this image can light surface `s` by way of the glossy
    /// surface: `s` is diffuse and faces it.
    pub fn lights(&self, scene: &Scene, s: u32) -> bool {
        let receiver = &scene.surfaces[s as usize];
        let plane = &scene.surfaces[self.surface as usize].patch;
        s != self.surface
            && s != self.emitter
            && !receiver.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION)
            && !faces_away(&receiver.patch, plane)
    }

    /// The direction from `x` towards the image of the emitter's point at
    /// `u` ∈ \[0,1\]² (uniform by area), if that line crosses the glossy
    /// surface (`patch`, the surface's) from the front before reaching the
    /// image: (direction, point on the surface, solid-angle density of the
    /// direction).
    pub fn sample(&self, patch: &Patch, x: DVec3, u: DVec2) -> Option<(DVec3, DVec3, f64)> {
        let m = self.image.point_at(self.image.square_to_param(u));
        let to = m - x;
        let s = to.length();
        let wi = to / s;
        let t = crossing(patch, x, wi)?;
        let y = x + t * wi;
        if t >= s || !patch.contains_param(patch.param_of(y)) {
            return None;
        }
        let cos = self.image.normal().dot(wi).abs();
        (cos > 0.0).then(|| (wi, y, s * s / (self.area * cos)))
    }

    /// Solid-angle density with which [`MirrorImage::sample`] picks the
    /// direction `wi` from `x`, whose ray first meets the glossy surface at
    /// distance `t`.
    pub fn pdf(&self, x: DVec3, wi: DVec3, t: f64) -> f64 {
        let n = self.image.normal();
        let cos = n.dot(wi);
        if cos == 0.0 {
            return 0.0;
        }
        let s = n.dot(self.image.vertices()[0] - x) / cos;
        if s <= t || !self.image.contains_param(self.image.param_of(x + s * wi)) {
            return 0.0;
        }
        s * s / (self.area * cos.abs())
    }
}

/// Whether `surface` reflects light into a lobe narrow enough for its
/// emitters' mirror images to be worth sampling
/// ([`Brdf::is_sharp`](crate::scene::brdf::Brdf::is_sharp)).
/// Broader lobes spread an emitter's light over much of the surface, which
/// area sampling already finds: on the glossy Cornell box (peak densities
/// 0.6 and 0.8) mirror sampling left the error as it was and cost a third
/// more render time; Figure 3's rolled aluminium has 15.
pub fn is_sharp(surface: &Surface) -> bool {
    surface.brdf.is_sharp()
}

/// Distance along the unit direction `wi` from `x`, in front of `patch`, to
/// its plane, if the ray meets the plane from the front.
fn crossing(patch: &Patch, x: DVec3, wi: DVec3) -> Option<f64> {
    let n = patch.normal();
    let toward = n.dot(wi);
    let t = n.dot(patch.vertices()[0] - x) / toward;
    (toward < 0.0 && t > 0.0).then_some(t)
}

/// The reflection through the plane of `patch`: p ↦ p − 2 n·(p − o) n.
fn reflection(patch: &Patch) -> DMat4 {
    let (n, o) = (patch.normal(), patch.vertices()[0]);
    let householder = DMat3::IDENTITY - 2.0 * DMat3::from_cols(n * n.x, n * n.y, n * n.z);
    DMat4::from_translation(2.0 * n.dot(o) * n) * DMat4::from_mat3(householder)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::hash2;
    use crate::scene::brdf::{Brdf, Ward};
    use crate::scene::Rgb;
    use crate::testing::{grey, mirror_floor_and_light};

    #[test]
    fn an_image_lights_the_diffuse_surfaces_facing_its_reflector() {
        let mut scene = mirror_floor_and_light();
        let wall = |origin: DVec3| {
            grey(Patch::Parallelogram {
                origin,
                edge_s: -DVec3::Y,
                edge_t: DVec3::Z,
            })
        };
        // Facing the floor (normal −x), then behind the floor's plane.
        scene.surfaces.push(wall(DVec3::new(1.2, 1.0, 0.0)));
        scene.surfaces.push(wall(DVec3::new(0.0, 0.0, -2.0)));
        let images = MirrorImages::of_scene(&scene, &[0], &[1]);
        let image = &images.images()[0];
        let lit: Vec<bool> = (0..4).map(|s| image.lights(&scene, s)).collect();
        assert_eq!(lit, [false, false, true, false]);
    }

    #[test]
    fn only_sharp_lobes_get_mirror_images() {
        let mut scene = mirror_floor_and_light();
        assert!(is_sharp(&scene.surfaces[0]));
        // The glossy Cornell box's floor: balanced Ward, α 0.25.
        scene.surfaces[0].brdf = Brdf::Ward(Ward {
            alpha_u: 0.25,
            alpha_v: 0.25,
            ..Ward::default()
        });
        assert!(!is_sharp(&scene.surfaces[0]));
        assert!(MirrorImages::of_scene(&scene, &[0], &[1])
            .images()
            .is_empty());
        scene.surfaces[0].brdf = Brdf::diffuse(Rgb::splat(0.5));
        assert!(!is_sharp(&scene.surfaces[0]));
    }

    #[test]
    fn the_image_lies_behind_the_plane_as_far_as_the_emitter_is_in_front() {
        let scene = mirror_floor_and_light();
        let images = MirrorImages::of_scene(&scene, &[0], &[1]);
        let images = images.images();
        assert_eq!(images.len(), 1);
        let light = scene.surfaces[1].patch.vertices();
        for (v, w) in light.iter().zip(images[0].image.vertices()) {
            assert!(
                (w - DVec3::new(v.x, v.y, -v.z)).length() < 1e-12,
                "{v} -> {w}"
            );
        }
    }

    #[test]
    fn sampled_directions_reflect_specularly_into_the_emitter() {
        let scene = mirror_floor_and_light();
        let images = MirrorImages::of_scene(&scene, &[0], &[1]);
        let image = &images.images()[0];
        let x = DVec3::new(0.9, 0.5, 0.4);
        let floor = &scene.surfaces[0].patch;
        let mut hits = 0;
        for k in 0..64 {
            let Some((wi, y, pdf)) = image.sample(floor, x, hash2(5, k)) else {
                continue;
            };
            hits += 1;
            // The reflected ray from y meets the light.
            let r = wi - 2.0 * wi.dot(DVec3::Z) * DVec3::Z;
            let s = (1.0 - y.z) / r.z;
            let at = scene.surfaces[1].patch.param_of(y + s * r);
            assert!(scene.surfaces[1].patch.contains_param(at), "{at}");
            // The density agrees with the one evaluated for that direction.
            let t = (y - x).length();
            assert!((image.pdf(x, wi, t) - pdf).abs() < 1e-9 * pdf);
        }
        assert_eq!(hits, 64, "samples that cross the floor");
    }

    #[test]
    fn the_density_integrates_to_one_over_directions() {
        // Seen from x, every direction towards the image crosses the large
        // floor: the density integrates to one over the sphere.
        let scene = mirror_floor_and_light();
        let images = MirrorImages::of_scene(&scene, &[0], &[1]);
        let image = &images.images()[0];
        let x = DVec3::new(0.4, 0.5, 0.3);
        let n = 400;
        let mut integral = 0.0;
        for j in 0..n {
            for i in 0..2 * n {
                // Midpoint rule over the lower hemisphere (θ from −z).
                let theta = (j as f64 + 0.5) / n as f64 * std::f64::consts::FRAC_PI_2;
                let phi = (i as f64 + 0.5) / (2 * n) as f64 * std::f64::consts::TAU;
                let wi = DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    -theta.cos(),
                );
                let d_omega = theta.sin()
                    * (std::f64::consts::FRAC_PI_2 / n as f64)
                    * (std::f64::consts::TAU / (2 * n) as f64);
                let t = x.z / theta.cos();
                integral += image.pdf(x, wi, t) * d_omega;
            }
        }
        assert!((integral - 1.0).abs() < 0.01, "{integral}");
    }
}
