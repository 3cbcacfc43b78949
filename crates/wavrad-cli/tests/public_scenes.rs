//! The public Mitsuba scenes of `scenes/public/`, unmodified, against their
//! table `scenes/public/scenes.json`.
//!
//! Each scene either passes (it renders, and its relRMSE against the Mitsuba 3
//! reference made by `scenes/public/make_references.py`, leaving out the pixels
//! that see an emitter directly, is within its tolerance), loads without a
//! reference (`"expect": "loads"`: Mitsuba 3 refuses the file, wavrad must
//! load and solve it), or fails the way the table records, with exactly the
//! recorded error. A scene that starts to load, or fails differently, turns
//! this test red until the table says so.
//!
//! By default only the load is checked: every scene is solved with a
//! one-second time limit, not rendered, so the test takes seconds.
//! `WAVRAD_PUBLIC_SCENES=all` also renders every passing scene with default
//! settings at the table's resolution and checks its error, and every
//! failing scene with a `tolerance_approximate` with `--approximate` and
//! checks that error against it (on 2 cores:
//! half a minute for the Cornell box, over ten minutes for veach-mis);
//! `WAVRAD_PUBLIC_SCENES=cornell-box,veach-mis` renders those only.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// What the default run asks of each scene: load it and solve it briefly.
const QUICK_SOLVE: &[&str] = &["-q", "--time-limit", "1"];

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `wavrad ARGS` run from the repository root, so that scene paths (and the
/// errors that name them) read `scenes/public/...`.
fn wavrad(args: &[String]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wavrad"))
        .current_dir(repo())
        .args(args)
        .output()
        .expect("run wavrad")
}

/// `command FILE -D k=v ...` for a scene's entry, `extra` after it.
fn arguments(command: &str, entry: &Value, extra: &[&str]) -> Vec<String> {
    let file = format!("scenes/public/{}", entry["file"].as_str().unwrap());
    let mut args = vec![command.to_string(), file];
    for (name, value) in entry["defines"].as_object().unwrap() {
        args.push("-D".into());
        args.push(format!("{name}={}", value.as_str().unwrap()));
    }
    args.extend(extra.iter().map(|s| s.to_string()));
    args
}

/// relRMSE of `image` against `reference` over the pixels where `emitters`
/// (a render of what is seen of the emitters directly) is zero:
/// `sqrt(mean((a − b)²)) / mean(b)`, both means over those pixels' channels.
fn error_without_emitters(image: &[f32], reference: &[f32], emitters: &[f32]) -> f64 {
    let kept: Vec<usize> = (0..reference.len() / 3)
        .filter(|&p| emitters[3 * p..3 * p + 3].iter().all(|&v| v <= 0.0))
        .flat_map(|p| 3 * p..3 * p + 3)
        .collect();
    let a: Vec<f32> = kept.iter().map(|&i| image[i]).collect();
    let b: Vec<f32> = kept.iter().map(|&i| reference[i]).collect();
    wavrad_io::relative_rmse(&a, &b)
}

fn read_exr(path: &Path) -> (u32, u32, Vec<f32>) {
    wavrad_io::read_exr_rgb(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Render a scene with defaults and the `options` (none for a passing
/// scene) and return its error.
fn render_error(name: &str, entry: &Value, dir: &Path, options: &[&str]) -> f64 {
    let out = dir.join(format!("{name}.exr"));
    let mut extra = vec!["-q", "-o", out.to_str().unwrap()];
    extra.extend_from_slice(options);
    let run = wavrad(&arguments("render", entry, &extra));
    assert!(
        run.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    let public = repo().join("scenes/public");
    let reference = &entry["reference"];
    let (w, h, expected) = read_exr(&public.join(reference["image"].as_str().unwrap()));
    let (_, _, emitters) = read_exr(&public.join(reference["emitters"].as_str().unwrap()));
    let (wi, hi, image) = read_exr(&out);
    assert_eq!((wi, hi), (w, h), "{name}: image size");
    error_without_emitters(&image, &expected, &emitters)
}

#[test]
fn public_scenes_behave_as_their_table_says() {
    let text = std::fs::read_to_string(repo().join("scenes/public/scenes.json")).unwrap();
    let table: Value = serde_json::from_str(&text).unwrap();
    let rendered = std::env::var("WAVRAD_PUBLIC_SCENES").unwrap_or_default();
    let render = |name: &str| rendered == "all" || rendered.split(',').any(|n| n == name);
    let dir = tempfile::tempdir().unwrap();
    let mut wrong = Vec::new();
    for (name, entry) in table["scenes"].as_object().unwrap() {
        let expect = entry["expect"].as_str().unwrap();
        if expect == "pass" && render(name) {
            let tolerance = entry["tolerance"].as_f64().unwrap();
            let error = render_error(name, entry, dir.path(), &[]);
            eprintln!("{name}: relRMSE without emitter pixels {error:.4} (tolerance {tolerance})");
            if error.is_nan() || error > tolerance {
                wrong.push(format!("{name}: relRMSE {error:.4} > {tolerance}"));
            }
            continue;
        }
        if expect == "pass" || expect == "loads" {
            let run = wavrad(&arguments("solve", entry, QUICK_SOLVE));
            if !run.status.success() {
                wrong.push(format!("{name}: {}", String::from_utf8_lossy(&run.stderr)));
            }
            continue;
        }
        assert!(
            expect.starts_with("fails-because "),
            "{name}: expect {expect:?}"
        );
        let error = entry["error"].as_str().unwrap();
        let run = wavrad(&arguments("solve", entry, QUICK_SOLVE));
        let stderr = String::from_utf8_lossy(&run.stderr);
        if run.status.success() || !stderr.lines().any(|line| line == error) {
            wrong.push(format!(
                "{name}: expected to fail with\n  {error}\nbut exited {:?} with\n  {stderr}",
                run.status.code()
            ));
        }
        if let Some(tolerance) = entry["tolerance_approximate"].as_f64() {
            if render(name) {
                let error = render_error(name, entry, dir.path(), &["--approximate"]);
                eprintln!(
                    "{name}: with --approximate, relRMSE without emitter pixels {error:.4} \
                     (tolerance {tolerance})"
                );
                if error.is_nan() || error > tolerance {
                    wrong.push(format!(
                        "{name}: with --approximate, relRMSE {error:.4} > {tolerance}"
                    ));
                }
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "scenes/public/scenes.json is out of date:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn the_error_leaves_out_pixels_that_see_an_emitter() {
    let reference = [1.0, 1.0, 1.0, 5.0, 5.0, 5.0];
    let emitters = [0.0, 0.0, 0.0, 4.0, 0.0, 0.0];
    let image = [1.1, 1.1, 1.1, 0.0, 0.0, 0.0];
    let error = error_without_emitters(&image, &reference, &emitters);
    assert!((error - 0.1).abs() < 1e-6, "{error}");
}
