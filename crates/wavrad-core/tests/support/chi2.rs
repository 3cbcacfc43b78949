//! A small chi-square goodness-of-fit test for BRDF sampling, after
//! Mitsuba's `mitsuba.chi2`: sampled directions are binned on a (cos θ, φ)
//! grid, the expected counts integrate `pdf()` over each cell, cells with
//! fewer than 5 expected samples are pooled, and the statistic's p-value
//! (Wilson–Hilferty) must exceed the significance level.

use glam::{DVec2, DVec3};
use std::f64::consts::PI;
use wavrad_core::scene::brdf::BrdfModel;

/// A seeded SplitMix64 stream of uniform numbers in [0, 1).
pub struct Rng(u64);

impl Rng {
    /// The stream for `seed`.
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    /// The next uniform number in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The outcome of [`chi2_test`].
#[derive(Debug)]
pub struct Chi2 {
    /// The statistic Σ (observed − expected)² / expected over pooled cells.
    pub statistic: f64,
    /// Degrees of freedom (pooled cells − 1).
    pub dof: usize,
    /// P(χ² ≥ statistic) under the null hypothesis.
    pub p_value: f64,
    /// Fraction of samples that were drawn (not `None`) vs ∫ pdf.
    pub drawn: f64,
    /// ∫ pdf over the hemisphere (≤ 1 when sampling can fail).
    pub pdf_integral: f64,
}

fn direction(cos_theta: f64, phi: f64) -> DVec3 {
    let s = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    DVec3::new(s * phi.cos(), s * phi.sin(), cos_theta)
}

/// Draw `samples` directions from `model.sample(wo, ..)` and compare their
/// histogram on a `bins.0 × bins.1` grid in (cos θ, φ) with `model.pdf`.
pub fn chi2_test(
    model: &dyn BrdfModel,
    wo: DVec3,
    samples: usize,
    bins: (usize, usize),
    seed: u64,
) -> Chi2 {
    let (nt, np) = bins;
    let cell = |d: DVec3| {
        let t = ((d.z.clamp(0.0, 1.0) * nt as f64) as usize).min(nt - 1);
        let phi = d.y.atan2(d.x).rem_euclid(2.0 * PI);
        let p = ((phi / (2.0 * PI) * np as f64) as usize).min(np - 1);
        t * np + p
    };
    // Observed counts
    let mut rng = Rng::new(seed);
    let mut observed = vec![0.0; nt * np];
    for _ in 0..samples {
        let u = DVec2::new(rng.uniform(), rng.uniform());
        if let Some(s) = model.sample(wo, u, rng.uniform()) {
            observed[cell(s.direction)] += 1.0;
        }
    }
    // Expected counts: the pdf integrated per cell by a midpoint rule
    let sub = 12;
    let (dt, dp) = (1.0 / (nt * sub) as f64, 2.0 * PI / (np * sub) as f64);
    let mut expected = vec![0.0; nt * np];
    for (i, e) in expected.iter_mut().enumerate() {
        let (t, p) = (i / np, i % np);
        let mut integral = 0.0;
        for a in 0..sub {
            for b in 0..sub {
                let c = (t * sub + a) as f64 * dt + 0.5 * dt;
                let phi = (p * sub + b) as f64 * dp + 0.5 * dp;
                integral += model.pdf(wo, direction(c, phi)) * dt * dp;
            }
        }
        *e = integral * samples as f64;
    }
    let pdf_integral = expected.iter().sum::<f64>() / samples as f64;
    let drawn = observed.iter().sum::<f64>() / samples as f64;
    // Pool small cells (in order of expected count), then sum
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut statistic, mut dof) = (0.0, 0usize);
    let (mut pool_e, mut pool_o) = (0.0, 0.0);
    for i in order {
        if expected[i] < 5.0 {
            pool_e += expected[i];
            pool_o += observed[i];
            if pool_e < 5.0 {
                continue;
            }
            statistic += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
            (pool_e, pool_o) = (0.0, 0.0);
        } else {
            statistic += (observed[i] - expected[i]).powi(2) / expected[i];
        }
        dof += 1;
    }
    if pool_e > 0.0 {
        statistic += (pool_o - pool_e) * (pool_o - pool_e) / pool_e.max(1.0);
        dof += 1;
    }
    let dof = dof.saturating_sub(1).max(1);
    Chi2 {
        statistic,
        dof,
        p_value: chi2_survival(statistic, dof as f64),
        drawn,
        pdf_integral,
    }
}

/// P(χ²_k ≥ x) by the Wilson–Hilferty cube-root normal approximation.
pub fn chi2_survival(x: f64, k: f64) -> f64 {
    let z = ((x / k).cbrt() - (1.0 - 2.0 / (9.0 * k))) / (2.0 / (9.0 * k)).sqrt();
    0.5 * erfc(z / std::f64::consts::SQRT_2)
}

fn erfc(x: f64) -> f64 {
    1.0 - wavrad_core::scene::brdf::microfacet::erf(x)
}
