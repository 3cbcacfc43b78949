//! Lights that are not surfaces: Mitsuba 3's `point`, `spot` and
//! `directional` emitters (delta lights: a point or a direction, never seen
//! by a ray) and its `constant` and `envmap` emitters (the sky: a source
//! enclosing the scene, seen by every ray that leaves it).
//!
//! What a light brings to a point is an [`Incident`]: a direction, a
//! distance and the irradiance it gives the point's plane. For a delta light
//! that is exact (E = I(ω)·cosθ/r², or E⊥·cosθ for a directional light); for
//! the sky it is one sample of E = ∫ L cosθ dω: an even sky's drawn in
//! proportion to cosθ (L·π, whatever the direction), an environment map's
//! drawn by cosθ or by the map's light, half and half, and weighted by the
//! balance heuristic (one-sample MIS, Veach 1997 §9.2.4), so that averaging
//! the samples of a stratified grid estimates its irradiance. Whether the light
//! is occluded is for the caller, who knows the scene's ray queries
//! ([`crate::kernel::lights`]).

use crate::scene::envmap::EnvMap;
use crate::scene::Rgb;
use glam::{DVec2, DVec3};
use std::f64::consts::PI;

/// A light that is not a surface.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Light {
    /// Mitsuba's `point`: radiant intensity `intensity` (W sr⁻¹) in every
    /// direction from `position`.
    Point {
        /// Where it is.
        position: DVec3,
        /// Radiant intensity per channel.
        intensity: Rgb,
    },
    /// Mitsuba's `spot`: a point light whose intensity falls off with the
    /// angle θ from its `axis`, as Mitsuba 3's smooth falloff: full within
    /// `beam_width`, linear in θ down to zero at `cutoff` (radians).
    Spot {
        /// Where it is.
        position: DVec3,
        /// Unit direction of the beam's centre.
        axis: DVec3,
        /// Radiant intensity along the axis, per channel.
        intensity: Rgb,
        /// Angle beyond which it sends nothing (0 < cutoff ≤ π/2).
        cutoff: f64,
        /// Angle within which it sends its full intensity (≤ cutoff).
        beam_width: f64,
    },
    /// Mitsuba's `directional`: parallel light travelling along
    /// `direction`, of irradiance `irradiance` on a plane facing it.
    Directional {
        /// Unit direction in which the light travels.
        direction: DVec3,
        /// Irradiance (W m⁻²) on a plane perpendicular to it.
        irradiance: Rgb,
    },
    /// Mitsuba's `constant`: radiance `radiance` arriving from every
    /// direction that leaves the scene.
    Constant {
        /// Radiance per channel.
        radiance: Rgb,
    },
    /// Mitsuba's `envmap`: radiance arriving from every direction that
    /// leaves the scene, read from an image.
    Envmap(EnvMap),
}

/// Light arriving at a point from a [`Light`] along one direction,
/// occlusion not considered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Incident {
    /// Unit direction from the point towards the light.
    pub direction: DVec3,
    /// Distance to the light (infinite for a directional light or the sky).
    pub distance: f64,
    /// Irradiance it gives the point's plane: exact for a delta light, one
    /// sample of a cosine-weighted estimate for the sky.
    pub irradiance: Rgb,
}

impl Light {
    /// True for a point, spot or directional light: light from one point or
    /// direction, which no ray can meet.
    pub fn is_delta(&self) -> bool {
        !matches!(self, Light::Constant { .. } | Light::Envmap(_))
    }

    /// True when it sends no light (all of its values zero).
    pub fn is_dark(&self) -> bool {
        let value = match self {
            Light::Point { intensity, .. } | Light::Spot { intensity, .. } => intensity,
            Light::Directional { irradiance, .. } => irradiance,
            Light::Constant { radiance } => radiance,
            Light::Envmap(_) => return false, // a map without light is refused
        };
        value.max_channel() <= 0.0
    }

    /// Where a point or spot light is and its radiant intensity along the
    /// unit direction `direction` it sends light in (a spot's falloff
    /// applied); `None` outside a spot's cone and for the other lights.
    pub fn point_intensity(&self, direction: DVec3) -> Option<(DVec3, Rgb)> {
        match *self {
            Light::Point {
                position,
                intensity,
            } => Some((position, intensity)),
            Light::Spot {
                position,
                axis,
                intensity,
                cutoff,
                beam_width,
            } => {
                let falloff = spot_falloff(axis.dot(direction), cutoff, beam_width);
                (falloff > 0.0).then(|| (position, intensity * falloff))
            }
            _ => None,
        }
    }

    /// Light arriving at `x`, on a plane of unit normal `normal`, from this
    /// light: a delta light's exact irradiance (`u` unused), or the sky's
    /// sample along the cosine-distributed direction `u` ∈ \[0,1)² picks
    /// about the normal. `None` where it brings nothing (behind the plane,
    /// outside a spot's cone).
    pub fn incident(&self, x: DVec3, normal: DVec3, u: DVec2) -> Option<Incident> {
        let towards = |position: DVec3, intensity: Rgb| {
            let d = position - x;
            let r2 = d.length_squared();
            let direction = d / r2.sqrt();
            let cos = normal.dot(direction);
            (cos > 0.0 && r2 > 0.0).then(|| Incident {
                direction,
                distance: r2.sqrt(),
                irradiance: intensity * (cos / r2),
            })
        };
        let cosine = |u: DVec2| {
            let local = crate::scene::brdf::cosine_hemisphere(u);
            let (t, b) = normal.any_orthonormal_pair();
            (local.x * t + local.y * b + local.z * normal).normalize()
        };
        match *self {
            Light::Point { position, .. } | Light::Spot { position, .. } => {
                let (_, intensity) = self.point_intensity((x - position).normalize())?;
                towards(position, intensity)
            }
            Light::Directional {
                direction,
                irradiance,
            } => {
                let cos = -normal.dot(direction);
                (cos > 0.0).then(|| Incident {
                    direction: -direction,
                    distance: f64::INFINITY,
                    irradiance: irradiance * cos,
                })
            }
            Light::Constant { radiance } => {
                let direction = cosine(u);
                (normal.dot(direction) > 0.0).then(|| Incident {
                    direction,
                    distance: f64::INFINITY,
                    irradiance: radiance * PI,
                })
            }
            Light::Envmap(ref map) => {
                // The first half of u.x draws by cosθ, the second by the map.
                let direction = match u.x < 0.5 {
                    true => cosine(DVec2::new(2.0 * u.x, u.y)),
                    false => map.sample(DVec2::new(2.0 * u.x - 1.0, u.y)).0,
                };
                let cos = normal.dot(direction);
                let density = 0.5 * cos * std::f64::consts::FRAC_1_PI + 0.5 * map.pdf(direction);
                (cos > 0.0 && density > 0.0).then(|| Incident {
                    direction,
                    distance: f64::INFINITY,
                    irradiance: map.radiance(direction) * (cos / density),
                })
            }
        }
    }

    /// Radiance a ray leaving the scene along `direction` meets: the sky's,
    /// zero for a delta light.
    pub fn radiance_towards(&self, direction: DVec3) -> Rgb {
        match self {
            Light::Constant { radiance } => *radiance,
            Light::Envmap(map) => map.radiance(direction),
            _ => Rgb::ZERO,
        }
    }

    /// A radiance on the scale of what this light makes a white Lambertian
    /// surface reflect at distance `extent` (the scene's size), so that
    /// tolerances and oracles relative to the brightest light have a
    /// reference where no surface emits.
    pub fn radiance_scale(&self, extent: f64) -> f64 {
        match *self {
            Light::Point { intensity, .. } | Light::Spot { intensity, .. } => {
                intensity.max_channel() / (PI * extent * extent).max(f64::MIN_POSITIVE)
            }
            Light::Directional { irradiance, .. } => irradiance.max_channel() / PI,
            Light::Constant { radiance } => radiance.max_channel(),
            Light::Envmap(ref map) => map.mean_radiance(),
        }
    }
}

/// Mitsuba 3's spot falloff (`spotlight.cpp`, `falloff_curve`) at
/// `cos_theta` from the axis: 1 within `beam_width`, (cutoff − θ)/(cutoff −
/// beam_width) beyond, 0 from `cutoff` on.
pub fn spot_falloff(cos_theta: f64, cutoff: f64, beam_width: f64) -> f64 {
    if cos_theta <= cutoff.cos() {
        return 0.0;
    }
    if cos_theta >= beam_width.cos() || cutoff <= beam_width {
        return 1.0;
    }
    ((cutoff - cos_theta.clamp(-1.0, 1.0).acos()) / (cutoff - beam_width)).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_light_irradiance_follows_the_inverse_square_and_cosine_laws() {
        let light = Light::Point {
            position: DVec3::new(0.0, 0.0, 2.0),
            intensity: Rgb::splat(8.0),
        };
        let at = |x: DVec3| light.incident(x, DVec3::Z, DVec2::ZERO);
        let below = at(DVec3::ZERO).unwrap();
        assert!((below.irradiance[0] - 2.0).abs() < 1e-12);
        assert!((below.distance - 2.0).abs() < 1e-12);
        // 45° off: r² = 8, cosθ = 1/√2.
        let off = at(DVec3::new(2.0, 0.0, 0.0)).unwrap();
        assert!((off.irradiance[0] - 8.0 / 8.0 / 2f64.sqrt()).abs() < 1e-12);
        // Behind the plane: nothing.
        assert!(light
            .incident(DVec3::ZERO, -DVec3::Z, DVec2::ZERO)
            .is_none());
    }

    #[test]
    fn spot_falloff_is_full_in_the_beam_linear_in_angle_and_zero_past_the_cutoff() {
        let (cutoff, beam) = (20f64.to_radians(), 15f64.to_radians());
        assert_eq!(spot_falloff(1.0, cutoff, beam), 1.0);
        assert_eq!(spot_falloff(14f64.to_radians().cos(), cutoff, beam), 1.0);
        let mid = spot_falloff(17.5f64.to_radians().cos(), cutoff, beam);
        assert!((mid - 0.5).abs() < 1e-9, "{mid}");
        assert_eq!(spot_falloff(21f64.to_radians().cos(), cutoff, beam), 0.0);
        let spot = Light::Spot {
            position: DVec3::new(0.0, 0.0, 1.0),
            axis: -DVec3::Z,
            intensity: Rgb::splat(1.0),
            cutoff,
            beam_width: beam,
        };
        let outside = DVec3::new(1.0, 0.0, 0.0); // 45° off the axis
        assert!(spot.incident(outside, DVec3::Z, DVec2::ZERO).is_none());
        assert!(spot.incident(DVec3::ZERO, DVec3::Z, DVec2::ZERO).is_some());
    }

    #[test]
    fn directional_light_and_sky_give_their_irradiance() {
        let sun = Light::Directional {
            direction: DVec3::new(0.0, -1.0, -1.0).normalize(),
            irradiance: Rgb::splat(2.0),
        };
        let lit = sun.incident(DVec3::ZERO, DVec3::Z, DVec2::ZERO).unwrap();
        assert!((lit.irradiance[0] - 2f64.sqrt()).abs() < 1e-12);
        assert!(lit.distance.is_infinite() && lit.direction.z > 0.0);
        assert!(sun.incident(DVec3::ZERO, -DVec3::Z, DVec2::ZERO).is_none());
        // The unoccluded sky of radiance L gives E = πL on any plane.
        let sky = Light::Constant {
            radiance: Rgb::splat(0.5),
        };
        let n = DVec3::new(1.0, 2.0, -0.5).normalize();
        let mut e = 0.0;
        for k in 0..64 {
            let u = DVec2::new(
                (f64::from(k % 8) + 0.5) / 8.0,
                (f64::from(k / 8) + 0.5) / 8.0,
            );
            let s = sky.incident(DVec3::ZERO, n, u).unwrap();
            assert!(s.direction.dot(n) > 0.0);
            e += s.irradiance[0] / 64.0;
        }
        assert!((e - 0.5 * PI).abs() < 1e-12);
        assert!(!sky.is_delta() && sun.is_delta());
    }
}
