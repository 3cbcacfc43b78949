//! What glass does to the light on diffuse surfaces: its caustics and its
//! shadows, as a signed photon map (Jensen 1996, "Global illumination using
//! photon maps": the caustic map, and its shadow photons).
//!
//! The solve and the final gather's shadow rays let light pass glass as if
//! it were not there ([`crate::render::glass`]). Photons shot from the
//! emitters towards each glass shape measure the difference: a photon whose
//! straight path meets glass before a surface leaves its power, negated,
//! where that straight path lands (the light the transparent glass let
//! through), and its power where it lands after following the glass's
//! specular chain (reflected and refracted as Mitsuba 3's `dielectric`
//! scatters power). Their density at a diffuse point, estimated from its
//! nearest photons on surfaces facing the same way, is the irradiance that
//! the glass adds there (a caustic) or takes away (a shadow); the final
//! gather adds it, times the Lambertian albedo over π, to the light
//! straight from the emitters.
//!
//! Photons leave the emitting surfaces (picked by power) and the point and
//! spot lights uniformly over the cone of directions that each glass
//! shape's bounding sphere subtends (the sphere around it, from inside), and
//! a directional light's from a disc across its path as wide as that
//! sphere, so that nearly all of them meet glass. The sky (`constant`,
//! `envmap`) shoots its photons as a directional light would, along a
//! direction drawn for each: uniformly over the sphere for `constant`, by
//! the map's luminance for `envmap`.

use super::discrete::{DiscreteDistribution, SurfaceDistribution};
use super::emitters::SphereEmitter;
use super::glass::GlassTracer;
use crate::geometry::tracing::SceneTracer;
use crate::render::camera::Ray;
use crate::sampling::hash2;
use crate::scene::brdf::microfacet::square_to_uniform_disk_concentric;
use crate::scene::glass::Transport;
use crate::scene::{Light, Rgb, Scene};
use glam::{DVec2, DVec3};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use std::f64::consts::PI;
use std::num::NonZero;

/// Photons shot towards each glass shape, at most: the scene's
/// [`PHOTONS`] shared among its glass shapes.
pub const PHOTONS_PER_SHAPE: u32 = 1 << 18;

/// Photons shot in all, at most, where the glass shapes are many.
pub const PHOTONS: u32 = 1 << 20;

/// Photons shot towards each of `shapes` glass shapes.
pub fn photons_per_shape(shapes: usize) -> u32 {
    let shared = u64::from(PHOTONS) / (shapes.max(1) as u64);
    shared.clamp(1, u64::from(PHOTONS_PER_SHAPE)) as u32
}

/// Glass interfaces at which a photon splits in two, before it chooses
/// one branch at each, by its probability.
pub const SPLIT_DEPTH: u32 = 2;

/// Where a photon's hash indices for the microfacet normals it meets
/// start (one per interface), clear of those of its source, direction and
/// branches.
const FACETS: u64 = 1 << 32;

/// Photons a density estimate gathers.
pub const NEAREST: usize = 128;

/// The farthest a density estimate reaches, as a share of the smallest
/// glass shape's bounding radius: caustics are about as sharp as the glass
/// that focuses them is small.
pub const MAX_RADIUS_SHARE: f64 = 0.1;

/// Least cosine between the normals of a photon's surface and of the point
/// whose irradiance it counts for: the two sides of a wall, or a floor and
/// the box standing on it, keep their photons apart.
const SAME_FACING: f64 = 0.9;

/// The signed photons glass leaves on the scene's diffuse surfaces.
pub struct CausticMap {
    tree: ImmutableKdTree<f64, 3>,
    photons: Vec<Photon>,
    max_radius: f64,
    /// The photons' bounding box, grown by `max_radius`: no point outside
    /// it has any within reach.
    reach: (DVec3, DVec3),
}

/// A photon at rest: its (signed) power and the front normal of the
/// surface it rests on; its position is in the tree.
#[derive(Debug, Clone, Copy)]
struct Photon {
    power: Rgb,
    normal: DVec3,
}

impl std::fmt::Debug for CausticMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CausticMap")
            .field("photons", &self.photons.len())
            .field("max_radius", &self.max_radius)
            .finish()
    }
}

impl CausticMap {
    /// Shoot the photons of `scene`'s glass: `None` without glass, without
    /// emitting surfaces or lights, or where no photon comes to rest.
    pub fn shoot(scene: &Scene, tracer: &SceneTracer, glass: &GlassTracer) -> Option<CausticMap> {
        if glass.is_empty() {
            return None;
        }
        let targets: Vec<SphereEmitter> = scene.glass.iter().map(bounding_sphere).collect();
        let sources: Vec<Sources> = (targets.iter())
            .map(|target| Sources::towards(scene, target))
            .collect::<Option<_>>()?;
        let smallest = targets
            .iter()
            .map(|t| t.radius)
            .fold(f64::INFINITY, f64::min);
        let shoot = Shot {
            scene,
            tracer,
            glass,
            limit: GlassTracer::interfaces_allowed(scene),
        };
        let each = u64::from(photons_per_shape(targets.len()));
        let shot: Vec<(DVec3, Photon)> = (0..targets.len() as u64 * each)
            .into_par_iter()
            .flat_map_iter(|i| {
                let g = (i / each) as usize;
                shoot.photon(&sources[g], (&targets[g], each), i)
            })
            .collect();
        if shot.is_empty() {
            return None;
        }
        let positions: Vec<[f64; 3]> = shot.iter().map(|(x, _)| x.to_array()).collect();
        let max_radius = MAX_RADIUS_SHARE * smallest;
        let (lo, hi) = (shot.iter()).fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), (x, _)| (lo.min(*x), hi.max(*x)),
        );
        Some(CausticMap {
            tree: ImmutableKdTree::new_from_slice(&positions),
            photons: shot.into_iter().map(|(_, p)| p).collect(),
            max_radius,
            reach: (lo - DVec3::splat(max_radius), hi + DVec3::splat(max_radius)),
        })
    }

    /// The irradiance that glass adds (or, negative, takes away) at point
    /// `x` of a surface whose front normal is `normal`: the power of the
    /// [`NEAREST`] photons within reach on surfaces facing the same way,
    /// over the disc they cover, weighted by Epanechnikov's kernel.
    pub fn irradiance(&self, x: DVec3, normal: DVec3) -> Rgb {
        if x.cmplt(self.reach.0).any() || x.cmpgt(self.reach.1).any() {
            return Rgb::ZERO;
        }
        let reach = self.max_radius * self.max_radius;
        let found = self.tree.nearest_n_within::<SquaredEuclidean>(
            &x.to_array(),
            reach,
            NonZero::new(NEAREST).expect("NEAREST > 0"),
            false,
        );
        if found.is_empty() {
            return Rgb::ZERO;
        }
        let r2 = if found.len() == NEAREST {
            found.iter().map(|n| n.distance).fold(0.0, f64::max)
        } else {
            reach
        };
        let r2 = r2.max(f64::MIN_POSITIVE);
        // Epanechnikov's kernel, 1 − d²/r², whose integral over the disc is
        // πr²/2: the photon that bounds the disc counts for nothing, so
        // whether the partner it rests with (a photon a pane dims where its
        // negative rests) falls inside or out changes nothing.
        let power: Rgb = (found.iter())
            .filter_map(|n| {
                let p = &self.photons[n.item as usize];
                (p.normal.dot(normal) >= SAME_FACING).then(|| p.power * (1.0 - n.distance / r2))
            })
            .sum();
        power / (0.5 * PI * r2)
    }

    /// How many photons rest on the surfaces.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    /// True when none does.
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }
}

/// The sphere around a glass shape's faces (that of their bounding box),
/// as the target the photons aim at.
fn bounding_sphere(glass: &crate::scene::glass::Glass) -> SphereEmitter {
    let (lo, hi) = (glass.faces.iter())
        .flat_map(|(patch, _)| patch.vertices())
        .fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), v| (lo.min(v), hi.max(v)),
        );
    SphereEmitter {
        center: 0.5 * (lo + hi),
        radius: 0.5 * (hi - lo).length(),
        surfaces: 0..0,
        emission: Rgb::ZERO,
    }
}

/// Where the photons aimed at one glass shape leave from: the emitting
/// surfaces, picked by power, and the point, spot and directional lights,
/// each group drawn by an estimate of the power it sends towards the shape
/// (which changes only the photons' noise).
struct Sources {
    surfaces: Option<SurfaceDistribution>,
    /// The delta lights (indices in [`Scene::lights`]).
    lights: Vec<usize>,
    /// Over `surfaces` (first, where there are any) and `lights`.
    choice: DiscreteDistribution,
    /// How far back from the target directional light's photons start:
    /// beyond every surface.
    far: f64,
}

impl Sources {
    /// The sources of `scene` for photons aimed at `target`; `None` where
    /// there are none.
    fn towards(scene: &Scene, target: &SphereEmitter) -> Option<Sources> {
        let solid_angle = |x: DVec3| {
            let d2 = (target.center - x).length_squared();
            match d2 > target.radius * target.radius {
                true => 2.0 * PI * (1.0 - (1.0 - target.radius * target.radius / d2).sqrt()),
                false => 4.0 * PI,
            }
        };
        let emitting: Vec<(u32, f64)> = (scene.surfaces.iter().enumerate())
            .filter(|(_, s)| s.is_emitter())
            .map(|(k, s)| (k as u32, s.emission.average() * s.patch.area()))
            .collect();
        let towards_target: f64 = (emitting.iter())
            .map(|&(k, power)| {
                let patch = &scene.surfaces[k as usize].patch;
                let centre = patch.centroid();
                let cos = patch
                    .normal()
                    .dot((target.center - centre).normalize_or_zero());
                power * solid_angle(centre) * cos.max(0.01) / PI
            })
            .sum();
        let cross_section = PI * target.radius * target.radius;
        let lights: Vec<(usize, f64)> = (scene.lights.iter().enumerate())
            .filter(|(_, l)| !l.is_dark())
            .map(|(k, light)| {
                let weight = match *light {
                    Light::Point {
                        position,
                        intensity,
                    } => intensity.average() * solid_angle(position),
                    Light::Spot {
                        position,
                        intensity,
                        ..
                    } => intensity.average() * solid_angle(position),
                    Light::Directional { irradiance, .. } => irradiance.average() * cross_section,
                    // Radiance from every direction onto the cross-section.
                    Light::Constant { radiance } => radiance.average() * 4.0 * PI * cross_section,
                    Light::Envmap(ref map) => map.mean_radiance() * 4.0 * PI * cross_section,
                };
                (k, weight)
            })
            .collect();
        if emitting.is_empty() && lights.is_empty() {
            return None;
        }
        let surfaces = (!emitting.is_empty()).then(|| SurfaceDistribution::new(emitting));
        let weights = surfaces.as_ref().map(|_| towards_target);
        let extent = (scene.surfaces.iter())
            .flat_map(|s| s.patch.vertices())
            .map(|v| (v - target.center).length())
            .fold(0.0, f64::max);
        Some(Sources {
            far: 2.0 * (target.radius + extent),
            surfaces,
            choice: DiscreteDistribution::new(
                weights.into_iter().chain(lights.iter().map(|l| l.1)),
            ),
            lights: lights.into_iter().map(|(k, _)| k).collect(),
        })
    }

    /// Photon `key` of the `count` aimed at `target`: its ray and its
    /// power, its share of theirs; `None` where it carries nothing (leaving
    /// an emitter's back, outside a spot's cone).
    fn launch(
        &self,
        scene: &Scene,
        (target, count): (&SphereEmitter, u64),
        key: u64,
    ) -> Option<(Ray, Rgb)> {
        let (u_source, u_direction) = (hash2(key, 0), hash2(key, 1));
        let cross_section = PI * target.radius * target.radius;
        let drawn = self.choice.sample(u_source.x, 0..0)?;
        let u = DVec2::new(drawn.u, u_source.y);
        let share = drawn.probability * count as f64;
        // Uniform over the cone of the target's sphere (every direction
        // from inside it), with the cone's solid angle.
        let aim = |x: DVec3| match target.sample(x, u_direction) {
            Some(cone) => (cone.direction, 1.0 / cone.pdf),
            None => (uniform_sphere(u_direction), 4.0 * PI),
        };
        let from = |origin: DVec3, direction: DVec3| Ray {
            origin,
            direction,
            t_min: 1e-7,
            t_max: f64::INFINITY,
        };
        let light = match (&self.surfaces, drawn.index) {
            (Some(surfaces), 0) => {
                let (s, uv, probability) = surfaces.sample(u, u32::MAX)?;
                let surface = &scene.surfaces[s as usize];
                let patch = &surface.patch;
                let x = patch.point_at(patch.square_to_param(uv));
                let (direction, solid_angle) = aim(x);
                let cos = patch.normal().dot(direction);
                let power = surface.emission * (cos * solid_angle * patch.area() / probability);
                return (cos > 0.0).then(|| (from(x, direction), power / share));
            }
            (Some(_), k) => &scene.lights[self.lights[k - 1]],
            (None, k) => &scene.lights[self.lights[k]],
        };
        let (ray, power) = match *light {
            Light::Point { position, .. } | Light::Spot { position, .. } => {
                let (direction, solid_angle) = aim(position);
                let (_, intensity) = light.point_intensity(direction)?;
                (from(position, direction), intensity * solid_angle)
            }
            Light::Directional {
                direction,
                irradiance,
            } => (
                self.across(target, direction, u),
                irradiance * cross_section,
            ),
            Light::Constant { radiance } => {
                let towards = uniform_sphere(u_direction);
                let ray = self.across(target, -towards, u);
                (ray, radiance * (4.0 * PI * cross_section))
            }
            Light::Envmap(ref map) => {
                let (towards, pdf) = map.sample(u_direction);
                if pdf <= 0.0 {
                    return None;
                }
                let ray = self.across(target, -towards, u);
                (ray, map.radiance(towards) * (cross_section / pdf))
            }
        };
        (power.max_channel() > 0.0).then(|| (ray, power / share))
    }

    /// A ray of parallel light travelling along `direction` through the
    /// point `u` ∈ \[0,1)² draws on a disc across its path as wide as
    /// `target`, from beyond the scene.
    fn across(&self, target: &SphereEmitter, direction: DVec3, u: DVec2) -> Ray {
        let (t, b) = direction.any_orthonormal_pair();
        let disc = target.radius * square_to_uniform_disk_concentric(u);
        Ray {
            origin: target.center - self.far * direction + disc.x * t + disc.y * b,
            direction,
            t_min: 1e-7,
            t_max: f64::INFINITY,
        }
    }
}

/// What one photon is traced through.
struct Shot<'a> {
    scene: &'a Scene,
    tracer: &'a SceneTracer,
    glass: &'a GlassTracer,
    limit: u32,
}

impl Shot<'_> {
    /// Photon `i` of those aimed at `target` (a glass shape's sphere, and
    /// how many photons aim at it) from one of `sources`: where
    /// its straight path lands, with its power negated, and where its
    /// branches through the glass land, each with its share of the power
    /// ([`Shot::spread`]); none where its straight path meets no glass
    /// first, and each only on a surface with a Lambertian lobe that it
    /// reaches from the front.
    fn photon(
        &self,
        sources: &Sources,
        target: (&SphereEmitter, u64),
        i: u64,
    ) -> Vec<(DVec3, Photon)> {
        let key = i.wrapping_mul(0x2545_f491_4f6c_dd1d);
        let Some((ray, power)) = sources.launch(self.scene, target, key) else {
            return Vec::new();
        };
        let (x, direction) = (ray.origin, ray.direction);
        // Where the straight path lands; the glass must come first.
        let straight = self.tracer.trace(x, direction, ray.t_min, ray.t_max);
        let before = Ray {
            t_max: straight.map_or(f64::INFINITY, |h| h.distance),
            ..ray
        };
        if self.glass.hit(self.scene, &before, None).is_none() {
            return Vec::new();
        }
        let mut rested: Vec<_> = (straight.into_iter())
            .filter_map(|h| self.rest(h.surface, h.position, direction, power * -1.0))
            .collect();
        self.spread((ray, None), power, (0, key), &mut rested);
        rested
    }

    /// Follow a photon of `power` along `ray` (leaving glass triangle
    /// `skip`, if any), at its `depth`-th glass interface (photon `key`),
    /// and append where it rests to `rested`. The first [`SPLIT_DEPTH`]
    /// interfaces split it, each branch weighted by its probability, so
    /// that where glass only dims the light (a pane, a slab) the photons
    /// that pass it rest with the negative ones they take the place of;
    /// deeper ones choose a branch by its probability ([`Dielectric`]).
    ///
    /// [`Dielectric`]: crate::scene::glass::Dielectric
    fn spread(
        &self,
        (ray, skip): (Ray, Option<u32>),
        power: Rgb,
        (depth, key): (u32, u64),
        rested: &mut Vec<(DVec3, Photon)>,
    ) {
        let glass = self.glass.hit(self.scene, &ray, skip);
        let opaque = self.tracer.trace(
            ray.origin,
            ray.direction,
            ray.t_min,
            glass.map_or(ray.t_max, |g| g.distance),
        );
        // A surface before any glass, or glass before any surface.
        let glass = match (opaque, glass) {
            (Some(hit), _) => {
                if depth > 0 {
                    rested.extend(self.rest(hit.surface, hit.position, ray.direction, power));
                }
                return;
            }
            (None, Some(glass)) if depth < self.limit => glass,
            _ => return,
        };
        let (dir, interface) = (ray.direction, glass.interface);
        // A rough interface's microfacet normal, drawn once for both
        // branches.
        let m = interface.facet(dir, glass.normal, hash2(key, FACETS + u64::from(depth)));
        let mut branch = |(direction, weight): (DVec3, Rgb)| {
            let next = Ray {
                origin: glass.position,
                direction,
                t_min: self.glass.clearance(),
                t_max: f64::INFINITY,
            };
            self.spread(
                (next, Some(glass.triangle)),
                power * weight,
                (depth + 1, key),
                rested,
            );
        };
        if depth < SPLIT_DEPTH {
            interface
                .branches(dir, (glass.normal, m), Transport::Power)
                .for_each(branch);
        } else {
            let u = hash2(key, 2 + u64::from(depth)).x;
            branch(interface.scatter_at(dir, (glass.normal, m), u, Transport::Power));
        }
    }

    /// A photon of `power` arriving along `direction` at `position` on
    /// surface `s`, if it rests there: on the front of a surface with a
    /// Lambertian lobe.
    fn rest(
        &self,
        s: u32,
        position: DVec3,
        direction: DVec3,
        power: Rgb,
    ) -> Option<(DVec3, Photon)> {
        let surface = &self.scene.surfaces[s as usize];
        let normal = surface.patch.normal();
        (normal.dot(direction) < 0.0 && surface.brdf.lambertian().is_some())
            .then_some((position, Photon { power, normal }))
    }
}

/// A direction uniform over the unit sphere from `u` ∈ [0,1)².
fn uniform_sphere(u: DVec2) -> DVec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn many_glass_shapes_share_a_bounded_number_of_photons() {
        assert_eq!(photons_per_shape(0), PHOTONS_PER_SHAPE);
        assert_eq!(photons_per_shape(4), PHOTONS_PER_SHAPE);
        assert_eq!(photons_per_shape(64), PHOTONS / 64);
        assert_eq!(photons_per_shape(10_000_000), 1);
        for shapes in [1, 5, 7, 100, 3000] {
            assert!(u64::from(photons_per_shape(shapes)) * shapes as u64 <= u64::from(PHOTONS));
        }
    }
}
