//! Closed-form point-to-polygon form factor (Lambert 1760; Baum, Rushmeier &
//! Winget 1989): the inner integral of the two-point kernel, exact for an
//! unoccluded polygon, which keeps adjacent surfaces (a shared edge, where the
//! kernel is singular) accurate.

use glam::DVec3;

/// Clip `polygon` to the half-space `normal·(p − origin) ≥ 0`
/// (Sutherland–Hodgman), writing into `out`.
fn clip_to_half_space(polygon: &[DVec3], origin: DVec3, normal: DVec3, out: &mut Vec<DVec3>) {
    out.clear();
    let n = polygon.len();
    for i in 0..n {
        let (p, q) = (polygon[i], polygon[(i + 1) % n]);
        let (dp, dq) = (normal.dot(p - origin), normal.dot(q - origin));
        if dp >= 0.0 {
            out.push(p);
        }
        if (dp >= 0.0) != (dq >= 0.0) {
            let t = dp / (dp - dq);
            out.push(p + t * (q - p));
        }
    }
}

/// The part of `polygon` in front of the plane through `x` with normal
/// `n_x` (what a point at `x` can see of it), as a polygon; fewer than three
/// vertices when nothing is in front.
pub fn front_part(polygon: &[DVec3], x: DVec3, n_x: DVec3) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(polygon.len() + 2);
    clip_to_half_space(polygon, x, n_x, &mut out);
    out
}

/// Form factor from a differential area at `x` with unit normal `n_x` to the
/// planar polygon `polygon` (vertices in order, front side given by
/// `n_polygon`): ∫ cosθ_x cosθ_y / (π r²) dA_y, without occlusion.
///
/// Zero when `x` is behind the polygon (one-sided). The part of the polygon
/// below `x`'s tangent plane is clipped away.
pub fn point_to_polygon(x: DVec3, n_x: DVec3, polygon: &[DVec3], n_polygon: DVec3) -> f64 {
    if n_polygon.dot(x - polygon[0]) <= 0.0 {
        return 0.0;
    }
    let clipped = front_part(polygon, x, n_x);
    if clipped.len() < 3 {
        return 0.0;
    }
    // Σ over edges of (angle subtended) × (unit normal of the edge's plane)·n_x.
    let mut sum = 0.0;
    let m = clipped.len();
    for i in 0..m {
        let r0 = clipped[i] - x;
        let r1 = clipped[(i + 1) % m] - x;
        let c = r0.cross(r1);
        let len = c.length();
        if len <= 1e-300 {
            continue;
        }
        let angle = len.atan2(r0.dot(r1));
        sum += angle * c.dot(n_x) / len;
    }
    (sum / (2.0 * std::f64::consts::PI)).abs()
}

/// The relative gradient g of a quantity sampled as `values` at `points` of
/// a plane with normal `n`: F(x) ≈ F̄·(1 + g·(x − x̄)), fitted by least
/// squares (x̄ the points' mean, F̄ the values'). Zero when F̄ is, or when the
/// points do not span the plane (fewer than three).
pub fn relative_gradient(points: &[DVec3], values: &[f64], n: DVec3) -> DVec3 {
    let count = points.len() as f64;
    let mean = values.iter().sum::<f64>() / count;
    if points.len() < 3 || mean <= 0.0 {
        return DVec3::ZERO;
    }
    let centre = points.iter().copied().sum::<DVec3>() / count;
    // Normal equations (Σ d dᵀ) g = Σ d (F − F̄) in the plane; n nᵀ, scaled
    // to the points' spread, makes the matrix invertible without giving g
    // a normal component.
    let spread = points
        .iter()
        .map(|&x| (x - centre).length_squared())
        .sum::<f64>();
    let mut m = glam::DMat3::from_cols(n * n.x, n * n.y, n * n.z) * spread;
    let mut b = DVec3::ZERO;
    for (&x, f) in points.iter().zip(values) {
        let d = x - centre;
        m += glam::DMat3::from_cols(d * d.x, d * d.y, d * d.z);
        b += d * (f - mean);
    }
    if m.determinant().abs() <= 1e-9 * spread.powi(3) {
        return DVec3::ZERO;
    }
    m.inverse() * b / mean
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_square_at(z: f64) -> [DVec3; 4] {
        [
            DVec3::new(0.0, 0.0, z),
            DVec3::new(1.0, 0.0, z),
            DVec3::new(1.0, 1.0, z),
            DVec3::new(0.0, 1.0, z),
        ]
    }

    #[test]
    fn disk_like_limit_for_a_huge_polygon_is_one() {
        let big = [
            DVec3::new(-1e4, -1e4, 1.0),
            DVec3::new(-1e4, 1e4, 1.0),
            DVec3::new(1e4, 1e4, 1.0),
            DVec3::new(1e4, -1e4, 1.0),
        ];
        let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &big, -DVec3::Z);
        assert!((f - 1.0).abs() < 1e-3, "{f}");
    }

    #[test]
    fn corner_of_parallel_square_matches_closed_form() {
        // Differential area below a corner of a parallel 1×1 rectangle at
        // distance 1 (Howell's catalogue, B-3):
        // F = 1/(2π)[A/√(1+A²) atan(B/√(1+A²)) + B/√(1+B²) atan(A/√(1+B²))], A=B=1.
        let a: f64 = 1.0;
        let s = (1.0 + a * a).sqrt();
        let expect = (2.0 * a / s * (a / s).atan()) / (2.0 * std::f64::consts::PI);
        let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &unit_square_at(1.0), -DVec3::Z);
        assert!((f - expect).abs() < 1e-12, "{f} vs {expect}");
    }

    #[test]
    fn polygon_behind_or_below_gives_zero() {
        // Behind: the polygon faces away.
        let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &unit_square_at(1.0), DVec3::Z);
        assert_eq!(f, 0.0);
        // Below the tangent plane.
        let f = point_to_polygon(
            DVec3::new(0.5, 0.5, 2.0),
            DVec3::Z,
            &unit_square_at(1.0),
            DVec3::Z,
        );
        assert_eq!(f, 0.0);
    }

    #[test]
    fn relative_gradient_of_lambert_is_the_derivative_of_the_form_factor() {
        // A 0.1-wide receiver on z = 0 under the unit square at z = 1, off to
        // one side: the fitted gradient matches the central difference of
        // Lambert's formula at its centre, and vanishes where symmetry does.
        let square = unit_square_at(1.0);
        let f = |x: DVec3| point_to_polygon(x, DVec3::Z, &square, -DVec3::Z);
        let quadrants = |c: DVec3| {
            [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
                .map(|(i, j)| c + 0.025 * DVec3::new(i, j, 0.0))
        };
        let gradient = |points: [DVec3; 4], n_square: DVec3| {
            let values = points.map(|x| point_to_polygon(x, DVec3::Z, &square, n_square));
            relative_gradient(&points, &values, DVec3::Z)
        };
        let c = DVec3::new(1.3, 0.5, 0.0);
        let g = gradient(quadrants(c), -DVec3::Z);
        let h = 1e-4;
        let dx = (f(c + h * DVec3::X) - f(c - h * DVec3::X)) / (2.0 * h) / f(c);
        assert!(dx < -0.5, "{dx}");
        assert!((g.x - dx).abs() < 0.02 * dx.abs(), "{g} vs {dx}");
        assert!(g.y.abs() < 1e-9 && g.z.abs() < 1e-12, "{g}");
        let centre = DVec3::new(0.5, 0.5, 0.0);
        let g = gradient(quadrants(centre), -DVec3::Z);
        assert!(g.length() < 1e-9, "{g}");
        // Nothing in front: no gradient; nor from two points.
        assert_eq!(gradient(quadrants(c), DVec3::Z), DVec3::ZERO);
        let two = relative_gradient(&quadrants(c)[..2], &[1.0, 2.0], DVec3::Z);
        assert_eq!(two, DVec3::ZERO);
    }
}
