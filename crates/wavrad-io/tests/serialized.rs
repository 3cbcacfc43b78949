//! Mitsuba's `serialized` meshes, read from files written here after the
//! format's specification (the documentation of Mitsuba 3's
//! `src/shapes/serialized.cpp`): versions 3 and 4, single and double
//! precision, optional vertex attributes, several shapes with the
//! end-of-file dictionary; and the `serialized` shape plugin.

use std::io::Write;
use std::path::{Path, PathBuf};

use flate2::write::ZlibEncoder;
use flate2::Compression;
use glam::{DVec2, DVec3};
use wavrad_io::mesh::read_serialized;
use wavrad_io::{load_scene_str, Loaded};

// The specification's flag bits.
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const FACE_NORMALS: u32 = 0x0010;
const SINGLE_PRECISION: u32 = 0x1000;
const DOUBLE_PRECISION: u32 = 0x2000;

/// One shape to write: its flags, name (written in version 4 only),
/// positions and triangles.
struct Shape<'a> {
    flags: u32,
    name: &'a str,
    positions: &'a [[f64; 3]],
    triangles: &'a [[u32; 3]],
}

/// Every vertex's normal in the files written here: not unit, not the
/// winding's (readers keep normals as stored).
const NORMAL: DVec3 = DVec3::new(0.0, 0.5, -2.0);

/// A quad in the z = 0 plane: (0,0), (1,0), (1,1), (0,1), facing +z.
const QUAD: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
];
const QUAD_TRIANGLES: [[u32; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

/// The uncompressed header, then the shape's zlib stream.
fn shape_bytes(version: u16, shape: &Shape) -> Vec<u8> {
    let mut body = Vec::new();
    body.extend(shape.flags.to_le_bytes());
    if version == 4 {
        body.extend(shape.name.as_bytes());
        body.push(0);
    }
    let vertices = shape.positions.len();
    body.extend((vertices as u64).to_le_bytes());
    body.extend((shape.triangles.len() as u64).to_le_bytes());
    let mut floats = |values: &mut dyn Iterator<Item = f64>| {
        for v in values {
            if shape.flags & DOUBLE_PRECISION != 0 {
                body.extend(v.to_le_bytes());
            } else {
                body.extend((v as f32).to_le_bytes());
            }
        }
    };
    floats(&mut shape.positions.iter().flatten().copied());
    if shape.flags & HAS_NORMALS != 0 {
        floats(&mut (0..vertices).flat_map(|_| NORMAL.to_array()));
    }
    if shape.flags & HAS_TEXCOORDS != 0 {
        floats(&mut (0..vertices).flat_map(|i| [i as f64 / 4.0, 0.5]));
    }
    if shape.flags & HAS_COLORS != 0 {
        floats(&mut (0..vertices).flat_map(|_| [0.9, 0.1, 0.2]));
    }
    for index in shape.triangles.iter().flatten() {
        body.extend(index.to_le_bytes());
    }
    let mut bytes = Vec::new();
    bytes.extend(0x041Cu16.to_le_bytes());
    bytes.extend(version.to_le_bytes());
    let mut zlib = ZlibEncoder::new(bytes, Compression::default());
    zlib.write_all(&body).unwrap();
    zlib.finish().unwrap()
}

/// The shapes one after the other; with `dictionary`, each one's offset
/// (`u64` in version 4, `u32` in version 3) and the count after them.
fn file_bytes(version: u16, shapes: &[Shape], dictionary: bool) -> Vec<u8> {
    let mut bytes = Vec::new();
    let mut offsets = Vec::new();
    for shape in shapes {
        offsets.push(bytes.len() as u64);
        bytes.extend(shape_bytes(version, shape));
    }
    if dictionary {
        for offset in offsets {
            match version {
                4 => bytes.extend(offset.to_le_bytes()),
                _ => bytes.extend((offset as u32).to_le_bytes()),
            }
        }
        bytes.extend((shapes.len() as u32).to_le_bytes());
    }
    bytes
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn quad(flags: u32) -> Shape<'static> {
    Shape {
        flags,
        name: "quad",
        positions: &QUAD,
        triangles: &QUAD_TRIANGLES,
    }
}

/// Three shapes told apart by their single triangle's height z = 1, 2, 3.
fn three_shapes(version: u16) -> Vec<u8> {
    const TRIANGLE: [[u32; 3]; 1] = [[0, 1, 2]];
    const POSITIONS: [[[f64; 3]; 3]; 3] = [
        [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]],
        [[0.0, 0.0, 2.0], [1.0, 0.0, 2.0], [0.0, 1.0, 2.0]],
        [[0.0, 0.0, 3.0], [1.0, 0.0, 3.0], [0.0, 1.0, 3.0]],
    ];
    let shapes: Vec<Shape> = POSITIONS
        .iter()
        .map(|positions| Shape {
            flags: SINGLE_PRECISION | HAS_NORMALS,
            name: "part",
            positions,
            triangles: &TRIANGLE,
        })
        .collect();
    file_bytes(version, &shapes, true)
}

#[test]
fn single_precision_with_every_vertex_attribute() {
    let dir = tempfile::tempdir().unwrap();
    let flags = SINGLE_PRECISION | HAS_NORMALS | HAS_TEXCOORDS | HAS_COLORS | FACE_NORMALS;
    for version in [3, 4] {
        let path = write(
            dir.path(),
            "quad.serialized",
            &file_bytes(version, &[quad(flags)], false),
        );
        let mesh = read_serialized(&path, 0).unwrap_or_else(|e| panic!("{e}"));
        let expected = QUAD_TRIANGLES.map(|t| t.map(|i| DVec3::from(QUAD[i as usize])));
        assert_eq!(mesh.triangles, expected, "version {version}");
        assert_eq!(mesh.normals, Some(vec![[NORMAL; 3]; 2]));
        let uv = QUAD_TRIANGLES.map(|t| t.map(|i| DVec2::new(f64::from(i) / 4.0, 0.5)));
        assert_eq!(mesh.texcoords, Some(uv.to_vec()), "version {version}");
    }
}

#[test]
fn double_precision_keeps_every_bit() {
    let dir = tempfile::tempdir().unwrap();
    let positions = [[0.1, 0.2, 0.3], [1.1, 0.2, 0.3], [0.1, 1.3, 0.3]];
    for flags in [DOUBLE_PRECISION, DOUBLE_PRECISION | HAS_TEXCOORDS] {
        let shape = Shape {
            flags,
            name: "thin",
            positions: &positions,
            triangles: &[[0, 1, 2]],
        };
        let path = write(dir.path(), "t.serialized", &file_bytes(4, &[shape], true));
        let mesh = read_serialized(&path, 0).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(mesh.triangles, [positions.map(DVec3::from)]);
        assert_eq!(mesh.normals, None);
    }
}

#[test]
fn shape_index_is_found_through_the_dictionary() {
    let dir = tempfile::tempdir().unwrap();
    for version in [3, 4] {
        let path = write(dir.path(), "parts.serialized", &three_shapes(version));
        for index in 0..3 {
            let mesh = read_serialized(&path, index).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(mesh.triangles.len(), 1);
            assert!(mesh.triangles[0]
                .iter()
                .all(|v| v.z == f64::from(index + 1)));
        }
        let e = read_serialized(&path, 3).unwrap_err().to_string();
        assert!(
            e.contains("parts.serialized")
                && e.contains("shape_index 3 is out of range")
                && e.contains("holds 3 shapes"),
            "{e}"
        );
    }
}

#[test]
fn bad_headers_and_indices_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let error = |bytes: &[u8]| {
        let path = write(dir.path(), "bad.serialized", bytes);
        let e = read_serialized(&path, 0).unwrap_err().to_string();
        assert!(e.starts_with(&format!("{}: ", path.display())), "{e}");
        e
    };
    let mut bytes = file_bytes(4, &[quad(SINGLE_PRECISION)], false);
    bytes[0] = 0x1D;
    assert!(error(&bytes).contains("not a Mitsuba serialized mesh"));
    bytes[0] = 0x1C;
    bytes[2] = 5;
    assert!(error(&bytes).contains("unsupported serialized version 5"));
    let shape = Shape {
        triangles: &[[0, 1, 7]],
        ..quad(SINGLE_PRECISION)
    };
    let e = error(&file_bytes(4, &[shape], false));
    assert!(
        e.contains("triangle 0 refers to vertex 7") && e.contains("only 4 vertices"),
        "{e}"
    );
    let shape = Shape {
        positions: &[[0.0, 0.0, 0.0], [f64::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]],
        triangles: &[[0, 1, 2]],
        ..quad(DOUBLE_PRECISION)
    };
    assert!(error(&file_bytes(3, &[shape], false)).contains("vertex 1 is not finite"));
}

#[test]
fn counts_are_checked_against_the_data_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    // A header claiming 2^32 − 1 vertices and 2^40 triangles, and no data.
    let mut body = SINGLE_PRECISION.to_le_bytes().to_vec();
    body.extend(u64::from(u32::MAX).to_le_bytes());
    body.extend((1u64 << 40).to_le_bytes());
    let mut bytes = 0x041Cu16.to_le_bytes().to_vec();
    bytes.extend(3u16.to_le_bytes());
    let mut zlib = ZlibEncoder::new(bytes, Compression::default());
    zlib.write_all(&body).unwrap();
    let path = write(dir.path(), "huge.serialized", &zlib.finish().unwrap());
    let e = read_serialized(&path, 0).unwrap_err().to_string();
    assert!(
        e.contains("truncated") && e.contains("the data ends after 0"),
        "{e}"
    );
}

#[test]
fn truncated_or_corrupted_files_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = three_shapes(4);
    let path = dir.path().join("cut.serialized");
    for end in 0..bytes.len() {
        std::fs::write(&path, &bytes[..end]).unwrap();
        // The last shape and the dictionary are needed by every index > 0.
        assert!(read_serialized(&path, 2).is_err(), "cut at {end}");
        let _ = read_serialized(&path, 0);
    }
    for at in 0..bytes.len() {
        let mut corrupted = bytes.clone();
        corrupted[at] ^= 0x5A;
        std::fs::write(&path, &corrupted).unwrap();
        for index in 0..3 {
            let _ = read_serialized(&path, index);
        }
    }
}

fn load(dir: &Path, shape: &str) -> wavrad_io::Result<Loaded> {
    let xml = format!("<scene version=\"3.0.0\">\n{shape}\n</scene>");
    load_scene_str(&xml, dir, "s.xml", &[])
}

#[test]
fn the_shape_plugin_honours_shape_index_to_world_and_flip_normals() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "parts.serialized", &three_shapes(4));
    let loaded = load(
        dir.path(),
        r#"<shape type="serialized" id="part">
            <string name="filename" value="parts.serialized"/>
            <integer name="shape_index" value="1"/>
            <boolean name="face_normals" value="true"/>
            <boolean name="flip_normals" value="true"/>
            <transform name="to_world"><scale x="2"/><translate y="5"/></transform>
            <emitter type="area"><rgb name="radiance" value="3"/></emitter>
        </shape>"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(loaded.warnings.is_empty());
    let [surface] = &loaded.scene.surfaces[..] else {
        panic!("{:?}", loaded.scene.surfaces)
    };
    assert_eq!(surface.name, "part");
    assert!(surface.is_emitter());
    assert!(
        (surface.patch.area() - 1.0).abs() < 1e-12,
        "scaled by 2 along x"
    );
    assert_eq!(surface.patch.normal(), -DVec3::Z, "flipped");
    assert!(surface
        .patch
        .vertices()
        .iter()
        .all(|v| v.z == 2.0 && v.y >= 5.0));
}

#[test]
fn the_front_is_the_side_of_mitsubas_shading_normal() {
    // The quad's stored normals point to −z, against its winding. Mitsuba
    // 3.9.1 emits this file's quad towards −z, towards +z with face_normals,
    // and towards −z under a mirror in x with face normals or without.
    let dir = tempfile::tempdir().unwrap();
    let flags = SINGLE_PRECISION | HAS_NORMALS;
    write(
        dir.path(),
        "quad.serialized",
        &file_bytes(4, &[quad(flags)], false),
    );
    for (mirror, face_normals, front) in [
        (false, false, -1.0),
        (false, true, 1.0),
        (true, false, -1.0),
        (true, true, -1.0),
    ] {
        let shape = format!(
            r#"<shape type="serialized">
                <string name="filename" value="quad.serialized"/>
                <boolean name="face_normals" value="{face_normals}"/>
                <transform name="to_world"><scale x="{}"/></transform>
            </shape>"#,
            if mirror { -1 } else { 1 }
        );
        let scene = load(dir.path(), &shape)
            .unwrap_or_else(|e| panic!("{e}"))
            .scene;
        for surface in &scene.surfaces {
            assert_eq!(
                surface.patch.normal(),
                DVec3::new(0.0, 0.0, front),
                "mirror {mirror}, face_normals {face_normals}"
            );
        }
    }
}

#[test]
fn the_shape_plugin_reports_bad_parameters_and_files_at_their_lines() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "parts.serialized", &three_shapes(3));
    let error = |shape: &str| load(dir.path(), shape).unwrap_err().to_string();
    let e = error(
        "<shape type=\"serialized\">\n<string name=\"filename\" value=\"parts.serialized\"/>\n<integer name=\"shape_index\" value=\"-1\"/></shape>",
    );
    assert!(
        e.starts_with("s.xml:4: ") && e.contains("non-negative"),
        "{e}"
    );
    let e = error(
        "<shape type=\"serialized\">\n<string name=\"filename\" value=\"parts.serialized\"/>\n<integer name=\"shape_index\" value=\"9\"/></shape>",
    );
    assert!(
        e.starts_with("s.xml:3: cannot load mesh of shape \"serialized\"")
            && e.contains("parts.serialized: shape_index 9 is out of range"),
        "{e}"
    );
    let e = error("<shape type=\"serialized\">\n<string name=\"filename\" value=\"none.serialized\"/></shape>");
    assert!(
        e.starts_with("s.xml:3: ") && e.contains("none.serialized"),
        "{e}"
    );
    let e = error("<shape type=\"serialized\"/>");
    assert!(e.contains("needs a \"filename\""), "{e}");
}
