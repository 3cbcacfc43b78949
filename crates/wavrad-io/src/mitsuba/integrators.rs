//! The `integrator`: any of Mitsuba 3's plugins is accepted, since wavrad
//! solves the scene its own way (every bounce, view-independent). Each
//! plugin's parameters are checked as Mitsuba checks them: a name the
//! plugin does not read is an error listing those it does, a value of the
//! wrong type too. Its settings that would change Mitsuba's image are not
//! honoured, and each one set is a warning:
//!
//! | parameter       | type        | Mitsuba's meaning                              | wavrad |
//! |-----------------|-------------|------------------------------------------------|--------|
//! | `max_depth`     | `<integer>` | longest path: 1 emitters seen directly, 2 direct lighting, … ; −1 no limit (default) | every bounce; a warning below [`UNLIMITED_DEPTH`] |
//! | `hide_emitters` | `<boolean>` | emitters seen directly are black               | shown; a warning when true |
//!
//! The `direct` integrator (direct lighting only, as `max_depth` 2) is a
//! warning too. Every other parameter (`rr_depth`, `timeout`, sample counts
//! of `direct`, …: [`PLUGINS`]) changes only the noise or the speed of
//! Mitsuba's image and is ignored. The integrators that nest others (`aov`,
//! `moment`, `stokes`) have theirs checked the same way. A plugin Mitsuba 3
//! does not ship (one registered from Python, say) is a warning, its
//! parameters unchecked.
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

/// Read an `<integrator>`: an error for a parameter its plugin does not
/// read, a value of the wrong type or a `max_depth` Mitsuba refuses; a
/// warning in `doc` for each setting wavrad does not honour.
pub(crate) fn check_integrator(integrator: Nested, doc: &Document) -> Result<()> {
    let mut obj = Object::parse(integrator.element, doc)?;
    let Some(plugin) = PLUGINS.iter().find(|p| p.name == obj.plugin) else {
        let known: Vec<&str> = PLUGINS.iter().map(|p| p.name).collect();
        doc.warn(obj.at().warning(format!(
            "integrator \"{}\" is not one of Mitsuba 3's ({}); its parameters are not \
             checked, and wavrad solves for every bounce whatever it does",
            obj.plugin,
            known.join(", ")
        )));
        return Ok(());
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
    for nested in &obj.nested {
        if !(plugin.nests && nested.tag() == "integrator") {
            return Err(obj.unexpected(nested));
        }
        check_integrator(*nested, doc)?;
    }
    obj.finish()?;
    warn_unhonoured(&mut obj, doc)
}

/// The error for a `max_depth` Mitsuba refuses, and a warning for each
/// setting of `obj` (its parameters checked) that wavrad does not honour.
fn warn_unhonoured(obj: &mut Object, doc: &Document) -> Result<()> {
    let max_depth = obj.integer("max_depth")?;
    let hide_emitters = obj.boolean("hide_emitters")?;
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
