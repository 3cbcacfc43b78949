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

//!
//! Each patch carries Mitsuba's texture coordinates at its parameter points
//! ([`with_uv`]), so that textures map onto the tessellated shape as onto
//! the exact one, up to the tessellation: the coordinates are exact at the
//! patch's corners (the azimuth continued across the seam at 2π, and taken
//! at the patch's middle where the corner is on the axis) and affine in
//! between. The sphere's and cylinder's patches carry the exact shape's
//! radial normals at their parameter points as shading normals
//! ([`wavrad_core::scene::Surface::shading`]), so that a render shades them
//! round; the disk is flat and needs none. Camera rays see the exact shape
//! instead: each curved shape is also kept as it is, with the range of its
//! surfaces ([`wavrad_core::scene::analytic`]), and a render shows its
//! outline and normals, the solution and texture read on the patch under
//! each point.

use std::f64::consts::{PI, TAU};

use glam::{DVec3, Vec2};
use wavrad_core::scene::Patch;

use super::Local;

/// Arcs per full circle around a shape's axis.
pub(super) const SEGMENTS: usize = 24;

/// The unit vector at angle 2π·j/[`SEGMENTS`] in the xy plane, j taken
/// modulo [`SEGMENTS`] so that a closed loop ends exactly where it began.
pub(super) fn around(j: usize) -> DVec3 {
    let phi = std::f64::consts::TAU * (j % SEGMENTS) as f64 / SEGMENTS as f64;
    DVec3::new(phi.cos(), phi.sin(), 0.0)
}

/// The points of `patch` at its parameters (0,0), (1,0) and (0,1).
pub(super) fn parameter_points(patch: &Patch) -> [DVec3; 3] {
    match *patch {
        Patch::Parallelogram {
            origin,
            edge_s,
            edge_t,
        } => [origin, origin + edge_s, origin + edge_t],
        Patch::Triangle(v) => v,
    }
}

/// `patches` (of a unit shape around the z axis) with texture coordinates
/// `uv(p, phi)` at their parameter points p, phi being p's azimuth in
/// radians, continued from the patch's middle (so that a patch across the
/// seam at 0 = 2π has coordinates on both sides of 1, as its texture lookups
/// need) and the middle's where p is on the axis.
pub(super) fn with_uv(patches: Vec<Patch>, uv: impl Fn(DVec3, f64) -> Vec2) -> Vec<Local> {
    let azimuth = |p: DVec3| p.y.atan2(p.x).rem_euclid(TAU);
    patches
        .into_iter()
        .map(|patch| {
            let vertices = patch.vertices();
            let middle = vertices.iter().sum::<DVec3>() / vertices.len() as f64;
            let phi_middle = azimuth(middle);
            let coordinates = parameter_points(&patch).map(|p| {
                let phi = if p.truncate().length() < 1e-12 {
                    phi_middle
                } else {
                    let phi = azimuth(p);
                    phi + TAU * ((phi_middle - phi) / TAU).round()
                };
                uv(p, phi)
            });
            (patch, coordinates)
        })
        .collect()
}

/// Mitsuba's u around the axis: the azimuth over 2π.
pub(super) fn u_of(phi: f64) -> f32 {
    (phi / TAU) as f32
}

/// Mitsuba's sphere v: the polar angle from +z over π.
pub(super) fn polar_v(p: DVec3) -> f32 {
    ((p.z / p.length()).clamp(-1.0, 1.0).acos() / PI) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coordinates_continue_across_the_seam_and_take_the_middle_on_the_axis() {
        let seam = Patch::Triangle([DVec3::ZERO, around(SEGMENTS - 1), around(SEGMENTS)]);
        let [(_, uv)] = with_uv(vec![seam], |_, phi| Vec2::new(u_of(phi), 0.0))[..] else {
            panic!()
        };
        let [centre, a, b] = uv.map(|c| c.x);
        let n = SEGMENTS as f32;
        assert!((a - (n - 1.0) / n).abs() < 1e-6, "{a}");
        assert!((b - 1.0).abs() < 1e-6, "{b}: past the seam, not 0");
        assert!((centre - (n - 0.5) / n).abs() < 1e-3, "{centre}");
    }

    #[test]
    fn a_loop_closes_exactly() {
        assert_eq!(around(SEGMENTS), around(0));
        assert_eq!(around(0), DVec3::X);
        assert!((around(SEGMENTS / 4) - DVec3::Y).length() < 1e-15);
    }
}
