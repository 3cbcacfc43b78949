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
    let d = max - min;
    let (x, y, z) = (DVec3::X * d.x, DVec3::Y * d.y, DVec3::Z * d.z);
    vec![
        // Floor (z = min) facing +z, ceiling facing −z.
        Patch::Parallelogram {
            origin: min,
            edge_s: x,
            edge_t: y,
        },
        Patch::Parallelogram {
            origin: min + z,
            edge_s: y,
            edge_t: x,
        },
        // y = min facing +y, y = max facing −y.
        Patch::Parallelogram {
            origin: min,
            edge_s: z,
            edge_t: x,
        },
        Patch::Parallelogram {
            origin: min + y,
            edge_s: x,
            edge_t: z,
        },
        // x = min facing +x, x = max facing −x.
        Patch::Parallelogram {
            origin: min,
            edge_s: y,
            edge_t: z,
        },
        Patch::Parallelogram {
            origin: min + x,
            edge_s: z,
            edge_t: y,
        },
    ]
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
