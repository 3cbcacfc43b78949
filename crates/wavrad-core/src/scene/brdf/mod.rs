//! BRDFs: how a surface reflects light (the f_p of the paper's eq. 1).
//!
//! Every model implements [`BrdfModel`] in a local shading frame ([`Frame`]:
//! z is the surface normal, x the tangent along the surface's first parameter
//! direction, Mitsuba's dp/du). Directions point *away* from the surface and
//! are unit vectors; every model is one-sided: zero when either direction is
//! below the surface. Every method takes the direction towards the viewer,
//! `wo`, first and the direction towards the light, `wi`, second, as pbrt-v4's
//! `BxDF::f(wo, wi)` and Mitsuba 3's `BSDF::eval(si.wi, wo)` (whose `si.wi`
//! is wavrad's `wo`): the order in which [`BrdfModel::sample`] conditions on
//! `wo` and draws `wi`. [`BrdfModel::flags`] says which lobes a model has
//! ([`BrdfFlags`]). [`Brdf`] is the closed set of models wavrad knows, with
//! the dispatch written once.
//!
//! | model (file)       | Mitsuba plugin               | lobes ([`BrdfModel::flags`])                            |
//! |--------------------|------------------------------|---------------------------------------------------------|
//! | [`Diffuse`]        | `diffuse`                    | diffuse: Lambertian                                     |
//! | [`Ward`]           | `ward` (Mitsuba 0.6)         | glossy: anisotropic Ward; diffuse: Lambertian           |
//! | [`RoughConductor`] | `roughconductor` (Mitsuba 3) | glossy: microfacet, conductor Fresnel                   |
//! | [`RoughPlastic`]   | `roughplastic` (Mitsuba 3)   | glossy: rough dielectric coating; diffuse: base below it |
//! | [`Principled`]     | `principled` (Mitsuba 3), its reflection | glossy: GGX, principled Fresnel; diffuse: Lambertian |
//!
//! [`microfacet`] holds the Beckmann/GGX distributions and [`fresnel`] the
//! Fresnel terms and named indices of refraction they share.

pub mod conductor;
pub mod diffuse;
pub mod fresnel;
pub mod microfacet;
pub mod plastic;
pub mod principled;
pub mod ward;

pub use conductor::RoughConductor;
pub use diffuse::Diffuse;
pub use microfacet::{Microfacet, MicrofacetType};
pub use plastic::{RoughPlastic, RoughPlasticParams};
pub use principled::{Principled, PrincipledParams};
pub use ward::{Ward, WardVariant};

use crate::scene::Rgb;
use glam::{DVec2, DVec3};

bitflags::bitflags! {
    /// The lobes of a BRDF and their attributes: the subset of Mitsuba 3's
    /// `BSDFFlags` (`include/mitsuba/render/bsdf.h`, same bit values) that
    /// one-sided reflection models report. Callers ask what they need, e.g.
    /// `flags().contains(BrdfFlags::GLOSSY_REFLECTION)`: whether the
    /// reflected radiance depends on the direction.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
    pub struct BrdfFlags: u32 {
        /// A diffuse lobe: light reflected into the whole hemisphere, smoothly.
        const DIFFUSE_REFLECTION = 0x0_0002;
        /// A glossy lobe: reflection concentrated about some directions.
        const GLOSSY_REFLECTION = 0x0_0008;
        /// A lobe that changes when the surface turns about its normal.
        const ANISOTROPIC = 0x0_1000;
        /// Reflects on the front side (the side the normal points to).
        const FRONT_SIDE = 0x0_8000;
    }
}

impl BrdfFlags {
    /// A glossy lobe on the front side, with a Lambertian one when
    /// `diffuse`, marked anisotropic when `anisotropic`.
    pub fn glossy(diffuse: bool, anisotropic: bool) -> BrdfFlags {
        let mut flags = BrdfFlags::GLOSSY_REFLECTION | BrdfFlags::FRONT_SIDE;
        flags.set(BrdfFlags::DIFFUSE_REFLECTION, diffuse);
        flags.set(BrdfFlags::ANISOTROPIC, anisotropic);
        flags
    }
}

/// An orthonormal shading frame: tangent `s`, bitangent `t`, normal `n`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Tangent (local x), along the first parameter direction.
    pub s: DVec3,
    /// Bitangent (local y), `n × s`.
    pub t: DVec3,
    /// Normal (local z).
    pub n: DVec3,
}

impl Frame {
    /// The frame with normal `n` whose tangent is `tangent` made orthogonal
    /// to `n` (any tangent if `tangent` is parallel to `n`).
    pub fn new(n: DVec3, tangent: DVec3) -> Frame {
        let n = n.normalize();
        let s = (tangent - n * n.dot(tangent)).normalize_or_zero();
        let s = if s == DVec3::ZERO {
            n.any_orthonormal_vector()
        } else {
            s
        };
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    /// A world direction in local coordinates.
    pub fn to_local(&self, v: DVec3) -> DVec3 {
        DVec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// A local direction in world coordinates.
    pub fn to_world(&self, v: DVec3) -> DVec3 {
        v.x * self.s + v.y * self.t + v.z * self.n
    }
}

/// A direction drawn by [`BrdfModel::sample`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrdfSample {
    /// The sampled direction (local frame, away from the surface).
    pub direction: DVec3,
    /// Its density per unit solid angle.
    pub pdf: f64,
    /// `f · cosθ / pdf` for the sampled direction.
    pub weight: Rgb,
}

impl BrdfSample {
    /// The sample of a mixture model that drew `wi` given `wo` (by any of
    /// its lobes): its density and weight come from the whole model's
    /// `pdf` and `eval`. `None` below the surface or where the density
    /// vanishes.
    pub fn drawn(model: &impl BrdfModel, wo: DVec3, wi: DVec3) -> Option<BrdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = model.pdf(wo, wi);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        let f = model.eval(wo, wi);
        Some(BrdfSample {
            direction: wi,
            pdf,
            weight: f.map(|f| f * wi.z / pdf),
        })
    }
}

/// What every reflection model provides (directions in the local frame,
/// `wo` towards the viewer first, `wi` towards the light second).
pub trait BrdfModel {
    /// f(wo, wi) per unit solid angle, without the cosine: light arriving
    /// from `wi` and leaving towards `wo` (the f_p of the paper's eq. 1).
    fn eval(&self, wo: DVec3, wi: DVec3) -> Rgb;
    /// Density per unit solid angle with which [`BrdfModel::sample`] given
    /// `wo` draws `wi`.
    fn pdf(&self, wo: DVec3, wi: DVec3) -> f64;
    /// Draw a direction `wi` given `wo` from two uniform numbers `u` and a
    /// third, `lobe`, that picks among lobes; `None` when none is drawn.
    fn sample(&self, wo: DVec3, u: DVec2, lobe: f64) -> Option<BrdfSample>;
    /// The model's lobes, as the Mitsuba plugin it follows reports them.
    fn flags(&self) -> BrdfFlags;
}

/// Largest solid angle (sr) of a sharp lobe ([`Brdf::is_sharp`]): a
/// quarter of a steradian, narrower than most emitters' images.
pub const SHARP_LOBE: f64 = 0.25;

/// Every reflection model wavrad supports.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Brdf {
    /// Lambertian (Mitsuba's `diffuse`).
    Diffuse(Diffuse),
    /// Anisotropic Ward (Mitsuba 0.6's `ward`).
    Ward(Ward),
    /// Rough conductor (Mitsuba 3's `roughconductor`).
    RoughConductor(RoughConductor),
    /// Rough plastic (Mitsuba 3's `roughplastic`).
    RoughPlastic(RoughPlastic),
    /// The reflection of Mitsuba 3's `principled`: Lambertian plus GGX.
    Principled(Principled),
}

impl Brdf {
    /// A Lambertian BRDF of reflectance ρ.
    pub fn diffuse(reflectance: Rgb) -> Brdf {
        Brdf::Diffuse(Diffuse { reflectance })
    }

    /// The albedo of the BRDF's Lambertian lobe: ρ of a diffuse BRDF, ρ_d
    /// of a Ward or principled one (unless black); `None` for models without one. The
    /// solvers carry light this lobe reflects like a diffuse surface's
    /// (two-point links, one radiance per element) and only the rest, f less
    /// ρ/π ([`Brdf::without_lambertian`]), through three-point links.
    pub fn lambertian(&self) -> Option<Rgb> {
        match self {
            Brdf::Diffuse(d) => Some(d.reflectance),
            Brdf::Ward(w) if w.diffuse_reflectance.max_channel() > 0.0 => {
                Some(w.diffuse_reflectance)
            }
            Brdf::Principled(p) if p.diffuse_reflectance.max_channel() > 0.0 => {
                Some(p.diffuse_reflectance)
            }
            _ => None,
        }
    }

    /// The BRDF with its Lambertian lobe's albedo `rho` (a texture's
    /// average over a surface): `diffuse`'s reflectance; `principled`'s
    /// Burley lobe scaled to that albedo. A BRDF without such a lobe is
    /// as it is.
    pub fn with_lambertian(&self, rho: Rgb) -> Brdf {
        match self {
            Brdf::Diffuse(_) => Brdf::diffuse(rho),
            Brdf::Principled(p) => {
                let scale = Rgb([0, 1, 2].map(|c| match p.diffuse_reflectance[c] > 0.0 {
                    true => rho[c] / p.diffuse_reflectance[c],
                    false => 0.0,
                }));
                Brdf::Principled(Principled {
                    diffuse_reflectance: rho,
                    burley: p.burley * scale,
                    ..*p
                })
            }
            other => other.clone(),
        }
    }

    /// The BRDF less its Lambertian lobe ([`Brdf::lambertian`]): what the
    /// three-point kernel (the paper's eq. 13) projects.
    pub fn without_lambertian(&self) -> Brdf {
        match self {
            Brdf::Diffuse(_) => Brdf::diffuse(Rgb::ZERO),
            Brdf::Ward(w) => Brdf::Ward(Ward {
                diffuse_reflectance: Rgb::ZERO,
                ..*w
            }),
            Brdf::Principled(p) => Brdf::Principled(Principled {
                diffuse_reflectance: Rgb::ZERO,
                burley: Rgb::ZERO,
                ..*p
            }),
            other => other.clone(),
        }
    }

    /// The BRDF less its Lambertian lobe as a point shaded in the final
    /// gather reflects it: together with ρ/π of [`Brdf::lambertian`], the
    /// whole BRDF. For all but `principled` this is
    /// [`Brdf::without_lambertian`]; `principled`'s diffuse lobe is
    /// Burley's, which the solution carries as a Lambertian lobe of the
    /// same albedo, so its rest here also holds the signed difference
    /// between Burley's lobe and that Lambertian one (its angular shape:
    /// darker at grazing angles, retro-reflective when rough).
    pub fn shading_rest(&self) -> Brdf {
        self.shading_rest_at(self.lambertian().unwrap_or(Rgb::ZERO))
    }

    /// [`Brdf::shading_rest`] at a point where a texture makes the
    /// Lambertian lobe's albedo `rho` ([`crate::scene::Scene::lambertian_at`]):
    /// `principled`'s difference between Burley's lobe and the Lambertian
    /// one scales with that albedo.
    pub fn shading_rest_at(&self, rho: Rgb) -> Brdf {
        match self {
            Brdf::Principled(_) => match self.with_lambertian(rho) {
                Brdf::Principled(p) => Brdf::Principled(Principled {
                    diffuse_reflectance: Rgb::ZERO,
                    lambertian_removed: rho,
                    ..p
                }),
                other => other,
            },
            other => other.without_lambertian(),
        }
    }

    /// The solid angle of the reflection lobe (sr), about one over its
    /// sampling density at normal incidence: 0.07 for Figure 3's rolled
    /// aluminium, 1.2–1.7 for the glossy Cornell box's broad Ward lobes;
    /// infinite where nothing is sampled.
    pub fn lobe_solid_angle(&self) -> f64 {
        let peak = self.pdf(DVec3::Z, DVec3::Z);
        if peak > 0.0 {
            1.0 / peak
        } else {
            f64::INFINITY
        }
    }

    /// Whether the lobe is narrower than [`SHARP_LOBE`]: it reflects an
    /// emitter as an image with edges (a highlight), where a broader lobe
    /// spreads its light smoothly over much of what it faces.
    pub fn is_sharp(&self) -> bool {
        self.lobe_solid_angle() < SHARP_LOBE
    }

    fn model(&self) -> &dyn BrdfModel {
        match self {
            Brdf::Diffuse(d) => d,
            Brdf::Ward(w) => w,
            Brdf::RoughConductor(c) => c,
            Brdf::RoughPlastic(p) => p,
            Brdf::Principled(p) => p,
        }
    }
}

impl BrdfModel for Brdf {
    fn eval(&self, wo: DVec3, wi: DVec3) -> Rgb {
        self.model().eval(wo, wi)
    }
    fn pdf(&self, wo: DVec3, wi: DVec3) -> f64 {
        self.model().pdf(wo, wi)
    }
    fn sample(&self, wo: DVec3, u: DVec2, lobe: f64) -> Option<BrdfSample> {
        self.model().sample(wo, u, lobe)
    }
    fn flags(&self) -> BrdfFlags {
        self.model().flags()
    }
}

/// A cosine-distributed direction about +z from two uniform numbers
/// (Malley's method: a uniform disk point lifted to the hemisphere).
pub fn cosine_hemisphere(u: DVec2) -> DVec3 {
    let (r, phi) = (u.x.sqrt(), 2.0 * std::f64::consts::PI * u.y);
    DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_are_what_mitsuba_reports() {
        // `bsdf.flags()` of the Mitsuba 3 plugin in its bits (DiffuseReflection
        // 0x2, GlossyReflection 0x8, Anisotropic 0x1000, FrontSide 0x8000);
        // for `ward` the components Mitsuba 0.6's `Ward::configure` lists,
        // which keeps the diffuse lobe even when it is black.
        let anisotropic = Microfacet::new(MicrofacetType::Ggx, 0.1, 0.3);
        let cases = [
            ("diffuse", Brdf::diffuse(Rgb::splat(0.5)), 0x8002),
            ("ward", Brdf::Ward(Ward::default()), 0x800a),
            (
                "ward, black diffuse lobe",
                Brdf::Ward(Ward {
                    diffuse_reflectance: Rgb::ZERO,
                    ..Ward::default()
                }),
                0x800a,
            ),
            (
                "ward, alpha_u != alpha_v",
                Brdf::Ward(Ward {
                    alpha_v: 0.3,
                    ..Ward::default()
                }),
                0x900a,
            ),
            (
                "roughconductor",
                Brdf::RoughConductor(RoughConductor::default()),
                0x8008,
            ),
            (
                "roughconductor, alpha_u != alpha_v",
                Brdf::RoughConductor(RoughConductor {
                    distribution: anisotropic,
                    ..RoughConductor::default()
                }),
                0x9008,
            ),
            (
                "roughplastic",
                Brdf::RoughPlastic(RoughPlastic::default()),
                0x800a,
            ),
        ];
        for (name, brdf, mitsuba) in cases {
            let flags = brdf.flags();
            assert_eq!(flags.bits(), mitsuba, "{name}: {flags:?}");
        }
    }
}
