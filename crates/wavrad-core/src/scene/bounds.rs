//! The bounds a scene must keep to be solved and rendered: sizes a file can
//! set that would otherwise overflow arithmetic or exhaust memory deep
//! inside the work (a ray structure over coordinates near `f32`'s range, a
//! film of billions of pixels), checked before any work starts.

use super::Scene;
use crate::{Error, Result};

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
    /// [`MAX_FILM_PIXELS`]; the error names the surface or the film.
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
        let mut largest = scene;
        (largest.film.width, largest.film.height) = (16384, 16384);
        largest.check_bounds().unwrap();
    }
}
