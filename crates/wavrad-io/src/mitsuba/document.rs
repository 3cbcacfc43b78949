//! From XML text to a tree of [`Element`]s with `<default>`, `$name`
//! substitution, `<include>` and `<path>` already applied and Mitsuba 0.x
//! scenes upgraded, each element knowing the file and line it came from.
//!
//! A relative file name (an include, a mesh, a spectrum) is looked up as
//! Mitsuba 3's file resolver does ([`SearchPath`]): in the directories
//! added by `<path value="..."/>` elements, the latest first, then beside
//! the file that names it, then in the scene file's directory.
//!
//! Bounds, so that no scene file can exhaust the machine: includes nest at
//! most [`MAX_INCLUDE_DEPTH`] deep (Mitsuba 3's own limit), at most
//! [`MAX_INCLUDES`] are expanded in all, the XML files read hold at most
//! [`MAX_XML_BYTES`] together and must be regular files, and elements nest
//! at most [`MAX_NESTING`] deep in a file.
//!
//! Parameter overrides (`-D name=value`, Python's `load_scene(path,
//! name=value)`) are checked as Mitsuba 3 checks them: one that no `$name`
//! reads is an error, as are an empty or malformed name and a name given
//! twice. A second `<default>` of a name is ignored (the first wins, as in
//! Mitsuba) with a warning.
//!
//! Scenes of version 0.x (Mitsuba 0.5, 0.6) are upgraded as Mitsuba 3's
//! loader upgrades them (`upgrade_tree` in its `src/core/xml.cpp`): every
//! `name` but a `<default>`'s from camelCase to snake_case (`toWorld` →
//! `to_world`, `intIOR` → `int_ior`), `<lookAt>` → `<lookat>`, and a
//! `diffuse` BSDF's `diffuse_reflectance` → `reflectance`. (Mitsuba's
//! `uoffset`/`uscale` → `to_uv` is a texture's, and textures are refused.)

use std::collections::{HashMap, HashSet};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::Warning;
use crate::error::{Error, Result};

/// Where an element was written: file name (as given to the loader), 1-based
/// line, and the directory relative paths in that file resolve against.
#[derive(Debug, Clone)]
pub(crate) struct Location {
    pub file: Arc<str>,
    pub line: u32,
    pub dir: Arc<Path>,
}

impl Location {
    /// An error at this location.
    pub fn error(&self, message: impl Into<String>) -> Error {
        Error::Scene {
            file: self.file.to_string(),
            line: self.line,
            message: message.into(),
        }
    }

    /// A warning at this location.
    pub fn warning(&self, message: impl Into<String>) -> Warning {
        Warning {
            file: self.file.to_string(),
            line: self.line,
            message: message.into(),
        }
    }
}

impl std::fmt::Display for Location {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.file, self.line)
    }
}

/// One XML element after expansion.
#[derive(Debug, Clone)]
pub(crate) struct Element {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub at: Location,
}

impl Element {
    /// The `<scene>` root over the expanded `children` of the scene file
    /// `file` (as named to the loader) in directory `dir`.
    pub fn root(children: Vec<Element>, file: &str, dir: &Path) -> Element {
        Element {
            tag: "scene".into(),
            attrs: Vec::new(),
            children,
            at: Location {
                file: Arc::from(file),
                line: 1,
                dir: Arc::from(dir),
            },
        }
    }

    /// Value of attribute `name`.
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// Value of attribute `name`, which must be present.
    pub fn required_attr(&self, name: &str) -> Result<&str> {
        self.attr(name).ok_or_else(|| {
            self.at
                .error(format!("<{}> needs a \"{name}\" attribute", self.tag))
        })
    }

    /// Fail on any attribute outside `allowed`.
    pub fn check_attrs(&self, allowed: &[&str]) -> Result<()> {
        match self
            .attrs
            .iter()
            .find(|(k, _)| !allowed.contains(&k.as_str()))
        {
            Some((k, _)) => Err(self.at.error(format!(
                "unexpected attribute \"{k}\" in <{}> (allowed: {})",
                self.tag,
                allowed.join(", ")
            ))),
            None => Ok(()),
        }
    }
}

/// Deepest nesting of elements within one file; deeper input is an error
/// rather than a stack overflow.
pub const MAX_NESTING: usize = 64;

/// Deepest nesting of included files below the scene file: Mitsuba 3's
/// parser refuses the same (its `max_include_depth` of 15 counts the scene
/// file), so every scene Mitsuba reads, wavrad reads.
pub const MAX_INCLUDE_DEPTH: usize = 14;

/// Most `<include>`s expanded in one scene, all files together. Depth alone
/// does not bound the work: files that each include the next twice expand
/// 2^depth times. Hand-written and exported scenes include a few files.
pub const MAX_INCLUDES: usize = 4096;

/// Most bytes of XML one scene reads, its included files (each time it is
/// included) together: 256 MiB. Mitsuba scenes keep geometry in mesh files,
/// so their XML is kilobytes to a few megabytes; the bound keeps a runaway
/// expansion from exhausting memory.
pub const MAX_XML_BYTES: u64 = 256 << 20;

/// Read the text file `path`, which must be a regular file (not a device
/// or a pipe, which could be read forever) of at most `limit` bytes;
/// `too_long` says why a longer one is refused.
pub(crate) fn read_text_file(
    path: &Path,
    limit: u64,
    too_long: impl FnOnce() -> String,
) -> std::io::Result<String> {
    if !std::fs::metadata(path)?.is_file() {
        return Err(std::io::Error::other("not a regular file"));
    }
    let mut text = String::new();
    std::fs::File::open(path)?
        .take(limit.saturating_add(1))
        .read_to_string(&mut text)?;
    if text.len() as u64 > limit {
        return Err(std::io::Error::other(too_long()));
    }
    Ok(text)
}

/// Read the XML file `path` of at most `limit` bytes ([`read_text_file`]).
pub(crate) fn read_xml(path: &Path, limit: u64) -> std::io::Result<String> {
    read_text_file(path, limit, too_much_xml)
}

/// Why more XML is refused.
fn too_much_xml() -> String {
    format!(
        "the scene's XML files (includes counted each time) would hold more than \
         {MAX_XML_BYTES} bytes, wavrad's bound"
    )
}

/// Where relative file names are looked up, as Mitsuba 3's file resolver
/// does: the directories of `<path>` elements (the latest first), then the
/// directory of the file naming it, then the scene file's directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct SearchPath {
    /// Directories added by `<path>`, the latest first.
    added: Vec<PathBuf>,
    /// Directory of the top-level scene file.
    scene_dir: PathBuf,
}

impl SearchPath {
    /// Only the scene file's directory.
    pub fn new(scene_dir: &Path) -> SearchPath {
        SearchPath {
            added: Vec::new(),
            scene_dir: scene_dir.to_path_buf(),
        }
    }

    /// The file `filename` names, written in a file of directory `beside`:
    /// an absolute name as is, else the first candidate that exists, else
    /// the name beside that file (so that messages name it there).
    pub fn resolve(&self, filename: &str, beside: &Path) -> PathBuf {
        let p = Path::new(filename);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        self.added
            .iter()
            .map(PathBuf::as_path)
            .chain([beside, self.scene_dir.as_path()])
            .map(|dir| dir.join(p))
            .find(|candidate| candidate.exists())
            .unwrap_or_else(|| beside.join(p))
    }
}

/// A scene document expanded.
#[derive(Debug)]
pub(crate) struct Expanded {
    /// The children of its `<scene>` root.
    pub elements: Vec<Element>,
    /// Where relative file names are looked up.
    pub search: SearchPath,
    /// What was read, but not as written (a repeated `<default>`).
    pub warnings: Vec<Warning>,
    /// Whether the scene file is a Mitsuba 0.x one (upgraded).
    pub legacy: bool,
}

/// Parse the scene document `xml` and expand it. `own_path` (canonical) is
/// the file itself when it has one, for include-cycle detection;
/// `overrides` (`name`, `value`) win over the `<default>`s, and each must
/// be read by some `$name`.
pub(crate) fn read_scene_document(
    xml: &str,
    name: &str,
    dir: &Path,
    own_path: Option<PathBuf>,
    overrides: &[(String, String)],
) -> Result<Expanded> {
    let mut params = HashMap::new();
    for (key, value) in overrides {
        params.entry(key.clone()).or_insert_with(|| value.clone());
    }
    let mut expander = Expander {
        params,
        defaults: HashMap::new(),
        read: HashSet::new(),
        include_stack: own_path.into_iter().collect(),
        include_depth: 0,
        includes: 0,
        xml_bytes: 0,
        search: SearchPath::new(dir),
        scene_at: None,
        legacy: None,
        warnings: Vec::new(),
    };
    let elements = expander.document(xml, name, dir)?;
    expander.check_overrides(overrides)?;
    Ok(Expanded {
        elements,
        search: expander.search,
        warnings: expander.warnings,
        legacy: expander.legacy.unwrap_or(false),
    })
}

/// The file being expanded.
struct Source<'d> {
    doc: &'d roxmltree::Document<'d>,
    file: &'d Arc<str>,
    dir: &'d Arc<Path>,
    /// Whether it is a Mitsuba 0.x scene, to be upgraded.
    legacy: bool,
}

struct Expander {
    /// `$name` values: overrides first, then `<default>`s in document order
    /// (the first definition wins, as in Mitsuba).
    params: HashMap<String, String>,
    /// Where each `<default>` name was first declared, and its value there.
    defaults: HashMap<String, (Location, String)>,
    /// The names some `$name` read.
    read: HashSet<String>,
    /// Canonical paths of the files being read, outermost first.
    include_stack: Vec<PathBuf>,
    /// Included files open now (0 in the scene file itself).
    include_depth: usize,
    /// `<include>`s expanded so far.
    includes: usize,
    /// Bytes of XML read so far.
    xml_bytes: u64,
    /// Where relative file names are looked up, `<path>`s read so far
    /// included.
    search: SearchPath,
    /// The scene file's `<scene>` element, once read.
    scene_at: Option<Location>,
    /// Whether the scene file (the first document read) is Mitsuba 0.x's.
    legacy: Option<bool>,
    /// Warnings so far.
    warnings: Vec<Warning>,
}

impl Expander {
    fn document(&mut self, xml: &str, name: &str, dir: &Path) -> Result<Vec<Element>> {
        let file: Arc<str> = Arc::from(name);
        let dir: Arc<Path> = Arc::from(dir);
        self.xml_bytes += xml.len() as u64;
        if self.xml_bytes > MAX_XML_BYTES {
            return Err(Error::Scene {
                file: name.to_string(),
                line: 1,
                message: too_much_xml(),
            });
        }
        let options = roxmltree::ParsingOptions {
            allow_dtd: false,
            ..Default::default()
        };
        let doc =
            roxmltree::Document::parse_with_options(xml, options).map_err(|e| Error::Scene {
                file: name.to_string(),
                line: e.pos().row,
                message: format!("malformed XML: {e}"),
            })?;
        let root = doc.root_element();
        let at = Location {
            file: file.clone(),
            line: doc.text_pos_at(root.range().start).row,
            dir: dir.clone(),
        };
        if root.tag_name().name() != "scene" {
            return Err(at.error(format!(
                "the root element must be <scene>, not <{}>",
                root.tag_name().name()
            )));
        }
        self.scene_at.get_or_insert_with(|| at.clone());
        let mut legacy = false;
        for attr in root.attributes() {
            match attr.name() {
                "version" => legacy = is_legacy_version(attr.value(), &at)?,
                other => {
                    return Err(at.error(format!(
                        "unexpected attribute \"{other}\" in <scene> (allowed: version)"
                    )))
                }
            }
        }
        self.legacy.get_or_insert(legacy);
        let mut out = Vec::new();
        let source = Source {
            doc: &doc,
            file: &file,
            dir: &dir,
            legacy,
        };
        self.children(&source, root, 1, &mut out)?;
        Ok(out)
    }

    fn children(
        &mut self,
        source: &Source,
        node: roxmltree::Node,
        depth: usize,
        out: &mut Vec<Element>,
    ) -> Result<()> {
        for child in node.children().filter(|n| n.is_element()) {
            let at = Location {
                file: source.file.clone(),
                line: source.doc.text_pos_at(child.range().start).row,
                dir: source.dir.clone(),
            };
            if depth > MAX_NESTING {
                return Err(at.error(format!("elements nested deeper than {MAX_NESTING} levels")));
            }
            let mut attrs = Vec::new();
            for a in child.attributes() {
                attrs.push((a.name().to_string(), self.substitute(a.value(), &at)?));
            }
            let mut element = Element {
                tag: child.tag_name().name().to_string(),
                attrs,
                children: Vec::new(),
                at,
            };
            match element.tag.as_str() {
                "default" => {
                    element.check_attrs(&["name", "value"])?;
                    let name = element.required_attr("name")?.to_string();
                    let value = element.required_attr("value")?.to_string();
                    if name.is_empty() {
                        return Err(element.at.error("<default> with an empty name"));
                    }
                    self.default(name, value, &element.at);
                }
                "include" => {
                    element.check_attrs(&["filename"])?;
                    let filename = element.required_attr("filename")?.to_string();
                    self.include(&element.at, &filename, out)?;
                }
                "path" => {
                    if depth > 1 {
                        return Err(element
                            .at
                            .error("<path> must be a child of the <scene> itself"));
                    }
                    element.check_attrs(&["value"])?;
                    let value = element.required_attr("value")?.to_string();
                    self.add_path(&element.at, &value)?;
                }
                _ => {
                    self.children(source, child, depth + 1, &mut element.children)?;
                    if source.legacy {
                        upgrade_from_legacy(&mut element, &mut self.warnings)?;
                    }
                    out.push(element);
                }
            }
        }
        Ok(())
    }

    /// `<default name value>`: the first one of a name counts, as in
    /// Mitsuba; a later one with another value is a warning.
    fn default(&mut self, name: String, value: String, at: &Location) {
        match self.defaults.get(&name) {
            Some((_, first_value)) if *first_value == value => {}
            Some((first, _)) => {
                // Declared names all have values (the first, or an override's).
                let winner = &self.params[&name];
                self.warnings.push(at.warning(format!(
                    "<default name=\"{name}\"> is declared again (first at {first}); this \
                     value \"{value}\" is ignored and ${name} stays \"{winner}\", as in Mitsuba"
                )));
            }
            None => {
                self.defaults
                    .insert(name.clone(), (at.clone(), value.clone()));
                self.params.entry(name).or_insert(value);
            }
        }
    }

    /// Fail on an override no `$name` read, with an empty or malformed
    /// name, or given twice: Mitsuba 3 refuses unused ones too, and a
    /// misspelt name would otherwise change nothing, silently.
    fn check_overrides(&self, overrides: &[(String, String)]) -> Result<()> {
        let scene_at = self.scene_at.as_ref().expect("the scene document was read");
        for (i, (name, value)) in overrides.iter().enumerate() {
            let what = format!("parameter override {name}={value}");
            if name.is_empty() {
                return Err(scene_at.error(format!("{what}: the name is empty")));
            }
            if !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(scene_at.error(format!(
                    "{what}: a parameter name holds only letters, digits and _"
                )));
            }
            if overrides[..i].iter().any(|(earlier, _)| earlier == name) {
                return Err(scene_at.error(format!("{what}: \"{name}\" is given twice")));
            }
            if !self.read.contains(name) {
                let at = self.defaults.get(name).map_or(scene_at, |(at, _)| at);
                let declared = if self.defaults.contains_key(name) {
                    format!("<default name=\"{name}\"> is declared here, but")
                } else {
                    "the scene declares no such <default>, and".to_string()
                };
                let mut known: Vec<&str> = self.read.iter().map(String::as_str).collect();
                known.sort_unstable();
                let known = if known.is_empty() {
                    "it reads no parameters".to_string()
                } else {
                    format!("it reads ${}", known.join(", $"))
                };
                return Err(at.error(format!(
                    "{what} is used nowhere: {declared} no attribute reads ${name} ({known})"
                )));
            }
        }
        Ok(())
    }

    /// `<path value>`: a directory looked up for relative file names from
    /// now on, before those added earlier. A relative one is taken beside
    /// the file naming it, else through the search path (Mitsuba 3's
    /// `<path>`); it must exist.
    fn add_path(&mut self, at: &Location, value: &str) -> Result<()> {
        let beside = at.dir.join(value);
        let dir = if beside.is_dir() {
            beside
        } else {
            self.search.resolve(value, &at.dir)
        };
        if !dir.is_dir() {
            return Err(at.error(format!(
                "<path>: no directory \"{value}\" (looked for {})",
                dir.display()
            )));
        }
        self.search.added.insert(0, dir);
        Ok(())
    }

    fn include(&mut self, at: &Location, filename: &str, out: &mut Vec<Element>) -> Result<()> {
        let path = self.search.resolve(filename, &at.dir);
        let canonical = std::fs::canonicalize(&path).map_err(|e| {
            at.error(format!(
                "cannot read included file \"{}\": {e}",
                path.display()
            ))
        })?;
        if let Some(first) = self.include_stack.iter().position(|p| *p == canonical) {
            let chain: Vec<String> = self.include_stack[first..]
                .iter()
                .chain(std::iter::once(&canonical))
                .map(|p| p.display().to_string())
                .collect();
            return Err(at.error(format!(
                "include cycle: \"{filename}\" is already being read ({})",
                chain.join(" -> ")
            )));
        }
        if self.include_depth >= MAX_INCLUDE_DEPTH {
            return Err(at.error(format!(
                "includes nested deeper than {MAX_INCLUDE_DEPTH} files below the scene file \
                 (Mitsuba's limit too)"
            )));
        }
        self.includes += 1;
        if self.includes > MAX_INCLUDES {
            return Err(at.error(format!(
                "more than {MAX_INCLUDES} <include>s expanded in all, wavrad's bound (do files \
                 include each other more than once?)"
            )));
        }
        let xml = read_xml(&path, MAX_XML_BYTES - self.xml_bytes).map_err(|e| {
            at.error(format!(
                "cannot read included file \"{}\": {e}",
                path.display()
            ))
        })?;
        let dir = path
            .parent()
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
        self.include_stack.push(canonical);
        self.include_depth += 1;
        let elements = self.document(&xml, &path.display().to_string(), &dir);
        self.include_depth -= 1;
        self.include_stack.pop();
        out.extend(elements?);
        Ok(())
    }

    /// Replace every `$name` in `value` (name: letters, digits, `_`); a `$`
    /// not followed by a name stays as is.
    fn substitute(&mut self, value: &str, at: &Location) -> Result<String> {
        if !value.contains('$') {
            return Ok(value.to_string());
        }
        let mut out = String::with_capacity(value.len());
        let mut rest = value;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let after = &rest[i + 1..];
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let name = &after[..len];
            if name.is_empty() {
                out.push('$');
            } else {
                let v = self.params.get(name).ok_or_else(|| {
                    at.error(format!(
                        "undefined parameter \"${name}\" (declare it with <default name=\"{name}\" value=\"...\"/> or pass it as an override)"
                    ))
                })?;
                out.push_str(v);
                if !self.read.contains(name) {
                    self.read.insert(name.to_string());
                }
            }
            rest = &after[len..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

/// Whether a scene `version` is Mitsuba 0.x's (to be upgraded); Mitsuba
/// 2.x and 3.x scenes are read as they are, anything else is an error.
fn is_legacy_version(version: &str, at: &Location) -> Result<bool> {
    let parts: Vec<&str> = version.trim().split('.').collect();
    let numeric = parts.len() <= 3 && parts.iter().all(|p| p.parse::<u32>().is_ok());
    if !numeric {
        return Err(at.error(format!("malformed scene version \"{version}\"")));
    }
    match parts[0] {
        "0" | "1" => Ok(true),
        "2" | "3" => Ok(false),
        _ => Err(at.error(format!(
            "unsupported scene version \"{version}\" (supported: 0.x (upgraded), 2.x, 3.x)"
        ))),
    }
}

/// Upgrade `element` (its own children already upgraded) from Mitsuba
/// 0.x's names to Mitsuba 3's, as Mitsuba 3's `upgrade_tree` does, and
/// Mitsuba 0.x's texture parameters and spectra to what they meant there
/// ([`upgrade_texture`], [`upgrade_spectrum`]). Elements of included files
/// keep their own file's version.
fn upgrade_from_legacy(element: &mut Element, warnings: &mut Vec<Warning>) -> Result<()> {
    if element.tag == "lookAt" {
        element.tag = "lookat".into();
    }
    if element.tag != "default" {
        rename(element, |name| Some(snake_case(name)));
    }
    if element.tag == "bsdf" && element.attr("type") == Some("diffuse") {
        let file = element.at.file.clone();
        for child in element.children.iter_mut() {
            if Arc::ptr_eq(&child.at.file, &file) {
                rename(child, |name| {
                    (name == "diffuse_reflectance").then(|| "reflectance".into())
                });
            }
        }
    }
    if element.tag == "texture" {
        upgrade_texture(element, warnings)?;
    }
    if element.tag == "spectrum" {
        upgrade_spectrum(element);
    }
    Ok(())
}

/// The UV parameters of Mitsuba 0.x's `Texture2D` (0.6's
/// `src/librender/texture.cpp`): the texture is looked up at
/// (u·uscale + uoffset, v·vscale + voffset), `uvscale` the default of both
/// scales. They become the `to_uv` `<transform>` of that affine map, a
/// `<matrix>` at the line of the first of them. (Mitsuba 3's upgrade,
/// `upgrade_from_v1` in `src/core/parser.cpp`, writes scale · translate,
/// which also scales the offset; the two agree unless a file gives both.)
/// `filter_type` `trilinear` and `ewa`, Mitsuba 0.x's MIP-map filters of a
/// `bitmap`, become `bilinear`, with a warning: wavrad has no MIP maps, and
/// a pixel averages the texels its samples see.
fn upgrade_texture(element: &mut Element, warnings: &mut Vec<Warning>) -> Result<()> {
    const UV: [&str; 5] = ["uscale", "vscale", "uoffset", "voffset", "uvscale"];
    let mut given = [None; 5];
    let mut first: Option<Location> = None;
    let mut kept = Vec::with_capacity(element.children.len());
    for child in std::mem::take(&mut element.children) {
        let index = (child.tag == "float")
            .then(|| {
                child
                    .attr("name")
                    .and_then(|n| UV.iter().position(|u| *u == n))
            })
            .flatten();
        let Some(index) = index else {
            kept.push(child);
            continue;
        };
        let value = child.attr("value").unwrap_or_default();
        let number = value.trim().parse::<f64>().ok().filter(|v| v.is_finite());
        let Some(number) = number else {
            return Err(child.at.error(format!(
                "{} of a Mitsuba 0.x texture must be a finite number, not \"{value}\"",
                UV[index]
            )));
        };
        if given[index].replace(number).is_some() {
            return Err(child.at.error(format!("{} given twice", UV[index])));
        }
        first.get_or_insert(child.at.clone());
    }
    element.children = kept;
    if let Some(at) = first {
        let scale = given[4].unwrap_or(1.0);
        let (su, sv) = (given[0].unwrap_or(scale), given[1].unwrap_or(scale));
        let (ou, ov) = (given[2].unwrap_or(0.0), given[3].unwrap_or(0.0));
        let matrix = format!("{su} 0 0 {ou} 0 {sv} 0 {ov} 0 0 1 0 0 0 0 1");
        element.children.push(Element {
            tag: "transform".into(),
            attrs: vec![("name".into(), "to_uv".into())],
            children: vec![Element {
                tag: "matrix".into(),
                attrs: vec![("value".into(), matrix)],
                children: Vec::new(),
                at: at.clone(),
            }],
            at,
        });
    }
    if element.attr("type") == Some("bitmap") {
        for child in element.children.iter_mut() {
            let filter = child.tag == "string" && child.attr("name") == Some("filter_type");
            let Some(value) = child.attr("value").filter(|_| filter).map(str::to_string) else {
                continue;
            };
            if ["trilinear", "ewa"].contains(&value.to_ascii_lowercase().as_str()) {
                warnings.push(child.at.warning(format!(
                    "filter_type \"{value}\" (Mitsuba 0.x's MIP-map filtering) is read as \
                     \"bilinear\": wavrad has no MIP maps; each pixel averages the texels its \
                     samples see"
                )));
                for (key, v) in &mut child.attrs {
                    if key == "value" {
                        *v = "bilinear".into();
                    }
                }
            }
        }
    }
    Ok(())
}

/// A Mitsuba 0.x `<spectrum value>` that lists values without wavelengths
/// gives one value per spectral sample of the renderer's build (0.6's
/// `scenehandler.cpp`; its default RGB build has three, red, green and
/// blue): three such values become the `<rgb>` they meant. Other forms are
/// left to the spectrum reader.
fn upgrade_spectrum(element: &mut Element) {
    let Some(value) = element.attr("value") else {
        return;
    };
    let tokens: Vec<&str> = value
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .collect();
    if tokens.len() == 3 && tokens.iter().all(|t| !t.contains(':')) {
        element.tag = "rgb".into();
    }
}

/// Replace `element`'s `name` where `new_name` gives one.
fn rename(element: &mut Element, new_name: impl Fn(&str) -> Option<String>) {
    for (key, value) in &mut element.attrs {
        if key == "name" {
            if let Some(name) = new_name(value) {
                *value = name;
            }
        }
    }
}

/// Mitsuba 3's `camel_to_underscore_case`: an upper-case letter after a
/// lower-case one starts a new word, lower-cased with the upper-case letters
/// right after it (`toWorld` → `to_world`, `intIOR` → `int_ior`, `B` stays).
fn snake_case(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if i > 0 && chars[i - 1].is_ascii_lowercase() && c.is_ascii_uppercase() {
            out.push('_');
            out.push(c.to_ascii_lowercase());
            while i + 1 < chars.len() && chars[i + 1].is_ascii_uppercase() {
                i += 1;
                out.push(chars[i].to_ascii_lowercase());
            }
        } else {
            out.push(c);
        }
        i += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(xml: &str, overrides: &[(&str, &str)]) -> Result<Vec<Element>> {
        let o: Vec<(String, String)> = overrides
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect();
        read_scene_document(xml, "t.xml", Path::new("."), None, &o).map(|e| e.elements)
    }

    #[test]
    fn defaults_substitute_and_overrides_win() {
        let xml = r#"<scene version="3.0.0">
            <default name="spp" value="16"/>
            <default name="w" value="8"/>
            <integer name="a" value="$spp"/>
            <string name="b" value="$w-$spp$ $"/>
        </scene>"#;
        let e = read(xml, &[("spp", "64")]).unwrap();
        assert_eq!(e.len(), 2);
        assert_eq!(e[0].attr("value"), Some("64"));
        assert_eq!(e[1].attr("value"), Some("8-64$ $"));
        assert_eq!(e[1].at.line, 5);
    }

    #[test]
    fn undefined_parameter_names_it() {
        let xml = "<scene version=\"3.0.0\">\n<integer name=\"a\" value=\"$nope\"/></scene>";
        let msg = read(xml, &[]).unwrap_err().to_string();
        assert!(
            msg.starts_with("t.xml:2:") && msg.contains("$nope"),
            "{msg}"
        );
    }

    #[test]
    fn text_files_are_read_up_to_their_bound() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        std::fs::write(&path, "12345").unwrap();
        assert_eq!(read_text_file(&path, 5, String::new).unwrap(), "12345");
        let e = read_text_file(&path, 4, || "too long".into()).unwrap_err();
        assert_eq!(e.to_string(), "too long");
        let e = read_text_file(dir.path(), 5, String::new).unwrap_err();
        assert_eq!(e.to_string(), "not a regular file");
    }

    #[test]
    fn overrides_must_be_read() {
        let xml = "<scene>\n<default name=\"a\" value=\"1\"/>\n<integer name=\"x\" value=\"$a\"/></scene>";
        assert_eq!(
            read(xml, &[("a", "2")]).unwrap()[0].attr("value"),
            Some("2")
        );
        let msg = read(xml, &[("a", "2"), ("b", "3")])
            .unwrap_err()
            .to_string();
        assert!(
            msg.starts_with("t.xml:1:") && msg.contains("b=3 is used nowhere"),
            "{msg}"
        );
    }

    #[test]
    fn versions() {
        for ok in ["0.5.0", "0.6.0", "2.0.0", "3.0.0", "3.5", "2"] {
            read(&format!("<scene version=\"{ok}\"/>"), &[]).unwrap();
        }
        read("<scene/>", &[]).unwrap();
        for bad in ["4.0.0", "x.y", "-1"] {
            let msg = read(&format!("<scene version=\"{bad}\"/>"), &[])
                .unwrap_err()
                .to_string();
            assert!(msg.contains(bad), "{msg}");
        }
    }

    #[test]
    fn deep_nesting_is_an_error() {
        let xml = format!(
            "<scene>{}{}</scene>",
            "<shape>".repeat(200),
            "</shape>".repeat(200)
        );
        assert!(read(&xml, &[]).is_err());
    }

    #[test]
    fn snake_case_as_mitsuba() {
        for (camel, snake) in [
            ("toWorld", "to_world"),
            ("intIOR", "int_ior"),
            ("sampleCount", "sample_count"),
            ("alphaU", "alpha_u"),
            ("specularReflectance", "specular_reflectance"),
            ("B", "B"),
            ("to_world", "to_world"),
            ("fovAxis", "fov_axis"),
        ] {
            assert_eq!(snake_case(camel), snake, "{camel}");
        }
    }

    #[test]
    fn legacy_scenes_are_upgraded_and_new_ones_are_not() {
        let body = r#"<default name="camelName" value="1"/>
            <shape type="rectangle">
                <transform name="toWorld"><lookAt origin="0,0,1" target="0,0,0" up="0,1,0"/></transform>
                <bsdf type="diffuse"><rgb name="diffuseReflectance" value="$camelName"/></bsdf>
            </shape>"#;
        let old = read(&format!("<scene version=\"0.5.0\">{body}</scene>"), &[]).unwrap();
        let transform = &old[0].children[0];
        assert_eq!(transform.attr("name"), Some("to_world"));
        assert_eq!(transform.children[0].tag, "lookat");
        let reflectance = &old[0].children[1].children[0];
        assert_eq!(reflectance.attr("name"), Some("reflectance"));
        assert_eq!(reflectance.attr("value"), Some("1"));
        let new = read(&format!("<scene version=\"3.0.0\">{body}</scene>"), &[]).unwrap();
        assert_eq!(new[0].children[0].attr("name"), Some("toWorld"));
        assert_eq!(new[0].children[0].children[0].tag, "lookAt");
    }

    #[test]
    fn path_elements_come_first_in_the_search_path() {
        let dir = tempfile::tempdir().unwrap();
        for sub in ["a", "b"] {
            std::fs::create_dir(dir.path().join(sub)).unwrap();
            std::fs::write(dir.path().join(sub).join("m.obj"), "").unwrap();
        }
        std::fs::write(dir.path().join("m.obj"), "").unwrap();
        let read_in =
            |xml: &str| read_scene_document(xml, "t.xml", dir.path(), None, &[]).map(|e| e.search);
        // The latest <path> first; relative ones beside the file.
        let search = read_in(r#"<scene><path value="a"/><path value="b"/></scene>"#).unwrap();
        assert_eq!(
            search.resolve("m.obj", dir.path()),
            dir.path().join("b/m.obj")
        );
        let search = read_in(r#"<scene><path value="b"/><path value="a"/></scene>"#).unwrap();
        assert_eq!(
            search.resolve("m.obj", dir.path()),
            dir.path().join("a/m.obj")
        );
        assert_eq!(
            search.resolve("none.obj", dir.path()),
            dir.path().join("none.obj")
        );
        let search = read_in("<scene/>").unwrap();
        assert_eq!(
            search.resolve("m.obj", dir.path()),
            dir.path().join("m.obj")
        );
        // A missing directory, or a <path> inside an object, is an error.
        let msg = read_in("<scene>\n<path value=\"c\"/></scene>")
            .unwrap_err()
            .to_string();
        assert!(
            msg.starts_with("t.xml:2:") && msg.contains("\"c\""),
            "{msg}"
        );
        let msg = read_in(r#"<scene><shape type="cube"><path value="a"/></shape></scene>"#)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("child of the <scene>"), "{msg}");
    }
}
