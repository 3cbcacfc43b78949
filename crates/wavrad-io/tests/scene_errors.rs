//! Bad scene input: every error names the file, the line and the offending
//! name, and no input makes the loader panic.

use std::fs;
use std::path::Path;
use std::time::{Duration, Instant};

use wavrad_io::{load_scene, load_scene_str};

/// Load `xml` as "bad.xml" from `dir` and return the error message.
fn error_in(dir: &Path, xml: &str) -> String {
    match load_scene_str(xml, dir, "bad.xml", &[]) {
        Ok(_) => panic!("loaded without error:\n{xml}"),
        Err(e) => e.to_string(),
    }
}

/// Assert the error of `xml` is at `bad.xml:line` and mentions every needle.
#[track_caller]
fn assert_error(xml: &str, line: u32, needles: &[&str]) {
    assert_error_in(Path::new("."), xml, line, needles);
}

#[track_caller]
fn assert_error_in(dir: &Path, xml: &str, line: u32, needles: &[&str]) {
    assert_message(&error_in(dir, xml), "bad.xml", line, needles);
}

/// Assert `msg` is at `file:line` and mentions every needle.
#[track_caller]
fn assert_message(msg: &str, file: &str, line: u32, needles: &[&str]) {
    assert!(
        msg.starts_with(&format!("{file}:{line}: ")),
        "expected {file}:{line}: {msg}"
    );
    for needle in needles {
        assert!(msg.contains(needle), "expected {needle:?} in: {msg}");
    }
}

/// Assert the error of `xml` loaded with `overrides` (as `-D name=value`)
/// is at `bad.xml:line` and mentions every needle.
#[track_caller]
fn assert_override_error(xml: &str, overrides: &[(&str, &str)], line: u32, needles: &[&str]) {
    let overrides: Vec<(String, String)> = overrides
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    match load_scene_str(xml, Path::new("."), "bad.xml", &overrides) {
        Ok(_) => panic!("loaded without error:\n{xml}"),
        Err(e) => assert_message(&e.to_string(), "bad.xml", line, needles),
    }
}

#[test]
fn unsupported_shape() {
    assert_error(
        "<scene version=\"3.0.0\">\n  <shape type=\"bsplinecurve\">\n  </shape>\n</scene>",
        2,
        &[
            "unsupported shape plugin \"bsplinecurve\"",
            "rectangle, cube, disk, cylinder, sphere, obj, ply, serialized",
        ],
    );
}

#[test]
fn degenerate_analytic_shapes() {
    assert_error(
        "<scene version=\"3.0.0\">\n<shape type=\"cylinder\">\n<point name=\"p1\" x=\"0\" y=\"0\" z=\"0\"/>\n</shape></scene>",
        3,
        &["cylinder", "p0 = p1"],
    );
    for (plugin, parameter) in [
        ("sphere", "<float name=\"radius\" value=\"0\"/>"),
        (
            "disk",
            "<transform name=\"to_world\"><scale y=\"0\"/></transform>",
        ),
        ("cylinder", "<float name=\"radius\" value=\"0\"/>"),
    ] {
        assert_error(
            &format!("<scene version=\"3.0.0\">\n<shape type=\"{plugin}\">\n{parameter}\n</shape></scene>"),
            2,
            &[plugin, "zero area after to_world"],
        );
    }
    assert_error(
        "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n<float name=\"radius\" value=\"1e300\"/>\n<transform name=\"to_world\"><scale value=\"1e300\"/></transform>\n</shape></scene>",
        2,
        &["sphere", "too large"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n<rgb name=\"center\" value=\"1\"/>\n</shape></scene>",
        3,
        &["center", "must be a <point>"],
    );
}

#[test]
fn unsupported_bsdfs() {
    for (plugin, message) in [
        (
            "blendbsdf",
            "unsupported bsdf plugin \"blendbsdf\" (supported: diffuse, twosided",
        ),
        ("normalmap", "bsdf \"normalmap\" is not supported"),
    ] {
        assert_error(
            &format!(
                "<scene version=\"3.0.0\">\n<shape type=\"rectangle\">\n<bsdf type=\"{plugin}\"/>\n</shape></scene>"
            ),
            3,
            &[message, "--approximate"],
        );
    }
    // Also when defined at the top level and never used.
    assert_error(
        "<scene version=\"3.0.0\">\n<bsdf type=\"hair\" id=\"p\"/></scene>",
        2,
        &["\"hair\""],
    );
}

#[test]
fn unknown_parameter() {
    assert_error(
        "<scene version=\"3.0.0\">\n<shape type=\"rectangle\">\n\n  <float name=\"radius\" value=\"2\"/>\n</shape></scene>",
        4,
        &["unknown parameter \"radius\"", "shape \"rectangle\"", "to_world"],
    );
    assert_error(
        "<scene>\n<shape type=\"cube\"><bsdf type=\"diffuse\">\n<rgb name=\"diffuse_reflectance\" value=\"0.5\"/></bsdf></shape></scene>",
        3,
        &["\"diffuse_reflectance\"", "bsdf \"diffuse\""],
    );
}

#[test]
fn malformed_float() {
    assert_error(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n<float name=\"fov\" value=\"4o\"/>\n</sensor></scene>",
        3,
        &["malformed number \"4o\"", "fov"],
    );
    assert_error(
        "<scene>\n<shape type=\"rectangle\"><transform name=\"to_world\">\n<translate value=\"1, 2, three\"/></transform></shape></scene>",
        3,
        &["\"three\"", "translate"],
    );
}

#[test]
fn missing_scene_file() {
    let e = load_scene(Path::new("/no/such/dir/scene.xml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("/no/such/dir/scene.xml"), "{e}");
}

#[test]
fn missing_mesh_file() {
    assert_error(
        "<scene version=\"3.0.0\">\n<shape type=\"obj\">\n<string name=\"filename\" value=\"meshes/missing.obj\"/>\n</shape></scene>",
        3,
        &["missing.obj", "shape \"obj\""],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<shape type=\"ply\">\n</shape></scene>",
        2,
        &["\"filename\"", "shape \"ply\""],
    );
}

#[test]
fn bad_ref_id() {
    assert_error(
        "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\" id=\"white\"/>\n<shape type=\"rectangle\">\n<ref id=\"whte\"/></shape></scene>",
        4,
        &["unknown id \"whte\""],
    );
}

#[test]
fn duplicate_id() {
    assert_error(
        "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\" id=\"white\"/>\n\n<bsdf type=\"diffuse\" id=\"white\"/></scene>",
        4,
        &["duplicate id \"white\"", "bad.xml:2"],
    );
}

#[test]
fn undefined_variable() {
    assert_error(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><sampler type=\"independent\">\n<integer name=\"sample_count\" value=\"$spp\"/></sampler></sensor></scene>",
        3,
        &["undefined parameter \"$spp\""],
    );
}

#[test]
fn include_cycle_and_missing_include() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(
        dir.path().join("a.xml"),
        "<scene version=\"3.0.0\">\n<include filename=\"b.xml\"/>\n</scene>",
    )
    .unwrap();
    fs::write(
        dir.path().join("b.xml"),
        "<scene version=\"3.0.0\">\n<shape type=\"cube\"/>\n<include filename=\"a.xml\"/>\n</scene>",
    )
    .unwrap();
    let e = load_scene(&dir.path().join("a.xml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("b.xml:3: include cycle"), "{e}");
    assert!(e.contains("\"a.xml\""), "{e}");
    // A file including itself, loaded from a string, stops at a depth limit.
    fs::write(
        dir.path().join("self.xml"),
        "<scene version=\"3.0.0\">\n<include filename=\"self.xml\"/>\n</scene>",
    )
    .unwrap();
    let e = error_in(
        dir.path(),
        "<scene>\n<include filename=\"self.xml\"/></scene>",
    );
    assert!(e.contains("self.xml:2: include cycle"), "{e}");
    assert_error_in(
        dir.path(),
        "<scene>\n\n<include filename=\"nope.xml\"/></scene>",
        3,
        &["nope.xml"],
    );
}

#[test]
fn malformed_xml() {
    // roxmltree reports the position where the document breaks.
    let msg = error_in(
        Path::new("."),
        "<scene version=\"3.0.0\">\n<shape type=\"cube\">\n<float name=\"x\" value=\"1\">\n</shape>\n</scene>",
    );
    assert!(msg.starts_with("bad.xml:4: malformed XML"), "{msg}");
    // A document cut short: roxmltree blames the root that never closes.
    assert_error(
        "<scene version=\"3.0.0\">\n<shape type=\"cube\"",
        1,
        &["malformed XML", "never closed"],
    );
}

#[test]
fn reflectance_out_of_range() {
    assert_error(
        "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\" id=\"hot\">\n<rgb name=\"reflectance\" value=\"0.5, 1.5, 0.5\"/>\n</bsdf></scene>",
        3,
        &["reflectance", "1.5", "outside [0, 1]"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<shape type=\"cube\"><bsdf type=\"diffuse\">\n<float name=\"reflectance\" value=\"-0.1\"/></bsdf></shape></scene>",
        3,
        &["-0.1"],
    );
}

#[test]
fn texture_errors() {
    assert_error(
        "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\">\n<texture type=\"bitmap\" name=\"reflectance\">\n<string name=\"filename\" value=\"wood.png\"/></texture></bsdf></scene>",
        4,
        &["wood.png", "of texture \"bitmap\"", "cannot open"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<texture type=\"mesh_attribute\" id=\"c\"/>\n</scene>",
        2,
        &[
            "unsupported texture plugin \"mesh_attribute\"",
            "checkerboard, bitmap",
        ],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<texture type=\"checkerboard\" id=\"c\">\n<float name=\"colour0\" value=\"1\"/></texture>\n</scene>",
        3,
        &["unknown parameter \"colour0\"", "color0"],
    );
}

#[test]
fn non_hdrfilm_film() {
    assert_error(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n<film type=\"specfilm\"/>\n</sensor></scene>",
        3,
        &["unsupported film plugin \"specfilm\"", "hdrfilm"],
    );
}

#[test]
fn unsupported_rfilter_and_huge_footprints() {
    let film = |rfilter: &str| {
        format!(
            "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\">\n\n{rfilter}\n</film></sensor></scene>"
        )
    };
    assert_error(
        &film("<rfilter type=\"sinc\"/>"),
        4,
        &["unsupported rfilter plugin \"sinc\"", "tent", "lanczos"],
    );
    assert_error(
        &film("<rfilter type=\"gaussian\">\n<float name=\"stddev\" value=\"1e9\"/></rfilter>"),
        5,
        &["gaussian", "at most 6 pixels"],
    );
    assert_error(
        &film("<rfilter type=\"lanczos\"><integer name=\"lobes\" value=\"-2\"/></rfilter>"),
        4,
        &["lobes", "-2"],
    );
    assert_error(
        &film("<rfilter type=\"tent\"><float name=\"radius\" value=\"0\"/></rfilter>"),
        4,
        &["tent", "radius must be a positive number"],
    );
    // Mitsuba's documentation says "A" and "B"; its code reads B and C.
    assert_error(
        &film("<rfilter type=\"mitchell\"><float name=\"A\" value=\"0.3\"/></rfilter>"),
        4,
        &["unknown parameter \"A\"", "B, C"],
    );
}

#[test]
fn unsupported_emitters() {
    for plugin in ["projector", "area_light"] {
        assert_error(
            &format!("<scene version=\"3.0.0\">\n\n<emitter type=\"{plugin}\"/></scene>"),
            3,
            &[&format!("unsupported emitter plugin \"{plugin}\"")],
        );
    }
    assert_error(
        "<scene version=\"3.0.0\">\n<shape type=\"rectangle\">\n<emitter type=\"spot\"/></shape></scene>",
        3,
        &["\"spot\""],
    );
    // The lights that are not surfaces check their parameters.
    assert_error(
        "<scene version=\"3.0.0\">\n<emitter type=\"spot\">\n<float name=\"cutoff_angle\" value=\"10\"/>\n<float name=\"beam_width\" value=\"15\"/></emitter></scene>",
        4,
        &["beam_width 15", "(0, 10]"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<emitter type=\"point\">\n<point name=\"position\" x=\"0\" y=\"0\" z=\"0\"/>\n<transform name=\"to_world\"><translate x=\"1\"/></transform></emitter></scene>",
        3,
        &["either position or to_world"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<emitter type=\"directional\">\n<rgb name=\"irradiance\" value=\"1, -1, 1\"/></emitter></scene>",
        3,
        &["irradiance", "negative"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<emitter type=\"envmap\"/></scene>",
        2,
        &["envmap", "needs a filename"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<emitter type=\"envmap\">\n<string name=\"filename\" value=\"sky.hdr\"/></emitter></scene>",
        3,
        &["sky.hdr", "cannot open"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<emitter type=\"envmap\">\n<string name=\"filename\" value=\"missing.exr\"/></emitter></scene>",
        3,
        &["cannot read the envmap image", "missing.exr"],
    );
    // An area emitter lights one shape, as in Mitsuba.
    assert_error(
        "<scene version=\"3.0.0\">\n<emitter type=\"area\" id=\"l\"/>\n<shape type=\"rectangle\"><ref id=\"l\"/></shape>\n<shape type=\"cube\">\n<ref id=\"l\"/></shape></scene>",
        5,
        &["attached to a shape already", "bad.xml:3", "bad.xml:2"],
    );
    // Its parameters are checked even when no shape references it.
    assert_error(
        "<scene version=\"3.0.0\">\n<emitter type=\"area\" id=\"l\">\n<rgb name=\"radiance\" value=\"-1\"/></emitter></scene>",
        3,
        &["negative"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<emitter type=\"area\">\n<float name=\"power\" value=\"1\"/></emitter></scene>",
        3,
        &["unknown parameter \"power\""],
    );
}

#[test]
fn empty_mesh() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(
        dir.path().join("empty.obj"),
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
    )
    .unwrap();
    assert_error_in(
        dir.path(),
        "<scene version=\"3.0.0\">\n<shape type=\"obj\">\n  <string name=\"filename\" value=\"empty.obj\"/>\n</shape></scene>",
        3,
        &["empty.obj", "no usable triangles"],
    );
    fs::write(
        dir.path().join("bad.ply"),
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 zero\n",
    )
    .unwrap();
    assert_error_in(
        dir.path(),
        "<scene version=\"3.0.0\">\n<shape type=\"ply\">\n  <string name=\"filename\" value=\"bad.ply\"/>\n</shape></scene>",
        3,
        &["bad.ply:8", "\"zero\""],
    );
}

#[test]
fn negative_width() {
    assert_error(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\">\n<integer name=\"width\" value=\"-5\"/>\n</film></sensor></scene>",
        3,
        &["width", "-5"],
    );
}

#[test]
fn unknown_element_tags() {
    assert_error(
        "<scene version=\"3.0.0\">\n<shape type=\"cube\">\n<medium type=\"homogeneous\" name=\"interior\"/></shape></scene>",
        3,
        &["<medium type=\"homogeneous\">"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<foo/>\n</scene>",
        2,
        &["unknown element <foo>"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<shape type=\"cube\"><transform name=\"to_world\">\n<shear value=\"1\"/></transform></shape></scene>",
        3,
        &["<shear>"],
    );
}

#[test]
fn unsupported_version_and_root() {
    assert_error("<scene version=\"4.0.0\">\n</scene>", 1, &["\"4.0.0\""]);
    assert_error(
        "\n<shape type=\"cube\"/>",
        2,
        &["root element must be <scene>"],
    );
}

#[test]
fn wrong_parameter_type_and_attribute() {
    assert_error(
        "<scene>\n<sensor type=\"perspective\">\n<string name=\"fov\" value=\"wide\"/></sensor></scene>",
        3,
        &["\"fov\"", "<float>", "<string>"],
    );
    assert_error(
        "<scene>\n<shape type=\"cube\" colour=\"red\"/></scene>",
        2,
        &["unexpected attribute \"colour\""],
    );
}

#[test]
fn unsupported_sensor_settings() {
    let sensor = |inner: &str| {
        format!(
            "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n{inner}\n</sensor></scene>"
        )
    };
    assert_error(
        &sensor("<float name=\"principal_point_offset_x\" value=\"0.1\"/>"),
        3,
        &["principal_point_offset_x"],
    );
    assert_error(
        &sensor("<film type=\"hdrfilm\"><integer name=\"crop_width\" value=\"10\"/></film>"),
        3,
        &["crop_width"],
    );
    assert_error(
        &sensor("<string name=\"fov_axis\" value=\"z\"/><float name=\"fov\" value=\"30\"/>"),
        3,
        &["fov_axis \"z\""],
    );
    assert_error(
        "<scene>\n<sensor type=\"thinlens\"/></scene>",
        2,
        &["unsupported sensor plugin \"thinlens\""],
    );
    assert_error(
        &sensor("<spectrum name=\"srf\" value=\"400:1, 500:2\"/>"),
        3,
        &["unknown parameter \"srf\""],
    );
}

#[test]
fn twosided_needs_a_bsdf() {
    assert_error(
        "<scene>\n<shape type=\"cube\">\n<bsdf type=\"twosided\"/></shape></scene>",
        3,
        &["twosided", "found 0"],
    );
    // A reference cycle is an error, not a stack overflow.
    assert_error(
        "<scene>\n<bsdf type=\"twosided\" id=\"a\"><ref id=\"a\"/></bsdf></scene>",
        2,
        &["a"],
    );
}

/// A scene touching most features, for the no-panic sweeps.
const SCENE: &str = r#"<scene version="3.0.0">
    <default name="spp" value="8"/>
    <bsdf type="twosided" id="white"><bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.7 0.6"/></bsdf></bsdf>
    <sensor type="perspective">
        <float name="fov" value="40"/><string name="fov_axis" value="smaller"/>
        <transform name="to_world"><lookat origin="0 0 4" target="0 0 0" up="0 1 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/>
            <rfilter type="gaussian"><float name="stddev" value="0.5"/></rfilter></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.3"/><rotate x="1" angle="90"/><translate y="0.99"/></transform>
        <ref name="bsdf" id="white"/>
        <emitter type="area"><rgb name="radiance" value="10"/></emitter>
    </shape>
    <shape type="cube"><transform name="to_world"><matrix value="0.3 0 0 0 0 0.6 0 0 0 0 0.3 0 0 0 0 1"/></transform>
        <bsdf type="diffuse"><spectrum name="reflectance" value="0.5"/></bsdf></shape>
</scene>"#;

#[test]
fn truncated_scenes_never_panic() {
    load_scene_str(SCENE, Path::new("."), "ok.xml", &[]).unwrap();
    for (end, _) in SCENE.char_indices() {
        let _ = load_scene_str(&SCENE[..end], Path::new("."), "cut.xml", &[]);
    }
}

#[test]
fn corrupted_scenes_never_panic() {
    let bytes: Vec<char> = SCENE.chars().collect();
    for i in 0..bytes.len() {
        for c in ['<', '"', '$', '0', '-', ' ', 'x', '/'] {
            let mut corrupted = bytes.clone();
            corrupted[i] = c;
            let text: String = corrupted.into_iter().collect();
            let _ = load_scene_str(&text, Path::new("."), "bad.xml", &[]);
        }
    }
}

#[test]
fn truncated_meshes_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1 4/1/1\n";
    for end in 0..obj.len() {
        let path = dir.path().join("cut.obj");
        fs::write(&path, &obj[..end]).unwrap();
        let _ = wavrad_io::mesh::read_obj(&path);
        let _ = load_scene_str(
            "<scene><shape type=\"obj\"><string name=\"filename\" value=\"cut.obj\"/></shape></scene>",
            dir.path(),
            "m.xml",
            &[],
        );
    }
}

fn bsdf_error(bsdf_body: &str, plugin: &str, line: u32, needles: &[&str]) {
    assert_error(
        &format!(
            "<scene version=\"3.0.0\">\n<bsdf type=\"{plugin}\" id=\"b\">\n{bsdf_body}\n</bsdf></scene>"
        ),
        line,
        needles,
    );
}

#[test]
fn glossy_bsdf_parameter_errors() {
    // Unknown names, listing the known ones.
    bsdf_error(
        "<string name=\"distribution\" value=\"phong\"/>",
        "roughconductor",
        3,
        &["unknown distribution \"phong\"", "beckmann, ggx"],
    );
    bsdf_error(
        "<string name=\"material\" value=\"Unobtainium\"/>",
        "roughconductor",
        3,
        &["unknown conductor material \"Unobtainium\"", "Au", "Cu"],
    );
    bsdf_error(
        "<string name=\"variant\" value=\"phong\"/>",
        "ward",
        3,
        &["unknown variant \"phong\"", "ward-duer"],
    );
    bsdf_error(
        "<string name=\"int_ior\" value=\"jelly\"/>",
        "roughplastic",
        3,
        &["unknown int_ior \"jelly\"", "polypropylene", "bk7"],
    );
    // Negative roughness, and ward's must be positive.
    bsdf_error(
        "<float name=\"alpha\" value=\"-0.1\"/>",
        "roughconductor",
        3,
        &["alpha = -0.1", "non-negative"],
    );
    bsdf_error(
        "\n<float name=\"alphaU\" value=\"0\"/>",
        "ward",
        4,
        &["alphaU = 0", "positive"],
    );
    // Reflectances out of range, and ward's ρ_s + ρ_d > 1.
    bsdf_error(
        "<rgb name=\"specular_reflectance\" value=\"1.2\"/>",
        "roughconductor",
        3,
        &["specular_reflectance", "outside [0, 1]"],
    );
    bsdf_error(
        "<rgb name=\"diffuse_reflectance\" value=\"0.5, 0.5, 1.5\"/>",
        "roughplastic",
        3,
        &["diffuse_reflectance", "1.5"],
    );
    bsdf_error(
        "<float name=\"specularReflectance\" value=\"0.4\"/>\n<rgb name=\"diffuseReflectance\" value=\"0.7\"/>",
        "ward",
        4,
        &["exceed 1", "specularReflectance + diffuseReflectance"],
    );
    // Conflicting or incomplete parameters.
    bsdf_error(
        "<string name=\"material\" value=\"Au\"/>\n<rgb name=\"eta\" value=\"0.2\"/>",
        "roughconductor",
        4,
        &["either \"material\" or \"eta\"/\"k\""],
    );
    bsdf_error(
        "<float name=\"alpha_u\" value=\"0.2\"/>",
        "roughconductor",
        3,
        &["both \"alpha_u\" and \"alpha_v\""],
    );
    bsdf_error(
        "<float name=\"alpha_u\" value=\"0.2\"/><float name=\"alpha_v\" value=\"0.3\"/>",
        "roughplastic",
        3,
        &["isotropic only"],
    );
    bsdf_error(
        "<float name=\"alpha\" value=\"0.2\"/><float name=\"alphaU\" value=\"0.2\"/><float name=\"alpha_u\" value=\"0.3\"/>",
        "ward",
        3,
        &["\"alpha_u\" or \"alphaU\", not both"],
    );
    bsdf_error(
        "<float name=\"int_ior\" value=\"1.5\"/><float name=\"ext_ior\" value=\"1.5\"/>",
        "roughplastic",
        3,
        &["must differ"],
    );
    bsdf_error(
        "<boolean name=\"sample_visible\" value=\"false\"/>",
        "roughplastic",
        3,
        &["sample_visible", "not supported"],
    );
    // Wrong types and textures.
    bsdf_error(
        "<rgb name=\"alpha\" value=\"0.1\"/>",
        "roughconductor",
        3,
        &["\"alpha\"", "must be a <float>"],
    );
    bsdf_error(
        "<texture type=\"checkerboard\" name=\"diffuse_reflectance\"/>",
        "roughplastic",
        3,
        &["a texture on diffuse_reflectance", "--approximate"],
    );
    bsdf_error(
        "<float name=\"exponent\" value=\"3\"/>",
        "ward",
        3,
        &["unknown parameter \"exponent\"", "bsdf \"ward\""],
    );
}

/// A scene reading `$res` and declaring `spp` without reading it.
const WITH_DEFAULTS: &str = "<scene version=\"3.0.0\">\n<default name=\"res\" value=\"8\"/>\n\
    <default name=\"spp\" value=\"4\"/>\n<sensor type=\"perspective\"><film type=\"hdrfilm\">\n\
    <integer name=\"width\" value=\"$res\"/></film></sensor>\n<shape type=\"cube\"/></scene>";

#[test]
fn overrides_no_parameter_reads() {
    // Declared but never read: named at its <default>.
    assert_override_error(
        WITH_DEFAULTS,
        &[("spp", "64")],
        3,
        &["spp=64 is used nowhere", "no attribute reads $spp", "$res"],
    );
    // Never declared (a misspelling): named at the <scene>.
    assert_override_error(
        WITH_DEFAULTS,
        &[("rez", "64")],
        1,
        &[
            "rez=64 is used nowhere",
            "declares no such <default>",
            "$res",
        ],
    );
}

#[test]
fn overrides_with_bad_names() {
    assert_override_error(WITH_DEFAULTS, &[("", "5")], 1, &["=5", "name is empty"]);
    assert_override_error(
        WITH_DEFAULTS,
        &[("res-x", "5")],
        1,
        &["res-x=5", "letters, digits and _"],
    );
    assert_override_error(
        WITH_DEFAULTS,
        &[("res", "5"), ("res", "6")],
        1,
        &["res=6", "given twice"],
    );
}

#[test]
fn unknown_integrator_parameters() {
    assert_error(
        "<scene version=\"3.0.0\">\n<integrator type=\"path\">\n<integer name=\"samples\" value=\"4\"/>\n</integrator></scene>",
        3,
        &["unknown parameter \"samples\"", "integrator \"path\"", "max_depth", "rr_depth"],
    );
    // What another plugin reads is unknown to this one.
    assert_error(
        "<scene version=\"3.0.0\">\n<integrator type=\"direct\">\n\n<integer name=\"max_depth\" value=\"4\"/>\n</integrator></scene>",
        4,
        &["unknown parameter \"max_depth\"", "integrator \"direct\"", "emitter_samples"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<integrator type=\"path\">\n<string name=\"rr_depth\" value=\"five\"/>\n</integrator></scene>",
        3,
        &["\"rr_depth\"", "must be an <integer>", "<string>"],
    );
}

#[test]
fn integrators_nest_only_where_mitsuba_nests_them() {
    assert_error(
        "<scene version=\"3.0.0\">\n<integrator type=\"path\">\n<integrator type=\"direct\"/>\n</integrator></scene>",
        3,
        &["integrator \"path\" cannot contain a <integrator>"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<integrator type=\"aov\">\n<bsdf type=\"diffuse\"/>\n</integrator></scene>",
        3,
        &["integrator \"aov\" cannot contain a <bsdf>"],
    );
    // A nested integrator's parameters are checked too.
    assert_error(
        "<scene version=\"3.0.0\">\n<integrator type=\"aov\"><integrator type=\"path\" name=\"image\">\n<float name=\"max_depth\" value=\"1.5\"/>\n</integrator></integrator></scene>",
        3,
        &["\"max_depth\"", "must be an <integer>"],
    );
}

#[test]
fn includes_doubling_at_each_level_fail_fast_at_the_depth_bound() {
    // 31 files each including the next twice would expand 2^31 files.
    let dir = tempfile::tempdir().unwrap();
    for i in 0..31 {
        let next = format!("<include filename=\"{}.xml\"/>", i + 1);
        fs::write(
            dir.path().join(format!("{i}.xml")),
            format!("<scene version=\"3.0.0\">\n{next}\n{next}\n</scene>"),
        )
        .unwrap();
    }
    fs::write(
        dir.path().join("31.xml"),
        "<scene version=\"3.0.0\"><shape type=\"cube\"/></scene>",
    )
    .unwrap();
    let started = Instant::now();
    let e = load_scene(&dir.path().join("0.xml"))
        .unwrap_err()
        .to_string();
    assert!(started.elapsed() < Duration::from_secs(5), "{e}");
    // Named at the include that would go one file deeper than Mitsuba goes.
    let deepest = dir
        .path()
        .join(format!("{}.xml", wavrad_io::mitsuba::MAX_INCLUDE_DEPTH));
    assert_message(
        &e,
        &deepest.display().to_string(),
        2,
        &["includes nested deeper than 14 files"],
    );
}

#[test]
fn includes_past_the_count_bound() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("leaf.xml"), "<scene version=\"3.0.0\"/>").unwrap();
    let n = wavrad_io::mitsuba::MAX_INCLUDES;
    let xml = format!(
        "<scene version=\"3.0.0\">\n{}</scene>",
        "<include filename=\"leaf.xml\"/>\n".repeat(n + 1)
    );
    // The first n load; the next is refused where it is written.
    assert_error_in(
        dir.path(),
        &xml,
        n as u32 + 2,
        &["more than 4096 <include>s"],
    );
}

#[test]
fn includes_and_spectra_of_devices_and_directories() {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir(dir.path().join("sub")).unwrap();
    if Path::new("/dev/zero").exists() {
        assert_error_in(
            dir.path(),
            "<scene version=\"3.0.0\">\n<include filename=\"/dev/zero\"/></scene>",
            2,
            &["\"/dev/zero\"", "not a regular file"],
        );
        assert_error_in(
            dir.path(),
            "<scene version=\"3.0.0\"><bsdf type=\"diffuse\">\n<spectrum name=\"reflectance\" filename=\"/dev/zero\"/></bsdf></scene>",
            2,
            &["\"/dev/zero\"", "not a regular file"],
        );
        let e = load_scene(Path::new("/dev/zero")).unwrap_err().to_string();
        assert_eq!(e, "/dev/zero: not a regular file");
    }
    assert_error_in(
        dir.path(),
        "<scene version=\"3.0.0\">\n\n<include filename=\"sub\"/></scene>",
        3,
        &["sub\"", "not a regular file"],
    );
}

/// `(body, line, needles)`: a scene of `body` at line 2 on fails at `line`
/// with a message holding every needle.
type Case = (&'static str, u32, &'static [&'static str]);

#[track_caller]
fn assert_cases(cases: &[Case]) {
    for &(body, line, needles) in cases {
        assert_error(
            &format!("<scene version=\"3.0.0\">\n{body}\n</scene>"),
            line,
            needles,
        );
    }
}

#[test]
fn sizes_past_their_bounds_name_the_line() {
    assert_cases(&[
        (
            "<shape type=\"rectangle\">\n<transform name=\"to_world\"><scale value=\"1e19\"/></transform></shape>",
            2,
            &["shape \"rectangle\"", "vertex", "up to 1e12"],
        ),
        (
            "<shape type=\"cube\">\n<transform name=\"to_world\"><scale value=\"1e38\"/></transform></shape>",
            2,
            &["shape \"cube\"", "up to 1e12"],
        ),
        (
            "\n<shape type=\"sphere\"><float name=\"radius\" value=\"1e20\"/></shape>",
            3,
            &["shape \"sphere\"", "up to 1e12"],
        ),
        (
            "<sensor type=\"perspective\"><film type=\"hdrfilm\">\n<integer name=\"width\" value=\"4294967295\"/>\n<integer name=\"height\" value=\"4294967295\"/></film></sensor>",
            3,
            &["width = 4294967295", "at most 32768 pixels a side"],
        ),
        (
            "<sensor type=\"perspective\"><film type=\"hdrfilm\">\n<integer name=\"width\" value=\"100\"/>\n<integer name=\"height\" value=\"65536\"/></film></sensor>",
            4,
            &["height = 65536"],
        ),
        (
            "<sensor type=\"perspective\"><film type=\"hdrfilm\">\n<integer name=\"width\" value=\"20000\"/>\n<integer name=\"height\" value=\"20000\"/></film></sensor>",
            4,
            &["20000×20000", "at most 268435456 pixels"],
        ),
        (
            "<sensor type=\"perspective\"><film type=\"hdrfilm\">\n<integer name=\"width\" value=\"99999999999\"/></film></sensor>",
            3,
            &["width must be a positive integer", "99999999999"],
        ),
        (
            "<sensor type=\"perspective\"><film type=\"hdrfilm\"><rfilter type=\"gaussian\">\n<float name=\"stddev\" value=\"1e6\"/></rfilter></film></sensor>",
            3,
            &["gaussian", "at most 6 pixels"],
        ),
        (
            "<sensor type=\"perspective\"><sampler type=\"independent\">\n<integer name=\"sample_count\" value=\"2000000000\"/></sampler></sensor>",
            3,
            &["sample_count", "1 to 65536", "2000000000"],
        ),
        (
            "<sampler type=\"independent\">\n\n<integer name=\"sample_count\" value=\"0\"/></sampler>",
            4,
            &["sample_count", "0"],
        ),
    ]);
}

#[test]
fn values_that_are_not_numbers_or_out_of_range() {
    assert_cases(&[
        (
            "<sensor type=\"perspective\">\n<float name=\"fov\" value=\"180\"/></sensor>",
            3,
            &["fov = 180", "(0, 180)"],
        ),
        (
            "<sensor type=\"perspective\">\n<float name=\"fov\" value=\"nan\"/></sensor>",
            3,
            &["malformed number \"nan\"", "fov"],
        ),
        (
            "<shape type=\"cube\"><transform name=\"to_world\">\n<translate x=\"inf\"/></transform></shape>",
            3,
            &["malformed number \"inf\"", "<translate>"],
        ),
        (
            "<shape type=\"cube\"><emitter type=\"area\">\n<rgb name=\"radiance\" value=\"nan\"/></emitter></shape>",
            3,
            &["malformed number \"nan\"", "radiance"],
        ),
        (
            "<sensor type=\"perspective\"><film type=\"hdrfilm\">\n<integer name=\"height\" value=\"0\"/></film></sensor>",
            3,
            &["height must be a positive integer", "0"],
        ),
        (
            "<sensor type=\"perspective\"><film type=\"hdrfilm\">\n<integer name=\"width\" value=\"4.5\"/></film></sensor>",
            3,
            &["malformed integer \"4.5\"", "width"],
        ),
        (
            "<shape type=\"cube\" id=\"c\">\n<boolean name=\"flip_normals\" value=\"yes\"/></shape>",
            3,
            &["malformed boolean \"yes\"", "true or false"],
        ),
        (
            "<bsdf type=\"diffuse\">\n<rgb name=\"reflectance\" value=\"0.1, 0.2\"/></bsdf>",
            3,
            &["1 or 3 values", "got 2"],
        ),
        (
            "<shape type=\"cube\"><transform name=\"to_world\">\n<matrix value=\"1 0 0 0 0 1 0 0 0 0 1 0 0 0 0\"/></transform></shape>",
            3,
            &["matrix"],
        ),
        (
            "<sensor type=\"perspective\">\n<float name=\"near_clip\" value=\"10\"/><float name=\"far_clip\" value=\"1\"/></sensor>",
            3,
            &["near_clip < far_clip", "near_clip = 10"],
        ),
        (
            "<sensor type=\"perspective\"><transform name=\"to_world\">\n<scale value=\"2\"/></transform></sensor>",
            2,
            &["must not scale"],
        ),
    ]);
}

#[test]
fn structure_mitsuba_refuses() {
    assert_cases(&[
        ("\n<include/>", 3, &["<include> needs a \"filename\" attribute"]),
        ("<default name=\"spp\"/>", 2, &["<default> needs a \"value\" attribute"]),
        ("\n<default name=\"\" value=\"1\"/>", 3, &["<default> with an empty name"]),
        (
            "<default name=\"spp\" value=\"1\" type=\"int\"/>",
            2,
            &["unexpected attribute \"type\" in <default>"],
        ),
        (
            "<sensor type=\"perspective\"><film type=\"hdrfilm\"/>\n<film type=\"hdrfilm\"/></sensor>",
            3,
            &["more than one <film>"],
        ),
        (
            "<shape type=\"cube\"><bsdf type=\"diffuse\"/>\n<bsdf type=\"diffuse\"/></shape>",
            3,
            &["more than one <bsdf>"],
        ),
        (
            "<bsdf type=\"diffuse\" id=\"w\"/>\n<ref id=\"w\"/>",
            3,
            &["<ref> at the top level"],
        ),
        (
            "<sampler type=\"independent\">\n<rfilter type=\"box\"/></sampler>",
            3,
            &["cannot contain a <rfilter>"],
        ),
        ("\n<rfilter type=\"box\"/>", 3, &["must be nested in a <film>"]),
        (
            "<shape type=\"cube\">\n<spectrum name=\"x\" value=\"400:1\" filename=\"s.spd\"/></shape>",
            3,
            &["either \"value\" or \"filename\""],
        ),
        (
            "<bsdf type=\"diffuse\">\n<spectrum name=\"reflectance\" filename=\"missing.spd\"/></bsdf>",
            3,
            &["cannot read spectrum file", "missing.spd"],
        ),
    ]);
    assert_error(
        "<scene version=\"x.y\">\n</scene>",
        1,
        &["malformed scene version \"x.y\""],
    );
}

#[test]
fn mesh_files_that_cannot_be_meshes() {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir(dir.path().join("meshes")).unwrap();
    fs::write(
        dir.path().join("far.obj"),
        "v 1e20 0 0\nv 0 1e20 0\nv 0 0 1e20\nf 1 2 3\n",
    )
    .unwrap();
    assert_error_in(
        dir.path(),
        "<scene version=\"3.0.0\">\n\n<shape type=\"obj\"><string name=\"filename\" value=\"far.obj\"/></shape></scene>",
        3,
        &["shape \"obj\"", "up to 1e12"],
    );
    assert_error_in(
        dir.path(),
        "<scene version=\"3.0.0\">\n<shape type=\"ply\">\n<string name=\"filename\" value=\"meshes\"/></shape></scene>",
        3,
        &["meshes", "not a regular file"],
    );
    if Path::new("/dev/zero").exists() {
        assert_error_in(
            dir.path(),
            "<scene version=\"3.0.0\">\n<shape type=\"obj\">\n<string name=\"filename\" value=\"/dev/zero\"/></shape></scene>",
            3,
            &["/dev/zero", "not a regular file"],
        );
    }
}

#[test]
fn values_that_would_make_pixels_infinite() {
    assert_cases(&[
        (
            "<shape type=\"cube\"><emitter type=\"area\">\n<rgb name=\"radiance\" value=\"1e300\"/></emitter></shape>",
            3,
            &["radiance", "1e300", "up to 1e20"],
        ),
        (
            "<emitter type=\"area\" id=\"e\">\n<spectrum name=\"radiance\" value=\"400:1e300, 700:1e300\"/></emitter>",
            3,
            &["radiance", "up to 1e20"],
        ),
        (
            "<bsdf type=\"ward\">\n<float name=\"alpha_u\" value=\"1e-308\"/><float name=\"alpha_v\" value=\"0.1\"/></bsdf>",
            3,
            &["alpha_u = 1e-308", "at least 1e-4"],
        ),
    ]);
}
