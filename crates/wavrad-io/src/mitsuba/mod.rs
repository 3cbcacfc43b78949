//! Mitsuba 3 XML scenes (the subset wavrad can solve) → [`Scene`].
//!
//! Supported:
//!
//! - `<scene version="2.x|3.x">`, and `0.x` (Mitsuba 0.5, 0.6) upgraded as
//!   Mitsuba 3's loader upgrades it (`mitsuba/document.rs`); `<default name
//!   value/>` with `$name` substitution in every attribute (overrides, like
//!   `mitsuba -D`, win; one that no `$name` reads is an error, as in
//!   Mitsuba 3), `<include filename/>`, `<path value/>` (search
//!   directories for every relative file name: `<path>`s latest first, then
//!   beside the naming file, then the scene's directory; cycles of includes
//!   are errors, and includes are bounded: [`MAX_INCLUDE_DEPTH`],
//!   [`MAX_INCLUDES`], [`MAX_XML_BYTES`]), `<ref id/>` to any object with an
//!   `id`;
//! - shapes `rectangle`, `cube`, `disk`, `cylinder`, `sphere` (tessellated),
//!   and `obj`, `ply`, `serialized` meshes (`mitsuba/shapes/`), BSDFs
//!   (`mitsuba/bsdfs.rs`), the `area` emitter nested in a shape or declared at
//!   the top level and referenced by one, `point`, `spot`, `directional` and
//!   `constant` emitters at the top level (`mitsuba/emitters.rs`), sensors
//!   `perspective` and `orthographic` with `hdrfilm`, every Mitsuba 3
//!   `rfilter` and any sampler (`mitsuba/sensors.rs`; of several sensors the
//!   first is the scene's camera, the others views to pick); any `integrator`, its parameters
//!   checked and its unhonoured settings warned about
//!   (`mitsuba/integrators.rs`), and top-level `sampler` elements (only
//!   `sample_count` is read);
//! - parameters `<float>`, `<integer>`, `<boolean>`, `<string>`, `<point>`,
//!   `<vector>`, `<rgb>`, `<spectrum>` (converted to RGB as Mitsuba 3's RGB
//!   variants do: `mitsuba/spectrum.rs`) and `<transform>`
//!   (`mitsuba/transform.rs`);
//! - textures `checkerboard` and `bitmap` on a `diffuse` reflectance
//!   (`mitsuba/textures.rs`).
//!
//! Everything else — other plugins, media, unknown parameters or elements,
//! malformed numbers — is an error naming the file, the line and the
//! offending name; unsupported BSDFs and textures are replaced by the
//! nearest supported model when loading with [`LoadOptions::approximate`]
//! (one warning per plugin). Nothing panics on bad input. What is loaded, but not
//! as written (a mesh's triangles of zero area are skipped, a sheared sphere
//! stays a sphere), is a [`Warning`] beside the scene in [`Loaded`].
//!
//! ```
//! use std::path::Path;
//! let xml = r#"<scene version="3.0.0">
//!     <default name="r" value="0.8"/>
//!     <shape type="rectangle">
//!         <bsdf type="twosided">
//!             <bsdf type="diffuse"><float name="reflectance" value="$r"/></bsdf>
//!         </bsdf>
//!     </shape>
//! </scene>"#;
//! let loaded = wavrad_io::load_scene_str(xml, Path::new("."), "doc.xml", &[]).unwrap();
//! assert!(loaded.warnings.is_empty());
//! let scene = loaded.scene;
//! assert_eq!(scene.surfaces.len(), 2); // front and back
//! assert_eq!(scene.surfaces[0].brdf.lambertian(), Some(wavrad_core::scene::Rgb::splat(0.8)));
//! ```

mod bsdfs;
mod document;
mod emitters;
mod integrators;
mod params;
mod sensors;
mod shapes;
mod spectrum;
mod textures;
mod transform;

use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};

use wavrad_core::scene::bounds::MAX_COORDINATE;
use wavrad_core::scene::enclosed::enclosed_sides;
use wavrad_core::scene::{Film, RenderHints, Scene, Sensor as SceneSensor, Surface};

use crate::error::{Error, Result};
use document::{read_scene_document, Element, Location};
pub use document::{MAX_INCLUDES, MAX_INCLUDE_DEPTH, MAX_NESTING, MAX_XML_BYTES};
use params::{Document, Object};

/// A scene as loaded, with the warnings the loader had about it.
#[derive(Debug, Clone, PartialEq)]
pub struct Loaded {
    /// The scene.
    pub scene: Scene,
    /// What was loaded, but not as written, in document order; users should
    /// be shown them.
    pub warnings: Vec<Warning>,
}

/// Something in a scene that was loaded, but not as written (as a
/// renderer's warning log would say). The `Display` form,
/// `file:line: message`, is meant for users as is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Warning {
    /// The scene (or included) file, as named to the loader.
    pub file: String,
    /// 1-based line of the element concerned.
    pub line: u32,
    /// What was done instead.
    pub message: String,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.file, self.line, self.message)
    }
}

/// Load a Mitsuba XML scene file.
pub fn load_scene(path: &Path) -> Result<Loaded> {
    load_scene_with(path, &[])
}

/// How a scene file is read.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct LoadOptions {
    /// Replace every unsupported BSDF or texture by the nearest supported
    /// model, with one [`Warning`] per plugin saying what was substituted
    /// (`--approximate`), rather than refuse it.
    pub approximate: bool,
}

/// Load a Mitsuba XML scene file with parameter overrides (`name`, `value`),
/// which take precedence over the file's `<default>`s like Mitsuba's
/// `-D name=value`.
pub fn load_scene_with(path: &Path, defaults: &[(String, String)]) -> Result<Loaded> {
    load_scene_with_options(path, defaults, LoadOptions::default())
}

/// [`load_scene_with`], read as `options` say.
pub fn load_scene_with_options(
    path: &Path,
    defaults: &[(String, String)],
    options: LoadOptions,
) -> Result<Loaded> {
    let xml = document::read_xml(path, document::MAX_XML_BYTES).map_err(|e| Error::io(path, e))?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let own_path = std::fs::canonicalize(path).ok();
    let name = path.display().to_string();
    load(&xml, &dir, &name, own_path, defaults, options)
}

/// Load a scene from XML text. Relative paths (includes, meshes) resolve
/// against `base_dir`; messages call the text `name_for_messages`.
pub fn load_scene_str(
    xml: &str,
    base_dir: &Path,
    name_for_messages: &str,
    overrides: &[(String, String)],
) -> Result<Loaded> {
    load(
        xml,
        base_dir,
        name_for_messages,
        None,
        overrides,
        LoadOptions::default(),
    )
}

fn load(
    xml: &str,
    dir: &Path,
    name: &str,
    own_path: Option<PathBuf>,
    overrides: &[(String, String)],
    options: LoadOptions,
) -> Result<Loaded> {
    let expanded = read_scene_document(xml, name, dir, own_path, overrides)?;
    let root = Element::root(expanded.elements, name, dir);
    let mut doc = Document::new(&root, expanded.search)?;
    doc.approximate = options.approximate;
    for warning in expanded.warnings {
        doc.warn(warning);
    }
    let scene = build_scene(&root, &doc, expanded.legacy)?;
    Ok(Loaded {
        scene,
        warnings: doc.into_warnings(),
    })
}

fn build_scene(root: &Element, doc: &Document, legacy: bool) -> Result<Scene> {
    let scene = Object::parse(root, doc)?;
    scene.finish()?;
    let mut built = shapes::Built::default();
    let mut sensors = Vec::new();
    let mut top_level_samples = None;
    // The integrator's longest path, once one is read.
    let mut max_depth = None;
    let mut shape_index = 0;
    let mut top_level_emitters = Vec::new();
    let mut lights = Vec::new();
    // Area emitters by element, with the shape each is attached to.
    let mut attached: HashMap<*const Element, &Location> = HashMap::new();
    for n in &scene.nested {
        if !std::ptr::eq(n.at, &n.element.at) {
            return Err(n
                .at
                .error("a <ref> at the top level of the scene does nothing"));
        }
        match n.tag() {
            // A group's shapes are built where an instance places them.
            "shape" if n.plugin() == "shapegroup" => {}
            "shape" if n.plugin() == "instance" => {
                let first_surface = built.surfaces.len();
                shapes::build_instance(*n, doc, shape_index, &mut built)?;
                check_coordinates(&built.surfaces[first_surface..], n)?;
                shape_index += 1;
            }
            "shape" => {
                let first_surface = built.surfaces.len();
                let identity = glam::DMat4::IDENTITY;
                let emitter = shapes::build_shape(*n, doc, shape_index, &identity, &mut built)?;
                check_coordinates(&built.surfaces[first_surface..], n)?;
                if let Some(e) = emitter {
                    if let Some(first) = attached.insert(e.element, e.at) {
                        return Err(e.at.error(format!(
                            "the area emitter at {} is attached to a shape already (at {first}); \
                             an area emitter lights one shape, as in Mitsuba",
                            e.element.at
                        )));
                    }
                }
                shape_index += 1;
            }
            "bsdf" => {
                bsdfs::parse_bsdf(*n, doc)?;
            }
            "texture" => {
                textures::parse_texture(*n, doc)?;
            }
            "emitter" => match emitters::parse_top_level_emitter(*n, doc)? {
                Some(light) => lights.push(light),
                None => top_level_emitters.push(*n),
            },
            "sensor" => sensors.push(sensors::parse_sensor(*n, doc)?),
            "sampler" => {
                let count = sensors::parse_sampler(*n, doc)?;
                top_level_samples = top_level_samples.or(count);
            }
            "integrator" => {
                let depth = integrators::check_integrator(*n, doc)?;
                max_depth = max_depth.or(Some(depth));
            }
            other => {
                return Err(n.at.error(format!(
                    "<{other}> must be nested in {}",
                    if other == "rfilter" {
                        "a <film>"
                    } else {
                        "a <sensor>"
                    }
                )))
            }
        }
    }
    for n in top_level_emitters {
        if !attached.contains_key(&std::ptr::from_ref(n.element)) {
            emitters::parse_area_emitter(n, doc)?;
            doc.warn(n.at.warning(
                "this area emitter is attached to no shape (none references its id), so it \
                 lights nothing, as in Mitsuba",
            ));
        }
    }
    let max_depth = match max_depth {
        Some(depth) => depth,
        None => integrators::default_max_depth(legacy, root, doc),
    };
    // The first sensor is the scene's camera; the others are views
    // `--sensor N` picks. A sensor's own sampler wins over the scene's.
    let mut sensors = sensors.into_iter().map(|s| SceneSensor {
        camera: s.camera,
        film: s.film,
        hints: RenderHints {
            samples_per_pixel: s.samples_per_pixel.or(top_level_samples),
            max_depth,
        },
    });
    let first = sensors.next();
    let scene = Scene {
        surfaces: built.surfaces,
        camera: first.map(|s| s.camera),
        film: first.map_or_else(Film::default, |s| s.film),
        hints: first.map_or(
            RenderHints {
                samples_per_pixel: top_level_samples,
                max_depth,
            },
            |s| s.hints,
        ),
        other_sensors: sensors.collect(),
        lights,
        textures: doc.take_textures(),
        shapes: built.curved,
        glass: built.glass,
    };
    let enclosed = enclosed_sides(&scene, &built.two_sided);
    Ok(scene.without_surfaces(&enclosed))
}

/// The core's bound on coordinates ([`MAX_COORDINATE`]), checked for the
/// surfaces of `shape` so that the error names its line.
fn check_coordinates(surfaces: &[Surface], shape: &params::Nested) -> Result<()> {
    let far = surfaces
        .iter()
        .flat_map(|s| s.patch.vertices())
        .find(|v| !v.is_finite() || v.abs().max_element() > MAX_COORDINATE);
    match far {
        Some(v) => Err(shape.at.error(format!(
            "shape \"{}\" has a vertex at {v} after to_world: wavrad accepts coordinates up to \
             {MAX_COORDINATE:e} in magnitude",
            shape.plugin()
        ))),
        None => Ok(()),
    }
}
