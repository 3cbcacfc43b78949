//! Progress, limits and interrupts of the `wavrad` command: a solve cut
//! short by its time limit or by Ctrl-C is finished from what was done and
//! says so; `--quiet` prints nothing but warnings and errors.

mod support;

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use support::{small_scene, stderr, wavrad, write};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn a_time_limit_cuts_the_solve_short_with_a_warning_and_still_writes_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "scene.xml", &small_scene(""));
    let (image, stats) = (dir.path().join("out.exr"), dir.path().join("stats.json"));
    let o = wavrad(&[
        "render",
        &scene,
        "-o",
        image.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
        "--time-limit",
        "1e-9",
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("warning: the time limit cut the solve short"),
        "{err}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(json["stopped"], "time_limit");
    assert!(json["unrefined_items"].as_u64().unwrap() > 0, "{json}");
    let (w, h, rgb) = wavrad_io::read_exr_rgb(&image).unwrap();
    assert_eq!((w, h), (8, 6));
    assert!(rgb.iter().all(|v| v.is_finite()) && rgb.iter().any(|&v| v > 0.0));

    // Without a limit nothing is cut.
    let o = wavrad(&["solve", &scene, "--stats", stats.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(
        (&json["stopped"], &json["unrefined_items"]),
        (&serde_json::Value::Null, &serde_json::json!(0))
    );
}

#[test]
fn quiet_prints_nothing_and_plain_lines_say_what_runs() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "scene.xml", &small_scene(""));
    let o = wavrad(&["solve", &scene, "--quiet"]);
    assert!(o.status.success());
    assert_eq!(stderr(&o), "");
    // Not a terminal: plain lines, no bar's control characters.
    let o = wavrad(&["solve", &scene]);
    let err = stderr(&o);
    assert!(
        err.contains("wavrad: loading ") && err.contains("surfaces"),
        "{err}"
    );
    assert!(!err.contains('\r') && !err.contains('\u{1b}'), "{err:?}");
}

#[test]
fn ctrl_c_finishes_the_solve_from_what_is_done_and_exits_130() {
    let dir = tempfile::tempdir().unwrap();
    let image = dir.path().join("out.exr");
    let scene = repo().join("scenes/cornell-box/scene.xml");
    // A solve far longer than the test waits: refinement to level 8 with a
    // fine threshold (minutes on two cores).
    let mut child = Command::new(env!("CARGO_BIN_EXE_wavrad"))
        .args(["render", scene.to_str().unwrap(), "-o"])
        .arg(&image)
        .args(["--max-level", "8", "--threshold", "1e-6", "--spp", "1"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut first = String::new();
    err.read_line(&mut first).unwrap();
    assert!(first.starts_with("wavrad: loading"), "{first}");
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "{rest}");
    assert!(
        rest.contains("interrupted") && rest.contains("an interrupt cut the solve short"),
        "{rest}"
    );
    let (_, _, rgb) = wavrad_io::read_exr_rgb(&image).unwrap();
    assert!(rgb.iter().all(|v| v.is_finite()) && rgb.iter().any(|&v| v > 0.0));
}
