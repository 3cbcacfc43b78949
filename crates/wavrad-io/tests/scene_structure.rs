//! Scene structure as people write it: `<path>` search directories, area
//! emitters declared at the top level and referenced by id, spectral values,
//! the integrator's settings, and Mitsuba 0.5 scenes upgraded. The fixtures
//! in `tests/fixtures/structure/` are one small room written both ways.

use std::fs;
use std::path::{Path, PathBuf};

use wavrad_core::scene::{PixelFilter, Projection, Rgb, Scene};
use wavrad_io::{load_scene, load_scene_str, Loaded};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/structure")
        .join(name)
}

fn load(name: &str) -> Loaded {
    load_scene(&fixture(name)).unwrap_or_else(|e| panic!("{e}"))
}

#[track_caller]
fn assert_close(a: Rgb, b: [f64; 3]) {
    for (x, y) in a.0.iter().zip(b) {
        assert!((x - y).abs() <= 2e-5 * y.abs().max(1e-2), "{a} vs {b:?}");
    }
}

/// Mitsuba 3.9.1 `scalar_rgb` loads `modern.xml` with these colours
/// (`mi.traverse`): the spectra converted as its RGB variants do.
#[test]
fn modern_scene_matches_mitsubas_colours() {
    let loaded = load("modern.xml");
    assert_eq!(loaded.warnings, []);
    let s = loaded.scene;
    // The mesh (two triangles, found through <path>), the floor, the light.
    assert_eq!(s.surfaces.len(), 4);
    let red = s.surfaces[0].brdf.lambertian().unwrap();
    assert_close(red, [0.729185, 0.274161, 0.00653984]);
    let light = &s.surfaces[3];
    assert_close(light.emission, [20.7108, 10.8546, 2.77115]);
    // The light's reflectance, from a spectrum file found through <path>.
    assert_close(
        light.brdf.lambertian().unwrap(),
        [0.69929, 0.699212, 0.699161],
    );
    assert_eq!(s.film.filter, PixelFilter::Tent { radius: 1.0 });
    assert_eq!(s.hints.samples_per_pixel, Some(16));
}

#[test]
fn mitsuba_0_5_scene_is_upgraded_to_the_same_scene() {
    let legacy = load("legacy-0.5.xml");
    assert_eq!(legacy.warnings, []);
    let modern = load("modern.xml").scene;
    let names = |s: &Scene| {
        s.surfaces
            .iter()
            .map(|x| x.name.clone())
            .collect::<Vec<_>>()
    };
    // Unnamed shapes are named by their index, the same in both files; the
    // modern file's light is named "shape#2" too.
    assert_eq!(names(&legacy.scene), names(&modern));
    assert_eq!(legacy.scene, modern);
}

#[test]
fn top_level_emitter_lights_the_shape_that_references_it() {
    let xml = r#"<scene version="3.0.0">
        <emitter type="area" id="sun"><rgb name="radiance" value="1 2 3"/></emitter>
        <emitter type="area" id="spare"/>
        <shape type="rectangle" id="a"><ref id="sun"/></shape>
        <shape type="rectangle" id="b"/>
    </scene>"#;
    let loaded = load_scene_str(xml, Path::new("."), "e.xml", &[]).unwrap();
    let s = &loaded.scene;
    assert_eq!(s.surfaces[0].emission, Rgb([1.0, 2.0, 3.0]));
    assert_eq!(s.surfaces[1].emission, Rgb::ZERO);
    // The emitter no shape references lights nothing, and says so.
    let [w] = &loaded.warnings[..] else {
        panic!("{:?}", loaded.warnings)
    };
    assert_eq!(w.line, 3);
    assert!(w.message.contains("attached to no shape"), "{w}");
}

#[test]
fn paths_are_searched_latest_first_for_meshes_and_includes() {
    let dir = tempfile::tempdir().unwrap();
    for sub in ["old", "new", "parts"] {
        fs::create_dir(dir.path().join(sub)).unwrap();
    }
    // The same name in two directories: the later <path> wins.
    fs::write(
        dir.path().join("old/m.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    fs::write(
        dir.path().join("new/m.obj"),
        "v 0 0 0\nv 2 0 0\nv 0 2 0\nf 1 2 3\n",
    )
    .unwrap();
    fs::write(
        dir.path().join("parts/lamp.xml"),
        r#"<scene version="3.0.0"><shape type="cube"/></scene>"#,
    )
    .unwrap();
    fs::write(
        dir.path().join("scene.xml"),
        r#"<scene version="3.0.0">
            <path value="old"/>
            <path value="new"/>
            <path value="parts"/>
            <include filename="lamp.xml"/>
            <shape type="obj"><string name="filename" value="m.obj"/></shape>
        </scene>"#,
    )
    .unwrap();
    let s = load_scene(&dir.path().join("scene.xml"))
        .unwrap_or_else(|e| panic!("{e}"))
        .scene;
    assert_eq!(s.surfaces.len(), 7);
    assert!((s.surfaces[6].patch.area() - 2.0).abs() < 1e-12);
}

/// The longest path an integrator asks for is the scene's `max_depth`
/// (`None`: no limit), without a warning; what wavrad does not honour warns
/// once.
#[test]
fn the_longest_path_is_read_and_unhonoured_integrator_settings_warn_once_each() {
    let load = |integrator: &str| {
        let xml =
            format!("<scene version=\"3.0.0\">\n{integrator}\n<shape type=\"cube\"/></scene>");
        load_scene_str(&xml, Path::new("."), "i.xml", &[]).unwrap_or_else(|e| panic!("{e}"))
    };
    for (quiet, max_depth) in [
        (r#"<integrator type="path"/>"#, None),
        (
            r#"<integrator type="ptracer"><integer name="samples_per_pass" value="4"/><float name="timeout" value="60"/></integrator>"#,
            None,
        ),
        (
            r#"<integrator type="aov"><string name="aovs" value="dd.y:depth"/><integrator type="path" name="image"/></integrator>"#,
            None,
        ),
        (
            r#"<integrator type="path"><integer name="max_depth" value="-1"/></integrator>"#,
            None,
        ),
        (
            r#"<integrator type="volpath"><integer name="max_depth" value="65"/><integer name="rr_depth" value="5"/></integrator>"#,
            None,
        ),
        (
            r#"<integrator type="path"><boolean name="hide_emitters" value="false"/></integrator>"#,
            None,
        ),
        (
            r#"<integrator type="path"><integer name="max_depth" value="2"/></integrator>"#,
            Some(2),
        ),
        (
            r#"<integrator type="prb"><integer name="max_depth" value="8"/></integrator>"#,
            Some(8),
        ),
        (r#"<integrator type="direct"/>"#, Some(2)),
        // Nested integrators are read as integrators.
        (
            r#"<integrator type="aov"><integrator type="direct" name="image"/></integrator>"#,
            Some(2),
        ),
    ] {
        let loaded = load(quiet);
        assert_eq!(loaded.warnings, [], "{quiet}");
        assert_eq!(loaded.scene.hints.max_depth, max_depth, "{quiet}");
    }
    for (loud, needle) in [
        (
            r#"<integrator type="path"><integer name="max_depth" value="1"/></integrator>"#,
            "only the emitters",
        ),
        (
            r#"<integrator type="path"><integer name="max_depth" value="0"/></integrator>"#,
            "renders black",
        ),
        (
            r#"<integrator type="path"><boolean name="hide_emitters" value="true"/></integrator>"#,
            "hide_emitters",
        ),
        // A plugin Mitsuba 3 does not ship: its parameters go unchecked.
        (
            r#"<integrator type="mypath"><float name="anything" value="1"/></integrator>"#,
            "not one of Mitsuba 3's",
        ),
    ] {
        let loaded = load(loud);
        let w = loaded.warnings;
        assert_eq!(w.len(), 1, "{loud}: {w:?}");
        assert_eq!(w[0].line, 2);
        assert!(w[0].message.contains(needle), "{}", w[0]);
        assert_eq!(loaded.scene.hints.max_depth, None, "{loud}");
    }
    // No integrator: every bounce, but Mitsuba 0.x's default, direct, for
    // a 0.x scene.
    assert_eq!(load("").scene.hints.max_depth, None);
    let legacy = load_scene_str(
        "<scene version=\"0.5.0\">\n<shape type=\"cube\"/></scene>",
        Path::new("."),
        "l.xml",
        &[],
    )
    .unwrap();
    assert_eq!(legacy.scene.hints.max_depth, Some(2));
    assert_eq!(legacy.warnings.len(), 1, "{:?}", legacy.warnings);
    assert!(legacy.warnings[0]
        .message
        .contains("Mitsuba 0.x renders a scene without one"));
    let xml = "<scene version=\"3.0.0\">\n<integrator type=\"path\">\n<integer name=\"max_depth\" value=\"-2\"/></integrator></scene>";
    let msg = load_scene_str(xml, Path::new("."), "i.xml", &[])
        .unwrap_err()
        .to_string();
    assert!(msg.starts_with("i.xml:3:") && msg.contains("-2"), "{msg}");
}

#[test]
fn every_sensor_is_kept_the_first_as_the_camera() {
    let xml = "<scene version=\"3.0.0\">\n<shape type=\"cube\"/>\n\
        <sampler type=\"independent\"><integer name=\"sample_count\" value=\"300\"/></sampler>\n\
        <sensor type=\"orthographic\"/>\n\
        <sensor type=\"perspective\"><float name=\"fov\" value=\"30\"/>\n\
        <sampler type=\"independent\"><integer name=\"sample_count\" value=\"512\"/></sampler>\n\
        <film type=\"hdrfilm\"><integer name=\"width\" value=\"5\"/></film></sensor>\n</scene>";
    let loaded = load_scene_str(xml, Path::new("."), "s.xml", &[]).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let scene = &loaded.scene;
    assert_eq!(scene.sensor_count(), 2);
    let first = scene.sensor(0).unwrap();
    assert_eq!(first.camera, scene.camera.unwrap());
    assert_eq!(first.camera.projection, Projection::Orthographic);
    assert_eq!(first.hints.samples_per_pixel, Some(300));
    let second = scene.sensor(1).unwrap();
    assert!(matches!(
        second.camera.projection,
        Projection::Perspective { .. }
    ));
    assert_eq!(
        (second.film.width, second.hints.samples_per_pixel),
        (5, Some(512))
    );
    let past = scene.sensor(2).unwrap_err().to_string();
    assert!(past.contains("sensor 2: the scene has 2 sensors"), "{past}");
}

#[test]
fn a_repeated_default_warns_once_and_the_first_wins() {
    let dir = tempfile::tempdir().unwrap();
    // The same declaration read twice (a file included twice) is no news.
    fs::write(
        dir.path().join("defaults.xml"),
        "<scene version=\"3.0.0\">\n<default name=\"r\" value=\"0.5\"/>\n</scene>",
    )
    .unwrap();
    let xml = "<scene version=\"3.0.0\">\n<include filename=\"defaults.xml\"/>\n\
        <include filename=\"defaults.xml\"/>\n<default name=\"r\" value=\"0.5\"/>\n\
        <default name=\"r\" value=\"0.9\"/>\n\
        <shape type=\"cube\"><bsdf type=\"diffuse\"><float name=\"reflectance\" value=\"$r\"/></bsdf></shape>\n</scene>";
    let loaded = load_scene_str(xml, dir.path(), "d.xml", &[]).unwrap();
    assert_eq!(
        loaded.scene.surfaces[0].brdf.lambertian(),
        Some(Rgb::splat(0.5))
    );
    let [warning] = &loaded.warnings[..] else {
        panic!("{:?}", loaded.warnings)
    };
    assert_eq!((warning.file.as_str(), warning.line), ("d.xml", 5));
    assert!(
        warning.message.contains("\"0.9\" is ignored")
            && warning.message.contains("defaults.xml:2")
            && warning.message.contains("stays \"0.5\""),
        "{warning}"
    );
    // An override wins over both, and the repeated one still warns.
    let overrides = [("r".to_string(), "0.1".to_string())];
    let loaded = load_scene_str(xml, dir.path(), "d.xml", &overrides).unwrap();
    assert_eq!(
        loaded.scene.surfaces[0].brdf.lambertian(),
        Some(Rgb::splat(0.1))
    );
    assert_eq!(loaded.warnings.len(), 1, "{:?}", loaded.warnings);
    assert!(loaded.warnings[0].message.contains("stays \"0.1\""));
}

/// A shape group of a rectangle and a rough-conductor cube, instanced
/// twice, loads to the shapes it stands for, written out one by one with
/// the instances' transforms applied after their own (Mitsuba's order).
#[test]
fn instances_of_a_shape_group_are_its_shapes_placed_by_each_instance() {
    let scene = |body: &str| {
        let xml = format!("<scene version=\"3.0.0\">\n{body}\n</scene>");
        let loaded = load_scene_str(&xml, Path::new("."), "i.xml", &[]);
        loaded.unwrap_or_else(|e| panic!("{e}")).scene
    };
    let rectangle = "<shape type=\"rectangle\"><transform name=\"to_world\">\
        <scale value=\"0.5\"/>{more}</transform></shape>";
    let cube = "<shape type=\"cube\"><transform name=\"to_world\"><translate z=\"2\"/>{more}\
        </transform><bsdf type=\"roughconductor\"/></shape>";
    let place = [
        "<rotate y=\"1\" angle=\"30\"/><translate x=\"3\"/>",
        "<scale value=\"2\"/>",
    ];
    let grouped = scene(&format!(
        "<shape type=\"shapegroup\" id=\"pair\">{}{}</shape>\n\
         <shape type=\"instance\"><ref id=\"pair\"/><transform name=\"to_world\">{}</transform></shape>\n\
         <shape type=\"instance\"><ref id=\"pair\"/><transform name=\"to_world\">{}</transform></shape>",
        rectangle.replace("{more}", ""),
        cube.replace("{more}", ""),
        place[0],
        place[1]
    ));
    let flat = scene(
        &place
            .iter()
            .flat_map(|p| [rectangle.replace("{more}", p), cube.replace("{more}", p)])
            .collect::<String>(),
    );
    assert_eq!(grouped.surfaces.len(), 2 * (1 + 6));
    assert_eq!(grouped.surfaces.len(), flat.surfaces.len());
    for (g, f) in grouped.surfaces.iter().zip(&flat.surfaces) {
        assert_eq!(g.brdf, f.brdf);
        for (a, b) in g.patch.vertices().iter().zip(f.patch.vertices()) {
            assert!((*a - b).length() < 1e-12, "{a} vs {b}");
        }
    }
}

#[test]
fn what_mitsuba_does_not_instance_is_refused_at_its_line() {
    let error = |body: &str| {
        let xml = format!("<scene version=\"3.0.0\">\n{body}\n</scene>");
        match load_scene_str(&xml, Path::new("."), "i.xml", &[]) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("loaded: {body}"),
        }
    };
    let group = |shapes: &str| format!("<shape type=\"shapegroup\" id=\"g\">\n{shapes}\n</shape>");
    let instance = "<shape type=\"instance\"><ref id=\"g\"/></shape>";
    let emitting = group(
        "<shape type=\"rectangle\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>",
    );
    let message = error(&format!("{emitting}\n{instance}"));
    assert!(message.starts_with("i.xml:3:"), "{message}");
    assert!(
        message.contains("instanced shapes cannot emit"),
        "{message}"
    );
    let nested =
        group("<shape type=\"rectangle\"/>\n<shape type=\"instance\"><ref id=\"g\"/></shape>");
    let message = error(&format!("{nested}\n{instance}"));
    assert!(message.starts_with("i.xml:4:"), "{message}");
    assert!(message.contains("nested instancing"), "{message}");
    let message = error("<shape type=\"instance\"/>");
    assert!(message.starts_with("i.xml:2:"), "{message}");
    assert!(message.contains("needs one shape group"), "{message}");
    let message = error(
        "<bsdf type=\"diffuse\" id=\"g\"/>\n<shape type=\"instance\"><ref id=\"g\"/></shape>",
    );
    assert!(message.starts_with("i.xml:3:"), "{message}");
    assert!(message.contains("cannot contain a <bsdf>"), "{message}");
}
