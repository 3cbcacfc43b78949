//! What wavrad's fuzz targets run on each input (`fuzz_targets/`), shared
//! with the stable-toolchain test that runs every committed corpus file
//! through them (`crates/wavrad-io/tests/fuzz_corpus.rs`, which includes
//! this file), so the corpora are a regression suite in CI too.
//!
//! Every entry point reads its input as a user's file would be read, and
//! passes when reading returns, `Ok` or `Err`: a panic, an abort, a
//! timeout or running out of memory is the failure the fuzzer looks for.
//! What reads successfully goes on as far as wavrad would take it cheaply:
//! a scene's ray queries are built (the BVH, which must hold every
//! coordinate the loader accepts), and a solution is rendered on a tiny
//! film.

use std::path::PathBuf;

use wavrad_core::geometry::tracing::SceneTracer;
use wavrad_core::progress::Silent;
use wavrad_core::render::{RenderSettings, Renderer};
use wavrad_core::scene::Film;
use wavrad_core::setting::Value;
use wavrad_io::solution_file::{
    checkpoint_file_bytes, read_solution, read_unfinished, solution_file_bytes,
};

/// The files a fuzzed scene may include or name besides its own: a scene
/// fragment with a `<default>` and a BSDF with an `id`, and the loader
/// tests' mesh and spectrum.
const FIXED_FILES: [(&str, &[u8]); 3] = [
    ("base.xml", include_bytes!("../fixtures/base.xml")),
    (
        "quad.obj",
        include_bytes!("../../crates/wavrad-io/tests/fixtures/structure/meshes/quad.obj"),
    ),
    (
        "white.spd",
        include_bytes!("../../crates/wavrad-io/tests/fixtures/structure/meshes/white.spd"),
    ),
];

/// Separates a `scene_xml` input's parts: the scene, then `part.xml`,
/// then `-D` overrides.
pub const PART_SEPARATOR: u8 = 0;

/// A fuzz target (`fuzz_targets/`) that runs the [`Workspace`] method
/// `$entry` on each input, in one temporary workspace per process.
#[macro_export]
macro_rules! workspace_target {
    ($entry:ident) => {
        libfuzzer_sys::fuzz_target!(|input: &[u8]| {
            static WORKSPACE: std::sync::OnceLock<(tempfile::TempDir, $crate::Workspace)> =
                std::sync::OnceLock::new();
            WORKSPACE
                .get_or_init($crate::Workspace::temporary)
                .1
                .$entry(input);
        });
    };
}

/// What a fuzz target runs on an input.
pub type Target = fn(&Workspace, &[u8]);

/// The fuzz targets by name (their corpus directory, `corpus/NAME/`), with
/// what each runs.
pub const TARGETS: [(&str, Target); 6] = [
    ("scene_xml", Workspace::scene_xml),
    ("obj", Workspace::obj),
    ("ply", Workspace::ply),
    ("serialized", Workspace::serialized),
    ("solution", Workspace::solution),
    ("checkpoint", Workspace::checkpoint),
];

/// A directory the entry points write their inputs to, to be read as
/// files, beside [`FIXED_FILES`].
pub struct Workspace {
    dir: PathBuf,
}

impl Workspace {
    /// A workspace in a new temporary directory, removed with the
    /// [`tempfile::TempDir`].
    pub fn temporary() -> (tempfile::TempDir, Workspace) {
        let dir = tempfile::tempdir().expect("a temporary directory");
        for (name, bytes) in FIXED_FILES {
            std::fs::write(dir.path().join(name), bytes).expect("writing a fixed file");
        }
        let workspace = Workspace {
            dir: dir.path().to_path_buf(),
        };
        (dir, workspace)
    }

    /// `bytes` written to the workspace file `name`, and its path.
    fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.dir.join(name);
        std::fs::write(&path, bytes).expect("writing a fuzz input");
        path
    }

    /// A Mitsuba XML scene: `input` split at [`PART_SEPARATOR`] into
    /// `scene.xml`, `part.xml` (which the scene, or the part itself, may
    /// `<include>`) and `-D` overrides, one `NAME=VALUE` a line; loaded
    /// with the overrides and, when it loads, its ray queries built.
    pub fn scene_xml(&self, input: &[u8]) {
        let mut parts = input.splitn(3, |&b| b == PART_SEPARATOR);
        let scene = self.file("scene.xml", parts.next().unwrap_or_default());
        self.file("part.xml", parts.next().unwrap_or_default());
        let overrides: Vec<(String, String)> =
            String::from_utf8_lossy(parts.next().unwrap_or_default())
                .lines()
                .filter_map(|line| line.split_once('='))
                .map(|(name, value)| (name.to_string(), value.to_string()))
                .collect();
        if let Ok(loaded) = wavrad_io::load_scene_with(&scene, &overrides) {
            SceneTracer::new(&loaded.scene);
        }
    }

    /// A mesh file of `plugin` (`obj`, `ply`, `serialized`) with the bytes
    /// of `input`, loaded as a scene's shape (with its `shape_index`), so
    /// that its triangles go through what the loader does with them and
    /// the BVH is built.
    fn mesh(&self, plugin: &str, input: &[u8], shape_index: u32) {
        let name = format!("mesh.{plugin}");
        self.file(&name, input);
        let xml = format!(
            r#"<scene version="3.0.0">
                <shape type="{plugin}">
                    <string name="filename" value="{name}"/>
                    {}
                </shape>
            </scene>"#,
            match plugin {
                "serialized" => format!(r#"<integer name="shape_index" value="{shape_index}"/>"#),
                _ => String::new(),
            }
        );
        if let Ok(loaded) = wavrad_io::load_scene_str(&xml, &self.dir, "mesh.xml", &[]) {
            SceneTracer::new(&loaded.scene);
        }
    }

    /// A Wavefront OBJ file.
    pub fn obj(&self, input: &[u8]) {
        self.mesh("obj", input, 0);
    }

    /// A Stanford PLY file.
    pub fn ply(&self, input: &[u8]) {
        self.mesh("ply", input, 0);
    }

    /// A Mitsuba `serialized` file: its first shape, and its second (which
    /// is found through the file's dictionary).
    pub fn serialized(&self, input: &[u8]) {
        for shape_index in [0, 1] {
            self.mesh("serialized", input, shape_index);
        }
    }

    /// A solution file's body before compression (postcard), behind a
    /// header and checksum made for it, so that every input gets past the
    /// checks of the header and the checksum into decoding; what reads is
    /// rendered on a 4×3 film with one camera ray per pixel, by the final
    /// gather and by the preview.
    pub fn solution(&self, input: &[u8]) {
        let file = solution_file_bytes(input).expect("zstd compresses any input");
        let path = self.file("fuzz.wavrad", &file);
        let Ok(read) = read_solution(&path) else {
            return;
        };
        let mut solution = read.solution;
        solution.scene.film = Film {
            width: 4,
            height: 3,
            ..solution.scene.film
        };
        let renderer = Renderer::new(solution);
        let _ = renderer.render(&RenderSettings::default().with_samples_per_pixel(1));
        let _ = renderer.preview();
    }

    /// A checkpoint file's body before compression (postcard), framed as
    /// [`Workspace::solution`]'s; what reads is resumed on its own scene
    /// with a time limit of 5 ms (refinement stops there, and the items
    /// left are linked whole), as `wavrad solve --resume` would resume it.
    pub fn checkpoint(&self, input: &[u8]) {
        let file = checkpoint_file_bytes(input).expect("zstd compresses any input");
        let path = self.file("fuzz.checkpoint.wavrad", &file);
        let Ok(read) = read_unfinished(&path) else {
            return;
        };
        let Ok(settings) = read
            .settings
            .for_resuming(&[("time_limit", Value::Real(0.005))])
        else {
            return;
        };
        let _ =
            wavrad_core::solve::resume(&read.scene, &settings, read.unfinished(), None, &Silent);
    }
}
