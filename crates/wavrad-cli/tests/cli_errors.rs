//! The command line on bad input: a clear message naming the file (and line),
//! a non-zero exit, no panic, and no output file left behind.

mod support;

use support::{small_scene, stderr, wavrad, write};

#[test]
fn unsupported_plugin_names_file_line_and_plugin_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(
        dir.path(),
        "bad.xml",
        "<scene version=\"3.0.0\">\n  <shape type=\"bsplinecurve\"/>\n</scene>\n",
    );
    let out = dir.path().join("out.png");
    let o = wavrad(&["render", &scene, "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let msg = stderr(&o);
    assert!(
        msg.contains("bad.xml:2") && msg.contains("bsplinecurve"),
        "{msg}"
    );
    assert!(!msg.contains("panicked"));
    assert!(!out.exists());
}

#[test]
fn missing_scene_file_is_named() {
    let o = wavrad(&["solve", "/nonexistent/scene.xml"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("/nonexistent/scene.xml"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn unknown_output_format_fails_before_solving() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.xml", &small_scene(""));
    let out = dir.path().join("out.tiff");
    let o = wavrad(&["render", &scene, "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("out.tiff") && stderr(&o).contains(".exr"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

#[test]
fn invalid_settings_and_defines_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.xml", &small_scene(""));
    // A value outside a setting's documented range is a usage error (exit
    // 2) that names the setting and the range, before the scene is read.
    let o = wavrad(&["solve", &scene, "--threshold=-1"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("threshold"), "{}", stderr(&o));
    let o = wavrad(&["solve", &scene, "-D", "novalue"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("NAME=VALUE"), "{}", stderr(&o));
    let o = wavrad(&["solve", &scene, "--max-level", "99"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("max_level: must be in 0..=16"),
        "{}",
        stderr(&o)
    );
    // Settings each in range but not together are refused before solving.
    let o = wavrad(&[
        "solve",
        &scene,
        "--three-point-max-level",
        "10",
        "--three-point-receiver-levels",
        "7",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("three-point max level plus receiver levels"),
        "{}",
        stderr(&o)
    );
    // Malformed numbers are clap's usage errors (exit 2).
    let o = wavrad(&["solve", &scene, "--threshold", "abc"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn scene_without_sensor_cannot_render_but_can_solve() {
    let dir = tempfile::tempdir().unwrap();
    let small = small_scene("");
    let text = small.replace(
        &small[small.find("<sensor").unwrap()..small.find("</sensor>").unwrap() + 9],
        "",
    );
    let scene = write(dir.path(), "nosensor.xml", &text);
    let out = dir.path().join("out.exr");
    let o = wavrad(&["render", &scene, "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("no sensor"), "{}", stderr(&o));
    assert!(!out.exists());
    let stats = dir.path().join("stats.json");
    let o = wavrad(&["solve", &scene, "--stats", stats.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert!(json["two_point_interactions"].as_u64().unwrap() > 0);
    assert_eq!(json["surfaces"], 2);
}

#[test]
fn loader_warnings_reach_stderr_and_the_solve_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    // A floor quad and one triangle of zero area, which is skipped.
    write(
        dir.path(),
        "floor.obj",
        "v -1 -1 -1\nv 1 -1 -1\nv 1 -1 1\nv -1 -1 1\nv 2 -1 -1\nf 1 4 3 2\nf 1 2 5\n",
    );
    let small = small_scene("");
    let floor = &small[small.rfind("<shape").unwrap()..small.rfind("</shape>").unwrap() + 8];
    let text = small.replace(
        floor,
        "<shape type=\"obj\">\n<string name=\"filename\" value=\"floor.obj\"/></shape>",
    );
    let scene = write(dir.path(), "s.xml", &text);
    let o = wavrad(&["solve", &scene, "--max-level", "2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let line = 1 + text.lines().position(|l| l.contains("floor.obj")).unwrap();
    let expected =
        format!("wavrad: warning: {scene}:{line}: shape \"obj\": skipped 1 of the 3 triangles");
    assert!(stderr(&o).contains(&expected), "{}", stderr(&o));
}

#[test]
fn render_writes_image_and_stats() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.xml", &small_scene(""));
    let out = dir.path().join("out.exr");
    let stats = dir.path().join("stats.json");
    for mode in ["haar", "smooth", "gather"] {
        let o = wavrad(&[
            "render",
            &scene,
            "-o",
            out.to_str().unwrap(),
            "--mode",
            mode,
            "--spp",
            "4",
            "--stats",
            stats.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let (w, h, rgb) = wavrad_io::read_exr_rgb(&out).unwrap();
        assert_eq!((w, h), (8, 6));
        assert!(rgb.iter().all(|v| v.is_finite() && *v >= 0.0));
        // The emitter faces the camera: the image is not black.
        assert!(rgb.iter().any(|&v| v > 0.5));
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    for key in [
        "two_point_nodes",
        "two_point_interactions",
        "nodes_per_level",
        "iterations",
        "times",
        "peak_memory_bytes",
    ] {
        assert!(!json[key].is_null(), "{key} missing");
    }
    assert!(json["times"]["render_s"].as_f64().unwrap() > 0.0);
}

#[test]
fn outputs_that_cannot_be_written_fail_before_the_solve() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.xml", &small_scene(""));
    let out = dir.path().join("out.exr");
    let missing = dir.path().join("no-such-dir");
    let solved = |o: &std::process::Output| stderr(o).contains("two-point nodes");
    // An image into a directory that does not exist.
    let image = missing.join("out.exr");
    let o = wavrad(&["render", &scene, "-o", image.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("cannot make a file in the folder")
            && err.contains("no-such-dir\": no such folder")
            && !err.contains(".wavrad-")
            && !solved(&o),
        "{err}"
    );
    // Statistics there, from render and from solve: nothing is written.
    let stats = missing.join("stats.json");
    for command in ["render", "solve"] {
        let mut args = vec![command, &scene, "--stats", stats.to_str().unwrap()];
        if command == "render" {
            args.extend(["-o", out.to_str().unwrap()]);
        }
        let o = wavrad(&args);
        assert_eq!(o.status.code(), Some(1), "{command}");
        assert!(
            stderr(&o).contains("stats.json") && !solved(&o),
            "{}",
            stderr(&o)
        );
        assert!(!out.exists());
    }
    // Statistics that would overwrite the image.
    let o = wavrad(&[
        "render",
        &scene,
        "-o",
        out.to_str().unwrap(),
        "--stats",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("the same file") && !solved(&o),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
    // No temporary file is left behind by the checks.
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, ["s.xml"]);
}
