//! Invariants of the glossy path (three-point links, directional radiance):
//! a glossy surface whose BRDF happens to be Lambertian must give what the
//! diffuse path gives, a closed glossy box obeys the furnace identity, and
//! glossy surfaces with albedo ≤ 1 never create energy.

use glam::DVec3;
use wavrad_core::brdf::{Brdf, Ward, WardVariant};
use wavrad_core::scene::{Patch, Rgb, Scene, Surface};
use wavrad_core::solve::{solve, Silent, Solution, SolveSettings};
use wavrad_core::testing::{inward_box, unit_floor, unit_square_midpoints};

/// Ward with no specular lobe: Lambertian, but solved as a glossy surface.
fn lambertian_ward(rho: f64) -> Brdf {
    Brdf::Ward(Ward {
        variant: WardVariant::Balanced,
        alpha_u: 0.2,
        alpha_v: 0.2,
        specular_reflectance: [0.0; 3],
        diffuse_reflectance: [rho; 3],
    })
}

/// Two- and three-point links refined alike, so both paths compare.
fn settings(max_level: u32) -> SolveSettings {
    let mut s = SolveSettings::default();
    s.refine.max_level = max_level;
    s.three_point_max_level = max_level;
    s.three_point_threshold = s.refine.oracle.threshold;
    s
}

fn surface(patch: Patch, brdf: Brdf, emission: Rgb) -> Surface {
    Surface {
        name: "s".into(),
        patch,
        brdf,
        emission,
    }
}

/// A unit floor with `floor_brdf`, lit by a square light above it and seen
/// by a grey wall along one edge; open elsewhere.
fn floor_light_wall(floor_brdf: Brdf) -> Scene {
    let floor = unit_floor();
    let light = Patch::Parallelogram {
        origin: DVec3::new(0.1, 0.2, 0.8),
        edge_s: DVec3::Y * 0.5,
        edge_t: DVec3::X * 0.5,
    };
    let wall = Patch::Parallelogram {
        origin: DVec3::new(1.0, 0.0, 0.0),
        edge_s: DVec3::Z,
        edge_t: DVec3::Y,
    };
    Scene::from_surfaces(vec![
        surface(floor, floor_brdf, [0.0; 3]),
        surface(light, Brdf::diffuse([0.0; 3]), [5.0; 3]),
        surface(wall, Brdf::diffuse([0.5; 3]), [0.0; 3]),
    ])
}

/// Every directional radiance value of the solution.
fn directional_values(solution: &Solution) -> impl Iterator<Item = f64> + '_ {
    solution.directional.iter().flatten().flat_map(|l| *l)
}

#[test]
fn closed_glossy_box_furnace_radiance_is_le_over_one_minus_rho() {
    let (rho, le) = (0.5, 1.0);
    let walls = inward_box(DVec3::new(-1.0, 0.0, 2.0), DVec3::new(1.0, 1.5, 3.0))
        .into_iter()
        .map(|p| surface(p, lambertian_ward(rho), [le; 3]))
        .collect();
    let solution = solve(&Scene::from_surfaces(walls), &settings(2), &Silent).unwrap();
    assert!(solution.stats.converged);
    assert!(solution.stats.three_point_interactions > 0);
    let expect = le / (1.0 - rho);
    // Whole-surface pairs: energy is conserved pair by pair.
    for (d, values) in solution
        .interactions
        .directional
        .iter()
        .zip(&solution.directional)
    {
        let e = (values[0][0] - expect).abs() / expect;
        assert!(e < 0.02, "L_{}→{} = {} vs {expect}", d.p, d.q, values[0][0]);
    }
    let worst = directional_values(&solution)
        .map(|l| (l - expect).abs() / expect)
        .fold(0.0, f64::max);
    assert!(worst < 0.2, "worst element pair error {worst}");
}

#[test]
fn a_box_resting_on_a_glossy_floor_leaves_the_furnace_exact() {
    // As for a diffuse floor (closed_box_furnace.rs): the floor under the
    // box is buried, and the floor's directional radiance is averaged over
    // its exposed part, so the furnace identity holds for it too.
    let (rho, le) = (0.5, 1.0);
    let room = inward_box(DVec3::ZERO, DVec3::splat(2.0));
    let cube = inward_box(DVec3::new(0.55, 0.6, 0.0), DVec3::new(1.3, 1.45, 0.9));
    let mut surfaces = vec![surface(room[0], lambertian_ward(rho), [le; 3])];
    surfaces.extend(
        room[1..]
            .iter()
            .map(|&p| surface(p, Brdf::diffuse([rho; 3]), [le; 3])),
    );
    // The cube without its bottom face, which would only face the floor.
    surfaces.extend(
        cube[1..]
            .iter()
            .map(|p| surface(p.flipped(), Brdf::diffuse([rho; 3]), [le; 3])),
    );
    let solution = solve(&Scene::from_surfaces(surfaces), &settings(3), &Silent).unwrap();
    assert!(solution.stats.converged);
    let expect = le / (1.0 - rho);
    for (d, values) in solution
        .interactions
        .directional
        .iter()
        .zip(&solution.directional)
    {
        let e = (values[0][0] - expect).abs() / expect;
        assert!(e < 0.03, "L_{}→{} = {} vs {expect}", d.p, d.q, values[0][0]);
    }
}

#[test]
fn glossy_path_of_a_lambertian_brdf_matches_the_diffuse_path() {
    // A floor lit by a square light, seen by a wall: the floor once diffuse,
    // once a Ward surface with no specular lobe (three-point links).
    let diffuse = solve(
        &floor_light_wall(Brdf::diffuse([0.6; 3])),
        &settings(4),
        &Silent,
    )
    .unwrap();
    let glossy = solve(
        &floor_light_wall(lambertian_ward(0.6)),
        &settings(4),
        &Silent,
    )
    .unwrap();
    assert_eq!(diffuse.stats.three_point_interactions, 0);
    assert!(glossy.stats.three_point_interactions > 0);
    // The wall's light, all of it via the floor. The diffuse path carries
    // the light's links down to the floor's finest elements
    // (`link::resolve_emitter_links`); the glossy path keeps the light
    // averaged over the elements its three-point links stop at. That puts
    // the diffuse wall 0.25 % darker, at maximum levels 4 to 6 alike
    // (before that step the two agreed within 0.05 %).
    let (d, g) = (diffuse.radiance[2][0][0], glossy.radiance[2][0][0]);
    assert!(
        d > 0.0 && (g - d).abs() / d < 0.004,
        "wall: diffuse {d}, glossy {g}"
    );
    // The floor's radiance towards the wall is its diffuse radiance.
    let s = glossy.interactions.structure_of[&(0, 2)] as usize;
    let (d, g) = (diffuse.radiance[0][0][0], glossy.directional[s][0][0]);
    assert!((g - d).abs() / d < 0.002, "floor: diffuse {d}, glossy {g}");
}

#[test]
fn glossy_box_with_albedo_below_one_gains_no_energy() {
    // Ward (balanced) with ρd + ρs = 0.75 on every wall, one wall emitting:
    // radiance can never exceed Le / (1 − 0.75).
    let ward = Brdf::Ward(Ward {
        variant: WardVariant::Balanced,
        alpha_u: 0.15,
        alpha_v: 0.4,
        specular_reflectance: [0.25; 3],
        diffuse_reflectance: [0.5; 3],
    });
    let walls = inward_box(DVec3::new(-1.0, 0.0, 2.0), DVec3::new(1.0, 1.5, 3.0))
        .into_iter()
        .enumerate()
        .map(|(i, p)| surface(p, ward.clone(), if i == 0 { [1.0; 3] } else { [0.0; 3] }))
        .collect();
    let solution = solve(&Scene::from_surfaces(walls), &settings(2), &Silent).unwrap();
    assert!(solution.stats.converged, "{:?}", solution.stats);
    let bound = 1.0 / (1.0 - 0.75);
    let brightest = directional_values(&solution).fold(0.0, f64::max);
    assert!(brightest <= bound, "{brightest} > {bound}");
    // Light did bounce: walls that do not emit are lit.
    let s = solution.interactions.structure_of[&(1, 2)] as usize;
    assert!(solution.directional[s][0][0] > 0.05);
}

#[test]
fn every_direction_leaving_a_glossy_surface_has_a_receiver() {
    // A Lambertian Ward floor (solved as glossy) lit by a square light, with
    // a wall on one side and open elsewhere: its radiance towards any
    // direction, the wall's or one leaving the scene (the enclosure
    // receiver's), is its diffuse radiance. Averaged over the floor for a
    // fixed direction, it must match the diffuse solve's floor average.
    let diffuse = solve(
        &floor_light_wall(Brdf::diffuse([0.6; 3])),
        &settings(3),
        &Silent,
    )
    .unwrap();
    let glossy = solve(
        &floor_light_wall(lambertian_ward(0.6)),
        &settings(3),
        &Silent,
    )
    .unwrap();
    let expect = diffuse.radiance[0][0][0];
    let n = 24;
    for (d, what) in [
        (DVec3::new(-1.0, 0.3, 0.4), "out of the open side"),
        (DVec3::new(0.2, -0.9, 0.5), "out of the open side"),
        (DVec3::new(1.0, 0.1, 0.3), "towards the wall"),
    ] {
        let d = d.normalize();
        let sum: f64 = unit_square_midpoints(n)
            .map(|y| glossy.glossy_radiance_towards(0, y, d)[0])
            .sum();
        let mean = sum / (n * n) as f64;
        assert!(
            (mean - expect).abs() / expect < 0.03,
            "{what} {d}: {mean} against the diffuse solve's {expect}"
        );
    }
    // The enclosure receives from the floor through the open sides only.
    let enclosure = glossy.enclosure();
    assert!(!enclosure.structures.is_empty());
    assert!(enclosure.structures.keys().all(|&(p, _)| p == 0));
}
