//! The rule by which curved shapes (`disk`, `cylinder`, `sphere`) become
//! planar patches for the solve.
//!
//! Every circle around a shape's axis is cut into [`SEGMENTS`] equal arcs
//! (15°), and a sphere's meridians into half as many, so the tessellation's
//! relative error is the same at any size: a patch's normal is within half
//! an arc's angle of the true normal along a circle (7.5°; 10.6° at worst on
//! the sphere, across a triangle's diagonal). Vertices are not on the exact
//! surface but on one scaled radially so that the patches' total area is the
//! shape's exact area (for the disk, cylinder and sphere alike): an emitter
//! then sends Mitsuba's power, and the mean projected area, which is a
//! quarter of the area for a convex body (Cauchy), is the shape's, so an
//! occluder casts as much shadow on average. The patches then lie within
//! 0.6 % of the radius of the exact disk and cylinder, and within 1 % of the
//! exact sphere (each shape's tests check its bound).

use glam::DVec3;

/// Arcs per full circle around a shape's axis.
pub(super) const SEGMENTS: usize = 24;

/// The unit vector at angle 2π·j/[`SEGMENTS`] in the xy plane, j taken
/// modulo [`SEGMENTS`] so that a closed loop ends exactly where it began.
pub(super) fn around(j: usize) -> DVec3 {
    let phi = std::f64::consts::TAU * (j % SEGMENTS) as f64 / SEGMENTS as f64;
    DVec3::new(phi.cos(), phi.sin(), 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_loop_closes_exactly() {
        assert_eq!(around(SEGMENTS), around(0));
        assert_eq!(around(0), DVec3::X);
        assert!((around(SEGMENTS / 4) - DVec3::Y).length() < 1e-15);
    }
}
