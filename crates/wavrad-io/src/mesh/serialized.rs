//! Mitsuba's `serialized` meshes: file format `0x041C`, versions 3 and 4
//! (Mitsuba 0.4 to 3), as Mitsuba 3's `src/shapes/serialized.cpp` reads them.
//!
//! All numbers are little-endian. A file is one or more shapes, each a
//! 4-byte uncompressed header (`u16` format id `0x041C`, `u16` version)
//! followed by a zlib stream holding:
//!
//! | field     | type                                               |
//! |-----------|----------------------------------------------------|
//! | flags     | `u32`, the bits below                              |
//! | name      | null-terminated UTF-8 (version 4 only)             |
//! | V, F      | `u64` vertex and triangle counts                   |
//! | positions | 3V floats (`f64` with flag `0x2000`, else `f32`)   |
//! | normals   | 3V floats, with flag `0x0001`                      |
//! | texcoords | 2V floats, with flag `0x0002`                      |
//! | colors    | 3V floats, with flag `0x0008`                      |
//! | triangles | 3F `u32` vertex indices, counter-clockwise         |
//!
//! Flags: `0x0001` vertex normals, `0x0002` texture coordinates, `0x0008`
//! vertex colors, `0x0010` face normals, `0x1000` single precision,
//! `0x2000` double precision.
//!
//! A file of several shapes ends with a dictionary: each shape's byte
//! offset (`u64` in version 4, `u32` in version 3), then the shape count as
//! a `u32`. Shape 0 starts at offset 0 and is read without the dictionary,
//! as Mitsuba does, so single-shape files need none.
//!
//! Positions, normals, texture coordinates and triangles are kept; colors
//! are skipped, and so is the face-normals flag (as Mitsuba 3 does
//! for these versions: only the scene's `face_normals` counts). Counts are never trusted for allocation: the
//! stream is decompressed first, up to the size the counts imply, and a
//! shape whose data ends early is an error.

use std::io::Read;
use std::path::Path;

use flate2::read::ZlibDecoder;
use glam::{DVec2, DVec3};

use super::Mesh;
use crate::error::{Error, Result};

/// The file format identifier every shape header starts with.
const FORMAT_ID: u16 = 0x041C;

/// Bits of a shape's flag word (`TriMeshFlags` in Mitsuba) that change the
/// layout; `0x0010` (face normals) and `0x1000` (single precision, the
/// default) do not.
mod flags {
    /// Per-vertex normals follow the positions.
    pub const NORMALS: u32 = 0x0001;
    /// Per-vertex texture coordinates follow.
    pub const TEXCOORDS: u32 = 0x0002;
    /// Per-vertex colors follow.
    pub const COLORS: u32 = 0x0008;
    /// Floats are `f64` rather than `f32`.
    pub const DOUBLE: u32 = 0x2000;
}

/// Read shape `shape_index` of a serialized file: its triangles in file
/// order, wound as stored, with their corners' normals when it has them.
pub fn read_serialized(path: &Path, shape_index: u32) -> Result<Mesh> {
    super::check_mesh_file(path)?;
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_serialized(&bytes, shape_index).map_err(|message| Error::mesh(path, None, message))
}

/// A problem with the file, for [`Error::Mesh`].
type SerializedResult<T> = std::result::Result<T, String>;

fn parse_serialized(bytes: &[u8], shape_index: u32) -> SerializedResult<Mesh> {
    let version = read_header(bytes, 0)?;
    let offset = if shape_index == 0 {
        0
    } else {
        shape_offset(bytes, version, shape_index)?
    };
    let shape = |message: String| format!("shape {shape_index}: {message}");
    if read_header(bytes, offset).map_err(shape)? != version {
        return Err(shape(format!(
            "its header at byte {offset} has another version than the file's ({version})"
        )));
    }
    read_shape(&bytes[offset + 4..], version).map_err(shape)
}

/// Check the header at `offset` and return its version.
fn read_header(bytes: &[u8], offset: usize) -> SerializedResult<u16> {
    let header = bytes
        .get(offset..offset.saturating_add(4))
        .ok_or_else(|| format!("file ends at byte {} inside a shape header", bytes.len()))?;
    let format = u16::from_le_bytes([header[0], header[1]]);
    if format != FORMAT_ID {
        return Err(format!(
            "not a Mitsuba serialized mesh (format id 0x{format:04X} at byte {offset}, expected 0x{FORMAT_ID:04X})"
        ));
    }
    match u16::from_le_bytes([header[2], header[3]]) {
        version @ (3 | 4) => Ok(version),
        other => Err(format!(
            "unsupported serialized version {other} (supported: 3 and 4)"
        )),
    }
}

/// The byte offset of shape `index` from the end-of-file dictionary.
fn shape_offset(bytes: &[u8], version: u16, index: u32) -> SerializedResult<usize> {
    let len = bytes.len();
    let tail = |at: usize, n: usize| {
        bytes
            .get(at..at + n)
            .ok_or_else(|| "file too short for its end-of-file dictionary".to_string())
    };
    let count = u32::from_le_bytes(tail(len.saturating_sub(4), 4)?.try_into().unwrap());
    if index >= count {
        return Err(format!(
            "shape_index {index} is out of range: the file holds {count} shape{}",
            if count == 1 { "" } else { "s" }
        ));
    }
    let entry_size = if version == 4 { 8 } else { 4 };
    let from_end = (count - index) as usize * entry_size + 4;
    let at = len
        .checked_sub(from_end)
        .ok_or_else(|| format!("file too short for a dictionary of {count} shapes"))?;
    let entry = tail(at, entry_size)?;
    let offset = if version == 4 {
        u64::from_le_bytes(entry.try_into().unwrap())
    } else {
        u64::from(u32::from_le_bytes(entry.try_into().unwrap()))
    };
    usize::try_from(offset)
        .ok()
        .filter(|&o| o < at)
        .ok_or_else(|| {
            format!("the dictionary puts shape {index} at byte {offset}, past the shapes' data")
        })
}

/// Decode one shape's zlib stream.
fn read_shape(compressed: &[u8], version: u16) -> SerializedResult<Mesh> {
    let mut stream = ZlibDecoder::new(compressed);
    let corrupt = |e: std::io::Error| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => "data ends inside the shape's header".to_string(),
        _ => format!("corrupt compressed data ({e})"),
    };

    // Header: flags, name (version 4), counts.
    let mut word = [0u8; 4];
    stream.read_exact(&mut word).map_err(corrupt)?;
    let flags = u32::from_le_bytes(word);
    if version == 4 {
        skip_name(&mut stream).map_err(corrupt)?;
    }
    let mut counts = [0u8; 16];
    stream.read_exact(&mut counts).map_err(corrupt)?;
    let vertices = u64::from_le_bytes(counts[..8].try_into().unwrap());
    let triangles = u64::from_le_bytes(counts[8..].try_into().unwrap());
    if vertices > u64::from(u32::MAX) {
        return Err(format!(
            "{vertices} vertices is more than 32-bit triangle indices can address"
        ));
    }

    // Payload size the counts imply; the data must then be there before
    // anything is allocated from the counts.
    let float_size: u64 = if flags & flags::DOUBLE != 0 { 8 } else { 4 };
    let attribute = |flag: u32, lanes: u64| if flags & flag != 0 { lanes } else { 0 };
    let floats_per_vertex = 3
        + attribute(flags::NORMALS, 3)
        + attribute(flags::TEXCOORDS, 2)
        + attribute(flags::COLORS, 3);
    let vertex_bytes = vertices * floats_per_vertex * float_size;
    let size = triangles
        .checked_mul(12)
        .and_then(|t| t.checked_add(vertex_bytes))
        .ok_or_else(|| format!("{triangles} triangles is more than any file holds"))?;
    let mut data = Vec::new();
    stream
        .take(size)
        .read_to_end(&mut data)
        .map_err(|e| format!("corrupt compressed data ({e})"))?;
    if (data.len() as u64) < size {
        return Err(format!(
            "truncated: {vertices} vertices and {triangles} triangles need {size} bytes, the data ends after {}",
            data.len()
        ));
    }

    // Positions and normals, then the triangles after the other attributes.
    let vectors_size = (vertices * 3 * float_size) as usize;
    let positions = vectors(&data[..vectors_size], float_size);
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(format!("vertex {i} is not finite ({})", positions[i]));
    }
    let vertex_normals = (flags & flags::NORMALS != 0)
        .then(|| vectors(&data[vectors_size..2 * vectors_size], float_size));
    let texcoords_start = vectors_size * (1 + usize::from(vertex_normals.is_some()));
    let vertex_texcoords = (flags & flags::TEXCOORDS != 0).then(|| {
        let end = texcoords_start + (vertices * 2 * float_size) as usize;
        pairs(&data[texcoords_start..end], float_size)
    });
    if let Some(i) = (vertex_texcoords.iter().flatten()).position(|uv| !uv.is_finite()) {
        return Err(format!("texture coordinates of vertex {i} are not finite"));
    }
    let mut texcoords = vertex_texcoords
        .as_ref()
        .map(|_| Vec::with_capacity(triangles as usize));
    let mut triangles = Vec::with_capacity(triangles as usize);
    let mut corners = Vec::with_capacity(triangles.capacity());
    let mut normals = vertex_normals
        .as_ref()
        .map(|_| Vec::with_capacity(triangles.capacity()));
    for (t, ijk) in data[vertex_bytes as usize..].chunks_exact(12).enumerate() {
        let ijk: [usize; 3] = std::array::from_fn(|k| {
            u32::from_le_bytes(ijk[4 * k..4 * k + 4].try_into().unwrap()) as usize
        });
        if let Some(&i) = ijk.iter().find(|&&i| i >= positions.len()) {
            return Err(format!(
                "triangle {t} refers to vertex {i}, but there are only {vertices} vertices"
            ));
        }
        triangles.push(ijk.map(|i| positions[i]));
        // Indices below the vertex count (a u32 count, checked above).
        corners.push(ijk.map(|i| i as u32));
        if let (Some(normals), Some(vertex_normals)) = (&mut normals, &vertex_normals) {
            normals.push(ijk.map(|i| vertex_normals[i]));
        }
        if let (Some(texcoords), Some(vertex_texcoords)) = (&mut texcoords, &vertex_texcoords) {
            texcoords.push(ijk.map(|i| vertex_texcoords[i]));
        }
    }
    Ok(Mesh {
        triangles,
        normals,
        texcoords,
        corners,
    })
}

/// Little-endian `f32` or `f64` pairs (`float_size` 4 or 8) as 2D vectors.
fn pairs(bytes: &[u8], float_size: u64) -> Vec<DVec2> {
    vectors_of(bytes, float_size, 2)
        .map(|c| DVec2::new(c[0], c[1]))
        .collect()
}

/// Little-endian `f32` or `f64` triples (`float_size` 4 or 8) as vectors.
fn vectors(bytes: &[u8], float_size: u64) -> Vec<DVec3> {
    vectors_of(bytes, float_size, 3)
        .map(|c| DVec3::new(c[0], c[1], c[2]))
        .collect()
}

/// Little-endian `f32` or `f64` values (`float_size` 4 or 8), `lanes` at a
/// time.
fn vectors_of(bytes: &[u8], float_size: u64, lanes: usize) -> impl Iterator<Item = Vec<f64>> + '_ {
    let float = |b: &[u8]| match b.len() {
        8 => f64::from_le_bytes(b.try_into().unwrap()),
        _ => f64::from(f32::from_le_bytes(b.try_into().unwrap())),
    };
    bytes
        .chunks_exact(lanes * float_size as usize)
        .map(move |v| v.chunks_exact(float_size as usize).map(float).collect())
}

/// Skip the null-terminated shape name of a version 4 shape.
fn skip_name(stream: &mut impl Read) -> std::io::Result<()> {
    let mut byte = [0u8; 1];
    loop {
        stream.read_exact(&mut byte)?;
        if byte[0] == 0 {
            return Ok(());
        }
    }
}
