//! Three-point kernel quadrature: the coefficient of the transfer r → p → q
//! through a glossy surface p over an element triple (paper eq. 8/13 in the
//! element-average form of DESIGN.md §1):
//!
//! `R(c,a,b) = 1/(|a||b|) ∫_a ∫_b ∫_c f_p(x→x'→x'') G(x,x') V(x,x') dA_x dA_x'' dA_x'`
//!
//! so that `L_{a→b} += R(c,a,b) · L_{c→a}`. Visibility enters only between
//! the source c and the glossy element a: L_{a→b} is the radiance *leaving*
//! a towards b, whether or not b sees it (b's own gather applies that).
//!
//! For each Gauss point x' on a, the inner integral over c is Lambert's
//! closed-form factor F(x', c) times the visible fraction of rays to c — the
//! same robust treatment of adjacent surfaces as the two-point kernel — and
//! the BRDF is averaged over c with the weights G(x_i, x') of Gauss points
//! x_i on c: `∫_c f G V dA ≈ π F V̄ · Σ_i w_i G_i f_i / Σ_i w_i G_i`, exact
//! for a BRDF constant over c.

use super::{form_factor, interleaved_targets, KernelContext, KernelElement, Quadrature};
use crate::scene::brdf::{Brdf, BrdfModel, Frame};
use crate::scene::{Patch, Rgb};
use glam::DVec3;
use std::f64::consts::PI;

/// The glossy element of a three-point kernel with its reflection model.
#[derive(Debug, Clone, Copy)]
pub struct GlossyElement<'a> {
    /// Element geometry and surface.
    pub element: KernelElement<'a>,
    /// The surface's BRDF.
    pub brdf: &'a Brdf,
    /// The surface's shading frame.
    pub frame: Frame,
}

/// R(c, a, b) per channel: light from source element `c` reflected by glossy
/// element `a` towards receiver element `b` (which may be a hypothetical
/// receiver outside the scene: it is never traced against).
///
/// The same as `IncidentLight::new(ctx, c, a).towards(b)`; refinement
/// that splits only the receiver can build the [`IncidentLight`] once.
pub fn coefficient(ctx: &KernelContext, c: KernelElement, a: GlossyElement, b: &Patch) -> Rgb {
    IncidentLight::new(ctx, c, a).towards(b)
}

/// What R(c, a, ·) needs of the source element `c`, whatever the receiver:
/// at each Gauss point x′ on `a`, the incident directions from `c`'s Gauss
/// points with their weights w_i G_i, and the factor π F V̄ / Σ w_i G_i. It
/// holds all of the kernel's ray queries and closed-form factors.
#[derive(Debug, Clone)]
pub struct IncidentLight<'a> {
    a: GlossyElement<'a>,
    q: Quadrature,
    points: Vec<IncidentPoint>,
}

#[derive(Debug, Clone)]
struct IncidentPoint {
    position: DVec3,
    /// w′ π F(x′, c) V̄ / Σ_i w_i G_i.
    scale: f64,
    /// Incident directions in `a`'s frame and their weights w_i G_i.
    incident: Vec<(DVec3, f64)>,
}

impl<'a> IncidentLight<'a> {
    /// Light from `c` arriving at the Gauss points of glossy element `a`.
    pub fn new(ctx: &KernelContext, c: KernelElement, a: GlossyElement<'a>) -> IncidentLight<'a> {
        let q = ctx.quadrature;
        let (n_a, n_c) = (a.element.patch.normal(), c.patch.normal());
        let polygon = c.patch.vertices();
        let sources = c.patch.gauss_points(q.points);
        let skip = ctx.skipping(a.element.surface, c.surface);
        let clear = ctx
            .tracer
            .occluder
            .clear_between(&a.element.patch.vertices(), &polygon, skip);
        let mut points = Vec::new();
        for (i, xp) in a
            .element
            .patch
            .gauss_points(q.points)
            .into_iter()
            .enumerate()
        {
            let ff = form_factor::point_to_polygon(xp.position, n_a, &polygon, n_c);
            if ff <= 0.0 || ctx.tracer.is_covered(a.element.surface, xp.position) {
                continue;
            }
            let targets = interleaved_targets(c.patch, q.rays, q.points, i);
            let v = ctx.visible_fraction(xp.position, n_a, c, &targets, skip, clear);
            if v == 0.0 {
                continue;
            }
            // Incident directions and their geometric weights over c.
            let incident: Vec<_> = sources
                .iter()
                .filter_map(|x| {
                    let d = x.position - xp.position;
                    let r2 = d.length_squared();
                    let w = d.normalize();
                    let g = x.weight * n_a.dot(w) * -n_c.dot(w) / r2;
                    (g > 0.0).then(|| (a.frame.to_local(w), g))
                })
                .collect();
            let g_total: f64 = incident.iter().map(|(_, g)| g).sum();
            if g_total <= 0.0 {
                continue;
            }
            points.push(IncidentPoint {
                position: xp.position,
                scale: xp.weight * PI * ff * v / g_total,
                incident,
            });
        }
        IncidentLight { a, q, points }
    }

    /// R(c, a, b) per channel for receiver element `b`.
    pub fn towards(&self, b: &Patch) -> Rgb {
        let (a, receivers) = (&self.a, b.gauss_points(self.q.points));
        let mut sum = Rgb::ZERO;
        for xp in &self.points {
            for xpp in &receivers {
                let wo = a.frame.to_local((xpp.position - xp.position).normalize());
                if wo.z <= 0.0 {
                    continue;
                }
                let mut f = Rgb::ZERO;
                for (wi, g) in &xp.incident {
                    f += a.brdf.eval(wo, *wi) * *g;
                }
                sum += f * (xp.scale * xpp.weight);
            }
        }
        let norm = a.element.patch.area() * b.area();
        sum / norm
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::tracing::SceneTracer;
    use crate::kernel::default_context;
    use crate::scene::Scene;
    use crate::testing::grey;
    use glam::DVec3;

    /// A unit floor, a light above it facing down and a wall at its edge,
    /// with their scene.
    fn floor_light_wall() -> ([Patch; 3], Scene) {
        let floor = Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X,
            edge_t: DVec3::Y,
        };
        let light = Patch::Parallelogram {
            origin: DVec3::new(0.2, 0.0, 0.7),
            edge_s: DVec3::Y,
            edge_t: DVec3::X,
        };
        let wall = Patch::Parallelogram {
            origin: DVec3::new(1.0, 0.0, 0.0),
            edge_s: DVec3::Y,
            edge_t: DVec3::Z,
        };
        let scene = Scene::from_surfaces(vec![grey(floor), grey(light), grey(wall)]);
        ([floor, light, wall], scene)
    }

    /// The floor (surface 0) with `brdf` as the glossy element, and the
    /// light (surface 1) as the source.
    fn floor_and_light<'a>(
        floor: &'a Patch,
        light: &'a Patch,
        brdf: &'a Brdf,
    ) -> (GlossyElement<'a>, KernelElement<'a>) {
        let a = GlossyElement {
            element: KernelElement {
                patch: floor,
                surface: 0,
            },
            brdf,
            frame: Frame::new(floor.normal(), floor.tangent()),
        };
        let c = KernelElement {
            patch: light,
            surface: 1,
        };
        (a, c)
    }

    /// Through a Lambertian p, R(c,a,b) for a receiver b in front of a is
    /// ρ/π · T(a,c)/|a| · π/π = ρ F(a,c): every direction carries the same
    /// reflected radiance.
    #[test]
    fn lambertian_three_point_kernel_is_rho_times_the_form_factor() {
        let ([floor, light, wall], scene) = floor_light_wall();
        let tracer = SceneTracer::new(&scene);
        let ctx = default_context(&scene, &tracer);
        let brdf = Brdf::diffuse(Rgb([0.5, 0.25, 0.125]));
        let (a, c) = floor_and_light(&floor, &light, &brdf);
        let r = coefficient(&ctx, c, a, &wall.flipped());
        let f = ctx.throughput(a.element, c) / floor.area();
        for (ch, rho) in [0.5, 0.25, 0.125].into_iter().enumerate() {
            assert!(
                (r[ch] - rho * f).abs() < 1e-12 * f,
                "{} vs {}",
                r[ch],
                rho * f
            );
        }
    }

    /// Refinement that splits only the receiver reuses the incident light:
    /// it must give exactly the coefficients of separate evaluations.
    #[test]
    fn incident_light_reused_over_receivers_is_bit_identical() {
        let ([floor, light, wall], scene) = floor_light_wall();
        let tracer = SceneTracer::new(&scene);
        let ctx = default_context(&scene, &tracer);
        let brdf = Brdf::Ward(crate::scene::brdf::Ward {
            variant: crate::scene::brdf::WardVariant::Balanced,
            alpha_u: 0.1,
            alpha_v: 0.35,
            specular_reflectance: Rgb::splat(0.15),
            diffuse_reflectance: Rgb([0.6, 0.5, 0.4]),
        });
        let (a, c) = floor_and_light(&floor, &light, &brdf);
        let incident = IncidentLight::new(&ctx, c, a);
        for b in wall.flipped().subdivide() {
            let r = coefficient(&ctx, c, a, &b);
            assert!(r[0] > 0.0);
            assert_eq!(incident.towards(&b), r);
        }
    }
}
