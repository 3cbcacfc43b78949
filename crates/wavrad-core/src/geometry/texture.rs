//! A textured surface's albedo over its elements: each element carries the
//! average of the surface's texture over it ([`TextureMapping::average`]),
//! so the solve reflects each element's mean albedo, while renders read the
//! texture at the point hit.

use crate::geometry::hierarchy::ElementTree;
use crate::scene::texture::TextureMapping;
use crate::scene::{Rgb, Scene};
use rayon::prelude::*;

/// The factor surface `s`'s texture puts on the light its Lambertian lobe
/// reflects, at every node of `tree`: the texture's average over the
/// element divided by the surface's albedo ([`crate::scene::brdf::Brdf::lambertian`],
/// the texture's average over the surface), channel by channel (zero where
/// that albedo is). `None` for an untextured surface.
pub fn texture_scales(scene: &Scene, s: usize, tree: &ElementTree) -> Option<Vec<Rgb>> {
    let surface = &scene.surfaces[s];
    let mapping: TextureMapping = surface.texture?;
    let rho = surface.brdf.lambertian()?;
    let texture = &scene.textures[mapping.texture as usize];
    let ratio = |a: Rgb| Rgb([0, 1, 2].map(|c| if rho[c] > 0.0 { a[c] / rho[c] } else { 0.0 }));
    Some(
        tree.nodes
            .par_iter()
            .map(|n| ratio(mapping.average(texture, &surface.patch, &n.patch)))
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::hierarchy::ElementId;
    use crate::scene::brdf::Brdf;
    use crate::scene::texture::{Texture, UvTransform};
    use glam::{DVec3, Vec2};

    #[test]
    fn each_element_scales_by_its_share_of_the_texture() {
        // A 2×2 checker of 0.8 and 0.2 (mean 0.5) over a square split once:
        // the children are single squares.
        let patch = crate::scene::Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X,
            edge_t: DVec3::Y,
        };
        let mut surface = crate::testing::grey(patch);
        surface.brdf = Brdf::diffuse(Rgb::splat(0.5));
        surface.texture = Some(TextureMapping {
            texture: 0,
            uv: [Vec2::ZERO, Vec2::X, Vec2::Y],
        });
        let mut scene = Scene::from_surfaces(vec![surface]);
        scene.textures.push(Texture::Checkerboard {
            color0: Rgb::splat(0.8),
            color1: Rgb::splat(0.2),
            to_uv: UvTransform::default(),
        });
        let ids = [ElementId::ROOT.child(0)].into_iter().collect();
        let tree = ElementTree::build(&patch, &ids);
        let scales = texture_scales(&scene, 0, &tree).unwrap();
        let values: Vec<f64> = scales.iter().map(|r| r[0]).collect();
        assert!((values[0] - 1.0).abs() < 1e-12, "{values:?}");
        let mut children = values[1..].to_vec();
        children.sort_by(f64::total_cmp);
        for (value, expected) in children.into_iter().zip([0.4, 0.4, 1.6, 1.6]) {
            assert!((value - expected).abs() < 1e-12, "{values:?}");
        }
        scene.surfaces[0].texture = None;
        assert!(texture_scales(&scene, 0, &tree).is_none());
    }
}
