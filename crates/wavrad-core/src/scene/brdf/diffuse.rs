//! Lambertian reflection (Mitsuba's `diffuse`): f = ρ/π.
//!
//! | parameter     | meaning                       | default |
//! |---------------|-------------------------------|---------|
//! | `reflectance` | albedo ρ per channel, in \[0,1\] | 0.5     |

use super::{cosine_hemisphere, BrdfFlags, BrdfModel, BrdfSample};
use crate::scene::Rgb;
use glam::{DVec2, DVec3};
use std::f64::consts::FRAC_1_PI;

/// Lambertian BRDF.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Diffuse {
    /// Albedo ρ per channel.
    pub reflectance: Rgb,
}

impl BrdfModel for Diffuse {
    fn eval(&self, wo: DVec3, wi: DVec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.reflectance.map(|r| r * FRAC_1_PI)
    }

    fn pdf(&self, wo: DVec3, wi: DVec3) -> f64 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        wi.z * FRAC_1_PI
    }

    fn sample(&self, wo: DVec3, u: DVec2, _lobe: f64) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = cosine_hemisphere(u);
        (wi.z > 0.0).then_some(BrdfSample {
            direction: wi,
            pdf: wi.z * FRAC_1_PI,
            weight: self.reflectance,
        })
    }

    fn flags(&self) -> BrdfFlags {
        BrdfFlags::DIFFUSE_REFLECTION | BrdfFlags::FRONT_SIDE
    }
}
