//! Solution files from the command line: `wavrad solve SCENE -o NAME.wavrad`
//! writes the solution, and `wavrad render NAME.wavrad -o IMAGE` renders it
//! without solving again, the image the scene renders to directly. Damaged,
//! foreign and stale files are refused: exit status 1, the file named, no
//! image left.

mod support;

use std::path::{Path, PathBuf};
use support::{small_scene, stderr, wavrad, write};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `wavrad ARGS`, which must succeed.
fn succeed(args: &[&str]) {
    let o = wavrad(args);
    assert!(o.status.success(), "wavrad {args:?}: {}", stderr(&o));
}

/// Render `scene` directly and through a solution file, solving with
/// `solve` and rendering with `render`: the same image, byte for byte.
fn renders_alike(scene: &Path, solve: &[&str], render: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene.to_str().unwrap();
    let (direct, solution, read) = (
        dir.path().join("direct.exr"),
        dir.path().join("scene.wavrad"),
        dir.path().join("read.exr"),
    );
    let path = |p: &Path| p.to_str().unwrap().to_string();
    let (direct, solution, read) = (path(&direct), path(&solution), path(&read));
    succeed(&[&["render", scene, "-o", &direct], solve, render].concat());
    succeed(&[&["solve", scene, "-o", &solution], solve].concat());
    succeed(&[&["render", &solution, "-o", &read], render].concat());
    assert!(
        std::fs::read(&direct).unwrap() == std::fs::read(&read).unwrap(),
        "{scene}: the image from the solution file differs"
    );
}

#[test]
fn diffuse_solution_file_renders_as_its_solve() {
    renders_alike(
        &repo().join("scenes/cornell-box/scene.xml"),
        &["-D", "res=16", "--max-level", "2"],
        &["--spp", "4"],
    );
}

#[test]
fn glossy_solution_file_renders_as_its_solve() {
    renders_alike(
        &repo().join("scenes/glossy-cornell-box/scene.xml"),
        &[
            "-D",
            "res=16",
            "--max-level",
            "2",
            "--three-point-max-level",
            "1",
        ],
        &["--spp", "4"],
    );
}

/// The small scene in `dir` solved into `dir`/small.wavrad; its bytes.
fn small_solution(dir: &Path) -> (String, String, Vec<u8>) {
    let scene = write(dir, "small.xml", &small_scene(""));
    let solution = dir.join("small.wavrad").display().to_string();
    succeed(&["solve", &scene, "-o", &solution, "--max-level", "2"]);
    let bytes = std::fs::read(&solution).unwrap();
    (scene, solution, bytes)
}

/// Rendering `solution` fails with a message naming it and saying `problem`,
/// and leaves no image.
fn refused(solution: &str, problem: &str) {
    let out = Path::new(solution).with_extension("exr");
    let o = wavrad(&["render", solution, "-o", out.to_str().unwrap()]);
    let message = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{message}");
    assert!(
        message.contains(solution) && message.contains(problem),
        "expected {problem:?}: {message}"
    );
    assert!(!message.contains("panicked"), "{message}");
    assert!(!out.exists());
}

#[test]
fn damaged_and_stale_solution_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, _, bytes) = small_solution(dir.path());
    let damaged = |name: &str, bytes: &[u8]| write_bytes(dir.path(), name, bytes);

    refused(
        &damaged("truncated.wavrad", &bytes[..bytes.len() / 2]),
        "truncated",
    );
    let mut flipped = bytes.clone();
    *flipped.last_mut().unwrap() ^= 1;
    refused(
        &damaged("flipped.wavrad", &flipped),
        "damaged: the checksum",
    );
    let mut newer = bytes.clone();
    newer[8] += 1;
    refused(&damaged("newer.wavrad", &newer), "format version 2");
    refused(
        &damaged("scene.wavrad", small_scene("").as_bytes()),
        "not a wavrad solution file",
    );

    // The scene edited after the solve: its floor is now darker.
    let floor = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.2"/></bsdf>"#;
    std::fs::write(&scene, small_scene(floor)).unwrap();
    refused(
        &dir.path().join("small.wavrad").display().to_string(),
        "the scene changed since the solve",
    );
}

fn write_bytes(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path.display().to_string()
}

#[test]
fn solution_files_take_no_solve_options_and_are_named_so() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, solution, _) = small_solution(dir.path());
    let out = dir.path().join("out.exr");
    let out = out.to_str().unwrap();
    for options in [
        &["--max-level", "3"][..],
        &["-D", "x=1"],
        &["--solver", "shoot"],
    ] {
        let o = wavrad(&[&["render", &solution, "-o", out], options].concat());
        assert_eq!(o.status.code(), Some(1));
        assert!(
            stderr(&o).contains(&solution) && stderr(&o).contains(options[0]),
            "{}",
            stderr(&o)
        );
        assert!(!Path::new(out).exists());
    }
    let o = wavrad(&["solve", &solution]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("is rendered"), "{}", stderr(&o));
    // A solution is written only to a .wavrad file, checked before solving.
    let o = wavrad(&["solve", &scene, "-o", out]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains(".wavrad") && !stderr(&o).contains("iterations"));
    assert!(!Path::new(out).exists());
    // The scene gone, the solution still renders, with a warning.
    std::fs::remove_file(&scene).unwrap();
    let o = wavrad(&["render", &solution, "-o", out]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("unchecked"), "{}", stderr(&o));
    assert!(Path::new(out).exists());
}
