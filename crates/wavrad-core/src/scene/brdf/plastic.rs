//! Rough plastic (Mitsuba 3's `roughplastic`): a rough dielectric coating
//! (microfacet reflection with dielectric Fresnel) over a Lambertian base,
//! with the base's internal reflections at the coating accounted for.
//!
//! | parameter              | meaning                                                  | default                  |
//! |------------------------|----------------------------------------------------------|--------------------------|
//! | `distribution`         | `beckmann` or `ggx` ([`super::microfacet`])              | `beckmann`               |
//! | `alpha`                | roughness of the coating (isotropic only, as Mitsuba)    | 0.1                      |
//! | `int_ior`              | interior index: number or name ([`super::fresnel::DIELECTRICS`]) | `polypropylene` (1.49) |
//! | `ext_ior`              | exterior index: number or name                           | `air` (1.000277)         |
//! | `specular_reflectance` | factor on the coating's reflection (physically 1)        | 1                        |
//! | `diffuse_reflectance`  | albedo ρ_d of the base                                   | 0.5                      |
//! | `nonlinear`            | account for the colour shift of internal scattering      | false                    |
//!
//! With η = int_ior / ext_ior,
//!
//! f = ρ_s F(wo·h, η) D(h) G(wo, wi, h) / (4 cos θ_o cos θ_i)
//!   + ρ_d / (1 − F_dr) · T(cos θ_i) T(cos θ_o) / (π η²),
//!
//! where T(μ) is the rough coating's directional transmittance and F_dr its
//! diffuse internal reflectance (`fdr_int`); F_dr is multiplied by ρ_d when
//! `nonlinear` (Weidlich & Wilkie, *Arbitrarily Layered Micro-Facet
//! Surfaces*, GRAPHITE 2007; Kelemen & Szirmay-Kalos 2001 for the
//! coupling). As in Mitsuba, T is tabulated at 64 cosines μ_k = k/63 and
//! interpolated linearly; each entry and F_dr = 2·mean_k(R(μ_k, 1/η) μ_k) are
//! Gauss–Legendre integrals over visible normals
//! ([`super::microfacet::eval_transmittance`]). f is reciprocal.
//!
//! Sampling picks the coating with probability ∝ (1 − T(cos θ_o)) w_s and
//! the base with probability ∝ T(cos θ_o)(1 − w_s), w_s = ρ̄_s / (ρ̄_s + ρ̄_d)
//! (channel means), as Mitsuba 3's `specular_sampling_weight`.

use super::fresnel::fresnel_dielectric;
use super::microfacet::{
    cosine_hemisphere_pdf, eval_reflectance, eval_transmittance, reflect, Microfacet,
    MicrofacetType,
};
use super::{cosine_hemisphere, BrdfFlags, BrdfModel, BrdfSample};
use crate::scene::Rgb;
use glam::{DVec2, DVec3};
use rayon::prelude::*;
use std::f64::consts::FRAC_1_PI;

/// Resolution of the transmittance table (Mitsuba's
/// `MI_ROUGH_TRANSMITTANCE_RES`).
pub const TRANSMITTANCE_RES: usize = 64;

/// The user-facing parameters of [`RoughPlastic`] (Mitsuba's defaults by
/// [`Default`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RoughPlasticParams {
    /// Beckmann or GGX.
    pub distribution: MicrofacetType,
    /// Roughness of the coating (≥ 10⁻⁴ after clamping).
    pub alpha: f64,
    /// Interior index of refraction.
    pub int_ior: f64,
    /// Exterior index of refraction.
    pub ext_ior: f64,
    /// Factor on the coating's reflection.
    pub specular_reflectance: Rgb,
    /// Albedo of the diffuse base.
    pub diffuse_reflectance: Rgb,
    /// Whether internal scattering shifts the base's colour.
    pub nonlinear: bool,
}

impl Default for RoughPlasticParams {
    fn default() -> RoughPlasticParams {
        RoughPlasticParams {
            distribution: MicrofacetType::Beckmann,
            alpha: 0.1,
            int_ior: 1.49,
            ext_ior: 1.000277,
            specular_reflectance: Rgb::splat(1.0),
            diffuse_reflectance: Rgb::splat(0.5),
            nonlinear: false,
        }
    }
}

/// Rough plastic BRDF (Mitsuba 3 `roughplastic`), with its precomputed
/// coating transmittance; build it with [`RoughPlastic::new`]. Serialised
/// as its parameters, the table integrated again when read.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(into = "RoughPlasticParams", try_from = "RoughPlasticParams")]
pub struct RoughPlastic {
    params: RoughPlasticParams,
    distribution: Microfacet,
    eta: f64,
    specular_sampling_weight: f64,
    external_transmittance: Box<[f64; TRANSMITTANCE_RES]>,
    internal_reflectance: f64,
}

/// The model of parameters read from a file (a solution file may hold
/// any): an error where [`RoughPlastic::new`] does not apply. The surfaces
/// of a mesh share one BSDF, each written with its parameters: the model
/// last read is reused while they repeat, so its table is integrated once,
/// as when the scene was loaded.
impl TryFrom<RoughPlasticParams> for RoughPlastic {
    type Error = String;

    fn try_from(params: RoughPlasticParams) -> Result<RoughPlastic, String> {
        thread_local! {
            static LAST: std::cell::RefCell<Option<RoughPlastic>> = const { std::cell::RefCell::new(None) };
        }
        let (int, ext) = (params.int_ior, params.ext_ior);
        if !(int > 0.0 && ext > 0.0 && int.is_finite() && ext.is_finite()) || int == ext {
            return Err(format!(
                "rough plastic with indices of refraction {int} and {ext}: they must be \
                 positive, finite and differ"
            ));
        }
        Ok(LAST.with_borrow_mut(|last| match last {
            Some(brdf) if brdf.params == params => brdf.clone(),
            _ => last.insert(RoughPlastic::new(params)).clone(),
        }))
    }
}

impl From<RoughPlastic> for RoughPlasticParams {
    fn from(brdf: RoughPlastic) -> RoughPlasticParams {
        brdf.params
    }
}

impl Default for RoughPlastic {
    fn default() -> RoughPlastic {
        RoughPlastic::new(RoughPlasticParams::default())
    }
}

impl RoughPlastic {
    /// Build the model, integrating the coating's transmittance table
    /// (≈10⁶ visible-normal samples; tens of milliseconds). The indices must
    /// be positive and differ (the scene reader checks this).
    pub fn new(params: RoughPlasticParams) -> RoughPlastic {
        debug_assert!(params.int_ior > 0.0 && params.ext_ior > 0.0);
        debug_assert!(params.int_ior != params.ext_ior);
        let eta = params.int_ior / params.ext_ior;
        let distribution = Microfacet::isotropic(params.distribution, params.alpha);
        let (d_mean, s_mean) = (
            params.diffuse_reflectance.average(),
            params.specular_reflectance.average(),
        );
        let specular_sampling_weight = if d_mean + s_mean > 0.0 {
            s_mean / (d_mean + s_mean)
        } else {
            0.0
        };
        // Tabulate T(μ) and R(μ, 1/η) at μ_k = max(10⁻⁶, k / 63)
        let rows: Vec<(f64, f64)> = (0..TRANSMITTANCE_RES)
            .into_par_iter()
            .map(|k| {
                let mu = (k as f64 / (TRANSMITTANCE_RES - 1) as f64).max(1e-6);
                let wi = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                (
                    eval_transmittance(&distribution, wi, eta),
                    eval_reflectance(&distribution, wi, 1.0 / eta) * mu,
                )
            })
            .collect();
        let external_transmittance = Box::new(std::array::from_fn(|k| rows[k].0));
        let internal_reflectance =
            2.0 * rows.iter().map(|r| r.1).sum::<f64>() / TRANSMITTANCE_RES as f64;
        RoughPlastic {
            params,
            distribution,
            eta,
            specular_sampling_weight,
            external_transmittance,
            internal_reflectance,
        }
    }

    /// The parameters it was built from.
    pub fn params(&self) -> &RoughPlasticParams {
        &self.params
    }

    /// Relative index of refraction η = int_ior / ext_ior.
    pub fn eta(&self) -> f64 {
        self.eta
    }

    /// Diffuse internal reflectance F_dr of the coating seen from inside.
    pub fn internal_reflectance(&self) -> f64 {
        self.internal_reflectance
    }

    /// Directional transmittance T(μ) of the coating from outside,
    /// interpolated in the table as Mitsuba's `lerp_gather`.
    pub fn external_transmittance(&self, mu: f64) -> f64 {
        let x = mu * (TRANSMITTANCE_RES - 1) as f64;
        let index = (x.max(0.0) as usize).min(TRANSMITTANCE_RES - 2);
        let w1 = x - index as f64;
        let t = &self.external_transmittance;
        (1.0 - w1) * t[index] + w1 * t[index + 1]
    }

    /// Probability of sampling the coating for the direction `wo`.
    fn specular_probability(&self, wo: DVec3) -> f64 {
        let t = self.external_transmittance(wo.z);
        let ps = (1.0 - t) * self.specular_sampling_weight;
        let pd = t * (1.0 - self.specular_sampling_weight);
        if ps + pd > 0.0 {
            ps / (ps + pd)
        } else {
            0.0
        }
    }
}

impl BrdfModel for RoughPlastic {
    fn eval(&self, wo: DVec3, wi: DVec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let p = &self.params;
        // Coating: microfacet reflection
        let h = (wi + wo).normalize();
        let d = self.distribution.eval(h);
        let fresnel = fresnel_dielectric(wo.dot(h), self.eta).0;
        let g = self.distribution.g(wo, wi, h);
        let spec = fresnel * d * g / (4.0 * wo.z * wi.z);
        // Base: diffuse light transmitted in and out of the coating
        let t = self.external_transmittance(wo.z) * self.external_transmittance(wi.z);
        let base = FRAC_1_PI * t / (self.eta * self.eta);
        let diffuse = p.diffuse_reflectance.map(|rho| {
            let fdr = if p.nonlinear {
                rho * self.internal_reflectance
            } else {
                self.internal_reflectance
            };
            rho / (1.0 - fdr) * base
        });
        p.specular_reflectance * spec + diffuse
    }

    fn pdf(&self, wo: DVec3, wi: DVec3) -> f64 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let ps = self.specular_probability(wo);
        let h = (wi + wo).normalize();
        let spec = self.distribution.eval(h) * self.distribution.smith_g1(wo, h) / (4.0 * wo.z);
        ps * spec + (1.0 - ps) * cosine_hemisphere_pdf(wi)
    }

    fn sample(&self, wo: DVec3, u: DVec2, lobe: f64) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if lobe < self.specular_probability(wo) {
            reflect(wo, self.distribution.sample(wo, u).0)
        } else {
            cosine_hemisphere(u)
        };
        BrdfSample::drawn(self, wo, wi)
    }

    /// The coating and the base, isotropic (as Mitsuba 3, which rejects
    /// anisotropic roughness here).
    fn flags(&self) -> BrdfFlags {
        BrdfFlags::GLOSSY_REFLECTION | BrdfFlags::DIFFUSE_REFLECTION | BrdfFlags::FRONT_SIDE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serialised_as_its_parameters_and_rebuilt_whole() {
        let p = RoughPlastic::new(RoughPlasticParams {
            alpha: 0.3,
            nonlinear: true,
            ..Default::default()
        });
        let json = serde_json::to_string(&p).unwrap();
        assert!(!json.contains("transmittance"), "{json}");
        assert_eq!(serde_json::from_str::<RoughPlastic>(&json).unwrap(), p);
    }

    #[test]
    fn parameters_new_refuses_are_an_error_when_read() {
        // Found by fuzzing solution files (docs/fuzzing.md): equal indices
        // reached `new`'s assertion from the deserialiser.
        for (int_ior, ext_ior) in [(1.5, 1.5), (-1.0, 1.0), (1.5, 0.0)] {
            let params = RoughPlasticParams {
                int_ior,
                ext_ior,
                ..Default::default()
            };
            let json = serde_json::to_string(&params).unwrap();
            let e = serde_json::from_str::<RoughPlastic>(&json).unwrap_err();
            assert!(e.to_string().contains("indices of refraction"), "{e}");
        }
    }

    #[test]
    fn coating_transmits_what_it_does_not_reflect() {
        // Smooth-ish coating at normal incidence: T ≈ 1 − F(1) = 1 − 0.04.
        let p = RoughPlastic::new(RoughPlasticParams {
            alpha: 0.01,
            int_ior: 1.5,
            ext_ior: 1.0,
            ..Default::default()
        });
        assert!((p.external_transmittance(1.0) - 0.96).abs() < 1e-4);
        // F_dr of η = 1.5 from inside is ≈ 0.6 (Egan & Hilgeman's fit: 0.596).
        assert!(
            (p.internal_reflectance() - 0.6).abs() < 0.02,
            "{}",
            p.internal_reflectance()
        );
    }

    #[test]
    fn defaults_are_mitsubas() {
        let p = RoughPlastic::default();
        assert!((p.eta() - 1.49 / 1.000277).abs() < 1e-12);
        assert_eq!(p.params().diffuse_reflectance, Rgb::splat(0.5));
    }
}
