//! Invariants of the glossy path (three-point links, directional radiance):
//! a glossy surface whose BRDF happens to be Lambertian must give exactly
//! what the diffuse path gives (its Lambertian lobe takes two-point links),
//! a specular lobe adds to that, a closed glossy box obeys the furnace
//! identity, and glossy surfaces with albedo ≤ 1 never create energy.

use glam::DVec3;
use wavrad_core::progress::Silent;
use wavrad_core::render::Renderer;
use wavrad_core::scene::brdf::{Brdf, Ward, WardVariant};
use wavrad_core::scene::{Patch, Rgb, Scene, Surface};
use wavrad_core::solve::{solve, Solution, SolveSettings};
use wavrad_core::testing::{inward_box, unit_floor, unit_square_midpoints};

/// Ward with no specular lobe: Lambertian, but a glossy surface's BRDF.
fn lambertian_ward(rho: f64) -> Brdf {
    Brdf::Ward(Ward {
        variant: WardVariant::Balanced,
        alpha_u: 0.2,
        alpha_v: 0.2,
        specular_reflectance: Rgb::ZERO,
        diffuse_reflectance: Rgb::splat(rho),
    })
}

/// Two- and three-point links refined alike, so both paths compare.
fn settings(max_level: u32) -> SolveSettings {
    let mut s = SolveSettings::default();
    s.refine.max_level = max_level;
    s.three_point_max_level = max_level;
    s.three_point_threshold = s.refine.threshold;
    s
}

fn surface(patch: Patch, brdf: Brdf, emission: Rgb) -> Surface {
    Surface {
        name: "s".into(),
        patch,
        brdf,
        emission,
        texture: None,
        shading: None,
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
        surface(floor, floor_brdf, Rgb::ZERO),
        surface(light, Brdf::diffuse(Rgb::ZERO), Rgb::splat(5.0)),
        surface(wall, Brdf::diffuse(Rgb::splat(0.5)), Rgb::ZERO),
    ])
}

/// Every directional radiance value of the solution.
fn directional_values(solution: &Solution) -> impl Iterator<Item = f64> + '_ {
    solution.directional.iter().flatten().flat_map(|l| l.0)
}

#[test]
fn closed_glossy_box_furnace_radiance_is_le_over_one_minus_rho() {
    // Ward walls with a specular lobe that reflects nothing: all of their
    // light goes through two-point links (the Lambertian lobe's), none
    // through three-point links, and the furnace identity holds per element.
    let (rho, le) = (0.5, 1.0);
    let walls = inward_box(DVec3::new(-1.0, 0.0, 2.0), DVec3::new(1.0, 1.5, 3.0))
        .into_iter()
        .map(|p| surface(p, lambertian_ward(rho), Rgb::splat(le)))
        .collect();
    let solution = solve(&Scene::from_surfaces(walls), &settings(2), &Silent).unwrap();
    assert!(solution.stats.converged);
    assert_eq!(solution.stats.three_point_interactions, 0);
    assert!(directional_values(&solution).all(|l| l == 0.0));
    let expect = le / (1.0 - rho);
    let worst = (solution.radiance.iter().flatten())
        .map(|l| (l[0] - expect).abs() / expect)
        .fold(0.0, f64::max);
    assert!(worst < 0.02, "worst element error {worst}");
}

#[test]
fn a_lambertian_lobe_solves_exactly_as_a_diffuse_surface() {
    // A floor lit by a square light, seen by a wall: the floor once diffuse,
    // once a Ward surface with no specular lobe. The Ward floor's
    // Lambertian lobe takes the same two-point links as the diffuse floor,
    // so every element of every surface gets the same radiance. (When the
    // whole BRDF went through three-point links, whose glossy elements stop
    // at the three-point maximum level, the wall came out 0.25 % off.)
    let diffuse = solve(
        &floor_light_wall(Brdf::diffuse(Rgb::splat(0.6))),
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
    assert_eq!(glossy.stats.three_point_interactions, 0);
    assert_eq!(
        diffuse.stats.two_point_interactions,
        glossy.stats.two_point_interactions
    );
    for (s, (d, g)) in diffuse.radiance.iter().zip(&glossy.radiance).enumerate() {
        assert_eq!(d.len(), g.len(), "surface {s}");
        for (d, g) in d.iter().zip(g) {
            assert!(
                (d[0] - g[0]).abs() <= 1e-12 * d[0].max(1.0),
                "surface {s}: {d:?} {g:?}"
            );
        }
    }
    assert!(diffuse.radiance[2][0][0] > 0.0);
}

#[test]
fn a_specular_lobe_adds_to_the_lambertian_light() {
    // The same floor with a specular lobe on top of its Lambertian one: its
    // elements hold what the Lambertian lobe reflects, as the diffuse
    // floor's do; the wall receives that plus the glossy reflection, more
    // than from the diffuse floor alone.
    let ward = |specular: f64| {
        Brdf::Ward(Ward {
            variant: WardVariant::Balanced,
            alpha_u: 0.2,
            alpha_v: 0.2,
            specular_reflectance: Rgb::splat(specular),
            diffuse_reflectance: Rgb::splat(0.6),
        })
    };
    let diffuse = solve(&floor_light_wall(ward(0.0)), &settings(3), &Silent).unwrap();
    let glossy = solve(&floor_light_wall(ward(0.3)), &settings(3), &Silent).unwrap();
    assert!(glossy.stats.three_point_interactions > 0);
    // The floor sees only the light (the wall's light reaches it at second
    // hand, a few per cent of it).
    let (d, g) = (diffuse.radiance[0][0][0], glossy.radiance[0][0][0]);
    assert!(g >= d && (g - d) / d < 0.05, "floor: {d} then {g}");
    let s = glossy.interactions.structure_of[&(0, 2)] as usize;
    assert!(glossy.directional[s][0][0] > 0.0);
    let (d, g) = (diffuse.radiance[2][0][0], glossy.radiance[2][0][0]);
    assert!(g > 1.05 * d, "wall: {d} then {g}");
}

#[test]
fn glossy_box_with_albedo_below_one_gains_no_energy() {
    // Ward (balanced) with ρd + ρs = 0.75 on every wall, one wall emitting:
    // radiance can never exceed Le / (1 − 0.75).
    let ward = Brdf::Ward(Ward {
        variant: WardVariant::Balanced,
        alpha_u: 0.15,
        alpha_v: 0.4,
        specular_reflectance: Rgb::splat(0.25),
        diffuse_reflectance: Rgb::splat(0.5),
    });
    let walls = inward_box(DVec3::new(-1.0, 0.0, 2.0), DVec3::new(1.0, 1.5, 3.0))
        .into_iter()
        .enumerate()
        .map(|(i, p)| {
            surface(
                p,
                ward.clone(),
                if i == 0 { Rgb::splat(1.0) } else { Rgb::ZERO },
            )
        })
        .collect();
    let solution = solve(&Scene::from_surfaces(walls), &settings(2), &Silent).unwrap();
    assert!(solution.stats.converged, "{:?}", solution.stats);
    let bound = 1.0 / (1.0 - 0.75);
    // Radiance towards each receiver, averaged over the pair of surfaces:
    // the glossy surface's own (Lambertian) plus its directional radiance.
    let towards = |(d, values): (&wavrad_core::solve::gather::Directional, &Vec<Rgb>)| {
        solution.radiance[d.p as usize][0][0] + values[0][0]
    };
    let pairs = solution
        .interactions
        .directional
        .iter()
        .zip(&solution.directional);
    let brightest = pairs.map(towards).fold(0.0, f64::max);
    assert!(brightest <= bound, "{brightest} > {bound}");
    // Light did bounce: walls that do not emit are lit, by both lobes.
    let s = solution.interactions.structure_of[&(1, 2)] as usize;
    assert!(solution.radiance[1][0][0] > 0.05);
    assert!(solution.directional[s][0][0] > 0.01);
}

#[test]
fn every_direction_leaving_a_glossy_surface_has_a_receiver() {
    // A Lambertian Ward floor (a glossy surface) lit by a square light, with
    // a wall on one side and open elsewhere: its radiance towards any
    // direction, the wall's or one leaving the scene (the enclosure
    // receiver's), is its diffuse radiance. Averaged over the floor for a
    // fixed direction, it must match the diffuse solve's floor average.
    let diffuse = solve(
        &floor_light_wall(Brdf::diffuse(Rgb::splat(0.6))),
        &settings(3),
        &Silent,
    )
    .unwrap();
    let glossy = Renderer::new(
        solve(
            &floor_light_wall(lambertian_ward(0.6)),
            &settings(3),
            &Silent,
        )
        .unwrap(),
    );
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
    // With a specular lobe, the enclosure receives it from the floor,
    // through the open sides only.
    let mut scene = floor_light_wall(lambertian_ward(0.6));
    if let Brdf::Ward(w) = &mut scene.surfaces[0].brdf {
        w.specular_reflectance = Rgb::splat(0.2);
    }
    let shiny = Renderer::new(solve(&scene, &settings(3), &Silent).unwrap());
    let enclosure = shiny.enclosure();
    assert!(!enclosure.structures.is_empty());
    assert!(enclosure.structures.keys().all(|&(p, _)| p == 0));
}
