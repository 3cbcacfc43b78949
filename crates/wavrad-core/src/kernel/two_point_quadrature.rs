//! Two-point kernel quadrature: the coefficient of the diffuse transport
//! kernel over a pair of elements (paper §3, K_rp; DESIGN.md §1).
//!
//! wavrad stores the symmetric *geometric throughput*
//! `T(a,c) = ∫_a ∫_c cosθ_a cosθ_c V / (π r²) dA_c dA_a`, from which both
//! directions of a link follow: `F(a,c) = T/|a|`, `F(c,a) = T/|c|`
//! (reciprocity holds by construction).

use super::{form_factor, interleaved_targets, sides_of_plane, KernelContext, KernelElement};
use crate::scene::Patch;

/// Whether `a` is the element a throughput's outer integral runs over:
/// the one lying wholly in front of the other's plane when only one does,
/// else the smaller. From points of an element that straddles the other's
/// plane, the integrand is zero over the part behind it; a strip in front
/// narrower than the Gauss points' inset was lost (a cube's top on the
/// floor of a furnace missed 2 % of its form factor to each wall, whose
/// elements it cut near their edge).
fn outer_is_a(a: &Patch, c: &Patch) -> bool {
    let straddles = |p: &Patch, q: &Patch| sides_of_plane(q, p, 0.0) == (true, true);
    match (straddles(a, c), straddles(c, a)) {
        (true, false) => false,
        (false, true) => true,
        _ => a.area() <= c.area(),
    }
}

/// The outer integral of a throughput, point by point.
#[derive(Debug, Clone, PartialEq)]
pub struct OuterSamples {
    /// Whether the outer (point-sampled) element was `a`, else `c`.
    pub outer_is_a: bool,
    /// For each point of `outer.gauss_points(q.points)`, in that order, its
    /// weight times the visible point-to-polygon factor.
    pub contributions: Vec<f64>,
    /// Nothing blocks the shaft between the two elements
    /// ([`Occluder::clear_between`](crate::geometry::visibility::Occluder::clear_between)),
    /// nor any shaft between parts of them.
    pub clear: bool,
}

impl OuterSamples {
    /// The throughput: the sum of the contributions.
    pub fn total(&self) -> f64 {
        self.contributions.iter().sum()
    }
}

impl KernelContext<'_> {
    /// Geometric throughput T(a,c) with visibility, point by point.
    ///
    /// The outer integral runs over one element (the smaller, unless only it
    /// straddles the other's plane: `outer_is_a`) with Gauss–Legendre points;
    /// the inner one is Lambert's closed form over the other element
    /// ([`form_factor::point_to_polygon`]) times the fraction of unoccluded rays
    /// from the point to a grid of points on it, where the shaft between the
    /// elements is not `known_clear` (a part of a clear one) or found clear.
    pub fn throughput_samples(
        &self,
        a: KernelElement,
        c: KernelElement,
        known_clear: bool,
    ) -> OuterSamples {
        let q = self.quadrature;
        let outer_is_a = outer_is_a(a.patch, c.patch);
        let (outer, inner) = if outer_is_a { (a, c) } else { (c, a) };
        let (n_outer, n_inner) = (outer.patch.normal(), inner.patch.normal());
        let polygon = inner.patch.vertices();
        let skip = self.skipping(a.surface, c.surface);
        let clear = known_clear
            || self
                .tracer
                .occluder
                .clear_between(&outer.patch.vertices(), &polygon, skip);
        let contributions = outer
            .patch
            .gauss_points(q.points)
            .into_iter()
            .enumerate()
            .map(|(i, x)| {
                if self.tracer.is_covered(outer.surface, x.position) {
                    return 0.0;
                }
                let unoccluded_ff =
                    form_factor::point_to_polygon(x.position, n_outer, &polygon, n_inner);
                if unoccluded_ff <= 0.0 {
                    return 0.0;
                }
                let targets = interleaved_targets(inner.patch, q.rays, q.points, i);
                x.weight
                    * unoccluded_ff
                    * self.visible_fraction(x.position, n_outer, inner, &targets, skip, clear)
            })
            .collect();
        OuterSamples {
            outer_is_a,
            contributions,
            clear,
        }
    }

    /// Geometric throughput T(a,c) with visibility ([`Self::throughput_samples`] summed).
    pub fn throughput(&self, a: KernelElement, c: KernelElement) -> f64 {
        self.throughput_samples(a, c, false).total()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::tracing::SceneTracer;
    use crate::kernel::Quadrature;
    use crate::scene::Scene;
    use crate::testing::grey;
    use glam::{DVec2, DVec3};

    #[test]
    fn an_element_cut_by_the_others_plane_near_its_edge_keeps_its_strip() {
        // A cube's top (z = 0.9) and a wall element x = 0, z ∈ [0.5, 1]:
        // only its top fifth is in front of the top's plane, above its
        // Gauss points (0.21 and 0.79 of its height). The smaller wall
        // element must not be the outer one, smaller though it is.
        let top = Patch::Parallelogram {
            origin: DVec3::new(0.2, 0.0, 0.9),
            edge_s: DVec3::X * 0.6,
            edge_t: DVec3::Y * 0.6,
        };
        let wall = Patch::Parallelogram {
            origin: DVec3::new(0.0, 0.0, 0.5),
            edge_s: DVec3::Y * 0.5,
            edge_t: DVec3::Z * 0.5,
        };
        assert!(wall.area() < top.area() && !outer_is_a(&wall, &top));
        let scene = Scene::from_surfaces(vec![grey(top), grey(wall)]);
        let tracer = SceneTracer::new(&scene);
        let ctx = KernelContext::new(&scene, &tracer, Quadrature::default());
        let (t, w) = (
            KernelElement {
                patch: &top,
                surface: 0,
            },
            KernelElement {
                patch: &wall,
                surface: 1,
            },
        );
        // Midpoint rule on the top, Lambert's formula over the wall.
        let n = 40;
        let mut reference = 0.0;
        for i in 0..n * n {
            let uv = DVec2::new((i % n) as f64 + 0.5, (i / n) as f64 + 0.5) / n as f64;
            let x = top.point_at(uv);
            let f = form_factor::point_to_polygon(x, top.normal(), &wall.vertices(), wall.normal());
            reference += f * top.area() / (n * n) as f64;
        }
        assert!(reference > 1e-4, "{reference}");
        // To the 2×2 rule's accuracy (refinement goes finer); from the
        // wall's points it was zero.
        for (a, c) in [(t, w), (w, t)] {
            let got = ctx.throughput(a, c);
            assert!((got / reference - 1.0).abs() < 0.15, "{got} vs {reference}");
        }
    }

    #[test]
    fn occluder_between_parallel_squares_blocks_light() {
        let bottom = Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X,
            edge_t: DVec3::Y,
        };
        let top = Patch::Parallelogram {
            origin: DVec3::new(0.0, 0.0, 1.0),
            edge_s: DVec3::Y,
            edge_t: DVec3::X,
        };
        let blocker = Patch::Parallelogram {
            origin: DVec3::new(-1.0, -1.0, 0.5),
            edge_s: DVec3::X * 3.0,
            edge_t: DVec3::Y * 3.0,
        };
        let throughput = |scene: &Scene, a, c| {
            let tracer = SceneTracer::new(scene);
            KernelContext::new(scene, &tracer, Quadrature::default()).throughput(a, c)
        };
        let open = Scene::from_surfaces(vec![grey(bottom), grey(top)]);
        let closed = Scene::from_surfaces(vec![grey(bottom), grey(top), grey(blocker)]);
        let b = KernelElement {
            patch: &bottom,
            surface: 0,
        };
        let t = KernelElement {
            patch: &top,
            surface: 1,
        };
        assert!(throughput(&open, b, t) > 0.1);
        assert_eq!(throughput(&closed, b, t), 0.0);
    }
}
