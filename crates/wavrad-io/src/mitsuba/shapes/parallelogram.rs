//! `rectangle` and `cube`: Mitsuba's, as exact parallelograms.
//!
//! `rectangle` is [-1,1]² at z = 0 with normal +z, uv (0,0) at (-1,-1) and
//! (1,0) at (1,-1); `cube` is [-1,1]³ as six outward-facing parallelograms,
//! each with Mitsuba 3's texture coordinates.
//! Both stay [`Patch::Parallelogram`]s under `to_world` (an affine map keeps
//! parallelograms). Neither has parameters of its own.

use glam::{DVec3, Vec2};
use wavrad_core::scene::Patch;

/// Texture coordinates of [`rectangle`] at its parameters (0,0), (1,0),
/// (0,1): Mitsuba 3's `(x + 1) / 2, (y + 1) / 2`.
pub(super) const RECTANGLE_UV: [Vec2; 3] = [Vec2::ZERO, Vec2::X, Vec2::Y];

/// Texture coordinates of each face of [`cube`] at its parameters (0,0),
/// (1,0), (0,1), probed with rays in Mitsuba 3.9.1 (its cube is a mesh
/// with texture coordinates per face).
pub(super) const CUBE_UV: [[Vec2; 3]; 6] = {
    const A: [Vec2; 3] = [Vec2::Y, Vec2::ONE, Vec2::ZERO];
    [A, A, A, A, A, [Vec2::X, Vec2::ZERO, Vec2::ONE]]
};

/// Mitsuba's rectangle: [-1,1]² at z = 0, normal +z.
pub(super) fn rectangle() -> Patch {
    Patch::Parallelogram {
        origin: DVec3::new(-1.0, -1.0, 0.0),
        edge_s: DVec3::new(2.0, 0.0, 0.0),
        edge_t: DVec3::new(0.0, 2.0, 0.0),
    }
}

/// Mitsuba's cube: [-1,1]³, faces +x, −x, +y, −y, +z, −z facing outwards.
pub(super) fn cube() -> [Patch; 6] {
    let face = |origin: [f64; 3], s: [f64; 3], t: [f64; 3]| Patch::Parallelogram {
        origin: DVec3::from(origin),
        edge_s: DVec3::from(s),
        edge_t: DVec3::from(t),
    };
    // Edge s runs along Mitsuba 3's dp/du of each face (probed with rays:
    // ±y on the ±x and ±z faces, −x on +y, +z on −y), so anisotropic BRDFs
    // get the same tangent frame.
    [
        face([1.0, -1.0, -1.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]),
        face([-1.0, -1.0, 1.0], [0.0, 2.0, 0.0], [0.0, 0.0, -2.0]),
        face([1.0, 1.0, -1.0], [-2.0, 0.0, 0.0], [0.0, 0.0, 2.0]),
        face([1.0, -1.0, -1.0], [0.0, 0.0, 2.0], [-2.0, 0.0, 0.0]),
        face([1.0, -1.0, 1.0], [0.0, 2.0, 0.0], [-2.0, 0.0, 0.0]),
        face([-1.0, -1.0, -1.0], [0.0, 2.0, 0.0], [2.0, 0.0, 0.0]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rectangle_is_mitsubas() {
        let r = rectangle();
        assert_eq!(r.area(), 4.0);
        assert_eq!(r.normal(), DVec3::Z);
        assert_eq!(r.vertices()[0], DVec3::new(-1.0, -1.0, 0.0));
        assert_eq!(r.vertices()[1], DVec3::new(1.0, -1.0, 0.0));
    }

    #[test]
    fn cube_faces_point_outwards() {
        let expected = [
            DVec3::X,
            -DVec3::X,
            DVec3::Y,
            -DVec3::Y,
            DVec3::Z,
            -DVec3::Z,
        ];
        for (face, n) in cube().iter().zip(expected) {
            assert_eq!(face.area(), 4.0);
            assert_eq!(face.normal(), n);
            let centre = face.vertices().iter().sum::<DVec3>() / 4.0;
            assert_eq!(centre, n, "face centred on its side");
        }
    }

    #[test]
    fn cube_tangents_follow_mitsubas_dp_du() {
        let axes = [DVec3::Y, DVec3::Y, DVec3::X, DVec3::Z, DVec3::Y, DVec3::Y];
        for (face, axis) in cube().iter().zip(axes) {
            assert_eq!(face.tangent().dot(axis).abs(), 1.0, "{face:?}");
        }
    }
}
