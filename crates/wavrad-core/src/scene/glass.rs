//! Glass: smooth dielectric interfaces (Mitsuba 3's `dielectric` and
//! `thindielectric`). They are not among the solve's surfaces: the solve,
//! its gathers and its shadow rays let light through them as if they were
//! not there, while camera rays follow their reflection and refraction
//! exactly ([`crate::render::glass`]; ARCHITECTURE.md, "Smooth specular and
//! glass").
//!
//! ```
//! use wavrad_core::scene::glass::{Dielectric, Transport::Radiance};
//! use wavrad_core::scene::Rgb;
//! use glam::DVec3;
//!
//! let glass = Dielectric { eta: 1.5, thin: false, reflectance: Rgb::splat(1.0), transmittance: Rgb::splat(1.0) };
//! // Straight down onto the interface: 4 % is reflected (u below it), the rest refracts.
//! let (dir, weight) = glass.scatter(-DVec3::Z, DVec3::Z, 0.5, Radiance);
//! assert_eq!(dir, -DVec3::Z);
//! assert!((weight[0] - 1.0 / 2.25).abs() < 1e-12);
//! let (dir, _) = glass.scatter(-DVec3::Z, DVec3::Z, 0.01, Radiance);
//! assert_eq!(dir, DVec3::Z);
//! ```

use crate::scene::brdf::fresnel::fresnel_dielectric;
use crate::scene::shading::ShadingNormals;
use crate::scene::{Patch, Rgb};
use glam::DVec3;

/// A smooth interface between two dielectrics, as Mitsuba 3's
/// `dielectric` (a solid's boundary: rays refract into and out of it) or
/// `thindielectric` (a thin pane: rays pass straight through, and the
/// light reflected back and forth inside it adds to the reflection).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Dielectric {
    /// Relative index of refraction, interior over exterior (`int_ior /
    /// ext_ior`); the interior is behind the shading normal.
    pub eta: f64,
    /// A thin pane (`thindielectric`) rather than a solid's boundary.
    pub thin: bool,
    /// Scales the reflected light (`specular_reflectance`).
    pub reflectance: Rgb,
    /// Scales the transmitted light (`specular_transmittance`).
    pub transmittance: Rgb,
}

/// What a ray carries across an interface, which decides how a refracted
/// ray's weight changes (Mitsuba 3's `TransportMode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transport {
    /// Radiance, traced from the eye: scaled by (η_t/η_i)⁻² where it
    /// refracts, the solid angle's compression.
    Radiance,
    /// Power (a photon), traced from a light: unscaled.
    Power,
}

/// The faces of one glass shape, all of one interface.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Glass {
    /// The shape's `id` (else its name, else `plugin#index`), for messages.
    pub name: String,
    /// What its faces are made of.
    pub interface: Dielectric,
    /// Its faces, front side that of its shading normal (the exterior),
    /// with their shading normals where the shape is curved or smooth.
    pub faces: Vec<(Patch, Option<ShadingNormals>)>,
    /// The exact sphere (centre, radius; the exterior outside) that the
    /// faces tessellate, for Mitsuba's `sphere`: rays meet it instead of
    /// its faces.
    pub sphere: Option<(DVec3, f64)>,
}

impl Dielectric {
    /// The reflectance of the interface for light arriving along a
    /// direction whose cosine with the shading normal is `cos_theta`
    /// (negative from inside), with a thin pane's inner reflections added
    /// (Mitsuba's `thindielectric`: R + T²R/(1 − R²) = 2R/(1 + R)).
    pub fn reflectance_at(&self, cos_theta: f64) -> f64 {
        if self.thin {
            let r = fresnel_dielectric(cos_theta.abs(), self.eta).0;
            r * 2.0 / (1.0 + r)
        } else {
            fresnel_dielectric(cos_theta, self.eta).0
        }
    }

    /// Where a ray travelling along `dir` (unit) that meets the interface
    /// at shading normal `normal` goes on, and the weight its radiance
    /// takes there, choosing reflection when `u` ∈ [0, 1) falls below the
    /// Fresnel reflectance and transmission otherwise (Mitsuba 3's
    /// `dielectric` and `thindielectric` `sample`: the choice's
    /// probability cancels the Fresnel factor, and a refracted ray's
    /// radiance, not its power, is scaled by (η_t/η_i)⁻², the solid
    /// angle's compression across the interface).
    pub fn scatter(&self, dir: DVec3, normal: DVec3, u: f64, transport: Transport) -> (DVec3, Rgb) {
        let cos_theta_i = -dir.dot(normal);
        let reflect = || dir + 2.0 * cos_theta_i * normal;
        if self.thin {
            return if u < self.reflectance_at(cos_theta_i) {
                (reflect(), self.reflectance)
            } else {
                (dir, self.transmittance)
            };
        }
        let (r, cos_theta_t, _, eta_ti) = fresnel_dielectric(cos_theta_i, self.eta);
        if u < r {
            return (reflect(), self.reflectance);
        }
        // Mitsuba's refract(): −η_ti·wi's tangential part, plus cosθt·n.
        let wi = -dir;
        let tangential = wi - cos_theta_i * normal;
        let refracted = (-eta_ti * tangential + cos_theta_t * normal).normalize();
        let scale = match transport {
            Transport::Radiance => eta_ti * eta_ti,
            Transport::Power => 1.0,
        };
        (refracted, self.transmittance * scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn glass(thin: bool) -> Dielectric {
        Dielectric {
            eta: 1.5,
            thin,
            reflectance: Rgb::splat(1.0),
            transmittance: Rgb::splat(1.0),
        }
    }

    #[test]
    fn refraction_obeys_snells_law_both_ways() {
        let g = glass(false);
        let n = DVec3::Z;
        for theta_deg in [10.0_f64, 30.0, 40.0, 60.0, 80.0] {
            let t = theta_deg.to_radians();
            let dir = DVec3::new(t.sin(), 0.0, -t.cos());
            let (out, w) = g.scatter(dir, n, 0.999, Transport::Radiance);
            // sin θi = η sin θt, on the same side of the normal's plane.
            assert!((t.sin() - 1.5 * out.x).abs() < 1e-12, "{theta_deg}");
            assert!(out.z < 0.0 && (out.length() - 1.0).abs() < 1e-12);
            assert!((w[0] - 1.0 / 2.25).abs() < 1e-12);
            // Back out along the reversed ray: the original direction, and
            // the inverse radiance scale.
            let (back, w) = g.scatter(-out, n, 0.999, Transport::Radiance);
            assert!((back + dir).length() < 1e-12, "{theta_deg}");
            assert!((w[0] - 2.25).abs() < 1e-12);
            // A photon's power is not scaled.
            let (_, w) = g.scatter(dir, n, 0.999, Transport::Power);
            assert_eq!(w, Rgb::splat(1.0));
        }
    }

    #[test]
    fn beyond_the_critical_angle_light_is_reflected_inside() {
        let g = glass(false);
        // sin θ = 0.8 > 1/1.5 from inside (travelling along +z into the
        // interface whose normal is +z).
        let dir = DVec3::new(0.8, 0.0, 0.6);
        assert_eq!(g.reflectance_at(-dir.dot(DVec3::Z)), 1.0);
        let (out, _) = g.scatter(dir, DVec3::Z, 0.9999, Transport::Power);
        assert!((out - DVec3::new(0.8, 0.0, -0.6)).length() < 1e-12);
    }

    #[test]
    fn a_thin_pane_reflects_its_inner_reflections_and_does_not_bend_light() {
        let (solid, thin) = (glass(false), glass(true));
        let r = solid.reflectance_at(1.0);
        assert!((r - 0.04).abs() < 1e-12);
        assert!((thin.reflectance_at(1.0) - 2.0 * r / (1.0 + r)).abs() < 1e-15);
        // The same from either side.
        assert_eq!(thin.reflectance_at(-0.3), thin.reflectance_at(0.3));
        let dir = DVec3::new(0.6, 0.0, -0.8);
        assert_eq!(
            thin.scatter(dir, DVec3::Z, 0.5, Transport::Radiance),
            (dir, Rgb::splat(1.0))
        );
    }
}
