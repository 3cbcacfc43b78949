//! Final gather over the solution at a visible point x (one bounce evaluated
//! per point instead of per element):
//!
//! * direct light, `ρ · Σ_e Le_e · ∫_e V(x,y) cosθ_x cosθ_y / (π r²) dA_y`:
//!   Lambert's closed-form point-to-polygon factor less what shadow rays,
//!   drawn roughly in proportion to the kernel, find hidden — what a Haar
//!   solution resolves worst (sharp shadows, the 1/r² falloff near lights);
//! * indirect light, `ρ/N · Σ L_solution(y_i)` over N cosine-distributed rays
//!   hitting points y_i, with the solution's radiance there less its emission
//!   (already counted as direct).
//!
//! ρ is the albedo of the surface's Lambertian lobe: a diffuse surface's, or
//! ρ_d of a glossy one whose BRDF has such a lobe besides others (Ward's),
//! whose other lobes [`glossy_radiance`] gathers through the BRDF.
//!
//! Cosines and the BRDF's frame are the point's shading normal's
//! ([`GatherPoint::normal`]; a curved surface's, [`crate::scene::Surface::shading_normal`]),
//! as Mitsuba's shading frame; light from below the surface's own plane is
//! left out, and no ray starts into the surface, so that shading normals
//! never let light leak through it.

use crate::geometry::tracing::{SceneTracer, SurfaceHit};
use crate::kernel::form_factor::{front_part, point_to_polygon};
use crate::kernel::lights;
use crate::render::discrete::SurfaceDistribution;
use crate::render::emitters::{ConeSample, Emitter, Emitters, SphereEmitter};
use crate::render::link_guide::LinkedSources;
use crate::render::mirror::MirrorImages;
use crate::sampling::{Bilinear, Samples, Stream};
use crate::scene::brdf::{Brdf, BrdfModel};
use crate::scene::{Patch, Rgb, Scene};
use glam::{DVec2, DVec3};

/// A visible point where light is gathered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GatherPoint {
    /// Surface the point is on.
    pub surface: u32,
    /// The point, where its rays start: on the surface, or on the exact
    /// curved shape the surface tessellates, above it
    /// ([`crate::geometry::analytic::ExactHit::convex_side`]).
    pub position: DVec3,
    /// Shading normal of the surface at the point ([`crate::scene::Surface::shading_normal`];
    /// the front normal of a flat one).
    pub normal: DVec3,
    /// Where its estimates draw their sample points.
    pub samples: Samples,
    /// For a point on the exact curved shape, the surfaces of its
    /// tessellation (first, past the last), which its rays pass through
    /// ([`GatherPoint::on_shape`]); `None` for a point of the surface.
    pub shape: Option<(u32, u32)>,
}

impl GatherPoint {
    /// The point `position` of `surface` in `scene`, with its shading
    /// normal, drawing `samples`.
    pub fn on(scene: &Scene, surface: u32, position: DVec3, samples: Samples) -> GatherPoint {
        let s = &scene.surfaces[surface as usize];
        GatherPoint {
            surface,
            position,
            normal: s.shading_normal(s.patch.param_of(position)),
            samples,
            shape: None,
        }
    }

    /// True when light can arrive at the point from direction `wi`: above
    /// its shading normal's plane and the surface's own (Mitsuba's rule
    /// for shading normals, so that none leaks through the surface).
    fn receives(&self, scene: &Scene, wi: DVec3) -> bool {
        self.normal.dot(wi) > 0.0 && self.front(scene).dot(wi) > 0.0
    }

    /// Whether a shadow ray from the point passes through surface `s`: its
    /// own, or one of the curved shape's it lies on ([`GatherPoint::on_shape`]).
    fn passes(&self, s: u32) -> bool {
        s == self.surface || self.on_shape(s)
    }

    /// Whether surface `s` tessellates the curved shape the point lies on
    /// exactly, on its convex side: the point's rays, leaving that side,
    /// never meet the shape, and pass through its tessellation, which
    /// reaches out past the shape at its vertices.
    pub fn on_shape(&self, s: u32) -> bool {
        self.shape
            .is_some_and(|(first, end)| (first..end).contains(&s))
    }

    /// The geometric normal at the point: its surface's front, or the
    /// exact shape's normal on a curved shape ([`GatherPoint::shape`]).
    fn front(&self, scene: &Scene) -> DVec3 {
        match self.shape {
            Some(_) => self.normal,
            None => scene.surfaces[self.surface as usize].patch.normal(),
        }
    }
}

/// The least density, relative to its largest, at which a final gather's
/// shadow rays draw points of an emitter ([`Bilinear::fit`]): parts the
/// corners' fit says send nothing are still drawn now and then.
const KERNEL_FLOOR: f64 = 0.02;

/// Rays towards the sky per shadow ray of a final gather: the sky fills the
/// hemisphere that an emitter's shadow rays only cross.
pub const SKY_RAYS_PER_SHADOW_RAY: u32 = 4;

/// Direct radiance reflected at `point` towards any direction from the
/// `emitters` and the scene's lights that are not surfaces: a shadow ray
/// to each point, spot and directional light (exact: ρ·E/π),
/// [`SKY_RAYS_PER_SHADOW_RAY`] × `grid` × `grid` rays towards the sky
/// (drawn as [`crate::scene::Light::incident`] draws them); for the emitters,
/// `grid` × `grid` shadow rays in all, each to a point of an
/// emitter drawn from their distribution (the point's own surface left
/// out), so that the cost does not grow with their number. An emitter e
/// drawn n_e of the N times gives `ρ · Le_e · I_e · n_e / (N · P(e))`,
/// where `I_e`, the integral of the visible kernel `V(x,y) cosθ_x cosθ_y /
/// (π r²)` over the emitter, is Lambert's closed-form point-to-polygon
/// factor F of the whole emitter less the kernel its shadow rays find
/// hidden, estimated by importance: their points are drawn from a bilinear
/// fit of the kernel over the emitter's parameter square ([`Bilinear`]),
/// each hidden one counting its kernel over its density. Unbiased: a
/// penumbra's near side, where the kernel is larger, counts for more than
/// its far side, as in the integral (F times the share of rays unoccluded
/// is not); a point that sees the whole emitter gets F exactly, and one
/// that sees none of it nothing, up to the fit's error (about zero: an
/// estimate there may be slightly negative). A lone emitter gets every ray.
pub fn direct_radiance(
    scene: &Scene,
    tracer: &SceneTracer,
    emitters: &Emitters,
    point: &GatherPoint,
    grid: u32,
) -> Rgb {
    let GatherPoint {
        surface,
        position: x,
        normal,
        samples,
        ..
    } = *point;
    let rho = lambertian_albedo(scene, surface, x);
    let n = grid * grid;
    let mut drawn: Vec<(Emitter, DVec2, f64)> = (0..n)
        .filter_map(|k| emitters.sample(samples.point(Stream::Shadow, n, k), surface))
        .collect();
    drawn.sort_unstable_by_key(|&(e, ..)| e);
    let mut out = Rgb::ZERO;
    for rays in drawn.chunk_by(|a, b| a.0 == b.0) {
        let (emitter, _, chosen) = rays[0];
        let share = rays.len() as f64 / (f64::from(n) * chosen);
        let e = match emitter {
            Emitter::Surface(e) => e,
            Emitter::Sphere(k) => {
                let sphere = emitters.sphere(k);
                let uv = rays.iter().map(|&(_, uv, _)| uv);
                out += rho
                    * sphere.emission
                    * (sphere_factor(scene, tracer, point, sphere, uv) * share);
                continue;
            }
        };
        let light = &scene.surfaces[e as usize];
        let on_light = |uv: DVec2| light.patch.point_at(light.patch.square_to_param(uv));
        if !lit_by(tracer, &light.patch, x) {
            continue;
        }
        let skip = |prim: u32| {
            let s = tracer.surface_of(prim);
            s == e || point.passes(s)
        };
        // The point-to-area kernel cosθ_x cosθ_y / (π r²) of light the
        // point receives (none from behind its planes).
        let kernel = |y: DVec3| {
            let d = y - x;
            let r2 = d.length_squared();
            let (cos_x, cos_y) = (normal.dot(d), -light.patch.normal().dot(d));
            match point.receives(scene, d) && cos_y > 0.0 && r2 > 0.0 {
                true => cos_x * cos_y / (std::f64::consts::PI * r2 * r2),
                false => 0.0,
            }
        };
        let warp = Bilinear::fit(
            [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .map(|(u, v)| kernel(on_light(DVec2::new(u, v)))),
            KERNEL_FLOOR,
        );
        let hidden: f64 = (rays.iter())
            .map(|&(_, xi, _)| {
                let uv = warp.sample(xi);
                let y = on_light(uv);
                let k = kernel(y);
                match k > 0.0 && tracer.occluder.occluded_except(x, y, skip) {
                    true => k / warp.pdf(uv),
                    false => 0.0,
                }
            })
            .sum();
        let unoccluded = shaded_factor(x, (normal, point.front(scene)), &light.patch);
        let light_from = unoccluded - hidden * light.patch.area() / rays.len() as f64;
        out += rho * light.emission * (light_from * share);
    }
    if !scene.lights.is_empty() {
        let rays = n * SKY_RAYS_PER_SHADOW_RAY;
        let sky: Vec<DVec2> = (0..rays)
            .map(|k| samples.point(Stream::Shadow, rays, k))
            .collect();
        let at = (surface, x, normal);
        let leaving = (point.front(scene), |s| point.on_shape(s));
        let e = lights::irradiance(scene, tracer, at, leaving, &sky);
        out += rho * e * std::f64::consts::FRAC_1_PI;
    }
    out
}

/// The form factor of the emitting `sphere` at `point`, the integral of
/// `V cosθ / π` over the solid angle it subtends, estimated from one cone
/// sample ([`SphereEmitter::sample`]) per `uv`: each sample that the point
/// receives and sees counts `cosθ / (π pdf)`. A shadow ray passes through
/// the sphere's own tessellation, which the exact sphere's near side
/// hides.
fn sphere_factor(
    scene: &Scene,
    tracer: &SceneTracer,
    point: &GatherPoint,
    sphere: &SphereEmitter,
    uv: impl ExactSizeIterator<Item = DVec2>,
) -> f64 {
    let count = uv.len().max(1) as f64;
    let seen: f64 = uv
        .filter_map(|uv| seen_on_sphere(scene, tracer, point, sphere, uv))
        .map(|sample| point.normal.dot(sample.direction) / (std::f64::consts::PI * sample.pdf))
        .sum();
    seen / count
}

/// How much of the emitters' light a point receives unoccluded
/// ([`emitters_seen`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EmittersSeen {
    /// All of it: [`direct_radiance`] is Lambert's closed form, exactly.
    Whole,
    /// None of it: an umbra.
    Nothing,
    /// Some: a penumbra, where [`direct_radiance`]'s shadow rays vary.
    Part,
}

/// Most emitters [`emitters_seen`] tests, with a shadow ray to each of
/// their corners and centres.
pub const MAX_EMITTERS_SEEN: usize = 8;

/// Whether `point` receives the light of the `emitters` whole, not at all
/// or in part, tested by a shadow ray to each corner and the centre of
/// every emitter that sends it light (an occluder that hides none of those
/// points from it, a thin one across the middle of an emitter, is missed).
/// `None` where that is not known: the scene has lights that are not
/// surfaces (points, spots, the sky), or more than [`MAX_EMITTERS_SEEN`]
/// emitters.
pub fn emitters_seen(
    scene: &Scene,
    tracer: &SceneTracer,
    emitters: &Emitters,
    point: &GatherPoint,
) -> Option<EmittersSeen> {
    if !scene.lights.is_empty() || emitters.surfaces().len() > MAX_EMITTERS_SEEN {
        return None;
    }
    let (mut seen, mut hidden) = (false, false);
    for &e in emitters.surfaces().iter().filter(|&&e| e != point.surface) {
        let light = &scene.surfaces[e as usize];
        if !lit_by(tracer, &light.patch, point.position) {
            continue;
        }
        let skip = |prim: u32| {
            let s = tracer.surface_of(prim);
            s == e || point.passes(s)
        };
        for (u, v) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)] {
            let y = light
                .patch
                .point_at(light.patch.square_to_param(DVec2::new(u, v)));
            let d = y - point.position;
            if !point.receives(scene, d) || light.patch.normal().dot(d) >= 0.0 {
                continue; // sends the point no light
            }
            match tracer.occluder.occluded_except(point.position, y, skip) {
                true => hidden = true,
                false => seen = true,
            }
        }
    }
    Some(match (seen, hidden) {
        (_, false) => EmittersSeen::Whole,
        (false, true) => EmittersSeen::Nothing,
        (true, true) => EmittersSeen::Part,
    })
}

/// Whether point `x` is in front of the emitter `light`'s plane, not
/// behind it or pressed against it (the back of a two-sided emitter, whose
/// closed form would count the emitter's own plane).
fn lit_by(tracer: &SceneTracer, light: &Patch, x: DVec3) -> bool {
    let on_light = light.point_at(light.square_to_param(DVec2::ZERO));
    light.normal().dot(x - on_light) > tracer.occluder.contact_distance()
}

/// Lambert's point-to-polygon factor ([`point_to_polygon`]) of `patch` at
/// `x` for a surface whose shading normal there is `normal` and whose own
/// normal is `front`: the cosine the shading normal's, over the part of
/// `patch` above both planes.
fn shaded_factor(x: DVec3, (normal, front): (DVec3, DVec3), patch: &Patch) -> f64 {
    let vertices = patch.vertices();
    if normal == front {
        return point_to_polygon(x, normal, &vertices, patch.normal());
    }
    let above = front_part(&vertices, x, front);
    if above.len() < 3 {
        return 0.0;
    }
    point_to_polygon(x, normal, &above, patch.normal())
}

/// Where a final gather looks for concentrated light besides its cosine
/// rays: `count` points by area on the `bright` surfaces together (glossy
/// ones, whose reflected light is concentrated, and unusually bright diffuse
/// ones: a small mirror-like surface lighting a wall is found by few cosine
/// rays), each drawn from one surface picked by their distribution, and as
/// many through the `mirrors` together (the specular reflection points of
/// an emitter on a planar glossy surface); so a gather's cost does not grow
/// with their number. And `linked_count` points on the source elements
/// of the point's links, drawn by the light each brings.
#[derive(Debug, Clone, Copy)]
pub struct GatherSources<'a> {
    /// Surfaces sampled by area.
    pub bright: &'a SurfaceDistribution,
    /// Emitters' images through glossy surfaces.
    pub mirrors: &'a MirrorImages,
    /// Samples of the bright surfaces.
    pub bright_count: u32,
    /// Samples of the mirror images.
    pub mirror_count: u32,
    /// The source elements of the links into the point's elements.
    pub linked: &'a LinkedSources,
    /// Samples of them.
    pub linked_count: u32,
}

/// What [`indirect_radiance`] finds at a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Indirect {
    /// The reflected radiance.
    pub radiance: Rgb,
    /// The reflected radiance per unit of the point's Lambertian albedo
    /// (the irradiance over π): what another albedo reflects of the same
    /// light, divided by it.
    pub per_albedo: Rgb,
    /// Harmonic mean of the distances at which the cosine rays meet a
    /// surface (infinite if none does): how far from the point the light
    /// it gathers can be taken as varying slowly, the radius of Ward,
    /// Rubinstein & Clear's irradiance cache (SIGGRAPH 1988, eq. 2).
    pub reach: f64,
}

/// Indirect radiance reflected at the diffuse `point` from the solution,
/// each sample looking up `outgoing(surface, point)`, the solution's radiance
/// leaving the point it reaches minus its emission: `rays` cosine-distributed
/// gather rays (stratified) and the `sources`' samples, combined with the
/// balance heuristic (Veach 1997).
pub fn indirect_radiance(
    scene: &Scene,
    tracer: &SceneTracer,
    point: &GatherPoint,
    rays: u32,
    sources: GatherSources,
    outgoing: impl Fn(u32, DVec3) -> Rgb,
) -> Indirect {
    let GatherPoint {
        surface,
        position: x,
        normal,
        samples,
        ..
    } = *point;
    let GatherSources {
        bright,
        mirrors,
        bright_count,
        mirror_count,
        linked,
        linked_count,
    } = sources;
    let rho = lambertian_albedo(scene, surface, x);
    let (t, b) = orthonormal_basis(normal);
    let (n_cos, n_bright) = (f64::from(rays), f64::from(bright_count));
    let n_mirror = f64::from(mirror_count);
    let n_linked = f64::from(linked_count);
    // Σ_k n_k·p_k(wi) over the strategies that can pick direction `wi`,
    // whose ray first meets surface q at y: each looks at q alone.
    let density = |q: u32, wi: DVec3, y: DVec3| {
        let mut d = n_cos * normal.dot(wi) * std::f64::consts::FRAC_1_PI;
        let patch = &scene.surfaces[q as usize].patch;
        let chosen = bright.probability(q, surface);
        if chosen > 0.0 {
            d += n_bright * chosen * area_pdf(patch, wi, (y - x).length_squared());
        }
        if linked_count > 0 {
            d += n_linked * linked.pdf((q, patch), x, y);
        }
        d + n_mirror * mirrors.pdf(surface, x, (wi, q, (y - x).length()))
    };
    let mut sum = Rgb::ZERO;
    // f·cos/Σ n_k·p_k with f = ρ/π (ρ applied at the end).
    let mut add = |q: u32, wi: DVec3, y: DVec3| {
        let weight = normal.dot(wi) * std::f64::consts::FRAC_1_PI / density(q, wi, y);
        sum += outgoing(q, y) * weight;
    };
    for k in 0..bright_count {
        let u = samples.point(Stream::Bright, bright_count, k);
        let Some((q, uv, _)) = bright.sample(u, surface) else {
            break;
        };
        if let Some((wi, y, _)) = area_sample(scene, tracer, point, q, uv) {
            add(q, wi, y);
        }
    }
    for k in 0..linked_count {
        let u = samples.point(Stream::Linked, linked_count, k);
        let Some((q, y)) = linked.sample(scene, u) else {
            break;
        };
        let wi = (y - x).normalize();
        let front = scene.surfaces[q as usize].patch.normal().dot(wi) < 0.0;
        if q != surface && front && sees(scene, tracer, point, q, y) {
            add(q, wi, y);
        }
    }
    for k in 0..mirror_count {
        let u = samples.point(Stream::Mirror, mirror_count, k);
        let Some((m, uv, _)) = mirrors.sample(u, surface) else {
            break;
        };
        let patch = &scene.surfaces[m.surface as usize].patch;
        let Some((wi, y, _)) = m.sample(patch, x, uv) else {
            continue;
        };
        if sees(scene, tracer, point, m.surface, y) {
            add(m.surface, wi, y);
        }
    }
    let mut inverse_distances = 0.0;
    for k in 0..rays {
        // Cosine-weighted (Malley).
        let local = crate::scene::brdf::cosine_hemisphere(samples.point(Stream::Cosine, rays, k));
        let dir = local.x * t + local.y * b + local.z * normal;
        if !point.receives(scene, dir) {
            continue; // below the surface: no light, and no ray into it
        }
        let Some(hit) = tracer.trace_through(x, dir, (1e-7, f64::INFINITY), |s| point.on_shape(s))
        else {
            continue;
        };
        inverse_distances += 1.0 / hit.distance;
        if hit.surface == surface {
            continue;
        }
        let hit_patch = &scene.surfaces[hit.surface as usize].patch;
        if hit_patch.normal().dot(dir) >= 0.0 {
            continue; // back of a one-sided surface: black
        }
        add(hit.surface, dir, hit.position);
    }
    Indirect {
        radiance: rho * sum,
        per_albedo: sum,
        reach: f64::from(rays) / inverse_distances,
    }
}

/// Solid-angle density of picking a point of `patch` uniformly by area,
/// seen along `wi` at squared distance `r2`.
fn area_pdf(patch: &Patch, wi: DVec3, r2: f64) -> f64 {
    let cos_y = -patch.normal().dot(wi);
    if cos_y <= 0.0 {
        return f64::INFINITY;
    }
    r2 / (cos_y * patch.area())
}

/// The point of surface `q` at `uv` ∈ \[0,1)² (uniform by area), if
/// `point` sees it in front of itself: (direction to it, the point,
/// solid-angle pdf).
fn area_sample(
    scene: &Scene,
    tracer: &SceneTracer,
    point: &GatherPoint,
    q: u32,
    uv: DVec2,
) -> Option<(DVec3, DVec3, f64)> {
    let patch = &scene.surfaces[q as usize].patch;
    let x = point.position;
    let y = patch.point_at(patch.square_to_param(uv));
    let wi = (y - x).normalize();
    let p = area_pdf(patch, wi, (y - x).length_squared());
    (p.is_finite() && sees(scene, tracer, point, q, y)).then_some((wi, y, p))
}

/// Whether `point` sees the point `y` of surface `q` in front of itself
/// (the shadow ray ignores both surfaces).
fn sees(scene: &Scene, tracer: &SceneTracer, point: &GatherPoint, q: u32, y: DVec3) -> bool {
    sees_past(scene, tracer, point, q..q + 1, y)
}

/// The cone sample of the emitting `sphere` that `uv` picks from `point`
/// ([`SphereEmitter::sample`]), if the point sees it in front of itself
/// (the shadow ray passing through the sphere's tessellation).
fn seen_on_sphere(
    scene: &Scene,
    tracer: &SceneTracer,
    point: &GatherPoint,
    sphere: &SphereEmitter,
    uv: DVec2,
) -> Option<ConeSample> {
    let sample = sphere.sample(point.position, uv)?;
    let past = sphere.surfaces.clone();
    sees_past(scene, tracer, point, past, sample.position).then_some(sample)
}

/// Whether `point` sees `y` in front of itself, the shadow ray passing
/// through the surfaces `past` and the point's own.
fn sees_past(
    scene: &Scene,
    tracer: &SceneTracer,
    point: &GatherPoint,
    past: std::ops::Range<u32>,
    y: DVec3,
) -> bool {
    let x = point.position;
    let skip = |prim: u32| {
        let s = tracer.surface_of(prim);
        past.contains(&s) || point.passes(s)
    };
    point.receives(scene, y - x) && !tracer.occluder.occluded_except(x, y, skip)
}

/// Radiance the BRDF `brdf` reflects at the glossy point `point` towards the
/// world direction `wo` (its surface's BRDF, or only some of its lobes;
/// emission not included): light straight from the `emitters` by light
/// sampling (each sample on an emitter drawn from their distribution) and
/// BRDF sampling combined with the balance heuristic (Veach 1997), from
/// the delta lights exactly (a shadow ray each), from the sky by the BRDF
/// samples that leave the scene, and the
/// rest of the solution by BRDF sampling, each sampled direction looking up
/// `outgoing(surface, point)`, the solution's radiance leaving the point
/// hit towards `point`. `grid` × `grid` light samples in all and as many
/// BRDF samples.
pub fn glossy_radiance(
    scene: &Scene,
    tracer: &SceneTracer,
    emitters: &Emitters,
    point: &GatherPoint,
    (brdf, wo): (&Brdf, DVec3),
    grid: u32,
    outgoing: impl Fn(u32, DVec3) -> Rgb,
) -> Rgb {
    let GatherPoint {
        surface,
        position: x,
        samples: sample_points,
        ..
    } = *point;
    let frame = scene.surfaces[surface as usize].frame_at(point.normal);
    let wo_local = frame.to_local(wo);
    if wo_local.z <= 0.0 {
        return Rgb::ZERO;
    }
    let mut out = Rgb::ZERO;
    let samples = grid * grid;
    let n = f64::from(samples.max(1));
    // Light sampling.
    for k in 0..samples {
        let u = sample_points.point(Stream::Light, samples, k);
        let Some((emitter, uv, chosen)) = emitters.sample(u, surface) else {
            break;
        };
        let seen = match emitter {
            Emitter::Surface(e) => area_sample(scene, tracer, point, e, uv)
                .map(|(wi, _, p)| (wi, p, scene.surfaces[e as usize].emission)),
            Emitter::Sphere(k) => {
                let sphere = emitters.sphere(k);
                seen_on_sphere(scene, tracer, point, sphere, uv)
                    .map(|sample| (sample.direction, sample.pdf, sphere.emission))
            }
        };
        let Some((wi, p_solid_angle, emission)) = seen else {
            continue;
        };
        let p_light = chosen * p_solid_angle;
        let wi_local = frame.to_local(wi);
        let f = brdf.eval(wo_local, wi_local);
        let p_brdf = brdf.pdf(wo_local, wi_local);
        let w = p_light / (p_light + p_brdf) * wi_local.z / p_light / n;
        out += f * w * emission;
    }
    // The delta lights, exactly.
    let at = (surface, x, point.normal);
    let passes = |s| point.on_shape(s);
    let leaving = (point.front(scene), passes);
    lights::visible_incidents_shaded(scene, tracer, at, leaving, &[], |_, incident| {
        out += brdf.eval(wo_local, frame.to_local(incident.direction)) * incident.irradiance;
    });
    // BRDF sampling: emitters (weighted against light sampling) and the rest
    // of the solution.
    for k in 0..samples {
        let u = sample_points.point(Stream::Brdf, samples, k);
        let lobe = sample_points.third(Stream::Brdf, samples, k);
        let Some(sample) = brdf.sample(wo_local, u, lobe) else {
            continue;
        };
        let wi = frame.to_world(sample.direction);
        if !point.receives(scene, wi) {
            continue; // below the surface: no light, and no ray into it
        }
        let hit = tracer.trace_through(x, wi, (1e-7, f64::INFINITY), passes);
        // A sphere light is met where its exact sphere is, as its light
        // samples are: before what else the ray meets, or where it meets
        // its tessellation (whose vertices reach outside it); a ray that
        // meets the tessellation alone passes the sphere by.
        let on_sphere =
            |h: &SurfaceHit| matches!(emitters.of_surface(h.surface), Emitter::Sphere(_));
        let far = hit
            .filter(|h| !on_sphere(h))
            .map_or(f64::INFINITY, |h| h.distance);
        if let Some(k) = emitters.sphere_met(x, wi, far, surface) {
            let sphere = emitters.sphere(k);
            let p_light = emitters.probability(Emitter::Sphere(k), surface) * sphere.pdf(x, wi);
            let reflected = match hit {
                Some(h) if emitters.of_surface(h.surface) == Emitter::Sphere(k) => {
                    (outgoing(h.surface, h.position) - sphere.emission).map(|x| x.max(0.0))
                }
                _ => Rgb::ZERO,
            };
            let emitted = sphere.emission * (sample.pdf / (p_light + sample.pdf));
            out += sample.weight * (emitted + reflected) / n;
            continue;
        }
        let Some(hit) = hit.filter(|h| !on_sphere(h)) else {
            if hit.is_none() {
                out += sample.weight * scene.sky_radiance(wi) / n;
            }
            continue;
        };
        let q = &scene.surfaces[hit.surface as usize];
        if hit.surface == surface || q.patch.normal().dot(wi) >= 0.0 {
            continue; // itself, or the back of a one-sided surface: black
        }
        let l = outgoing(hit.surface, hit.position);
        let chosen = emitters.probability(Emitter::Surface(hit.surface), surface);
        let emitted_weight = if chosen > 0.0 {
            let p_light = chosen * area_pdf(&q.patch, wi, (hit.position - x).length_squared());
            sample.pdf / (p_light + sample.pdf)
        } else {
            1.0
        };
        let reflected = (l - q.emission).map(|x| x.max(0.0));
        out += sample.weight * (q.emission * emitted_weight + reflected) / n;
    }
    out
}

/// The albedo of the surface's Lambertian lobe at `x` ([`Scene::lambertian_at`]:
/// its texture there, if it has one): what the diffuse gathers above
/// reflect (black for a model without one, which is gathered through its
/// whole BRDF instead).
fn lambertian_albedo(scene: &Scene, surface: u32, x: DVec3) -> Rgb {
    let patch = &scene.surfaces[surface as usize].patch;
    scene
        .lambertian_at(surface as usize, patch.param_of(x))
        .unwrap_or(Rgb::ZERO)
}

/// Two unit vectors completing `n` to an orthonormal basis (Duff et al. 2017).
fn orthonormal_basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Patch, Surface};
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn basis_is_orthonormal() {
        for n in [DVec3::Z, -DVec3::Z, DVec3::new(0.3, -0.5, 0.8).normalize()] {
            let (t, b) = orthonormal_basis(n);
            assert!(
                t.dot(b).abs() < 1e-12
                    && t.dot(n).abs() < 1e-12
                    && (t.length() - 1.0).abs() < 1e-12
            );
            assert!((t.cross(b) - n).length() < 1e-12);
        }
    }

    #[test]
    fn indirect_gather_of_a_uniform_enclosure_is_rho_times_its_radiance() {
        // Inside a closed box whose walls leave radiance 2, a point reflects
        // ρ·2 whatever direction the gather rays take.
        let walls: Vec<Surface> = crate::testing::inward_box(DVec3::ZERO, DVec3::ONE)
            .into_iter()
            .map(|patch| Surface {
                name: "wall".into(),
                patch,
                brdf: crate::scene::brdf::Brdf::diffuse(Rgb::splat(0.5)),
                emission: Rgb::ZERO,
                texture: None,
                shading: None,
            })
            .collect();
        let scene = Scene::from_surfaces(walls);
        let tracer = SceneTracer::new(&scene);
        let x = scene.surfaces[0].patch.point_at(glam::DVec2::new(0.3, 0.6));
        let n = scene.surfaces[0].patch.normal();
        let point = GatherPoint {
            surface: 0,
            position: x,
            normal: n,
            samples: Samples::Hashed(3),
            shape: None,
        };
        let sources = GatherSources {
            bright: &SurfaceDistribution::default(),
            mirrors: &MirrorImages::default(),
            bright_count: 1,
            mirror_count: 1,
            linked: &LinkedSources::default(),
            linked_count: 0,
        };
        let l = indirect_radiance(&scene, &tracer, &point, 64, sources, |_, _| Rgb::splat(2.0));
        assert!((l.radiance[0] - 1.0).abs() < 1e-12, "{}", l.radiance[0]);
    }

    /// A wall point facing a sharp glossy floor lit from above by two
    /// lights, and a small panel: light leaves the floor in a bump where it
    /// mirrors the lights towards the point, and the panel evenly. Cosine
    /// rays, area samples of the floor, the panel and the wall itself (never
    /// drawn, as the wall cannot light itself) from one distribution, and
    /// the lights' mirror images, combined, must integrate it as a fine
    /// midpoint rule over the floor and the panel does; the images must cut
    /// the noise.
    #[test]
    fn mirror_and_area_samples_leave_the_gather_unbiased() {
        let mut scene = crate::testing::mirror_floor_and_light();
        let square = |origin: DVec3, edge_s: DVec3, edge_t: DVec3| Patch::Parallelogram {
            origin,
            edge_s,
            edge_t,
        };
        let wall = square(DVec3::new(1.2, 0.0, 0.0), DVec3::Z, DVec3::Y);
        let panel = square(DVec3::new(0.0, 0.2, 0.1), DVec3::Y * 0.6, DVec3::Z * 0.4);
        let light = square(DVec3::new(0.1, 0.6, 0.9), DVec3::Y * 0.2, DVec3::X * 0.2);
        scene.surfaces.push(crate::testing::grey(wall));
        scene.surfaces.push(crate::testing::grey(panel));
        scene.surfaces.push(Surface {
            emission: Rgb::splat(3.0),
            ..crate::testing::grey(light)
        });
        let tracer = SceneTracer::new(&scene);
        let x = DVec3::new(1.2, 0.5, 0.4);
        let normal = scene.surfaces[2].patch.normal();
        assert!((normal + DVec3::X).length() < 1e-12);
        assert!((scene.surfaces[3].patch.normal() - DVec3::X).length() < 1e-12);
        // The light's centre mirrored through the floor, seen from x, is
        // at (0.986, 0.5, 0): the bump sits where the floor reflects it.
        let centre = DVec3::new(0.95, 0.5, 0.0);
        let bump = |y: DVec3| (-(y - centre).length_squared() / 0.005).exp();
        let outgoing = |q: u32, y: DVec3| {
            Rgb::splat(match q {
                0 => bump(y),
                3 => 0.2,
                _ => 0.0,
            })
        };
        let bright = SurfaceDistribution::new(vec![(3, 0.5), (0, 1.0), (2, 1.0)]);
        let mirrors = MirrorImages::of_scene(&scene, &[0], &[1, 4]);
        assert_eq!(mirrors.images().len(), 2);
        // Mean and standard error over `runs` seeds.
        let estimate = |mirrors: &MirrorImages| {
            let sources = GatherSources {
                bright: &bright,
                mirrors,
                bright_count: 9,
                mirror_count: 9,
                linked: &LinkedSources::default(),
                linked_count: 0,
            };
            let runs = 1000;
            let (mut sum, mut sq) = (0.0, 0.0);
            for seed in 0..runs {
                let point = GatherPoint {
                    surface: 2,
                    position: x,
                    normal,
                    samples: Samples::Hashed(seed),
                    shape: None,
                };
                let v =
                    indirect_radiance(&scene, &tracer, &point, 16, sources, outgoing).radiance[0];
                (sum, sq) = (sum + v, sq + v * v);
            }
            let mean = sum / runs as f64;
            (
                mean,
                ((sq / runs as f64 - mean * mean) / runs as f64).sqrt(),
            )
        };
        // ρ/π ∫ L cos θ_x cos θ_y / r² dA over the floor and the panel.
        let n = 1000;
        let mut expect = 0.0;
        for (q, origin, edges) in [
            (0, DVec3::ZERO, [DVec3::X, DVec3::Y]),
            (
                3,
                DVec3::new(0.0, 0.2, 0.1),
                [DVec3::Y * 0.6, DVec3::Z * 0.4],
            ),
        ] {
            let patch = &scene.surfaces[q as usize].patch;
            for m in crate::testing::unit_square_midpoints(n) {
                let y = origin + m.x * edges[0] + m.y * edges[1];
                let d = y - x;
                let r2 = d.length_squared();
                let cos_x = normal.dot(d) / r2.sqrt();
                let cos_y = -patch.normal().dot(d) / r2.sqrt();
                let area = patch.area() / (n * n) as f64;
                expect += outgoing(q, y)[0] * cos_x * cos_y / r2 * area;
            }
        }
        expect *= 0.5 / std::f64::consts::PI;
        let (area_only, area_error) = estimate(&MirrorImages::default());
        let (mirrored, mirror_error) = estimate(&mirrors);
        for (mean, error) in [(area_only, area_error), (mirrored, mirror_error)] {
            assert!(
                (mean - expect).abs() < 4.0 * error + 1e-12,
                "{mean} ± {error} vs {expect}"
            );
        }
        assert!(
            mirror_error < 0.6 * area_error,
            "mirror images leave the noise at {mirror_error}, area samples alone {area_error}"
        );
    }

    /// A glossy floor in a closed box whose ceiling alone sends light
    /// (radiance 1) reflects ∫ f cos θ over the ceiling's directions towards
    /// `wo`. BRDF samples drawn as one pixel's blocks (each sample's lobe
    /// chosen independently of its direction) average to it, as
    /// independent samples do.
    #[test]
    fn brdf_samples_average_to_the_reflected_light() {
        let mut walls: Vec<Surface> =
            Patch::inward_box(DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, 1.0, 2.0))
                .into_iter()
                .map(crate::testing::grey)
                .collect();
        walls[0].brdf = crate::testing::rolled_aluminium();
        let scene = Scene::from_surfaces(walls);
        let tracer = SceneTracer::new(&scene);
        let floor = &scene.surfaces[0];
        let wo = DVec3::new(0.5, 0.2, 0.8).normalize();
        let x = DVec3::new(0.1, -0.2, 0.0);
        // ∫ f(wo, wi) cos θ dω over the directions reaching the ceiling
        // (z = 2, |x|, |y| ≤ 1), by the midpoint rule in (θ, φ).
        let frame = floor.frame();
        let wo_local = frame.to_local(wo);
        let n = 1500;
        let (dt, dp) = (FRAC_PI_2 / n as f64, 2.0 * PI / n as f64);
        let mut reflected = 0.0;
        for i in 0..n {
            let theta = (i as f64 + 0.5) * dt;
            for j in 0..n {
                let phi = (j as f64 + 0.5) * dp;
                let wi = DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                let w = frame.to_world(wi);
                let at = x + w * (2.0 / w.z);
                if at.x.abs() > 1.0 || at.y.abs() > 1.0 {
                    continue;
                }
                let f = floor.brdf.eval(wo_local, wi)[0];
                reflected += f * theta.cos() * theta.sin() * dt * dp;
            }
        }
        let estimate = |samples: Samples| {
            let ceiling = |q: u32, _| Rgb::splat(if q == 1 { 1.0 } else { 0.0 });
            let brdf = (&floor.brdf, wo);
            let no_emitters = &Emitters::default();
            let point = on_floor(x, samples);
            glossy_radiance(&scene, &tracer, no_emitters, &point, brdf, 2, ceiling)[0]
        };
        let hashed = mean_and_error((0..4096).map(|s| estimate(Samples::Hashed(s))).collect());
        // Each pixel's 16 blocks together, as one estimate.
        let pixels = (0..256u64)
            .map(|p| {
                (0..16)
                    .map(|block| estimate(Samples::pixel(p, block)))
                    .sum::<f64>()
                    / 16.0
            })
            .collect();
        let pixel = mean_and_error(pixels);
        for (mean, error) in [hashed, pixel] {
            assert!(
                (mean - reflected).abs() < 4.0 * error + 2e-3 * reflected,
                "{mean} ± {error} vs {reflected}"
            );
        }
    }

    #[test]
    fn unoccluded_direct_light_matches_closed_form() {
        // A point 1 below the corner of a unit square light of radiance 1,
        // reflectance 0.5: 0.5 × Howell B-3 factor.
        let floor = Patch::Parallelogram {
            origin: DVec3::new(-5.0, -5.0, 0.0),
            edge_s: DVec3::X * 10.0,
            edge_t: DVec3::Y * 10.0,
        };
        let light = Patch::Parallelogram {
            origin: DVec3::Z,
            edge_s: DVec3::Y,
            edge_t: DVec3::X,
        };
        let scene = Scene::from_surfaces(vec![
            Surface {
                name: "floor".into(),
                patch: floor,
                brdf: crate::scene::brdf::Brdf::diffuse(Rgb::splat(0.5)),
                emission: Rgb::ZERO,
                texture: None,
                shading: None,
            },
            Surface {
                name: "light".into(),
                patch: light,
                brdf: crate::scene::brdf::Brdf::diffuse(Rgb::ZERO),
                emission: Rgb::splat(1.0),
                texture: None,
                shading: None,
            },
        ]);
        let s = 2f64.sqrt();
        let expect = 0.5 * (2.0 / s * (1.0 / s).atan()) / (2.0 * std::f64::consts::PI);
        // Nothing hides the light: the closed form, exactly.
        let tracer = SceneTracer::new(&scene);
        let light = Emitters::new(&scene, vec![(1, 1.0)]);
        let l = direct_radiance(
            &scene,
            &tracer,
            &light,
            &on_floor(DVec3::ZERO, Samples::Hashed(7)),
            1,
        );
        assert!((l[0] - expect).abs() < 1e-12, "{} vs {expect}", l[0]);
        let (mean, error) = direct_estimates(&scene, DVec3::ZERO, 1);
        assert!(
            (mean - expect).abs() < 4.0 * error + 1e-12,
            "{mean} ± {error} vs {expect}"
        );
    }

    #[test]
    fn light_partly_below_the_point_is_seen_through_its_front_part_alone() {
        // An upright unit light of radiance 1 whose lower half reaches
        // below the floor, facing a point of it: the point receives from
        // the upper half (Lambert's closed form clips the rest). A shadow
        // ray drawn on the lower half is no evidence of occlusion: one ray
        // per estimate, or a 2 × 2 grid, must still average to the closed
        // form.
        let light = Patch::Parallelogram {
            origin: DVec3::new(1.0, 0.5, -0.5),
            edge_s: DVec3::NEG_Y,
            edge_t: DVec3::Z,
        };
        let scene = floor_lit_by(light, None);
        assert!(light.normal().x < 0.0, "the light faces the point");
        let rho = lambertian_albedo(&scene, 0, DVec3::ZERO)[0];
        let expect =
            rho * point_to_polygon(DVec3::ZERO, DVec3::Z, &light.vertices(), light.normal());
        assert!(expect > 0.0);
        for grid in [1, 2] {
            let (mean, error) = direct_estimates(&scene, DVec3::ZERO, grid);
            assert!(
                (mean - expect).abs() < 4.0 * error + 1e-12,
                "grid {grid}: {mean} ± {error} vs {expect}"
            );
        }
    }

    #[test]
    fn the_back_of_a_two_sided_emitter_receives_none_of_its_light() {
        // The light's other side: a surface in the light's plane facing up,
        // its points pressed against the emitter (a rounding error off its
        // plane, as a ray finds them), which the closed form would
        // otherwise count whole.
        let light = Patch::Parallelogram {
            origin: DVec3::new(-0.5, -0.5, 1.0),
            edge_s: DVec3::Y,
            edge_t: DVec3::X,
        };
        let back = Patch::Parallelogram {
            origin: DVec3::new(-0.5, -0.5, 1.0),
            edge_s: DVec3::X,
            edge_t: DVec3::Y,
        };
        let scene = floor_lit_by(light, Some(back));
        let tracer = SceneTracer::new(&scene);
        let emitters = Emitters::new(&scene, vec![(1, 1.0)]);
        for (k, x) in [(0.1, 0.2), (-0.3, 0.4)].into_iter().enumerate() {
            let point = GatherPoint {
                surface: 2,
                position: DVec3::new(x.0, x.1, 1.0 - 1e-9),
                normal: DVec3::Z,
                samples: Samples::Hashed(k as u64),
                shape: None,
            };
            assert_eq!(
                direct_radiance(&scene, &tracer, &emitters, &point, 2),
                Rgb::ZERO
            );
        }
        // The floor below still sees it.
        let below = on_floor(DVec3::ZERO, Samples::Hashed(0));
        assert!(direct_radiance(&scene, &tracer, &emitters, &below, 2)[0] > 0.1);
    }

    #[test]
    fn a_point_sees_the_light_whole_in_part_or_not_at_all() {
        // Far to the right of the wall's edge a floor point sees all of the
        // light, far to its left none, under the edge part.
        let mut scene = floor_under_a_wall_edge();
        let tracer = SceneTracer::new(&scene);
        let emitters = Emitters::new(&scene, vec![(1, 1.0)]);
        let seen = |scene: &Scene, x: f64| {
            let point = on_floor(DVec3::new(x, 0.0, 0.0), Samples::Hashed(0));
            emitters_seen(scene, &tracer, &emitters, &point)
        };
        assert_eq!(seen(&scene, 3.0), Some(EmittersSeen::Whole));
        assert_eq!(seen(&scene, -3.0), Some(EmittersSeen::Nothing));
        assert_eq!(seen(&scene, 0.0), Some(EmittersSeen::Part));
        // Beside the floor, a point light whose visibility is not tested.
        scene.lights.push(crate::scene::Light::Point {
            position: DVec3::new(0.0, 0.0, 2.0),
            intensity: Rgb::splat(1.0),
        });
        assert_eq!(seen(&scene, 3.0), None);
    }

    #[test]
    fn a_penumbra_receives_the_kernel_weighted_visible_part_of_the_light() {
        // A floor point under the edge of a wall that hides all but the
        // far fifth of a 1 × 1 light above: the light it receives is the
        // integral of the point-to-area kernel over that fifth (a fine
        // midpoint rule with shadow rays), less than F times the visible
        // area's share, since the hidden part's kernel is larger. One shadow ray per
        // estimate and a 2 × 2 grid both average to it.
        let scene = floor_under_a_wall_edge();
        let light = scene.surfaces[1].patch;
        let x = DVec3::new(-0.3, 0.0, 0.0);
        let tracer = SceneTracer::new(&scene);
        let m = 200;
        let visible_kernel: f64 = (0..m * m)
            .map(|k| {
                let uv = DVec2::new(
                    (f64::from(k % m) + 0.5) / f64::from(m),
                    (f64::from(k / m) + 0.5) / f64::from(m),
                );
                let y = light.point_at(light.square_to_param(uv));
                let d = y - x;
                let open = !tracer
                    .occluder
                    .occluded_except(x, y, |p| tracer.surface_of(p) != 2);
                match open {
                    true => d.z * d.z / (std::f64::consts::PI * d.length_squared().powi(2)),
                    false => 0.0,
                }
            })
            .sum::<f64>()
            * light.area()
            / f64::from(m * m);
        let rho = lambertian_albedo(&scene, 0, x)[0];
        let expect = rho * visible_kernel;
        let unoccluded = point_to_polygon(x, DVec3::Z, &light.vertices(), light.normal());
        assert!(
            visible_kernel < 0.45 * unoccluded,
            "{visible_kernel} of {unoccluded}"
        );
        for grid in [1, 2] {
            let (mean, error) = direct_estimates(&scene, x, grid);
            assert!(
                (mean - expect).abs() < 4.0 * error + 0.01 * expect,
                "grid {grid}: {mean} ± {error} vs {expect}"
            );
        }
    }

    /// The floor under a 1 × 1 light at height 1, and a wall at height 0.5
    /// over x < 0 whose edge runs under the light's middle.
    fn floor_under_a_wall_edge() -> Scene {
        let light = Patch::Parallelogram {
            origin: DVec3::new(-0.5, -0.5, 1.0),
            edge_s: DVec3::Y,
            edge_t: DVec3::X,
        };
        let wall = Patch::Parallelogram {
            origin: DVec3::new(-5.0, -5.0, 0.5),
            edge_s: DVec3::X * 5.0,
            edge_t: DVec3::Y * 10.0,
        };
        floor_lit_by(light, Some(wall))
    }

    /// A grey 10 × 10 floor (surface 0) at z = 0 around the origin, lit by
    /// `light` of radiance 1 (surface 1), with a grey `blocker` (surface 2).
    fn floor_lit_by(light: Patch, blocker: Option<Patch>) -> Scene {
        let floor = Patch::Parallelogram {
            origin: DVec3::new(-5.0, -5.0, 0.0),
            edge_s: DVec3::X * 10.0,
            edge_t: DVec3::Y * 10.0,
        };
        let lit = Surface {
            emission: Rgb::splat(1.0),
            ..crate::testing::grey(light)
        };
        let mut surfaces = vec![crate::testing::grey(floor), lit];
        surfaces.extend(blocker.map(crate::testing::grey));
        Scene::from_surfaces(surfaces)
    }

    /// Mean and standard error of 4 000 independent estimates of the direct
    /// light at `x` on the floor (surface 0) of `scene`, whose surface 1 is
    /// the lone emitter.
    fn direct_estimates(scene: &Scene, x: DVec3, grid: u32) -> (f64, f64) {
        let tracer = SceneTracer::new(scene);
        let emitters = Emitters::new(scene, vec![(1, 1.0)]);
        mean_and_error(
            (0..4000)
                .map(|k| {
                    direct_radiance(
                        scene,
                        &tracer,
                        &emitters,
                        &on_floor(x, Samples::Hashed(k)),
                        grid,
                    )[0]
                })
                .collect(),
        )
    }

    /// The unit floor (surface 0) under three lights of different power: the
    /// light overhead (radiance 1), a brighter one off to the side, and an
    /// upright one beyond the floor's edge facing it.
    fn floor_under_three_lights() -> Scene {
        let mut scene = crate::testing::mirror_floor_and_light();
        let light = |origin: DVec3, edge_s: DVec3, edge_t: DVec3, radiance: f64| Surface {
            emission: Rgb::splat(radiance),
            ..crate::testing::grey(Patch::Parallelogram {
                origin,
                edge_s,
                edge_t,
            })
        };
        let (side, upright) = (DVec3::new(0.6, 0.0, 0.7), DVec3::new(-0.3, 0.2, 0.05));
        scene
            .surfaces
            .push(light(side, DVec3::Y * 0.3, DVec3::X * 0.3, 2.5));
        scene
            .surfaces
            .push(light(upright, DVec3::Y * 0.4, DVec3::Z * 0.4, 4.0));
        scene
    }

    /// Mean and standard error of independent estimates.
    fn mean_and_error(values: Vec<f64>) -> (f64, f64) {
        let m = values.len() as f64;
        let mean = values.iter().sum::<f64>() / m;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (m - 1.0);
        (mean, (var / m).sqrt())
    }

    /// The point `x` of a floor (surface 0, facing +z), drawing `samples`.
    fn on_floor(x: DVec3, samples: Samples) -> GatherPoint {
        GatherPoint {
            surface: 0,
            position: x,
            normal: DVec3::Z,
            samples,
            shape: None,
        }
    }

    /// Four shadow rays among three emitters, each drawn by power (the
    /// floor itself, also listed, left out): the direct light averages to
    /// ρ Σ Le·F over the three in closed form, although each estimate
    /// leaves some emitter out.
    #[test]
    fn direct_light_drawn_among_emitters_averages_to_all_of_it() {
        let mut scene = floor_under_three_lights();
        scene.surfaces[0].brdf = crate::scene::brdf::Brdf::diffuse(Rgb::splat(0.5));
        let tracer = SceneTracer::new(&scene);
        let x = DVec3::new(0.5, 0.5, 0.0);
        let power = |e: u32| {
            let s = &scene.surfaces[e as usize];
            s.emission[0] * s.patch.area()
        };
        let weights = vec![(0, 1.0), (1, power(1)), (2, power(2)), (3, power(3))];
        // Drawn by power, and for the floor mostly by the light its links
        // would say two of them bring (one as if they missed it): both
        // average to all of the light.
        let scene_wide = Emitters::new(&scene, weights.clone());
        let received = vec![vec![(1, 1.0), (3, 9.0)], vec![], vec![], vec![]];
        let by_links = Emitters::new(&scene, weights).with_received(received);
        let expect: f64 = (1..4)
            .map(|e| {
                let light = &scene.surfaces[e].patch;
                let ff = point_to_polygon(x, DVec3::Z, &light.vertices(), light.normal());
                0.5 * scene.surfaces[e].emission[0] * ff
            })
            .sum();
        for emitters in [&scene_wide, &by_links] {
            let (mean, error) = mean_and_error(
                (0..4000)
                    .map(|s| {
                        let point = on_floor(x, Samples::Hashed(s));
                        direct_radiance(&scene, &tracer, emitters, &point, 2)[0]
                    })
                    .collect(),
            );
            assert!(error > 1e-3 * expect, "the emitters drawn vary: {error}");
            assert!(
                (mean - expect).abs() < 4.0 * error + 1e-12,
                "{mean} ± {error} vs {expect}"
            );
        }
    }

    /// A sharp glossy floor under three lights: light samples drawn among
    /// them (and the floor, left out) and BRDF samples, combined, average
    /// to ∫ f Le cos θ over the lights (the midpoint rule over each).
    #[test]
    fn light_samples_drawn_among_emitters_average_to_the_reflected_light() {
        let scene = floor_under_three_lights();
        let tracer = SceneTracer::new(&scene);
        let floor = &scene.surfaces[0];
        let x = DVec3::new(0.5, 0.5, 0.0);
        // Mirrored, wo points at the overhead light's corner.
        let wo = DVec3::new(0.3, 0.1, 1.0).normalize();
        let frame = floor.frame();
        let wo_local = frame.to_local(wo);
        let n = 400;
        let mut reflected = 0.0;
        for e in 1..4 {
            let light = &scene.surfaces[e];
            let cell = light.patch.area() / (n * n) as f64;
            for m in crate::testing::unit_square_midpoints(n) {
                let y = light
                    .patch
                    .point_at(light.patch.square_to_param(m.truncate()));
                let d = y - x;
                let r2 = d.length_squared();
                let wi = d / r2.sqrt();
                let cos_y = -light.patch.normal().dot(wi);
                let f = floor.brdf.eval(wo_local, frame.to_local(wi))[0];
                reflected += f * light.emission[0] * wi.z * cos_y / r2 * cell;
            }
        }
        let emitters = Emitters::new(&scene, vec![(0, 1.0), (1, 1.0), (2, 2.0), (3, 1.0)]);
        let emission = |q: u32, _| scene.surfaces[q as usize].emission;
        let (mean, error) = mean_and_error(
            (0..4000)
                .map(|s| {
                    let (point, brdf) = (on_floor(x, Samples::Hashed(s)), (&floor.brdf, wo));
                    glossy_radiance(&scene, &tracer, &emitters, &point, brdf, 2, emission)[0]
                })
                .collect(),
        );
        assert!(
            (mean - reflected).abs() < 4.0 * error + 2e-3 * reflected,
            "{mean} ± {error} vs {reflected}"
        );
    }
}
