//! Objects and their typed parameters: `<float>`, `<integer>`, `<boolean>`,
//! `<string>`, `<point>`, `<vector>`, `<rgb>`, `<spectrum>`
//! (`mitsuba/spectrum.rs`), `<transform>`, and nested objects (directly or
//! through `<ref>`), read in the [`Document`] that holds them.
//!
//! A plugin asks for each parameter it knows by name; [`Object::finish`]
//! then rejects whatever was left unasked, so an unknown or misspelled
//! parameter is an error naming the plugin, the parameter and its line.

use std::cell::RefCell;
use std::collections::{BTreeSet, HashMap};

use glam::{DMat4, DVec3};
use wavrad_core::scene::texture::Texture;
use wavrad_core::scene::Rgb;

use super::document::{read_text_file, Element, Location, SearchPath};
use super::spectrum::{ColorRole, Spectrum};
use super::transform::parse_transform;
use super::Warning;
use crate::error::Result;

/// The expanded scene as its objects see it: every object with an `id`,
/// where relative file names are looked up, and the warnings so far.
#[derive(Debug)]
pub(crate) struct Document<'a> {
    ids: HashMap<&'a str, &'a Element>,
    /// Where relative file names (meshes, spectra) are looked up.
    pub search: SearchPath,
    warnings: RefCell<Vec<Warning>>,
    /// Whether unsupported plugins are replaced by the nearest supported
    /// model (`--approximate`) rather than refused.
    pub approximate: bool,
    /// The plugins approximated so far (each is warned about once).
    approximated: RefCell<BTreeSet<String>>,
    /// The textures read so far, and the element each came from.
    textures: RefCell<(Vec<Texture>, HashMap<*const Element, u32>)>,
}

impl<'a> Document<'a> {
    /// The document below `root`: every element with an `id` (but `<ref>`s)
    /// indexed; a repeated id is an error.
    pub fn new(root: &'a Element, search: SearchPath) -> Result<Document<'a>> {
        fn walk<'a>(e: &'a Element, ids: &mut HashMap<&'a str, &'a Element>) -> Result<()> {
            for child in &e.children {
                if child.tag != "ref" {
                    if let Some(id) = child.attr("id") {
                        if let Some(first) = ids.insert(id, child) {
                            return Err(child.at.error(format!(
                                "duplicate id \"{id}\" (first defined at {})",
                                first.at
                            )));
                        }
                    }
                }
                walk(child, ids)?;
            }
            Ok(())
        }
        let mut ids = HashMap::new();
        walk(root, &mut ids)?;
        Ok(Document {
            ids,
            search,
            warnings: RefCell::new(Vec::new()),
            approximate: false,
            approximated: RefCell::new(BTreeSet::new()),
            textures: RefCell::new((Vec::new(), HashMap::new())),
        })
    }

    /// Record something loaded, but not as written.
    pub fn warn(&self, warning: Warning) {
        self.warnings.borrow_mut().push(warning);
    }

    /// The warnings, in the order they were made.
    pub fn into_warnings(self) -> Vec<Warning> {
        self.warnings.into_inner()
    }

    /// Replace the unsupported `plugin` at `at` as `substitute` says when
    /// approximating, with one warning per plugin; otherwise the error
    /// naming it and suggesting `--approximate`.
    pub fn approximate(&self, at: &Location, plugin: &str, substitute: &str) -> Result<()> {
        if !self.approximate {
            return Err(at.error(format!(
                "{plugin} is not supported (with --approximate: {substitute})"
            )));
        }
        if self.approximated.borrow_mut().insert(plugin.to_string()) {
            self.warn(at.warning(format!("approximated {plugin}: {substitute}")));
        }
        Ok(())
    }

    /// The index of the texture read from `element`, read by `read` on its
    /// first use.
    pub fn texture_index(
        &self,
        element: &Element,
        read: impl FnOnce() -> Result<Texture>,
    ) -> Result<u32> {
        let key = std::ptr::from_ref(element);
        if let Some(&index) = self.textures.borrow().1.get(&key) {
            return Ok(index);
        }
        let texture = read()?;
        let mut textures = self.textures.borrow_mut();
        let index = textures.0.len() as u32;
        textures.0.push(texture);
        textures.1.insert(key, index);
        Ok(index)
    }

    /// `f` of the texture at `index` ([`Document::texture_index`]).
    pub fn with_texture<R>(&self, index: u32, f: impl FnOnce(&Texture) -> R) -> R {
        f(&self.textures.borrow().0[index as usize])
    }

    /// The index of `texture`, made here rather than read (a texture
    /// read, scaled).
    pub fn add_texture(&self, texture: Texture) -> u32 {
        let mut textures = self.textures.borrow_mut();
        textures.0.push(texture);
        (textures.0.len() - 1) as u32
    }

    /// Every texture read, in the order of their indices.
    pub fn take_textures(&self) -> Vec<Texture> {
        std::mem::take(&mut self.textures.borrow_mut().0)
    }
}

/// Tags of objects wavrad can meet nested in other objects.
const OBJECT_TAGS: &[&str] = &[
    "shape",
    "bsdf",
    "emitter",
    "sensor",
    "film",
    "rfilter",
    "sampler",
    "integrator",
    "texture",
];

/// Tags of Mitsuba objects wavrad rejects, with the reason.
const UNSUPPORTED_TAGS: &[(&str, &str)] = &[
    ("medium", "participating media are not supported"),
    ("phase", "participating media are not supported"),
    ("volume", "volumes are not supported"),
];

/// A parameter value.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Value {
    Float(f64),
    Integer(i64),
    Boolean(bool),
    String(String),
    Point(DVec3),
    Vector(DVec3),
    Rgb(Rgb),
    Spectrum(Spectrum),
    Transform(DMat4),
}

impl Value {
    fn tag(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Integer(_) => "integer",
            Value::Boolean(_) => "boolean",
            Value::String(_) => "string",
            Value::Point(_) => "point",
            Value::Vector(_) => "vector",
            Value::Rgb(_) => "rgb",
            Value::Spectrum(_) => "spectrum",
            Value::Transform(_) => "transform",
        }
    }
}

/// A parameter that may be a number or a name.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum FloatOrString {
    Float(f64),
    String(String),
}

#[derive(Debug)]
struct Property {
    name: String,
    value: Value,
    at: Location,
    used: bool,
}

/// An object nested in another, directly or through `<ref>`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Nested<'a> {
    /// The object's element (the target, for a `<ref>`).
    pub element: &'a Element,
    /// Where it is used: the `<ref>` or the element itself.
    pub at: &'a Location,
    /// The parameter it is given for (`name`, on the `<ref>` or the
    /// element), as a texture is.
    pub name: Option<&'a str>,
}

impl<'a> Nested<'a> {
    /// `shape`, `bsdf`, …
    pub fn tag(&self) -> &'a str {
        &self.element.tag
    }

    /// The plugin name (`type` attribute), empty if absent.
    pub fn plugin(&self) -> &'a str {
        self.element.attr("type").unwrap_or("")
    }
}

/// One object (`<shape type="rectangle">`, …) with its parameters parsed.
#[derive(Debug)]
pub(crate) struct Object<'a> {
    /// `shape`, `bsdf`, …
    pub tag: &'a str,
    /// The `type` attribute.
    pub plugin: &'a str,
    /// The element.
    pub element: &'a Element,
    /// Nested objects, in document order.
    pub nested: Vec<Nested<'a>>,
    props: Vec<Property>,
    known: Vec<&'static str>,
    doc: &'a Document<'a>,
}

impl<'a> Object<'a> {
    /// Parse `element` (an object tag) and its children. `<ref>`s resolve
    /// through `doc`.
    pub fn parse(element: &'a Element, doc: &'a Document<'a>) -> Result<Object<'a>> {
        let plugin = if element.tag == "scene" {
            "scene"
        } else {
            element.check_attrs(&["type", "id", "name"])?;
            element.required_attr("type")?
        };
        let mut object = Object {
            tag: &element.tag,
            plugin,
            element,
            nested: Vec::new(),
            props: Vec::new(),
            known: Vec::new(),
            doc,
        };
        for child in &element.children {
            let tag = child.tag.as_str();
            if tag == "ref" {
                child.check_attrs(&["id", "name"])?;
                let id = child.required_attr("id")?;
                let target = doc
                    .ids
                    .get(id)
                    .copied()
                    .ok_or_else(|| child.at.error(format!("<ref> to unknown id \"{id}\"")))?;
                if let Some((_, why)) = UNSUPPORTED_TAGS.iter().find(|(t, _)| *t == target.tag) {
                    return Err(child
                        .at
                        .error(format!("<ref id=\"{id}\"> names a <{}>: {why}", target.tag)));
                }
                object.nested.push(Nested {
                    element: target,
                    at: &child.at,
                    name: child.attr("name").or(target.attr("name")),
                });
            } else if OBJECT_TAGS.contains(&tag) {
                object.nested.push(Nested {
                    element: child,
                    at: &child.at,
                    name: child.attr("name"),
                });
            } else if let Some((_, why)) = UNSUPPORTED_TAGS.iter().find(|(t, _)| *t == tag) {
                let plugin = child
                    .attr("type")
                    .map(|t| format!(" type=\"{t}\""))
                    .unwrap_or_default();
                return Err(child
                    .at
                    .error(format!("unsupported element <{tag}{plugin}>: {why}")));
            } else {
                let value = parse_value(child, &doc.search)?;
                let name = child.required_attr("name")?;
                if let Some(first) = object.props.iter().find(|p| p.name == name) {
                    return Err(child.at.error(format!(
                        "parameter \"{name}\" of {} given twice (first at line {})",
                        object.describe(),
                        first.at.line
                    )));
                }
                object.props.push(Property {
                    name: name.to_string(),
                    value,
                    at: child.at.clone(),
                    used: false,
                });
            }
        }
        Ok(object)
    }

    /// `shape "rectangle"`, for messages.
    pub fn describe(&self) -> String {
        if self.tag == "scene" {
            "<scene>".to_string()
        } else {
            format!("{} \"{}\"", self.tag, self.plugin)
        }
    }

    /// Where the object is written.
    pub fn at(&self) -> &'a Location {
        &self.element.at
    }

    /// Where parameter `name` is written (the object's location if absent).
    pub fn location_of(&self, name: &str) -> &Location {
        self.props
            .iter()
            .find(|p| p.name == name)
            .map_or(&self.element.at, |p| &p.at)
    }

    fn take(&mut self, name: &'static str) -> Option<(Value, Location)> {
        if !self.known.contains(&name) {
            self.known.push(name);
        }
        let p = self.props.iter_mut().find(|p| p.name == name)?;
        p.used = true;
        Some((p.value.clone(), p.at.clone()))
    }

    fn mismatch(&self, name: &str, expected: &str, found: &Value, at: &Location) -> crate::Error {
        at.error(format!(
            "parameter \"{name}\" of {} must be {expected}, not <{}>",
            self.describe(),
            found.tag()
        ))
    }

    /// A `<float>` (or `<integer>`) parameter.
    pub fn float(&mut self, name: &'static str) -> Result<Option<f64>> {
        let Some((value, at)) = self.take(name) else {
            return Ok(None);
        };
        match value {
            Value::Float(v) => Ok(Some(v)),
            Value::Integer(v) => Ok(Some(v as f64)),
            other => Err(self.mismatch(name, "a <float>", &other, &at)),
        }
    }

    /// An `<integer>` parameter.
    pub fn integer(&mut self, name: &'static str) -> Result<Option<i64>> {
        let Some((value, at)) = self.take(name) else {
            return Ok(None);
        };
        match value {
            Value::Integer(v) => Ok(Some(v)),
            other => Err(self.mismatch(name, "an <integer>", &other, &at)),
        }
    }

    /// A `<boolean>` parameter.
    pub fn boolean(&mut self, name: &'static str) -> Result<Option<bool>> {
        let Some((value, at)) = self.take(name) else {
            return Ok(None);
        };
        match value {
            Value::Boolean(v) => Ok(Some(v)),
            other => Err(self.mismatch(name, "a <boolean>", &other, &at)),
        }
    }

    /// A `<string>` parameter.
    pub fn string(&mut self, name: &'static str) -> Result<Option<String>> {
        let Some((value, at)) = self.take(name) else {
            return Ok(None);
        };
        match value {
            Value::String(v) => Ok(Some(v)),
            other => Err(self.mismatch(name, "a <string>", &other, &at)),
        }
    }

    /// A `<float>` (or `<integer>`) or a `<string>` parameter, such as an
    /// index of refraction given by value or by name.
    pub fn float_or_string(&mut self, name: &'static str) -> Result<Option<FloatOrString>> {
        let Some((value, at)) = self.take(name) else {
            return Ok(None);
        };
        match value {
            Value::Float(v) => Ok(Some(FloatOrString::Float(v))),
            Value::Integer(v) => Ok(Some(FloatOrString::Float(v as f64))),
            Value::String(v) => Ok(Some(FloatOrString::String(v))),
            other => Err(self.mismatch(name, "a <float> or a <string>", &other, &at)),
        }
    }

    /// Whether parameter `name` is given (without consuming it).
    pub fn has(&self, name: &str) -> bool {
        self.props.iter().any(|p| p.name == name)
    }

    /// A reflectance colour: `<rgb>`, `<float>`, `<integer>` or
    /// `<spectrum>` (converted as Mitsuba's RGB variants do, clamped to
    /// \[0, 1\] with a warning). A nested `<texture>` under this name has
    /// already been rejected by [`Object::parse`].
    pub fn color(&mut self, name: &'static str) -> Result<Option<Rgb>> {
        self.color_as(name, ColorRole::Reflectance)
    }

    /// An optical constant's colour (`eta`, `k`): as [`Object::color`], a
    /// spectrum clamped at zero only.
    pub fn unbounded_color(&mut self, name: &'static str) -> Result<Option<Rgb>> {
        self.color_as(name, ColorRole::Unbounded)
    }

    /// An emitted radiance: as [`Object::color`], a spectrum converted as
    /// Mitsuba's RGB variants convert emission.
    pub fn radiance(&mut self, name: &'static str) -> Result<Option<Rgb>> {
        self.color_as(name, ColorRole::Emission)
    }

    fn color_as(&mut self, name: &'static str, role: ColorRole) -> Result<Option<Rgb>> {
        let Some((value, at)) = self.take(name) else {
            return Ok(None);
        };
        match value {
            Value::Rgb(c) => Ok(Some(c)),
            Value::Float(v) => Ok(Some(Rgb::splat(v))),
            Value::Integer(v) => Ok(Some(Rgb::splat(v as f64))),
            Value::Spectrum(s) => {
                let converted = s.to_rgb(role);
                if let Some(before) = converted.clamped_from {
                    self.doc.warn(at.warning(format!(
                        "spectrum \"{name}\" of {} is {before} in linear sRGB, outside the gamut; \
                         clamped to {}, as Mitsuba's RGB variants do",
                        self.describe(),
                        converted.rgb
                    )));
                }
                Ok(Some(converted.rgb))
            }
            other => Err(self.mismatch(name, "an <rgb>, <float> or <spectrum>", &other, &at)),
        }
    }

    /// A `<point>` (or `<vector>`) parameter, e.g. a sphere's `center`.
    pub fn point(&mut self, name: &'static str) -> Result<Option<DVec3>> {
        let Some((value, at)) = self.take(name) else {
            return Ok(None);
        };
        match value {
            Value::Point(p) | Value::Vector(p) => Ok(Some(p)),
            other => Err(self.mismatch(name, "a <point>", &other, &at)),
        }
    }

    /// A `<transform>` parameter.
    pub fn transform(&mut self, name: &'static str) -> Result<Option<DMat4>> {
        let Some((value, at)) = self.take(name) else {
            return Ok(None);
        };
        match value {
            Value::Transform(m) => Ok(Some(m)),
            other => Err(self.mismatch(name, "a <transform>", &other, &at)),
        }
    }

    /// Accept parameters that do not matter to wavrad, whatever their type.
    pub fn ignore(&mut self, names: &[&'static str]) {
        for &name in names {
            self.take(name);
        }
    }

    /// Accept every parameter (for plugins whose settings wavrad ignores).
    pub fn ignore_all(&mut self) {
        for p in &mut self.props {
            p.used = true;
        }
    }

    /// Fail on the first parameter the plugin did not ask for.
    pub fn finish(&self) -> Result<()> {
        match self.props.iter().find(|p| !p.used) {
            None => Ok(()),
            Some(p) => {
                let known = if self.known.is_empty() {
                    "it takes none".to_string()
                } else {
                    format!("known: {}", self.known.join(", "))
                };
                Err(p.at.error(format!(
                    "unknown parameter \"{}\" for {} ({known})",
                    p.name,
                    self.describe()
                )))
            }
        }
    }

    /// The error for a nested object this plugin does not take.
    pub fn unexpected(&self, nested: &Nested) -> crate::Error {
        nested.at.error(format!(
            "{} cannot contain a <{}> (type \"{}\")",
            self.describe(),
            nested.tag(),
            nested.plugin()
        ))
    }
}

/// Parse a parameter element; `search` finds spectrum files.
fn parse_value(e: &Element, search: &SearchPath) -> Result<Value> {
    fn value(e: &Element) -> Result<&str> {
        e.required_attr("value")
    }
    Ok(match e.tag.as_str() {
        "float" => {
            e.check_attrs(&["name", "value"])?;
            Value::Float(parse_f64(value(e)?, e)?)
        }
        "integer" => {
            e.check_attrs(&["name", "value"])?;
            let v = value(e)?;
            Value::Integer(v.trim().parse().map_err(|_| {
                e.at.error(format!("malformed integer \"{v}\" in {}", describe(e)))
            })?)
        }
        "boolean" => {
            e.check_attrs(&["name", "value"])?;
            let v = value(e)?;
            Value::Boolean(match v.trim().to_ascii_lowercase().as_str() {
                "true" => true,
                "false" => false,
                _ => {
                    return Err(e.at.error(format!(
                        "malformed boolean \"{v}\" in {} (expected true or false)",
                        describe(e)
                    )))
                }
            })
        }
        "string" => {
            e.check_attrs(&["name", "value"])?;
            Value::String(value(e)?.to_string())
        }
        "point" | "vector" => {
            e.check_attrs(&["name", "value", "x", "y", "z"])?;
            let v = parse_xyz(e, 0.0)?;
            if e.tag == "point" {
                Value::Point(v)
            } else {
                Value::Vector(v)
            }
        }
        "rgb" => {
            e.check_attrs(&["name", "value"])?;
            let v = parse_numbers(value(e)?, e)?;
            match v.as_slice() {
                [x] => Value::Rgb(Rgb::splat(*x)),
                [r, g, b] => Value::Rgb(Rgb([*r, *g, *b])),
                _ => {
                    return Err(e.at.error(format!(
                        "{} needs 1 or 3 values, got {}",
                        describe(e),
                        v.len()
                    )))
                }
            }
        }
        "spectrum" => Value::Spectrum(parse_spectrum(e, search)?),
        "transform" => {
            e.check_attrs(&["name"])?;
            Value::Transform(parse_transform(e)?)
        }
        "blackbody" => return Err(blackbody(e)),
        other => return Err(e.at.error(format!("unknown element <{other}>"))),
    })
}

/// Longest spectrum file read (1 MiB): a spectrum is a few hundred lines
/// of wavelength–value pairs.
const MAX_SPECTRUM_FILE_BYTES: u64 = 1 << 20;

/// A `<spectrum>` given by `value` or by `filename`.
fn parse_spectrum(e: &Element, search: &SearchPath) -> Result<Spectrum> {
    if let Some(plugin) = e.attr("type") {
        return Err(if plugin == "blackbody" {
            blackbody(e)
        } else {
            e.at.error(format!(
                "unsupported spectrum plugin \"{plugin}\" in {}: spectrum plugins are textures; \
                 give <spectrum value=\"...\"/> or <rgb> instead",
                describe(e)
            ))
        });
    }
    e.check_attrs(&["name", "value", "filename"])?;
    let malformed = |why: String| e.at.error(format!("{}: {why}", describe(e)));
    match (e.attr("value"), e.attr("filename")) {
        (Some(value), None) => Spectrum::parse(value).map_err(malformed),
        (None, Some(filename)) => {
            let path = search.resolve(filename, &e.at.dir);
            let text = read_text_file(&path, MAX_SPECTRUM_FILE_BYTES, || {
                format!("longer than {MAX_SPECTRUM_FILE_BYTES} bytes, wavrad's bound")
            })
            .map_err(|err| {
                malformed(format!(
                    "cannot read spectrum file \"{}\": {err}",
                    path.display()
                ))
            })?;
            Spectrum::parse_file(&text)
                .map_err(|why| malformed(format!("spectrum file \"{}\", {why}", path.display())))
        }
        _ => Err(malformed(
            "give either \"value\" or \"filename\" (but not both)".to_string(),
        )),
    }
}

/// The error for a black-body spectrum (`<spectrum type="blackbody">`, or
/// Mitsuba 0.x's `<blackbody>`): Mitsuba 3 evaluates it in its spectral
/// variants only, and wavrad renders as its RGB variants do.
fn blackbody(e: &Element) -> crate::Error {
    e.at.error(format!(
        "black-body spectra ({}) are not supported: Mitsuba 3 has them in its spectral variants \
         only, and wavrad renders as its RGB variants do; give the emitter's <rgb> radiance",
        describe(e)
    ))
}

/// `<float name="fov">`, for messages.
pub(crate) fn describe(e: &Element) -> String {
    match e.attr("name") {
        Some(name) => format!("<{} name=\"{name}\">", e.tag),
        None => format!("<{}>", e.tag),
    }
}

/// Numbers separated by commas and/or white space; each must be finite.
pub(crate) fn parse_numbers(text: &str, e: &Element) -> Result<Vec<f64>> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(e
                .at
                .error(format!("malformed number \"{t}\" in {}", describe(e)))),
        })
        .collect()
}

/// Exactly one number.
pub(crate) fn parse_f64(text: &str, e: &Element) -> Result<f64> {
    match parse_numbers(text, e)?.as_slice() {
        [v] => Ok(*v),
        _ => Err(e.at.error(format!(
            "malformed number \"{text}\" in {} (expected one value)",
            describe(e)
        ))),
    }
}

/// A 3-vector from `value="x, y, z"` (or one value for all three) or from
/// `x`, `y`, `z` attributes, missing ones being `default`.
pub(crate) fn parse_xyz(e: &Element, default: f64) -> Result<DVec3> {
    if let Some(v) = e.attr("value") {
        if ["x", "y", "z"].iter().any(|k| e.attr(k).is_some()) {
            return Err(e.at.error(format!(
                "{}: give either \"value\" or \"x\", \"y\", \"z\", not both",
                describe(e)
            )));
        }
        return match parse_numbers(v, e)?.as_slice() {
            [s] => Ok(DVec3::splat(*s)),
            [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
            other => Err(e.at.error(format!(
                "{} needs 1 or 3 values, got {}",
                describe(e),
                other.len()
            ))),
        };
    }
    let c = |k: &str| e.attr(k).map_or(Ok(default), |t| parse_f64(t, e));
    Ok(DVec3::new(c("x")?, c("y")?, c("z")?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mitsuba::document::read_scene_document;
    use std::path::Path;

    /// The root of `xml` read in `dir`.
    fn root_in(xml: &str, dir: &Path) -> (Element, SearchPath) {
        let expanded = read_scene_document(xml, "p.xml", dir, None, &[]).unwrap();
        let (children, search) = (expanded.elements, expanded.search);
        (Element::root(children, "p.xml", dir), search)
    }

    fn read(xml: &str) -> (Element, SearchPath) {
        root_in(xml, Path::new("."))
    }

    #[test]
    fn typed_values_and_unknown_parameter() {
        let (root, search) = read(
            r#"<scene><shape type="x">
            <float name="f" value="1.5"/>
            <integer name="i" value="-3"/>
            <boolean name="b" value="True"/>
            <rgb name="c" value="0.1, 0.2,0.3"/>
            <spectrum name="s" value="0.25"/>
            <point name="p" x="1" z="3"/>
            <string name="extra" value="?"/>
            </shape></scene>"#,
        );
        let doc = Document::new(&root, search).unwrap();
        let mut o = Object::parse(&root.children[0], &doc).unwrap();
        assert_eq!(o.float("f").unwrap(), Some(1.5));
        assert_eq!(o.float("i").unwrap(), Some(-3.0));
        assert_eq!(o.boolean("b").unwrap(), Some(true));
        assert_eq!(o.color("c").unwrap(), Some(Rgb([0.1, 0.2, 0.3])));
        assert_eq!(o.color("s").unwrap(), Some(Rgb::splat(0.25)));
        assert_eq!(o.float("missing").unwrap(), None);
        assert!(o.integer("f").is_err());
        o.ignore(&["p"]);
        let msg = o.finish().unwrap_err().to_string();
        assert!(
            msg.starts_with("p.xml:8:") && msg.contains("\"extra\"") && msg.contains("shape \"x\""),
            "{msg}"
        );
    }

    #[test]
    fn malformed_numbers_name_the_line() {
        let xml =
            "<scene><shape type=\"x\">\n\n<float name=\"f\" value=\"1.5.2\"/></shape></scene>";
        let (root, search) = read(xml);
        let doc = Document::new(&root, search).unwrap();
        let msg = Object::parse(&root.children[0], &doc)
            .unwrap_err()
            .to_string();
        assert!(
            msg.starts_with("p.xml:3:") && msg.contains("1.5.2"),
            "{msg}"
        );
        for bad in ["nan", "inf", ""] {
            let xml = format!(
                "<scene><shape type=\"x\"><float name=\"f\" value=\"{bad}\"/></shape></scene>"
            );
            let (root, search) = read(&xml);
            let doc = Document::new(&root, search).unwrap();
            assert!(Object::parse(&root.children[0], &doc).is_err(), "{bad}");
        }
    }

    #[test]
    fn spectra_convert_by_role_and_warn_when_clamped() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("spd")).unwrap();
        std::fs::write(
            dir.path().join("spd/green.spd"),
            "# a narrow green band\n500 0\n520 1\n540 0\n",
        )
        .unwrap();
        let (root, search) = root_in(
            r#"<scene><path value="spd"/><shape type="x">
            <spectrum name="gray" value="0.5"/>
            <spectrum name="emitted" value="0.5"/>
            <spectrum name="green" filename="green.spd"/>
            </shape></scene>"#,
            dir.path(),
        );
        let doc = Document::new(&root, search).unwrap();
        let mut o = Object::parse(&root.children[0], &doc).unwrap();
        assert_eq!(o.color("gray").unwrap(), Some(Rgb::splat(0.5)));
        // An equal-energy emitter is pinkish in sRGB, as in Mitsuba.
        let emitted = o.radiance("emitted").unwrap().unwrap();
        assert!((emitted[0] - 0.5 * 1.204794).abs() < 1e-5, "{emitted}");
        assert!(emitted[0] > emitted[1] && emitted[1] > emitted[2]);
        let green = o.color("green").unwrap().unwrap();
        assert!(
            green[0] == 0.0 && green[1] > 0.2 && green[2] == 0.0,
            "{green}"
        );
        o.finish().unwrap();
        let warnings = doc.into_warnings();
        let [w] = &warnings[..] else {
            panic!("{warnings:?}")
        };
        assert_eq!(w.line, 4);
        assert!(
            w.message.contains("\"green\"") && w.message.contains("clamped"),
            "{w}"
        );
    }

    #[test]
    fn unusable_spectra_name_the_line_and_the_reason() {
        for (spectrum, needle) in [
            (r#"<spectrum name="s" value="500:1"/>"#, "at least two"),
            (r#"<spectrum name="s" filename="none.spd"/>"#, "none.spd"),
            (
                r#"<spectrum name="s" value="1" filename="x.spd"/>"#,
                "not both",
            ),
            (
                r#"<spectrum name="s" type="blackbody"><float name="temperature" value="5000"/></spectrum>"#,
                "spectral variants",
            ),
            (
                r#"<blackbody name="s" temperature="5000K"/>"#,
                "spectral variants",
            ),
            (
                r#"<spectrum name="s" type="d65"/>"#,
                "spectrum plugin \"d65\"",
            ),
        ] {
            let xml = format!("<scene><shape type=\"x\">\n{spectrum}</shape></scene>");
            let (root, search) = read(&xml);
            let doc = Document::new(&root, search).unwrap();
            let msg = Object::parse(&root.children[0], &doc)
                .unwrap_err()
                .to_string();
            assert!(msg.starts_with("p.xml:2:") && msg.contains(needle), "{msg}");
        }
    }
}
