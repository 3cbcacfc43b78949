//! Two-point kernel quadrature: the coefficient of the diffuse transport
//! kernel over a pair of elements (paper §3, K_rp; DESIGN.md §1).
//!
//! wavrad stores the symmetric *geometric throughput*
//! `T(a,c) = ∫_a ∫_c cosθ_a cosθ_c V / (π r²) dA_c dA_a`, from which both
//! directions of a link follow: `F(a,c) = T/|a|`, `F(c,a) = T/|c|`
//! (reciprocity holds by construction).

pub mod exposure;
pub mod form_factor;
pub mod three_point_quadrature;

use crate::geometry::element::AreaSample;
use crate::geometry::tracing::SceneTracer;
use crate::scene::{Patch, Scene};
use glam::{DVec2, DVec3};

/// Quadrature settings for kernel coefficients.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Quadrature {
    /// Gauss–Legendre order per axis on the outer (point) element.
    pub points: usize,
    /// Order per axis of the visibility sample grid on the inner element
    /// (`rays` × `rays` occlusion rays per outer point).
    pub rays: usize,
}

impl Default for Quadrature {
    fn default() -> Self {
        Quadrature { points: 2, rays: 2 }
    }
}

/// What every kernel evaluation reads besides its elements: the scene, ray
/// queries over it and the quadrature rule. A solve makes one (as pbrt's
/// integrator owns its aggregate and Mitsuba's scene its ray queries) and
/// every projection, exposure test and coefficient takes it.
#[derive(Debug, Clone, Copy)]
pub struct KernelContext<'a> {
    /// The scene whose kernels are evaluated.
    pub scene: &'a Scene,
    /// Ray queries over its surfaces.
    pub tracer: &'a SceneTracer,
    /// Quadrature of every kernel coefficient.
    pub quadrature: Quadrature,
}

/// An element taking part in a kernel evaluation: its geometry and the
/// surface it lies on (whose primitives never occlude the interaction).
#[derive(Debug, Clone, Copy)]
pub struct KernelElement<'a> {
    /// Element geometry.
    pub patch: &'a Patch,
    /// Index of its surface.
    pub surface: u32,
}

/// True when the two planar elements cannot exchange light at all: one lies
/// entirely behind (or in the plane of) the other's front side.
pub fn faces_away(a: &Patch, c: &Patch) -> bool {
    let behind = |p: &Patch, q: &Patch| !sides_of_plane(p, q).0;
    behind(a, c) || behind(c, a)
}

/// Whether some vertex of `q` lies in front of the plane of `p`, and
/// whether some lies behind it (vertices in the plane count as neither).
fn sides_of_plane(p: &Patch, q: &Patch) -> (bool, bool) {
    let (n, o) = (p.normal(), p.vertices()[0]);
    q.vertices()
        .iter()
        .fold((false, false), |(front, back), v| {
            let (h, tolerance) = (n.dot(*v - o), 1e-12 * (1.0 + v.length()));
            (front || h > tolerance, back || h < -tolerance)
        })
}

/// Whether `a` is the element a throughput's outer integral runs over:
/// the one lying wholly in front of the other's plane when only one does,
/// else the smaller. From points of an element that straddles the other's
/// plane, the integrand is zero over the part behind it; a strip in front
/// narrower than the Gauss points' inset was lost (a cube's top on the
/// floor of a furnace missed 2 % of its form factor to each wall, whose
/// elements it cut near their edge).
fn outer_is_a(a: &Patch, c: &Patch) -> bool {
    let straddles = |p: &Patch, q: &Patch| sides_of_plane(q, p) == (true, true);
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
                let unoccluded_ff =
                    form_factor::point_to_polygon(x.position, n_outer, &polygon, n_inner);
                if unoccluded_ff <= 0.0 {
                    return 0.0;
                }
                let targets = interleaved_targets(inner.patch, q.rays, q.points, i);
                x.weight
                    * unoccluded_ff
                    * self.visible_fraction(x.position, n_outer, &polygon, &targets, skip, clear)
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

    /// The occlusion test of an interaction between surfaces `a` and `c`:
    /// true for the primitives of either, which never occlude it.
    pub fn skipping(&self, a: u32, c: u32) -> impl Fn(u32) -> bool + Copy + '_ {
        move |prim: u32| {
            let s = self.tracer.surface_of(prim);
            s == a || s == c
        }
    }

    /// Fraction of the `targets` in front of (`x`, `n_x`) that `x` sees, each
    /// weighted by the kernel cosθ_x cosθ_y / r² towards it (as Lambert's
    /// formula weighs the polygon's points, so that an occluder hiding the
    /// polygon's near part hides more than its share of the targets), the
    /// primitives `skip` accepts never occluding. The targets lie on the
    /// `polygon` they sample; when none of them is in front of `x` but part of
    /// the polygon is (a large element straddling `x`'s plane, whose front part
    /// Lambert's formula still counts), the centroid of that part stands in for
    /// them. 0 when nothing is in front. With `clear`, the caller knows that
    /// nothing blocks the shaft between `x`'s element and the polygon
    /// ([`Occluder::clear_between`](crate::geometry::visibility::Occluder::clear_between)):
    /// no ray is traced, and the result is the same.
    pub fn visible_fraction(
        &self,
        x: DVec3,
        n_x: DVec3,
        polygon: &[DVec3],
        targets: &[AreaSample],
        skip: impl Fn(u32) -> bool + Copy,
        clear: bool,
    ) -> f64 {
        let sees = |y: DVec3| clear || !self.tracer.occluder.occluded_except(x, y, skip);
        let n_y = (polygon[1] - polygon[0])
            .cross(polygon[2] - polygon[0])
            .normalize_or_zero();
        let (mut seen, mut total) = (0.0, 0.0);
        for y in targets {
            let d = y.position - x;
            let r2 = d.length_squared();
            if n_x.dot(d) <= 0.0 || r2 <= 0.0 {
                continue;
            }
            let w = n_x.dot(d) * n_y.dot(d).abs() / (r2 * r2);
            total += w;
            if sees(y.position) {
                seen += w;
            }
        }
        if total > 0.0 {
            return seen / total;
        }
        let front = form_factor::front_part(polygon, x, n_x);
        if front.len() < 3 {
            return 0.0;
        }
        let centroid = front.iter().sum::<DVec3>() / front.len() as f64;
        f64::from(u8::from(sees(centroid)))
    }
}

/// The visibility targets of outer point `i` of an `m` × `m` rule: the
/// centres of every `m`-th cell, offset by `i`, of an `n·m` × `n·m` grid
/// on `patch`. Each point aims its `n` × `n` rays at places of its own,
/// spread over the whole element, and together the points of a link sample
/// the full grid, where fixed targets would test the same lines of sight
/// from every point.
pub(crate) fn interleaved_targets(patch: &Patch, n: usize, m: usize, i: usize) -> Vec<AreaSample> {
    let side = (n * m) as f64;
    let weight = patch.area() / (n * n) as f64;
    (0..n * n)
        .map(|k| {
            let cell = DVec2::new(((k % n) * m + i % m) as f64, ((k / n) * m + i / m) as f64);
            AreaSample {
                position: patch.point_at(patch.square_to_param((cell + 0.5) / side)),
                weight,
            }
        })
        .collect()
}

/// The kernel context of `scene` with the default quadrature, for tests.
#[cfg(test)]
pub(crate) fn default_context<'a>(scene: &'a Scene, tracer: &'a SceneTracer) -> KernelContext<'a> {
    KernelContext {
        scene,
        tracer,
        quadrature: Quadrature::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;
    use crate::testing::grey;
    use glam::DVec3;

    #[test]
    fn interleaved_targets_of_all_points_fill_the_grid_once() {
        let patch = Patch::Parallelogram {
            origin: DVec3::new(1.0, 0.0, 0.0),
            edge_s: DVec3::X * 2.0,
            edge_t: DVec3::Y,
        };
        let (n, m) = (2, 2);
        let mut cells: Vec<(i64, i64)> = (0..m * m)
            .flat_map(|i| interleaved_targets(&patch, n, m, i))
            .map(|t| {
                let uv = patch.param_of(t.position) * (n * m) as f64 - DVec2::splat(0.5);
                assert!(
                    (uv - uv.round()).length() < 1e-9,
                    "{uv:?} is not a cell centre"
                );
                (uv.x.round() as i64, uv.y.round() as i64)
            })
            .collect();
        cells.sort_unstable();
        cells.dedup();
        assert_eq!(cells.len(), 16, "every cell of the 4×4 grid, each once");
        // One point's targets spread over the whole element, one per quadrant.
        let quadrants: Vec<_> = interleaved_targets(&patch, n, m, 3)
            .iter()
            .map(|t| patch.locate_child(patch.param_of(t.position)).0)
            .collect();
        assert_eq!(quadrants, [0, 1, 2, 3]);
    }

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
        let ctx = KernelContext {
            scene: &scene,
            tracer: &tracer,
            quadrature: Quadrature::default(),
        };
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
            KernelContext {
                scene,
                tracer: &tracer,
                quadrature: Quadrature::default(),
            }
            .throughput(a, c)
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
