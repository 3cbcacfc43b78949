//! The reflection of Mitsuba 3's `principled` BSDF (Burley, *Physically
//! Based Shading at Disney*, SIGGRAPH 2012 course; Mitsuba 3's
//! `src/bsdfs/principled.cpp` and `principledhelpers.h`) that the radiosity
//! solution can carry: a Lambertian lobe plus its GGX specular lobe, its
//! clearcoat and its sheen.
//!
//! | parameter     | meaning                                                        | default |
//! |---------------|----------------------------------------------------------------|---------|
//! | `base_color`  | colour of the diffuse lobe and of the metallic reflection      | 0.5     |
//! | `roughness`   | α = roughness² of the GGX lobe                                 | 0.5     |
//! | `anisotropic` | α_u = α/a, α_v = α·a with a = √(1 − 0.9·anisotropic)           | 0       |
//! | `metallic`    | blend from dielectric to metallic reflection                   | 0       |
//! | `specular`    | index η = 2 / (1 − √(0.08·specular)) − 1 of the dielectric part | 0.5    |
//! | `spec_tint`   | share of the dielectric Fresnel tinted towards `base_color`    | 0       |
//! | `spec_trans`  | share of the base that transmits (the transmission is dropped) | 0       |
//! | `clearcoat`   | weight of a second, colourless GTR1 specular lobe               | 0       |
//! | `clearcoat_gloss` | its α = 0.1 (gloss 0) to 0.001 (gloss 1), linearly          | 0       |
//! | `sheen`       | weight of a retro-reflective lobe that brightens grazing views  | 0       |
//! | `sheen_tint`  | share of the sheen tinted towards `base_color`                  | 0       |
//! | `flatness`    | blend of Burley's diffuse lobe towards his fake subsurface      | 0       |
//!
//! With h the half vector and c = wo·h, the front-side BRDF is
//!
//! f = ρ_d / π + F(c) D(h) G(wo, wi, h) / (4 cos θ_o cos θ_i),
//!
//! F = (1 − m)(1 − t) F_diel(c, η) + m S(base, c) + (1 − m) t S(base/lum · R₀(η), c),
//!
//! exactly Mitsuba's `principled_fresnel` on the front side (m: `metallic`,
//! t: `spec_tint`, S the Schlick approximation `calc_schlick`, R₀(η) =
//! ((η − 1)/(η + 1))², lum the base's luminance); the lobe is off where
//! F_diel = 0 (η = 1), as there. Mitsuba's diffuse lobe is Burley's
//! (`f_diff + f_retro`, blended towards the fake subsurface by `flatness`),
//! which is not Lambertian: wavrad takes ρ_d = base (1 − m)(1 − spec_trans)
//! · A(roughness, flatness),
//! where A is the ratio of that lobe's bihemispherical albedo to a
//! Lambertian's ([`burley_albedo`]), so a surface under uniform light
//! reflects the same power. The Lambertian lobe goes through the solution's
//! two-point links ([`super::Brdf::lambertian`]), the specular one through
//! three-point links.
//!
//! Clearcoat and sheen are added as Mitsuba 3.9's `principled.cpp` adds
//! them (which departs from Burley's notes: its clearcoat has no
//! 1/(4 cos θ_i cos θ_o), its sheen no 1/π):
//!
//! f_cc = ¼ c S(0.04, wo·h) D₁(h) G₁(wo) G₁(wi), f_sh = s (1 − m) C_sh (1 − wi·h)⁵,
//!
//! D₁ Burley's GTR1 of α = lerp(0.1, 0.001, `clearcoat_gloss`), G₁ Smith's
//! GGX masking at α = 0.25, C_sh = lerp(1, base/lum, `sheen_tint`); the
//! sheen only where the diffuse lobe is, as there. Both are among the
//! specular part the three-point links carry, not the Lambertian lobe.
//! The specular transmission is not modelled (the scene reader warns).
//!
//! Sampling picks the specular lobe, the clearcoat and the cosine-sampled
//! diffuse and sheen lobes in proportion to ρ̄_s, ¼c and ρ̄_d + s̄, ρ̄_s the
//! channel mean of F at normal incidence; the specular lobe draws a visible
//! normal, the clearcoat a GTR1 normal (Burley's inversion), each
//! reflected. The density is the mixture of the three.

use super::fresnel::fresnel_dielectric;
use super::microfacet::{cosine_hemisphere_pdf, reflect, Microfacet, MicrofacetType};
use super::{cosine_hemisphere, BrdfFlags, BrdfModel, BrdfSample};
use crate::scene::Rgb;
use glam::{DVec2, DVec3};
use std::f64::consts::{FRAC_1_PI, PI};

/// Burley's diffuse plus GGX reflection of a `principled` surface, with
/// the Lambertian lobe the solution carries for the diffuse one.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Principled {
    /// Albedo ρ_d of the Lambertian lobe the solution's two-point links
    /// carry ([`super::Brdf::lambertian`]); zero in the BRDF less it.
    pub diffuse_reflectance: Rgb,
    /// The weight base (1 − m)(1 − spec_trans) of Burley's diffuse lobe,
    /// which [`BrdfModel::eval`] evaluates; zero where the diffuse lobe is
    /// left out ([`super::Brdf::without_lambertian`]).
    pub burley: Rgb,
    /// `roughness`: Burley's retro-reflection grows with it.
    pub roughness: f64,
    /// `flatness`, in [0, 1]: the share of Burley's fake subsurface in his
    /// diffuse lobe.
    pub flatness: f64,
    /// The Lambertian albedo taken out of Burley's lobe
    /// ([`super::Brdf::shading_rest`]): [`BrdfModel::eval`] subtracts its
    /// ρ/π, leaving the signed difference between Burley's lobe and the
    /// Lambertian one, with no bihemispherical albedo.
    pub lambertian_removed: Rgb,
    /// `base_color`: the metallic Fresnel's normal reflectance and the tint.
    pub base_color: Rgb,
    /// `metallic`, in [0, 1].
    pub metallic: f64,
    /// `spec_tint`, in [0, 1].
    pub spec_tint: f64,
    /// Relative index of refraction η of the dielectric part.
    pub eta: f64,
    /// The GGX distribution of the specular lobe.
    pub distribution: Microfacet,
    /// `clearcoat`, in [0, 1]: the clearcoat lobe's weight (¼ of it).
    pub clearcoat: f64,
    /// The clearcoat's GTR1 roughness, lerp(0.1, 0.001, `clearcoat_gloss`).
    pub clearcoat_alpha: f64,
    /// The sheen lobe's colour s (1 − m) C_sh, zero without a diffuse lobe.
    pub sheen: Rgb,
}

/// The parameters of Mitsuba 3's `principled` that [`Principled`] models.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrincipledParams {
    /// `base_color`.
    pub base_color: Rgb,
    /// `roughness`.
    pub roughness: f64,
    /// `anisotropic`.
    pub anisotropic: f64,
    /// `metallic`.
    pub metallic: f64,
    /// `specular` (ignored when `eta` is given).
    pub specular: f64,
    /// `eta`, given instead of `specular`.
    pub eta: Option<f64>,
    /// `spec_tint`.
    pub spec_tint: f64,
    /// `spec_trans`.
    pub spec_trans: f64,
    /// `clearcoat`.
    pub clearcoat: f64,
    /// `clearcoat_gloss`.
    pub clearcoat_gloss: f64,
    /// `sheen`.
    pub sheen: f64,
    /// `sheen_tint`.
    pub sheen_tint: f64,
    /// `flatness`.
    pub flatness: f64,
}

impl Default for PrincipledParams {
    /// Mitsuba 3's defaults.
    fn default() -> PrincipledParams {
        PrincipledParams {
            base_color: Rgb::splat(0.5),
            roughness: 0.5,
            anisotropic: 0.0,
            metallic: 0.0,
            specular: 0.5,
            eta: None,
            spec_tint: 0.0,
            spec_trans: 0.0,
            clearcoat: 0.0,
            clearcoat_gloss: 0.0,
            sheen: 0.0,
            sheen_tint: 0.0,
            flatness: 0.0,
        }
    }
}

impl Principled {
    /// The model of Mitsuba's parameters (weights clamped to [0, 1]), as
    /// its constructor and `calc_dist_params` derive η and α_u, α_v.
    pub fn new(p: PrincipledParams) -> Principled {
        let unit = |x: f64| x.clamp(0.0, 1.0);
        let (metallic, spec_tint, spec_trans) =
            (unit(p.metallic), unit(p.spec_tint), unit(p.spec_trans));
        let eta = p
            .eta
            .unwrap_or_else(|| 2.0 / (1.0 - (0.08 * unit(p.specular)).sqrt()) - 1.0);
        let alpha = p.roughness * p.roughness;
        let aspect = (1.0 - 0.9 * unit(p.anisotropic)).sqrt();
        let distribution = Microfacet::new(
            MicrofacetType::Ggx,
            (alpha / aspect).max(1e-3),
            (alpha * aspect).max(1e-3),
        );
        let base_color = p.base_color.map(unit);
        let burley = base_color.map(|c| c * (1.0 - metallic) * (1.0 - spec_trans));
        let roughness = unit(p.roughness);
        let flatness = unit(p.flatness);
        let lum = base_color.luminance();
        let sheen_tint = unit(p.sheen_tint);
        let sheen = match (1.0 - metallic) * (1.0 - spec_trans) > 0.0 {
            true => base_color.map(|c| {
                let tint = if lum > 0.0 { c / lum } else { 1.0 };
                unit(p.sheen) * (1.0 - metallic) * (1.0 + sheen_tint * (tint - 1.0))
            }),
            false => Rgb::ZERO,
        };
        let gloss = unit(p.clearcoat_gloss);
        Principled {
            diffuse_reflectance: burley.map(|c| c * burley_albedo(roughness, flatness)),
            burley,
            roughness,
            flatness,
            lambertian_removed: Rgb::ZERO,
            base_color,
            metallic,
            spec_tint,
            eta,
            distribution,
            clearcoat: unit(p.clearcoat),
            clearcoat_alpha: 0.1 + gloss * (0.001 - 0.1),
            sheen,
        }
    }

    /// The Fresnel term of the specular lobe at c = wo·h (Mitsuba's
    /// `principled_fresnel`, front side).
    pub fn fresnel(&self, cos_theta: f64) -> Rgb {
        let dielectric = fresnel_dielectric(cos_theta, self.eta).0;
        let (m, t) = (self.metallic, self.spec_tint);
        let mut f = Rgb::splat((1.0 - m) * (1.0 - t) * dielectric);
        if m > 0.0 {
            f += self
                .base_color
                .map(|r0| m * schlick(r0, cos_theta, self.eta));
        }
        if t > 0.0 {
            let lum = self.base_color.luminance();
            let r0 = ((self.eta - 1.0) / (self.eta + 1.0)).powi(2);
            f += self.base_color.map(|c| {
                let tint = if lum > 0.0 { c / lum } else { 1.0 };
                (1.0 - m) * t * schlick(tint * r0, cos_theta, self.eta)
            });
        }
        f
    }

    /// The specular lobe alone (no cosine), zero where F_diel vanishes.
    fn specular(&self, wo: DVec3, wi: DVec3) -> Rgb {
        let h = (wi + wo).normalize();
        if wo.dot(h) <= 0.0 || wi.dot(h) <= 0.0 || fresnel_dielectric(wo.dot(h), self.eta).0 <= 0.0
        {
            return Rgb::ZERO;
        }
        let d = self.distribution.eval(h);
        if d == 0.0 {
            return Rgb::ZERO;
        }
        let value = d * self.distribution.g(wo, wi, h) / (4.0 * wo.z * wi.z);
        self.fresnel(wo.dot(h)).map(|f| f * value)
    }

    /// The clearcoat lobe alone (no cosine), as Mitsuba 3.9 evaluates it.
    fn clearcoat(&self, wo: DVec3, wi: DVec3) -> f64 {
        let h = (wi + wo).normalize();
        if self.clearcoat == 0.0 || wo.dot(h) <= 0.0 || wi.dot(h) <= 0.0 {
            return 0.0;
        }
        let g = ggx_masking(wo, h, CLEARCOAT_G_ALPHA) * ggx_masking(wi, h, CLEARCOAT_G_ALPHA);
        0.25 * self.clearcoat
            * schlick(0.04, wo.dot(h), self.eta)
            * gtr1(h.z, self.clearcoat_alpha)
            * g
    }

    /// The sheen lobe alone (no cosine), as Mitsuba 3.9 evaluates it.
    fn sheen(&self, wo: DVec3, wi: DVec3) -> Rgb {
        if self.sheen == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let cos_d = (wi + wo).normalize_or_zero().dot(wi).abs();
        self.sheen * (1.0 - cos_d).clamp(0.0, 1.0).powi(5)
    }

    /// Burley's diffuse lobe (Mitsuba's `f_diff + f_retro` times
    /// base/π, without `flatness`) less the Lambertian lobe removed.
    fn diffuse(&self, wo: DVec3, wi: DVec3) -> Rgb {
        if self.burley == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let shape = burley_shape(wo, wi, (self.roughness, self.flatness));
        (self.burley.map(|b| b * shape) - self.lambertian_removed).map(|r| r * FRAC_1_PI)
    }

    /// Probabilities of sampling the specular lobe and the clearcoat (the
    /// rest: the cosine-sampled diffuse and sheen).
    fn lobe_probabilities(&self) -> (f64, f64) {
        let s = match fresnel_dielectric(1.0, self.eta).0 > 0.0 {
            true => self.fresnel(1.0).average(),
            false => 0.0,
        };
        let c = 0.25 * self.clearcoat;
        let d = self.burley.average() + self.sheen.average();
        let total = s + c + d;
        if total > 0.0 {
            (s / total, c / total)
        } else {
            (0.0, 0.0)
        }
    }
}

/// The roughness of the clearcoat's Smith masking (Mitsuba's, Burley's).
const CLEARCOAT_G_ALPHA: f64 = 0.25;

/// Burley's GTR1 distribution of roughness `alpha` at a normal of cosine
/// `cos_theta` (Mitsuba's `GTR1Isotropic::eval`): normalised so that
/// ∫ D cos θ dω = 1.
fn gtr1(cos_theta: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let d = (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * cos_theta * cos_theta));
    if d * cos_theta > 1e-20 {
        d
    } else {
        0.0
    }
}

/// A normal drawn from GTR1 of roughness `alpha` in proportion to
/// D cos θ by `u` ∈ \[0,1)² (Burley's inversion, as Mitsuba's
/// `GTR1Isotropic::sample`).
fn sample_gtr1(u: DVec2, alpha: f64) -> DVec3 {
    let a2 = alpha * alpha;
    let cos2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
    let (sin, cos) = ((1.0 - cos2).max(0.0).sqrt(), cos2.max(0.0).sqrt());
    let phi = 2.0 * PI * u.x;
    DVec3::new(phi.cos() * sin, phi.sin() * sin, cos)
}

/// Smith's isotropic GGX masking of direction `v` (local) at roughness
/// `alpha`, zero where `v` sees the back of `h` (Mitsuba's `smith_ggx1`).
fn ggx_masking(v: DVec3, h: DVec3, alpha: f64) -> f64 {
    if v.dot(h) * v.z <= 0.0 {
        return 0.0;
    }
    if v.z == 1.0 {
        return 1.0;
    }
    let cos2 = v.z * v.z;
    let tan2 = (1.0 - cos2) / cos2;
    2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// Schlick's Fresnel approximation with normal reflectance `r0` at c = wo·h
/// for a surface of index η (Mitsuba's `calc_schlick`, outside: the weight
/// (1 − c)⁵ of the incident cosine for η > 1, of the refracted one for
/// η < 1).
fn schlick(r0: f64, cos_theta: f64, eta: f64) -> f64 {
    let cos = if eta > 1.0 {
        cos_theta.abs()
    } else {
        let cos_t_sqr = 1.0 - (1.0 - cos_theta * cos_theta) / (eta * eta);
        cos_t_sqr.max(0.0).sqrt()
    };
    let w = (1.0 - cos).clamp(0.0, 1.0).powi(5);
    r0 + (1.0 - r0) * w
}

/// The bihemispherical albedo of Burley's diffuse lobe (Mitsuba's
/// `f_diff + f_retro` of a white base, blended towards its fake subsurface
/// by `flatness`) relative to a Lambertian one's: ∫∫ π f cos θ_i cos θ_o
/// dω_i dω_o / π², by a midpoint rule over cosine-distributed directions
/// (32 incidence cosines, 32 × 32 outgoing directions); (41/42)² at
/// roughness 0 and flatness 0, where the lobe separates, and growing with
/// roughness (retro-reflection).
pub fn burley_albedo(roughness: f64, flatness: f64) -> f64 {
    const N: usize = 32;
    let mut sum = 0.0;
    for i in 0..N {
        let wi = cosine_hemisphere(DVec2::new((i as f64 + 0.5) / N as f64, 0.0));
        for j in 0..N {
            for k in 0..N {
                let u = DVec2::new((j as f64 + 0.5) / N as f64, (k as f64 + 0.5) / N as f64);
                sum += burley_shape(cosine_hemisphere(u), wi, (roughness, flatness));
            }
        }
    }
    sum / (N * N * N) as f64
}

/// Burley's diffuse lobe of a white base over a Lambertian one's, π f: the
/// `f_diff + f_retro` of Mitsuba's `principled.cpp`, with F = (1 − cos)⁵
/// (`schlick_weight`) at each direction, f_diff = (1 − F_i/2)(1 − F_o/2),
/// R_r = 2 roughness cos²θ_d (θ_d between either direction and the half
/// vector) and f_retro = R_r (F_o + F_i + F_o F_i (R_r − 1)); blended by
/// `flatness` towards the Hanrahan–Krueger-like fake subsurface
/// f_ss = 1.25 (F_ss (1/(cos θ_o + cos θ_i) − ½) + ½), F_ss =
/// lerp(1, R_r/2, F_o) lerp(1, R_r/2, F_i).
fn burley_shape(wo: DVec3, wi: DVec3, (roughness, flatness): (f64, f64)) -> f64 {
    let weight = |x: f64| (1.0 - x).clamp(0.0, 1.0).powi(5);
    let (fo, fi) = (weight(wo.z), weight(wi.z));
    let cos_d = (wi + wo).normalize_or_zero().dot(wo);
    let rr = 2.0 * roughness * cos_d * cos_d;
    let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
    let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
    if flatness == 0.0 {
        return f_diff + f_retro;
    }
    let lerp = |a: f64, b: f64, t: f64| a + t * (b - a);
    let f_ss90 = 0.5 * rr;
    let f_ss = lerp(1.0, f_ss90, fo) * lerp(1.0, f_ss90, fi);
    let subsurface = 1.25 * (f_ss * (1.0 / (wo.z.abs() + wi.z.abs()) - 0.5) + 0.5);
    lerp(f_diff + f_retro, subsurface, flatness)
}

impl BrdfModel for Principled {
    fn eval(&self, wo: DVec3, wi: DVec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.diffuse(wo, wi)
            + self.specular(wo, wi)
            + self.sheen(wo, wi)
            + Rgb::splat(self.clearcoat(wo, wi))
    }

    fn pdf(&self, wo: DVec3, wi: DVec3) -> f64 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let (ps, pc) = self.lobe_probabilities();
        let h = (wi + wo).normalize();
        let facing = wo.dot(h) > 0.0 && wi.dot(h) > 0.0;
        let spec = if ps > 0.0 && facing {
            self.distribution.eval(h) * self.distribution.smith_g1(wo, h) / (4.0 * wo.z)
        } else {
            0.0
        };
        let coat = if pc > 0.0 && facing {
            gtr1(h.z, self.clearcoat_alpha) * h.z / (4.0 * wo.dot(h))
        } else {
            0.0
        };
        ps * spec + pc * coat + (1.0 - ps - pc) * cosine_hemisphere_pdf(wi)
    }

    fn sample(&self, wo: DVec3, u: DVec2, lobe: f64) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let (ps, pc) = self.lobe_probabilities();
        let wi = if lobe < ps {
            reflect(wo, self.distribution.sample(wo, u).0)
        } else if lobe < ps + pc {
            reflect(wo, sample_gtr1(u, self.clearcoat_alpha))
        } else {
            cosine_hemisphere(u)
        };
        BrdfSample::drawn(self, wo, wi)
    }

    /// The components Mitsuba's `principled` lists for reflection: diffuse
    /// and glossy, anisotropic when α_u ≠ α_v.
    fn flags(&self) -> BrdfFlags {
        let d = &self.distribution;
        BrdfFlags::glossy(true, d.alpha_u != d.alpha_v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn burley_albedo_is_lambertian_where_it_is_known() {
        // Roughness 0: f = (1 − F_i/2)(1 − F_o/2) separates, and each factor
        // averages 1 − ∫2μ(1−μ)⁵dμ / 2 = 1 − 1/42 over cosine-weighted μ.
        let smooth = burley_albedo(0.0, 0.0);
        assert!((smooth - (41.0f64 / 42.0).powi(2)).abs() < 2e-3, "{smooth}");
        // Retro-reflection grows with roughness.
        assert!(burley_albedo(1.0, 0.0) > 1.05 && burley_albedo(0.4, 0.0) < 1.01);
    }

    /// With the fake subsurface, whose 1/(cos θ_o + cos θ_i) grows where
    /// both directions graze, the midpoint rule agrees with a Monte Carlo
    /// estimate over cosine-distributed pairs (10⁶ of them, ±0.1 %).
    #[test]
    fn burley_albedo_with_flatness_agrees_with_monte_carlo() {
        use crate::sampling::hash2;
        for (roughness, flatness) in [(0.5, 1.0), (0.2, 0.6)] {
            let n = 1_000_000;
            let sum: f64 = (0..n)
                .map(|k| {
                    let (wo, wi) = (hash2(5, 2 * k), hash2(5, 2 * k + 1));
                    let (wo, wi) = (cosine_hemisphere(wo), cosine_hemisphere(wi));
                    burley_shape(wo, wi, (roughness, flatness))
                })
                .sum();
            let (sampled, ruled) = (sum / n as f64, burley_albedo(roughness, flatness));
            assert!(
                (ruled / sampled - 1.0).abs() < 0.004,
                "{ruled} vs {sampled}"
            );
            // Flattening lowers the albedo (the subsurface is darker).
            assert!(ruled < burley_albedo(roughness, 0.0), "{ruled}");
        }
    }

    /// The whole BRDF is Mitsuba 3's: values of its `principled` (3.9.1,
    /// `scalar_rgb`, base_color 0.8 0.5 0.3, roughness 0.6, metallic 0.2,
    /// the rest defaults), its `eval` divided by the light's cosine, for
    /// the view at (θ, φ) and the light at (θ', φ'); the last pair is near
    /// the mirror direction at grazing incidence, where the GGX lobe
    /// dominates.
    #[test]
    #[allow(clippy::approx_constant)] // φ = 3.14159 as Mitsuba was given it
    fn eval_is_mitsubas_principled() {
        let p = Principled::new(PrincipledParams {
            base_color: Rgb([0.8, 0.5, 0.3]),
            roughness: 0.6,
            metallic: 0.2,
            ..PrincipledParams::default()
        });
        let at = |theta: f64, phi: f64| {
            DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            )
        };
        let mitsuba = [
            (
                (0.3, 0.0),
                (0.5, 3.0),
                [0.324676066, 0.210555947, 0.134475873],
            ),
            (
                (1.2, 0.4),
                (1.3, 0.5),
                [0.266359597, 0.167457286, 0.101522421],
            ),
            (
                (0.1, 1.0),
                (1.45, 2.0),
                [0.253829711, 0.160621535, 0.098482757],
            ),
            (
                (1.4, 0.0),
                (1.4, 3.14159),
                [3.942530015, 3.610171640, 3.388599390],
            ),
        ];
        for ((view, light, expect), k) in mitsuba.into_iter().zip(0..) {
            let f = p.eval(at(view.0, view.1), at(light.0, light.1));
            for c in 0..3 {
                // Mitsuba computes in single precision.
                let e = expect[c];
                assert!(
                    (f.0[c] - e).abs() < 2e-5 * e,
                    "pair {k}: {f:?} vs {expect:?}"
                );
            }
        }
    }

    /// Less the Lambertian lobe the solution carries, the diffuse lobe is
    /// a signed difference with no bihemispherical albedo: added back, it
    /// is the whole BRDF again.
    #[test]
    fn shading_rest_and_the_lambertian_lobe_are_the_whole_brdf() {
        let brdf = super::super::Brdf::Principled(Principled::new(PrincipledParams {
            roughness: 0.8,
            ..PrincipledParams::default()
        }));
        let (rho, rest) = (brdf.lambertian().unwrap(), brdf.shading_rest());
        let (wo, wi) = (DVec3::new(0.6, 0.0, 0.8), DVec3::new(-0.96, 0.0, 0.28));
        let (f, g) = (brdf.eval(wo, wi), rest.eval(wo, wi));
        for c in 0..3 {
            assert!((f.0[c] - rho.0[c] * FRAC_1_PI - g.0[c]).abs() < 1e-12);
        }
        assert_eq!(rest.lambertian(), None);
    }

    #[test]
    fn dielectric_lobe_is_a_rough_conductor_of_real_index() {
        // metallic 0, spec_tint 0: F is the dielectric Fresnel, which a
        // conductor of index η + 0i equals.
        let p = Principled::new(PrincipledParams {
            roughness: 0.4,
            ..PrincipledParams::default()
        });
        let conductor = super::super::RoughConductor {
            distribution: p.distribution,
            eta: Rgb::splat(p.eta),
            k: Rgb::ZERO,
            specular_reflectance: Rgb::splat(1.0),
        };
        let (wo, wi) = (
            DVec3::new(0.3, 0.1, 0.9).normalize(),
            DVec3::new(-0.5, 0.05, 0.6).normalize(),
        );
        let lambert = p.diffuse(wo, wi);
        let (f, c) = (p.eval(wo, wi), conductor.eval(wo, wi));
        for ch in 0..3 {
            let spec = f.0[ch] - lambert.0[ch];
            assert!((spec - c.0[ch]).abs() < 1e-9 * c.0[ch], "{f:?} {c:?}");
        }
        // specular 0.5 is η = 1.5, F(1) = 0.04.
        assert!((p.eta - 1.5).abs() < 1e-12);
        assert!((p.fresnel(1.0).0[0] - 0.04).abs() < 1e-12);
    }

    #[test]
    fn serialised_whole_within_brdf() {
        // A solution file holds the BRDF; the Lambertian split must survive.
        let brdf = super::super::Brdf::Principled(Principled::new(PrincipledParams {
            metallic: 0.2,
            ..PrincipledParams::default()
        }));
        let json = serde_json::to_string(&brdf).unwrap();
        let back: super::super::Brdf = serde_json::from_str(&json).unwrap();
        assert_eq!(back, brdf);
        assert_eq!(back.lambertian(), brdf.lambertian());
        assert!(back.lambertian().is_some());
    }

    #[test]
    fn metallic_reflects_its_base_color_head_on() {
        let base = Rgb([0.9, 0.6, 0.2]);
        let p = Principled::new(PrincipledParams {
            base_color: base,
            metallic: 1.0,
            ..PrincipledParams::default()
        });
        assert_eq!(p.diffuse_reflectance, Rgb::ZERO);
        for (f, b) in p.fresnel(1.0).0.into_iter().zip(base.0) {
            assert!((f - b).abs() < 1e-12);
        }
        // At grazing incidence Schlick goes to 1.
        assert!(p.fresnel(1e-9).0.iter().all(|f| (f - 1.0).abs() < 1e-6));
    }

    #[test]
    fn sample_weight_is_f_cos_over_pdf_and_reciprocal() {
        let p = Principled::new(PrincipledParams {
            base_color: Rgb([0.8, 0.5, 0.3]),
            roughness: 0.3,
            anisotropic: 0.5,
            metallic: 0.3,
            spec_tint: 0.4,
            ..PrincipledParams::default()
        });
        let wo = DVec3::new(0.4, -0.2, 0.8).normalize();
        for (u, lobe) in [(DVec2::new(0.3, 0.7), 0.01), (DVec2::new(0.6, 0.2), 0.99)] {
            let s = p.sample(wo, u, lobe).unwrap();
            let f = p.eval(wo, s.direction);
            for (w, f) in s.weight.0.into_iter().zip(f.0) {
                let expect = f * s.direction.z / s.pdf;
                assert!((w - expect).abs() < 1e-12 * expect);
            }
        }
        let wi = DVec3::new(-0.3, 0.3, 0.7).normalize();
        // The dielectric part is reciprocal (wo·h = wi·h).
        let (a, b) = (p.eval(wo, wi), p.eval(wi, wo));
        assert!((0..3).all(|c| (a.0[c] - b.0[c]).abs() < 1e-12 * a.0[c]));
    }
}
