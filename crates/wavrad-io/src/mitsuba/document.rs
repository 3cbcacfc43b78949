//! From XML text to a tree of [`Element`]s with `<default>`, `$name`
//! substitution and `<include>` already applied, each element knowing the
//! file and line it came from.

use std::collections::HashMap;
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

/// Deepest element nesting (and include depth) accepted; deeper input is an
/// error rather than a stack overflow.
const MAX_DEPTH: usize = 64;

/// Parse the scene document `xml` and return the children of its `<scene>`
/// root, expanded. `own_path` (canonical) is the file itself when it has one,
/// for include-cycle detection.
pub(crate) fn read_scene_document(
    xml: &str,
    name: &str,
    dir: &Path,
    own_path: Option<PathBuf>,
    overrides: &[(String, String)],
) -> Result<Vec<Element>> {
    let mut expander = Expander {
        params: overrides.iter().cloned().collect(),
        include_stack: own_path.into_iter().collect(),
        scene_dir: Arc::from(dir),
    };
    expander.document(xml, name, dir)
}

struct Expander {
    /// `$name` values: overrides first, then `<default>`s in document order
    /// (the first definition wins, as in Mitsuba).
    params: HashMap<String, String>,
    /// Canonical paths of the files being read, outermost first.
    include_stack: Vec<PathBuf>,
    /// Directory of the top-level scene file: the fallback for relative
    /// include paths (Mitsuba's file resolver).
    scene_dir: Arc<Path>,
}

impl Expander {
    fn document(&mut self, xml: &str, name: &str, dir: &Path) -> Result<Vec<Element>> {
        let file: Arc<str> = Arc::from(name);
        let dir: Arc<Path> = Arc::from(dir);
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
        for attr in root.attributes() {
            match attr.name() {
                "version" => check_version(attr.value(), &at)?,
                other => {
                    return Err(at.error(format!(
                        "unexpected attribute \"{other}\" in <scene> (allowed: version)"
                    )))
                }
            }
        }
        let mut out = Vec::new();
        self.children(&doc, root, &file, &dir, 1, &mut out)?;
        Ok(out)
    }

    fn children(
        &mut self,
        doc: &roxmltree::Document,
        node: roxmltree::Node,
        file: &Arc<str>,
        dir: &Arc<Path>,
        depth: usize,
        out: &mut Vec<Element>,
    ) -> Result<()> {
        for child in node.children().filter(|n| n.is_element()) {
            let at = Location {
                file: file.clone(),
                line: doc.text_pos_at(child.range().start).row,
                dir: dir.clone(),
            };
            if depth > MAX_DEPTH {
                return Err(at.error(format!("elements nested deeper than {MAX_DEPTH} levels")));
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
                    self.params.entry(name).or_insert(value);
                }
                "include" => {
                    element.check_attrs(&["filename"])?;
                    let filename = element.required_attr("filename")?.to_string();
                    self.include(&element.at, &filename, out)?;
                }
                _ => {
                    self.children(doc, child, file, dir, depth + 1, &mut element.children)?;
                    out.push(element);
                }
            }
        }
        Ok(())
    }

    fn include(&mut self, at: &Location, filename: &str, out: &mut Vec<Element>) -> Result<()> {
        let path = resolve_path(filename, &at.dir, &self.scene_dir);
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
        if self.include_stack.len() > MAX_DEPTH {
            return Err(at.error(format!("includes nested deeper than {MAX_DEPTH} levels")));
        }
        let xml = std::fs::read_to_string(&path).map_err(|e| {
            at.error(format!(
                "cannot read included file \"{}\": {e}",
                path.display()
            ))
        })?;
        let dir = path
            .parent()
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
        self.include_stack.push(canonical);
        let elements = self.document(&xml, &path.display().to_string(), &dir);
        self.include_stack.pop();
        out.extend(elements?);
        Ok(())
    }

    /// Replace every `$name` in `value` (name: letters, digits, `_`); a `$`
    /// not followed by a name stays as is.
    fn substitute(&self, value: &str, at: &Location) -> Result<String> {
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
            }
            rest = &after[len..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

/// A relative `filename` is looked up beside the file that names it, then
/// in the top-level scene's directory (where Mitsuba's file resolver looks).
pub(crate) fn resolve_path(filename: &str, dir: &Path, scene_dir: &Path) -> PathBuf {
    let p = Path::new(filename);
    if p.is_absolute() {
        return p.to_path_buf();
    }
    let beside = dir.join(p);
    if beside.exists() {
        return beside;
    }
    let in_scene_dir = scene_dir.join(p);
    if in_scene_dir.exists() {
        in_scene_dir
    } else {
        beside
    }
}

/// Accept Mitsuba 2.x and 3.x scene versions.
fn check_version(version: &str, at: &Location) -> Result<()> {
    let parts: Vec<&str> = version.trim().split('.').collect();
    let numeric = parts.len() <= 3 && parts.iter().all(|p| p.parse::<u32>().is_ok());
    if !numeric {
        return Err(at.error(format!("malformed scene version \"{version}\"")));
    }
    match parts[0] {
        "2" | "3" => Ok(()),
        _ => Err(at.error(format!(
            "unsupported scene version \"{version}\" (supported: 2.x, 3.x)"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(xml: &str, overrides: &[(&str, &str)]) -> Result<Vec<Element>> {
        let o: Vec<(String, String)> = overrides
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect();
        read_scene_document(xml, "t.xml", Path::new("."), None, &o)
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
    fn versions() {
        for ok in ["2.0.0", "3.0.0", "3.5", "2"] {
            read(&format!("<scene version=\"{ok}\"/>"), &[]).unwrap();
        }
        read("<scene/>", &[]).unwrap();
        for bad in ["0.6.0", "4.0.0", "x.y"] {
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
}
