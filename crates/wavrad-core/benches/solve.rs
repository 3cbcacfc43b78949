//! The solve's inner loop over a solved Cornell box (default settings): one
//! Gauss–Seidel sweep (eq. 12 gather + push–pull on every surface), and its
//! two parts on the surface with the most incoming transfers.

mod support;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use wavrad_core::progress::Silent;
use wavrad_core::scene::Rgb;
use wavrad_core::solve::{push_pull::push_pull, solve, Solution, SolveSettings};

/// One sweep as `solve` does it (diffuse surfaces only: the Cornell box has
/// no glossy one), updating `radiance` in place.
fn sweep(s: &Solution, radiance: &mut [Vec<Rgb>]) {
    let far = (s.interactions).far_field(&s.scene, &s.trees, (radiance, &s.directional), None);
    for (p, surface) in s.scene.surfaces.iter().enumerate() {
        let rho = surface.brdf.lambertian().expect("diffuse scene");
        let read = (&radiance[..], &s.directional[..]);
        let gathered = s.interactions.gather(p, rho, &s.trees[p], read, &far);
        let exposure = Some(&s.interactions.exposure[p][..]);
        let limit = Some(&s.interactions.limit[p][..]);
        let texture = s.interactions.texture_of(p);
        radiance[p] = push_pull(
            &s.trees[p],
            &gathered,
            surface.emission,
            exposure,
            limit,
            texture,
        );
    }
}

fn gauss_seidel(c: &mut Criterion) {
    let scene = support::bundled("cornell-box");
    let s = solve(&scene, &SolveSettings::default(), &Silent).expect("solves");
    let transfers: usize = s.interactions.incoming.iter().map(Vec::len).sum();
    let nodes: usize = s.trees.iter().map(|t| t.nodes.len()).sum();
    let busiest = (0..scene.surfaces.len())
        .max_by_key(|&p| s.interactions.incoming[p].len())
        .expect("surfaces");
    eprintln!(
        "cornell box: {transfers} transfers, {nodes} nodes; busiest surface {} ({}): {} transfers, {} nodes",
        busiest,
        scene.surfaces[busiest].name,
        s.interactions.incoming[busiest].len(),
        s.trees[busiest].nodes.len()
    );

    let mut group = c.benchmark_group("gauss_seidel/cornell_box");
    group.throughput(Throughput::Elements(transfers as u64));
    group.bench_function("sweep (gather + push_pull, all surfaces)", |b| {
        let mut radiance = s.radiance.clone();
        b.iter(|| sweep(&s, black_box(&mut radiance)))
    });
    let rho = scene.surfaces[busiest].brdf.lambertian().expect("diffuse");
    let tree = &s.trees[busiest];
    group.throughput(Throughput::Elements(
        s.interactions.incoming[busiest].len() as u64
    ));
    let far = (s.interactions).far_field(&s.scene, &s.trees, (&s.radiance, &s.directional), None);
    let read = (&s.radiance[..], &s.directional[..]);
    group.bench_function("gather (busiest surface)", |b| {
        b.iter(|| {
            s.interactions
                .gather(busiest, rho, tree, black_box(read), &far)
        })
    });
    let gathered = s.interactions.gather(busiest, rho, tree, read, &far);
    group.throughput(Throughput::Elements(tree.nodes.len() as u64));
    group.bench_function("push_pull (busiest surface)", |b| {
        let exposure = Some(&s.interactions.exposure[busiest][..]);
        let emission = scene.surfaces[busiest].emission;
        let limit = Some(&s.interactions.limit[busiest][..]);
        b.iter(|| push_pull(tree, black_box(&gathered), emission, exposure, limit, None))
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = support::criterion();
    targets = gauss_seidel
}
criterion_main!(benches);
