//! BVH library measurement for wavrad's visibility queries (docs/bvh-choice.md).
//!
//! `cargo run --release --manifest-path benches/bvh-choice/Cargo.toml [--features embree] [-- QUERIES]`
//!
//! Every candidate except Embree culls with its own BVH and tests triangles
//! with the same f64 Möller–Trumbore test, so the numbers compare BVH builds
//! and traversals; Embree does everything natively in f32. The obvhs
//! candidate is wavrad's own `visibility::Occluder`, compiled from
//! `crates/wavrad-core/src/visibility.rs`.

#[path = "../../../crates/wavrad-core/src/visibility.rs"]
#[allow(dead_code)]
mod visibility;

use glam::DVec3;
use rayon::prelude::*;
use std::time::Instant;

type Tri = [DVec3; 3];

// ---------------------------------------------------------------- scenes

fn quad(o: DVec3, a: DVec3, b: DVec3, out: &mut Vec<Tri>) {
    out.push([o, o + a, o + a + b]);
    out.push([o, o + a + b, o + b]);
}

/// Axis-aligned unit cube [-1,1]^3 scaled, rotated about y, translated: 12 triangles.
fn cuboid(center: DVec3, half: DVec3, rot_y_deg: f64, out: &mut Vec<Tri>) {
    let (s, c) = rot_y_deg.to_radians().sin_cos();
    let xf = |p: DVec3| {
        let p = p * half;
        center + DVec3::new(c * p.x + s * p.z, p.y, -s * p.x + c * p.z)
    };
    let corners: Vec<DVec3> = (0..8)
        .map(|i| {
            xf(DVec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            ))
        })
        .collect();
    for f in [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ] {
        let [a, b, cc, d] = f.map(|i| corners[i]);
        out.push([a, b, cc]);
        out.push([a, cc, d]);
    }
}

/// Cornell box: 5 walls at ±1 (open at +z), light quad, two boxes: 36 triangles.
fn cornell() -> Vec<Tri> {
    let mut t = Vec::new();
    let v = DVec3::new;
    quad(v(-1., -1., -1.), v(2., 0., 0.), v(0., 0., 2.), &mut t); // floor
    quad(v(-1., 1., -1.), v(0., 0., 2.), v(2., 0., 0.), &mut t); // ceiling
    quad(v(-1., -1., -1.), v(0., 2., 0.), v(2., 0., 0.), &mut t); // back
    quad(v(-1., -1., -1.), v(0., 0., 2.), v(0., 2., 0.), &mut t); // left
    quad(v(1., -1., -1.), v(0., 2., 0.), v(0., 0., 2.), &mut t); // right
    quad(
        v(-0.25, 0.99, -0.25),
        v(0.5, 0., 0.),
        v(0., 0., 0.5),
        &mut t,
    ); // light
    cuboid(v(0.335, -0.7, 0.38), DVec3::splat(0.3), -17.5, &mut t);
    cuboid(v(-0.33, -0.4, -0.28), v(0.3, 0.61, 0.3), 17.5, &mut t);
    t
}

/// Cornell box + a 45k-triangle terrain on the floor + a 55k-triangle sphere.
fn big() -> Vec<Tri> {
    let mut t = cornell();
    let n = 150;
    let h = |i: usize, j: usize| {
        let (x, z) = (
            -1.0 + 2.0 * i as f64 / n as f64,
            -1.0 + 2.0 * j as f64 / n as f64,
        );
        DVec3::new(x, -0.95 + 0.04 * (7.0 * x).sin() * (5.0 * z).cos(), z)
    };
    for i in 0..n {
        for j in 0..n {
            t.push([h(i, j), h(i, j + 1), h(i + 1, j + 1)]);
            t.push([h(i, j), h(i + 1, j + 1), h(i + 1, j)]);
        }
    }
    let (nl, nm) = (150, 184);
    let s = |i: usize, j: usize| {
        let th = std::f64::consts::PI * i as f64 / nl as f64;
        let ph = 2.0 * std::f64::consts::PI * j as f64 / nm as f64;
        DVec3::new(0.1, 0.1, 0.0)
            + 0.45 * DVec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
    };
    for i in 0..nl {
        for j in 0..nm {
            t.push([s(i, j), s(i + 1, j), s(i + 1, j + 1)]);
            t.push([s(i, j), s(i + 1, j + 1), s(i, j + 1)]);
        }
    }
    t
}

// ---------------------------------------------------------------- queries

struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f64 {
        // xorshift64*
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn point_on(&mut self, tris: &[Tri]) -> DVec3 {
        let [a, b, c] = tris[(self.f() * tris.len() as f64) as usize % tris.len()];
        let (mut u, mut v) = (self.f(), self.f());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        a + u * (b - a) + v * (c - a)
    }
}

/// Segments between random points on random triangles (fixed seed).
fn segments(tris: &[Tri], n: usize) -> Vec<(DVec3, DVec3)> {
    let mut r = Rng(0x9E37_79B9_7F4A_7C15);
    (0..n)
        .map(|_| (r.point_on(tris), r.point_on(tris)))
        .collect()
}

// ---------------------------------------------------------------- exact f64 triangle test

#[derive(Clone, Copy)]
struct ETri {
    v0: DVec3,
    e1: DVec3,
    e2: DVec3,
}
impl ETri {
    fn new([a, b, c]: Tri) -> Self {
        ETri {
            v0: a,
            e1: b - a,
            e2: c - a,
        }
    }
    #[inline(always)]
    fn t(&self, o: DVec3, d: DVec3) -> Option<f64> {
        let p = d.cross(self.e2);
        let det = self.e1.dot(p);
        if det == 0.0 {
            return None;
        }
        let inv = 1.0 / det;
        let s = o - self.v0;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(self.e1);
        let v = d.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        Some(self.e2.dot(q) * inv)
    }
}
const EPS: f64 = visibility::SEGMENT_EPSILON;

// ---------------------------------------------------------------- candidates

trait Candidate: Sync {
    /// Open segment, ends excluded by EPS (relative).
    fn occluded(&self, a: DVec3, b: DVec3) -> bool;
    /// Closest hit t in (tmin, inf), and primitive.
    fn closest(&self, o: DVec3, d: DVec3, tmin: f64) -> Option<(f64, u32)>;
}

impl Candidate for visibility::Occluder {
    fn occluded(&self, a: DVec3, b: DVec3) -> bool {
        visibility::Occluder::occluded(self, a, b)
    }
    fn closest(&self, o: DVec3, d: DVec3, tmin: f64) -> Option<(f64, u32)> {
        self.intersect(o, d, tmin, f64::INFINITY)
            .map(|h| (h.t, h.primitive))
    }
}

// --- bvh 0.13 (f64, binary SAH BVH, nalgebra)
mod bvh_crate {
    use super::*;
    use bvh::aabb::{Aabb, Bounded, IntersectsAabb};
    use bvh::bounding_hierarchy::{BHShape, BoundingHierarchy};
    use nalgebra::{Point3, Vector3};

    pub struct Shape {
        tri: ETri,
        lo: Point3<f64>,
        hi: Point3<f64>,
        node: usize,
    }
    impl Bounded<f64, 3> for Shape {
        fn aabb(&self) -> Aabb<f64, 3> {
            Aabb::with_bounds(self.lo, self.hi)
        }
    }
    impl BHShape<f64, 3> for Shape {
        fn set_bh_node_index(&mut self, i: usize) {
            self.node = i;
        }
        fn bh_node_index(&self) -> usize {
            self.node
        }
    }
    /// Slab test restricted to t in [0, tmax].
    struct Seg {
        o: [f64; 3],
        inv: [f64; 3],
        tmax: f64,
    }
    impl IntersectsAabb<f64, 3> for Seg {
        #[inline(always)]
        fn intersects_aabb(&self, b: &Aabb<f64, 3>) -> bool {
            let (mut t0, mut t1) = (0.0f64, self.tmax);
            for k in 0..3 {
                let a = (b.min[k] - self.o[k]) * self.inv[k];
                let c = (b.max[k] - self.o[k]) * self.inv[k];
                t0 = t0.max(a.min(c));
                t1 = t1.min(a.max(c));
            }
            t0 <= t1
        }
    }
    pub struct Bvh {
        bvh: bvh::bvh::Bvh<f64, 3>,
        shapes: Vec<Shape>,
    }
    impl Bvh {
        pub fn new(tris: &[Tri]) -> Self {
            let mut shapes: Vec<Shape> = tris
                .iter()
                .map(|t| {
                    // Padded: zero-thickness boxes (axis-aligned walls) break the slab test.
                    let lo = t[0].min(t[1]).min(t[2]) - DVec3::splat(1e-9);
                    let hi = t[0].max(t[1]).max(t[2]) + DVec3::splat(1e-9);
                    Shape {
                        tri: ETri::new(*t),
                        lo: Point3::new(lo.x, lo.y, lo.z),
                        hi: Point3::new(hi.x, hi.y, hi.z),
                        node: 0,
                    }
                })
                .collect();
            let bvh = bvh::bvh::Bvh::build_par(&mut shapes);
            Bvh { bvh, shapes }
        }
    }
    fn inv(d: DVec3) -> [f64; 3] {
        [1.0 / d.x, 1.0 / d.y, 1.0 / d.z]
    }
    impl Candidate for Bvh {
        fn occluded(&self, a: DVec3, b: DVec3) -> bool {
            let d = b - a;
            let q = Seg {
                o: a.to_array(),
                inv: inv(d),
                tmax: 1.0,
            };
            self.bvh
                .traverse_iterator(&q, &self.shapes)
                .any(|s| matches!(s.tri.t(a, d), Some(t) if t > EPS && t < 1.0 - EPS))
        }
        fn closest(&self, o: DVec3, d: DVec3, tmin: f64) -> Option<(f64, u32)> {
            let ray = bvh::ray::Ray::new(Point3::new(o.x, o.y, o.z), Vector3::new(d.x, d.y, d.z));
            let mut best: Option<(f64, u32)> = None;
            for s in self.bvh.nearest_traverse_iterator(&ray, &self.shapes) {
                if let Some((bt, _)) = best {
                    // Shapes come ordered by box entry distance.
                    if let Some((enter, _)) = ray.intersection_slice_for_aabb(&s.aabb()) {
                        if enter > bt {
                            break;
                        }
                    }
                }
                if let Some(t) = s.tri.t(o, d) {
                    if t > tmin && best.is_none_or(|(bt, _)| t < bt) {
                        // index of the shape = original primitive id
                        let id = (s as *const Shape as usize - self.shapes.as_ptr() as usize)
                            / std::mem::size_of::<Shape>();
                        best = Some((t, id as u32));
                    }
                }
            }
            best
        }
    }
}

// --- parry3d 0.31 (f32 BVH, binned SAH), boxes padded and ray backed off as in visibility.rs
mod parry {
    use super::*;
    use parry3d::bounding_volume::Aabb;
    use parry3d::math::Vector;
    use parry3d::partitioning::{Bvh, BvhBuildStrategy, TraversalAction};
    use parry3d::query::Ray;

    pub struct Parry {
        bvh: Bvh,
        tris: Vec<ETri>,
        slack: f64,
    }
    fn v(p: DVec3) -> Vector {
        Vector::new(p.x as f32, p.y as f32, p.z as f32)
    }
    impl Parry {
        pub fn new(tris: &[Tri]) -> Self {
            let pad = 1e-5 * 2.0;
            let aabbs: Vec<Aabb> = tris
                .iter()
                .map(|t| {
                    let lo = t[0].min(t[1]).min(t[2]) - DVec3::splat(pad);
                    let hi = t[0].max(t[1]).max(t[2]) + DVec3::splat(pad);
                    Aabb::new(v(lo), v(hi))
                })
                .collect();
            Parry {
                bvh: Bvh::from_leaves(BvhBuildStrategy::default(), &aabbs),
                tris: tris.iter().map(|t| ETri::new(*t)).collect(),
                slack: 4.0 * pad,
            }
        }
        fn ray(&self, o: DVec3, d: DVec3, tmax: f64) -> (Ray, f32, f64) {
            let len = d.length();
            let u = d / len;
            (
                Ray::new(v(o - u * self.slack), v(u)),
                ((tmax * len + 2.0 * self.slack) * 1.00001) as f32,
                len,
            )
        }
    }
    impl Candidate for Parry {
        fn occluded(&self, a: DVec3, b: DVec3) -> bool {
            let d = b - a;
            let (ray, tmax, _) = self.ray(a, d, 1.0);
            let mut hit = false;
            self.bvh.traverse(|node| {
                if node.cast_ray(&ray, tmax) == f32::MAX {
                    return TraversalAction::Prune;
                }
                if let Some(i) = node.leaf_data() {
                    if matches!(self.tris[i as usize].t(a, d), Some(t) if t > EPS && t < 1.0 - EPS)
                    {
                        hit = true;
                        return TraversalAction::EarlyExit;
                    }
                }
                TraversalAction::Continue
            });
            hit
        }
        fn closest(&self, o: DVec3, d: DVec3, tmin: f64) -> Option<(f64, u32)> {
            let (ray, tmax, len) = self.ray(o, d, 1e30);
            let best = std::cell::Cell::new(f64::INFINITY);
            let slack = self.slack;
            self.bvh
                .cast_ray(&ray, tmax, |i, _| {
                    let t = self.tris[i as usize].t(o, d)?;
                    if t > tmin && t < best.get() {
                        best.set(t);
                        Some(((t * len + 2.0 * slack) * 1.00001) as f32)
                    } else {
                        None
                    }
                })
                .map(|(i, _)| (best.get(), i))
        }
    }
}

// --- Embree 3 (system library, f32, native triangle tests)
#[cfg(feature = "embree")]
mod embree_c {
    use super::*;
    use cgmath::{Vector3, Vector4};
    use embree::{Device, Geometry, IntersectContext, Ray, RayHit, Scene, TriangleMesh};

    pub struct Embree {
        // Leaked so the committed scene can borrow for 'static.
        scene: embree::CommittedScene<'static>,
    }
    unsafe impl Sync for Embree {}
    unsafe impl Send for Embree {}
    impl Embree {
        pub fn new(tris: &[Tri]) -> Self {
            let device: &'static Device = Box::leak(Box::new(Device::new()));
            let mut mesh = TriangleMesh::unanimated(device, tris.len(), 3 * tris.len());
            {
                let mut vb = mesh.vertex_buffer.map();
                for (i, t) in tris.iter().enumerate() {
                    for k in 0..3 {
                        vb[3 * i + k] =
                            Vector4::new(t[k].x as f32, t[k].y as f32, t[k].z as f32, 0.0);
                    }
                }
            }
            {
                let mut ib = mesh.index_buffer.map();
                for i in 0..tris.len() {
                    let b = 3 * i as u32;
                    ib[i] = Vector3::new(b, b + 1, b + 2);
                }
            }
            let mut g = Geometry::Triangle(mesh);
            g.commit();
            let scene: &'static mut Scene<'static> = Box::leak(Box::new(Scene::new(device)));
            scene.attach_geometry(g);
            let scene: &'static Scene<'static> = scene;
            Embree {
                scene: scene.commit(),
            }
        }
    }
    fn v(p: DVec3) -> Vector3<f32> {
        Vector3::new(p.x as f32, p.y as f32, p.z as f32)
    }
    impl Candidate for Embree {
        fn occluded(&self, a: DVec3, b: DVec3) -> bool {
            let mut ctx = IntersectContext::incoherent();
            let mut ray = Ray::segment(v(a), v(b - a), EPS as f32, (1.0 - EPS) as f32);
            self.scene.occluded(&mut ctx, &mut ray);
            ray.tfar == f32::NEG_INFINITY
        }
        fn closest(&self, o: DVec3, d: DVec3, tmin: f64) -> Option<(f64, u32)> {
            let mut ctx = IntersectContext::incoherent();
            let mut rh = RayHit::new(Ray::segment(v(o), v(d), tmin as f32, f32::INFINITY));
            self.scene.intersect(&mut ctx, &mut rh);
            rh.hit.hit().then(|| (rh.ray.tfar as f64, rh.hit.primID))
        }
    }
}

// ---------------------------------------------------------------- reference

const REFERENCE_QUERIES: usize = 20_000;

/// Brute force over all triangles: (closest t > 1e-6, occluded).
fn brute_force(tris: &[Tri], segs: &[(DVec3, DVec3)]) -> Vec<(Option<f64>, bool)> {
    let et: Vec<ETri> = tris.iter().map(|t| ETri::new(*t)).collect();
    segs.par_iter()
        .map(|&(a, b)| {
            let d = b - a;
            let mut best: Option<(f64, u32)> = None;
            let mut occ = false;
            for (i, t) in et.iter().enumerate() {
                if let Some(t) = t.t(a, d) {
                    occ |= t > EPS && t < 1.0 - EPS;
                    if t > 1e-6 && best.is_none_or(|(bt, _)| t < bt) {
                        best = Some((t, i as u32));
                    }
                }
            }
            (best.map(|b| b.0), occ)
        })
        .collect()
}

// ---------------------------------------------------------------- timing

struct Row {
    scene: &'static str,
    lib: &'static str,
    build_ms: f64,
    occ_1t: f64,
    occ_mt: f64,
    hit_1t: f64,
    hit_mt: f64,
    occluded: usize,
    hits: usize,
    /// Closest-hit primitive disagreements with the reference (first candidate).
    mismatches: usize,
}

fn best_of<T>(reps: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..reps {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (best, out.unwrap())
}

fn measure(
    scene: &'static str,
    lib: &'static str,
    tris: &[Tri],
    build: &dyn Fn(&[Tri]) -> Box<dyn Candidate>,
    segs: &[(DVec3, DVec3)],
    reference: &[(Option<f64>, bool)],
) -> Row {
    let t = Instant::now();
    let c = build(tris);
    let build_ms = t.elapsed().as_secs_f64() * 1e3;
    let c = &*c;
    let n = segs.len() as f64;
    let (occ1, occluded) = best_of(2, || {
        segs.iter().filter(|(a, b)| c.occluded(*a, *b)).count()
    });
    let (occm, _) = best_of(2, || {
        segs.par_iter().filter(|(a, b)| c.occluded(*a, *b)).count()
    });
    let closest = |&(a, b): &(DVec3, DVec3)| c.closest(a, b - a, 1e-6).map(|h| h.1);
    let (hit1, prims) = best_of(2, || segs.iter().map(closest).collect::<Vec<_>>());
    let (hitm, _) = best_of(2, || segs.par_iter().map(closest).collect::<Vec<_>>());
    let hits = prims.iter().filter(|p| p.is_some()).count();
    let mismatches = reference
        .iter()
        .zip(segs)
        .filter(|((rt, o), (a, b))| {
            let t = c.closest(*a, *b - *a, 1e-6).map(|h| h.0);
            let same = match (rt, t) {
                (Some(x), Some(y)) => (x - y).abs() <= 1e-6 * x.max(1.0),
                (None, None) => true,
                _ => false,
            };
            !same || *o != c.occluded(*a, *b)
        })
        .count();
    let r = Row {
        scene,
        lib,
        build_ms,
        occ_1t: n / occ1 / 1e6,
        occ_mt: n / occm / 1e6,
        hit_1t: n / hit1 / 1e6,
        hit_mt: n / hitm / 1e6,
        occluded,
        hits,
        mismatches,
    };
    println!(
        "| {} | {} | {:.1} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {} | {} |",
        r.scene,
        r.lib,
        r.build_ms,
        r.occ_1t,
        r.occ_mt,
        r.hit_1t,
        r.hit_mt,
        r.occluded,
        r.hits,
        r.mismatches
    );
    r
}

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().expect("query count"))
        .unwrap_or(1_000_000);
    println!(
        "threads: {}, queries per measurement: {n}, best of 2",
        rayon::current_num_threads()
    );
    type Builder = Box<dyn Fn(&[Tri]) -> Box<dyn Candidate>>;
    let mut libs: Vec<(&'static str, Builder)> = vec![
        (
            "obvhs 0.4 (wavrad Occluder)",
            Box::new(|t| Box::new(visibility::Occluder::new(t))),
        ),
        (
            "bvh 0.13 (f64)",
            Box::new(|t| Box::new(bvh_crate::Bvh::new(t))),
        ),
        (
            "parry3d 0.31 (f32 Bvh)",
            Box::new(|t| Box::new(parry::Parry::new(t))),
        ),
    ];
    #[cfg(feature = "embree")]
    libs.push((
        "Embree 3 (native f32)",
        Box::new(|t| Box::new(embree_c::Embree::new(t))),
    ));
    println!();
    println!("| scene | library | build ms | occlusion Mq/s 1 thread | occlusion Mq/s all threads | closest-hit Mq/s 1 thread | closest-hit Mq/s all threads | occluded | hits | disagreements with brute force (first 20k: occluded, or closest t off by >1e-6) |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    for (scene, tris) in [("Cornell box", cornell()), ("100k", big())] {
        let scene: &'static str = if scene == "100k" {
            Box::leak(format!("big ({} tris)", tris.len()).into_boxed_str())
        } else {
            Box::leak(format!("{scene} ({} tris)", tris.len()).into_boxed_str())
        };
        let segs = segments(&tris, n);
        let reference = brute_force(&tris, &segs[..REFERENCE_QUERIES.min(n)]);
        for (lib, build) in &mut libs {
            rows.push(measure(scene, lib, &tris, build, &segs, &reference));
        }
    }
    let _ = rows;
}
