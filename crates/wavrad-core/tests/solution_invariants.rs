//! Invariants of whole solutions: energy balance in an open scene, and
//! results that do not depend on the number of threads nor on how the
//! projection is split into blocks.

use glam::DVec3;
use wavrad_core::progress::Silent;
use wavrad_core::refine::oracle::Oracle;
use wavrad_core::render::estimator::{Estimator, Mode};
use wavrad_core::render::{RenderSettings, Renderer};
use wavrad_core::scene::{
    Camera, Film, FovAxis, Patch, PixelFilter, Projection, Rgb, Scene, Surface,
};
use wavrad_core::solve::shoot::solve_shooting;
use wavrad_core::solve::{plan, solve, BlockLinks, SolveSettings};

fn square(z: f64, up: bool) -> Patch {
    let (s, t) = if up {
        (DVec3::X, DVec3::Y)
    } else {
        (DVec3::Y, DVec3::X)
    };
    Patch::Parallelogram {
        origin: DVec3::new(0.0, 0.0, z),
        edge_s: s,
        edge_t: t,
    }
}

/// An emitter facing a receiver, open to the void: the receiver's average
/// radiance is exactly ρ · F(receiver → emitter) · Le (one bounce; the
/// emitter reflects nothing), with F from Howell's closed form (0.19982 for
/// parallel unit squares at distance 1).
#[test]
fn open_scene_energy_balance_single_bounce() {
    let scene = Scene::from_surfaces(vec![
        Surface {
            name: "receiver".into(),
            patch: square(0.0, true),
            brdf: wavrad_core::scene::brdf::Brdf::diffuse(Rgb([0.6, 0.3, 0.1])),
            emission: Rgb::ZERO,
            texture: None,
            shading: None,
        },
        Surface {
            name: "emitter".into(),
            patch: square(1.0, false),
            brdf: wavrad_core::scene::brdf::Brdf::diffuse(Rgb::ZERO),
            emission: Rgb([5.0, 5.0, 5.0]),
            texture: None,
            shading: None,
        },
    ]);
    let solution = solve(&scene, &SolveSettings::default(), &Silent).unwrap();
    let f = 0.199_825_3;
    for (ch, rho) in [0.6, 0.3, 0.1].into_iter().enumerate() {
        let l = solution.radiance[0][0][ch];
        assert!(
            (l - rho * f * 5.0).abs() < 1e-3 * 5.0 * rho,
            "channel {ch}: {l}"
        );
    }
    // The emitter's radiance is its emission only.
    assert_eq!(solution.radiance[1][0], Rgb::splat(5.0));
    // Everything the receiver reflects is a first bounce, node by node.
    let first = solution.first_bounce().unwrap();
    for (f, l) in first[0].iter().zip(&solution.radiance[0]) {
        (0..3).for_each(|ch| assert!((f[ch] - l[ch]).abs() < 1e-12, "{f:?} vs {l:?}"));
    }
    assert!(first[1].iter().all(|f| *f == Rgb::ZERO));
}

/// A unit square receiver (ρ 0.8) under an emitting one (Le 5, ρ 0.8) a
/// unit above it, facing each other.
fn receiver_under_a_reflecting_emitter() -> Scene {
    Scene::from_surfaces(vec![
        Surface {
            name: "receiver".into(),
            patch: square(0.0, true),
            brdf: wavrad_core::scene::brdf::Brdf::diffuse(Rgb::splat(0.8)),
            emission: Rgb::ZERO,
            texture: None,
            shading: None,
        },
        Surface {
            name: "emitter".into(),
            patch: square(1.0, false),
            brdf: wavrad_core::scene::brdf::Brdf::diffuse(Rgb::splat(0.8)),
            emission: Rgb::splat(5.0),
            texture: None,
            shading: None,
        },
    ])
}

/// With a reflecting emitter the receiver's radiance has a second bounce
/// (receiver → emitter → receiver); its first bounce is still ρ · F · Le.
#[test]
fn first_bounce_is_the_light_straight_from_the_emitters() {
    let scene = receiver_under_a_reflecting_emitter();
    let solution = solve(&scene, &SolveSettings::default(), &Silent).unwrap();
    let first = solution.first_bounce().unwrap();
    let f = 0.199_825_3;
    let (first, all) = (first[0][0][0], solution.radiance[0][0][0]);
    assert!(
        (first - 0.8 * f * 5.0).abs() < 1e-3 * 5.0,
        "first bounce {first}"
    );
    // Receiver → emitter → receiver adds about ρ²F² of the first bounce
    // to each surface in turn (F is the same both ways here).
    let second = all - first;
    assert!(second > 0.5 * 0.64 * f * f * first, "{second} of {all}");
    assert!(second < 2.0 * 0.64 * f * f * first, "{second} of {all}");
}

/// A scene whose integrator limits the path length holds the light of
/// that many reflections less the final gather's: none at max_depth 2
/// (direct lighting: the gather makes the only one), the first bounce at 3,
/// and at 4 the emitter's reflection of it too, while the receiver, whose
/// next light would be a third reflection, keeps only the first.
#[test]
fn a_limited_path_length_keeps_that_many_bounces() {
    let mut scene = receiver_under_a_reflecting_emitter();
    let solved = |scene: &Scene| solve(scene, &SolveSettings::default(), &Silent).unwrap();
    let unlimited = solved(&scene);
    let first = unlimited.first_bounce().unwrap();
    let close = |a: &[Rgb], b: &[Rgb]| {
        a.len() == b.len()
            && a.iter()
                .zip(b)
                .all(|(a, b)| (*a - *b).map(f64::abs).max_channel() < 1e-12)
    };
    scene.hints.max_depth = Some(2);
    let direct = solved(&scene);
    assert!(direct.radiance[0].iter().all(|l| *l == Rgb::ZERO));
    assert!(direct.radiance[1].iter().all(|l| *l == Rgb::splat(5.0)));
    // Direct lighting needs no links between surfaces.
    assert_eq!(direct.stats.two_point_interactions, 0);
    assert!(unlimited.stats.two_point_interactions > 0);
    scene.hints.max_depth = Some(3);
    let one = solved(&scene);
    assert!(close(&one.radiance[0], &first[0]));
    assert!(one.radiance[1].iter().all(|l| *l == Rgb::splat(5.0)));
    scene.hints.max_depth = Some(4);
    let two = solved(&scene);
    assert!(close(&two.radiance[0], &first[0]));
    let back = two.radiance[1][0][0] - 5.0;
    assert!(
        back > 0.0 && back < unlimited.radiance[1][0][0] - 5.0,
        "{back}"
    );
    assert!(unlimited.radiance[0][0][0] > first[0][0][0] + 1e-6);
}

/// Refinement, solve and rendering give bit-identical results on 1 and 2
/// threads, diffuse and glossy (two- and three-point links, the eye).
/// Whatever the oracle and however many refine–solve passes run, the
/// solution returned has its emitter links resolved down to the elements
/// where their light changes: a light close over a floor's corner makes the
/// floor's elements under it at the maximum level, even with an oracle
/// threshold so loose that it refines nothing itself.
#[test]
fn every_solution_has_its_emitter_links_resolved() {
    let scene = wavrad_core::testing::light_over_a_corner(0.3);
    for (oracle, passes) in [
        (Oracle::Kernel, 1),
        (Oracle::Power, 1),
        (Oracle::Power, 2),
        (Oracle::Power, 4),
    ] {
        let mut settings = SolveSettings {
            max_refine_passes: passes,
            ..SolveSettings::for_oracle(oracle)
        };
        settings.refine.threshold = 1e9;
        settings.refine.max_level = 3;
        let solution = solve(&scene, &settings, &Silent).unwrap();
        assert_eq!(solution.trees[0].depth(), 3, "{oracle:?}, {passes} passes");
    }
}

#[test]
fn results_do_not_depend_on_thread_count() {
    let scene = glossy_box_under_a_camera();
    for oracle in [Oracle::Kernel, Oracle::Power, Oracle::Importance] {
        same_on_one_and_two_threads(&scene, &glossy_settings(oracle));
    }
}

/// However a plan's items are split into blocks, and in whatever order the
/// blocks come back, the solution is the one-process solve's bit for bit,
/// two- and three-point links alike, the importance oracle's refine–solve
/// loop included.
#[test]
fn results_do_not_depend_on_block_split() {
    let scene = glossy_box_under_a_camera();
    for oracle in [Oracle::Kernel, Oracle::Importance] {
        let settings = SolveSettings {
            max_refine_passes: 2,
            ..glossy_settings(oracle)
        };
        let whole = solve(&scene, &settings, &Silent).unwrap();
        let items = plan(&scene, &settings, &Silent).unwrap().items().end;
        for n in [3, items] {
            let plan = plan(&scene, &settings, &Silent).unwrap();
            let mut blocks: Vec<BlockLinks> = plan
                .blocks(n)
                .into_iter()
                .map(|block| plan.project(block, &Silent).unwrap())
                .collect();
            assert_eq!(blocks.len(), n);
            blocks.reverse();
            let split = plan.finish(blocks, &Silent).unwrap();
            assert!(split.stats.three_point_interactions > 0);
            assert_eq!(split.radiance, whole.radiance, "{oracle}, {n} blocks");
            assert_eq!(split.directional, whole.directional, "{oracle}, {n} blocks");
        }
    }
}

/// Blocks that leave items out, hold some twice or reach past the plan are
/// refused with what is wrong, not solved into a wrong image.
#[test]
fn blocks_that_do_not_cover_the_plan_once_are_refused() {
    let scene = glossy_box_under_a_camera();
    let settings = SolveSettings::default();
    let projected = || {
        let plan = plan(&scene, &settings, &Silent).unwrap();
        let blocks: Vec<BlockLinks> = plan
            .blocks(3)
            .into_iter()
            .map(|block| plan.project(block, &Silent).unwrap())
            .collect();
        (plan, blocks)
    };
    let (plan, mut blocks) = projected();
    let missing = blocks.remove(1).items;
    assert_eq!(
        problem(plan.finish(blocks, &Silent)),
        format!("no block holds items {missing:?}")
    );
    let (plan, mut blocks) = projected();
    blocks.push(blocks[0].clone());
    assert!(problem(plan.finish(blocks, &Silent)).contains("overlaps"));
    let (plan, mut blocks) = projected();
    let last = blocks.pop().unwrap().items;
    assert_eq!(
        problem(plan.finish(blocks, &Silent)),
        format!("no block holds items {last:?}")
    );
    let (plan, _) = projected();
    let items = plan.items().end;
    assert!(problem(plan.project(0..items + 1, &Silent)).contains("not a range"));
}

/// What an [`wavrad_core::Error::Blocks`] says is wrong.
fn problem<T>(result: wavrad_core::Result<T>) -> String {
    match result {
        Err(wavrad_core::Error::Blocks { problem, .. }) => problem,
        Err(e) => panic!("unexpected error {e}"),
        Ok(_) => panic!("accepted"),
    }
}

/// Settings that make three-point links on [`glossy_box_under_a_camera`].
fn glossy_settings(oracle: Oracle) -> SolveSettings {
    SolveSettings {
        three_point_max_level: 2,
        three_point_threshold: 1e-3,
        ..SolveSettings::for_oracle(oracle)
    }
}

/// A closed box, one wall emitting, one glossy (Ward), a tilted triangle
/// inside, seen by a small camera.
fn glossy_box_under_a_camera() -> Scene {
    let mut surfaces: Vec<Surface> =
        wavrad_core::testing::inward_box(DVec3::splat(-1.0), DVec3::ONE)
            .into_iter()
            .map(|patch| Surface {
                name: "wall".into(),
                patch,
                brdf: wavrad_core::scene::brdf::Brdf::diffuse(Rgb([0.7, 0.5, 0.3])),
                emission: Rgb::ZERO,
                texture: None,
                shading: None,
            })
            .collect();
    surfaces[1].emission = Rgb::splat(3.0);
    surfaces[2].brdf = wavrad_core::scene::brdf::Brdf::Ward(wavrad_core::scene::brdf::Ward {
        alpha_u: 0.15,
        alpha_v: 0.3,
        ..Default::default()
    });
    surfaces.push(Surface {
        name: "blocker".into(),
        patch: Patch::Triangle([
            DVec3::new(-0.5, -0.5, 0.0),
            DVec3::new(0.5, -0.5, 0.0),
            DVec3::new(0.0, 0.5, 0.2),
        ]),
        brdf: wavrad_core::scene::brdf::Brdf::diffuse(Rgb::splat(0.5)),
        emission: Rgb::ZERO,
        texture: None,
        shading: None,
    });
    let mut scene = Scene::from_surfaces(surfaces);
    scene.camera = Some(Camera {
        world_from_camera: glam::DMat4::look_at_rh(
            DVec3::new(0.0, 0.0, -0.9),
            DVec3::ZERO,
            DVec3::Y,
        )
        .inverse(),
        projection: Projection::Perspective {
            fov_x_degrees: 80.0,
            fov_axis: FovAxis::X,
        },
        near_clip: 0.01,
        far_clip: 100.0,
    });
    scene.film = Film {
        width: 12,
        height: 9,
        filter: PixelFilter::Gaussian { stddev: 0.5 },
    };
    scene
}

fn same_on_one_and_two_threads(scene: &Scene, settings: &SolveSettings) {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let s = solve(scene, settings, &Silent).unwrap();
            let render = RenderSettings {
                samples_per_pixel: 16,
                gather_samples_per_pixel: 4,
                ..RenderSettings::default()
            };
            let renderer = Renderer::new(&s);
            let gather = renderer.render(&render).unwrap();
            let direct = renderer
                .render(&RenderSettings {
                    estimator: Mode::Direct.estimator(true, true).unwrap(),
                    ..render
                })
                .unwrap();
            let cached = renderer
                .render(&RenderSettings {
                    estimator: Estimator::FinalGather { cached: true },
                    ..render
                })
                .unwrap();
            let counts = (
                s.stats.two_point_interactions,
                s.stats.three_point_interactions,
            );
            (
                (s.radiance, s.directional),
                counts,
                (gather.rgb, direct.rgb, cached.rgb),
            )
        })
    };
    let (r1, n1, i1) = run(1);
    let (r2, n2, i2) = run(2);
    assert!(
        n1.1 > 0,
        "{}: the glossy wall makes three-point links",
        settings.oracle
    );
    assert_eq!(n1, n2);
    assert_eq!(r1, r2);
    assert_eq!(i1, i2);
}

/// The shooting solver links surfaces pairwise: a mesh too fine for that is
/// refused at once, not solved for hours, with the way out in the message.
#[test]
fn too_many_surfaces_for_shooting_is_a_clear_error() {
    let tiny = Surface {
        name: "t".into(),
        patch: Patch::Triangle([DVec3::ZERO, DVec3::X, DVec3::Y]),
        brdf: wavrad_core::scene::brdf::Brdf::diffuse(Rgb::splat(0.5)),
        emission: Rgb::ZERO,
        texture: None,
        shading: None,
    };
    let limit = wavrad_core::solve::shoot::MAX_SHOOTING_SURFACES;
    let scene = Scene::from_surfaces(vec![tiny; limit + 1]);
    let err = solve_shooting(&scene, &SolveSettings::default(), &Silent, None)
        .err()
        .unwrap();
    assert!(err.to_string().contains("4097 surfaces"), "{err}");
    assert!(err.to_string().contains("gathering solver"), "{err}");
}
