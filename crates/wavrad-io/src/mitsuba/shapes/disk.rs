//! `disk`: Mitsuba's unit disk at z = 0 with normal +z, placed by
//! `to_world` (no parameters of its own).
//!
//! ```xml
//! <shape type="disk">
//!     <transform name="to_world">
//!         <scale value="0.3"/>
//!         <rotate x="1" angle="90"/>
//!     </transform>
//!     <emitter type="area"><rgb name="radiance" value="10"/></emitter>
//! </shape>
//! ```
//!
//! Tessellated ([`super::tessellation`]) as a fan of triangles around the
//! centre, their first edge radial like Mitsuba's dp/du.

use std::f64::consts::PI;

use glam::{DVec3, Vec2};
use wavrad_core::scene::Patch;

use super::tessellation::{around, u_of, with_uv, SEGMENTS};
use super::Local;

/// The radius of the tessellated disk's rim: that which makes its area π.
fn rim() -> f64 {
    let n = SEGMENTS as f64;
    (2.0 * PI / (n * (2.0 * PI / n).sin())).sqrt()
}

/// The unit disk as [`SEGMENTS`] triangles around its centre, facing +z,
/// their rim at the radius that makes the total area π.
pub(super) fn unit_disk() -> Vec<Patch> {
    let rim = rim();
    (0..SEGMENTS)
        .map(|j| Patch::Triangle([DVec3::ZERO, rim * around(j), rim * around(j + 1)]))
        .collect()
}

/// [`unit_disk`] with Mitsuba's texture coordinates: (r, φ/2π), the rim at
/// r = 1.
pub(super) fn textured_unit_disk() -> Vec<Local> {
    let rim = rim();
    with_uv(unit_disk(), |p, phi| {
        Vec2::new((p.truncate().length() / rim) as f32, u_of(phi))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn area_is_exact_and_every_triangle_faces_up() {
        let disk = unit_disk();
        let area: f64 = disk.iter().map(Patch::area).sum();
        assert!((area - PI).abs() < 1e-12, "{area}");
        for t in &disk {
            assert!((t.normal() - DVec3::Z).length() < 1e-12, "{t:?}");
        }
    }

    #[test]
    fn rim_stays_within_its_bound_and_tangents_are_radial() {
        for t in unit_disk() {
            let v = t.vertices();
            // Rim vertices outside, chord midpoints inside: both within 0.6 %.
            for p in [v[1], v[2], (v[1] + v[2]) / 2.0] {
                assert!((p.length() - 1.0).abs() < 0.006, "{p}");
            }
            assert!((t.tangent() - v[1].normalize()).length() < 1e-12);
        }
    }
}
