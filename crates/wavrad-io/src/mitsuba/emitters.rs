//! Emitter plugins: only `area`, nested in a shape or declared at the top
//! level with an `id` and referenced from one shape (`<ref id="..."/>`), as
//! Mitsuba 3 attaches it.
//!
//! | parameter         | type                                   | range     | default |
//! |-------------------|----------------------------------------|-----------|---------|
//! | `radiance`        | `<rgb>`, `<float>`, `<spectrum value>` | 0 to 1e20 | 1       |
//! | `sampling_weight` | `<float>` (ignored)                    |           | 1       |
//!
//! ```xml
//! <shape type="rectangle">
//!     <emitter type="area">
//!         <rgb name="radiance" value="18.387, 13.9873, 6.75357"/>
//!     </emitter>
//! </shape>
//! ```
//!
//! ```xml
//! <emitter type="area" id="light">
//!     <spectrum name="radiance" value="400:0, 500:8, 600:15.6, 700:18.4"/>
//! </emitter>
//! <shape type="rectangle"><ref id="light"/></shape>
//! ```
//!
//! The emission leaves the front side of the shape only, as in Mitsuba. A
//! spectral `radiance` becomes the colour Mitsuba's RGB variants give it
//! (`mitsuba/spectrum.rs`). An area emitter attached to two shapes is an
//! error (Mitsuba's too); one attached to none lights nothing, with a
//! warning.

use wavrad_core::scene::Rgb;

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
    let radiance = obj.radiance("radiance")?.unwrap_or(Rgb::splat(1.0));
    if let Some(c) = radiance.0.iter().find(|c| **c < 0.0) {
        return Err(obj.location_of("radiance").error(format!(
            "radiance {radiance} of emitter \"area\" has a negative component ({c})"
        )));
    }
    if let Some(c) = radiance.0.iter().find(|c| **c > MAX_RADIANCE) {
        return Err(obj.location_of("radiance").error(format!(
            "radiance {radiance} of emitter \"area\" has a component of {c}: wavrad accepts \
             up to {MAX_RADIANCE:e}"
        )));
    }
    obj.ignore(&["sampling_weight"]);
    if let Some(n) = obj.nested.first() {
        return Err(obj.unexpected(n));
    }
    obj.finish()?;
    Ok(radiance)
}

/// Check an emitter declared at the top level: only an `area` emitter can
/// be, for a shape to reference.
pub(crate) fn check_top_level_emitter(emitter: Nested, doc: &Document) -> Result<()> {
    let obj = Object::parse(emitter.element, doc)?;
    if obj.plugin != "area" {
        return Err(unsupported(&obj));
    }
    Ok(())
}

fn unsupported(obj: &Object) -> crate::Error {
    obj.at().error(format!(
        "unsupported emitter plugin \"{}\" (supported: area, nested in a shape or referenced \
         by one)",
        obj.plugin
    ))
}
