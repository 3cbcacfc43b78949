//! The Cornell box lit by lights that are not surfaces (`scenes/lights/`:
//! a point light, a spot light, sunlight through the open ceiling, an even
//! sky over it, an environment map with a sun, the same with a glass
//! sphere) against Mitsuba 3's path
//! tracer (`reference-*.exr`, made by `scenes/make_references.py --scene
//! lights-NAME`, 64², 16384 spp).
//!
//! relRMSE = sqrt(mean((a − b)²)) / mean(b) over all pixels and channels.

use std::path::PathBuf;
use wavrad_core::progress::Silent;
use wavrad_core::render::{RenderSettings, Renderer};
use wavrad_core::solve::{solve, SolveSettings};

/// Each scene of `scenes/lights/` and the relRMSE it must stay below:
/// about a third above what was measured (the references' own noise:
/// point 0.54 %, spot 0.97 %, directional 0.45 %, sky 0.21 %, envmap
/// 0.42 %; the rest is mostly the final gather's noise at the default
/// samples). With a glass sphere on the floor under the environment map
/// (`envmap-glass`, reference 262 144 spp, 0.80 %) it was 15.4 %, 8.0 %
/// off the sphere, nearly all of it in the four pixels of the sun's caustic
/// (up to 30 times the image's mean; wavrad's up to 20 % brighter there);
/// before the sky shot photons through glass, the caustic was missing:
/// 61.6 %.
const SCENES: [(&str, f64); 6] = [
    ("point", 0.016),
    ("spot", 0.040),
    ("directional", 0.025),
    ("sky", 0.015),
    ("envmap", 0.045),
    ("envmap-glass", 0.2),
];

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
fn lights_match_mitsuba() {
    let failed: Vec<String> = SCENES
        .iter()
        .filter_map(|&(name, tolerance)| {
            let error = error_against_mitsuba(name);
            (error >= tolerance).then(|| format!("{name}: {error:.4} >= {tolerance}"))
        })
        .collect();
    assert!(failed.is_empty(), "{failed:?}");
}
