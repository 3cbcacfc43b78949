//! Scene fixtures shared by tests, examples and benchmarks.

use crate::scene::{Patch, Surface};
use glam::DVec3;

/// A non-emitting surface reflecting 50 % in every channel.
pub fn grey(patch: Patch) -> Surface {
    Surface {
        name: String::new(),
        patch,
        brdf: crate::brdf::Brdf::diffuse([0.5; 3]),
        emission: [0.0; 3],
    }
}

/// The six faces of the axis-aligned box [min, max], normals pointing inward
/// (a closed enclosure, as in a furnace test).
pub fn inward_box(min: DVec3, max: DVec3) -> Vec<Patch> {
    Patch::inward_box(min, max).to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inward_box_faces_point_inside() {
        let centre = DVec3::splat(0.5);
        for f in inward_box(DVec3::ZERO, DVec3::ONE) {
            assert!(f.normal().dot(centre - f.centroid()) > 0.49);
            assert!((f.area() - 1.0).abs() < 1e-12);
        }
    }
}
