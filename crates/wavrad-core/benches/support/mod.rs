//! Fixtures shared by the criterion benches: the bundled scenes, element
//! pairs picked by what their kernels look like, a larger triangle scene,
//! and the occlusion queries a kernel evaluation issues.
//!
//! Each bench file includes this module with `mod support;` and uses only
//! part of it.
#![allow(dead_code)]

use criterion::Criterion;
use glam::DVec3;
use std::path::PathBuf;
use std::time::Duration;
use wavrad_core::geometry::element::AreaSample;
use wavrad_core::geometry::hierarchy::ElementId;
use wavrad_core::geometry::tracing::SceneTracer;
use wavrad_core::kernel::{faces_away, form_factor, KernelContext, KernelElement, Quadrature};
use wavrad_core::scene::{Patch, Scene, Surface};

/// Short runs: the whole `cargo bench -p wavrad-core` takes a few minutes
/// on two cores. Pass `--measurement-time` / `--sample-size` to criterion
/// for tighter intervals.
pub fn criterion() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .configure_from_args()
}

/// A bundled scene, `scenes/<name>/scene.xml`.
pub fn bundled(name: &str) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
        .join("scene.xml");
    wavrad_io::load_scene(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .scene
}

/// Index of the first surface called `name`.
pub fn surface(scene: &Scene, name: &str) -> u32 {
    scene
        .surfaces
        .iter()
        .position(|s| s.name == name)
        .unwrap_or_else(|| panic!("no surface {name}")) as u32
}

/// Every element of `root` at `level`, in path order.
pub fn elements(level: u32) -> impl Iterator<Item = ElementId> {
    (0..4u64.pow(level)).map(move |path| ElementId { level, path })
}

/// An element of a surface, with its geometry.
#[derive(Debug, Clone, Copy)]
pub struct Element {
    /// Surface index.
    pub surface: u32,
    /// Element on it.
    pub id: ElementId,
    /// Its geometry.
    pub patch: Patch,
}

impl Element {
    pub fn new(scene: &Scene, surface: u32, id: ElementId) -> Element {
        Element {
            surface,
            id,
            patch: id.patch(&scene.surfaces[surface as usize].patch),
        }
    }

    pub fn kernel(&self) -> KernelElement<'_> {
        KernelElement {
            patch: &self.patch,
            surface: self.surface,
        }
    }
}

/// T(a,c) with and without the rest of the scene: (visible, unoccluded).
pub fn visible_and_open(ctx: &KernelContext, a: &Element, c: &Element) -> (f64, f64) {
    let alone = Scene::from_surfaces(vec![
        ctx.scene.surfaces[a.surface as usize].clone(),
        ctx.scene.surfaces[c.surface as usize].clone(),
    ]);
    let open_tracer = SceneTracer::new(&alone);
    let open_ctx = KernelContext::new(&alone, &open_tracer, ctx.quadrature);
    let open = open_ctx.throughput(
        KernelElement {
            patch: &a.patch,
            surface: 0,
        },
        KernelElement {
            patch: &c.patch,
            surface: 1,
        },
    );
    let seen = ctx.throughput(a.kernel(), c.kernel());
    (seen, open)
}

/// The first pair of `level` elements of surfaces `p` and `r` (in path
/// order) for which `accept(a, c, visible_fraction)` holds, where the
/// visible fraction is T(a,c) with the scene over T(a,c) alone.
pub fn pick_pair(
    ctx: &KernelContext,
    (p, r): (u32, u32),
    level: u32,
    accept: impl Fn(&Element, &Element, f64) -> bool,
) -> (Element, Element) {
    for ia in elements(level) {
        for ic in elements(level) {
            let (a, c) = (
                Element::new(ctx.scene, p, ia),
                Element::new(ctx.scene, r, ic),
            );
            let (seen, open) = visible_and_open(ctx, &a, &c);
            if open > 0.0 && accept(&a, &c, seen / open) {
                return (a, c);
            }
        }
    }
    panic!("no pair of surfaces {p}, {r} at level {level} fits");
}

/// True when the two elements share an edge (two vertices).
pub fn share_an_edge(a: &Patch, c: &Patch) -> bool {
    let shared = a
        .vertices()
        .iter()
        .filter(|v| c.vertices().iter().any(|w| v.distance(*w) < 1e-9))
        .count();
    shared >= 2
}

/// Every pair of `level` elements of surfaces that can exchange light
/// (what refinement evaluates at that level), among the first `surfaces`.
pub fn exchanging_pairs(scene: &Scene, surfaces: usize, level: u32) -> Vec<(Element, Element)> {
    let mut pairs = Vec::new();
    for p in 0..surfaces as u32 {
        for r in p + 1..surfaces as u32 {
            let (sp, sr) = (&scene.surfaces[p as usize], &scene.surfaces[r as usize]);
            if faces_away(&sp.patch, &sr.patch) {
                continue;
            }
            for ia in elements(level) {
                for ic in elements(level) {
                    let (a, c) = (Element::new(scene, p, ia), Element::new(scene, r, ic));
                    if !faces_away(&a.patch, &c.patch) {
                        pairs.push((a, c));
                    }
                }
            }
        }
    }
    pairs
}

/// One occlusion query a kernel evaluation issues: the segment and the two
/// surfaces whose primitives never occlude it.
#[derive(Debug, Clone, Copy)]
pub struct Query {
    pub from: DVec3,
    pub to: DVec3,
    pub surfaces: (u32, u32),
}

/// The occlusion queries `KernelContext::throughput(a, c)` issues, in
/// its order: Gauss points on the smaller element that see the larger one
/// at all, to the ray targets in front of them (mirrors
/// `kernel::throughput_samples` and `kernel::visible_fraction`).
pub fn kernel_queries(q: Quadrature, a: &Element, c: &Element) -> Vec<Query> {
    let (outer, inner) = if a.patch.area() <= c.patch.area() {
        (a, c)
    } else {
        (c, a)
    };
    let (n_outer, n_inner) = (outer.patch.normal(), inner.patch.normal());
    let polygon = inner.patch.vertices();
    let targets: Vec<AreaSample> = inner.patch.gauss_points(q.rays);
    let mut out = Vec::new();
    for x in outer.patch.gauss_points(q.points) {
        if form_factor::point_to_polygon(x.position, n_outer, &polygon, n_inner) <= 0.0 {
            continue;
        }
        for y in &targets {
            if n_outer.dot(y.position - x.position) > 0.0 {
                out.push(Query {
                    from: x.position,
                    to: y.position,
                    surfaces: (a.surface, c.surface),
                });
            }
        }
    }
    out
}

/// The Cornell box with a tessellated sphere (an icosphere of
/// `20·4^subdivisions` triangles, radius 0.35, above the small box) as
/// extra triangle surfaces after the box's own: a scene whose BVH is deep.
/// The box's surfaces keep their indices.
pub fn cornell_box_with_sphere(subdivisions: u32) -> Scene {
    let mut scene = bundled("cornell-box");
    let centre = DVec3::new(0.3, 0.1, 0.3);
    for [a, b, c] in icosphere(subdivisions) {
        let patch = Patch::Triangle([centre + 0.35 * a, centre + 0.35 * b, centre + 0.35 * c]);
        scene.surfaces.push(Surface {
            name: "sphere".into(),
            patch,
            brdf: wavrad_core::scene::brdf::Brdf::diffuse(wavrad_core::scene::Rgb::splat(0.5)),
            emission: wavrad_core::scene::Rgb::ZERO,
            texture: None,
            shading: None,
        });
    }
    scene
}

/// Unit icosphere triangles, outward facing, `20·4^subdivisions` of them.
fn icosphere(subdivisions: u32) -> Vec<[DVec3; 3]> {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let v = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .map(|(x, y, z)| DVec3::new(x, y, z).normalize());
    let faces = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut tris: Vec<[DVec3; 3]> = faces.iter().map(|f| f.map(|i| v[i])).collect();
    for _ in 0..subdivisions {
        tris = tris
            .into_iter()
            .flat_map(|[a, b, c]| {
                let (ab, bc, ca) = (
                    (a + b).normalize(),
                    (b + c).normalize(),
                    (c + a).normalize(),
                );
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    tris
}
