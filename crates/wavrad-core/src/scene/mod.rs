//! The scene as the solver sees it: planar patches with diffuse optics, a
//! sensor and a film. Readers of scene files (`wavrad-io`) build this; the
//! solver never sees file formats.
//!
//! Every [`Surface`] is one-sided: it reflects and emits only on the side its
//! normal points to, as Mitsuba's `diffuse` BSDF and `area` emitter do. A
//! `twosided` material becomes two surfaces, one per side.

pub mod analytic;
pub mod bounds;
pub mod brdf;
mod color;
pub mod enclosed;
pub mod envmap;
mod filter;
pub mod glass;
pub mod light;
pub mod shading;
pub mod texture;

use crate::scene::analytic::AnalyticShape;
use crate::scene::brdf::{Brdf, Frame};
use crate::scene::shading::ShadingNormals;
use crate::scene::texture::{Texture, TextureMapping};
use glam::{DMat4, DVec2, DVec3};

pub use color::Rgb;
pub use filter::PixelFilter;
pub use light::Light;

/// The planar shape of a surface, parametrised over the unit square (paper §2:
/// "each u,v pair taking the value in a unit square will span the full area").
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Patch {
    /// `origin + s·edge_s + t·edge_t`, (s,t) ∈ \[0,1\]². Normal is
    /// `edge_s × edge_t` normalised.
    Parallelogram {
        /// Corner at (s,t) = (0,0).
        origin: DVec3,
        /// Edge from (0,0) to (1,0).
        edge_s: DVec3,
        /// Edge from (0,0) to (0,1).
        edge_t: DVec3,
    },
    /// Triangle with vertices in counter-clockwise order seen from the front;
    /// normal is `(v1−v0) × (v2−v0)` normalised.
    Triangle([DVec3; 3]),
}

/// One planar, one-sided surface: its reflection model and emission.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Surface {
    /// Where it came from, for messages and statistics (shape id or index).
    pub name: String,
    /// Geometry.
    pub patch: Patch,
    /// How it reflects (diffuse exactly when the BRDF is Lambertian).
    pub brdf: Brdf,
    /// Emitted radiance Le per channel (zero for non-emitters).
    pub emission: Rgb,
    /// A texture on the albedo of the BRDF's Lambertian lobe, which then
    /// holds the texture's average over the surface.
    pub texture: Option<TextureMapping>,
    /// Normals for shading a render, where the surface stands for a curved
    /// one (a tessellated sphere, a mesh with vertex normals); the patch's
    /// own normal without ([`Surface::shading_normal`]).
    pub shading: Option<ShadingNormals>,
}

/// Film: image size and pixel filter (Mitsuba's `hdrfilm`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Reconstruction filter.
    pub filter: PixelFilter,
}

/// Projection of a sensor.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Projection {
    /// Pinhole camera; `fov_x_degrees` is the full horizontal field of view
    /// (any `fov_axis` is converted to x using the film's aspect ratio).
    Perspective {
        /// Horizontal field of view in degrees.
        fov_x_degrees: f64,
        /// The film axis the scene gave its `fov` along (kept so that a
        /// changed view can take a field of view in the scene's terms).
        fov_axis: FovAxis,
    },
    /// Orthographic camera: the camera-space square [-1,1]² (scaled by
    /// `world_from_camera`) maps to the film, x spanning the width.
    Orthographic,
}

/// The film axis a perspective sensor's `fov` is measured along: Mitsuba's
/// `fov_axis`, with `smaller` and `larger` resolved for the film's aspect
/// ratio (conversions in [`crate::render::camera`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum FovAxis {
    /// The film's width (Mitsuba's default).
    #[default]
    X,
    /// The film's height.
    Y,
    /// The film's diagonal (how a `focal_length` is converted).
    Diagonal,
}

/// A sensor with Mitsuba's conventions: camera space looks along +z, +y is
/// up and +x is *left* (what `lookat` produces), so that the same world ray
/// lands on the same pixel as in Mitsuba 3.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Camera {
    /// `to_world` of the sensor.
    pub world_from_camera: DMat4,
    /// Perspective or orthographic.
    pub projection: Projection,
    /// Near clip distance along the view axis.
    pub near_clip: f64,
    /// Far clip distance.
    pub far_clip: f64,
}

/// Settings read from the scene's `integrator`/`sampler` that matter to wavrad.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct RenderHints {
    /// Samples per pixel asked for by the scene's sampler, if any.
    pub samples_per_pixel: Option<u32>,
    /// The integrator's longest path, in Mitsuba's count of segments (2:
    /// direct lighting only, 3: one bounce more, …), at least 2; `None`:
    /// no limit. A solve honours it ([`crate::solve::solve`]).
    pub max_depth: Option<u32>,
}

/// One sensor of a scene: where it looks from, its film, and what its
/// sampler asked for.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sensor {
    /// The camera.
    pub camera: Camera,
    /// Its film.
    pub film: Film,
    /// Its sampler's wishes (or the scene's top-level sampler's).
    pub hints: RenderHints,
}

/// A complete scene.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Scene {
    /// All surfaces (after expanding two-sided materials into two surfaces).
    pub surfaces: Vec<Surface>,
    /// The first sensor, if the file has one.
    pub camera: Option<Camera>,
    /// The sensor's film (defaults to 768×576 gaussian, as Mitsuba's hdrfilm).
    pub film: Film,
    /// What the integrator and sampler asked for.
    pub hints: RenderHints,
    /// The sensors after the first (`camera`, `film`, `hints`), in file
    /// order: other views to render ([`Scene::sensor`]).
    pub other_sensors: Vec<Sensor>,
    /// Lights that are not surfaces (point, spot, directional, the sky).
    pub lights: Vec<Light>,
    /// The textures surfaces refer to ([`Surface::texture`]).
    pub textures: Vec<Texture>,
    /// The curved shapes some surfaces tessellate, exact for camera rays
    /// ([`analytic`]).
    pub shapes: Vec<AnalyticShape>,
    /// Glass shapes: not surfaces of the solve (light passes them), but
    /// met by camera rays, which they reflect and refract ([`glass`]).
    pub glass: Vec<glass::Glass>,
}

impl Patch {
    /// The six faces of the axis-aligned box [min, max], normals pointing inward
    /// (a closed enclosure, as in a furnace test).
    pub fn inward_box(min: DVec3, max: DVec3) -> [Patch; 6] {
        let d = max - min;
        let (x, y, z) = (DVec3::X * d.x, DVec3::Y * d.y, DVec3::Z * d.z);
        [
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

    /// The patch as triangles for ray queries, each wound as the patch
    /// (its front side theirs): two for a parallelogram, split along its
    /// diagonal from (0,0) to (1,1).
    pub fn triangles(&self) -> Vec<[DVec3; 3]> {
        match *self {
            Patch::Parallelogram {
                origin,
                edge_s,
                edge_t,
            } => {
                let far = origin + edge_s + edge_t;
                vec![
                    [origin, origin + edge_s, far],
                    [origin, far, origin + edge_t],
                ]
            }
            Patch::Triangle(v) => vec![v],
        }
    }

    /// Vertices in parameter order: (0,0), (1,0), (1,1), (0,1) for a
    /// parallelogram; v0, v1, v2 for a triangle.
    pub fn vertices(&self) -> Vec<DVec3> {
        match *self {
            Patch::Parallelogram {
                origin,
                edge_s,
                edge_t,
            } => vec![
                origin,
                origin + edge_s,
                origin + edge_s + edge_t,
                origin + edge_t,
            ],
            Patch::Triangle(v) => v.to_vec(),
        }
    }

    /// Unnormalised normal whose length is the parallelogram's area, or twice
    /// the triangle's.
    fn cross(&self) -> DVec3 {
        match *self {
            Patch::Parallelogram { edge_s, edge_t, .. } => edge_s.cross(edge_t),
            Patch::Triangle([a, b, c]) => (b - a).cross(c - a),
        }
    }

    /// Surface area.
    pub fn area(&self) -> f64 {
        match self {
            Patch::Parallelogram { .. } => self.cross().length(),
            Patch::Triangle(_) => 0.5 * self.cross().length(),
        }
    }

    /// Unit direction of the first parameter (s for a parallelogram, v1−v0
    /// for a triangle).
    pub fn tangent(&self) -> DVec3 {
        match *self {
            Patch::Parallelogram { edge_s, .. } => edge_s.normalize_or_zero(),
            Patch::Triangle([a, b, _]) => (b - a).normalize_or_zero(),
        }
    }

    /// Unit normal of the front side.
    pub fn normal(&self) -> DVec3 {
        self.cross().normalize_or_zero()
    }

    /// The same patch seen from the other side (normal reversed; a
    /// parallelogram keeps the axis of its tangent, as Mitsuba's `twosided`
    /// and `flip_normals` keep dp/du).
    pub fn flipped(&self) -> Patch {
        match *self {
            Patch::Parallelogram {
                origin,
                edge_s,
                edge_t,
            } => Patch::Parallelogram {
                origin: origin + edge_s,
                edge_s: -edge_s,
                edge_t,
            },
            Patch::Triangle([a, b, c]) => Patch::Triangle([a, c, b]),
        }
    }

    /// Apply an affine transform (points transform as points).
    pub fn transformed(&self, m: &DMat4) -> Patch {
        match *self {
            Patch::Parallelogram {
                origin,
                edge_s,
                edge_t,
            } => Patch::Parallelogram {
                origin: m.transform_point3(origin),
                edge_s: m.transform_vector3(edge_s),
                edge_t: m.transform_vector3(edge_t),
            },
            Patch::Triangle(v) => Patch::Triangle(v.map(|p| m.transform_point3(p))),
        }
    }

    /// True when the patch has (numerically) zero area.
    pub fn is_degenerate(&self) -> bool {
        let scale = self
            .vertices()
            .iter()
            .map(|v| v.length_squared())
            .fold(1e-300, f64::max);
        self.cross().length_squared() <= 1e-24 * scale * scale
    }
}

impl Default for Film {
    fn default() -> Self {
        Film {
            width: 768,
            height: 576,
            filter: PixelFilter::Gaussian { stddev: 0.5 },
        }
    }
}

impl Scene {
    /// A scene of the given surfaces with no sensor and a default film.
    pub fn from_surfaces(surfaces: Vec<Surface>) -> Self {
        Scene {
            surfaces,
            camera: None,
            film: Film::default(),
            hints: RenderHints::default(),
            other_sensors: Vec::new(),
            lights: Vec::new(),
            textures: Vec::new(),
            shapes: Vec::new(),
            glass: Vec::new(),
        }
    }

    /// How many sensors the scene has (the first is `camera`).
    pub fn sensor_count(&self) -> usize {
        usize::from(self.camera.is_some()) + self.other_sensors.len()
    }

    /// Sensor `index` (0 the first, `camera`, `film` and `hints`), in the
    /// scene file's order.
    ///
    /// # Errors
    /// [`crate::Error::NoSensor`] without any, [`crate::Error::NoSuchSensor`] past the
    /// last.
    pub fn sensor(&self, index: usize) -> crate::Result<Sensor> {
        let camera = self.camera.ok_or(crate::Error::NoSensor)?;
        match index {
            0 => Ok(Sensor {
                camera,
                film: self.film,
                hints: self.hints,
            }),
            _ => (self.other_sensors.get(index - 1).copied()).ok_or(crate::Error::NoSuchSensor {
                index,
                count: self.sensor_count(),
            }),
        }
    }

    /// The first difference of `now` from this scene, in words ("another
    /// surface 3 (\"floor\")", "another film"); `None` when they are
    /// equal.
    pub fn difference(&self, now: &Scene) -> Option<String> {
        if self.surfaces.len() != now.surfaces.len() {
            return Some(format!(
                "{} surfaces, {} before",
                now.surfaces.len(),
                self.surfaces.len()
            ));
        }
        let surface = (self.surfaces.iter().zip(&now.surfaces)).position(|(a, b)| a != b);
        if let Some(s) = surface {
            let name = &now.surfaces[s].name;
            return Some(format!("another surface {s} ({name:?})"));
        }
        if let Some(t) = (self.textures.iter().zip(&now.textures)).position(|(a, b)| a != b) {
            return Some(format!("another texture {t}"));
        }
        if self.textures.len() != now.textures.len() {
            return Some(format!(
                "{} textures, {} before",
                now.textures.len(),
                self.textures.len()
            ));
        }
        if self.shapes != now.shapes {
            return Some("other curved shapes".into());
        }
        if self.camera != now.camera || self.other_sensors != now.other_sensors {
            return Some("another sensor".into());
        }
        if self.lights != now.lights {
            return Some("other lights".into());
        }
        if self.film != now.film {
            return Some("another film".into());
        }
        (self.hints != now.hints).then(|| "another sampler".into())
    }

    /// True when something sends light: a surface that emits, or a light
    /// of some power.
    pub fn has_light(&self) -> bool {
        self.surfaces.iter().any(Surface::is_emitter) || self.lights.iter().any(|l| !l.is_dark())
    }

    /// Radiance a ray leaving the scene along `direction` meets (the sky's;
    /// zero without one).
    pub fn sky_radiance(&self, direction: DVec3) -> Rgb {
        self.lights
            .iter()
            .map(|l| l.radiance_towards(direction))
            .fold(Rgb::ZERO, |a, b| a + b)
    }

    /// The brightest radiance the scene's light sources give (largest
    /// channel): the brightest emission, or where the [`Scene::lights`]
    /// are brighter, their [`Light::radiance_scale`] over the scene's
    /// size; what relative tolerances and thresholds refer to.
    pub fn brightest_radiance(&self) -> f64 {
        let emitted = (self.surfaces.iter())
            .map(|s| s.emission.max_channel())
            .fold(0.0f64, f64::max);
        if self.lights.is_empty() {
            return emitted;
        }
        let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
        for v in self.surfaces.iter().flat_map(|s| s.patch.vertices()) {
            (lo, hi) = (lo.min(v), hi.max(v));
        }
        let extent = (hi - lo).length();
        (self.lights.iter())
            .map(|l| l.radiance_scale(extent))
            .fold(emitted, f64::max)
    }

    /// The albedo of surface `s`'s Lambertian lobe at its patch parameter
    /// `param`: its texture's value there, else the BRDF's
    /// ([`Brdf::lambertian`]); `None` for a BRDF without one.
    pub fn lambertian_at(&self, s: usize, param: DVec2) -> Option<Rgb> {
        let surface = &self.surfaces[s];
        let rho = surface.brdf.lambertian()?;
        Some(match &surface.texture {
            Some(t) => self.textures[t.texture as usize].eval(t.uv_at(param)),
            None => rho,
        })
    }
}

impl Surface {
    /// True when the surface emits light.
    pub fn is_emitter(&self) -> bool {
        self.emission.max_channel() > 0.0
    }

    /// The shading frame of the BRDF: the front normal and, as tangent, the
    /// first parameter direction (Mitsuba's dp/du).
    pub fn frame(&self) -> Frame {
        Frame::new(self.patch.normal(), self.patch.tangent())
    }

    /// The unit shading normal at patch parameter `param`: the
    /// interpolated [`Surface::shading`] normal, or the patch's normal
    /// without one (or where the interpolated one does not point to the
    /// front side).
    pub fn shading_normal(&self, param: DVec2) -> DVec3 {
        let front = self.patch.normal();
        (self.shading.and_then(|n| n.at(param)))
            .filter(|n| n.dot(front) > 0.0)
            .unwrap_or(front)
    }

    /// The shading frame of the BRDF at the point whose shading normal is
    /// `normal` ([`Surface::shading_normal`]): that normal and, as tangent,
    /// the first parameter direction made orthogonal to it (Mitsuba's
    /// `si.sh_frame`).
    pub fn frame_at(&self, normal: DVec3) -> Frame {
        Frame::new(normal, self.patch.tangent())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flipped_parallelogram_keeps_area_and_reverses_normal() {
        let p = Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X * 2.0,
            edge_t: DVec3::Y,
        };
        assert!((p.area() - 2.0).abs() < 1e-12);
        assert!((p.normal() - DVec3::Z).length() < 1e-12);
        let f = p.flipped();
        assert!((f.area() - 2.0).abs() < 1e-12);
        assert!((f.normal() + DVec3::Z).length() < 1e-12);
        assert_eq!(f.tangent().dot(p.tangent()).abs(), 1.0);
    }

    #[test]
    fn triangle_area_and_degeneracy() {
        let t = Patch::Triangle([DVec3::ZERO, DVec3::X, DVec3::Y]);
        assert!((t.area() - 0.5).abs() < 1e-12);
        assert!(!t.is_degenerate());
        let d = Patch::Triangle([DVec3::ZERO, DVec3::X, DVec3::X * 2.0]);
        assert!(d.is_degenerate());
    }
}
