//! Never a wrong image in silence: surfaces that touch or coincide render as
//! Mitsuba renders them, and what cannot be solved is an error.
//!
//! The bundled Cornell box with every material `twosided` (each surface
//! then has a second, coincident one facing the other way; the small box's
//! inner base lies on the floor) renders as the one-sided box; its boxes
//! moved to rest exactly on the floor, or within 1e-8 of it, render as
//! boxes lifted 1e-4 above it. Each of these made Gauss–Seidel diverge and
//! wrote `inf` pixels with exit status 0. Small renders (48², coarse
//! elements) keep the test quick; the comparison is between two renders of
//! the same settings, so what they share cancels.

mod support;

use std::path::{Path, PathBuf};
use support::{small_scene, stderr, wavrad, write};

/// The bundled Cornell box's XML.
fn cornell_box() -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box/scene.xml");
    std::fs::read_to_string(path).unwrap()
}

/// `xml` with `from` replaced by `to`, which must occur.
fn replaced(xml: &str, from: &str, to: &str) -> String {
    assert!(xml.contains(from), "{from}");
    xml.replace(from, to)
}

/// The Cornell box with every material wrapped in `twosided`.
fn twosided(xml: &str) -> String {
    ["white", "green", "red"]
        .iter()
        .fold(xml.to_string(), |xml, id| {
            let open = format!("<bsdf type=\"diffuse\" id=\"{id}\">");
            let start = xml.find(&open).unwrap();
            let end = start + xml[start..].find("</bsdf>").unwrap() + "</bsdf>".len();
            let inner = xml[start..end].replace(&format!(" id=\"{id}\""), "");
            let wrapped = format!("<bsdf type=\"twosided\" id=\"{id}\">{inner}</bsdf>");
            format!("{}{wrapped}{}", &xml[..start], &xml[end..])
        })
}

/// The Cornell box with both boxes' bases at height `lift` above the floor
/// (y = −1; the small box's is already on it, the large one's 0.01 below).
fn boxes_at(xml: &str, lift: f64) -> String {
    let xml = replaced(
        xml,
        "<translate x=\"0.335\" y=\"-0.7\" z=\"0.38\"/>",
        &format!("<translate x=\"0.335\" y=\"{}\" z=\"0.38\"/>", -0.7 + lift),
    );
    replaced(
        &xml,
        "<translate x=\"-0.33\" y=\"-0.4\" z=\"-0.28\"/>",
        &format!(
            "<translate x=\"-0.33\" y=\"{}\" z=\"-0.28\"/>",
            -0.39 + lift
        ),
    )
}

/// Render `xml` (written to `dir/name.xml`) at 48² with elements no finer
/// than `max_level`, to `dir/name.exr`; the run must succeed.
fn render(dir: &Path, name: &str, xml: &str, max_level: u32) -> PathBuf {
    let scene = write(dir, &format!("{name}.xml"), xml);
    let out = dir.join(format!("{name}.exr"));
    let level = max_level.to_string();
    let args = ["render", &scene, "-D", "res=48", "--max-level", &level];
    let o = wavrad(&[&args[..], &["-o", out.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{name}: {}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{name}: {}", stderr(&o));
    out
}

/// relRMSE of the image at `a` against the one at `b`.
fn error(a: &Path, b: &Path) -> f64 {
    let (_, _, a) = wavrad_io::read_exr_rgb(a).unwrap();
    let (_, _, b) = wavrad_io::read_exr_rgb(b).unwrap();
    assert!(a.iter().all(|v| v.is_finite()));
    wavrad_io::relative_rmse(&a, &b)
}

#[test]
fn the_twosided_cornell_box_renders_as_the_one_sided_one() {
    let dir = tempfile::tempdir().unwrap();
    let xml = cornell_box();
    let one_sided = render(dir.path(), "one-sided", &xml, 4);
    let two_sided = render(dir.path(), "twosided", &twosided(&xml), 4);
    let e = error(&two_sided, &one_sided);
    assert!(e < 0.01, "relRMSE {e}");
}

#[test]
fn boxes_resting_on_the_floor_render_as_lifted_ones() {
    let dir = tempfile::tempdir().unwrap();
    let xml = cornell_box();
    let lifted = render(dir.path(), "lifted", &boxes_at(&xml, 1e-4), 3);
    for (name, lift) in [("on", 0.0), ("above", 1e-8), ("below", -1e-8)] {
        let resting = render(dir.path(), name, &boxes_at(&xml, lift), 3);
        let e = error(&resting, &lifted);
        assert!(e < 0.01, "{name}: relRMSE {e}");
    }
}

#[test]
fn a_scene_without_light_is_an_error_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let emitter = "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter>";
    let dark = replaced(&small_scene(""), emitter, "");
    let scene = write(dir.path(), "dark.xml", &dark);
    let out = dir.path().join("dark.exr");
    let o = wavrad(&["render", &scene, "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let message = stderr(&o);
    assert!(
        message.contains("dark.xml") && message.contains("no light"),
        "{message}"
    );
    assert!(!out.exists());
}
