//! Emitter plugins: only `area`, nested in a shape.
//!
//! | parameter         | type                                   | default |
//! |-------------------|----------------------------------------|---------|
//! | `radiance`        | `<rgb>`, `<float>`, `<spectrum value>` | 1       |
//! | `sampling_weight` | `<float>` (ignored)                    | 1       |
//!
//! ```xml
//! <shape type="rectangle">
//!     <emitter type="area">
//!         <rgb name="radiance" value="18.387, 13.9873, 6.75357"/>
//!     </emitter>
//! </shape>
//! ```
//!
//! The emission leaves the front side of the shape only, as in Mitsuba.

use wavrad_core::scene::Rgb;

use super::params::{Ids, Nested, Object};
use crate::error::Result;

/// The emitted radiance of an `area` emitter.
pub(crate) fn parse_area_emitter(emitter: Nested, ids: &Ids) -> Result<Rgb> {
    let mut obj = Object::parse(emitter.element, ids)?;
    if obj.plugin != "area" {
        return Err(unsupported(&obj));
    }
    let radiance = obj.color("radiance")?.unwrap_or(Rgb::splat(1.0));
    if let Some(c) = radiance.0.iter().find(|c| **c < 0.0) {
        return Err(obj.location_of("radiance").error(format!(
            "radiance {radiance} of emitter \"area\" has a negative component ({c})"
        )));
    }
    obj.ignore(&["sampling_weight"]);
    if let Some(n) = obj.nested.first() {
        return Err(obj.unexpected(n));
    }
    obj.finish()?;
    Ok(radiance)
}

/// The error for an emitter outside a shape.
pub(crate) fn top_level_emitter(emitter: Nested, ids: &Ids) -> crate::Error {
    match Object::parse(emitter.element, ids) {
        Err(e) => e,
        Ok(obj) if obj.plugin == "area" => obj
            .at()
            .error("an area emitter must be nested in a <shape>"),
        Ok(obj) => unsupported(&obj),
    }
}

fn unsupported(obj: &Object) -> crate::Error {
    obj.at().error(format!(
        "unsupported emitter plugin \"{}\" (supported: area, nested in a shape)",
        obj.plugin
    ))
}
