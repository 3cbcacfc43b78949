//! Kernel quadrature: the coefficients of the transport kernels over
//! elements, two-point ([`two_point_quadrature`], paper §3) and three-point
//! ([`three_point_quadrature`], eq. 13), evaluated in a [`KernelContext`]
//! (the scene, its ray queries and the quadrature orders), with what both
//! share: visibility fractions towards interleaved targets, Lambert's
//! closed-form factor ([`form_factor`]) and the exposed part of an element
//! ([`exposure`]); and the light of point, spot, directional lights and the
//! sky at a point ([`lights`]).

pub mod exposure;
pub mod form_factor;
pub mod lights;
pub mod three_point_quadrature;
pub mod two_point_quadrature;

use crate::geometry::element::AreaSample;
use crate::geometry::tracing::SceneTracer;
use crate::scene::{Patch, Scene};
use glam::{DVec2, DVec3};

/// Quadrature settings for kernel coefficients.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
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
    faces_away_within(a, c, 0.0)
}

/// [`faces_away`], with the vertices within `contact` of a plane counted
/// as lying in it.
fn faces_away_within(a: &Patch, c: &Patch, contact: f64) -> bool {
    let behind = |p: &Patch, q: &Patch| !sides_of_plane(p, q, contact).0;
    behind(a, c) || behind(c, a)
}

impl<'a> KernelContext<'a> {
    /// The context of `scene`, with `tracer` over its surfaces.
    pub fn new(scene: &'a Scene, tracer: &'a SceneTracer, quadrature: Quadrature) -> Self {
        KernelContext {
            scene,
            tracer,
            quadrature,
        }
    }

    /// The deepest level `surface`'s elements may reach under a maximum
    /// level of `max_level`. The maximum level counts the levels of the
    /// scene's largest surface, of area A_max; a smaller surface stops at
    /// the first level whose elements are no larger than A_max/4^max_level,
    /// the scene's minimum element area (A_ε of Hanrahan, Salzman &
    /// Aupperle 1991). A fine mesh's triangles are then split only as deep
    /// as the wall beside them, not 4^max_level ways each, and a triangle
    /// smaller than the wall's finest elements stays whole.
    pub fn deepest_level(&self, surface: u32, max_level: u32) -> u32 {
        let area = self.scene.surfaces[surface as usize].patch.area();
        let ratio = area / self.tracer.largest_area() * 4f64.powi(max_level as i32);
        if ratio.is_nan() || ratio <= 1.0 {
            return 0;
        }
        // Less a rounding margin: a surface exactly 4^-k of the largest
        // stops k levels sooner, not k − 1.
        ((ratio.log(4.0) - 1e-9).ceil() as u32).min(max_level)
    }

    /// The distance below which surfaces touch
    /// ([`Occluder::contact_distance`](crate::geometry::visibility::Occluder::contact_distance)).
    pub fn contact_distance(&self) -> f64 {
        self.tracer.occluder.contact_distance()
    }

    /// True when the planar elements `a` and `c` exchange no light: they
    /// face away from each other ([`faces_away`]), or one lies within the
    /// contact distance of the other's plane, pressed against its front (a
    /// box's base on the floor it rests on, a wall inside a wall). The
    /// parts of surfaces pressed together are buried
    /// ([`exposure::is_buried`]): they neither receive nor send light, so
    /// no link may join them.
    pub fn exchange_nothing(&self, a: &Patch, c: &Patch) -> bool {
        faces_away_within(a, c, self.contact_distance())
    }

    /// The occlusion test of an interaction between surfaces `a` and `c`:
    /// true for the primitives of either, which never occlude it, and of
    /// the surfaces lying in the plane of either
    /// ([`SceneTracer::coplanar`]: the other side of a `twosided` surface),
    /// which a segment between them cannot cross; shafts next to a
    /// `twosided` surface are clear again
    /// ([`Occluder::clear_between`](crate::geometry::visibility::Occluder::clear_between)).
    pub fn skipping(&self, a: u32, c: u32) -> impl Fn(u32) -> bool + Copy + '_ {
        let (in_a, in_c) = (self.tracer.coplanar(a), self.tracer.coplanar(c));
        move |prim: u32| {
            let s = self.tracer.surface_of(prim);
            s == a || s == c || in_a.contains(&s) || in_c.contains(&s)
        }
    }

    /// Fraction of the `targets` in front of (`x`, `n_x`) that `x` sees, each
    /// weighted by the kernel cosθ_x cosθ_y / r² towards it (as Lambert's
    /// formula weighs the polygon's points, so that an occluder hiding the
    /// polygon's near part hides more than its share of the targets), the
    /// primitives `skip` accepts never occluding, and targets covered by a
    /// coincident surface ([`SceneTracer::is_covered`]) never seen. The
    /// targets lie on the `inner` element they sample; when none of them is
    /// in front of `x` but part of the element is (a large element straddling
    /// `x`'s plane, whose front part Lambert's formula still counts), the
    /// centroid of that part stands in for them. 0 when nothing is in front.
    /// With `clear`, the caller knows that nothing blocks the shaft between
    /// `x`'s element and `inner`
    /// ([`Occluder::clear_between`](crate::geometry::visibility::Occluder::clear_between)):
    /// no ray is traced, and the result is the same.
    pub fn visible_fraction(
        &self,
        x: DVec3,
        n_x: DVec3,
        inner: KernelElement,
        targets: &[AreaSample],
        skip: impl Fn(u32) -> bool + Copy,
        clear: bool,
    ) -> f64 {
        let sees = |y: DVec3| {
            !self.tracer.is_covered(inner.surface, y)
                && (clear || !self.tracer.occluder.occluded_except(x, y, skip))
        };
        let polygon = inner.patch.vertices();
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
        let front = form_factor::front_part(&polygon, x, n_x);
        if front.len() < 3 {
            return 0.0;
        }
        let centroid = front.iter().sum::<DVec3>() / front.len() as f64;
        f64::from(u8::from(sees(centroid)))
    }
}

/// Whether some vertex of `q` lies in front of the plane of `p`, and
/// whether some lies behind it: farther from it than `contact` and than
/// the rounding of their coordinates (vertices nearer count as neither).
pub(super) fn sides_of_plane(p: &Patch, q: &Patch, contact: f64) -> (bool, bool) {
    let first = |p: &Patch| match *p {
        Patch::Parallelogram { origin, .. } => origin,
        Patch::Triangle([a, _, _]) => a,
    };
    let (n, o) = (p.normal(), first(p));
    // The corners without allocating (this runs for every pair of
    // surfaces linking visits).
    let corners = match *q {
        Patch::Parallelogram {
            origin,
            edge_s,
            edge_t,
        } => [
            origin,
            origin + edge_s,
            origin + edge_s + edge_t,
            origin + edge_t,
        ],
        Patch::Triangle([a, b, c]) => [a, b, c, c],
    };
    corners.iter().fold((false, false), |(front, back), v| {
        let (h, tolerance) = (n.dot(*v - o), contact.max(1e-12 * (1.0 + v.length())));
        (front || h > tolerance, back || h < -tolerance)
    })
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
    KernelContext::new(scene, tracer, Quadrature::default())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn faces_pressed_together_exchange_nothing_and_a_gap_does() {
        use crate::geometry::tracing::SceneTracer;
        use crate::testing::{grey, inward_box};
        // A unit cube's base (facing down) at height `lift` over a 2×2
        // floor (facing up).
        let exchange = |lift: f64| {
            let floor = Patch::Parallelogram {
                origin: DVec3::ZERO,
                edge_s: DVec3::X * 2.0,
                edge_t: DVec3::Y * 2.0,
            };
            let cube = inward_box(DVec3::new(0.5, 0.5, lift), DVec3::new(1.5, 1.5, 1.0 + lift));
            let base = cube[0].flipped();
            let scene = Scene::from_surfaces(vec![grey(floor), grey(base)]);
            let tracer = SceneTracer::new(&scene);
            let ctx = default_context(&scene, &tracer);
            assert_eq!(faces_away(&floor, &base), lift == 0.0);
            !ctx.exchange_nothing(&floor, &base)
        };
        assert!(!exchange(0.0));
        assert!(!exchange(1e-8));
        assert!(exchange(1e-4));
    }

    /// Levels count on the largest surface: a surface a quarter of its
    /// area stops one level sooner, one a fifth of it too (its elements at
    /// that level are already smaller than the largest's finest), and one
    /// smaller than the largest's finest elements is never split.
    #[test]
    fn a_surface_stops_where_its_elements_are_as_small_as_the_largest_ones() {
        use crate::geometry::tracing::SceneTracer;
        use crate::testing::grey;
        let square = |side: f64| {
            grey(Patch::Parallelogram {
                origin: DVec3::ZERO,
                edge_s: DVec3::X * side,
                edge_t: DVec3::Y * side,
            })
        };
        let sides = [4.0, 2.0, 4.0 / 5f64.sqrt(), 1.0, 0.25, 4.0 / 32.0, 0.01];
        let scene = Scene::from_surfaces(sides.map(square).to_vec());
        let tracer = SceneTracer::new(&scene);
        let ctx = default_context(&scene, &tracer);
        let levels: Vec<u32> = (0..sides.len() as u32)
            .map(|s| ctx.deepest_level(s, 5))
            .collect();
        // Area 16 → 1/1024 of it is 1/64, side 1/8: the 0.125 square is
        // exactly one finest element and stays whole.
        assert_eq!(levels, [5, 4, 4, 3, 1, 0, 0]);
        assert_eq!(ctx.deepest_level(0, 0), 0);
        assert_eq!(ctx.deepest_level(3, 2), 0);
    }

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
}
