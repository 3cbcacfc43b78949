//! Sensor plugins (`perspective`, `orthographic`) with their nested film
//! (`hdrfilm`), reconstruction filter (every Mitsuba 3 `rfilter`:
//! [`PixelFilter`]) and sampler.
//!
//! | plugin         | parameter                 | type        | default        |
//! |----------------|---------------------------|-------------|----------------|
//! | both           | `to_world`                | transform   | identity       |
//! | both           | `near_clip`, `far_clip`   | float       | 0.01, 10⁴      |
//! | `perspective`  | `fov`                     | float (°)   | from 50 mm     |
//! | `perspective`  | `fov_axis`                | string      | `x`            |
//! | `perspective`  | `focal_length`            | string      | `50mm`         |
//! | `perspective`  | `focus_distance`          | (ignored)   |                |
//! | `perspective`  | `principal_point_offset_x/y` | float, must be 0 | 0     |
//! | `hdrfilm`      | `width`, `height`         | integer     | 768, 576       |
//! | `hdrfilm`      | `crop_*`                  | integer, full frame only |   |
//! | `hdrfilm`      | `pixel_format`, `component_format`, `file_format`, `banner`, `sample_border` | (ignored) | |
//! | `box`, `catmullrom` | (none)               |             |                |
//! | `tent`         | `radius`                  | float       | 1              |
//! | `gaussian`     | `stddev`                  | float       | 0.5            |
//! | `mitchell`     | `B`, `C`                  | float       | 1/3, 1/3       |
//! | `lanczos`      | `lobes`                   | integer     | 3              |
//! | any sampler    | `sample_count`            | integer     | none           |
//!
//! ```xml
//! <sensor type="perspective">
//!     <float name="fov" value="39.3077"/>
//!     <string name="fov_axis" value="smaller"/>
//!     <transform name="to_world">
//!         <lookat origin="0, 0, 3.9" target="0, 0, 0" up="0, 1, 0"/>
//!     </transform>
//!     <sampler type="independent"><integer name="sample_count" value="64"/></sampler>
//!     <film type="hdrfilm">
//!         <integer name="width" value="256"/>
//!         <integer name="height" value="256"/>
//!         <rfilter type="gaussian"/>
//!     </film>
//! </sensor>
//! ```

use glam::DMat4;
use wavrad_core::render::settings::MAX_SAMPLES_PER_PIXEL;
use wavrad_core::scene::bounds::{MAX_FILM_PIXELS, MAX_FILM_SIDE};
use wavrad_core::scene::{Camera, Film, FovAxis, PixelFilter, Projection};

use super::params::{Document, Nested, Object};
use crate::error::Result;

/// What a sensor element yields.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sensor {
    pub camera: Camera,
    pub film: Film,
    pub samples_per_pixel: Option<u32>,
}

/// Read a `<sensor>`.
pub(crate) fn parse_sensor(sensor: Nested, doc: &Document) -> Result<Sensor> {
    let mut obj = Object::parse(sensor.element, doc)?;
    let perspective = match obj.plugin {
        "perspective" => true,
        "orthographic" => false,
        other => {
            return Err(obj.at().error(format!(
                "unsupported sensor plugin \"{other}\" (supported: perspective, orthographic)"
            )))
        }
    };

    // Nested film and sampler.
    let mut film = None;
    let mut samples_per_pixel = None;
    let mut seen_sampler = false;
    for n in &obj.nested {
        match n.tag() {
            "film" if film.is_none() => film = Some(parse_film(*n, doc)?),
            "sampler" if !seen_sampler => {
                seen_sampler = true;
                samples_per_pixel = parse_sampler(*n, doc)?;
            }
            "film" | "sampler" => {
                return Err(n.at.error(format!(
                    "{} has more than one <{}>",
                    obj.describe(),
                    n.tag()
                )))
            }
            _ => return Err(obj.unexpected(n)),
        }
    }
    let film = film.unwrap_or_default();

    // Placement and clipping.
    let world_from_camera = obj.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
    let near_clip = obj.float("near_clip")?.unwrap_or(0.01);
    let far_clip = obj.float("far_clip")?.unwrap_or(1e4);
    if !(near_clip > 0.0 && far_clip > near_clip) {
        return Err(obj.location_of("near_clip").error(format!(
            "{} needs 0 < near_clip < far_clip, got near_clip = {near_clip}, far_clip = {far_clip}",
            obj.describe()
        )));
    }
    if !world_from_camera.is_finite() || world_from_camera.determinant().abs() < 1e-300 {
        return Err(obj
            .location_of("to_world")
            .error(format!("to_world of {} is singular", obj.describe())));
    }

    let projection = if perspective {
        if has_scale(&world_from_camera) {
            return Err(obj.location_of("to_world").error(
                "to_world of sensor \"perspective\" must not scale (Mitsuba forbids it too)",
            ));
        }
        let (fov, fov_axis) = fov(&mut obj, &film)?;
        let aspect = f64::from(film.width) / f64::from(film.height);
        Projection::Perspective {
            fov_x_degrees: fov_axis.fov_x_degrees(fov, aspect),
            fov_axis,
        }
    } else {
        Projection::Orthographic
    };
    obj.ignore(&["shutter_open", "shutter_close"]);
    obj.finish()?;
    Ok(Sensor {
        camera: Camera {
            world_from_camera,
            projection,
            near_clip,
            far_clip,
        },
        film,
        samples_per_pixel,
    })
}

/// The field of view in degrees and the axis it is along, from `fov` +
/// `fov_axis` or `focal_length`, as Mitsuba's `parse_fov`.
fn fov(obj: &mut Object, film: &Film) -> Result<(f64, FovAxis)> {
    for name in ["principal_point_offset_x", "principal_point_offset_y"] {
        if let Some(v) = obj.float(name)? {
            if v != 0.0 {
                return Err(obj.location_of(name).error(format!(
                    "{name} = {v}: off-centre projections are not supported (only 0)"
                )));
            }
        }
    }
    obj.ignore(&["focus_distance"]);
    let fov = obj.float("fov")?;
    let focal_length = obj.string("focal_length")?;
    let axis = obj.string("fov_axis")?;
    let aspect = f64::from(film.width) / f64::from(film.height);
    let (fov, axis) = match (fov, focal_length) {
        (Some(_), Some(_)) => {
            return Err(obj
                .location_of("focal_length")
                .error("give either \"fov\" or \"focal_length\", not both"))
        }
        (Some(fov), None) => (fov, axis.unwrap_or_else(|| "x".into()).to_ascii_lowercase()),
        (None, focal) => {
            // 35 mm film equivalent: the diagonal of 36 × 24 mm.
            let text = focal.unwrap_or_else(|| "50mm".into());
            let mm = text
                .trim()
                .trim_end_matches("mm")
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|f| f.is_finite() && *f > 0.0)
                .ok_or_else(|| {
                    obj.location_of("focal_length").error(format!(
                        "malformed focal_length \"{text}\" (expected e.g. \"50mm\")"
                    ))
                })?;
            let diagonal = (36f64.hypot(24.0) / (2.0 * mm)).atan().to_degrees() * 2.0;
            (diagonal, "diagonal".to_string())
        }
    };
    if !(fov > 0.0 && fov < 180.0) {
        return Err(obj
            .location_of("fov")
            .error(format!("fov = {fov} outside (0, 180) degrees")));
    }
    let axis = match axis.as_str() {
        "smaller" if aspect > 1.0 => "y",
        "smaller" => "x",
        "larger" if aspect > 1.0 => "x",
        "larger" => "y",
        other => other,
    };
    let axis = match axis {
        "x" => FovAxis::X,
        "y" => FovAxis::Y,
        "diagonal" => FovAxis::Diagonal,
        other => {
            return Err(obj.location_of("fov_axis").error(format!(
                "unknown fov_axis \"{other}\" (expected x, y, diagonal, smaller or larger)"
            )))
        }
    };
    Ok((fov, axis))
}

/// Mitsuba's `has_scale`: some axis of the linear part is not unit length.
fn has_scale(m: &DMat4) -> bool {
    [m.x_axis, m.y_axis, m.z_axis]
        .iter()
        .any(|a| (a.truncate().length_squared() - 1.0).abs() > 1e-3)
}

/// Read an `hdrfilm`.
fn parse_film(film: Nested, doc: &Document) -> Result<Film> {
    let mut obj = Object::parse(film.element, doc)?;
    if obj.plugin != "hdrfilm" {
        return Err(obj.at().error(format!(
            "unsupported film plugin \"{}\" (supported: hdrfilm)",
            obj.plugin
        )));
    }
    let mut size = |name: &'static str, default: u32| -> Result<u32> {
        match obj.integer(name)? {
            None => Ok(default),
            Some(v) => u32::try_from(v).ok().filter(|v| *v > 0).ok_or_else(|| {
                obj.location_of(name)
                    .error(format!("film {name} must be a positive integer, got {v}"))
            }),
        }
    };
    let width = size("width", 768)?;
    let height = size("height", 576)?;
    // The core's bounds, checked here too so that the error names the line.
    for (name, side) in [("width", width), ("height", height)] {
        if side > MAX_FILM_SIDE {
            return Err(obj.location_of(name).error(format!(
                "film {name} = {side}: wavrad renders films of at most {MAX_FILM_SIDE} pixels a side"
            )));
        }
    }
    if u64::from(width) * u64::from(height) > MAX_FILM_PIXELS {
        return Err(obj.location_of("height").error(format!(
            "the film is {width}×{height} pixels: wavrad renders at most {MAX_FILM_PIXELS} pixels"
        )));
    }
    for (name, full) in [
        ("crop_offset_x", 0),
        ("crop_offset_y", 0),
        ("crop_width", i64::from(width)),
        ("crop_height", i64::from(height)),
    ] {
        if let Some(v) = obj.integer(name)? {
            if v != full {
                return Err(obj.location_of(name).error(format!(
                    "{name} = {v}: cropped films are not supported (only the full frame, {full})"
                )));
            }
        }
    }
    obj.ignore(&[
        "pixel_format",
        "component_format",
        "file_format",
        "banner",
        "sample_border",
    ]);
    obj.finish()?;
    let mut filter = None;
    for n in &obj.nested {
        match n.tag() {
            "rfilter" if filter.is_none() => filter = Some(parse_rfilter(*n, doc)?),
            "rfilter" => return Err(n.at.error("film \"hdrfilm\" has more than one <rfilter>")),
            _ => return Err(obj.unexpected(n)),
        }
    }
    Ok(Film {
        width,
        height,
        filter: filter.unwrap_or(Film::default().filter),
    })
}

/// Read an `rfilter`: every Mitsuba 3 reconstruction filter, with its
/// parameters and defaults ([`PixelFilter`]).
fn parse_rfilter(rfilter: Nested, doc: &Document) -> Result<PixelFilter> {
    let mut obj = Object::parse(rfilter.element, doc)?;
    let (filter, parameter) = match obj.plugin {
        "box" => (PixelFilter::Box, None),
        "tent" => {
            let radius = obj.float("radius")?.unwrap_or(1.0);
            (PixelFilter::Tent { radius }, Some("radius"))
        }
        "gaussian" => {
            let stddev = obj.float("stddev")?.unwrap_or(0.5);
            (PixelFilter::Gaussian { stddev }, Some("stddev"))
        }
        "mitchell" => {
            let b = obj.float("B")?.unwrap_or(1.0 / 3.0);
            let c = obj.float("C")?.unwrap_or(1.0 / 3.0);
            (PixelFilter::Mitchell { b, c }, Some("B"))
        }
        "catmullrom" => (PixelFilter::CATMULL_ROM, None),
        "lanczos" => {
            let lobes = obj.integer("lobes")?.unwrap_or(3);
            let lobes = u32::try_from(lobes).map_err(|_| {
                obj.location_of("lobes").error(format!(
                    "lobes of rfilter \"lanczos\" must be a positive integer, got {lobes}"
                ))
            })?;
            (PixelFilter::Lanczos { lobes }, Some("lobes"))
        }
        other => {
            return Err(obj.at().error(format!(
                "unsupported rfilter plugin \"{other}\" (supported: box, tent, gaussian, \
                 mitchell, catmullrom, lanczos)"
            )))
        }
    };
    if let Some(n) = obj.nested.first() {
        return Err(obj.unexpected(n));
    }
    obj.finish()?;
    filter.validate().map_err(|e| {
        let at = parameter.map_or(obj.at(), |p| obj.location_of(p));
        at.error(e.to_string())
    })?;
    Ok(filter)
}

/// Any sampler: only `sample_count` matters.
pub(crate) fn parse_sampler(sampler: Nested, doc: &Document) -> Result<Option<u32>> {
    let mut obj = Object::parse(sampler.element, doc)?;
    let count = match obj.integer("sample_count")? {
        None => None,
        Some(v) => Some(
            u32::try_from(v)
                .ok()
                .filter(|v| (1..=MAX_SAMPLES_PER_PIXEL).contains(v))
                .ok_or_else(|| {
                    obj.location_of("sample_count").error(format!(
                        "sample_count must be an integer from 1 to {MAX_SAMPLES_PER_PIXEL} (the \
                         most samples per pixel wavrad renders), got {v}"
                    ))
                })?,
        ),
    };
    obj.ignore_all();
    if let Some(n) = obj.nested.first() {
        return Err(obj.unexpected(n));
    }
    Ok(count)
}
