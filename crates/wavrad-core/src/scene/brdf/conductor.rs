//! Rough metal (Mitsuba 3's `roughconductor`): a microfacet reflection with
//! the Fresnel reflectance of a complex index of refraction per channel.
//!
//! | parameter              | meaning                                                    | default    |
//! |------------------------|------------------------------------------------------------|------------|
//! | `distribution`         | `beckmann` or `ggx` ([`super::microfacet`])                | `beckmann` |
//! | `alpha`                | roughness of both directions                               | 0.1        |
//! | `alpha_u`, `alpha_v`   | anisotropic roughness (both or neither, not with `alpha`)  | `alpha`    |
//! | `material`             | a named conductor ([`super::fresnel::CONDUCTORS`])         | `none`     |
//! | `eta`, `k`             | complex index η + ik per channel (instead of `material`)   | 0, 1       |
//! | `specular_reflectance` | factor on the reflection (physically 1)                    | 1          |
//!
//! f(wo, wi) = ρ_s F(wo·h) D(h) G(wo, wi, h) / (4 cos θ_o cos θ_i) with h the
//! normalised half vector (Torrance & Sparrow 1967; Walter et al. 2007,
//! eq. 20), F the conductor Fresnel term ([`super::fresnel::fresnel_conductor`]).
//! It is reciprocal: wi·h = wo·h and G is symmetric. The default `none`
//! (η = 0, k = 1) is Mitsuba's: F = 1, a perfect mirror at every angle.
//! Sampling draws a visible normal for `wo` and reflects (Heitz & d'Eon
//! 2014); the density is D(h) G1(wo, h) / (4 cos θ_o), the weight
//! ρ_s F G1(wi, h).

use super::fresnel::fresnel_conductor_rgb;
use super::microfacet::{reflect, Microfacet};
use super::{BrdfFlags, BrdfModel, BrdfSample};
use crate::scene::Rgb;
use glam::{DVec2, DVec3};

/// Rough conductor BRDF (Mitsuba 3 `roughconductor`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RoughConductor {
    /// The microfacet distribution (type and roughness).
    pub distribution: Microfacet,
    /// Real part η of the relative index of refraction, per channel.
    pub eta: Rgb,
    /// Imaginary part k of the relative index, per channel.
    pub k: Rgb,
    /// Factor on the reflection, per channel.
    pub specular_reflectance: Rgb,
}

impl Default for RoughConductor {
    /// Mitsuba's defaults: Beckmann, α = 0.1, material `none`, ρ_s = 1.
    fn default() -> RoughConductor {
        RoughConductor {
            distribution: Microfacet::isotropic(super::MicrofacetType::Beckmann, 0.1),
            eta: Rgb::ZERO,
            k: Rgb::splat(1.0),
            specular_reflectance: Rgb::splat(1.0),
        }
    }
}

impl RoughConductor {
    fn fresnel(&self, cos_theta: f64) -> Rgb {
        fresnel_conductor_rgb(cos_theta, self.eta, self.k) * self.specular_reflectance
    }
}

impl BrdfModel for RoughConductor {
    fn eval(&self, wo: DVec3, wi: DVec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let h = (wi + wo).normalize();
        let d = self.distribution.eval(h);
        if d == 0.0 {
            return Rgb::ZERO;
        }
        let g = self.distribution.g(wo, wi, h);
        let value = d * g / (4.0 * wo.z * wi.z);
        self.fresnel(wo.dot(h)).map(|f| f * value)
    }

    fn pdf(&self, wo: DVec3, wi: DVec3) -> f64 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let h = (wi + wo).normalize();
        if wo.dot(h) <= 0.0 || wi.dot(h) <= 0.0 {
            return 0.0;
        }
        self.distribution.eval(h) * self.distribution.smith_g1(wo, h) / (4.0 * wo.z)
    }

    fn sample(&self, wo: DVec3, u: DVec2, _lobe: f64) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let (m, pdf_m) = self.distribution.sample(wo, u);
        let wi = reflect(wo, m);
        if pdf_m == 0.0 || wi.z <= 0.0 {
            return None;
        }
        let g1 = self.distribution.smith_g1(wi, m);
        let pdf = pdf_m / (4.0 * wi.dot(m));
        Some(BrdfSample {
            direction: wi,
            pdf,
            weight: self.fresnel(wo.dot(m)).map(|f| f * g1),
        })
    }

    /// Anisotropic when α_u ≠ α_v (Mitsuba 3 compares the two textures, so
    /// it also calls equal `alpha_u` and `alpha_v` given apart anisotropic).
    fn flags(&self) -> BrdfFlags {
        let d = &self.distribution;
        BrdfFlags::glossy(false, d.alpha_u != d.alpha_v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::brdf::MicrofacetType;

    #[test]
    fn default_is_a_white_mirror_lobe() {
        let c = RoughConductor::default();
        // F = 1: the value is the bare microfacet term.
        let (wi, wo) = (
            DVec3::new(0.3, 0.1, 0.9).normalize(),
            DVec3::new(-0.25, -0.05, 0.95).normalize(),
        );
        let h = (wi + wo).normalize();
        let d = &c.distribution;
        let expect = d.eval(h) * d.g(wo, wi, h) / (4.0 * wi.z * wo.z);
        let f = c.eval(wo, wi);
        assert!(f.0.iter().all(|v| (v - expect).abs() < 1e-12 * expect));
    }

    #[test]
    fn sample_weight_is_f_cos_over_pdf() {
        let c = RoughConductor {
            distribution: Microfacet::new(MicrofacetType::Ggx, 0.3, 0.15),
            eta: Rgb([0.2, 0.9, 1.1]),
            k: Rgb([3.9, 2.4, 2.1]),
            specular_reflectance: Rgb::splat(1.0),
        };
        let wo = DVec3::new(0.5, 0.2, 0.7).normalize();
        let s = c.sample(wo, DVec2::new(0.3, 0.8), 0.0).unwrap();
        let f = c.eval(wo, s.direction);
        assert!((s.pdf - c.pdf(wo, s.direction)).abs() < 1e-12 * s.pdf);
        for (w, f) in s.weight.0.into_iter().zip(f.0) {
            let expect = f * s.direction.z / s.pdf;
            assert!((w - expect).abs() < 1e-12 * expect);
        }
    }
}
