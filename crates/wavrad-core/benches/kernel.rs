//! Kernel quadrature: one two-point throughput T(a,c) for element pairs of
//! distinct character, and one three-point coefficient R(c,a,b) through a
//! Ward floor, on the bundled Cornell boxes; and the four coefficients of a
//! receiver split, evaluated separately or sharing their incident light.

mod support;

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use support::{pick_pair, share_an_edge, surface, Element};
use wavrad_core::geometry::hierarchy::ElementId;
use wavrad_core::geometry::tracing::SceneTracer;
use wavrad_core::kernel::three_point_quadrature::{coefficient, GlossyElement, IncidentLight};
use wavrad_core::kernel::{KernelContext, Quadrature};
use wavrad_core::scene::brdf::Brdf;

fn two_point(c: &mut Criterion) {
    let scene = support::bundled("cornell-box");
    let tracer = SceneTracer::new(&scene);
    let (floor, ceiling, back) = (
        surface(&scene, "floor"),
        surface(&scene, "ceiling"),
        surface(&scene, "back"),
    );
    let q = Quadrature::default();
    let ctx = KernelContext::new(&scene, &tracer, q);
    let cases = [
        (
            "distant parallel (floor-ceiling, unoccluded)",
            pick_pair(&ctx, (floor, ceiling), 2, |_, _, v| v == 1.0),
        ),
        (
            "perpendicular sharing an edge (floor-back)",
            pick_pair(&ctx, (floor, back), 2, |a, c, _| {
                share_an_edge(&a.patch, &c.patch)
            }),
        ),
        (
            "partially occluded (floor-ceiling, 30-70 % visible)",
            pick_pair(&ctx, (floor, ceiling), 2, |_, _, v| (0.3..0.7).contains(&v)),
        ),
    ];
    let mut group = c.benchmark_group("two_point_throughput");
    for (name, (a, e)) in &cases {
        let queries = support::kernel_queries(q, a, e).len();
        let (seen, open) = support::visible_and_open(&ctx, a, e);
        eprintln!(
            "{name}: elements {:?} / {:?}, {queries} occlusion queries, visible fraction {:.3}",
            a.id,
            e.id,
            seen / open
        );
        group.bench_function(*name, |b| {
            b.iter(|| ctx.throughput(black_box(a.kernel()), black_box(e.kernel())))
        });
    }
    group.finish();
}

fn three_point(c: &mut Criterion) {
    let scene = support::bundled("glossy-cornell-box");
    let tracer = SceneTracer::new(&scene);
    let (floor, light, ceiling, back, red) = (
        surface(&scene, "floor"),
        surface(&scene, "light"),
        surface(&scene, "ceiling"),
        surface(&scene, "back"),
        surface(&scene, "red-wall"),
    );
    let glossy = &scene.surfaces[floor as usize];
    assert!(matches!(glossy.brdf, Brdf::Ward(_)), "the floor is Ward");
    let ctx = KernelContext::new(&scene, &tracer, Quadrature::default());
    let at = |s: u32, level: u32, path: u64| Element::new(&scene, s, ElementId { level, path });
    let reflect = |source: &Element, reflector: &Element, receiver: &Element| {
        let a = GlossyElement {
            element: reflector.kernel(),
            brdf: &glossy.brdf,
            frame: glossy.frame(),
        };
        coefficient(&ctx, source.kernel(), a, &receiver.patch)
    };
    // The first floor element (path order) lit by each source.
    let lit = |source: &Element, receiver: &Element| {
        support::elements(2)
            .map(|id| Element::new(&scene, floor, id))
            .find(|a| reflect(source, a, receiver).0.iter().all(|&x| x > 0.0))
            .expect("a lit floor element")
    };
    let cases = [
        (
            "light -> floor (Ward) -> back wall",
            at(light, 0, 0),
            at(back, 1, 1),
        ),
        (
            "ceiling -> floor (Ward) -> red wall",
            at(ceiling, 1, 2),
            at(red, 2, 6),
        ),
    ]
    .map(|(name, source, receiver)| (name, source, lit(&source, &receiver), receiver));
    let mut group = c.benchmark_group("three_point_coefficient");
    for (name, source, reflector, receiver) in &cases {
        let a = GlossyElement {
            element: reflector.kernel(),
            brdf: &glossy.brdf,
            frame: glossy.frame(),
        };
        eprintln!(
            "{name}: elements {:?} / {:?} / {:?}, R = {:?}",
            source.id,
            reflector.id,
            receiver.id,
            reflect(source, reflector, receiver)
        );
        group.bench_function(*name, |b| {
            b.iter(|| {
                coefficient(
                    &ctx,
                    black_box(source.kernel()),
                    black_box(a),
                    black_box(&receiver.patch),
                )
            })
        });
    }

    // Virtual resolution splitting the receiver: four coefficients, or the
    // receiver-independent part (all ray queries) once.
    let (_, source, reflector, receiver) = &cases[0];
    let a = GlossyElement {
        element: reflector.kernel(),
        brdf: &glossy.brdf,
        frame: glossy.frame(),
    };
    let children = receiver.patch.subdivide();
    group.bench_function("receiver split: 4 x coefficient", |b| {
        b.iter(|| children.map(|child| coefficient(&ctx, source.kernel(), a, &child)))
    });
    group.bench_function("receiver split: IncidentLight + 4 x towards", |b| {
        b.iter(|| {
            let incident = IncidentLight::new(&ctx, black_box(source.kernel()), a);
            children.map(|child| incident.towards(&child))
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = support::criterion();
    targets = two_point, three_point
}
criterion_main!(benches);
