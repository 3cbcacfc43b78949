//! Scene fixtures shared by tests, examples and benchmarks.

use crate::sampling::hash2;
use crate::scene::analytic::{AnalyticShape, ShapeKind};
use crate::scene::brdf::ward::{Ward, WardVariant};
use crate::scene::brdf::Brdf;
use crate::scene::{Patch, Rgb, Scene, Surface};
use glam::{DMat4, DVec3};

/// A non-emitting surface reflecting 50 % in every channel.
pub fn grey(patch: Patch) -> Surface {
    Surface {
        name: String::new(),
        patch,
        brdf: Brdf::diffuse(Rgb::splat(0.5)),
        emission: Rgb::ZERO,
        texture: None,
        shading: None,
    }
}

/// The paper's Figure 3 reflector: Ward's rolled aluminium (Ward 1992;
/// ρd .10, ρs .21, αx .04, αy .09).
pub fn rolled_aluminium() -> Brdf {
    Brdf::Ward(Ward {
        variant: WardVariant::Ward,
        alpha_u: 0.04,
        alpha_v: 0.09,
        specular_reflectance: Rgb::splat(0.21),
        diffuse_reflectance: Rgb::splat(0.10),
    })
}

/// The unit square at z = 0, facing +z: a floor.
pub fn unit_floor() -> Patch {
    Patch::Parallelogram {
        origin: DVec3::ZERO,
        edge_s: DVec3::X,
        edge_t: DVec3::Y,
    }
}

/// A grey unit floor (surface 0) under a 0.2 square light of radiance 1
/// facing down at height `h` over its corner (surface 1).
pub fn light_over_a_corner(h: f64) -> Scene {
    let light = Patch::Parallelogram {
        origin: DVec3::new(0.0, 0.0, h),
        edge_s: DVec3::Y * 0.2,
        edge_t: DVec3::X * 0.2,
    };
    Scene::from_surfaces(vec![
        grey(unit_floor()),
        Surface {
            emission: Rgb::splat(1.0),
            ..grey(light)
        },
    ])
}

/// A unit floor of rolled aluminium (z = 0, facing +z; surface 0) under a
/// 0.4 × 0.5 square light of radiance 1 at z = 1 facing down (surface 1).
pub fn mirror_floor_and_light() -> Scene {
    let floor = unit_floor();
    let light = Patch::Parallelogram {
        origin: DVec3::new(0.2, 0.3, 1.0),
        edge_s: DVec3::Y * 0.4,
        edge_t: DVec3::X * 0.5,
    };
    Scene::from_surfaces(vec![
        Surface {
            brdf: rolled_aluminium(),
            ..grey(floor)
        },
        Surface {
            emission: Rgb::splat(1.0),
            ..grey(light)
        },
    ])
}

/// The centres of an `n` × `n` grid over the unit square at z = 0, row by
/// row: the midpoint rule over a unit floor, each point worth 1/n².
pub fn unit_square_midpoints(n: usize) -> impl Iterator<Item = DVec3> {
    (0..n * n).map(move |k| {
        let (i, j) = (k % n, k / n);
        DVec3::new(
            (i as f64 + 0.5) / n as f64,
            (j as f64 + 0.5) / n as f64,
            0.0,
        )
    })
}

/// The six faces of the axis-aligned box [min, max], normals pointing inward
/// (a closed enclosure, as in a furnace test).
pub fn inward_box(min: DVec3, max: DVec3) -> Vec<Patch> {
    Patch::inward_box(min, max).to_vec()
}

/// A 0.2 square light of radiance 5 facing down just under the unit box's
/// ceiling, about its centre.
fn ceiling_light() -> Surface {
    Surface {
        emission: Rgb::splat(5.0),
        ..grey(Patch::Parallelogram {
            origin: DVec3::new(0.4, 0.4, 0.99),
            edge_s: DVec3::Y * 0.2,
            edge_t: DVec3::X * 0.2,
        })
    }
}

/// The unit box (inward faces, grey) with its floor (z = 0) cut into
/// 4^`levels` tiles of rolled aluminium (the first surfaces) and a 0.2
/// square light of radiance 5 facing down just under its ceiling (the
/// last): many glossy surfaces, each with its surface triples.
pub fn glossy_tiled_box(levels: u32) -> Scene {
    let faces = inward_box(DVec3::ZERO, DVec3::ONE);
    let mut tiles = vec![faces[0]];
    for _ in 0..levels {
        tiles = tiles.iter().flat_map(|t| t.subdivide()).collect();
    }
    let glossy = tiles.into_iter().map(|patch| Surface {
        brdf: rolled_aluminium(),
        ..grey(patch)
    });
    let walls = faces[1..].iter().map(|&f| grey(f));
    Scene::from_surfaces(glossy.chain(walls).chain([ceiling_light()]).collect())
}

/// The unit box (inward faces, grey), a 0.2 square light of radiance 5
/// facing down just under its ceiling (the last surface), and, first, a
/// ball of radius 0.25 at the box's centre tessellated as a UV sphere of
/// `rings` × 2·`rings` quads (two triangles each, one at the poles) in
/// `brdf`: many small glossy surfaces that see none of each other, which
/// cluster links join to the room.
pub fn ball_in_a_box(rings: usize, brdf: Brdf) -> Scene {
    let centre = DVec3::splat(0.5);
    let point = |i: usize, j: usize| {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        let phi = std::f64::consts::PI * j as f64 / rings as f64;
        centre
            + 0.25
                * DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                )
    };
    let mut ball = Vec::new();
    for i in 0..rings {
        for j in 0..2 * rings {
            let [a, b, c, d] = [
                point(i, j),
                point(i, j + 1),
                point(i + 1, j),
                point(i + 1, j + 1),
            ];
            // Counter-clockwise from outside; a pole's quad is one triangle.
            if i > 0 {
                ball.push([a, c, b]);
            }
            if i + 1 < rings {
                ball.push([b, c, d]);
            }
        }
    }
    let ball = ball.into_iter().map(|t| Surface {
        brdf: brdf.clone(),
        ..grey(Patch::Triangle(t))
    });
    let walls = inward_box(DVec3::ZERO, DVec3::ONE).into_iter().map(grey);
    Scene::from_surfaces(ball.chain(walls).chain([ceiling_light()]).collect())
}

/// Triangles on a bowl: the unit sphere's lower half, `n` × `n` cells
/// of its (polar, azimuth) grid, each cut in two; facing inwards, and
/// with `both_sides` each followed by its flipped twin.
pub fn bowl(n: usize, both_sides: bool) -> Scene {
    let at = |i: usize, j: usize| {
        let (polar, azimuth) = (
            std::f64::consts::FRAC_PI_2 * (1.0 + i as f64 / n as f64),
            std::f64::consts::TAU * j as f64 / n as f64,
        );
        DVec3::new(
            polar.sin() * azimuth.cos(),
            polar.cos(),
            polar.sin() * azimuth.sin(),
        )
    };
    let mut surfaces = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let [a, b, c, d] = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
            for corners in [[a, b, c], [a, c, d]] {
                let mut patch = Patch::Triangle(corners);
                if patch.normal().dot(patch.centroid()) > 0.0 {
                    patch = patch.flipped();
                }
                if patch.area() < 1e-12 {
                    continue;
                }
                surfaces.push(grey(patch));
                if both_sides {
                    surfaces.push(grey(patch.flipped()));
                }
            }
        }
    }
    Scene::from_surfaces(surfaces)
}

/// `count` curved shapes, of `kinds` in turn, scattered over the cube
/// [-1, 1]³ from `seed`, in a scene with no surfaces (ray queries against
/// the exact shapes alone): centres uniform, radii between 0.5 and 1.5
/// times 0.3·count^(-1/3), so that the shapes fill the same share of the
/// cube whatever the count. Spheres stay round; disks and cylinders
/// are stretched by up to 2 along their unit shape's x and z (a cylinder's
/// length) and turned about a random axis.
pub fn scattered_shapes(count: usize, kinds: &[ShapeKind], seed: u64) -> Scene {
    let size = 0.3 / (count.max(1) as f64).cbrt();
    let mut scene = Scene::from_surfaces(Vec::new());
    scene.shapes = (0..count)
        .map(|i| {
            let [a, b, c] = [0, 1, 2].map(|j| hash2(seed, 3 * i as u64 + j));
            let centre = DVec3::new(a.x, a.y, b.x) * 2.0 - DVec3::ONE;
            let radius = size * (0.5 + b.y);
            let kind = kinds[i % kinds.len()];
            let world_from_shape = if kind == ShapeKind::Sphere {
                DMat4::from_translation(centre) * DMat4::from_scale(DVec3::splat(radius))
            } else {
                let (z, phi) = (2.0 * c.x - 1.0, std::f64::consts::TAU * c.y);
                let r = (1.0 - z * z).sqrt();
                let axis = DVec3::new(r * phi.cos(), r * phi.sin(), z);
                let stretch = DVec3::new(1.0 + a.x, 1.0, 1.0 + b.y);
                DMat4::from_translation(centre)
                    * DMat4::from_axis_angle(axis, 7.0 * c.x + 3.0 * c.y)
                    * DMat4::from_scale(radius * stretch)
            };
            AnalyticShape {
                kind,
                world_from_shape,
                surfaces: 0..0,
            }
        })
        .collect();
    scene
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
