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
    let version = wavrad_io::solution_file::FORMAT_VERSION;
    let newer_version = format!("format version {}", version + 1);
    refused(&damaged("newer.wavrad", &newer), &newer_version);
    let mut older = bytes.clone();
    older[8] -= 1;
    refused(
        &damaged("older.wavrad", &older),
        &format!("format version {}, written by wavrad", version - 1),
    );
    refused(&damaged("older.wavrad", &older), "solve the scene again");
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

/// The statistics JSON at `path`.
fn stats(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

#[test]
fn a_solve_cut_short_resumes_to_the_uninterrupted_solution() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/cornell-box/scene.xml");
    let scene = scene.to_str().unwrap();
    let at = |name: &str| dir.path().join(name).display().to_string();
    let solve_at = |res: &str, extra: &[&str]| {
        wavrad(&[&["solve", scene, "-D", res, "--max-level", "4"], extra].concat())
    };
    let solve = |extra: &[&str]| solve_at("res=16", extra);

    // Solved in one go; then cut short by a time limit of a third of the
    // time its kernels took: a solution, and how to finish it.
    let o = solve(&["-o", &at("whole.wavrad"), "--stats", &at("whole.json")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let whole = stats(Path::new(&at("whole.json")));
    let limit = (whole["times"]["kernels_s"].as_f64().unwrap() / 3.0).to_string();
    let cut = ["-o", &at("cut.wavrad"), "--stats", &at("cut.json")];
    let o = solve(&[&["--time-limit", &limit][..], &cut].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("--resume"), "{}", stderr(&o));
    assert_eq!(stats(Path::new(&at("cut.json")))["stopped"], "time_limit");
    // Rendering it says it can be resumed.
    let o = wavrad(&[
        "render",
        &at("cut.wavrad"),
        "-o",
        &at("cut.exr"),
        "--spp",
        "1",
    ]);
    assert!(stderr(&o).contains("--resume"), "{}", stderr(&o));

    // Resumed: only the items the first run left are projected again, and
    // the solution is the uninterrupted one.
    let resumed = ["--resume", &at("cut.wavrad"), "-o", &at("resumed.wavrad")];
    let o = solve(&[&resumed[..], &["--stats", &at("resumed.json")]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let resumed = stats(Path::new(&at("resumed.json")));
    assert_eq!(resumed["stopped"], serde_json::Value::Null);
    let items = whole["projected_items"].as_u64().unwrap();
    let kept = resumed["resumed_items"].as_u64().unwrap();
    assert!(kept > 0 && kept < items, "{kept} of {items} kept");
    assert_eq!(resumed["projected_items"].as_u64().unwrap() + kept, items);
    for key in [
        "two_point_nodes",
        "two_point_interactions",
        "iterations",
        "residual",
    ] {
        assert_eq!(resumed[key], whole[key], "{key}");
    }
    // The same image, byte for byte.
    for name in ["resumed", "whole"] {
        let (solution, image) = (at(&format!("{name}.wavrad")), at(&format!("{name}.exr")));
        succeed(&["render", &solution, "-o", &image, "--spp", "4"]);
    }
    assert!(std::fs::read(at("resumed.exr")).unwrap() == std::fs::read(at("whole.exr")).unwrap());

    // Nothing to resume in a finished solve; a refinement setting may not
    // change; the scene must be the one solved.
    let refused_at = |res: &str, extra: &[&str], problem: &str| {
        let o = solve_at(res, &[extra, &["-o", &at("again.wavrad")]].concat());
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(
            stderr(&o).contains(problem),
            "expected {problem:?}: {}",
            stderr(&o)
        );
        assert!(!Path::new(&at("again.wavrad")).exists());
    };
    let refused = |extra: &[&str], problem: &str| refused_at("res=16", extra, problem);
    refused(
        &["--resume", &at("whole.wavrad")],
        "nothing is left to resume",
    );
    refused(
        &["--resume", &at("cut.wavrad"), "--threshold", "1e-4"],
        "threshold is 1e-4",
    );
    refused_at(
        "res=8",
        &["--resume", &at("cut.wavrad")],
        "the scene changed since the solve: it now has another film",
    );
    refused(
        &["--resume", &at("cut.wavrad"), "--solver", "shoot"],
        "--solver shoot",
    );
}

#[test]
fn a_solve_killed_outright_resumes_from_its_last_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/cornell-box/scene.xml");
    let scene = scene.to_str().unwrap();
    let at = |name: &str| dir.path().join(name).display().to_string();
    let solve = ["solve", scene, "-D", "res=16", "--max-level", "5"];
    let checkpoint = dir.path().join("killed.checkpoint.wavrad");

    // Saving checkpoints every 50 ms, killed (SIGKILL) once one is saved.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_wavrad"))
        .args(solve)
        .args(["-o", &at("killed.wavrad"), "--checkpoint-every", "0.05"])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    while !checkpoint.exists() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the solve ended ({status}) before it saved a checkpoint");
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!Path::new(&at("killed.wavrad")).exists());
    std::fs::copy(&checkpoint, at("saved.checkpoint.wavrad")).unwrap();

    // Solving again from the start says what it replaces.
    let o = wavrad(
        &[
            &solve[..],
            &["-o", &at("killed.wavrad"), "--threshold", "0.5"],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("starts over and replaces it"),
        "{}",
        stderr(&o)
    );
    assert!(!checkpoint.exists());
    std::fs::copy(at("saved.checkpoint.wavrad"), &checkpoint).unwrap();

    // Resumed from the checkpoint: the uninterrupted solution, and the
    // checkpoint is gone once the solution is written.
    let resume = ["--resume", &at("killed.checkpoint.wavrad")];
    let out = ["-o", &at("killed.wavrad"), "--stats", &at("resumed.json")];
    let o = wavrad(&[&solve[..], &resume, &out].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!checkpoint.exists());
    let out = ["-o", &at("whole.wavrad"), "--stats", &at("whole.json")];
    succeed(&[&solve[..], &out, &["--checkpoint-every", "0"]].concat());
    let (resumed, whole) = (
        stats(Path::new(&at("resumed.json"))),
        stats(Path::new(&at("whole.json"))),
    );
    let kept = resumed["resumed_items"].as_u64().unwrap();
    assert!(kept > 0, "{resumed}");
    for key in ["two_point_interactions", "iterations", "residual"] {
        assert_eq!(resumed[key], whole[key], "{key}");
    }
    for name in ["killed", "whole"] {
        let (solution, image) = (at(&format!("{name}.wavrad")), at(&format!("{name}.exr")));
        succeed(&["render", &solution, "-o", &image, "--spp", "4"]);
    }
    assert!(std::fs::read(at("killed.exr")).unwrap() == std::fs::read(at("whole.exr")).unwrap());

    // A checkpoint is not a solution to render.
    let o = wavrad(&["render", &at("saved.checkpoint.wavrad"), "-o", &at("x.exr")]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("not a solution"), "{}", stderr(&o));
    assert!(!Path::new(&at("x.exr")).exists());
}

#[test]
fn the_sensor_to_render_is_picked_by_number() {
    let dir = tempfile::tempdir().unwrap();
    // The small scene with a second sensor, 5×4, seeing the floor from above.
    let second = r#"<sensor type="perspective">
        <transform name="to_world"><lookat origin="0,2,3" target="0,0,0" up="0,1,0"/></transform>
        <film type="hdrfilm"><integer name="width" value="5"/><integer name="height" value="4"/></film>
    </sensor>
    <shape"#;
    let xml = small_scene("").replacen("<shape", second, 1);
    let scene = write(dir.path(), "two.xml", &xml);
    let at = |name: &str| dir.path().join(name).display().to_string();
    succeed(&["solve", &scene, "--max-level", "2", "-o", &at("two.wavrad")]);
    let fast = ["--mode", "smooth", "--spp", "4"];
    for (input, sensor, size) in [
        (&scene, None, (8, 6)),
        (&scene, Some("1"), (5, 4)),
        (&at("two.wavrad"), Some("0"), (8, 6)),
        (&at("two.wavrad"), Some("1"), (5, 4)),
    ] {
        let image = at("view.exr");
        let pick = sensor.map(|n| vec!["--sensor", n]).unwrap_or_default();
        let solve = if input == &scene {
            vec!["--max-level", "2"]
        } else {
            vec![]
        };
        succeed(&[&["render", input, "-o", &image], &fast[..], &pick, &solve].concat());
        let (w, h, _) = wavrad_io::read_exr_rgb(Path::new(&image)).unwrap();
        assert_eq!((w, h), size, "{input} --sensor {sensor:?}");
    }
    // One past the last: an error naming how many there are, before the
    // solve, and no image.
    for input in [&scene, &at("two.wavrad")] {
        let o = wavrad(&["render", input, "-o", &at("none.exr"), "--sensor", "2"]);
        assert_eq!(o.status.code(), Some(1));
        let message = stderr(&o);
        assert!(
            message.contains("sensor 2: the scene has 2 sensors"),
            "{message}"
        );
        assert!(!message.contains("iterations"), "{message}");
        assert!(!Path::new(&at("none.exr")).exists());
    }
}
