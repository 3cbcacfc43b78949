//! The bounds a scene must keep to be solved and rendered: sizes a file can
//! set that would otherwise overflow arithmetic or exhaust memory deep
//! inside the work (a ray structure over coordinates near `f32`'s range, a
//! film of billions of pixels), checked before any work starts.

use super::analytic::AnalyticShape;
use super::Scene;
use crate::{Error, Result};
use glam::DMat3;

/// Largest coordinate magnitude of a vertex, in scene units: the ray
/// structure's boxes are `f32`, whose squares (surface areas) must stay
/// finite, and no modelled scene comes near it.
pub const MAX_COORDINATE: f64 = 1e12;

/// Largest film side, in pixels.
pub const MAX_FILM_SIDE: u32 = 1 << 15;

/// Largest film, in pixels (16384², 3 GiB of linear RGB).
pub const MAX_FILM_PIXELS: u64 = 1 << 28;

impl Scene {
    /// Check the scene against [`MAX_COORDINATE`], [`MAX_FILM_SIDE`] and
    /// [`MAX_FILM_PIXELS`], and that each curved shape is tessellated by
    /// surfaces of the scene and placed by an invertible transform; the
    /// error names the surface, the shape or the film.
    pub fn check_bounds(&self) -> Result<()> {
        for (index, surface) in self.surfaces.iter().enumerate() {
            if let Some(v) = surface
                .patch
                .vertices()
                .iter()
                .find(|v| !v.is_finite() || v.abs().max_element() > MAX_COORDINATE)
            {
                let name = match surface.name.as_str() {
                    "" => format!("surface {index}"),
                    name => format!("surface {index} ({name})"),
                };
                return Err(Error::OutOfBounds(format!(
                    "{name} has a vertex at {v}: wavrad accepts coordinates up to \
                     {MAX_COORDINATE:e} in magnitude"
                )));
            }
        }
        for (index, shape) in self.shapes.iter().enumerate() {
            check_shape(shape, self.surfaces.len())
                .map_err(|e| Error::OutOfBounds(format!("curved shape {index} {e}")))?;
        }
        let (w, h) = (self.film.width, self.film.height);
        if w == 0 || h == 0 || w > MAX_FILM_SIDE || h > MAX_FILM_SIDE {
            return Err(Error::OutOfBounds(format!(
                "the film is {w}×{h} pixels: each side must be 1 to {MAX_FILM_SIDE}"
            )));
        }
        if u64::from(w) * u64::from(h) > MAX_FILM_PIXELS {
            return Err(Error::OutOfBounds(format!(
                "the film is {w}×{h} pixels: wavrad renders at most {MAX_FILM_PIXELS} pixels"
            )));
        }
        Ok(())
    }
}

/// Why `shape` cannot be traced in a scene of `surfaces` surfaces, if it
/// cannot.
fn check_shape(shape: &AnalyticShape, surfaces: usize) -> std::result::Result<(), String> {
    let range = &shape.surfaces;
    if range.start > range.end || range.end as usize > surfaces {
        return Err(format!(
            "is tessellated by surfaces {}..{} of {surfaces}",
            range.start, range.end
        ));
    }
    let m = shape.world_from_shape;
    let det = DMat3::from_mat4(m).determinant();
    let (lo, hi) = shape.bounds();
    let far = lo.abs().max(hi.abs()).max_element();
    if !m.is_finite() || det == 0.0 || !det.is_finite() || !m.inverse().is_finite() {
        return Err("has a singular or infinite transform".into());
    }
    if far > MAX_COORDINATE {
        return Err(format!(
            "reaches {far:e}: wavrad accepts coordinates up to {MAX_COORDINATE:e} in magnitude"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Patch;
    use crate::testing::light_over_a_corner;
    use glam::DVec3;

    #[test]
    fn far_vertices_and_huge_films_are_named_and_refused() {
        let scene = light_over_a_corner(0.3);
        scene.check_bounds().unwrap();

        let mut far = scene.clone();
        if let Patch::Parallelogram { origin, .. } = &mut far.surfaces[0].patch {
            *origin = DVec3::new(1e19, 0.0, 0.0);
        } else if let Patch::Triangle(v) = &mut far.surfaces[0].patch {
            v[0] = DVec3::new(1e19, 0.0, 0.0);
        }
        let message = far.check_bounds().unwrap_err().to_string();
        assert!(
            message.contains("surface 0") && message.contains("1e12"),
            "{message}"
        );

        for (w, h) in [(0, 8), (u32::MAX, u32::MAX), (MAX_FILM_SIDE, MAX_FILM_SIDE)] {
            let mut big = scene.clone();
            (big.film.width, big.film.height) = (w, h);
            let message = big.check_bounds().unwrap_err().to_string();
            assert!(message.contains("the film is"), "{message}");
        }
        let shape = |surfaces, world_from_shape| AnalyticShape {
            kind: super::super::analytic::ShapeKind::Sphere,
            world_from_shape,
            surfaces,
        };
        for (bad, what) in [
            (shape(0..99, glam::DMat4::IDENTITY), "surfaces 0..99"),
            (shape(0..1, glam::DMat4::ZERO), "singular"),
            (
                shape(0..1, glam::DMat4::from_scale(DVec3::splat(1e13))),
                "reaches",
            ),
        ] {
            let mut curved = scene.clone();
            curved.shapes.push(bad);
            let message = curved.check_bounds().unwrap_err().to_string();
            assert!(
                message.contains("curved shape 0") && message.contains(what),
                "{message}"
            );
        }
        let mut curved = scene.clone();
        curved.shapes.push(shape(0..1, glam::DMat4::IDENTITY));
        curved.check_bounds().unwrap();

        let mut largest = scene;
        (largest.film.width, largest.film.height) = (16384, 16384);
        largest.check_bounds().unwrap();
    }
}
