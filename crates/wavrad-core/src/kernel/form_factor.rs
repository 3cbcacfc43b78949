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
}
