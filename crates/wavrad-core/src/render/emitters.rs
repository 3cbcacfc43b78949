//! The scene's emitters as a final gather draws light from them: surfaces
//! picked by power, where an emitting sphere counts as one emitter, sampled
//! as a whole by the cone of directions it subtends.
//!
//! A small sphere light is tessellated into hundreds of facets, and picking
//! facets by power sends half of a point's shadow rays to facets that face
//! away from it: each point then sees a few random facets of the sphere,
//! and the light it receives is as grainy as the number of facets drawn.
//! The cone a sphere subtends from a point outside it is known in closed
//! form: drawn uniformly over that solid angle (pbrt-v4's
//! `Sphere::Sample(ctx, u)`, Pharr, Jakob & Humphreys 2023, §6.2.4;
//! Shirley & Wang 1996), every sample meets the sphere's near side, and its
//! estimate of the irradiance varies only with the cosine over the cone,
//! which is nearly constant for a small or distant light. The sample is on
//! the exact sphere, as the camera sees it and as Mitsuba 3 samples it.
//!
//! A sphere qualifies when it is round (its shape's map is a rotation,
//! uniform scale and translation) and its tessellation's surfaces that face
//! outwards all emit the same radiance and the others none; any other
//! curved emitter is drawn facet by facet.

use super::discrete::SurfaceDistribution;
use crate::scene::analytic::ShapeKind;
use crate::scene::{Rgb, Scene};
use glam::{DVec2, DVec3};
use std::f64::consts::PI;
use std::ops::Range;

/// One emitter as a final gather draws it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Emitter {
    /// An emitting surface, drawn by area.
    Surface(u32),
    /// An emitting sphere ([`Emitters::sphere`]), drawn by solid angle.
    Sphere(u32),
}

/// An emitting sphere: centre, radius, the surfaces of its tessellation
/// and the radiance its outside emits.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereEmitter {
    /// Its centre.
    pub center: DVec3,
    /// Its radius.
    pub radius: f64,
    /// The surfaces of its tessellation (in
    /// [`crate::scene::Scene::surfaces`]).
    pub surfaces: Range<u32>,
    /// The radiance it emits outwards.
    pub emission: Rgb,
}

/// A point drawn on an emitting sphere as seen from a point outside it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConeSample {
    /// Unit direction from the point to the sample.
    pub direction: DVec3,
    /// The sample: where that direction first meets the sphere.
    pub position: DVec3,
    /// Its density per unit solid angle.
    pub pdf: f64,
}

impl SphereEmitter {
    /// 1 − cos θmax of the cone the sphere subtends from `x`, computed
    /// without cancellation for a small or distant sphere: `None` where
    /// `x` is on or inside it.
    fn cone(&self, x: DVec3) -> Option<f64> {
        let d2 = (self.center - x).length_squared();
        let r2 = self.radius * self.radius;
        if d2 <= r2 {
            return None;
        }
        let sin2 = r2 / d2;
        Some(sin2 / (1.0 + (1.0 - sin2).sqrt()))
    }

    /// The density per unit solid angle, from `x`, of
    /// [`SphereEmitter::sample`]'s directions: uniform over the cone the
    /// sphere subtends, 1 / (2π(1 − cos θmax)), for a direction within the
    /// cone; 0 outside it or from inside the sphere.
    pub fn pdf(&self, x: DVec3, direction: DVec3) -> f64 {
        let Some(one_minus_cos) = self.cone(x) else {
            return 0.0;
        };
        let axis = (self.center - x).normalize();
        match 1.0 - axis.dot(direction) <= one_minus_cos {
            true => 1.0 / (2.0 * PI * one_minus_cos),
            false => 0.0,
        }
    }

    /// The point of the sphere that `u` ∈ \[0,1)² picks, uniformly by
    /// solid angle as seen from `x` outside it; `None` from inside.
    pub fn sample(&self, x: DVec3, u: DVec2) -> Option<ConeSample> {
        let one_minus_cos = self.cone(x)?;
        let to_center = self.center - x;
        let axis = to_center.normalize();
        let (a, b) = axis.any_orthonormal_pair();
        // 1 − cos θ uniform over [0, 1 − cos θmax], sin θ from it exactly.
        let h = u.x * one_minus_cos;
        let sin = (h * (2.0 - h)).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        let direction = (axis * (1.0 - h) + (a * phi.cos() + b * phi.sin()) * sin).normalize();
        // The nearer root of |x + t·direction − centre| = r; a direction
        // at the cone's edge grazes the sphere, where rounding could make
        // the discriminant slightly negative.
        let along = direction.dot(to_center);
        let c = to_center.length_squared() - self.radius * self.radius;
        let t = along - (along * along - c).max(0.0).sqrt();
        Some(ConeSample {
            direction,
            position: x + direction * t,
            pdf: 1.0 / (2.0 * PI * one_minus_cos),
        })
    }

    /// The sphere of `shape` (of `scene.shapes`) if it qualifies as one
    /// emitter (module doc).
    fn of_shape(scene: &Scene, shape: &crate::scene::analytic::AnalyticShape) -> Option<Self> {
        if shape.kind != ShapeKind::Sphere {
            return None;
        }
        let m = shape.world_from_shape;
        let axes = [m.x_axis, m.y_axis, m.z_axis].map(|c| c.truncate());
        let radius = axes[0].length();
        let round = radius > 0.0
            && axes
                .iter()
                .all(|c| (c.length() - radius).abs() <= 1e-9 * radius)
            && (0..3).all(|i| axes[i].dot(axes[(i + 1) % 3]).abs() <= 1e-9 * radius * radius);
        let center = m.w_axis.truncate();
        let surfaces = scene
            .surfaces
            .get(shape.surfaces.start as usize..shape.surfaces.end as usize)?;
        let mut emission = None;
        for s in surfaces {
            let vertices = s.patch.vertices();
            let middle = vertices.iter().sum::<DVec3>() / vertices.len() as f64;
            let outwards = s.patch.normal().dot(middle - center) > 0.0;
            if outwards != s.is_emitter()
                || (outwards && *emission.get_or_insert(s.emission) != s.emission)
            {
                return None;
            }
        }
        let emission = emission.filter(|_| round)?;
        Some(SphereEmitter {
            center,
            radius,
            surfaces: shape.surfaces.clone(),
            emission,
        })
    }
}

/// Of the emitters drawn for a point on a surface whose links bring it
/// light from emitters ([`Emitters::with_received`]), the share drawn by
/// the scene-wide weights all the same: it keeps every emitter drawn now
/// and then where the links miss its light (brought by a cluster link, or
/// through a gap the link's visibility estimate did not see). Small,
/// because the rays it sends to a bright emitter that the point cannot
/// see each estimate its hidden part against its whole closed-form
/// factor, whose difference is noisy.
pub const SCENE_WIDE_SHARE: f64 = 0.1;

/// The scene's emitters: its emitting surfaces with probabilities in
/// proportion to their weights (their power), where the facets of an
/// emitting sphere together are one emitter, drawn with their probability
/// summed; for a point on a surface that the solution's links say is lit
/// by some emitters more than others, mostly in proportion to the light
/// each brings it ([`Emitters::with_received`]).
#[derive(Debug, Clone, Default)]
pub struct Emitters {
    by_weight: SurfaceDistribution,
    /// Per receiving surface, its emitters by the light they bring it
    /// (`None` where no link brings any; empty without
    /// [`Emitters::with_received`]).
    by_receiver: Vec<Option<SurfaceDistribution>>,
    spheres: Vec<SphereEmitter>,
    /// Per surface, the sphere it tessellates, if an emitting one (empty
    /// without such spheres).
    sphere_of: Vec<Option<u32>>,
}

impl Emitters {
    /// The emitting surfaces of `scene` by `weighted` (surface, weight)
    /// pairs, and its emitting spheres.
    pub fn new(scene: &Scene, weighted: Vec<(u32, f64)>) -> Emitters {
        let spheres: Vec<SphereEmitter> = (scene.shapes.iter())
            .filter_map(|shape| SphereEmitter::of_shape(scene, shape))
            .collect();
        let mut sphere_of = vec![
            None;
            if spheres.is_empty() {
                0
            } else {
                scene.surfaces.len()
            }
        ];
        for (k, sphere) in spheres.iter().enumerate() {
            for s in sphere.surfaces.clone() {
                sphere_of[s as usize] = Some(k as u32);
            }
        }
        Emitters {
            by_weight: SurfaceDistribution::new(weighted),
            by_receiver: Vec::new(),
            spheres,
            sphere_of,
        }
    }

    /// The same emitters, drawn for a point on surface p mostly (all but
    /// [`SCENE_WIDE_SHARE`]) in proportion to `received[p]`, the (emitter
    /// surface, weight) pairs of the light each emitter brings p through
    /// its links, visibility included. On a ceiling lit by a lamp below it
    /// while a brighter spotlight shines elsewhere from inside its housing,
    /// scene-wide weights sent most shadow rays to the hidden spotlight.
    /// A receiver's own surface and weights that sum to nothing are left
    /// out; with one emitting surface or none there is nothing to choose.
    pub fn with_received(mut self, received: Vec<Vec<(u32, f64)>>) -> Emitters {
        if self.surfaces().len() < 2 {
            return self;
        }
        self.by_receiver = (received.into_iter().enumerate())
            .map(|(p, weights)| {
                let weights: Vec<(u32, f64)> = (weights.into_iter())
                    .filter(|&(e, w)| e as usize != p && w > 0.0 && w.is_finite())
                    .collect();
                (!weights.is_empty()).then(|| SurfaceDistribution::new(weights))
            })
            .collect();
        self
    }

    /// The distribution drawn from for a point on surface `at` besides the
    /// scene-wide one, if any.
    fn received_by(&self, at: u32) -> Option<&SurfaceDistribution> {
        self.by_receiver.get(at as usize).and_then(Option::as_ref)
    }

    /// The emitting surfaces, ascending.
    pub fn surfaces(&self) -> &[u32] {
        self.by_weight.surfaces()
    }

    /// Emitting sphere `k` ([`Emitter::Sphere`]).
    pub fn sphere(&self, k: u32) -> &SphereEmitter {
        &self.spheres[k as usize]
    }

    /// The emitter surface `s` belongs to.
    pub fn of_surface(&self, s: u32) -> Emitter {
        match self.sphere_of.get(s as usize).copied().flatten() {
            Some(k) => Emitter::Sphere(k),
            None => Emitter::Surface(s),
        }
    }

    /// The emitter that `u` ∈ \[0,1)² picks for a point on surface `at`,
    /// among those other than the one `at` is on, with the point of
    /// \[0,1)² it then samples and the probability it had
    /// ([`Emitters::probability`]); `None` where there is none.
    pub fn sample(&self, u: DVec2, at: u32) -> Option<(Emitter, DVec2, f64)> {
        let share = SCENE_WIDE_SHARE;
        let (s, uv, chosen) = match self.received_by(at) {
            Some(received) if u.x >= share => {
                received.sample(DVec2::new((u.x - share) / (1.0 - share), u.y), at)?
            }
            Some(_) => self.by_weight.sample(DVec2::new(u.x / share, u.y), at)?,
            None => self.by_weight.sample(u, at)?,
        };
        let emitter = self.of_surface(s);
        // A surface drawn by the scene-wide weights alone has the
        // probability it was drawn with; the mixture and a sphere's facets
        // together are looked up.
        let alone = self.received_by(at).is_none() && matches!(emitter, Emitter::Surface(_));
        let chosen = if alone {
            chosen
        } else {
            self.probability(emitter, at)
        };
        Some((emitter, uv, chosen))
    }

    /// The emitting sphere that the ray `x + t·dir` (unit `dir`) meets
    /// first, at t ∈ (0, `far`), other than one surface `from` is on: the
    /// exact sphere, where its cone samples lie.
    pub fn sphere_met(&self, x: DVec3, dir: DVec3, far: f64, from: u32) -> Option<u32> {
        let own = self.of_surface(from);
        (0..self.spheres.len() as u32)
            .filter(|&k| Emitter::Sphere(k) != own)
            .filter_map(|k| {
                let sphere = self.sphere(k);
                let to_center = sphere.center - x;
                let along = dir.dot(to_center);
                let disc = along * along - (to_center.length_squared() - sphere.radius.powi(2));
                let t = along - disc.sqrt();
                (disc >= 0.0 && t > 0.0 && t < far).then_some((k, t))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(k, _)| k)
    }

    /// The probability that [`Emitters::sample`] picks `emitter` for a
    /// point on surface `at`.
    pub fn probability(&self, emitter: Emitter, at: u32) -> f64 {
        let of = |d: &SurfaceDistribution| match emitter {
            Emitter::Surface(s) => d.probability(s, at),
            Emitter::Sphere(k) => d.run_probability(self.sphere(k).surfaces.clone(), at),
        };
        match self.received_by(at) {
            Some(received) => {
                SCENE_WIDE_SHARE * of(&self.by_weight) + (1.0 - SCENE_WIDE_SHARE) * of(received)
            }
            None => of(&self.by_weight),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// For a point on a surface whose links bring it light from some
    /// emitters, they are drawn mostly by that light, every emitter still
    /// now and then: the probabilities sum to one, each draw reports the
    /// probability [`Emitters::probability`] gives, and the draws follow
    /// it. Elsewhere the scene-wide weights alone decide.
    #[test]
    fn emitters_are_drawn_mostly_by_the_light_the_links_bring() {
        let light = |x: f64| crate::scene::Surface {
            emission: Rgb::splat(1.0),
            ..crate::testing::grey(crate::scene::Patch::Parallelogram {
                origin: DVec3::new(x, 0.0, 1.0),
                edge_s: DVec3::X,
                edge_t: DVec3::Y,
            })
        };
        let floor = crate::testing::grey(crate::scene::Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X,
            edge_t: DVec3::Y,
        });
        let scene = Scene::from_surfaces(vec![floor.clone(), floor, light(0.0), light(2.0)]);
        let emitters = Emitters::new(&scene, vec![(2, 3.0), (3, 1.0)]).with_received(vec![
            vec![(3, 1.0)],
            vec![],
            vec![],
            vec![],
        ]);
        let p = |e, at| emitters.probability(Emitter::Surface(e), at);
        let lit = (1.0 - SCENE_WIDE_SHARE) + SCENE_WIDE_SHARE * 0.25;
        assert!((p(3, 0) - lit).abs() < 1e-12 && (p(2, 0) + p(3, 0) - 1.0).abs() < 1e-12);
        assert!((p(3, 1) - 0.25).abs() < 1e-12, "no links: by power");
        let n = 4000;
        let mut drawn = 0;
        for k in 0..n {
            let u = DVec2::new((k as f64 + 0.5) / n as f64, 0.5);
            let (e, uv, chosen) = emitters.sample(u, 0).unwrap();
            assert_eq!(chosen, emitters.probability(e, 0));
            assert!((0.0..1.0).contains(&uv.x) && (0.0..1.0).contains(&uv.y));
            drawn += usize::from(e == Emitter::Surface(3));
        }
        assert!((drawn as f64 / n as f64 - lit).abs() < 1e-3, "{drawn}");
    }

    /// Directions drawn over a sphere's cone cover its solid angle: the
    /// mean of 1/pdf is the solid angle 2π(1 − cos θmax), every sample lies
    /// on the sphere's near side, and the pdf reports the density drawn.
    #[test]
    fn cone_samples_cover_the_sphere_seen() {
        let sphere = SphereEmitter {
            center: DVec3::new(0.0, 0.0, 10.0),
            radius: 0.1,
            surfaces: 0..0,
            emission: Rgb::splat(1.0),
        };
        let x = DVec3::ZERO;
        let cos_max = (1.0 - 0.01f64 / 100.0).sqrt();
        let solid_angle = 2.0 * PI * (1.0 - cos_max);
        let n = 64;
        for i in 0..n {
            for j in 0..n {
                let u = DVec2::new((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let s = sphere.sample(x, u).unwrap();
                assert!((1.0 / s.pdf - solid_angle).abs() < 1e-9 * solid_angle);
                assert!(((s.position - sphere.center).length() - 0.1).abs() < 1e-12);
                assert!((s.position - sphere.center).z < 1e-12, "far side: {s:?}");
                assert!(((s.position - x).normalize() - s.direction).length() < 1e-12);
                assert_eq!(sphere.pdf(x, s.direction), s.pdf);
            }
        }
        assert_eq!(sphere.pdf(x, DVec3::X), 0.0);
        assert_eq!(sphere.sample(sphere.center, DVec2::splat(0.5)), None);
        assert_eq!(sphere.pdf(sphere.center, DVec3::Z), 0.0);
    }

    /// A sphere close enough to fill most of a hemisphere: the irradiance
    /// its cone samples estimate at a point facing it is π sin²θmax times
    /// its radiance (the closed form for a sphere wholly above the
    /// horizon), and samples never fall outside the sphere.
    #[test]
    fn irradiance_from_a_near_sphere_is_its_closed_form() {
        let sphere = SphereEmitter {
            center: DVec3::new(0.0, 0.0, 2.0),
            radius: 1.5,
            surfaces: 0..0,
            emission: Rgb::splat(1.0),
        };
        let n = 256;
        let mut e = 0.0;
        for i in 0..n {
            for j in 0..n {
                let u = DVec2::new((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let s = sphere.sample(DVec3::ZERO, u).unwrap();
                e += s.direction.z / s.pdf;
            }
        }
        e /= (n * n) as f64;
        let expect = PI * (1.5f64 / 2.0).powi(2);
        assert!((e - expect).abs() < 1e-4 * expect, "{e} against {expect}");
    }
}
