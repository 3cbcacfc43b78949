//! `cylinder`: Mitsuba's open cylinder (no end caps), normals outwards.
//!
//! | parameter | type      | default   |
//! |-----------|-----------|-----------|
//! | `p0`      | `<point>` | (0, 0, 0) |
//! | `p1`      | `<point>` | (0, 0, 1) |
//! | `radius`  | `<float>` | 1         |
//!
//! ```xml
//! <shape type="cylinder">
//!     <point name="p0" x="0" y="-1" z="0"/>
//!     <point name="p1" x="0" y="1" z="0"/>
//!     <float name="radius" value="0.2"/>
//! </shape>
//! ```
//!
//! As in Mitsuba, the unit cylinder (radius 1 around z from z = 0 to 1) is
//! placed by `to_world · translate(p0) · frame(p1 − p0) · scale(radius,
//! radius, |p1 − p0|)`, the frame being Mitsuba's `coordinate_system` of the
//! axis (Duff et al. 2017, glam's `any_orthonormal_pair`). Tessellated
//! ([`super::tessellation`]) as [`SEGMENTS`] rectangles along the axis,
//! their first edge around it like Mitsuba's dp/du.

use std::f64::consts::PI;

use glam::{DMat4, DVec3, DVec4, Vec2};
use wavrad_core::scene::Patch;

use super::tessellation::{around, u_of, with_uv, SEGMENTS};
use super::Local;

/// The unit cylinder as [`SEGMENTS`] rectangles facing outwards, at the
/// radius that makes the total area 2π.
pub(super) fn unit_cylinder() -> Vec<Patch> {
    let n = SEGMENTS as f64;
    let radius = PI / (n * (PI / n).sin());
    (0..SEGMENTS)
        .map(|j| Patch::Parallelogram {
            origin: radius * around(j),
            edge_s: radius * (around(j + 1) - around(j)),
            edge_t: DVec3::Z,
        })
        .collect()
}

/// [`unit_cylinder`] with Mitsuba's texture coordinates: (φ/2π, z).
pub(super) fn textured_unit_cylinder() -> Vec<Local> {
    with_uv(unit_cylinder(), |p, phi| Vec2::new(u_of(phi), p.z as f32))
}

/// Mitsuba's placement of the unit cylinder between `p0` and `p1`; `None`
/// when they coincide (or are too far apart for `f64`).
pub(super) fn local_from_cylinder(p0: DVec3, p1: DVec3, radius: f64) -> Option<DMat4> {
    let axis = p1 - p0;
    let length = axis.length();
    if length == 0.0 || !length.is_finite() {
        return None;
    }
    let (s, t) = (axis / length).any_orthonormal_pair();
    Some(DMat4::from_cols(
        (radius * s).extend(0.0),
        (radius * t).extend(0.0),
        axis.extend(0.0),
        DVec4::from((p0, 1.0)),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn area_is_exact_and_normals_point_away_from_the_axis() {
        let cylinder = unit_cylinder();
        let area: f64 = cylinder.iter().map(Patch::area).sum();
        assert!((area - 2.0 * PI).abs() < 1e-12, "{area}");
        for p in &cylinder {
            let centre = p.vertices().iter().sum::<DVec3>() / 4.0;
            let outward = (centre * DVec3::new(1.0, 1.0, 0.0)).normalize();
            // Within half an arc (7.5°) of the true normal, and exact at
            // the rectangle's middle.
            assert!((p.normal() - outward).length() < 1e-12, "{p:?}");
            assert!(p.tangent().dot(DVec3::Z).abs() < 1e-12, "dp/du goes around");
            for v in p.vertices() {
                assert!((v.truncate().length() - 1.0).abs() < 0.006);
            }
            assert!((centre.truncate().length() - 1.0).abs() < 0.006);
        }
    }

    #[test]
    fn placement_follows_p0_p1_and_radius() {
        let (p0, p1) = (DVec3::new(1.0, 2.0, 3.0), DVec3::new(1.0, -2.0, 3.0));
        let m = local_from_cylinder(p0, p1, 0.5).unwrap();
        assert!(m.determinant() > 0.0, "outward stays outward");
        assert_eq!(m.transform_point3(DVec3::ZERO), p0);
        assert!((m.transform_point3(DVec3::Z) - p1).length() < 1e-15);
        for p in unit_cylinder() {
            let p = p.transformed(&m);
            let v = p.vertices()[0];
            let off_axis = (v - p0) - (v - p0).dot(-DVec3::Y) * -DVec3::Y;
            assert!((off_axis.length() / 0.5 - 1.0).abs() < 0.006);
            assert!(p.normal().dot(off_axis) > 0.0, "outwards");
        }
        assert_eq!(local_from_cylinder(p0, p0, 1.0), None);
    }
}
