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

use glam::DVec3;
use wavrad_core::scene::Patch;

use super::tessellation::{around, SEGMENTS};

/// The unit disk as [`SEGMENTS`] triangles around its centre, facing +z,
/// their rim at the radius that makes the total area π.
pub(super) fn unit_disk() -> Vec<Patch> {
    let n = SEGMENTS as f64;
    let rim = (2.0 * PI / (n * (2.0 * PI / n).sin())).sqrt();
    (0..SEGMENTS)
        .map(|j| Patch::Triangle([DVec3::ZERO, rim * around(j), rim * around(j + 1)]))
        .collect()
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
