//! BSDF plugins: `diffuse` and `twosided`.
//!
//! | plugin     | parameter     | type                                   | default |
//! |------------|---------------|----------------------------------------|---------|
//! | `diffuse`  | `reflectance` | `<rgb>`, `<float>`, `<spectrum value>` | 0.5     |
//! | `twosided` | one or two nested BSDFs (front, back)                ||         |
//!
//! ```xml
//! <bsdf type="twosided" id="white">
//!     <bsdf type="diffuse">
//!         <rgb name="reflectance" value="0.885809, 0.698859, 0.666422"/>
//!     </bsdf>
//! </bsdf>
//! ```
//!
//! Without `twosided` a surface reflects on its front side only, as in
//! Mitsuba. Textures and every other plugin are rejected.

use wavrad_core::brdf::Brdf;

use super::params::{Ids, Nested, Object};
use crate::error::Result;

/// The BRDF of the front side and, for `twosided`, of the back.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Material {
    pub front: Brdf,
    pub back: Option<Brdf>,
}

impl Default for Material {
    /// Mitsuba's default for shapes without a BSDF: one-sided diffuse 0.5.
    fn default() -> Self {
        Material {
            front: Brdf::diffuse([0.5; 3]),
            back: None,
        }
    }
}

/// How deep `twosided` (and references) may nest before we call it a cycle.
const MAX_NESTING: usize = 8;

/// Read the BSDF `bsdf` (a `<bsdf>` element, possibly reached by `<ref>`).
pub(crate) fn parse_bsdf(bsdf: Nested, ids: &Ids) -> Result<Material> {
    parse_nested(bsdf, ids, 0)
}

fn parse_nested(bsdf: Nested, ids: &Ids, depth: usize) -> Result<Material> {
    if depth > MAX_NESTING {
        return Err(bsdf
            .at
            .error("BSDFs nested too deeply (is there a <ref> cycle?)"));
    }
    let mut obj = Object::parse(bsdf.element, ids)?;
    match obj.plugin {
        "diffuse" => {
            let reflectance = obj.color("reflectance")?.unwrap_or([0.5; 3]);
            if let Some(c) = reflectance.iter().find(|c| !(0.0..=1.0).contains(*c)) {
                return Err(obj.location_of("reflectance").error(format!(
                    "reflectance {reflectance:?} of {} has a component ({c}) outside [0, 1]",
                    obj.describe()
                )));
            }
            if let Some(n) = obj.nested.first() {
                return Err(obj.unexpected(n));
            }
            obj.finish()?;
            Ok(Material {
                front: Brdf::diffuse(reflectance),
                back: None,
            })
        }
        "twosided" => {
            obj.finish()?;
            let mut sides = Vec::new();
            for n in &obj.nested {
                if n.tag() != "bsdf" {
                    return Err(obj.unexpected(n));
                }
                let side = parse_nested(*n, ids, depth + 1)?;
                if side.back.is_some() {
                    return Err(n
                        .at
                        .error("a twosided BSDF cannot wrap another twosided BSDF"));
                }
                sides.push(side.front);
            }
            match sides.as_slice() {
                [both] => Ok(Material {
                    front: both.clone(),
                    back: Some(both.clone()),
                }),
                [front, back] => Ok(Material {
                    front: front.clone(),
                    back: Some(back.clone()),
                }),
                _ => Err(obj.at().error(format!(
                    "bsdf \"twosided\" needs one or two nested BSDFs, found {}",
                    sides.len()
                ))),
            }
        }
        other => Err(obj.at().error(format!(
            "unsupported bsdf plugin \"{other}\" (supported: diffuse, twosided)"
        ))),
    }
}
