//! BSDF plugins: `diffuse`, `ward`, `roughconductor`, `conductor`,
//! `roughplastic`, `plastic`, `principled` (its reflection), the glass
//! `dielectric` and `thindielectric` (not surfaces of the solve:
//! [`wavrad_core::scene::glass`]), `twosided` and `mask`. Colours are `<rgb>`,
//! `<float>` or `<spectrum value>`; reflectances must lie in [0, 1]. A
//! `diffuse` reflectance, and the `base_color` of a `principled` without
//! `metallic` and `spec_tint`, may be a texture (`checkerboard`, `bitmap`:
//! `mitsuba/textures.rs`).
//!
//! | plugin           | parameter                                        | type                 | default         |
//! |------------------|--------------------------------------------------|----------------------|-----------------|
//! | `diffuse`        | `reflectance`                                    | colour or texture    | 0.5             |
//! | `ward` (0.6)     | `variant`: `ward`, `ward-duer`, `balanced`       | `<string>`           | `balanced`      |
//! |                  | `alpha`; `alpha_u`/`alphaU`, `alpha_v`/`alphaV`  | `<float>` ≥ 1e-4     | 0.1; `alpha`    |
//! |                  | `specular_reflectance` (`specularReflectance`)   | colour               | 0.2             |
//! |                  | `diffuse_reflectance` (`diffuseReflectance`)     | colour, ρ_s + ρ_d ≤ 1 | 0.5            |
//! | `roughconductor` | `distribution`: `beckmann`, `ggx`                | `<string>`           | `beckmann`      |
//! |                  | `alpha`, or both `alpha_u` and `alpha_v`         | `<float>` ≥ 0        | 0.1             |
//! |                  | `material` (Mitsuba's names, e.g. `Au`, `Cu`)    | `<string>`           | `none` (mirror) |
//! |                  | `eta`, `k` (instead of `material`)               | colour ≥ 0           | 0, 1            |
//! |                  | `specular_reflectance`                           | colour               | 1               |
//! | `conductor`      | `material`, `eta`, `k`, `specular_reflectance`   | as above             | as above        |
//! | `roughplastic`   | `distribution`, `alpha` (isotropic only)         | as above             | `beckmann`, 0.1 |
//! |                  | `int_ior`, `ext_ior` (number or name, e.g. `bk7`) | `<float>`/`<string>` | `polypropylene`, `air` |
//! |                  | `specular_reflectance`, `diffuse_reflectance`    | colour               | 1, 0.5          |
//! |                  | `nonlinear`                                      | `<boolean>`          | false           |
//! | `plastic`        | `int_ior`, `ext_ior`, `specular_reflectance`, `diffuse_reflectance`, `nonlinear` | as above | as above |
//! | `principled`     | `base_color`                                     | colour               | 0.5             |
//! |                  | `roughness`, `anisotropic`, `metallic`, `specular` (or `eta`), `spec_tint` | `<float>` | 0.5, 0, 0, 0.5, 0 |
//! |                  | `clearcoat`, `clearcoat_gloss`, `sheen`, `sheen_tint` | `<float>`       | 0               |
//! |                  | `flatness`                                       | `<float>`            | 0               |
//! |                  | `spec_trans`: 0 (see below)                      | `<float>`            | 0               |
//! | `dielectric`     | `int_ior`, `ext_ior` (number or name)            | `<float>`/`<string>` | `bk7`, `air`    |
//! |                  | `specular_reflectance`, `specular_transmittance` | colour               | 1, 1            |
//! | `thindielectric` | as `dielectric`                                  | as above             | as above        |
//! | `roughdielectric` | as `dielectric`; `distribution`, `alpha` (or `alpha_u`, `alpha_v`) | as above | as above; `beckmann`, 0.1 |
//! | `twosided`       | one or two nested BSDFs (front, back)            |                      |                 |
//! | `mask`           | `opacity` 1 and one nested BSDF                  | `<float>`            | 1               |
//!
//! `sample_visible` is accepted when true (the only sampling wavrad has).
//! Mitsuba rescales a `ward` whose ρ_s + ρ_d exceeds 1; wavrad rejects it.
//! `plastic` and `conductor` are `roughplastic` and `roughconductor` at
//! Mitsuba's smallest roughness, 10⁻⁴ (ARCHITECTURE.md, "Smooth specular
//! and glass").
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
//! Mitsuba. Every other plugin, and a texture anywhere but on a `diffuse`
//! reflectance or the `base_color` of a `principled` without `metallic` and
//! `spec_tint`, is an error naming it and its line; with `--approximate`
//! ([`crate::LoadOptions`]) each is replaced, with one warning per plugin:
//!
//! | plugin                                          | replaced by                                              |
//! |-------------------------------------------------|----------------------------------------------------------|
//! | `roughdielectric` with `alpha_u` ≠ `alpha_v`     | isotropic, of roughness √(`alpha_u`·`alpha_v`)           |
//! | `principled` with 0 < `spec_trans` < 1, or 1 with `metallic`, `spec_tint` or `clearcoat` | its reflection ([`Principled`]) without the transmission: Burley's diffuse lobe of `base_color`·(1−`metallic`)·(1−`spec_trans`) plus its GGX lobe, clearcoat and sheen |
//! | `normalmap`, `bumpmap`                          | the nested BSDF, with the surface's own normals          |
//! | `mask` with `opacity` < 1 or textured           | the nested BSDF, opaque                                  |
//! | a texture on another parameter                  | the texture's mean                                       |
//! | a texture of another plugin                     | the parameter's default                                  |
//! | any other BSDF                                  | `diffuse` 0.5 (Mitsuba's default BSDF)                   |

use wavrad_core::scene::brdf::fresnel::{conductor_ior, dielectric_ior, CONDUCTORS, DIELECTRICS};
use wavrad_core::scene::brdf::principled::burley_albedo;
use wavrad_core::scene::brdf::{
    Brdf, Microfacet, MicrofacetType, Principled, PrincipledParams, RoughConductor, RoughPlastic,
    RoughPlasticParams, Ward, WardVariant,
};
use wavrad_core::scene::glass::Dielectric;
use wavrad_core::scene::Rgb;

use super::params::{Document, FloatOrString, Nested, Object};
use super::textures::{parse_texture, texture_mean};
use super::Location;
use crate::error::Result;

/// One side of a material: its BRDF and the texture on the albedo of its
/// Lambertian lobe (an index into the scene's textures).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Side {
    pub brdf: Brdf,
    pub texture: Option<u32>,
}

/// What a shape's surfaces are made of.
// One lives while a shape is read; boxing its sides would gain nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Material {
    /// Surfaces reflecting by `front`, and for `twosided` by `back` behind.
    Opaque { front: Side, back: Option<Side> },
    /// No surfaces of the solve: glass, which light passes and camera
    /// rays reflect and refract at ([`Dielectric`]).
    Glass(Dielectric),
}

impl Default for Material {
    /// Mitsuba's default for shapes without a BSDF: one-sided diffuse 0.5.
    fn default() -> Self {
        Material::opaque(Brdf::diffuse(Rgb::splat(0.5)))
    }
}

impl Material {
    fn opaque(brdf: Brdf) -> Material {
        Material::Opaque {
            front: Side {
                brdf,
                texture: None,
            },
            back: None,
        }
    }
}

/// How deep `twosided` (and references) may nest before we call it a cycle.
const MAX_NESTING: usize = 8;

/// The BSDF plugins wavrad reads, for messages.
const SUPPORTED: &str =
    "diffuse, twosided, ward, roughconductor, conductor, roughplastic, plastic, \
                         principled, dielectric, thindielectric, roughdielectric, mask (opaque)";

/// What `--approximate` puts in place of anisotropic rough glass.
const ANISOTROPIC_GLASS: &str = "isotropic, of roughness sqrt(alpha_u * alpha_v)";

/// What `--approximate` puts in place of a `principled` with the parts
/// wavrad does not model.
const PRINCIPLED: &str =
    "its reflection without it: Burley's diffuse lobe of base_color·(1−metallic)·(1−spec_trans) \
     plus its GGX specular lobe, clearcoat and sheen (as Mitsuba)";

/// Parameters of `principled` that change nothing wavrad computes: sampling
/// rates, which change the noise of Mitsuba's estimate, not its value.
const PRINCIPLED_IGNORED: [&str; 4] = [
    "diffuse_reflectance_sampling_rate",
    "specular_reflectance_sampling_rate",
    "spec_trans_sampling_rate",
    "clearcoat_sampling_rate",
];

/// Read the BSDF `bsdf` (a `<bsdf>` element, possibly reached by `<ref>`).
pub(crate) fn parse_bsdf(bsdf: Nested, doc: &Document) -> Result<Material> {
    parse_nested(bsdf, doc, 0)
}

fn parse_nested(bsdf: Nested, doc: &Document, depth: usize) -> Result<Material> {
    if depth > MAX_NESTING {
        return Err(bsdf
            .at
            .error("BSDFs nested too deeply (is there a <ref> cycle?)"));
    }
    let mut obj = Object::parse(bsdf.element, doc)?;
    let plugin = format!("bsdf \"{}\"", obj.plugin);
    match obj.plugin {
        "diffuse" => {
            let side = match albedo(&mut obj, "reflectance", 0.5, doc)? {
                Albedo::Constant(rho) => {
                    check_unit(&obj, "reflectance", rho)?;
                    Side {
                        brdf: Brdf::diffuse(rho),
                        texture: None,
                    }
                }
                Albedo::Texture(index) => Side {
                    brdf: Brdf::diffuse(doc.with_texture(index, texture_mean)),
                    texture: Some(index),
                },
            };
            one_sided(&obj, side.brdf.clone())?;
            Ok(Material::Opaque {
                front: side,
                back: None,
            })
        }
        "ward" => {
            let ward = parse_ward(&mut obj, doc)?;
            one_sided(&obj, Brdf::Ward(ward))
        }
        "roughconductor" | "conductor" => {
            let distribution = match obj.plugin {
                "roughconductor" => parse_microfacet(&mut obj)?,
                _ => Microfacet::isotropic(MicrofacetType::Beckmann, 0.0),
            };
            let conductor = parse_conductor(&mut obj, distribution, doc)?;
            one_sided(&obj, Brdf::RoughConductor(conductor))
        }
        "roughplastic" | "plastic" => {
            let params = parse_plastic(&mut obj, doc)?;
            one_sided(&obj, Brdf::RoughPlastic(RoughPlastic::new(params)))
        }
        "twosided" => {
            obj.finish()?;
            let mut sides = Vec::new();
            for n in &obj.nested {
                if n.tag() != "bsdf" {
                    return Err(obj.unexpected(n));
                }
                match parse_nested(*n, doc, depth + 1)? {
                    Material::Opaque { back: Some(_), .. } => {
                        return Err(n
                            .at
                            .error("a twosided BSDF cannot wrap another twosided BSDF"))
                    }
                    Material::Opaque { front, back: None } => sides.push(front),
                    Material::Glass(glass) => return Ok(Material::Glass(glass)),
                }
            }
            match sides.as_slice() {
                [both] => Ok(Material::Opaque {
                    front: both.clone(),
                    back: Some(both.clone()),
                }),
                [front, back] => Ok(Material::Opaque {
                    front: front.clone(),
                    back: Some(back.clone()),
                }),
                _ => Err(obj.at().error(format!(
                    "bsdf \"twosided\" needs one or two nested BSDFs, found {}",
                    sides.len()
                ))),
            }
        }
        "mask" => {
            // Opaque where opacity is 1 (Mitsuba's default); partial
            // opacity is approximated by the nested BSDF alone.
            let opaque = match obj.nested.iter().position(|n| n.name == Some("opacity")) {
                Some(i) => {
                    let n = obj.nested.remove(i);
                    doc.approximate(
                        n.at,
                        "bsdf \"mask\" with a textured opacity",
                        "its nested BSDF, opaque everywhere",
                    )?;
                    true
                }
                None => obj.float("opacity")?.unwrap_or(1.0) >= 1.0,
            };
            if !opaque {
                doc.approximate(
                    obj.location_of("opacity"),
                    "bsdf \"mask\" with opacity below 1",
                    "its nested BSDF, opaque",
                )?;
            }
            nested_only(obj, doc, depth)
        }
        "normalmap" | "bumpmap" => {
            doc.approximate(
                obj.at(),
                &plugin,
                "its nested BSDF, with the surface's own normals",
            )?;
            obj.nested.retain(|n| n.tag() == "bsdf");
            obj.ignore_all();
            nested_only(obj, doc, depth)
        }
        "dielectric" | "thindielectric" | "roughdielectric" => {
            let glass = parse_dielectric(&mut obj, doc)?;
            if let Some(n) = obj.nested.first() {
                return Err(obj.unexpected(n));
            }
            obj.finish()?;
            Ok(Material::Glass(glass))
        }
        "principled" => {
            let material = principled(&mut obj, doc)?;
            if let Some(n) = obj.nested.first() {
                return Err(obj.unexpected(n));
            }
            obj.finish()?;
            Ok(material)
        }
        other => {
            if doc.approximate {
                doc.approximate(obj.at(), &plugin, "diffuse 0.5 (Mitsuba's default BSDF)")?;
                return Ok(Material::default());
            }
            Err(obj.at().error(format!(
                "unsupported bsdf plugin \"{other}\" (supported: {SUPPORTED}; with \
                 --approximate: the nearest supported model)"
            )))
        }
    }
}

/// The one nested BSDF of a wrapper (`mask`, `normalmap`, `bumpmap`).
fn nested_only(obj: Object, doc: &Document, depth: usize) -> Result<Material> {
    obj.finish()?;
    match obj.nested.as_slice() {
        [n] if n.tag() == "bsdf" => parse_nested(*n, doc, depth + 1),
        [n] => Err(obj.unexpected(n)),
        _ => Err(obj.at().error(format!(
            "{} needs exactly one nested BSDF, found {}",
            obj.describe(),
            obj.nested.len()
        ))),
    }
}

/// Mitsuba 3's `principled`: its reflection as [`Principled`] (Burley's
/// diffuse lobe, its GGX specular lobe, clearcoat and sheen as Mitsuba
/// evaluates them), from `base_color`, `roughness`, `anisotropic`,
/// `metallic`, `specular` (or `eta`), `spec_tint`, `spec_trans`,
/// `clearcoat`, `clearcoat_gloss`, `sheen`, `sheen_tint` and `flatness`. A texture on
/// `base_color` of a surface without `metallic`, `spec_tint` and tinted
/// sheen is the texture of its diffuse lobe's albedo (as on a `diffuse`
/// reflectance); any other texture becomes its mean (with `--approximate`).
/// With `spec_trans` 1 and neither `metallic`, `spec_tint` nor `clearcoat`
/// it is glass ([`transmissive_principled`]); with any other `spec_trans`
/// above 0, the transmission it adds is dropped (with `--approximate`; an
/// error naming it without).
fn principled(obj: &mut Object, doc: &Document) -> Result<Material> {
    obj.ignore(&PRINCIPLED_IGNORED);
    let defaults = PrincipledParams::default();
    let eta = match obj.has("eta") {
        true => Some(constant_float(obj, "eta", 1.5, doc)?),
        false => None,
    };
    if let Some(eta) = eta.filter(|e| !(e.is_finite() && *e > 0.0)) {
        return Err(obj.location_of("eta").error(format!(
            "eta of bsdf \"principled\" must be positive, not {eta}"
        )));
    }
    let base_at = (obj.nested.iter())
        .find(|n| n.name == Some("base_color"))
        .map_or(obj.at(), |n| n.at);
    let base = albedo(obj, "base_color", 0.5, doc)?;
    let params = PrincipledParams {
        base_color: match base {
            Albedo::Constant(c) => c,
            Albedo::Texture(index) => doc.with_texture(index, texture_mean),
        },
        roughness: constant_float(obj, "roughness", defaults.roughness, doc)?,
        anisotropic: constant_float(obj, "anisotropic", defaults.anisotropic, doc)?,
        metallic: constant_float(obj, "metallic", defaults.metallic, doc)?,
        specular: constant_float(obj, "specular", defaults.specular, doc)?,
        eta,
        spec_tint: constant_float(obj, "spec_tint", defaults.spec_tint, doc)?,
        spec_trans: constant_float(obj, "spec_trans", defaults.spec_trans, doc)?,
        clearcoat: constant_float(obj, "clearcoat", defaults.clearcoat, doc)?,
        clearcoat_gloss: constant_float(obj, "clearcoat_gloss", defaults.clearcoat_gloss, doc)?,
        sheen: constant_float(obj, "sheen", defaults.sheen, doc)?,
        sheen_tint: constant_float(obj, "sheen_tint", defaults.sheen_tint, doc)?,
        flatness: constant_float(obj, "flatness", defaults.flatness, doc)?,
    };
    if params.spec_trans >= 1.0
        && params.metallic <= 0.0
        && params.spec_tint <= 0.0
        && params.clearcoat <= 0.0
    {
        return transmissive_principled(params, (base, base_at), doc);
    }
    if params.spec_trans > 0.0 {
        let plugin = "bsdf \"principled\" with specular transmission";
        doc.approximate(obj.at(), plugin, PRINCIPLED)?;
    }
    let principled = Principled::new(params);
    let texture = match base {
        Albedo::Constant(_) => None,
        // Without metallic and spec_tint the base colours only the diffuse
        // lobe: its texture is that lobe's albedo, scaled as the lobe is.
        Albedo::Texture(index)
            if principled.metallic == 0.0
                && principled.spec_tint == 0.0
                && (params.sheen <= 0.0 || params.sheen_tint <= 0.0) =>
        {
            let weight = (1.0 - params.spec_trans.clamp(0.0, 1.0))
                * burley_albedo(principled.roughness, principled.flatness);
            let scaled = doc.with_texture(index, |t| t.scaled(Rgb::splat(weight)));
            Some(doc.add_texture(scaled))
        }
        Albedo::Texture(_) => {
            let what = "a texture on base_color of a metallic or tinted bsdf \"principled\"";
            doc.approximate(base_at, what, "its mean value")?;
            None
        }
    };
    Ok(Material::Opaque {
        front: Side {
            brdf: Brdf::Principled(principled),
            texture,
        },
        back: None,
    })
}

/// A `principled` whose base all transmits (`spec_trans` 1), neither
/// metallic nor tinted and without clearcoat, as the glass it is: Mitsuba
/// 3's `principled` then has no diffuse lobe (nor sheen), and its specular
/// reflection and transmission are a `roughdielectric`'s of GGX roughness
/// α = max(0.001, `roughness`²) (made isotropic of √(α_u·α_v), with
/// `--approximate`, where `anisotropic` is above 0) whose transmission is
/// tinted by √`base_color` (its mean, with `--approximate`, where
/// textured).
fn transmissive_principled(
    params: PrincipledParams,
    (base, base_at): (Albedo, &Location),
    doc: &Document,
) -> Result<Material> {
    let model = Principled::new(params);
    if let Albedo::Texture(_) = base {
        let what = "a texture on base_color of a transmissive bsdf \"principled\"";
        doc.approximate(base_at, what, "its mean value")?;
    }
    let (au, av) = (model.distribution.alpha_u, model.distribution.alpha_v);
    if au != av {
        let what = "bsdf \"principled\" with spec_trans 1 and anisotropic";
        doc.approximate(base_at, what, ANISOTROPIC_GLASS)?;
    }
    Ok(Material::Glass(Dielectric {
        eta: model.eta,
        thin: false,
        reflectance: Rgb::splat(1.0),
        transmittance: model.base_color.map(f64::sqrt),
        roughness: Some(Microfacet::isotropic(MicrofacetType::Ggx, (au * av).sqrt())),
    }))
}

/// A reflectance given as a colour or as a texture.
enum Albedo {
    Constant(Rgb),
    Texture(u32),
}

/// The nested object given for parameter `name`, taken out of `obj`'s list.
fn take_named<'a>(obj: &mut Object<'a>, name: &str) -> Option<Nested<'a>> {
    let i = obj.nested.iter().position(|n| n.name == Some(name))?;
    Some(obj.nested.remove(i))
}

/// Parameter `name` as a colour or a texture (`<texture name=...>` nested or
/// referenced); a texture of a plugin wavrad does not read is refused, or
/// with `--approximate` replaced by the default.
fn albedo(obj: &mut Object, name: &'static str, default: f64, doc: &Document) -> Result<Albedo> {
    let Some(n) = take_named(obj, name) else {
        return Ok(Albedo::Constant(
            obj.color(name)?.unwrap_or(Rgb::splat(default)),
        ));
    };
    if n.tag() != "texture" {
        return Err(obj.unexpected(&n));
    }
    if obj.has(name) {
        return Err(n
            .at
            .error(format!("{name} of {} given twice", obj.describe())));
    }
    if !["checkerboard", "bitmap"].contains(&n.plugin()) && doc.approximate {
        let plugin = format!("texture \"{}\"", n.plugin());
        doc.approximate(n.at, &plugin, &format!("the constant {default}"))?;
        return Ok(Albedo::Constant(Rgb::splat(default)));
    }
    Ok(Albedo::Texture(parse_texture(n, doc)?))
}

/// Parameter `name` as a colour; a texture is refused, or with
/// `--approximate` replaced by its mean.
fn constant_color(
    obj: &mut Object,
    name: &'static str,
    default: f64,
    doc: &Document,
) -> Result<Rgb> {
    let given = obj.nested.iter().find(|n| n.name == Some(name));
    let at = given.map_or(obj.at(), |n| n.at);
    match albedo(obj, name, default, doc)? {
        Albedo::Constant(c) => Ok(c),
        Albedo::Texture(index) => {
            let what = format!("a texture on {name} of {}", obj.describe());
            doc.approximate(at, &what, "its mean value")?;
            Ok(doc.with_texture(index, texture_mean))
        }
    }
}

/// Parameter `name` as a float; a texture is as in [`constant_color`].
fn constant_float(
    obj: &mut Object,
    name: &'static str,
    default: f64,
    doc: &Document,
) -> Result<f64> {
    if obj.nested.iter().any(|n| n.name == Some(name)) {
        return Ok(constant_color(obj, name, default, doc)?.average());
    }
    Ok(obj.float(name)?.unwrap_or(default))
}

/// A one-sided material from a plugin that takes no nested objects.
fn one_sided(obj: &Object, brdf: Brdf) -> Result<Material> {
    if let Some(n) = obj.nested.first() {
        return Err(obj.unexpected(n));
    }
    obj.finish()?;
    Ok(Material::opaque(brdf))
}

/// Reject a reflectance with a component outside [0, 1].
fn check_unit(obj: &Object, name: &str, value: Rgb) -> Result<()> {
    match value.0.iter().find(|c| !(0.0..=1.0).contains(*c)) {
        None => Ok(()),
        Some(c) => Err(obj.location_of(name).error(format!(
            "{name} {value} of {} has a component ({c}) outside [0, 1]",
            obj.describe()
        ))),
    }
}

/// A colour under its Mitsuba 3 name or its Mitsuba 0.6 camelCase alias
/// (a texture as in [`constant_color`]); returns the value and the name it
/// was given under.
fn color_alias(
    obj: &mut Object,
    (name, alias): (&'static str, &'static str),
    default: f64,
    doc: &Document,
) -> Result<(Rgb, &'static str)> {
    for n in [name, alias] {
        if obj.nested.iter().any(|x| x.name == Some(n)) {
            return Ok((constant_color(obj, n, default, doc)?, n));
        }
    }
    both_not_allowed(obj, name, alias)?;
    Ok(match (obj.color(name)?, obj.color(alias)?) {
        (Some(v), _) => (v, name),
        (None, Some(v)) => (v, alias),
        (None, None) => (Rgb::splat(default), name),
    })
}

/// A float under its Mitsuba 3 name or its Mitsuba 0.6 alias.
fn float_alias(obj: &mut Object, name: &'static str, alias: &'static str) -> Result<Option<f64>> {
    both_not_allowed(obj, name, alias)?;
    Ok(obj.float(name)?.or(obj.float(alias)?))
}

fn both_not_allowed(obj: &Object, a: &str, b: &str) -> Result<()> {
    if obj.has(a) && obj.has(b) {
        return Err(obj.location_of(b).error(format!(
            "{} takes \"{a}\" or \"{b}\", not both",
            obj.describe()
        )));
    }
    Ok(())
}

/// Smallest roughness of `ward`: its lobe divides by αu·αv and their
/// squares, which overflow long before α reaches 0; smaller is a mirror,
/// and Mitsuba 3 clamps its microfacet roughness to the same 1e-4.
const MIN_WARD_ALPHA: f64 = 1e-4;

/// Roughness `name` must be non-negative, or when `strict` (ward) at least
/// [`MIN_WARD_ALPHA`].
fn check_alpha(obj: &Object, name: &str, alpha: f64, strict: bool) -> Result<f64> {
    if alpha < 0.0 || (strict && alpha < MIN_WARD_ALPHA) {
        let bound = if strict {
            format!("positive, at least {MIN_WARD_ALPHA:e} (smaller is a mirror)")
        } else {
            "non-negative".to_string()
        };
        // Tiny and huge values in scientific notation, not 300 digits.
        let shown = if alpha == 0.0 || (1e-3..1e6).contains(&alpha.abs()) {
            alpha.to_string()
        } else {
            format!("{alpha:e}")
        };
        return Err(obj.location_of(name).error(format!(
            "roughness {name} = {shown} of {} must be {bound}",
            obj.describe()
        )));
    }
    Ok(alpha)
}

fn parse_ward(obj: &mut Object, doc: &Document) -> Result<Ward> {
    let variant = match obj.string("variant")? {
        None => WardVariant::Balanced,
        Some(v) => WardVariant::from_name(&v).ok_or_else(|| {
            obj.location_of("variant").error(format!(
                "unknown variant \"{v}\" of {} (known: ward, ward-duer, balanced)",
                obj.describe()
            ))
        })?,
    };
    let alpha = obj.float("alpha")?.unwrap_or(0.1);
    check_alpha(obj, "alpha", alpha, true)?;
    let alpha_u = float_alias(obj, "alpha_u", "alphaU")?.unwrap_or(alpha);
    let alpha_v = float_alias(obj, "alpha_v", "alphaV")?.unwrap_or(alpha);
    let name_u = if obj.has("alphaU") {
        "alphaU"
    } else {
        "alpha_u"
    };
    let name_v = if obj.has("alphaV") {
        "alphaV"
    } else {
        "alpha_v"
    };
    check_alpha(obj, name_u, alpha_u, true)?;
    check_alpha(obj, name_v, alpha_v, true)?;
    let specular = ("specular_reflectance", "specularReflectance");
    let (spec, spec_name) = color_alias(obj, specular, 0.2, doc)?;
    let diffuse = ("diffuse_reflectance", "diffuseReflectance");
    let (diff, diff_name) = color_alias(obj, diffuse, 0.5, doc)?;
    check_unit(obj, spec_name, spec)?;
    check_unit(obj, diff_name, diff)?;
    if let Some(c) = (0..3).find(|&c| spec[c] + diff[c] > 1.0) {
        return Err(obj.location_of(diff_name).error(format!(
            "{spec_name} + {diff_name} of {} exceed 1 in channel {c} ({} + {}): the BRDF \
             would create energy (Mitsuba rescales it; scale them down instead)",
            obj.describe(),
            spec[c],
            diff[c]
        )));
    }
    Ok(Ward {
        variant,
        alpha_u,
        alpha_v,
        specular_reflectance: spec,
        diffuse_reflectance: diff,
    })
}

/// `distribution`, `alpha` / `alpha_u` + `alpha_v` and `sample_visible` of
/// Mitsuba 3's microfacet plugins.
fn parse_microfacet(obj: &mut Object) -> Result<Microfacet> {
    let kind = match obj.string("distribution")? {
        None => MicrofacetType::Beckmann,
        Some(d) => MicrofacetType::from_name(&d).ok_or_else(|| {
            obj.location_of("distribution").error(format!(
                "unknown distribution \"{d}\" of {} (known: beckmann, ggx)",
                obj.describe()
            ))
        })?,
    };
    if obj.boolean("sample_visible")? == Some(false) {
        return Err(obj.location_of("sample_visible").error(format!(
            "sample_visible = false of {} is not supported (wavrad samples visible normals)",
            obj.describe()
        )));
    }
    let has_u = obj.has("alpha_u");
    let alpha = obj.float("alpha")?;
    let alpha_u = obj.float("alpha_u")?;
    let alpha_v = obj.float("alpha_v")?;
    let (au, av) = match (alpha, alpha_u, alpha_v) {
        (Some(_), Some(_), _) | (Some(_), _, Some(_)) => {
            let name = if has_u { "alpha_u" } else { "alpha_v" };
            return Err(obj.location_of(name).error(format!(
                "{} takes either \"alpha\" or \"alpha_u\"/\"alpha_v\", not both",
                obj.describe()
            )));
        }
        (_, Some(u), Some(v)) => (u, v),
        (None, Some(_), None) | (None, None, Some(_)) => {
            let name = if has_u { "alpha_u" } else { "alpha_v" };
            return Err(obj.location_of(name).error(format!(
                "{} needs both \"alpha_u\" and \"alpha_v\"",
                obj.describe()
            )));
        }
        (a, None, None) => (a.unwrap_or(0.1), a.unwrap_or(0.1)),
    };
    let (name_u, name_v) = if has_u {
        ("alpha_u", "alpha_v")
    } else {
        ("alpha", "alpha")
    };
    check_alpha(obj, name_u, au, false)?;
    check_alpha(obj, name_v, av, false)?;
    Ok(Microfacet::new(kind, au, av))
}

/// The optics of `conductor` and `roughconductor` over `distribution`.
fn parse_conductor(
    obj: &mut Object,
    distribution: Microfacet,
    doc: &Document,
) -> Result<RoughConductor> {
    let material = obj.string("material")?;
    let (eta, k) = (obj.unbounded_color("eta")?, obj.unbounded_color("k")?);
    let ior = match material.as_deref() {
        Some(m) if m != "none" => {
            if eta.is_some() || k.is_some() {
                let name = if eta.is_some() { "eta" } else { "k" };
                return Err(obj.location_of(name).error(format!(
                    "{} takes either \"material\" or \"eta\"/\"k\", not both",
                    obj.describe()
                )));
            }
            conductor_ior(m).ok_or_else(|| {
                let known: Vec<&str> = CONDUCTORS.iter().map(|c| c.0).collect();
                obj.location_of("material").error(format!(
                    "unknown conductor material \"{m}\" of {} (known: none, {})",
                    obj.describe(),
                    known.join(", ")
                ))
            })?
        }
        _ => {
            let mut ior = conductor_ior("none").expect("the default conductor");
            ior.eta = eta.unwrap_or(ior.eta);
            ior.k = k.unwrap_or(ior.k);
            ior
        }
    };
    for (name, v) in [("eta", ior.eta), ("k", ior.k)] {
        if let Some(c) = v.0.iter().find(|c| **c < 0.0) {
            return Err(obj.location_of(name).error(format!(
                "{name} {v} of {} has a negative component ({c})",
                obj.describe()
            )));
        }
    }
    let specular_reflectance = constant_color(obj, "specular_reflectance", 1.0, doc)?;
    check_unit(obj, "specular_reflectance", specular_reflectance)?;
    Ok(RoughConductor {
        distribution,
        eta: ior.eta,
        k: ior.k,
        specular_reflectance,
    })
}

/// An index of refraction given by value or by one of Mitsuba's names.
fn parse_ior(obj: &mut Object, name: &'static str, default: f64) -> Result<f64> {
    let ior = match obj.float_or_string(name)? {
        None => default,
        Some(FloatOrString::Float(v)) => v,
        Some(FloatOrString::String(s)) => dielectric_ior(&s).ok_or_else(|| {
            let known: Vec<&str> = DIELECTRICS.iter().map(|d| d.0).collect();
            obj.location_of(name).error(format!(
                "unknown {name} \"{s}\" of {} (known: {})",
                obj.describe(),
                known.join(", ")
            ))
        })?,
    };
    if ior <= 0.0 {
        return Err(obj.location_of(name).error(format!(
            "{name} = {ior} of {} must be positive",
            obj.describe()
        )));
    }
    Ok(ior)
}

/// `dielectric`, `thindielectric` or `roughdielectric`: Mitsuba's
/// defaults, BK7 glass in air. An anisotropic `roughdielectric` is made
/// isotropic (with `--approximate`), of roughness √(α_u·α_v): glass faces
/// carry no tangents.
fn parse_dielectric(obj: &mut Object, doc: &Document) -> Result<Dielectric> {
    let roughness = match obj.plugin {
        "roughdielectric" => {
            let distribution = parse_microfacet(obj)?;
            let (au, av) = (distribution.alpha_u, distribution.alpha_v);
            if au != av {
                let at = obj.location_of("alpha_u").clone();
                let plugin = "bsdf \"roughdielectric\" with alpha_u and alpha_v unequal";
                doc.approximate(&at, plugin, ANISOTROPIC_GLASS)?;
            }
            Some(Microfacet::isotropic(distribution.kind, (au * av).sqrt()))
        }
        _ => None,
    };
    let int_ior = parse_ior(obj, "int_ior", 1.5046)?;
    let ext_ior = parse_ior(obj, "ext_ior", 1.000277)?;
    let reflectance = constant_color(obj, "specular_reflectance", 1.0, doc)?;
    let transmittance = constant_color(obj, "specular_transmittance", 1.0, doc)?;
    check_unit(obj, "specular_reflectance", reflectance)?;
    check_unit(obj, "specular_transmittance", transmittance)?;
    Ok(Dielectric {
        eta: int_ior / ext_ior,
        thin: obj.plugin == "thindielectric",
        reflectance,
        transmittance,
        roughness,
    })
}

/// `roughplastic`, or `plastic` as its smooth limit (Mitsuba's smallest
/// roughness, [`wavrad_core::scene::brdf::microfacet::MIN_ALPHA`]).
fn parse_plastic(obj: &mut Object, doc: &Document) -> Result<RoughPlasticParams> {
    let distribution = match obj.plugin {
        "roughplastic" => parse_microfacet(obj)?,
        _ => Microfacet::isotropic(MicrofacetType::Beckmann, 0.0),
    };
    if distribution.alpha_u != distribution.alpha_v {
        return Err(obj.location_of("alpha_u").error(format!(
            "{} is isotropic only (as in Mitsuba): alpha_u and alpha_v must be equal",
            obj.describe()
        )));
    }
    let int_ior = parse_ior(obj, "int_ior", 1.49)?;
    let ext_ior = parse_ior(obj, "ext_ior", 1.000277)?;
    if int_ior == ext_ior {
        return Err(obj.location_of("int_ior").error(format!(
            "int_ior and ext_ior of {} must differ (both {int_ior})",
            obj.describe()
        )));
    }
    let specular_reflectance = constant_color(obj, "specular_reflectance", 1.0, doc)?;
    let diffuse_reflectance = constant_color(obj, "diffuse_reflectance", 0.5, doc)?;
    check_unit(obj, "specular_reflectance", specular_reflectance)?;
    check_unit(obj, "diffuse_reflectance", diffuse_reflectance)?;
    Ok(RoughPlasticParams {
        distribution: distribution.kind,
        alpha: distribution.alpha_u,
        int_ior,
        ext_ior,
        specular_reflectance,
        diffuse_reflectance,
        nonlinear: obj.boolean("nonlinear")?.unwrap_or(false),
    })
}
