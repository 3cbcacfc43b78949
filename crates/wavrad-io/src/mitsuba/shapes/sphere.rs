//! `sphere`: Mitsuba's sphere, normals outwards.
//!
//! | parameter | type      | default   |
//! |-----------|-----------|-----------|
//! | `center`  | `<point>` | (0, 0, 0) |
//! | `radius`  | `<float>` | 1         |
//!
//! ```xml
//! <shape type="sphere">
//!     <point name="center" x="0" y="0.5" z="0"/>
//!     <float name="radius" value="0.3"/>
//!     <emitter type="area"><rgb name="radiance" value="5"/></emitter>
//! </shape>
//! ```
//!
//! As in Mitsuba, `to_world · translate(center) · scale(radius)` places the
//! unit sphere, and the sphere is then centred where that puts the origin,
//! with the radius it gives the point (1, 0, 0): it stays a sphere under a
//! shear or a non-uniform scale (Mitsuba warns, and so does wavrad). A
//! mirroring transform, or a negative radius, turns it inside out (Mitsuba
//! flips its normals when the transform's polar decomposition has a negative
//! scale).
//!
//! Tessellated ([`super::tessellation`]) as a UV sphere: [`SEGMENTS`] arcs
//! around the pole axis (local z) and [`RINGS`] from pole to pole, 528
//! triangles, each with its first edge along a parallel like Mitsuba's dp/du.

use std::f64::consts::PI;

use glam::{DMat4, DVec3, Vec2};
use wavrad_core::scene::Patch;

use super::tessellation::{around, polar_v, u_of, with_uv, SEGMENTS};
use super::Local;

/// Arcs from pole to pole.
const RINGS: usize = SEGMENTS / 2;

/// Similarity tolerance: relative to the radius, what a transform written
/// with single-precision digits may differ from an exact one.
const SIMILARITY_TOLERANCE: f64 = 1e-5;

/// The unit sphere as a UV sphere facing outwards, its vertices at the
/// radius that makes the total area 4π.
pub(super) fn unit_sphere() -> Vec<Patch> {
    // Vertex of ring i (polar angle πi/RINGS) at arc j.
    let vertex = |i: usize, j: usize| match i {
        0 => DVec3::Z,
        _ if i == RINGS => -DVec3::Z,
        _ => {
            let (sin, cos) = (PI * i as f64 / RINGS as f64).sin_cos();
            sin * around(j) + DVec3::new(0.0, 0.0, cos)
        }
    };
    // Each triangle's first edge runs along a parallel, and its third vertex
    // lies towards the pole the first edge turns counter-clockwise around.
    let mut triangles = Vec::with_capacity(2 * SEGMENTS * (RINGS - 1));
    for j in 0..SEGMENTS {
        triangles.push([vertex(1, j), vertex(1, j + 1), vertex(0, j)]);
        for i in 1..RINGS - 1 {
            triangles.push([vertex(i + 1, j), vertex(i + 1, j + 1), vertex(i, j + 1)]);
            triangles.push([vertex(i, j + 1), vertex(i, j), vertex(i + 1, j)]);
        }
        triangles.push([
            vertex(RINGS - 1, j + 1),
            vertex(RINGS - 1, j),
            vertex(RINGS, j),
        ]);
    }
    let area: f64 = triangles.iter().map(|t| Patch::Triangle(*t).area()).sum();
    let scale = (4.0 * PI / area).sqrt();
    triangles
        .into_iter()
        .map(|t| Patch::Triangle(t.map(|v| scale * v)))
        .collect()
}

/// [`unit_sphere`] with Mitsuba's texture coordinates: (φ/2π, θ/π), θ the
/// polar angle from +z.
pub(super) fn textured_unit_sphere() -> Vec<Local> {
    with_uv(unit_sphere(), |p, phi| Vec2::new(u_of(phi), polar_v(p)))
}

/// Where Mitsuba's sphere is: the unit sphere's transform (`to_world ·
/// translate(center) · scale(radius)`) with its linear part replaced by the
/// similarity of the same radius, orientation and handedness (Gram–Schmidt
/// on its columns).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Placement {
    /// Maps the unit sphere onto the sphere.
    pub world_from_sphere: DMat4,
    /// The given transform was not a similarity and was replaced.
    pub replaced: bool,
}

impl Placement {
    /// The sphere `world_from_unit` makes of the unit sphere; `None` when
    /// that transform is singular.
    pub fn new(world_from_unit: &DMat4) -> Option<Placement> {
        let m = world_from_unit;
        let [a, b, c] = [m.x_axis, m.y_axis, m.z_axis].map(|v| v.truncate());
        let r = a.length();
        let x = a.normalize_or_zero();
        let y = (b - b.dot(x) * x).normalize_or_zero();
        let z = (c - c.dot(x) * x - c.dot(y) * y).normalize_or_zero();
        if [x, y, z].contains(&DVec3::ZERO) {
            return None;
        }
        let tolerance = SIMILARITY_TOLERANCE * r;
        let replaced = (b.length() - r).abs() > tolerance
            || (c.length() - r).abs() > tolerance
            || [a.dot(b), a.dot(c), b.dot(c)]
                .iter()
                .any(|d| d.abs() > tolerance * r);
        Some(Placement {
            world_from_sphere: DMat4::from_cols(
                (r * x).extend(0.0),
                (r * y).extend(0.0),
                (r * z).extend(0.0),
                m.w_axis,
            ),
            replaced,
        })
    }

    /// `to_world · translate(center) · scale(radius)`, Mitsuba's transform
    /// of the unit sphere.
    pub fn world_from_unit(world_from_local: &DMat4, center: DVec3, radius: f64) -> DMat4 {
        *world_from_local
            * DMat4::from_translation(center)
            * DMat4::from_scale(DVec3::splat(radius))
    }

    /// The sphere's radius in world space.
    pub fn radius(&self) -> f64 {
        self.world_from_sphere.x_axis.truncate().length()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn centroid(p: &Patch) -> DVec3 {
        p.vertices().iter().sum::<DVec3>() / 3.0
    }

    #[test]
    fn area_is_exact_and_normals_point_outwards_within_the_bound() {
        let sphere = unit_sphere();
        assert_eq!(sphere.len(), 528);
        let area: f64 = sphere.iter().map(Patch::area).sum();
        assert!((area - 4.0 * PI).abs() < 1e-12, "{area}");
        let mut worst = 0.0f64;
        for t in &sphere {
            let v = t.vertices();
            let edges = [0, 1, 2].map(|k| (v[k] + v[(k + 1) % 3]) / 2.0);
            for p in v.iter().chain(&edges).chain([&centroid(t)]) {
                worst = worst.max(t.normal().angle_between(*p).to_degrees());
                // Vertices 0.72 % outside, faces at most 1 % inside.
                assert!((p.length() - 1.0).abs() < 0.01, "{p}");
            }
        }
        assert!(worst < 10.6, "normals within 10.6°: {worst}°");
        assert!(worst > 7.5, "the bound is tight: {worst}°");
    }

    #[test]
    fn first_edges_run_along_parallels() {
        for t in unit_sphere() {
            let [a, b, _] = t.vertices()[..] else {
                unreachable!()
            };
            assert!((a.z - b.z).abs() < 1e-15, "{t:?}");
            let east = DVec3::Z.cross(centroid(&t)).normalize();
            assert!(t.tangent().dot(east).abs() > 0.99, "{t:?}");
        }
    }

    #[test]
    fn a_similarity_is_kept_and_anything_else_becomes_mitsubas_sphere() {
        let m = DMat4::from_rotation_x(0.3) * DMat4::from_scale(DVec3::splat(2.0));
        let p = Placement::new(&Placement::world_from_unit(&m, DVec3::X, 0.5)).unwrap();
        assert!(!p.replaced);
        assert!((p.radius() - 1.0).abs() < 1e-15);
        let expected = m * DMat4::from_translation(DVec3::X) * DMat4::from_scale(DVec3::splat(0.5));
        assert!(p.world_from_sphere.abs_diff_eq(expected, 1e-15));

        let squash = DMat4::from_scale(DVec3::new(2.0, 1.0, 0.5));
        let p = Placement::new(&squash).unwrap();
        assert!(p.replaced);
        assert!((p.radius() - 2.0).abs() < 1e-15, "radius from the x axis");
        assert!(p
            .world_from_sphere
            .abs_diff_eq(DMat4::from_scale(DVec3::splat(2.0)), 1e-15));

        let flat = DMat4::from_scale(DVec3::new(1.0, 1.0, 0.0));
        assert_eq!(Placement::new(&flat), None);
        assert_eq!(Placement::new(&DMat4::ZERO), None);
    }

    #[test]
    fn mirroring_or_a_negative_radius_turns_it_inside_out() {
        let mirror = DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0));
        for (m, radius) in [(mirror, 1.0), (DMat4::IDENTITY, -1.0)] {
            let p = Placement::new(&Placement::world_from_unit(&m, DVec3::ZERO, radius)).unwrap();
            assert!(!p.replaced);
            for t in unit_sphere() {
                let t = t.transformed(&p.world_from_sphere);
                assert!(t.normal().dot(centroid(&t)) < 0.0, "inwards");
            }
        }
    }
}
