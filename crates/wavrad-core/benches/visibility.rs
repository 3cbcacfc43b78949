//! Occlusion throughput: the segment queries that two-point kernel
//! evaluation issues, asked of the BVH directly ("raw") and through
//! `kernel::throughput` ("kernel"), on the Cornell box and on the Cornell box
//! with a 20 480-triangle sphere. Both report queries per second, so
//! kernel ÷ raw is the share of raw occlusion throughput that kernel
//! evaluation achieves (the rest is Gauss points, Lambert's closed form and
//! bookkeeping). The ratio is also printed from an interleaved timing.

mod support;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use std::time::{Duration, Instant};
use support::{Element, Query};
use wavrad_core::geometry::tracing::SceneTracer;
use wavrad_core::kernel::{KernelContext, Quadrature};
use wavrad_core::scene::Scene;

/// Element level of the pairs: level 1 gives 4 × 4 element pairs per
/// surface pair.
const LEVEL: u32 = 1;

struct Workload {
    scene: Scene,
    tracer: SceneTracer,
    pairs: Vec<(Element, Element)>,
    queries: Vec<Query>,
}

impl Workload {
    /// Every exchanging pair of level-1 elements of the Cornell box's own
    /// surfaces (the first `box_surfaces` of `scene`).
    fn new(scene: &Scene, box_surfaces: usize) -> Workload {
        let q = Quadrature::default();
        let pairs = support::exchanging_pairs(scene, box_surfaces, LEVEL);
        let queries = pairs
            .iter()
            .flat_map(|(a, c)| support::kernel_queries(q, a, c))
            .collect();
        Workload {
            scene: scene.clone(),
            tracer: SceneTracer::new(scene),
            pairs,
            queries,
        }
    }

    /// Raw: every query straight to the BVH; returns the number blocked.
    fn raw(&self) -> usize {
        let tracer = &self.tracer;
        self.queries
            .iter()
            .filter(|q| {
                tracer.occluder.occluded_except(q.from, q.to, |prim| {
                    let s = tracer.surface_of(prim);
                    s == q.surfaces.0 || s == q.surfaces.1
                })
            })
            .count()
    }

    /// Kernel: the same queries issued by kernel evaluation.
    fn kernel(&self) -> f64 {
        let ctx = KernelContext::new(&self.scene, &self.tracer, Quadrature::default());
        self.pairs
            .iter()
            .map(|(a, c)| ctx.throughput(a.kernel(), c.kernel()))
            .sum()
    }
}

/// Median times of `a` and `b` over 7 rounds, each round running both.
fn interleaved_medians(a: impl Fn(), b: impl Fn()) -> (Duration, Duration) {
    let time = |f: &dyn Fn()| {
        let clock = Instant::now();
        f();
        clock.elapsed()
    };
    let (mut ta, mut tb): (Vec<_>, Vec<_>) = (0..7).map(|_| (time(&a), time(&b))).unzip();
    ta.sort();
    tb.sort();
    (ta[3], tb[3])
}

fn occlusion(c: &mut Criterion) {
    let cornell = support::bundled("cornell-box");
    let n = cornell.surfaces.len();
    let scenes = [
        ("cornell_box", cornell.clone()),
        (
            "cornell_box_sphere_20k",
            support::cornell_box_with_sphere(5),
        ),
    ];
    for (name, scene) in &scenes {
        let w = Workload::new(scene, n);
        let queries = w.queries.len();
        let mut group = c.benchmark_group(format!("occlusion/{name}"));
        group.throughput(Throughput::Elements(queries as u64));
        group.bench_function("raw occluded_except", |b| b.iter(|| black_box(w.raw())));
        group.bench_function("via kernel::throughput", |b| {
            b.iter(|| black_box(w.kernel()))
        });
        group.finish();

        // The ratio, from medians of interleaved runs.
        let (raw, kernel) = interleaved_medians(
            || {
                black_box(w.raw());
            },
            || {
                black_box(w.kernel());
            },
        );
        let rate = |t: Duration| queries as f64 / t.as_secs_f64() / 1e6;
        eprintln!(
            "{name}: {} triangles, {} element pairs, {queries} queries ({:.1} % blocked): \
             raw {:.2} M queries/s, via kernel {:.2} M queries/s = {:.0} % of raw",
            w.tracer.occluder.len(),
            w.pairs.len(),
            100.0 * w.raw() as f64 / queries as f64,
            rate(raw),
            rate(kernel),
            100.0 * raw.as_secs_f64() / kernel.as_secs_f64()
        );
    }
}

criterion_group! {
    name = benches;
    config = support::criterion();
    targets = occlusion
}
criterion_main!(benches);
