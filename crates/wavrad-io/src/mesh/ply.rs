//! Stanford PLY (ascii, binary_little_endian, binary_big_endian): the
//! `vertex` element's `x y z` (and `nx ny nz` normals when it has all
//! three, texture coordinates `u v`, `s t`, `texture_u texture_v` or
//! `texture_s texture_t` when it has both) and the `face` element's `vertex_indices` (or `vertex_index`)
//! list; every other element and property is skipped.
//!
//! Written by hand rather than with `ply-rs-bw`: we need only positions,
//! normals and faces, want errors with the header/ascii line, must never panic or
//! pre-allocate from an untrusted element count, and that crate requires a
//! newer Rust (1.87) than the workspace's `rust-version`.

use std::path::Path;

use glam::{DVec2, DVec3};

use super::{fan, push_fan, Mesh};
use crate::error::{Error, Result};

/// Read every face of a PLY file as triangles (polygons fan-triangulated),
/// with their corners' normals.
pub fn read_ply(path: &Path) -> Result<Mesh> {
    super::check_mesh_file(path)?;
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_ply(&bytes).map_err(|(line, message)| Error::mesh(path, line, message))
}

/// Problem with its line (header and ascii body) when known.
type PlyResult<T> = std::result::Result<T, (Option<u32>, String)>;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

#[derive(Debug, Clone)]
enum Property {
    Scalar {
        name: String,
        ty: Scalar,
    },
    List {
        name: String,
        count: Scalar,
        item: Scalar,
    },
}

#[derive(Debug, Clone)]
struct ElementDef {
    name: String,
    count: u64,
    properties: Vec<Property>,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

/// What we keep of the file: positions, normals, texture coordinates and
/// polygons.
#[derive(Default)]
struct Elements {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    texcoords: Vec<DVec2>,
    polygons: Vec<Vec<usize>>,
}

fn parse_ply(bytes: &[u8]) -> PlyResult<Mesh> {
    let (format, elements, body_start, header_lines) = parse_header(bytes)?;
    let body = &bytes[body_start..];
    let mut mesh = Elements::default();
    match format {
        Format::Ascii => read_ascii(body, header_lines, &elements, &mut mesh)?,
        Format::BinaryLittleEndian | Format::BinaryBigEndian => {
            read_binary(body, format, &elements, &mut mesh)?
        }
    }
    let mut triangles = Vec::new();
    // A vertex element with nx, ny, nz gave every vertex a normal.
    let with_normals = mesh.normals.len() == mesh.positions.len();
    let mut normals = with_normals.then(Vec::new);
    let with_texcoords = mesh.texcoords.len() == mesh.positions.len();
    let mut texcoords = with_texcoords.then(Vec::new);
    let mut corners = Vec::new();
    for polygon in &mesh.polygons {
        push_fan(&mesh.positions, polygon, &mut triangles).map_err(|i| {
            (
                None,
                format!(
                    "face refers to vertex {i}, but there are only {} vertices",
                    mesh.positions.len()
                ),
            )
        })?;
        // Indices below the vertex count (checked with the positions), which
        // a file of at most MAX_MESH_FILE_BYTES keeps below 2^32.
        corners.extend(fan(polygon).map(|c| c.map(|i| i as u32)));
        if let Some(normals) = &mut normals {
            push_fan(&mesh.normals, polygon, normals).expect("indices checked with positions");
        }
        if let Some(texcoords) = &mut texcoords {
            push_fan(&mesh.texcoords, polygon, texcoords).expect("indices checked with positions");
        }
    }
    Ok(Mesh {
        triangles,
        normals,
        texcoords,
        corners,
    })
}

/// Parse the header; returns the format, the elements, the byte offset of
/// the body and the number of header lines.
fn parse_header(bytes: &[u8]) -> PlyResult<(Format, Vec<ElementDef>, usize, u32)> {
    let mut offset = 0usize;
    let mut line_no = 0u32;
    let mut format = None;
    let mut elements: Vec<ElementDef> = Vec::new();
    loop {
        let rest = &bytes[offset..];
        let Some(len) = rest.iter().position(|&b| b == b'\n') else {
            return Err((
                Some(line_no + 1),
                "header ends before \"end_header\"".into(),
            ));
        };
        line_no += 1;
        offset += len + 1;
        let line = std::str::from_utf8(&rest[..len])
            .map_err(|_| (Some(line_no), "header is not text".to_string()))?
            .trim();
        let err = |msg: String| (Some(line_no), msg);
        let words: Vec<&str> = line.split_whitespace().collect();
        if line_no == 1 {
            if line != "ply" {
                return Err(err("not a PLY file (first line must be \"ply\")".into()));
            }
            continue;
        }
        match words.as_slice() {
            [] => {}
            ["comment", ..] | ["obj_info", ..] => {}
            ["format", kind, _version] => {
                format = Some(match *kind {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLittleEndian,
                    "binary_big_endian" => Format::BinaryBigEndian,
                    other => return Err(err(format!("unknown PLY format \"{other}\""))),
                });
            }
            ["element", name, count] => {
                let count = count
                    .parse::<u64>()
                    .map_err(|_| err(format!("bad element count \"{count}\"")))?;
                elements.push(ElementDef {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            ["property", "list", count, item, name] => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| err("property before any element".into()))?;
                let ty = |t: &str| {
                    Scalar::parse(t).ok_or_else(|| err(format!("unknown property type \"{t}\"")))
                };
                let (count, item) = (ty(count)?, ty(item)?);
                if !count.is_integer() {
                    return Err(err(format!(
                        "list count of \"{name}\" must be an integer type"
                    )));
                }
                element.properties.push(Property::List {
                    name: name.to_string(),
                    count,
                    item,
                });
            }
            ["property", ty, name] => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| err("property before any element".into()))?;
                let ty = Scalar::parse(ty)
                    .ok_or_else(|| err(format!("unknown property type \"{ty}\"")))?;
                element.properties.push(Property::Scalar {
                    name: name.to_string(),
                    ty,
                });
            }
            ["end_header"] => break,
            _ => return Err(err(format!("unexpected header line \"{line}\""))),
        }
    }
    let format = format.ok_or((None, "header has no \"format\" line".to_string()))?;
    Ok((format, elements, offset, line_no))
}

/// Where `x`, `y`, `z`, `nx`, `ny`, `nz`, the texture coordinates and the
/// index list sit in an element's properties.
#[derive(Default)]
struct Layout {
    xyz: [Option<usize>; 3],
    normal: [Option<usize>; 3],
    texcoord: [Option<usize>; 2],
    indices: Option<usize>,
}

fn layout(element: &ElementDef) -> PlyResult<Layout> {
    let mut layout = Layout::default();
    for (i, p) in element.properties.iter().enumerate() {
        match (element.name.as_str(), p) {
            ("vertex", Property::Scalar { name, .. }) => match name.as_str() {
                "x" => layout.xyz[0] = Some(i),
                "y" => layout.xyz[1] = Some(i),
                "z" => layout.xyz[2] = Some(i),
                "nx" => layout.normal[0] = Some(i),
                "ny" => layout.normal[1] = Some(i),
                "nz" => layout.normal[2] = Some(i),
                // The names Mitsuba 3's PLY reader takes for them.
                "u" | "s" | "texture_u" | "texture_s" => layout.texcoord[0] = Some(i),
                "v" | "t" | "texture_v" | "texture_t" => layout.texcoord[1] = Some(i),
                _ => {}
            },
            ("face", Property::List { name, item, .. })
                if name == "vertex_indices" || name == "vertex_index" =>
            {
                if !item.is_integer() {
                    return Err((None, format!("face list \"{name}\" must hold integers")));
                }
                layout.indices = Some(i);
            }
            _ => {}
        }
    }
    if element.name == "vertex" && layout.xyz.iter().any(Option::is_none) {
        return Err((None, "element \"vertex\" lacks x, y or z".into()));
    }
    if element.name == "face" && layout.indices.is_none() {
        return Err((
            None,
            "element \"face\" has no \"vertex_indices\" list".into(),
        ));
    }
    Ok(layout)
}

/// Store one element instance: `scalars[i]` is property i's value (NaN for
/// lists), `list` the index list when the element has one.
fn store(
    element: &ElementDef,
    layout: &Layout,
    scalars: &[f64],
    list: Vec<usize>,
    mesh: &mut Elements,
) -> std::result::Result<(), String> {
    let vector = |at: [Option<usize>; 3]| at.map(|k| k.map(|i| scalars[i]));
    match element.name.as_str() {
        "vertex" => {
            let [Some(x), Some(y), Some(z)] = vector(layout.xyz) else {
                unreachable!("layout() requires x, y and z")
            };
            let p = DVec3::new(x, y, z);
            if !p.is_finite() {
                return Err(format!("vertex {} is not finite", mesh.positions.len()));
            }
            mesh.positions.push(p);
            if let [Some(x), Some(y), Some(z)] = vector(layout.normal) {
                let n = DVec3::new(x, y, z);
                if !n.is_finite() {
                    return Err(format!(
                        "normal of vertex {} is not finite",
                        mesh.positions.len() - 1
                    ));
                }
                mesh.normals.push(n);
            }
            if let [Some(u), Some(v)] = layout.texcoord.map(|k| k.map(|i| scalars[i])) {
                let uv = DVec2::new(u, v);
                if !uv.is_finite() {
                    return Err(format!(
                        "texture coordinates of vertex {} are not finite",
                        mesh.positions.len() - 1
                    ));
                }
                mesh.texcoords.push(uv);
            }
        }
        "face" => mesh.polygons.push(list),
        _ => {}
    }
    Ok(())
}

fn to_index(v: f64) -> std::result::Result<usize, String> {
    if v >= 0.0 && v.fract() == 0.0 && v <= u32::MAX as f64 {
        Ok(v as usize)
    } else {
        Err(format!("bad vertex index {v}"))
    }
}

fn read_ascii(
    body: &[u8],
    header_lines: u32,
    elements: &[ElementDef],
    mesh: &mut Elements,
) -> PlyResult<()> {
    let text = std::str::from_utf8(body).map_err(|_| (None, "ascii body is not text".into()))?;
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (header_lines + 1 + i as u32, l))
        .filter(|(_, l)| !l.trim().is_empty());
    for element in elements {
        let layout = layout(element)?;
        if element.properties.is_empty() {
            continue;
        }
        for _ in 0..element.count {
            let Some((line_no, line)) = lines.next() else {
                return Err((
                    None,
                    format!("file ends inside element \"{}\"", element.name),
                ));
            };
            let err = |msg: String| (Some(line_no), msg);
            let mut tokens = line.split_whitespace();
            let mut next = |what: &str| -> PlyResult<f64> {
                let t = tokens
                    .next()
                    .ok_or_else(|| err(format!("missing value for \"{what}\"")))?;
                t.parse::<f64>()
                    .map_err(|_| err(format!("malformed number \"{t}\" for \"{what}\"")))
            };
            let mut scalars = vec![f64::NAN; element.properties.len()];
            let mut list = Vec::new();
            for (i, p) in element.properties.iter().enumerate() {
                match p {
                    Property::Scalar { name, .. } => scalars[i] = next(name)?,
                    Property::List { name, .. } => {
                        let n = next(name)?;
                        let n = to_index(n).map_err(|_| err(format!("bad list length {n}")))?;
                        let keep = layout.indices == Some(i);
                        for _ in 0..n {
                            let v = next(name)?;
                            if keep {
                                list.push(to_index(v).map_err(err)?);
                            }
                        }
                    }
                }
            }
            if tokens.next().is_some() {
                return Err(err(format!(
                    "more values than properties in element \"{}\"",
                    element.name
                )));
            }
            store(element, &layout, &scalars, list, mesh).map_err(err)?;
        }
    }
    Ok(())
}

/// A bounds-checked reader over the binary body.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
    big_endian: bool,
}

impl Cursor<'_> {
    fn read(&mut self, ty: Scalar) -> PlyResult<f64> {
        let n = ty.size();
        let chunk = self
            .bytes
            .get(self.at..self.at + n)
            .ok_or((None, "unexpected end of file in binary body".to_string()))?;
        self.at += n;
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(chunk);
        if self.big_endian {
            b[..n].reverse();
        }
        Ok(match ty {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            Scalar::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
            Scalar::I32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::F64 => f64::from_le_bytes(b),
        })
    }
}

fn read_binary(
    body: &[u8],
    format: Format,
    elements: &[ElementDef],
    mesh: &mut Elements,
) -> PlyResult<()> {
    let mut cursor = Cursor {
        bytes: body,
        at: 0,
        big_endian: format == Format::BinaryBigEndian,
    };
    let err =
        |element: &ElementDef, msg: String| (None, format!("element \"{}\": {msg}", element.name));
    for element in elements {
        let layout = layout(element)?;
        if element.properties.is_empty() {
            continue; // occupies no bytes, however large its count
        }
        for _ in 0..element.count {
            let mut scalars = vec![f64::NAN; element.properties.len()];
            let mut list = Vec::new();
            for (i, p) in element.properties.iter().enumerate() {
                match p {
                    Property::Scalar { ty, .. } => scalars[i] = cursor.read(*ty)?,
                    Property::List { count, item, .. } => {
                        let n = cursor.read(*count)?;
                        let n = to_index(n)
                            .map_err(|_| err(element, format!("bad list length {n}")))?;
                        let keep = layout.indices == Some(i);
                        for _ in 0..n {
                            let v = cursor.read(*item)?;
                            if keep {
                                list.push(to_index(v).map_err(|m| err(element, m))?);
                            }
                        }
                    }
                }
            }
            store(element, &layout, &scalars, list, mesh).map_err(|m| err(element, m))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASCII_QUAD: &str = "ply\nformat ascii 1.0\ncomment a unit quad\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n4 0 1 2 3\n";

    #[test]
    fn ascii_quad_is_two_ccw_triangles() {
        let mesh = parse_ply(ASCII_QUAD.as_bytes()).unwrap();
        assert_eq!(mesh.triangles.len(), 2);
        for t in &mesh.triangles {
            assert!((t[1] - t[0]).cross(t[2] - t[0]).z > 0.0);
        }
        assert_eq!(mesh.normals, None, "nx alone is no normal");
        assert_eq!(mesh.corners, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn normals_are_kept_per_corner() {
        let with_normals = ASCII_QUAD
            .replace(
                "property float nx\n",
                "property float nx\nproperty float ny\nproperty float nz\n",
            )
            .replace(" 9\n", " 0 0 -1\n");
        let mesh = parse_ply(with_normals.as_bytes()).unwrap();
        assert_eq!(mesh.normals, Some(vec![[-DVec3::Z; 3]; 2]));
        let bad = with_normals.replace("1 0 0 0 0 -1\n", "1 0 0 0 0 nan\n");
        let (_, msg) = parse_ply(bad.as_bytes()).unwrap_err();
        assert!(msg.contains("normal of vertex 1 is not finite"), "{msg}");
    }

    fn binary(big_endian: bool) -> Vec<u8> {
        let fmt = if big_endian {
            "binary_big_endian"
        } else {
            "binary_little_endian"
        };
        let mut b = format!(
            "ply\r\nformat {fmt} 1.0\r\nelement vertex 3\r\nproperty double x\r\nproperty double y\r\nproperty double z\r\nelement edge 1\r\nproperty list uchar int vertex1\r\nelement face 1\r\nproperty list uchar uint vertex_index\r\nend_header\r\n"
        )
        .into_bytes();
        let f64b = |v: f64| {
            if big_endian {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        let u32b = |v: u32| {
            if big_endian {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        for p in [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 3.0, 0.0]] {
            for c in p {
                b.extend_from_slice(&f64b(c));
            }
        }
        b.push(2);
        b.extend_from_slice(&u32b(0));
        b.extend_from_slice(&u32b(1));
        b.push(3);
        for i in [0, 1, 2] {
            b.extend_from_slice(&u32b(i));
        }
        b
    }

    #[test]
    fn binary_both_endiannesses_and_skipped_elements() {
        for be in [false, true] {
            let mesh = parse_ply(&binary(be)).unwrap();
            assert_eq!(mesh.triangles.len(), 1);
            assert_eq!(mesh.triangles[0][2], DVec3::new(0.0, 3.0, 0.0));
        }
    }

    #[test]
    fn truncated_inputs_error_without_panicking() {
        for data in [ASCII_QUAD.as_bytes().to_vec(), binary(false)] {
            for n in 0..data.len() {
                let _ = parse_ply(&data[..n]);
            }
        }
    }

    #[test]
    fn errors_carry_line_numbers() {
        let bad = ASCII_QUAD.replace("1 1 0 9", "1 x 0 9");
        let (line, msg) = parse_ply(bad.as_bytes()).unwrap_err();
        assert_eq!(line, Some(14));
        assert!(msg.contains("\"x\""), "{msg}");
        let bad = ASCII_QUAD.replace("4 0 1 2 3", "4 0 1 2 7");
        let (_, msg) = parse_ply(bad.as_bytes()).unwrap_err();
        assert!(msg.contains("vertex 7"), "{msg}");
    }
}
