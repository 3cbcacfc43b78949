//! Glass: dielectric interfaces, smooth (Mitsuba 3's `dielectric` and
//! `thindielectric`) or rough (`roughdielectric`: Walter et al.,
//! *Microfacet Models for Refraction through Rough Surfaces*, EGSR 2007).
//! They are not among the solve's surfaces: the solve,
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
//! let glass = Dielectric {
//!     eta: 1.5,
//!     thin: false,
//!     reflectance: Rgb::splat(1.0),
//!     transmittance: Rgb::splat(1.0),
//!     roughness: None,
//! };
//! // Straight down onto the interface: 4 % is reflected (u below it), the rest refracts.
//! let (dir, weight) = glass.scatter(-DVec3::Z, DVec3::Z, DVec3::splat(0.5), Radiance);
//! assert_eq!(dir, -DVec3::Z);
//! assert!((weight[0] - 1.0 / 2.25).abs() < 1e-12);
//! let (dir, _) = glass.scatter(-DVec3::Z, DVec3::Z, DVec3::splat(0.01), Radiance);
//! assert_eq!(dir, DVec3::Z);
//! ```

use crate::scene::brdf::fresnel::fresnel_dielectric;
use crate::scene::brdf::microfacet::Microfacet;
use crate::scene::brdf::Frame;
use crate::scene::shading::ShadingNormals;
use crate::scene::{Patch, Rgb};
use glam::{DVec2, DVec3};

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
    /// The microfacet normals of a rough interface (`roughdielectric`;
    /// isotropic, and never on a thin pane), `None` on a smooth one.
    pub roughness: Option<Microfacet>,
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

    /// The normal that a ray travelling along `dir` (unit) meets where the
    /// interface's shading normal is `normal`: `normal` itself on a smooth
    /// interface; on a rough one a microfacet normal, drawn by `u` ∈ [0,1)²
    /// from those the ray sees (Heitz & d'Eon 2014, as Mitsuba 3's
    /// `roughdielectric` with `sample_visible`), on the side of `normal`.
    pub fn facet(&self, dir: DVec3, normal: DVec3, u: DVec2) -> DVec3 {
        let Some(distribution) = self.roughness else {
            return normal;
        };
        // Isotropic: any tangent will do.
        let frame = Frame::new(normal, DVec3::ZERO);
        // From inside, the facets' undersides face the ray: those it sees
        // are the ones seen from outside along the ray's reversal.
        let wi = frame.to_local(-dir);
        let seen_from = if wi.z < 0.0 { -wi } else { wi };
        frame.to_world(distribution.sample(seen_from, u).0)
    }

    /// Where a ray travelling along `dir` (unit) that meets the interface
    /// at shading normal `normal` goes on, and the weight its radiance
    /// takes there. `u.x` ∈ [0, 1) chooses reflection when it falls below
    /// the Fresnel reflectance and transmission otherwise, `(u.y, u.z)`
    /// draws the microfacet normal of a rough interface
    /// ([`Dielectric::facet`]) about which it reflects or refracts.
    /// Mitsuba 3's `dielectric`, `thindielectric` and `roughdielectric`
    /// `sample`: the choice's probability cancels the Fresnel factor, and
    /// the visible normals' density all of the microfacet BSDF (Walter et
    /// al. 2007, eqs. 20–21) but the masking of the way out, G1(o, m); a
    /// refracted ray's radiance, not its power, is scaled by (η_t/η_i)⁻²,
    /// the solid angle's compression across the interface.
    pub fn scatter(
        &self,
        dir: DVec3,
        normal: DVec3,
        u: DVec3,
        transport: Transport,
    ) -> (DVec3, Rgb) {
        let m = self.facet(dir, normal, DVec2::new(u.y, u.z));
        self.scatter_at(dir, (normal, m), u.x, transport)
    }

    /// Both ways on from the facet `m` already drawn ([`Dielectric::facet`];
    /// `normal` on a smooth interface), reflected and refracted, each with
    /// [`Dielectric::scatter_at`]'s weight times its probability: together
    /// what one choice gives on average. A way of probability zero (no
    /// refraction past the critical angle) is left out.
    pub fn branches(
        &self,
        dir: DVec3,
        (normal, m): (DVec3, DVec3),
        transport: Transport,
    ) -> impl Iterator<Item = (DVec3, Rgb)> + '_ {
        let r = self.reflectance_at(-dir.dot(m));
        [(0.5 * r, r), (r + 0.5 * (1.0 - r), 1.0 - r)]
            .into_iter()
            .filter(|&(_, p)| p > 0.0)
            .map(move |(u, p)| {
                let (out, weight) = self.scatter_at(dir, (normal, m), u, transport);
                (out, weight * p)
            })
    }

    /// [`Dielectric::scatter`] about the facet `m` already drawn
    /// ([`Dielectric::facet`]; `normal` on a smooth interface), choosing
    /// reflection when `u` ∈ [0, 1) falls below its Fresnel reflectance.
    pub fn scatter_at(
        &self,
        dir: DVec3,
        (normal, m): (DVec3, DVec3),
        u: f64,
        transport: Transport,
    ) -> (DVec3, Rgb) {
        let cos_theta_i = -dir.dot(m);
        let reflect = || dir + 2.0 * cos_theta_i * m;
        if self.thin {
            return if u < self.reflectance_at(cos_theta_i) {
                (reflect(), self.reflectance)
            } else {
                (dir, self.transmittance)
            };
        }
        let (r, cos_theta_t, _, eta_ti) = fresnel_dielectric(cos_theta_i, self.eta);
        let (out, weight) = if u < r {
            (reflect(), self.reflectance)
        } else {
            // Mitsuba's refract(): −η_ti·wi's tangential part, plus cosθt·m.
            let wi = -dir;
            let tangential = wi - cos_theta_i * m;
            let refracted = (-eta_ti * tangential + cos_theta_t * m).normalize();
            let scale = match transport {
                Transport::Radiance => eta_ti * eta_ti,
                Transport::Power => 1.0,
            };
            (refracted, self.transmittance * scale)
        };
        match self.roughness {
            None => (out, weight),
            Some(distribution) => {
                let frame = Frame::new(normal, DVec3::ZERO);
                let masking = distribution.smith_g1(frame.to_local(out), frame.to_local(m));
                (out, weight * masking)
            }
        }
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
            roughness: None,
        }
    }

    #[test]
    fn refraction_obeys_snells_law_both_ways() {
        let g = glass(false);
        let n = DVec3::Z;
        for theta_deg in [10.0_f64, 30.0, 40.0, 60.0, 80.0] {
            let t = theta_deg.to_radians();
            let dir = DVec3::new(t.sin(), 0.0, -t.cos());
            let (out, w) = g.scatter(dir, n, DVec3::splat(0.999), Transport::Radiance);
            // sin θi = η sin θt, on the same side of the normal's plane.
            assert!((t.sin() - 1.5 * out.x).abs() < 1e-12, "{theta_deg}");
            assert!(out.z < 0.0 && (out.length() - 1.0).abs() < 1e-12);
            assert!((w[0] - 1.0 / 2.25).abs() < 1e-12);
            // Back out along the reversed ray: the original direction, and
            // the inverse radiance scale.
            let (back, w) = g.scatter(-out, n, DVec3::splat(0.999), Transport::Radiance);
            assert!((back + dir).length() < 1e-12, "{theta_deg}");
            assert!((w[0] - 2.25).abs() < 1e-12);
            // A photon's power is not scaled.
            let (_, w) = g.scatter(dir, n, DVec3::splat(0.999), Transport::Power);
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
        let (out, _) = g.scatter(dir, DVec3::Z, DVec3::splat(0.9999), Transport::Power);
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
            thin.scatter(dir, DVec3::Z, DVec3::splat(0.5), Transport::Radiance),
            (dir, Rgb::splat(1.0))
        );
    }

    /// Mitsuba 3's `roughdielectric` `eval` for light carried as power
    /// (Walter et al. 2007, eqs. 20–21, times |cos θ_o|): what a sample's
    /// weight must average to over the directions `wo` (local frame).
    fn walter(distribution: &Microfacet, eta: f64, wi: DVec3, wo: DVec3) -> f64 {
        let reflect = wi.z * wo.z > 0.0;
        let eta_io = if wi.z > 0.0 { eta } else { 1.0 / eta };
        let m = (wi + wo * if reflect { 1.0 } else { eta_io }).normalize();
        let m = m * m.z.signum();
        if wi.dot(m) * wi.z <= 0.0 || wo.dot(m) * wo.z <= 0.0 {
            return 0.0;
        }
        let d = distribution.eval(m);
        let f = fresnel_dielectric(wi.dot(m), eta).0;
        let g = distribution.g(wi, wo, m);
        if reflect {
            f * d * g / (4.0 * wi.z.abs())
        } else {
            let denominator = (wi.dot(m) + eta_io * wo.dot(m)).powi(2);
            ((1.0 - f) * d * g * eta_io * eta_io * wi.dot(m) * wo.dot(m) / (wi.z * denominator))
                .abs()
        }
    }

    #[test]
    fn a_rough_interface_scatters_as_walters_microfacet_bsdf() {
        use crate::sampling::hash2;
        use crate::scene::brdf::microfacet::MicrofacetType;
        use std::f64::consts::PI;
        for (kind, alpha) in [(MicrofacetType::Beckmann, 0.3), (MicrofacetType::Ggx, 0.2)] {
            let distribution = Microfacet::isotropic(kind, alpha);
            let glass = Dielectric {
                roughness: Some(distribution),
                ..glass(false)
            };
            // From outside at 40°, from inside at 25° (below the critical
            // angle, 41.8°) and at 50° (beyond it), the normal tilted so
            // that the frame is not the world's.
            let normal = DVec3::new(0.3, -0.2, 1.0).normalize();
            let frame = Frame::new(normal, DVec3::ZERO);
            for theta_deg in [40.0_f64, -25.0, -50.0] {
                let t = theta_deg.to_radians();
                let wi = DVec3::new(t.sin().abs(), 0.0, t.cos() * theta_deg.signum());
                // Sums of the weights of the reflected and transmitted
                // samples, and of their directions' x (where they go).
                let n = 400_000;
                let mut sampled = [0.0; 4];
                for k in 0..n {
                    let (a, b) = (hash2(7, 2 * k), hash2(7, 2 * k + 1));
                    let u = DVec3::new(a.x, a.y, b.x);
                    let (out, w) = glass.scatter(-frame.to_world(wi), normal, u, Transport::Power);
                    let wo = frame.to_local(out);
                    let side = usize::from(wo.z * wi.z < 0.0);
                    sampled[side] += w[0] / n as f64;
                    sampled[2 + side] += w[0] * wo.x / n as f64;
                }
                // The same integrals of the closed-form BSDF over the sphere.
                let (rows, columns) = (1200, 400);
                let mut integral = [0.0; 4];
                for i in 0..rows {
                    let theta = (i as f64 + 0.5) * PI / rows as f64;
                    for j in 0..columns {
                        let phi = (j as f64 + 0.5) * 2.0 * PI / columns as f64;
                        let wo = DVec3::new(
                            theta.sin() * phi.cos(),
                            theta.sin() * phi.sin(),
                            theta.cos(),
                        );
                        let d_omega = theta.sin() * PI / rows as f64 * 2.0 * PI / columns as f64;
                        let f = walter(&distribution, glass.eta, wi, wo) * d_omega;
                        let side = usize::from(wo.z * wi.z < 0.0);
                        integral[side] += f;
                        integral[2 + side] += f * wo.x;
                    }
                }
                let case = format!(
                    "{kind} {alpha} at {theta_deg}°: sampled {sampled:?}, Walter {integral:?}"
                );
                for (s, i) in sampled.iter().zip(&integral) {
                    assert!((s - i).abs() < 0.002 + 0.005 * i.abs(), "{case}");
                }
                // Beyond the critical angle nearly everything reflects; the
                // rest refracts through facets tilted towards the ray.
                if theta_deg == -50.0 {
                    assert!(integral[0] > 0.5 && integral[1] < 0.3, "{case}");
                } else {
                    assert!(integral[1] > 0.5, "{case}");
                }
            }
        }
    }

    #[test]
    fn a_smooth_interfaces_facet_is_its_normal_and_a_rough_ones_faces_the_ray() {
        use crate::sampling::hash2;
        use crate::scene::brdf::microfacet::MicrofacetType;
        let normal = DVec3::Z;
        let dir = DVec3::new(0.5, 0.0, -0.75f64.sqrt());
        assert_eq!(
            glass(false).facet(dir, normal, DVec2::new(0.3, 0.9)),
            normal
        );
        let rough = Dielectric {
            roughness: Some(Microfacet::isotropic(MicrofacetType::Ggx, 0.5)),
            ..glass(false)
        };
        for k in 0..1000 {
            for dir in [dir, -dir] {
                let m = rough.facet(dir, normal, hash2(3, k));
                // On the normal's side, and met by the ray from its front
                // (from outside) or from its back (from inside).
                assert!(m.z > 0.0 && (m.length() - 1.0).abs() < 1e-12);
                assert!(dir.dot(m) * dir.dot(normal) > 0.0, "{dir} {m}");
            }
        }
    }
}
