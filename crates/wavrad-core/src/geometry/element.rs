//! Elements: the dyadic pieces of a surface's parameter domain (paper §4.2,
//! "the increment in the resolution of the wavelet basis means the regular
//! subdivision of the surface in the parametric domain").
//!
//! A parallelogram splits into four parallelograms by halving (s,t); a
//! triangle splits into four by its edge midpoints. Both give children of a
//! quarter of the parent's area, so the Haar scaling function of an element is
//! a box over it and its coefficient is 2^{-J}·(element average) (see
//! [`crate::geometry::haar`]).

use crate::scene::Patch;
use glam::{DVec2, DVec3};

/// Gauss–Legendre nodes and weights on [0,1] for orders 1 to 4.
fn gauss_legendre(n: usize) -> &'static [(f64, f64)] {
    const G1: [(f64, f64); 1] = [(0.5, 1.0)];
    const G2: [(f64, f64); 2] = [
        (0.211_324_865_405_187_1, 0.5),
        (0.788_675_134_594_812_9, 0.5),
    ];
    const G3: [(f64, f64); 3] = [
        (0.112_701_665_379_258_3, 5.0 / 18.0),
        (0.5, 8.0 / 18.0),
        (0.887_298_334_620_741_7, 5.0 / 18.0),
    ];
    const G4: [(f64, f64); 4] = [
        (0.069_431_844_202_973_7, 0.173_927_422_568_726_9),
        (0.330_009_478_207_571_9, 0.326_072_577_431_273_1),
        (0.669_990_521_792_428_1, 0.326_072_577_431_273_1),
        (0.930_568_155_797_026_3, 0.173_927_422_568_726_9),
    ];
    match n {
        0 | 1 => &G1,
        2 => &G2,
        3 => &G3,
        _ => &G4,
    }
}

/// A quadrature point on a patch: position and the area it stands for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AreaSample {
    /// Point on the patch.
    pub position: DVec3,
    /// Quadrature weight in area units (weights sum to the patch area).
    pub weight: f64,
}

impl Patch {
    /// Point at parameter `uv`: (s,t) ∈ \[0,1\]² for a parallelogram,
    /// barycentric (u,v) towards (v1,v2) with u+v ≤ 1 for a triangle.
    pub fn point_at(&self, uv: DVec2) -> DVec3 {
        match *self {
            Patch::Parallelogram {
                origin,
                edge_s,
                edge_t,
            } => origin + uv.x * edge_s + uv.y * edge_t,
            Patch::Triangle([a, b, c]) => a + uv.x * (b - a) + uv.y * (c - a),
        }
    }

    /// Parameter of the point `p` (assumed on the patch's plane); inverse of
    /// [`Patch::point_at`].
    pub fn param_of(&self, p: DVec3) -> DVec2 {
        let (o, e1, e2) = match *self {
            Patch::Parallelogram {
                origin,
                edge_s,
                edge_t,
            } => (origin, edge_s, edge_t),
            Patch::Triangle([a, b, c]) => (a, b - a, c - a),
        };
        let d = p - o;
        let (a11, a12, a22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (b1, b2) = (e1.dot(d), e2.dot(d));
        let det = a11 * a22 - a12 * a12;
        DVec2::new((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det)
    }

    /// The four children, each a quarter of the area, in the order that
    /// [`Patch::locate_child`] indexes.
    pub fn subdivide(&self) -> [Patch; 4] {
        match *self {
            Patch::Parallelogram {
                origin,
                edge_s,
                edge_t,
            } => {
                let (hs, ht) = (0.5 * edge_s, 0.5 * edge_t);
                let child = |i: f64, j: f64| Patch::Parallelogram {
                    origin: origin + i * hs + j * ht,
                    edge_s: hs,
                    edge_t: ht,
                };
                [
                    child(0.0, 0.0),
                    child(1.0, 0.0),
                    child(0.0, 1.0),
                    child(1.0, 1.0),
                ]
            }
            Patch::Triangle([a, b, c]) => {
                let (ab, bc, ca) = (0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a));
                [
                    Patch::Triangle([a, ab, ca]),
                    Patch::Triangle([ab, b, bc]),
                    Patch::Triangle([ca, bc, c]),
                    Patch::Triangle([bc, ca, ab]),
                ]
            }
        }
    }

    /// Which child of [`Patch::subdivide`] contains parameter `uv`, and the
    /// parameter of the same point in that child.
    pub fn locate_child(&self, uv: DVec2) -> (usize, DVec2) {
        match self {
            Patch::Parallelogram { .. } => {
                let i = usize::from(uv.x >= 0.5);
                let j = usize::from(uv.y >= 0.5);
                let local = DVec2::new(2.0 * uv.x - i as f64, 2.0 * uv.y - j as f64);
                (i + 2 * j, local)
            }
            Patch::Triangle(_) => {
                let (u, v) = (uv.x, uv.y);
                if u >= 0.5 {
                    (1, DVec2::new(2.0 * u - 1.0, 2.0 * v))
                } else if v >= 0.5 {
                    (2, DVec2::new(2.0 * u, 2.0 * v - 1.0))
                } else if u + v < 0.5 {
                    (0, DVec2::new(2.0 * u, 2.0 * v))
                } else {
                    (3, DVec2::new(1.0 - 2.0 * u, 1.0 - 2.0 * v))
                }
            }
        }
    }

    /// Whether parameter `uv` lies in the patch's domain (its point on the
    /// patch's plane is on the patch).
    pub fn contains_param(&self, uv: DVec2) -> bool {
        let inside = uv.min_element() >= 0.0;
        match self {
            Patch::Parallelogram { .. } => inside && uv.max_element() <= 1.0,
            Patch::Triangle(_) => inside && uv.x + uv.y <= 1.0,
        }
    }

    /// Clamp a parameter into the patch's domain.
    pub fn clamp_param(&self, uv: DVec2) -> DVec2 {
        let c = uv.clamp(DVec2::ZERO, DVec2::ONE);
        match self {
            Patch::Parallelogram { .. } => c,
            Patch::Triangle(_) => {
                let s = c.x + c.y;
                if s > 1.0 {
                    c / s
                } else {
                    c
                }
            }
        }
    }

    /// Map the unit square onto the parameter domain, uniformly by area
    /// (for a triangle the square's upper half folds back onto the lower,
    /// which keeps strata compact).
    pub fn square_to_param(&self, uv: DVec2) -> DVec2 {
        match self {
            Patch::Parallelogram { .. } => uv,
            Patch::Triangle(_) if uv.x + uv.y > 1.0 => DVec2::new(1.0 - uv.x, 1.0 - uv.y),
            Patch::Triangle(_) => uv,
        }
    }

    /// Centroid.
    pub fn centroid(&self) -> DVec3 {
        match self {
            Patch::Parallelogram { .. } => self.point_at(DVec2::splat(0.5)),
            Patch::Triangle([a, b, c]) => (*a + *b + *c) / 3.0,
        }
    }

    /// Product Gauss–Legendre rule of order `n` per axis (a collapsed
    /// "Duffy" square for triangles), weights summing to the area.
    pub fn gauss_points(&self, n: usize) -> Vec<AreaSample> {
        let rule = gauss_legendre(n);
        let area = self.area();
        let mut out = Vec::with_capacity(rule.len() * rule.len());
        for &(x, wx) in rule {
            for &(y, wy) in rule {
                out.push(match *self {
                    Patch::Parallelogram { .. } => AreaSample {
                        position: self.point_at(DVec2::new(x, y)),
                        weight: wx * wy * area,
                    },
                    // x runs from v0 to the edge v1v2, y along that edge.
                    Patch::Triangle([a, b, c]) => AreaSample {
                        position: a + x * (b - a) + x * y * (c - b),
                        weight: wx * wy * 2.0 * area * x,
                    },
                });
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Patch {
        Patch::Parallelogram {
            origin: DVec3::new(1.0, 2.0, 3.0),
            edge_s: DVec3::new(2.0, 0.0, 0.0),
            edge_t: DVec3::new(0.5, 1.0, 0.0),
        }
    }

    fn triangle() -> Patch {
        Patch::Triangle([
            DVec3::ZERO,
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.3, 1.5, 0.2),
        ])
    }

    #[test]
    fn children_quarter_the_area_and_keep_the_normal() {
        for p in [square(), triangle()] {
            for c in p.subdivide() {
                assert!((c.area() - p.area() / 4.0).abs() < 1e-12);
                assert!((c.normal() - p.normal()).length() < 1e-12);
            }
        }
    }

    #[test]
    fn locate_child_agrees_with_subdivide() {
        for p in [square(), triangle()] {
            let children = p.subdivide();
            for &(u, v) in &[(0.1, 0.2), (0.7, 0.1), (0.2, 0.6), (0.3, 0.4), (0.45, 0.45)] {
                let uv = DVec2::new(u, v);
                let (k, local) = p.locate_child(uv);
                let a = p.point_at(uv);
                let b = children[k].point_at(local);
                assert!((a - b).length() < 1e-12, "{p:?} {uv:?}");
                assert!((p.param_of(a) - uv).length() < 1e-12);
            }
        }
    }

    #[test]
    fn gauss_points_integrate_linear_functions_exactly() {
        for p in [square(), triangle()] {
            let pts = p.gauss_points(2);
            let w: f64 = pts.iter().map(|s| s.weight).sum();
            assert!((w - p.area()).abs() < 1e-12);
            let mean: DVec3 = pts.iter().map(|s| s.position * s.weight).sum::<DVec3>() / w;
            assert!((mean - p.centroid()).length() < 1e-12);
        }
    }
}
