//! `--solver shoot` on the command line: progressive images, one per step,
//! and clear errors where shooting does not apply.

mod support;

use support::{small_scene as scene, stderr, wavrad, write};

#[test]
fn progressive_shooting_writes_one_image_per_step() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.xml", &scene(""));
    let steps = dir.path().join("steps");
    let stats = dir.path().join("stats.json");
    let out = dir.path().join("out.exr");
    let o = wavrad(&[
        "render",
        &scene,
        "-o",
        out.to_str().unwrap(),
        "--spp",
        "4",
        "--solver",
        "shoot",
        "--oracle",
        "power",
        "--progressive",
        steps.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(json["solver"], "shoot");
    let n = json["shooting_steps"].as_u64().unwrap();
    assert!(n >= 2, "{n} steps");
    let mut names: Vec<String> = std::fs::read_dir(&steps)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let expected: Vec<String> = (1..=n).map(|i| format!("step-{i:04}.exr")).collect();
    assert_eq!(names, expected);
    let (w, h, rgb) = wavrad_io::read_exr_rgb(&steps.join("step-0001.exr")).unwrap();
    assert_eq!((w, h), (8, 6));
    assert!(rgb.iter().any(|&v| v > 0.5));
    assert!(out.exists());
}

#[test]
fn progressive_needs_the_shooting_solver() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.xml", &scene(""));
    let o = wavrad(&[
        "solve",
        &scene,
        "--progressive",
        dir.path().to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--solver shoot"), "{}", stderr(&o));
    let o = wavrad(&["solve", &scene, "--solver", "splat"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("gather, shoot"), "{}", stderr(&o));
}

#[test]
fn shooting_a_glossy_scene_is_a_clean_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(
        dir.path(),
        "glossy.xml",
        &scene(r#"<bsdf type="roughplastic"/>"#),
    );
    let out = dir.path().join("out.exr");
    let o = wavrad(&[
        "render",
        &scene,
        "-o",
        out.to_str().unwrap(),
        "--solver",
        "shoot",
    ]);
    assert_eq!(o.status.code(), Some(1));
    let msg = stderr(&o);
    assert!(
        msg.contains("glossy.xml") && msg.contains("diffuse scenes"),
        "{msg}"
    );
    assert!(!msg.contains("panicked"));
    assert!(!out.exists());
}
