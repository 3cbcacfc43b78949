//! The `integrator`: any of Mitsuba 3's plugins is accepted, since wavrad
//! solves the scene its own way (view-independent). Each plugin's
//! parameters are checked as Mitsuba checks them: a name the plugin does
//! not read is an error listing those it does, a value of the wrong type
//! too. Of its settings that change Mitsuba's image, the longest path is
//! honoured and the rest are warnings:
//!
//! | parameter       | type        | Mitsuba's meaning                              | wavrad |
//! |-----------------|-------------|------------------------------------------------|--------|
//! | `max_depth`     | `<integer>` | longest path: 1 emitters seen directly, 2 direct lighting, … ; −1 no limit (default) | honoured from 2 to [`UNLIMITED_DEPTH`] − 1 ([`RenderHints::max_depth`](wavrad_core::scene::RenderHints::max_depth)); 0 and 1 a warning, solved as −1 |
//! | `hide_emitters` | `<boolean>` | emitters seen directly are black               | shown; a warning when true |
//!
//! The `direct` integrator is direct lighting only, as `max_depth` 2; so is
//! a Mitsuba 0.x scene without an integrator, as Mitsuba 0.x renders it
//! (its default integrator is `direct`; Mitsuba 3 refuses to render a scene
//! without one), with a warning. A Mitsuba 2 or 3 scene without one is
//! solved for every bounce. Every other parameter (`rr_depth`, `timeout`,
//! sample counts of `direct`, …: [`PLUGINS`]) changes only the noise or the
//! speed of Mitsuba's image and is ignored. The integrators that nest
//! others (`aov`, `moment`, `stokes`) have theirs checked the same way, and
//! the first nested one's longest path is the scene's. A plugin Mitsuba 3
//! does not ship (one registered from Python, say) is a warning, its
//! parameters unchecked.
//!
//! ```xml
//! <integrator type="path">
//!     <integer name="max_depth" value="-1"/>
//! </integrator>
//! ```
//!
//! A solve honours the longest path by sweeping Jacobi's way a fixed
//! number of times ([`wavrad_core::solve::bounces`]), so the radiance holds
//! exactly the light of the reflections a path of that length makes.

use super::document::Element;
use super::params::{Document, Nested, Object};
use crate::error::Result;

/// The smallest `max_depth` read as "no limit": paths of
/// more bounces carry less than 4 % of the light even where every surface
/// reflects 90 % (0.9³¹ ≈ 0.038), and less than 0.01 % at 60 %.
pub(crate) const UNLIMITED_DEPTH: i64 = 32;

/// The type of an integrator parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Integer,
    Float,
    Boolean,
    Text,
}

use Kind::{Boolean, Float, Integer, Text};

/// Parameters by name and type.
type Params = &'static [(&'static str, Kind)];

/// What every integrator reads (Mitsuba 3's `Integrator`).
const INTEGRATOR: Params = &[("timeout", Float), ("hide_emitters", Boolean)];
/// What sampling integrators add (`SamplingIntegrator`).
const SAMPLING: Params = &[("block_size", Integer), ("samples_per_pass", Integer)];
/// What path tracers add (`MonteCarloIntegrator`, the Python `ADIntegrator`).
const PATHS: Params = &[("max_depth", Integer), ("rr_depth", Integer)];
/// What the projective-sampling integrators add (`PSIntegrator`).
const PROJECTIVE: Params = &[
    ("sppc", Integer),
    ("sppp", Integer),
    ("sppi", Integer),
    ("guiding", Text),
    ("guiding_proj", Boolean),
    ("guiding_rounds", Integer),
    ("project_seed", Text),
];

/// An integrator plugin of Mitsuba 3.
struct Plugin {
    name: &'static str,
    /// The parameters it reads beyond [`INTEGRATOR`]'s.
    reads: &'static [Params],
    /// Whether it nests integrators.
    nests: bool,
}

/// A plugin that nests no integrator.
const fn plugin(name: &'static str, reads: &'static [Params]) -> Plugin {
    Plugin {
        name,
        reads,
        nests: false,
    }
}

/// A plugin that nests integrators (its AOVs, moments, Stokes vector).
const fn nesting(name: &'static str, reads: &'static [Params]) -> Plugin {
    Plugin {
        name,
        reads,
        nests: true,
    }
}

/// Mitsuba 3's integrator plugins: `src/integrators/`, and the Python ones
/// of `mitsuba.ad.integrators`.
const PLUGINS: &[Plugin] = &[
    plugin("path", &[SAMPLING, PATHS]),
    plugin("volpath", &[SAMPLING, PATHS]),
    plugin(
        "volpathmis",
        &[SAMPLING, PATHS, &[("use_spectral_mis", Boolean)]],
    ),
    plugin(
        "direct",
        &[
            SAMPLING,
            &[
                ("shading_samples", Integer),
                ("emitter_samples", Integer),
                ("bsdf_samples", Integer),
            ],
        ],
    ),
    plugin("depth", &[SAMPLING]),
    nesting("aov", &[SAMPLING, &[("aovs", Text)]]),
    nesting("moment", &[SAMPLING]),
    nesting("stokes", &[SAMPLING]),
    plugin("ptracer", &[&[("samples_per_pass", Integer)], PATHS]),
    plugin("prb", &[SAMPLING, PATHS]),
    plugin("prb_basic", &[SAMPLING, PATHS]),
    plugin("prbvolpath", &[SAMPLING, PATHS]),
    plugin("direct_projective", &[SAMPLING, PATHS, PROJECTIVE]),
    plugin("prb_projective", &[SAMPLING, PATHS, PROJECTIVE]),
    plugin(
        "volprim_rf_basic",
        &[SAMPLING, PATHS, &[("srgb_primitives", Boolean)]],
    ),
];

/// Read an `<integrator>`: its longest path ([`RenderHints::max_depth`](wavrad_core::scene::RenderHints::max_depth));
/// an error for a parameter its plugin does not read, a value of the wrong
/// type or a `max_depth` Mitsuba refuses; a warning in `doc` for each
/// setting wavrad does not honour.
pub(crate) fn check_integrator(integrator: Nested, doc: &Document) -> Result<Option<u32>> {
    let mut obj = Object::parse(integrator.element, doc)?;
    let Some(plugin) = PLUGINS.iter().find(|p| p.name == obj.plugin) else {
        let known: Vec<&str> = PLUGINS.iter().map(|p| p.name).collect();
        doc.warn(obj.at().warning(format!(
            "integrator \"{}\" is not one of Mitsuba 3's ({}); its parameters are not \
             checked, and wavrad solves for every bounce whatever it does",
            obj.plugin,
            known.join(", ")
        )));
        return Ok(None);
    };
    for &(name, kind) in std::iter::once(INTEGRATOR)
        .chain(plugin.reads.iter().copied())
        .flatten()
    {
        match kind {
            Integer => obj.integer(name).map(drop)?,
            Float => obj.float(name).map(drop)?,
            Boolean => obj.boolean(name).map(drop)?,
            Text => obj.string(name).map(drop)?,
        }
    }
    let mut nested_depth = None;
    for nested in &obj.nested {
        if !(plugin.nests && nested.tag() == "integrator") {
            return Err(obj.unexpected(nested));
        }
        let depth = check_integrator(*nested, doc)?;
        nested_depth = nested_depth.or(Some(depth));
    }
    obj.finish()?;
    let depth = longest_path(&mut obj, doc)?;
    Ok(nested_depth.unwrap_or(depth))
}

/// The longest path `obj` (its parameters checked) asks for, `None` for no
/// limit; the error for a `max_depth` Mitsuba refuses, and a warning for
/// each setting wavrad does not honour.
fn longest_path(obj: &mut Object, doc: &Document) -> Result<Option<u32>> {
    let max_depth = obj.integer("max_depth")?;
    let hide_emitters = obj.boolean("hide_emitters")?;
    let what = obj.describe();
    match max_depth {
        Some(d) if d < -1 => {
            return Err(obj.location_of("max_depth").error(format!(
                "max_depth = {d} of {what}: must be -1 (no limit) or at least 0, as in Mitsuba"
            )))
        }
        Some(d @ (0 | 1)) => {
            let mitsuba = match d {
                0 => "renders black",
                _ => "shows only the emitters seen directly",
            };
            doc.warn(obj.location_of("max_depth").warning(format!(
                "max_depth = {d} of {what} is not honoured: Mitsuba {mitsuba}, wavrad solves \
                 for every bounce (as max_depth = -1)"
            )));
        }
        _ => {}
    }
    let depth = match max_depth {
        _ if obj.plugin == "direct" => Some(2),
        Some(d) if (2..UNLIMITED_DEPTH).contains(&d) => u32::try_from(d).ok(),
        _ => None,
    };
    if hide_emitters == Some(true) {
        doc.warn(obj.location_of("hide_emitters").warning(format!(
            "hide_emitters of {what} is not honoured: wavrad shows the emitters seen directly"
        )));
    }
    Ok(depth)
}

/// The longest path of a scene without an integrator, `root`: none for a
/// Mitsuba 2 or 3 scene; for a `legacy` (0.x) one, 2, as Mitsuba 0.x's
/// default integrator `direct` (its `Scene::configure`), with a warning.
pub(crate) fn default_max_depth(legacy: bool, root: &Element, doc: &Document) -> Option<u32> {
    if !legacy {
        return None;
    }
    doc.warn(root.at.warning(
        "the scene has no <integrator>: rendered with direct lighting only, as Mitsuba 0.x \
         renders a scene without one (its default integrator \"direct\")",
    ));
    Some(2)
}
