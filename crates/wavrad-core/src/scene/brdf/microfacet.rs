//! Microfacet normal distributions: Beckmann and GGX with anisotropic
//! roughness, Smith shadowing–masking and visible-normal sampling, as
//! Mitsuba 3's `MicrofacetDistribution` with `sample_visible = true`.
//!
//! | parameter      | meaning                                               | default    |
//! |----------------|-------------------------------------------------------|------------|
//! | `distribution` | `beckmann` (Gaussian random surface) or `ggx`         | `beckmann` |
//! | `alpha`        | roughness along both tangent directions               | 0.1        |
//! | `alpha_u`      | roughness along the tangent (local x)                 | `alpha`    |
//! | `alpha_v`      | roughness along the bitangent (local y)               | `alpha`    |
//!
//! D is Beckmann's (Walter et al., *Microfacet Models for Refraction through
//! Rough Surfaces*, EGSR 2007, eq. 25) or GGX/Trowbridge–Reitz (ibid. eq. 33),
//! both stretched anisotropically. G1 is Smith's: for GGX exact (ibid.
//! eq. 34), for Beckmann Walter's rational approximation (eq. 27, < 0.35 %
//! error), as Mitsuba. Normals are drawn from the distribution of normals
//! visible from `wi`, D_wi(m) = G1(wi, m) max(0, wi·m) D(m) / cos θ_i
//! (Heitz & d'Eon, *Importance Sampling Microfacet-Based BSDFs using the
//! Distribution of Visible Normals*, EGSR 2014): Beckmann by Jakob's
//! numerical inversion in the erf domain, GGX by Heitz's projected-disk
//! method (*Sampling the GGX Distribution of Visible Normals*, JCGT 2018).
//! Roughness below 10⁻⁴ is clamped to 10⁻⁴, as in Mitsuba.

use glam::{DVec2, DVec3};
use std::f64::consts::{FRAC_1_PI, PI};

/// Which microfacet normal distribution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum MicrofacetType {
    /// Beckmann: slopes of a Gaussian random surface (the default).
    Beckmann,
    /// GGX / Trowbridge–Reitz: longer tails.
    Ggx,
}

impl MicrofacetType {
    /// The type named `name` (`beckmann` or `ggx`, any case).
    pub fn from_name(name: &str) -> Option<MicrofacetType> {
        match name.to_ascii_lowercase().as_str() {
            "beckmann" => Some(MicrofacetType::Beckmann),
            "ggx" => Some(MicrofacetType::Ggx),
            _ => None,
        }
    }
}

impl std::fmt::Display for MicrofacetType {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            MicrofacetType::Beckmann => "beckmann",
            MicrofacetType::Ggx => "ggx",
        })
    }
}

/// A microfacet distribution with roughness `alpha_u` along local x and
/// `alpha_v` along local y.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Microfacet {
    /// Beckmann or GGX.
    pub kind: MicrofacetType,
    /// Roughness along the tangent (local x), ≥ 10⁻⁴.
    pub alpha_u: f64,
    /// Roughness along the bitangent (local y), ≥ 10⁻⁴.
    pub alpha_v: f64,
}

/// Mitsuba's lower bound on the roughness.
pub const MIN_ALPHA: f64 = 1e-4;

impl Microfacet {
    /// An anisotropic distribution; roughness is clamped to ≥ [`MIN_ALPHA`].
    pub fn new(kind: MicrofacetType, alpha_u: f64, alpha_v: f64) -> Microfacet {
        Microfacet {
            kind,
            alpha_u: alpha_u.max(MIN_ALPHA),
            alpha_v: alpha_v.max(MIN_ALPHA),
        }
    }

    /// An isotropic distribution of roughness `alpha`.
    pub fn isotropic(kind: MicrofacetType, alpha: f64) -> Microfacet {
        Microfacet::new(kind, alpha, alpha)
    }

    /// The normal distribution D(m), per unit solid angle of m, normalised
    /// so that ∫ D(m) cos θ_m dω_m = 1.
    pub fn eval(&self, m: DVec3) -> f64 {
        let (au, av) = (self.alpha_u, self.alpha_v);
        let cos2 = m.z * m.z;
        let d = match self.kind {
            MicrofacetType::Beckmann => {
                (-((m.x / au).powi(2) + (m.y / av).powi(2)) / cos2).exp()
                    / (PI * au * av * cos2 * cos2)
            }
            MicrofacetType::Ggx => {
                let t = (m.x / au).powi(2) + (m.y / av).powi(2) + cos2;
                1.0 / (PI * au * av * t * t)
            }
        };
        // Mitsuba's guard against numerical trouble far in the tails
        if d * m.z > 1e-20 {
            d
        } else {
            0.0
        }
    }

    /// Smith's masking G1(v, m); zero when v sees the back of m.
    pub fn smith_g1(&self, v: DVec3, m: DVec3) -> f64 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let xy_alpha_2 = (self.alpha_u * v.x).powi(2) + (self.alpha_v * v.y).powi(2);
        if xy_alpha_2 == 0.0 {
            return 1.0;
        }
        let tan_theta_alpha_2 = xy_alpha_2 / (v.z * v.z);
        match self.kind {
            MicrofacetType::Beckmann => {
                let a = 1.0 / tan_theta_alpha_2.sqrt();
                if a >= 1.6 {
                    1.0
                } else {
                    (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
                }
            }
            MicrofacetType::Ggx => 2.0 / (1.0 + (1.0 + tan_theta_alpha_2).sqrt()),
        }
    }

    /// Separable shadowing–masking G(wo, wi, m) = G1(wo, m) G1(wi, m).
    pub fn g(&self, wo: DVec3, wi: DVec3, m: DVec3) -> f64 {
        self.smith_g1(wo, m) * self.smith_g1(wi, m)
    }

    /// Density per unit solid angle of m with which [`Microfacet::sample`]
    /// draws m given `wi`: D_wi(m) = D(m) G1(wi, m) |wi·m| / cos θ_i.
    pub fn pdf(&self, wi: DVec3, m: DVec3) -> f64 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        self.eval(m) * self.smith_g1(wi, m) * wi.dot(m).abs() / wi.z
    }

    /// Draw a normal visible from `wi` (wi.z > 0) from two uniform numbers;
    /// returns the normal and its density ([`Microfacet::pdf`]).
    pub fn sample(&self, wi: DVec3, u: DVec2) -> (DVec3, f64) {
        // Step 1: stretch wi to the configuration with unit roughness
        let wi_p = DVec3::new(self.alpha_u * wi.x, self.alpha_v * wi.y, wi.z).normalize();
        let sin_theta = (1.0 - wi_p.z * wi_p.z).max(0.0).sqrt();
        let (sin_phi, cos_phi) = if sin_theta == 0.0 {
            (0.0, 1.0)
        } else {
            (
                (wi_p.y / sin_theta).clamp(-1.0, 1.0),
                (wi_p.x / sin_theta).clamp(-1.0, 1.0),
            )
        };
        // Step 2: sample the slopes visible at unit roughness
        let slope = self.sample_visible_11(wi_p.z, u);
        // Step 3: rotate back and unstretch
        let slope = DVec2::new(
            (cos_phi * slope.x - sin_phi * slope.y) * self.alpha_u,
            (sin_phi * slope.x + cos_phi * slope.y) * self.alpha_v,
        );
        // Step 4: the normal and its density
        let m = DVec3::new(-slope.x, -slope.y, 1.0).normalize();
        (m, self.pdf(wi, m))
    }

    /// Slopes of a unit-roughness surface visible at incidence cosine
    /// `cos_theta_i`, as Mitsuba 3's `sample_visible_11`.
    fn sample_visible_11(&self, cos_theta_i: f64, u: DVec2) -> DVec2 {
        match self.kind {
            MicrofacetType::Beckmann => {
                // Jakob's inversion of the visible-slope CDF in the erf domain
                let tan_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt() / cos_theta_i;
                let cot_theta_i = 1.0 / tan_theta_i;
                let maxval = erf(cot_theta_i);
                let u = DVec2::new(u.x.clamp(1e-6, 1.0 - 1e-6), u.y.clamp(1e-6, 1.0 - 1e-6));
                // Initial guess: the analytic solution for θ_i = π/2
                let mut x = maxval - (maxval + 1.0) * erf((-u.x.ln()).sqrt());
                let target = u.x
                    * (1.0
                        + maxval
                        + FRAC_1_SQRT_PI * tan_theta_i * (-cot_theta_i * cot_theta_i).exp());
                // Newton iterations (Mitsuba stops after three in f32)
                let limit = 1.0 - 1e-15;
                for _ in 0..20 {
                    let slope = erfinv(x);
                    let value =
                        1.0 + x + FRAC_1_SQRT_PI * tan_theta_i * (-slope * slope).exp() - target;
                    let derivative = 1.0 - slope * tan_theta_i;
                    let step = value / derivative;
                    x = (x - step).clamp(-limit, limit);
                    if step.abs() < 1e-13 {
                        break;
                    }
                }
                DVec2::new(erfinv(x), erfinv(2.0 * u.y - 1.0))
            }
            MicrofacetType::Ggx => {
                // Heitz 2018: a disk point projected onto the visible hemisphere
                let p = square_to_uniform_disk_concentric(u);
                let s = 0.5 * (1.0 + cos_theta_i);
                let (x, y0) = (p.x, p.y);
                let h = (1.0 - x * x).max(0.0).sqrt();
                let y = h + s * (y0 - h);
                let z = (1.0 - x * x - y * y).max(0.0).sqrt();
                let sin_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt();
                let norm = 1.0 / (sin_theta_i * y + cos_theta_i * z);
                DVec2::new(cos_theta_i * y - sin_theta_i * z, x) * norm
            }
        }
    }
}

const FRAC_1_SQRT_PI: f64 = 0.564_189_583_547_756_3;

/// Shirley–Chiu concentric map of the unit square onto the unit disk
/// (Dave Cline's branch-reduced form, as Mitsuba's
/// `square_to_uniform_disk_concentric`).
pub fn square_to_uniform_disk_concentric(u: DVec2) -> DVec2 {
    let (r1, r2) = (2.0 * u.x - 1.0, 2.0 * u.y - 1.0);
    if r1 == 0.0 && r2 == 0.0 {
        return DVec2::ZERO;
    }
    let (r, phi) = if r1.abs() < r2.abs() {
        (r2, 0.5 * PI - 0.25 * PI * r1 / r2)
    } else {
        (r1, 0.25 * PI * r2 / r1)
    };
    DVec2::new(r * phi.cos(), r * phi.sin())
}

/// The error function, to ≈1e-15 (a series with positive terms,
/// Abramowitz & Stegun 7.1.6).
pub fn erf(x: f64) -> f64 {
    let ax = x.abs();
    if ax >= 6.0 {
        return x.signum();
    }
    let x2 = ax * ax;
    let (mut term, mut sum) = (ax, ax);
    let mut n = 0.0;
    while term > 1e-17 * sum {
        n += 1.0;
        term *= 2.0 * x2 / (2.0 * n + 1.0);
        sum += term;
    }
    (2.0 * FRAC_1_SQRT_PI * (-x2).exp() * sum)
        .min(1.0)
        .copysign(x)
}

/// The inverse error function on (−1, 1) (±∞ at ±1): Giles' single
/// precision approximation (2010) polished by Newton steps on [`erf`].
pub fn erfinv(y: f64) -> f64 {
    if y <= -1.0 {
        return f64::NEG_INFINITY;
    }
    if y >= 1.0 {
        return f64::INFINITY;
    }
    let mut w = -((1.0 - y) * (1.0 + y)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        [
            2.810_226_36e-08,
            3.432_739_39e-07,
            -3.523_387_7e-06,
            -4.391_506_54e-06,
            0.000_218_580_87,
            -0.001_253_725_03,
            -0.004_177_681_64,
            0.246_640_727,
            1.501_409_41,
        ]
        .iter()
        .fold(0.0, |p, c| c + p * w)
    } else {
        w = w.sqrt() - 3.0;
        [
            -0.000_200_214_257,
            0.000_100_950_558,
            0.001_349_343_22,
            -0.003_673_428_44,
            0.005_739_507_73,
            -0.007_622_461_3,
            0.009_438_870_47,
            1.001_674_06,
            2.832_976_82,
        ]
        .iter()
        .fold(0.0, |p, c| c + p * w)
    };
    let mut x = p * y;
    for _ in 0..2 {
        let d = 2.0 * FRAC_1_SQRT_PI * (-x * x).exp();
        if d == 0.0 {
            break;
        }
        x -= (erf(x) - y) / d;
    }
    x
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on Pₙ).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut nodes, mut weights) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // P_n(x) and its derivative by the three-term recurrence
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let pn = if n == 1 { x } else { p1 };
            let pm = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (x * pn - pm) / (x * x - 1.0);
            let dx = pn / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        nodes[i] = x;
        weights[i] = 2.0 / ((1.0 - x * x) * dp * dp);
    }
    (nodes, weights)
}

/// Reflect `wi` about `m`.
pub fn reflect(wi: DVec3, m: DVec3) -> DVec3 {
    2.0 * wi.dot(m) * m - wi
}

/// Tensor-product Gauss–Legendre quadrature over visible normals drawn by
/// `distr.sample(wi, ·)`, as Mitsuba 3's `eval_reflectance` and
/// `eval_transmittance` (`microfacet.h`): 32² nodes for η > 1, 128²
/// otherwise.
fn visible_normal_quadrature(
    distr: &Microfacet,
    wi: DVec3,
    eta: f64,
    integrand: impl Fn(DVec3) -> f64,
) -> f64 {
    // A fuzzed solution file (docs/fuzzing.md) makes a rough plastic, and
    // so this table, of nearly every input; the full rule held the fuzzer
    // to a few inputs a second.
    let res = if cfg!(fuzzing) {
        4
    } else if eta > 1.0 {
        32
    } else {
        128
    };
    let (nodes, weights) = gauss_legendre(res);
    let mut sum = 0.0;
    for (y, wy) in nodes.iter().zip(&weights) {
        for (x, wx) in nodes.iter().zip(&weights) {
            let u = DVec2::new(0.5 * x + 0.5, 0.5 * y + 0.5);
            let m = distr.sample(wi, u).0;
            sum += integrand(m) * wx * wy * 0.25;
        }
    }
    sum
}

/// Directional albedo of a rough dielectric interface of relative index
/// `eta` in reflection, ∫ F G1 over visible normals (Mitsuba 3's
/// `eval_reflectance`).
pub fn eval_reflectance(distr: &Microfacet, wi: DVec3, eta: f64) -> f64 {
    visible_normal_quadrature(distr, wi, eta, |m| {
        let wo = reflect(wi, m);
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let f = super::fresnel::fresnel_dielectric(wi.dot(m), eta).0;
        distr.smith_g1(wo, m) * f
    })
}

/// Directional transmittance of a rough dielectric interface of relative
/// index `eta`, ∫ (1 − F) G1 over visible normals (Mitsuba 3's
/// `eval_transmittance`).
pub fn eval_transmittance(distr: &Microfacet, wi: DVec3, eta: f64) -> f64 {
    visible_normal_quadrature(distr, wi, eta, |m| {
        let (f, cos_t, _, eta_ti) = super::fresnel::fresnel_dielectric(wi.dot(m), eta);
        let wo = m * (wi.dot(m) * eta_ti + cos_t) - wi * eta_ti;
        if wo.z * wi.z >= 0.0 {
            return 0.0;
        }
        distr.smith_g1(wo, m) * (1.0 - f)
    })
}

/// Cosine-weighted hemisphere density, for mixtures with a diffuse lobe.
pub(crate) fn cosine_hemisphere_pdf(w: DVec3) -> f64 {
    if w.z <= 0.0 {
        0.0
    } else {
        w.z * FRAC_1_PI
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erf_and_its_inverse() {
        for (x, e) in [
            (0.5, 0.520_499_877_813_046_5),
            (1.0, 0.842_700_792_949_714_9),
            (2.0, 0.995_322_265_018_952_7),
            (3.5, 0.999_999_256_901_627_7),
        ] {
            assert!((erf(x) - e).abs() < 1e-14, "erf({x})");
            assert!((erf(-x) + e).abs() < 1e-14);
            assert!((erfinv(e) - x).abs() < 1e-9 * x.max(1.0), "erfinv({e})");
        }
        assert_eq!(erf(0.0), 0.0);
    }

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        let (x, w) = gauss_legendre(5);
        let integral: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(8)).sum();
        assert!((integral - 2.0 / 9.0).abs() < 1e-14);
        assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-14);
    }

    #[test]
    fn projected_area_normalisation() {
        // ∫ D(m) cos θ_m dω = 1, by a midpoint rule in (cos θ, φ).
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            let d = Microfacet::new(kind, 0.3, 0.6);
            let (nt, np) = (800, 200);
            let mut sum = 0.0;
            for i in 0..nt {
                // u = cos θ squared spacing concentrates nodes near the pole
                let t = (i as f64 + 0.5) / nt as f64;
                let (c, dc) = (1.0 - t * t, 2.0 * t / nt as f64);
                let s = (1.0 - c * c).sqrt();
                for j in 0..np {
                    let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                    let m = DVec3::new(s * phi.cos(), s * phi.sin(), c);
                    sum += d.eval(m) * c * dc * 2.0 * PI / np as f64;
                }
            }
            assert!((sum - 1.0).abs() < 2e-3, "{kind}: {sum}");
        }
    }

    #[test]
    fn visible_normals_have_the_claimed_density() {
        // The sampled normals' pdf matches pdf(), and normals face wi.
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            let d = Microfacet::new(kind, 0.2, 0.5);
            let wi = DVec3::new(0.6, -0.3, 0.5).normalize();
            for k in 0..100 {
                let u = DVec2::new(
                    (k as f64 + 0.5) / 100.0,
                    ((k * 37) % 100) as f64 / 100.0 + 0.005,
                );
                let (m, pdf) = d.sample(wi, u);
                assert!(m.z > 0.0 && wi.dot(m) > 0.0, "{kind} {u}");
                assert!((pdf - d.pdf(wi, m)).abs() <= 1e-12 * pdf);
            }
        }
    }
}
