//! Bad scene input: every error names the file, the line and the offending
//! name, and no input makes the loader panic.

use std::fs;
use std::path::Path;

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
    let msg = error_in(dir, xml);
    assert!(
        msg.starts_with(&format!("bad.xml:{line}: ")),
        "expected line {line}: {msg}"
    );
    for needle in needles {
        assert!(msg.contains(needle), "expected {needle:?} in: {msg}");
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
    for plugin in ["conductor", "dielectric"] {
        assert_error(
            &format!(
                "<scene version=\"3.0.0\">\n<shape type=\"rectangle\">\n<bsdf type=\"{plugin}\"/>\n</shape></scene>"
            ),
            3,
            &[&format!("unsupported bsdf plugin \"{plugin}\""), "diffuse, twosided"],
        );
    }
    // Also when defined at the top level and never used.
    assert_error(
        "<scene version=\"3.0.0\">\n<bsdf type=\"plastic\" id=\"p\"/></scene>",
        2,
        &["\"plastic\""],
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
fn textures_are_unsupported() {
    assert_error(
        "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\">\n<texture type=\"bitmap\" name=\"reflectance\">\n<string name=\"filename\" value=\"wood.png\"/></texture></bsdf></scene>",
        3,
        &["<texture type=\"bitmap\">", "not supported"],
    );
    assert_error(
        "<scene version=\"3.0.0\">\n<texture type=\"checkerboard\" id=\"c\"/>\n</scene>",
        2,
        &["texture", "checkerboard"],
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
    for plugin in ["point", "constant", "envmap", "directional"] {
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
        "<texture type=\"bitmap\" name=\"diffuse_reflectance\"/>",
        "roughplastic",
        3,
        &["<texture type=\"bitmap\">", "not supported"],
    );
    bsdf_error(
        "<float name=\"exponent\" value=\"3\"/>",
        "ward",
        3,
        &["unknown parameter \"exponent\"", "bsdf \"ward\""],
    );
}
