//! Emitter plugins: `area`, nested in a shape or declared at the top level
//! with an `id` and referenced from one shape (`<ref id="..."/>`), as
//! Mitsuba 3 attaches it; and at the top level `point`, `spot`,
//! `directional`, `constant` and `envmap` ([`wavrad_core::scene::Light`]).
//!
//! | plugin        | parameter         | type                        | default              |
//! |---------------|-------------------|-----------------------------|----------------------|
//! | `area`        | `radiance`        | spectrum (W m⁻² sr⁻¹)       | 1                    |
//! | `point`       | `intensity`       | spectrum (W sr⁻¹)           | 1                    |
//! |               | `position`        | `<point>`                   | from `to_world`      |
//! |               | `to_world`        | transform (its translation) | identity             |
//! | `spot`        | `intensity`       | spectrum (W sr⁻¹)           | 1                    |
//! |               | `cutoff_angle`    | float, degrees, (0, 180]    | 20                   |
//! |               | `beam_width`      | float, degrees, (0, cutoff] | cutoff_angle · 3/4   |
//! |               | `to_world`        | transform (shines along +z) | identity             |
//! | `directional` | `irradiance`      | spectrum (W m⁻²)            | 1                    |
//! |               | `direction`       | `<vector>`                  | from `to_world`      |
//! |               | `to_world`        | transform (travels along +z)| identity             |
//! | `constant`    | `radiance`        | spectrum (W m⁻² sr⁻¹)       | 1                    |
//! | `envmap`      | `filename`        | string, an image (EXR, HDR, PNG, JPEG, …) | (required) |
//! |               | `scale`           | float                       | 1                    |
//! |               | `to_world`        | transform (a rotation)      | identity             |
//! | all           | `sampling_weight` | float (ignored)             | 1                    |
//!
//! A spectrum is an `<rgb>`, a `<float>` or a `<spectrum value>`; a
//! spectral value becomes the colour Mitsuba's RGB variants give it
//! (`mitsuba/spectrum.rs`). A spot's `texture` is an error naming it. An
//! `envmap` image is linear RGB as Mitsuba reads it: OpenEXR and Radiance
//! HDR as stored, 8- and 16-bit images (PNG, JPEG, …) made linear from sRGB.
//!
//! ```xml
//! <shape type="rectangle">
//!     <emitter type="area">
//!         <rgb name="radiance" value="18.387, 13.9873, 6.75357"/>
//!     </emitter>
//! </shape>
//! <emitter type="point">
//!     <point name="position" x="0" y="1.9" z="0"/>
//!     <rgb name="intensity" value="10"/>
//! </emitter>
//! <emitter type="spot">
//!     <transform name="to_world">
//!         <lookat origin="0, 1.9, 0" target="0, 0, 0" up="0, 0, 1"/>
//!     </transform>
//!     <float name="cutoff_angle" value="30"/>
//! </emitter>
//! ```
//!
//! The emission of an area emitter leaves the front side of the shape
//! only, as in Mitsuba. An area emitter attached to two shapes is an error
//! (Mitsuba's too); one attached to none lights nothing, with a warning.

use glam::{DMat3, DMat4, DVec3};
use wavrad_core::scene::envmap::EnvMap;
use wavrad_core::scene::{Light, Rgb};

use super::params::{Document, Nested, Object};
use crate::error::Result;

/// Largest radiance component: far above anything physical (the sun's disk
/// is about 2e7 W m⁻² sr⁻¹), and low enough that sums of it stay finite in
/// the `f32` pixels of an image (a radiance of 1e300 rendered as +inf).
pub(crate) const MAX_RADIANCE: f64 = 1e20;

/// The emitted radiance of an `area` emitter.
pub(crate) fn parse_area_emitter(emitter: Nested, doc: &Document) -> Result<Rgb> {
    let mut obj = Object::parse(emitter.element, doc)?;
    if obj.plugin != "area" {
        return Err(unsupported(&obj));
    }
    let radiance = emitted(&mut obj, "radiance")?;
    finish(obj)?;
    Ok(radiance)
}

/// An emitter declared at the top level: a [`Light`] for `point`, `spot`,
/// `directional` and `constant`; `None` for an `area` emitter, which a
/// shape references.
pub(crate) fn parse_top_level_emitter(emitter: Nested, doc: &Document) -> Result<Option<Light>> {
    let mut obj = Object::parse(emitter.element, doc)?;
    let light = match obj.plugin {
        "area" => return Ok(None),
        "point" => {
            let intensity = emitted(&mut obj, "intensity")?;
            let position = match (obj.point("position")?, obj.transform("to_world")?) {
                (Some(_), Some(_)) => return Err(both(&obj, "position")),
                (Some(p), None) => p,
                (None, m) => m.unwrap_or(DMat4::IDENTITY).transform_point3(DVec3::ZERO),
            };
            Light::Point {
                position,
                intensity,
            }
        }
        "spot" => {
            let intensity = emitted(&mut obj, "intensity")?;
            let degrees = |obj: &mut Object, name, default: f64, most: f64| {
                let value = obj.float(name)?.unwrap_or(default);
                if value > 0.0 && value <= most {
                    Ok(value)
                } else {
                    Err(obj.location_of(name).error(format!(
                        "{name} {value} of emitter \"spot\" must be in (0, {most}] degrees"
                    )))
                }
            };
            let cutoff = degrees(&mut obj, "cutoff_angle", 20.0, 180.0)?;
            let beam_width = degrees(&mut obj, "beam_width", cutoff * 0.75, cutoff)?;
            if obj.has("texture") {
                return Err(obj.location_of("texture").error(
                    "the texture of emitter \"spot\" is not supported (wavrad's spot shines \
                     its intensity alone)",
                ));
            }
            let m = obj.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
            Light::Spot {
                position: m.transform_point3(DVec3::ZERO),
                axis: direction_of(&obj, m)?,
                intensity,
                cutoff: cutoff.to_radians(),
                beam_width: beam_width.to_radians(),
            }
        }
        "directional" => {
            let irradiance = emitted(&mut obj, "irradiance")?;
            let direction = match (obj.point("direction")?, obj.transform("to_world")?) {
                (Some(_), Some(_)) => return Err(both(&obj, "direction")),
                (Some(d), None) => d.try_normalize().ok_or_else(|| {
                    obj.location_of("direction")
                        .error("direction of emitter \"directional\" is zero")
                })?,
                (None, m) => direction_of(&obj, m.unwrap_or(DMat4::IDENTITY))?,
            };
            Light::Directional {
                direction,
                irradiance,
            }
        }
        "constant" => Light::Constant {
            radiance: emitted(&mut obj, "radiance")?,
        },
        "envmap" => Light::Envmap(parse_envmap(&mut obj, doc)?),
        _ => return Err(unsupported(&obj)),
    };
    finish(obj)?;
    Ok(Some(light))
}

/// An `envmap`'s image, scale and rotation.
fn parse_envmap(obj: &mut Object, doc: &Document) -> Result<EnvMap> {
    let Some(filename) = obj.string("filename")? else {
        return Err(obj.at().error("emitter \"envmap\" needs a filename"));
    };
    let at = obj.location_of("filename").clone();
    let scale = obj.float("scale")?.unwrap_or(1.0);
    if !(0.0..=MAX_RADIANCE).contains(&scale) {
        return Err(obj.location_of("scale").error(format!(
            "scale {scale} of emitter \"envmap\" must be in 0 to {MAX_RADIANCE:e}"
        )));
    }
    let to_world = obj.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
    let rotation = DMat3::from_mat4(to_world);
    let orthonormal = (rotation.transpose() * rotation - DMat3::IDENTITY)
        .to_cols_array()
        .iter()
        .all(|v| v.abs() < 1e-6);
    if !orthonormal || rotation.determinant() <= 0.0 {
        return Err(obj
            .location_of("to_world")
            .error("to_world of emitter \"envmap\" must be a rotation"));
    }
    obj.ignore(&["mis_compensation"]);
    let path = doc.search.resolve(&filename, &at.dir);
    let is_exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    // OpenEXR through the exr crate (every layout Mitsuba writes); the
    // rest (HDR, PNG, JPEG, …) as bitmap textures are read, sRGB made linear.
    let (width, height, rgb) = if is_exr {
        crate::image::read_exr_rgb(&path)
            .map_err(|e| at.error(format!("cannot read the envmap image: {e}")))?
    } else {
        let (width, height, texels) = super::textures::read_linear_rgb(&path, false)
            .map_err(|e| at.error(format!("envmap image \"{}\": {e}", path.display())))?;
        (width, height, texels.concat())
    };
    if let Some(v) = rgb.iter().find(|v| !v.is_finite()) {
        return Err(at.error(format!(
            "envmap image \"{filename}\" holds a pixel of {v}: wavrad needs finite radiance"
        )));
    }
    EnvMap::new(width as usize, height as usize, &rgb, scale, rotation).ok_or_else(|| {
        at.error(format!(
            "envmap image \"{filename}\" ({width}x{height}) sends no light or has fewer than \
             2 rows"
        ))
    })
}

/// The spectrum `name` of an emitter (default 1), each component in 0 to
/// [`MAX_RADIANCE`].
fn emitted(obj: &mut Object, name: &'static str) -> Result<Rgb> {
    let value = obj.radiance(name)?.unwrap_or(Rgb::splat(1.0));
    let plugin = obj.plugin;
    if let Some(c) = value.0.iter().find(|c| **c < 0.0) {
        return Err(obj.location_of(name).error(format!(
            "{name} {value} of emitter \"{plugin}\" has a negative component ({c})"
        )));
    }
    if let Some(c) = value.0.iter().find(|c| **c > MAX_RADIANCE) {
        return Err(obj.location_of(name).error(format!(
            "{name} {value} of emitter \"{plugin}\" has a component of {c:e}: wavrad accepts \
             up to {MAX_RADIANCE:e}"
        )));
    }
    Ok(value)
}

/// Where `to_world` sends the local +z axis (the direction a spot shines
/// and a directional light travels), as a unit vector.
fn direction_of(obj: &Object, to_world: DMat4) -> Result<DVec3> {
    to_world
        .transform_vector3(DVec3::Z)
        .try_normalize()
        .ok_or_else(|| {
            obj.location_of("to_world")
                .error(format!("to_world of {} is singular", obj.describe()))
        })
}

/// Mitsuba's error for an emitter given both `name` and `to_world`.
fn both(obj: &Object, name: &str) -> crate::Error {
    obj.location_of(name).error(format!(
        "emitter \"{}\" takes either {name} or to_world, not both (as in Mitsuba)",
        obj.plugin
    ))
}

/// The parameters every emitter ignores; then nothing may be left.
fn finish(mut obj: Object) -> Result<()> {
    obj.ignore(&["sampling_weight"]);
    if let Some(n) = obj.nested.first() {
        return Err(obj.unexpected(n));
    }
    obj.finish()
}

fn unsupported(obj: &Object) -> crate::Error {
    obj.at().error(format!(
        "unsupported emitter plugin \"{}\" (supported: area, nested in a shape or referenced \
         by one; point, spot, directional, constant and envmap at the top level)",
        obj.plugin
    ))
}
