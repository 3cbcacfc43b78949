//! The Cornell box lit by lights that are not surfaces (`scenes/lights/`:
//! a point light, a spot light, sunlight through the open ceiling, an even
//! sky over it, an environment map with a sun) against Mitsuba 3's path tracer (`reference-*.exr`, made by
//! `scenes/make_references.py --scene lights-NAME`, 64², 16384 spp).
//!
//! relRMSE = sqrt(mean((a − b)²)) / mean(b) over all pixels and channels.

use std::path::PathBuf;

// Tolerances about a third above what was measured (the references' own
// noise: point 0.54 %, spot 0.97 %, directional 0.45 %, sky 0.21 %, envmap
// 0.42 %; the rest is mostly the final gather's noise at the default
// samples).
const TOLERANCE_POINT: f64 = 0.016;
const TOLERANCE_SPOT: f64 = 0.040;
const TOLERANCE_DIRECTIONAL: f64 = 0.025;
const TOLERANCE_SKY: f64 = 0.015;
const TOLERANCE_ENVMAP: f64 = 0.045;
use wavrad_core::progress::Silent;
use wavrad_core::render::{RenderSettings, Renderer};
use wavrad_core::solve::{solve, SolveSettings};

/// relRMSE of the default solve and render of `scenes/lights/NAME.xml`
/// against its Mitsuba reference.
fn error_against_mitsuba(name: &str) -> f64 {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/lights");
    let scene = wavrad_io::load_scene(&dir.join(format!("{name}.xml")))
        .unwrap()
        .scene;
    let (w, h, reference) =
        wavrad_io::read_exr_rgb(&dir.join(format!("reference-{name}.exr"))).unwrap();
    assert_eq!((w, h), (scene.film.width, scene.film.height));
    let solution = solve(&scene, &SolveSettings::default(), &Silent).unwrap();
    assert!(solution.stats.converged, "{name}");
    let image = Renderer::new(solution)
        .render(&RenderSettings::for_scene(&scene))
        .unwrap();
    let error = wavrad_io::relative_rmse(&image.rgb, &reference);
    eprintln!("{name}: relRMSE {error:.4}");
    error
}

#[test]
fn point_light_matches_mitsuba() {
    let error = error_against_mitsuba("point");
    assert!(error < TOLERANCE_POINT, "{error}");
}

#[test]
fn spot_light_matches_mitsuba() {
    let error = error_against_mitsuba("spot");
    assert!(error < TOLERANCE_SPOT, "{error}");
}

#[test]
fn directional_light_matches_mitsuba() {
    let error = error_against_mitsuba("directional");
    assert!(error < TOLERANCE_DIRECTIONAL, "{error}");
}

#[test]
fn envmap_matches_mitsuba() {
    let error = error_against_mitsuba("envmap");
    assert!(error < TOLERANCE_ENVMAP, "{error}");
}

#[test]
fn sky_matches_mitsuba() {
    let error = error_against_mitsuba("sky");
    assert!(error < TOLERANCE_SKY, "{error}");
}
