//! Three-point links and their adaptive projection: the paper's
//! Compute_3point_Kernel (§4.2) with virtual resolution.
//!
//! For every glossy surface p, every surface r that can light it and every
//! surface q it can light, the triple of whole surfaces is refined: the four
//! children of the *largest* of the three elements are integrated
//! ([`crate::kernel::three_point_quadrature::coefficient`]); if the kernel's Haar
//! details over them pass the oracle the link is kept at this level with the
//! coefficient assembled from the children, else each child triple is
//! refined in turn. Source and glossy elements never go below their
//! surface's deepest level ([`KernelContext::deepest_level`] under
//! `max_level`: a mesh's small triangles stop where their elements are as
//! small as the largest surface's finest, as in two-point links), or below
//! `max_level` for a highlight (an emitter seen in a sharp lobe); the
//! receiving element may go further ([`ThreePointSettings`]).

use crate::geometry::hierarchy::{ElementId, ElementRef};
use crate::kernel::three_point_quadrature::{GlossyElement, IncidentLight};
use crate::kernel::KernelContext;
use crate::progress::{Progress, Silent};
use crate::refine::estimate::LightEstimate;
use crate::refine::oracle::{average_detail, kernel_detail, Judge, Verdict};
use crate::refine::two_point_projection::RefineSettings;
use crate::refine::{project_each, project_while_unspent, ByItem, Part, Projected, Projection};
use crate::scene::brdf::{Brdf, BrdfFlags, BrdfModel, Frame};
use crate::scene::{Patch, Rgb, Scene};

/// A three-point interaction r → p → q: `L_{a→b} += coefficient · L_{c→a}`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ThreePointLink {
    /// Source surface.
    pub r: u32,
    /// Element on `r`.
    pub c: ElementId,
    /// Glossy surface.
    pub p: u32,
    /// Element on `p`.
    pub a: ElementId,
    /// Receiving surface (an index past the scene's surfaces names a
    /// hypothetical receiver, such as the eye).
    pub q: u32,
    /// Element on `q`.
    pub b: ElementId,
    /// R(c, a, b) per channel (element-average form of eq. 13).
    pub coefficient: Rgb,
    /// Largest detail of R the weighted oracles saw when they kept the link
    /// (see [`crate::refine::two_point_projection::Link::detail`]).
    pub detail: f32,
}

impl ThreePointLink {
    /// Its three elements: source `c` on `r`, glossy `a` on `p` and
    /// receiver `b` on `q`.
    pub fn elements(&self) -> [ElementRef; 3] {
        let at = ElementRef::new;
        [at(self.r, self.c), at(self.p, self.a), at(self.q, self.b)]
    }
}

/// Settings of the three-point kernel projection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThreePointSettings {
    /// Oracle, quadrature, and the deepest level of the source and glossy
    /// elements.
    pub refine: RefineSettings,
    /// Deepest level of the receiving element. Splitting only the receiver
    /// reuses the light incident on the glossy element (no ray queries, see
    /// [`IncidentLight`]), so a highlight's edges on a receiver can be
    /// resolved at a fraction of the cost of a deeper `refine.max_level`.
    pub receiver_max_level: u32,
}

/// The surfaces of one triple and what the kernel needs of them.
struct TripleRefiner<'a> {
    ctx: KernelContext<'a>,
    /// Asks refinement to stop ([`Progress::interrupted`]): the links
    /// under way are kept as they are.
    stop: &'a dyn Progress,
    judge: Judge<'a>,
    r: u32,
    p: u32,
    q: u32,
    frame: Frame,
    /// p's BRDF less its Lambertian lobe, which two-point links carry.
    brdf: Brdf,
    /// Solid angle of p's lobe where it is sharp ([`Brdf::is_sharp`]) and
    /// the source r emits, else zero: a receiver splits below the others'
    /// deepest level only to resolve a highlight, an emitter's image
    /// ([`finer_than_element`]). Light from surfaces that do not emit is
    /// spread over them, and splitting its receivers too tripled the solve
    /// of Veach's MIS scene (four sharp plates) for nothing seen.
    lobe: f64,
    /// Deepest level of the source, glossy and receiving elements
    /// ([`KernelContext::deepest_level`] of their surfaces under
    /// `refine.max_level`, or `refine.max_level` itself for a highlight's
    /// source and glossy elements; the receiver's under
    /// `receiver_max_level`, and a hypothetical receiver is a point, never
    /// split), and the receiver's under `refine.max_level`, below which it
    /// splits only for a lobe.
    deepest: [u32; 3],
    receiver_deepest: u32,
    links: Vec<ThreePointLink>,
}

impl<'a> TripleRefiner<'a> {
    fn new(
        ctx: &KernelContext<'a>,
        settings: ThreePointSettings,
        estimate: Option<&'a LightEstimate>,
        (r, p, q): (u32, u32, u32),
        stop: &'a dyn Progress,
    ) -> Self {
        let scene = ctx.scene;
        let max_level = settings.refine.max_level;
        // A hypothetical receiver (the eye) is a point: never split.
        let receiver = |max: u32| {
            if q as usize >= scene.surfaces.len() {
                0
            } else {
                ctx.deepest_level(q, max)
            }
        };
        let lobe = Some(&scene.surfaces[p as usize].brdf)
            .filter(|brdf| {
                brdf.is_sharp() && scene.surfaces[r as usize].emission.max_channel() > 0.0
            })
            .map_or(0.0, Brdf::lobe_solid_angle);
        // A highlight (an emitter's image in a sharp lobe) is shaped by the
        // emitter's and the glossy surface's elements however small those
        // surfaces are: they keep `max_level`. Elsewhere a glossy element
        // may be a quarter of A_ε: the image of what it reflects moves
        // across it faster than light varies over a diffuse one
        // (docs/decisions-measurements.md, "Three-point elements as small
        // as the largest surface's").
        let deepest = |s: u32, finer: u32| {
            if lobe > 0.0 {
                max_level
            } else {
                ctx.deepest_level(s, max_level + finer).min(max_level)
            }
        };
        TripleRefiner {
            ctx: *ctx,
            stop,
            judge: Judge {
                threshold: settings.refine.threshold,
                estimate,
            },
            r,
            p,
            q,
            frame: scene.surfaces[p as usize].frame(),
            brdf: scene.surfaces[p as usize].brdf.without_lambertian(),
            lobe,
            deepest: [
                deepest(r, 0),
                deepest(p, 1),
                receiver(settings.receiver_max_level),
            ],
            receiver_deepest: receiver(max_level),
            links: Vec::new(),
        }
    }

    /// The light from `c` at the Gauss points of the glossy element `a`,
    /// which every receiver of the pair shares.
    fn incident<'s>(&'s self, c: &'s Part, a: &'s Part) -> IncidentLight<'s> {
        IncidentLight::new(
            &self.ctx,
            c.kernel(),
            GlossyElement {
                element: a.kernel(),
                brdf: &self.brdf,
                frame: self.frame,
            },
        )
    }

    fn coefficient(&self, c: &Part, a: &Part, b: &Part) -> Rgb {
        self.incident(c, a).towards(&b.patch)
    }

    fn push(&mut self, c: &Part, a: &Part, b: &Part, coefficient: Rgb, detail: f64) {
        if coefficient.max_channel() > 0.0 {
            self.links.push(ThreePointLink {
                r: self.r,
                c: c.element.id,
                p: self.p,
                a: a.element.id,
                q: self.q,
                b: b.element.id,
                coefficient,
                detail: detail as f32,
            });
        }
    }

    /// Compute_3point_Kernel for the triple (c, a, b) whose coefficient is
    /// known.
    ///
    /// Virtual resolution splits one element at a time, largest first. The
    /// details over the children of one element are blind to variation
    /// along the others (a Lambertian p's kernel does not depend on b at
    /// all), so when the largest element's details pass, the next one's are
    /// tested too; the first element whose details fail is subdivided. The
    /// link is kept only when every refinable element passes.
    fn refine(&mut self, c: Part, a: Part, b: Part, known: Rgb) {
        if self.stop.interrupted() {
            return self.push(&c, &a, &b, known, 0.0);
        }
        let parts = [c, a, b];
        // Below the others' deepest level the receiver splits only while
        // the lobe is narrower than it, as seen from the glossy element.
        let past_lobe = |i: usize| {
            i == 2
                && parts[2].element.id.level >= self.receiver_deepest
                && (self.lobe == 0.0
                    || !finer_than_element(self.lobe, &parts[1].patch, &parts[2].patch))
        };
        let mut order: Vec<usize> = (0..3)
            .filter(|&i| parts[i].element.id.level < self.deepest[i] && !past_lobe(i))
            .collect();
        order.sort_by(|&i, &j| parts[j].patch.area().total_cmp(&parts[i].patch.area()));
        let mut kept = None;
        let mut detail = 0.0f64;
        for split in order {
            let children = parts[split].children();
            let coefficients = if split == 2 {
                // Only the receiver changes: the incident light is shared.
                let incident = self.incident(&parts[0], &parts[1]);
                children.map(|child| incident.towards(&child.patch))
            } else {
                children.map(|child| {
                    let mut t = parts;
                    t[split] = child;
                    self.coefficient(&t[0], &t[1], &t[2])
                })
            };
            let verdict = self.test(&parts, split, &children, &coefficients);
            detail = detail.max(verdict.detail);
            if !verdict.smooth {
                for (child, k) in children.into_iter().zip(coefficients) {
                    let mut t = parts;
                    t[split] = child;
                    self.refine(t[0], t[1], t[2], k);
                }
                return;
            }
            // Hierarchical decomposition: the coefficient from the children
            // (R integrates over c and averages over a and b).
            let weight = if split == 0 { 1.0 } else { 0.25 };
            kept.get_or_insert_with(|| coefficients.into_iter().sum::<Rgb>() * weight);
        }
        self.push(&c, &a, &b, kept.unwrap_or(known), detail);
    }

    /// The oracle on the children of `parts[split]` with coefficients `k`.
    fn test(&self, parts: &[Part; 3], split: usize, children: &[Part; 4], k: &[Rgb; 4]) -> Verdict {
        self.judge.verdict(
            || {
                // The paper's: the kernel in its parametrisation,
                // K = f·G·V·A_r, averaged over each child triple.
                let area_c = if split == 0 {
                    children[0].patch.area()
                } else {
                    parts[0].patch.area()
                };
                let means = k.map(|k| k.max_channel() / area_c);
                let other_levels: u32 = (0..3)
                    .filter(|&i| i != split)
                    .map(|i| parts[i].element.id.level)
                    .sum();
                let r_area = self.ctx.scene.surfaces[self.r as usize].patch.area();
                kernel_detail(means, parts[split].element.id.level, other_levels, r_area)
            },
            |e| {
                // R integrates over c: a child of c carries a quarter of the light.
                let scale = if split == 0 { 4.0 } else { 1.0 };
                let detail = average_detail(k.map(|k| scale * k.max_channel()));
                (detail, [detail * self.weight(e, parts)])
            },
        )
    }

    /// The light a triple carries, for the weighted oracles: L_{c→a}
    /// relative to the brightest emission, times the importance of b.
    fn weight(&self, e: &LightEstimate, [c, a, b]: &[Part; 3]) -> f64 {
        e.radiance(c.element, a.element) * e.importance(b.element)
    }
}

/// How many receiving elements a sharp lobe's reflection may cover before
/// the receiver stops splitting ([`finer_than_element`]): about 4×4, so
/// that a highlight's blurred edges fall across a few elements, which the
/// smooth reconstruction draws as a ramp.
const ELEMENTS_PER_LOBE: f64 = 16.0;

/// Whether a lobe of solid angle `lobe` reflected from `glossy` is narrower
/// than [`ELEMENTS_PER_LOBE`] times the solid angle `receiver` subtends
/// from `glossy`'s centroid: then splitting the receiver resolves the
/// reflection's shape on it.
fn finer_than_element(lobe: f64, glossy: &Patch, receiver: &Patch) -> bool {
    let d = receiver.centroid() - glossy.centroid();
    let distance2 = d.length_squared();
    let subtended = if distance2 > 0.0 {
        (receiver.area() * receiver.normal().dot(d).abs() / (distance2 * distance2.sqrt()))
            .min(2.0 * std::f64::consts::PI)
    } else {
        2.0 * std::f64::consts::PI
    };
    lobe < ELEMENTS_PER_LOBE * subtended
}

/// Most surface triples a plan projects ([`surface_triples`]). A glossy
/// surface's triples are the square of the surfaces it exchanges light
/// with element to element, and each makes hundreds to thousands of
/// three-point links, so a glossy mesh of a thousand triangles plans
/// hundreds of thousands, more than any memory holds the links of (a
/// concave one of 924 triangles took 24 GB and was killed). Past this many,
/// the largest glossy surfaces keep all theirs, while they fit, and the
/// rest have none: their lobes' light goes through their distributions
/// per bin ([`crate::solve::glossy_clusters`]) to every receiver, as to the
/// ends of their cluster links. Fixed, whatever the limits of the solve,
/// so that a plan and its resumption agree on their items.
pub const MAX_TRIPLES: usize = 1 << 13;

/// The surface triples of a plan ([`surface_triples`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceTriples {
    /// The triples (r, p, q) projected, in order.
    pub planned: Vec<(u32, u32, u32)>,
    /// Triples of the scene past [`MAX_TRIPLES`], left out of the plan.
    pub left_out: u64,
    /// The glossy surfaces whose triples are left out.
    pub binned: u64,
}

/// The surface triples (r, p, q) of three-point links: a glossy p with two
/// surfaces r ≠ p (the source) and q ≠ p (the receiver) that each make one
/// of `pairs` with it (the surface pairs that can exchange light, p < r),
/// in order of p. Past [`MAX_TRIPLES`], the glossy surfaces in order of
/// decreasing area (then index) keep all their triples while the total
/// fits, and the others none.
pub fn surface_triples(scene: &Scene, pairs: &[(u32, u32)]) -> SurfaceTriples {
    surface_triples_at_most(scene, pairs, MAX_TRIPLES)
}

/// [`surface_triples`] keeping at most `most`.
fn surface_triples_at_most(scene: &Scene, pairs: &[(u32, u32)], most: usize) -> SurfaceTriples {
    let mut near = vec![Vec::new(); scene.surfaces.len()];
    for &(p, r) in pairs {
        near[p as usize].push(r);
        near[r as usize].push(p);
    }
    near.iter_mut().for_each(|n| {
        n.sort_unstable();
        n.dedup();
    });
    let mut glossy: Vec<usize> = (0..scene.surfaces.len())
        .filter(|&p| (scene.surfaces[p].brdf.flags()).contains(BrdfFlags::GLOSSY_REFLECTION))
        .collect();
    let triples = |p: usize| near[p].len() * near[p].len();
    let total: usize = glossy.iter().map(|&p| triples(p)).sum();
    let mut binned = 0;
    if total > most {
        let area = |p: usize| scene.surfaces[p].patch.area();
        glossy.sort_by(|&a, &b| area(b).total_cmp(&area(a)).then(a.cmp(&b)));
        let mut kept = 0;
        glossy.retain(|&p| {
            let fits = kept + triples(p) <= most;
            kept += if fits { triples(p) } else { 0 };
            binned += u64::from(!fits);
            fits
        });
        glossy.sort_unstable();
    }
    let planned: Vec<(u32, u32, u32)> = (glossy.iter())
        .flat_map(|&p| {
            let near = &near[p];
            near.iter()
                .flat_map(move |&r| near.iter().map(move |&q| (r, p as u32, q)))
        })
        .collect();
    SurfaceTriples {
        left_out: (total - planned.len()) as u64,
        planned,
        binned,
    }
}

/// The progress phase of the three-point projection.
pub const PHASE: &str = "3-point kernels";

/// The three-point links of the triple `(r, p, q)`, refined from the whole
/// surfaces with `settings` (compute_kernel of §4.2 for glossy surfaces);
/// `receiver(q)` gives the geometry of receiver `q`. Refinement stops where
/// it is when `progress` asks it to.
fn project_triple(
    ctx: &KernelContext,
    settings: ThreePointSettings,
    estimate: Option<&LightEstimate>,
    (r, p, q): (u32, u32, u32),
    receiver: &impl Fn(u32) -> Patch,
    progress: &dyn Progress,
) -> Vec<ThreePointLink> {
    let mut refiner = TripleRefiner::new(ctx, settings, estimate, (r, p, q), progress);
    let (c, a, b) = (
        Part::of(ctx.scene, ElementRef::root(r)),
        Part::of(ctx.scene, ElementRef::root(p)),
        Part {
            element: ElementRef::root(q),
            patch: receiver(q),
        },
    );
    let k = refiner.coefficient(&c, &a, &b);
    refiner.refine(c, a, b, k);
    refiner.links
}

/// The three-point links of the triples `(r, p, q)` (compute_kernel of §4.2
/// for glossy surfaces), triple by triple, with whether each was refined in
/// full; refined in parallel over triples, and the result does not depend
/// on the number of threads. `receiver(q)` gives the geometry of receiver
/// `q`, which may be a hypothetical surface outside the scene. With an
/// `estimate` the weighted oracles decide, else the paper's. Once the work
/// is asked to stop, the triples left are linked whole.
pub fn refine_three_point_links(
    ctx: &KernelContext,
    settings: ThreePointSettings,
    estimate: Option<&LightEstimate>,
    triples: &[(u32, u32, u32)],
    receiver: impl Fn(u32) -> Patch + Sync,
    progress: &dyn Progress,
) -> ByItem<ThreePointLink> {
    let unrefined = ThreePointSettings {
        refine: RefineSettings {
            max_level: 0,
            ..settings.refine
        },
        receiver_max_level: 0,
    };
    project_each(PHASE, triples, progress, |&triple, refine| {
        let settings = if refine { settings } else { unrefined };
        project_triple(ctx, settings, estimate, triple, &receiver, progress)
    })
}

/// The three-point links of a solve's `triples` (r, p, q) of the scene's
/// surfaces, as [`refine_three_point_links`] makes them, except that once
/// the work is asked to stop the triples not yet started are left out,
/// without links (`project_while_unspent`): linking them whole would
/// cost a quadrature each, and a plan can hold [`MAX_TRIPLES`] of them.
pub fn project_triples(
    ctx: &KernelContext,
    settings: ThreePointSettings,
    estimate: Option<&LightEstimate>,
    triples: &[(u32, u32, u32)],
    progress: &dyn Progress,
) -> Projected<ThreePointLink> {
    let receiver = |q: u32| ctx.scene.surfaces[q as usize].patch;
    project_while_unspent(PHASE, triples, progress, |&triple| {
        project_triple(ctx, settings, estimate, triple, &receiver, progress)
    })
}

impl Projection for ThreePointSettings {
    type Link = ThreePointLink;
    const PHASE: &'static str = PHASE;

    fn refine_link(
        &self,
        ctx: &KernelContext,
        estimate: &LightEstimate,
        l: &ThreePointLink,
    ) -> Vec<ThreePointLink> {
        let mut refiner = TripleRefiner::new(ctx, *self, Some(estimate), (l.r, l.p, l.q), &Silent);
        let [c, a, b] = l.elements().map(|e| Part::of(ctx.scene, e));
        let error = |e| Some(f64::from(l.detail) * refiner.weight(e, &[c, a, b]));
        if refiner.judge.still_accepts(error) {
            return vec![*l];
        }
        refiner.refine(c, a, b, l.coefficient);
        refiner.links
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::glossy_tiled_box;

    /// Every pair of `scene`'s surfaces (p < r).
    fn all_pairs(scene: &Scene) -> Vec<(u32, u32)> {
        let n = scene.surfaces.len() as u32;
        (0..n)
            .flat_map(|p| (p + 1..n).map(move |r| (p, r)))
            .collect()
    }

    #[test]
    fn a_plan_past_its_most_triples_keeps_the_largest_glossy_surfaces_whole() {
        let mut scene = glossy_tiled_box(1);
        // Tile 2 the largest of the four (still within the floor's plane).
        if let Patch::Parallelogram { edge_s, .. } = &mut scene.surfaces[2].patch {
            *edge_s *= 1.5;
        }
        let pairs = all_pairs(&scene);
        let all = surface_triples_at_most(&scene, &pairs, usize::MAX);
        assert_eq!((all.left_out, all.binned), (0, 0));
        // Each of the 4 glossy tiles with the 9 other surfaces (all pairs
        // are given), as sources and receivers.
        assert_eq!(all.planned.len(), 4 * 9 * 9);
        assert_eq!(surface_triples(&scene, &pairs), all);
        let of = |cut: &SurfaceTriples, p: u32| cut.planned.iter().filter(|t| t.1 == p).count();
        for (most, kept) in [
            (81, vec![2]),
            (200, vec![0, 2]),
            (323, vec![0, 1, 2]),
            (80, vec![]),
        ] {
            let cut = surface_triples_at_most(&scene, &pairs, most);
            for p in 0..4 {
                let whole = if kept.contains(&p) { 81 } else { 0 };
                assert_eq!(of(&cut, p), whole, "tile {p} within {most}");
            }
            assert_eq!(cut.binned, 4 - kept.len() as u64);
            assert_eq!(cut.left_out, (all.planned.len() - cut.planned.len()) as u64);
            let in_order = cut.planned.windows(2).all(|w| w[0].1 <= w[1].1);
            assert!(in_order, "in order of the glossy surface");
        }
    }

    #[test]
    fn small_glossy_surfaces_stop_where_their_elements_are_as_small_as_the_largest_ones() {
        use crate::geometry::tracing::SceneTracer;
        // 16 glossy floor tiles of 1/16 the walls' area, and a 0.2 square
        // light: under max_level 2 (A_ε is the walls' 1/16) both stay
        // whole, the walls reach level 2; a glossy element may be a
        // quarter of A_ε, so the tiles split once.
        let scene = glossy_tiled_box(2);
        let tracer = SceneTracer::new(&scene);
        let ctx = crate::kernel::default_context(&scene, &tracer);
        let light = scene.surfaces.len() as u32 - 1;
        let deepest = |s: u32| ctx.deepest_level(s, 2);
        assert_eq!((deepest(5), deepest(light), deepest(16)), (0, 0, 2));
        // A threshold of zero refines every triple as deep as it may go.
        let settings = ThreePointSettings {
            refine: RefineSettings {
                threshold: 0.0,
                max_level: 2,
            },
            receiver_max_level: 2,
        };
        let deepest_seen = |source: u32| {
            let triples: Vec<(u32, u32, u32)> = (16..light)
                .filter(|&q| q != source)
                .map(|q| (source, 5, q))
                .collect();
            let links = refine_three_point_links(
                &ctx,
                settings,
                None,
                &triples,
                |q| scene.surfaces[q as usize].patch,
                &Silent,
            )
            .into_links();
            let most = |level: fn(&ThreePointLink) -> u32| links.iter().map(level).max();
            [
                most(|l| l.c.level),
                most(|l| l.a.level),
                most(|l| l.b.level),
            ]
        };
        // Light from a wall: the tile splits once, the walls twice.
        assert_eq!(deepest_seen(17), [Some(2), Some(1), Some(2)]);
        // The light's image in the tile's sharp lobe (a highlight): its
        // source and glossy elements keep max_level.
        assert_eq!(deepest_seen(light), [Some(2), Some(2), Some(2)]);
    }
}
