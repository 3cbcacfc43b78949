//! Camera rays against the exact curved shapes
//! (`wavrad_core::geometry::analytic`): rays per second through
//! `SceneTracer::trace_seen` against 1 to 10 000 spheres scattered over a
//! cube (`testing::scattered_shapes`, filling the same share of it
//! whatever the count), seen through a 32 × 32 pinhole camera. The scenes
//! have no surfaces, so the time is the curved shapes'.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::DVec3;
use std::hint::black_box;
use wavrad_core::geometry::tracing::SceneTracer;
use wavrad_core::scene::analytic::ShapeKind;
use wavrad_core::testing::scattered_shapes;

mod support;

/// Pixels along each side of the camera's image.
const SIDE: usize = 32;

/// Unit-direction rays from (0, 0, 4) through a grid over the square of
/// side 2.4 at z = 0, which covers the cube's face.
fn camera_rays() -> Vec<(DVec3, DVec3)> {
    let eye = DVec3::new(0.0, 0.0, 4.0);
    let coordinate = |k: usize| 2.4 * ((k as f64 + 0.5) / SIDE as f64 - 0.5);
    (0..SIDE * SIDE)
        .map(|p| {
            let target = DVec3::new(coordinate(p % SIDE), coordinate(p / SIDE), 0.0);
            (eye, (target - eye).normalize())
        })
        .collect()
}

fn spheres(c: &mut Criterion) {
    let rays = camera_rays();
    let mut group = c.benchmark_group("camera_rays/spheres");
    group.throughput(Throughput::Elements(rays.len() as u64));
    for count in [1, 4, 10, 100, 1_000, 10_000] {
        let tracer = SceneTracer::new(&scattered_shapes(count, &[ShapeKind::Sphere], 1));
        let seen = || {
            (rays.iter())
                .filter(|(o, d)| tracer.trace_seen(*o, *d, 0.0, f64::INFINITY).is_some())
                .count()
        };
        eprintln!(
            "{count} spheres: {:.0} % of the rays meet one",
            100.0 * seen() as f64 / rays.len() as f64
        );
        group.bench_function(BenchmarkId::from_parameter(count), |b| {
            b.iter(|| black_box(seen()))
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = support::criterion();
    targets = spheres
}
criterion_main!(benches);
