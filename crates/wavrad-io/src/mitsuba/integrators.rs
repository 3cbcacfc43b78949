//! The `integrator`: any plugin is accepted, since wavrad solves the scene
//! its own way (every bounce, view-independent). Its settings that would
//! change Mitsuba's image are not honoured, and each one set is a warning:
//!
//! | parameter       | type        | Mitsuba's meaning                              | wavrad |
//! |-----------------|-------------|------------------------------------------------|--------|
//! | `max_depth`     | `<integer>` | longest path: 1 emitters seen directly, 2 direct lighting, … ; −1 no limit (default) | every bounce; a warning below [`UNLIMITED_DEPTH`] |
//! | `hide_emitters` | `<boolean>` | emitters seen directly are black               | shown; a warning when true |
//!
//! The `direct` integrator (direct lighting only, as `max_depth` 2) is a
//! warning too. Every other parameter (`rr_depth`, sample counts of
//! `direct`, …) changes only the noise of Mitsuba's image and is ignored.
//!
//! ```xml
//! <integrator type="path">
//!     <integer name="max_depth" value="-1"/>
//! </integrator>
//! ```
//!
//! Why not honour small depths: the solution is the radiance after every
//! bounce at once (the radiance equation solved by Gauss–Seidel), not a sum
//! of bounces that could be cut short; a depth limit would need a solve per
//! bounce order.

use super::params::{Document, Nested, Object};
use crate::error::Result;

/// The smallest `max_depth` read as "no limit" without a warning: paths of
/// more bounces carry less than 4 % of the light even where every surface
/// reflects 90 % (0.9³¹ ≈ 0.038), and less than 0.01 % at 60 %.
pub(crate) const UNLIMITED_DEPTH: i64 = 32;

/// Read an `<integrator>`: an error for a `max_depth` Mitsuba refuses, a
/// warning in `doc` for each setting wavrad does not honour.
pub(crate) fn check_integrator(integrator: Nested, doc: &Document) -> Result<()> {
    // Only the settings read here are parsed; the rest, nested integrators
    // included, is left as it is.
    let mut read = integrator.element.clone();
    read.children
        .retain(|c| matches!(c.attr("name"), Some("max_depth" | "hide_emitters")));
    let mut obj = Object::parse(&read, doc)?;
    let max_depth = obj.integer("max_depth")?;
    let hide_emitters = obj.boolean("hide_emitters")?;
    obj.finish()?;
    let what = obj.describe();
    match max_depth {
        Some(d) if d < -1 => {
            return Err(obj.location_of("max_depth").error(format!(
                "max_depth = {d} of {what}: must be -1 (no limit) or at least 0, as in Mitsuba"
            )))
        }
        Some(d) if (0..UNLIMITED_DEPTH).contains(&d) => {
            let mitsuba = match d {
                0 => "renders black".to_string(),
                1 => "shows only the emitters seen directly".to_string(),
                2 => "renders direct lighting only".to_string(),
                _ => format!("follows light over at most {} bounces", d - 1),
            };
            doc.warn(obj.location_of("max_depth").warning(format!(
                "max_depth = {d} of {what} is not honoured: Mitsuba {mitsuba}, wavrad solves \
                 for every bounce (as max_depth = -1), so its image is brighter where light \
                 bounces more"
            )));
        }
        _ => {}
    }
    if obj.plugin == "direct" {
        doc.warn(obj.at().warning(
            "integrator \"direct\" renders direct lighting only; wavrad solves for every bounce \
             (as \"path\" with max_depth = -1), so its image is brighter where light bounces",
        ));
    }
    if hide_emitters == Some(true) {
        doc.warn(obj.location_of("hide_emitters").warning(format!(
            "hide_emitters of {what} is not honoured: wavrad shows the emitters seen directly"
        )));
    }
    Ok(())
}
