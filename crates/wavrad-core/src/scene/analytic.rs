//! Analytic shapes: the exact description of a curved shape (Mitsuba's
//! `sphere`, `disk`, `cylinder`) whose tessellation stands for it among the
//! scene's surfaces. The solve, its gathers and its shadow rays see only the
//! tessellation; camera rays see the exact shape
//! ([`crate::geometry::analytic`]), and read the solution on the surface of
//! the tessellation that covers the point they meet.
//!
//! ```
//! use wavrad_core::scene::analytic::{AnalyticShape, ShapeKind};
//! use glam::{DMat4, DVec3};
//!
//! let sphere = AnalyticShape {
//!     kind: ShapeKind::Sphere,
//!     world_from_shape: DMat4::from_scale(DVec3::splat(2.0)),
//!     surfaces: 0..528,
//! };
//! let (lo, hi) = sphere.bounds();
//! assert_eq!((lo, hi), (DVec3::splat(-2.0), DVec3::splat(2.0)));
//! ```

use glam::{DMat4, DVec3};
use std::ops::Range;

/// A unit shape in its own space, as Mitsuba 3 defines it before `to_world`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum ShapeKind {
    /// The unit sphere |p| = 1 (`sphere`: `to_world · translate(center) ·
    /// scale(radius)` places it), normals outwards.
    Sphere,
    /// The unit disk x² + y² ≤ 1 at z = 0 (`disk`), normal +z.
    Disk,
    /// The open unit cylinder x² + y² = 1, 0 ≤ z ≤ 1, without caps
    /// (`cylinder`: `translate(p0) · frame(p1 − p0) · scale(radius, radius,
    /// |p1 − p0|)` places it), normals away from the axis.
    Cylinder,
}

/// A curved shape: the unit shape `kind`, placed by `world_from_shape`,
/// and the scene's surfaces that tessellate it (both sides of a `twosided`
/// one).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AnalyticShape {
    /// Which unit shape.
    pub kind: ShapeKind,
    /// The affine map of the unit shape onto the shape in the scene.
    pub world_from_shape: DMat4,
    /// Indices of the surfaces of its tessellation in
    /// [`crate::scene::Scene::surfaces`].
    pub surfaces: Range<u32>,
}

impl ShapeKind {
    /// The corners of the unit shape's axis-aligned bounding box.
    fn corners(self) -> [DVec3; 8] {
        let (z0, z1) = match self {
            ShapeKind::Sphere => (-1.0, 1.0),
            ShapeKind::Disk => (0.0, 0.0),
            ShapeKind::Cylinder => (0.0, 1.0),
        };
        std::array::from_fn(|k| {
            let pick = |bit: usize, lo: f64, hi: f64| if k & bit == 0 { lo } else { hi };
            DVec3::new(pick(1, -1.0, 1.0), pick(2, -1.0, 1.0), pick(4, z0, z1))
        })
    }
}

impl AnalyticShape {
    /// The corners of its world-space axis-aligned bounding box (that of
    /// the unit shape's box, placed).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let corners = self.kind.corners();
        corners.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &c| {
                let p = self.world_from_shape.transform_point3(c);
                (lo.min(p), hi.max(p))
            },
        )
    }
}
