//! Solution files (`.wavrad`): a solve written once and rendered from any
//! number of times, in this process or another, without solving again.
//!
//! A file is a fixed header and a body:
//!
//! | bytes | what |
//! |---|---|
//! | 0..8 | [`MAGIC`], `wavrad` and the kind of file |
//! | 8..12 | [`FORMAT_VERSION`], little-endian |
//! | 12..44 | the wavrad version that wrote it, ASCII, zero-padded |
//! | 44..52 | the body's length in bytes, little-endian |
//! | 52..56 | the body's CRC-32 (IEEE), little-endian |
//! | 56.. | the body |
//!
//! The body is the solution in [postcard](https://docs.rs/postcard)
//! (integers as varints, floats as their IEEE bytes, so a solution reads
//! back bit for bit), compressed with [zstd](https://docs.rs/zstd): the
//! scene as solved, the element trees, the radiance of every element and
//! element pair, the links arranged for gathering, the settings and the
//! statistics, where the scene came from ([`Source`]), and for a solve cut
//! short its [`Checkpoint`] (the linking and the links of the items it
//! finished, for `wavrad solve --resume`). The ray queries are rebuilt
//! from the scene on reading, as the solve built them.
//!
//! A solve under way can also save *checkpoint files* ([`write_checkpoint`]):
//! the same header with [`CHECKPOINT_MAGIC`], and a body of the scene, the
//! settings, the source and the [`Checkpoint`] alone, which only a resumed
//! solve reads ([`read_unfinished`]).
//!
//! Reading refuses, each with its own [`SolutionProblem`]: a file that is
//! not a solution (or is a checkpoint file), one of another format version, one cut short, one whose
//! body does not match its checksum, and one whose scene file now loads to
//! another scene than the one solved (the scene file, an included file or
//! a mesh was edited since the solve), so a stale solution is never
//! rendered as the current scene. The scene is embedded, so a solution
//! whose scene file is gone still renders, with a warning that it could
//! not be checked.
//!
//! ```
//! use wavrad_core::progress::Silent;
//! use wavrad_core::solve::{solve, SolveSettings};
//! use wavrad_io::solution_file::{read_solution, write_solution};
//!
//! let scene = wavrad_core::testing::light_over_a_corner(0.3);
//! let solution = solve(&scene, &SolveSettings::default(), &Silent).unwrap();
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("corner.wavrad");
//! write_solution(&path, &solution, None).unwrap();
//! let read = read_solution(&path).unwrap();
//! assert_eq!(read.solution.radiance, solution.radiance);
//! assert!(read.warnings.is_empty());
//! ```

mod check;
mod checkpoint_file;

pub use checkpoint_file::{
    checkpoint_file_bytes, read_unfinished, write_checkpoint, ReadUnfinished, CHECKPOINT_MAGIC,
};

use crate::{Error, LoadOptions, Result};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use wavrad_core::geometry::hierarchy::ElementTree;
use wavrad_core::geometry::tracing::SceneTracer;
use wavrad_core::scene::{Rgb, Scene};
use wavrad_core::setting::Described;
use wavrad_core::solve::gather::Interactions;
use wavrad_core::solve::stats::Stats;
use wavrad_core::solve::{Checkpoint, Solution, SolveSettings};

/// The first bytes of a solution file.
pub const MAGIC: [u8; 8] = *b"wavradSF";

/// The version of the format [`write_solution`] writes and
/// [`read_solution`] reads; a change of the body, or of any type it holds,
/// needs a new one.
pub const FORMAT_VERSION: u32 = 18;

/// Bytes before the body.
const HEADER_LEN: usize = 56;

/// Bytes of the header's wavrad version.
const WRITER_LEN: usize = 32;
const _: () = assert!(env!("CARGO_PKG_VERSION").len() <= WRITER_LEN);

/// zstd's level for the body: its default, which on the bundled scenes
/// compresses about as well as its higher levels in a fraction of their
/// time.
const ZSTD_LEVEL: i32 = 3;

/// zstd's worker threads for the body, at most. Its multithreaded frames
/// are the same bytes for any number of workers, so a file does not depend
/// on the machine that wrote it.
const ZSTD_WORKERS: usize = 8;

/// How many times its compressed size a body may decompress to: real
/// solutions compress about 2–4×, and the bound keeps a crafted file from
/// taking unbounded memory.
const MAX_EXPANSION: u64 = 256;

/// Where a solved scene came from: the scene file and the `-D` values it
/// was loaded with. Reading a solution loads it again and compares.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Source {
    /// The scene file, as an absolute path.
    pub scene: PathBuf,
    /// The parameters set on loading (`-D NAME=VALUE`), in order.
    pub defines: Vec<(String, String)>,
    /// How it was read (`--approximate`).
    pub options: LoadOptions,
}

impl Source {
    /// The source of a scene loaded from `scene` with `defines` and
    /// `options` ([`crate::load_scene_with_options`]).
    pub fn new(scene: &Path, defines: &[(String, String)], options: LoadOptions) -> Result<Source> {
        Ok(Source {
            scene: std::fs::canonicalize(scene).map_err(|e| Error::io(scene, e))?,
            defines: defines.to_vec(),
            options,
        })
    }
}

/// What [`read_solution`] read.
pub struct ReadSolution {
    /// The solution, ready to render.
    pub solution: Solution,
    /// Where its scene came from, if it was written with one.
    pub source: Option<Source>,
    /// The wavrad version that wrote it.
    pub written_by: String,
    /// What users should be told: that the scene file could not be
    /// checked, because it is not there any more.
    pub warnings: Vec<String>,
}

/// What is wrong with a solution file ([`Error::Solution`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SolutionProblem {
    /// It does not start with [`MAGIC`].
    #[error("not a wavrad solution file (it does not start with {:?})", String::from_utf8_lossy(&MAGIC))]
    NotASolution,
    /// A checkpoint file ([`write_checkpoint`]): a solve under way, not a
    /// solution.
    #[error(
        "a checkpoint of a solve that did not finish, not a solution: \
         `wavrad solve SCENE --resume FILE -o NEW.wavrad` finishes it"
    )]
    Checkpoint,
    /// A solution that ran to the end, given to resume.
    #[error("the solve ran to the end: nothing is left to resume")]
    Finished,
    /// Another format version.
    #[error(
        "format version {found}, written by wavrad {written_by}; this wavrad ({}) reads version \
         {FORMAT_VERSION}: solve the scene again",
        env!("CARGO_PKG_VERSION")
    )]
    Version {
        /// The file's format version.
        found: u32,
        /// The wavrad version that wrote it.
        written_by: String,
    },
    /// Shorter than its header says.
    #[error("truncated: {found} bytes of {expected} (the write was cut short, or the copy)")]
    Truncated {
        /// The bytes the header promises.
        expected: u64,
        /// The bytes there are.
        found: u64,
    },
    /// Longer than its header says.
    #[error("{0} stray bytes after the solution")]
    TrailingBytes(u64),
    /// The body does not match its checksum.
    #[error("damaged: the checksum is {computed:08x}, the header says {stored:08x}")]
    Checksum {
        /// The CRC-32 in the header.
        stored: u32,
        /// The CRC-32 of the body as read.
        computed: u32,
    },
    /// The body matches its checksum but is not a solution (a writer's
    /// bug, or a file made by hand).
    #[error("damaged: {0}")]
    Undecodable(String),
    /// The body decodes, but its parts do not fit together (a writer's
    /// bug, or a file made by hand): an index out of range, a value that
    /// is not finite, a tree that is not one ([`read_solution`] checks
    /// everything the renderer relies on).
    #[error("damaged: {part}: {problem}")]
    Inconsistent {
        /// The part of the solution, e.g. `surface 3's incoming transfer
        /// 12`.
        part: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The scene file loads to another scene than the one solved.
    #[error(
        "the scene changed since the solve: {scene} now loads with {difference}; solve it again"
    )]
    SceneChanged {
        /// The scene file.
        scene: PathBuf,
        /// What differs (or why it no longer loads).
        difference: String,
    },
}

/// Write `solution` to `path` atomically (a temporary file beside it,
/// renamed into place), with the `source` its scene was loaded from, if
/// any, for [`read_solution`] to check.
pub fn write_solution(path: &Path, solution: &Solution, source: Option<&Source>) -> Result<()> {
    write_body(path, &MAGIC, &Body::of(solution, source))
}

/// Write `body` to `path` atomically, in a file of the kind `magic`. The
/// body is encoded and compressed as it is written, so neither it nor its
/// compressed bytes are ever held whole: a large solve's file costs no more
/// memory than the solution it holds.
fn write_body(path: &Path, magic: &[u8; 8], body: &impl Serialize) -> Result<()> {
    crate::image::write_atomically(path, |file| {
        write_file(file, magic, |out| encode(body, out)).map_err(|e| Error::io(path, e))
    })
}

/// Write `body` in postcard to `out` as it is encoded. An error of `out`
/// is returned as it came (postcard would report any as a full buffer);
/// a body postcard cannot write (a path that is not UTF-8) is invalid data.
fn encode(body: &impl Serialize, out: &mut dyn Write) -> std::io::Result<()> {
    let mut out = Recording::new(out);
    let encoded = postcard::to_io(body, &mut out).map(drop);
    out.into_result()?;
    encoded.map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
}

/// The bytes of a solution file whose body, before compression, is
/// `encoded` (a [`Solution`] in postcard): the header, with the body's
/// length and checksum, then the body compressed, as [`write_solution`]
/// writes them. Tools that make files by other means (the fuzz targets,
/// which fuzz the body behind a checksum that matches it) use it.
pub fn solution_file_bytes(encoded: &[u8]) -> std::io::Result<Vec<u8>> {
    file_bytes(&MAGIC, encoded)
}

/// [`solution_file_bytes`] for a file of the kind `magic`.
fn file_bytes(magic: &[u8; 8], encoded: &[u8]) -> std::io::Result<Vec<u8>> {
    let mut file = std::io::Cursor::new(Vec::new());
    write_file(&mut file, magic, |out| out.write_all(encoded))?;
    Ok(file.into_inner())
}

/// Write a file of the kind `magic` to `file`: the header, then the body
/// that `encode` writes, compressed as it comes. The header's length and
/// checksum are written last, once the compressed body is known.
fn write_file<W: Write + Seek>(
    file: &mut W,
    magic: &[u8; 8],
    encode: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> std::io::Result<()> {
    file.write_all(&header(magic, 0, 0))?;
    let mut body = Checksummed::new(BufWriter::new(&mut *file));
    let mut compressor = zstd::stream::Encoder::new(&mut body, ZSTD_LEVEL)?;
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    compressor.multithread(cores.min(ZSTD_WORKERS) as u32)?;
    // postcard writes a value's few bytes at a time.
    let mut buffered = BufWriter::new(compressor);
    encode(&mut buffered)?;
    buffered
        .into_inner()
        .map_err(|e| e.into_error())?
        .finish()?;
    let (length, checksum) = (body.length, body.checksum.clone().finalize());
    body.inner.flush()?;
    drop(body);
    file.seek(SeekFrom::Start(0))?;
    file.write_all(&header(magic, length, checksum))?;
    file.seek(SeekFrom::End(0))?;
    Ok(())
}

/// The header of a file of the kind `magic` whose compressed body is
/// `length` bytes with the CRC-32 `checksum`.
fn header(magic: &[u8; 8], length: u64, checksum: u32) -> [u8; HEADER_LEN] {
    let mut header = [0u8; HEADER_LEN];
    header[..8].copy_from_slice(magic);
    header[8..12].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
    let version = env!("CARGO_PKG_VERSION").as_bytes();
    header[12..12 + version.len()].copy_from_slice(version);
    header[44..52].copy_from_slice(&length.to_le_bytes());
    header[52..56].copy_from_slice(&checksum.to_le_bytes());
    header
}

/// A writer that passes bytes on and counts them and their CRC-32.
struct Checksummed<W> {
    inner: W,
    length: u64,
    checksum: crc32fast::Hasher,
}

impl<W> Checksummed<W> {
    fn new(inner: W) -> Self {
        Checksummed {
            inner,
            length: 0,
            checksum: crc32fast::Hasher::new(),
        }
    }
}

impl<W: Write> Write for Checksummed<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.length += n as u64;
        self.checksum.update(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// A writer that keeps the first error of the one it wraps, for
/// [`encode`]. Its flush does nothing: postcard flushes once it has
/// written, and a flush of the compressor would end a block there (the
/// caller finishes the compressed body).
struct Recording<'a> {
    inner: &'a mut dyn Write,
    error: Option<std::io::Error>,
}

impl<'a> Recording<'a> {
    fn new(inner: &'a mut dyn Write) -> Self {
        Recording { inner, error: None }
    }

    /// The first error, if any.
    fn into_result(self) -> std::io::Result<()> {
        self.error.map_or(Ok(()), Err)
    }
}

impl Write for Recording<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self.inner.write(buf) {
            Err(e) if e.kind() != std::io::ErrorKind::Interrupted => {
                let kind = e.kind();
                self.error.get_or_insert(e);
                Err(kind.into())
            }
            written => written,
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Read the solution in `path`, rebuild its ray queries, and check that
/// its scene file, if it was written with one and is still there, loads
/// with the same `-D` values to the scene solved.
///
/// # Errors
/// [`Error::Io`] if the file cannot be read; [`Error::Solution`] if it is
/// not a solution file, is of another format version, is truncated or
/// damaged, or its scene changed since the solve.
pub fn read_solution(path: &Path) -> Result<ReadSolution> {
    let bytes = read_file(path)?;
    if bytes.starts_with(&CHECKPOINT_MAGIC) {
        return Err(Error::solution(path, SolutionProblem::Checkpoint));
    }
    solution_of(path, &bytes)
}

/// The bytes of the regular file `path`.
fn read_file(path: &Path) -> Result<Vec<u8>> {
    let metadata = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !metadata.is_file() {
        return Err(Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file"),
        ));
    }
    std::fs::read(path).map_err(|e| Error::io(path, e))
}

/// [`read_solution`] of the solution file `path` whose bytes are `bytes`.
fn solution_of(path: &Path, bytes: &[u8]) -> Result<ReadSolution> {
    let (written_by, body) = decode(&MAGIC, bytes).map_err(|p| Error::solution(path, p))?;
    let Body {
        source,
        scene,
        pairs,
        trees,
        radiance,
        interactions,
        directional,
        settings,
        stats,
        checkpoint,
    } = body;
    let mut stats = stats.into_owned();
    stats.settings = settings.values().into_iter().collect();
    let scene = scene.into_owned();
    // The ray queries' BVH needs the scene's coordinates within bounds.
    scene
        .check_bounds()
        .map_err(|e| Error::solution(path, check::inconsistent("the scene", e)))?;
    let solution = Solution {
        tracer: SceneTracer::new(&scene),
        scene,
        pairs: pairs.into_owned(),
        trees: trees.into_owned(),
        radiance: radiance.into_owned(),
        interactions: interactions.into_owned(),
        directional: directional.into_owned(),
        settings,
        stats,
        checkpoint: checkpoint.map(Cow::into_owned),
    };
    check::check_solution(&solution).map_err(|p| Error::solution(path, p))?;
    let source = source.map(Cow::into_owned);
    let mut warnings = Vec::new();
    if let Some(source) = &source {
        if let Some(warning) = check_source(path, source, &solution.scene)? {
            warnings.push(warning);
        }
    }
    Ok(ReadSolution {
        solution,
        source,
        written_by,
        warnings,
    })
}

/// What a solution file's body holds: every field of a [`Solution`] but
/// its ray queries, and the scene's [`Source`]. Borrowed to write, owned
/// when read.
#[derive(Serialize, Deserialize)]
struct Body<'a> {
    source: Option<Cow<'a, Source>>,
    scene: Cow<'a, Scene>,
    pairs: Cow<'a, [(u32, u32)]>,
    trees: Cow<'a, [ElementTree]>,
    radiance: Cow<'a, [Vec<Rgb>]>,
    interactions: Cow<'a, Interactions>,
    directional: Cow<'a, [Vec<Rgb>]>,
    settings: SolveSettings,
    stats: Cow<'a, Stats>,
    checkpoint: Option<Cow<'a, Checkpoint>>,
}

impl<'a> Body<'a> {
    /// The body of `solution`, borrowed, with its `source`.
    fn of(solution: &'a Solution, source: Option<&'a Source>) -> Body<'a> {
        Body {
            source: source.map(Cow::Borrowed),
            scene: Cow::Borrowed(&solution.scene),
            pairs: Cow::Borrowed(&solution.pairs),
            trees: Cow::Borrowed(&solution.trees),
            radiance: Cow::Borrowed(&solution.radiance),
            interactions: Cow::Borrowed(&solution.interactions),
            directional: Cow::Borrowed(&solution.directional),
            settings: solution.settings,
            stats: Cow::Borrowed(&solution.stats),
            checkpoint: solution.checkpoint.as_ref().map(Cow::Borrowed),
        }
    }
}

/// The writer's version and the body of the `bytes` of a file of the kind
/// `magic`.
fn decode<T: serde::de::DeserializeOwned>(
    magic: &[u8; 8],
    bytes: &[u8],
) -> std::result::Result<(String, T), SolutionProblem> {
    let start = &bytes[..bytes.len().min(magic.len())];
    if start != &magic[..start.len()] || bytes.is_empty() {
        return Err(SolutionProblem::NotASolution);
    }
    if bytes.len() < HEADER_LEN {
        return Err(SolutionProblem::Truncated {
            expected: HEADER_LEN as u64,
            found: bytes.len() as u64,
        });
    }
    let field = |range: std::ops::Range<usize>| &bytes[range];
    let version = u32::from_le_bytes(field(8..12).try_into().expect("4 bytes"));
    let writer = field(12..12 + WRITER_LEN);
    let written_by =
        String::from_utf8_lossy(&writer[..writer.iter().take_while(|&&b| b != 0).count()])
            .into_owned();
    if version != FORMAT_VERSION {
        return Err(SolutionProblem::Version {
            found: version,
            written_by,
        });
    }
    let length = u64::from_le_bytes(field(44..52).try_into().expect("8 bytes"));
    let stored = u32::from_le_bytes(field(52..56).try_into().expect("4 bytes"));
    let body = &bytes[HEADER_LEN..];
    let found = body.len() as u64;
    if found < length {
        return Err(SolutionProblem::Truncated {
            expected: HEADER_LEN as u64 + length,
            found: bytes.len() as u64,
        });
    }
    if found > length {
        return Err(SolutionProblem::TrailingBytes(found - length));
    }
    let computed = crc32fast::hash(body);
    if computed != stored {
        return Err(SolutionProblem::Checksum { stored, computed });
    }
    let undecodable = |e: &dyn std::fmt::Display| SolutionProblem::Undecodable(e.to_string());
    let limit = MAX_EXPANSION * length + (1 << 20);
    let mut encoded = Vec::new();
    zstd::stream::Decoder::new(body)
        .and_then(|decoder| decoder.take(limit + 1).read_to_end(&mut encoded))
        .map_err(|e| undecodable(&e))?;
    if encoded.len() as u64 > limit {
        return Err(undecodable(&format_args!(
            "it decompresses to more than {limit} bytes ({MAX_EXPANSION} times its size)"
        )));
    }
    let body = postcard::from_bytes(&encoded).map_err(|e| undecodable(&e))?;
    Ok((written_by, body))
}

/// Load `source` again and compare it with the `solved` scene: an error
/// if it loads differently or not at all, a warning if the scene file is
/// not there to check.
fn check_source(path: &Path, source: &Source, solved: &Scene) -> Result<Option<String>> {
    if !source.scene.exists() {
        return Ok(Some(format!(
            "{}: its scene file {} is not there, so it is rendered as solved, unchecked",
            path.display(),
            source.scene.display()
        )));
    }
    let changed = |difference: String| {
        Error::solution(
            path,
            SolutionProblem::SceneChanged {
                scene: source.scene.clone(),
                difference,
            },
        )
    };
    let now = match crate::load_scene_with_options(&source.scene, &source.defines, source.options) {
        Ok(loaded) => loaded.scene,
        Err(e) => return Err(changed(format!("an error: {e}"))),
    };
    match solved.difference(&now) {
        Some(difference) => Err(changed(difference)),
        None => Ok(None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wavrad_core::progress::Silent;
    use wavrad_core::solve::solve;

    /// A light over a floor of `floor_bsdf`, its radiance a parameter, and
    /// a sensor.
    fn scene_xml(floor_bsdf: &str) -> String {
        format!(
            r#"<scene version="3.0.0">
    <default name="radiance" value="1"/>
    <sensor type="perspective">
        <transform name="to_world"><lookat origin="0,0,3" target="0,0,0" up="0,1,0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
    </sensor>
    <shape type="rectangle" id="light">
        <emitter type="area"><rgb name="radiance" value="$radiance"/></emitter>
    </shape>
    <shape type="rectangle" id="floor">
        <transform name="to_world"><rotate x="1" angle="-90"/><translate y="-1" z="1"/></transform>
        {floor_bsdf}
    </shape>
</scene>
"#
        )
    }

    const GLOSSY: &str = r#"<bsdf type="roughconductor"><float name="alpha" value="0.2"/></bsdf>"#;

    /// The scene in `dir`/scene.xml solved, with its source (radiance 2).
    fn solved(dir: &Path, floor_bsdf: &str) -> (Solution, Source) {
        let scene = dir.join("scene.xml");
        std::fs::write(&scene, scene_xml(floor_bsdf)).unwrap();
        let defines = [("radiance".to_string(), "2".to_string())];
        let loaded = crate::load_scene_with(&scene, &defines).unwrap();
        let settings = SolveSettings::default();
        let solution = solve(&loaded.scene, &settings, &Silent).unwrap();
        (
            solution,
            Source::new(&scene, &defines, LoadOptions::default()).unwrap(),
        )
    }

    /// `solution` written to `dir`/solution.wavrad with `source`, as bytes.
    fn written(dir: &Path, solution: &Solution, source: Option<&Source>) -> (PathBuf, Vec<u8>) {
        let path = dir.join("solution.wavrad");
        write_solution(&path, solution, source).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        (path, bytes)
    }

    /// The problem reading `bytes` as a solution file in `dir`.
    fn problem_of(dir: &Path, bytes: &[u8]) -> SolutionProblem {
        let path = dir.join("damaged.wavrad");
        std::fs::write(&path, bytes).unwrap();
        match read_solution(&path) {
            Err(Error::Solution {
                path: named,
                problem,
            }) => {
                assert_eq!(named, path);
                problem
            }
            Err(e) => panic!("another error: {e}"),
            Ok(_) => panic!("read"),
        }
    }

    #[test]
    fn solutions_round_trip_bit_for_bit() {
        for floor in ["", GLOSSY] {
            let dir = tempfile::tempdir().unwrap();
            let (solution, source) = solved(dir.path(), floor);
            assert_eq!(floor.is_empty(), solution.directional.is_empty());
            let (path, bytes) = written(dir.path(), &solution, Some(&source));
            let read = read_solution(&path).unwrap();
            assert!(read.warnings.is_empty(), "{:?}", read.warnings);
            assert_eq!(read.source.as_ref(), Some(&source));
            assert_eq!(read.written_by, env!("CARGO_PKG_VERSION"));
            let (a, b) = (&solution, &read.solution);
            assert_eq!(a.scene, b.scene);
            assert_eq!(a.pairs, b.pairs);
            assert_eq!(a.trees, b.trees);
            assert_eq!(a.radiance, b.radiance);
            assert_eq!(a.interactions, b.interactions);
            assert_eq!(a.directional, b.directional);
            assert_eq!(a.settings, b.settings);
            assert_eq!(a.stats, b.stats);
            // Written again, the same bytes.
            let again = dir.path().join("again.wavrad");
            write_solution(&again, b, Some(&source)).unwrap();
            assert_eq!(std::fs::read(&again).unwrap(), bytes);
        }
    }

    #[test]
    fn a_body_written_as_it_is_encoded_makes_the_file_of_its_encoded_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let (solution, source) = solved(dir.path(), GLOSSY);
        let (_, bytes) = written(dir.path(), &solution, Some(&source));
        let encoded = postcard::to_allocvec(&Body::of(&solution, Some(&source))).unwrap();
        assert_eq!(zstd::decode_all(&bytes[HEADER_LEN..]).unwrap(), encoded);
        assert_eq!(solution_file_bytes(&encoded).unwrap(), bytes);
    }

    #[test]
    fn a_write_that_fails_reports_the_error_of_the_file() {
        /// A file with room for `room` more bytes.
        struct Full {
            room: usize,
        }
        impl Write for Full {
            fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
                if self.room == 0 {
                    return Err(std::io::ErrorKind::StorageFull.into());
                }
                let n = buf.len().min(self.room);
                self.room -= n;
                Ok(n)
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        impl Seek for Full {
            fn seek(&mut self, _: SeekFrom) -> std::io::Result<u64> {
                Ok(0)
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let (solution, _) = solved(dir.path(), "");
        let body = Body::of(&solution, None);
        for room in [0, 100, 10_000] {
            let e = write_file(&mut Full { room }, &MAGIC, |out| encode(&body, out)).unwrap_err();
            assert_eq!(
                e.kind(),
                std::io::ErrorKind::StorageFull,
                "room {room}: {e}"
            );
        }
        let e = encode(&body, &mut Full { room: 10 }).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::StorageFull, "{e}");
        assert!(
            write_file(&mut Full { room: 1 << 30 }, &MAGIC, |out| encode(
                &body, out
            ))
            .is_ok()
        );
    }

    #[test]
    fn a_checkpoint_round_trips_and_resumes_after_reading() {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("scene.xml");
        std::fs::write(&scene, scene_xml(GLOSSY)).unwrap();
        let loaded = crate::load_scene_with(&scene, &[]).unwrap();
        let settings = SolveSettings::default();
        let limited = SolveSettings {
            time_limit: 1e-9,
            ..settings
        };
        let cut = solve(&loaded.scene, &limited, &Silent).unwrap();
        assert!(cut.checkpoint.is_some());
        let (path, _) = written(dir.path(), &cut, None);
        let read = read_solution(&path).unwrap().solution;
        assert_eq!(read.checkpoint, cut.checkpoint);
        let from = read.unfinished().unwrap();
        let resumed = wavrad_core::solve::resume(&loaded.scene, &settings, from, None, &Silent);
        let whole = solve(&loaded.scene, &settings, &Silent).unwrap();
        assert_eq!(resumed.unwrap().radiance, whole.radiance);
    }

    #[test]
    fn damaged_files_are_refused_with_their_problem() {
        let dir = tempfile::tempdir().unwrap();
        let (solution, _) = solved(dir.path(), GLOSSY);
        let (_, bytes) = written(dir.path(), &solution, None);
        let dir = dir.path();

        let problem = problem_of(dir, b"<scene version=\"3.0.0\"/>");
        assert!(
            matches!(problem, SolutionProblem::NotASolution),
            "{problem}"
        );
        assert!(matches!(
            problem_of(dir, b""),
            SolutionProblem::NotASolution
        ));

        for cut in [4, HEADER_LEN - 1, HEADER_LEN, bytes.len() - 1] {
            let problem = problem_of(dir, &bytes[..cut]);
            let SolutionProblem::Truncated { found, .. } = problem else {
                panic!("cut at {cut}: {problem}");
            };
            assert_eq!(found, cut as u64);
            assert!(problem.to_string().contains("truncated"));
        }
        let longer = [&bytes[..], b"\0"].concat();
        let problem = problem_of(dir, &longer);
        assert!(
            matches!(problem, SolutionProblem::TrailingBytes(1)),
            "{problem}"
        );

        for at in [HEADER_LEN, bytes.len() / 2, bytes.len() - 1] {
            let mut flipped = bytes.clone();
            flipped[at] ^= 0x10;
            let problem = problem_of(dir, &flipped);
            assert!(
                matches!(problem, SolutionProblem::Checksum { .. }),
                "flipped at {at}: {problem}"
            );
            assert!(problem.to_string().contains("damaged"));
        }

        let mut newer = bytes.clone();
        newer[8..12].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
        let problem = problem_of(dir, &newer);
        let SolutionProblem::Version { found, written_by } = &problem else {
            panic!("{problem}");
        };
        assert_eq!(
            (*found, written_by.as_str()),
            (FORMAT_VERSION + 1, env!("CARGO_PKG_VERSION"))
        );
        let message = problem.to_string();
        assert!(
            message.contains(&format!("format version {}", FORMAT_VERSION + 1)),
            "{message}"
        );
    }

    #[test]
    fn a_body_that_decompresses_too_far_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        // A well-formed header and checksum over a tiny body that expands
        // 50 000 times: zeros, as a crafted file could hold.
        let crafted = solution_file_bytes(&vec![0u8; 50 << 20]).unwrap();
        let body = (crafted.len() - HEADER_LEN) as u64;
        assert!(body * MAX_EXPANSION + (1 << 20) < 50 << 20);
        let problem = problem_of(dir.path(), &crafted);
        assert!(
            matches!(&problem, SolutionProblem::Undecodable(m) if m.contains("decompresses to more than")),
            "{problem}"
        );
    }

    #[test]
    fn a_changed_scene_is_refused_and_a_missing_one_warned_of() {
        let dir = tempfile::tempdir().unwrap();
        let (solution, source) = solved(dir.path(), "");
        let (path, _) = written(dir.path(), &solution, Some(&source));
        let scene = &source.scene;
        let unchanged = scene_xml("");
        let changed = |xml: String| {
            std::fs::write(scene, xml).unwrap();
            match read_solution(&path) {
                Err(Error::Solution {
                    problem:
                        SolutionProblem::SceneChanged {
                            scene: named,
                            difference,
                        },
                    ..
                }) => {
                    assert_eq!(&named, scene);
                    difference
                }
                Err(e) => panic!("another error: {e}"),
                Ok(_) => panic!("a changed scene was read"),
            }
        };
        // An edit that loads to the same scene is no change.
        std::fs::write(scene, format!("<!-- edited -->\n{unchanged}")).unwrap();
        assert!(read_solution(&path).unwrap().warnings.is_empty());
        let floor = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.3"/></bsdf>"#;
        assert!(changed(scene_xml(floor)).contains("surface 1 (\"floor\")"));
        assert!(
            changed(unchanged.replace("</film>", "<rfilter type=\"box\"/></film>"))
                .contains("film")
        );
        assert!(changed(unchanged.replace(
            "<shape type=\"rectangle\" id=\"light\">",
            "<shape type=\"bogus\">"
        ))
        .contains("an error"));
        // The -D value is the one solved with, whatever the file's default.
        std::fs::write(scene, unchanged.replace("value=\"1\"", "value=\"3\"")).unwrap();
        assert!(read_solution(&path).is_ok());

        std::fs::remove_file(scene).unwrap();
        let read = read_solution(&path).unwrap();
        assert_eq!(read.warnings.len(), 1);
        assert!(
            read.warnings[0].contains("not there"),
            "{}",
            read.warnings[0]
        );
        assert_eq!(read.solution.radiance, solution.radiance);
    }

    /// The problem reading `solution` from a file whose body `edit`
    /// changed, behind a header and checksum that match it.
    fn problem_after(dir: &Path, solution: &Solution, edit: impl FnOnce(&mut Body)) -> String {
        let mut body = Body::of(solution, None);
        edit(&mut body);
        let bytes = solution_file_bytes(&postcard::to_allocvec(&body).unwrap()).unwrap();
        let problem = problem_of(dir, &bytes);
        assert!(
            matches!(problem, SolutionProblem::Inconsistent { .. }),
            "{problem}"
        );
        problem.to_string()
    }

    #[test]
    fn a_body_with_a_matching_checksum_is_checked_index_by_index() {
        use wavrad_core::solve::gather::{Shares, Source};
        let dir = tempfile::tempdir().unwrap();
        let (solution, _) = solved(dir.path(), GLOSSY);
        let dir = dir.path();
        let (s, _) = (solution.interactions.incoming.iter().enumerate())
            .find(|(_, t)| !t.is_empty())
            .expect("a surface that gathers");
        type Edit = Box<dyn FnOnce(&mut Body)>;
        let element = |surface, node, towards| Source::Element {
            surface,
            node,
            shares: Shares::NONE,
            towards,
        };
        let cases: [(&str, Edit); 18] = [
            (
                // Found by fuzzing: the render allocated rays⁴ samples.
                "the settings: quadrature orders 2 and 1073741824",
                Box::new(|b| b.settings.quadrature.rays = 1 << 30),
            ),
            (
                // Found by fuzzing: the camera rays' origins were not finite.
                "the sensor: to_world",
                Box::new(|b| {
                    let camera = b.scene.to_mut().camera.as_mut().unwrap();
                    camera.world_from_camera.w_axis.x = f64::NAN;
                }),
            ),
            (
                "the scene: a sampler of 4294967295 samples per pixel",
                Box::new(|b| b.scene.to_mut().hints.samples_per_pixel = Some(u32::MAX)),
            ),
            (
                // Found by fuzzing: the renderer drew emitters by it.
                "surface 0: its emission Rgb([5.0, -100.0, 0.0])",
                Box::new(|b| b.scene.to_mut().surfaces[0].emission = Rgb([5.0, -100.0, 0.0])),
            ),
            (
                "surface 1: its element tree: node 0's children start at node 4000",
                Box::new(|b| b.trees.to_mut()[1].nodes[0].first_child = Some(4000)),
            ),
            (
                "is not child 2 of node 0",
                Box::new(|b| {
                    let tree = &mut b.trees.to_mut()[0];
                    tree.nodes[0].first_child.get_or_insert(1);
                    tree.nodes[3].id.path = 7;
                }),
            ),
            (
                "node 9999 out of range",
                Box::new(move |b| {
                    b.interactions.to_mut().incoming[s][0].source = element(0, 9999, 0..0)
                }),
            ),
            (
                "source surface 77 out of range",
                Box::new(move |b| {
                    b.interactions.to_mut().incoming[s][0].source = element(77, 0, 0..0)
                }),
            ),
            (
                "source bin 200 out of range",
                Box::new(move |b| {
                    let interactions = b.interactions.to_mut();
                    let at = interactions.bins.len() as u32;
                    interactions.bins.push((200, 1.0));
                    interactions.incoming[s][0].source = element(0, 0, at..at + 1)
                }),
            ),
            (
                "the lights' bins: surface 0's bin 130 of",
                Box::new(|b| {
                    let bins = &mut b.interactions.to_mut().light_bins;
                    bins.resize(b.scene.surfaces.len(), Vec::new());
                    bins[0].push((130, Rgb::splat(1.0)));
                }),
            ),
            (
                "the lights' light per surface: item 0's node 5000",
                Box::new(|b| {
                    let lights = &mut b.interactions.to_mut().lights;
                    lights.resize(b.scene.surfaces.len(), Vec::new());
                    lights[0].push((5000, Rgb::splat(1.0)));
                }),
            ),
            (
                "the lights' light per directional structure: item 0's node 0",
                Box::new(|b| {
                    let interactions = b.interactions.to_mut();
                    let structures = interactions.directional.len();
                    let pairs = &mut interactions.light_pairs;
                    pairs.resize(structures, Vec::new());
                    pairs[0].push((0, Rgb::splat(f64::INFINITY)));
                }),
            ),
            (
                "the lights' bins: 1 lists for",
                Box::new(|b| b.interactions.to_mut().light_bins = vec![Vec::new(); 1]),
            ),
            (
                &format!("surface {s}'s incoming transfer 0: node 70000 out of range"),
                Box::new(move |b| b.interactions.to_mut().incoming[s][0].receiver = 70000),
            ),
            (
                "surface 0: its radiance: Rgb([NaN",
                Box::new(|b| b.radiance.to_mut()[0][0] = Rgb::splat(f64::NAN)),
            ),
            (
                "not indexed by their surface pairs",
                Box::new(|b| {
                    let map = &mut b.interactions.to_mut().structure_of;
                    let first = *map.keys().next().unwrap();
                    map.insert(first, 5);
                }),
            ),
            (
                "covers 0..100000 out of range",
                Box::new(|b| {
                    let t = &mut b.interactions.to_mut().incoming_three_point[0][0];
                    t.receivers = 0..100_000;
                }),
            ),
            (
                "the cluster links: the cluster tree is not the scene's",
                Box::new(|b| {
                    let clusters = &mut b.interactions.to_mut().clusters.clusters;
                    clusters.nodes.push(clusters.nodes[0].clone());
                }),
            ),
        ];
        for (needle, edit) in cases {
            let message = problem_after(dir, &solution, edit);
            assert!(message.starts_with("damaged: "), "{message}");
            assert!(
                message.contains(needle),
                "expected {needle:?} in: {message}"
            );
        }
    }

    #[test]
    fn solutions_of_the_shooting_solver_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let scene = wavrad_core::testing::light_over_a_corner(0.3);
        let settings = SolveSettings::default();
        let solution =
            wavrad_core::solve::shoot::solve_shooting(&scene, &settings, &Silent, None).unwrap();
        let (path, _) = written(dir.path(), &solution, None);
        let read = read_solution(&path).unwrap();
        assert_eq!(read.solution.trees, solution.trees);
        assert_eq!(read.solution.interactions, solution.interactions);
    }
}
