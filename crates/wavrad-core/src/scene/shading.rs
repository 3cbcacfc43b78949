//! Shading normals: the normals a curved shape or a smooth mesh has at the
//! points of its planar patches, interpolated as Mitsuba 3 interpolates a
//! mesh's vertex normals (its shading frame, `si.sh_frame`). The solve
//! never sees them; a render shades camera-ray hits and the points its
//! gathers reach with them, so that a tessellated sphere looks round.
//!
//! ```
//! use wavrad_core::scene::shading::ShadingNormals;
//! use glam::{DVec2, DVec3, Vec3};
//!
//! let normals = ShadingNormals([Vec3::Z, Vec3::X, Vec3::Y]);
//! let n = normals.at(DVec2::new(0.5, 0.0)).unwrap();
//! assert!((n - DVec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6);
//! ```

use crate::scene::texture::flipped_corners;
use crate::scene::Patch;
use glam::{DMat4, DVec2, DVec3, Vec3};

/// Unit shading normals at a patch's parameters (0,0), (1,0) and (0,1)
/// ([`Patch::point_at`]), pointing to its front side; in between they are
/// interpolated affinely and normalised.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShadingNormals(pub [Vec3; 3]);

impl ShadingNormals {
    /// The unit normals `normals` (any length; made unit), `None` when one
    /// of them has no direction or is not finite.
    pub fn new(normals: [DVec3; 3]) -> Option<ShadingNormals> {
        let unit = normals.map(DVec3::normalize_or_zero);
        (!unit.contains(&DVec3::ZERO)).then(|| ShadingNormals(unit.map(|n| n.as_vec3())))
    }

    /// The unit shading normal at patch parameter `param`; `None` where the
    /// interpolated normal vanishes (or is not finite).
    pub fn at(&self, param: DVec2) -> Option<DVec3> {
        let [a, b, c] = self.0.map(|n| n.as_dvec3());
        let n = a + param.x * (b - a) + param.y * (c - a);
        let n = n.normalize_or_zero();
        (n != DVec3::ZERO).then_some(n)
    }

    /// The normals of the same points on [`Patch::flipped`] of `patch`
    /// (moved to its parameters and reversed), as Mitsuba's `flip_normals`
    /// and `twosided` reverse the shading frame.
    pub fn flipped(&self, patch: &Patch) -> ShadingNormals {
        ShadingNormals(flipped_corners(self.0, patch).map(|n| -n))
    }

    /// The normals after the affine map `world_from_local` (as normals: by
    /// the inverse transpose of its linear part); `None` when it is
    /// singular.
    pub fn transformed(&self, world_from_local: &DMat4) -> Option<ShadingNormals> {
        let m = glam::DMat3::from_mat4(*world_from_local);
        let det = m.determinant();
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let normal_from_local = m.inverse().transpose();
        ShadingNormals::new(self.0.map(|n| normal_from_local * n.as_dvec3()))
    }

    /// The normals reversed if they point, together, away from
    /// `front`: so that they point to the side a patch faces.
    pub fn facing(&self, front: DVec3) -> ShadingNormals {
        let sum: DVec3 = self.0.iter().map(|n| n.as_dvec3()).sum();
        match sum.dot(front) < 0.0 {
            true => ShadingNormals(self.0.map(|n| -n)),
            false => *self,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bent triangle: the shading normal at each vertex is the vertex's,
    /// and it follows every point when the triangle is flipped.
    #[test]
    fn flipped_normals_follow_their_points_and_reverse() {
        let bent = [
            DVec3::new(-0.3, 0.0, 1.0),
            DVec3::new(0.4, 0.1, 1.0),
            DVec3::new(0.0, 0.5, 1.0),
        ];
        let normals = ShadingNormals::new(bent).unwrap();
        for patch in [
            Patch::Triangle([DVec3::ZERO, DVec3::X, DVec3::Y]),
            Patch::Parallelogram {
                origin: DVec3::ZERO,
                edge_s: DVec3::X,
                edge_t: DVec3::Y,
            },
        ] {
            let flipped = normals.flipped(&patch);
            let back = patch.flipped();
            for param in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.2, 0.3)] {
                let param = DVec2::from(param);
                let n = normals.at(param).unwrap();
                let x = patch.point_at(param);
                let m = flipped.at(back.param_of(x)).unwrap();
                assert!((n + m).length() < 1e-6, "{n} vs {m} at {param}");
            }
            for (k, param) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)].into_iter().enumerate() {
                let n = normals.at(DVec2::from(param)).unwrap();
                assert!((n - bent[k].normalize()).length() < 1e-6);
            }
        }
    }

    /// Normals transform by the inverse transpose: after a shear they stay
    /// perpendicular to the plane they were perpendicular to.
    #[test]
    fn a_shear_keeps_normals_perpendicular_to_their_plane() {
        let shear = DMat4::from_cols_array(&[
            1.0, 0.0, 0.0, 0.0, 0.7, 1.0, 0.0, 0.0, 0.3, -0.2, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ]);
        let normals = ShadingNormals::new([DVec3::Z; 3]).unwrap();
        let moved = normals
            .transformed(&shear)
            .unwrap()
            .at(DVec2::ZERO)
            .unwrap();
        for tangent in [DVec3::X, DVec3::Y] {
            assert!(moved.dot(shear.transform_vector3(tangent)).abs() < 1e-6);
        }
        let squash = DMat4::from_scale(DVec3::new(1.0, 1.0, 0.0));
        assert_eq!(normals.transformed(&squash), None);
        assert_eq!(ShadingNormals::new([DVec3::Z, DVec3::ZERO, DVec3::Z]), None);
        let back = normals.facing(-DVec3::Z);
        assert!((back.at(DVec2::ZERO).unwrap() + DVec3::Z).length() < 1e-6);
    }
}
