//! The principled floor (`scenes/principled-floor/`: a rough `principled`
//! floor whose `base_color` is a checkerboard, a `principled` cube on it, a
//! point light, `max_depth` 3) against Mitsuba 3's path tracer
//! (`reference.exr`, made by `scenes/make_references.py`, 64², 65 536 spp,
//! its own noise 0.18 %), and the same with clearcoat and sheen.
//!
//! relRMSE = sqrt(mean((a − b)²)) / mean(b) over all pixels and channels.

use std::path::PathBuf;
use wavrad_core::progress::Silent;
use wavrad_core::render::{RenderSettings, Renderer};
use wavrad_core::solve::{solve, SolveSettings};

/// The cube's front face, where it meets the floor (rows, columns of the
/// 64² image): lit by the floor's reflection of the light, which gather
/// rays from it read on the checkerboard's squares close by.
const CUBE_FOOT: (std::ops::Range<usize>, std::ops::Range<usize>) = (27..34, 21..31);

/// relRMSE of the default solve and render of `scenes/principled-floor/XML`
/// against its `REFERENCE`, and the cube's foot's sum over Mitsuba's.
fn against_mitsuba(xml: &str, reference: &str) -> (f64, f64) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/principled-floor");
    let scene = wavrad_io::load_scene(&dir.join(xml)).unwrap().scene;
    assert!(!scene.textures.is_empty(), "the checkerboard");
    let (w, h, reference) = wavrad_io::read_exr_rgb(&dir.join(reference)).unwrap();
    assert_eq!((w, h), (scene.film.width, scene.film.height));
    let solution = solve(&scene, &SolveSettings::default(), &Silent).unwrap();
    let image = Renderer::new(solution)
        .render(&RenderSettings::for_scene(&scene))
        .unwrap();
    let error = wavrad_io::relative_rmse(&image.rgb, &reference);
    let sum = |rgb: &[f32]| -> f64 {
        let (rows, columns) = CUBE_FOOT;
        rows.flat_map(|y| columns.clone().map(move |x| 3 * (y * w as usize + x)))
            .map(|i| rgb[i..i + 3].iter().map(|&v| f64::from(v)).sum::<f64>())
            .sum()
    };
    let foot = sum(&image.rgb) / sum(&reference);
    eprintln!("{xml}: relRMSE {error:.4}, cube's foot {foot:.4} of Mitsuba's");
    (error, foot)
}

#[test]
fn principled_floor_matches_mitsuba_path_tracer() {
    let (error, foot) = against_mitsuba("scene.xml", "reference.exr");
    // Measured 1.23 % and 0.994; gather rays that read the floor's
    // average albedo, not the square they land on, and the floor's
    // elements rather than its first bounce per point close by, made them
    // 2.12 % and 0.963.
    assert!(error < 0.016, "relRMSE {error}");
    assert!((foot - 1.0).abs() < 0.02, "cube's foot {foot}");
}

/// The same with clearcoat and sheen on the floor and the cube, and the
/// cube's diffuse lobe flattened (`coated.xml`, `reference-coated.exr`, 65 536 spp, noise 0.20 %).
#[test]
fn clearcoat_and_sheen_match_mitsuba_path_tracer() {
    let (error, foot) = against_mitsuba("coated.xml", "reference-coated.exr");
    // Measured 1.19 % and 0.991; the uncoated scene is 30.6 % from this
    // reference, and the cube without its flatness 2.05 %.
    assert!(error < 0.016, "relRMSE {error}");
    assert!((foot - 1.0).abs() < 0.02, "cube's foot {foot}");
}
