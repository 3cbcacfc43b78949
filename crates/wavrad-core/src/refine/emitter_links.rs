//! Emitter links resolved per receiver element: a link from an emitter is
//! carried down its diffuse receiver's element tree wherever the light it
//! brings changes over the receiver's children, after the oracle kept it.

use crate::geometry::hierarchy::ElementId;
use crate::kernel::{KernelContext, KernelElement};
use crate::progress::Progress;
use crate::refine::oracle::average_detail;
use crate::refine::refine_each;
use crate::refine::two_point_projection::{ChildShares, Link};

/// Relative variation of an emitter link's kernel over its receiver's
/// children (largest Haar detail of their mean kernel over the mean) above
/// which [`resolve_emitter_links`] carries the link down to them.
pub const EMITTER_LINK_VARIATION: f64 = 0.02;

/// Links from an emitter carried down their diffuse receiver's element
/// tree, as far as its deepest level under `max_level`
/// ([`KernelContext::deepest_level`]), wherever the kernel varies over the
/// receiver's children by more than [`EMITTER_LINK_VARIATION`] of its mean.
///
/// The oracles test a kernel's details against a threshold in absolute
/// units, so a small emitter's links stop coarse where its light changes
/// fast: on the Cornell box, the light's link to the top of the back wall
/// covered the two rows of elements below the ceiling, across which the
/// grazing direct light falls by a factor of four, and gave both their
/// average (the top row 2.4× too bright; the ceiling beside it, lit by that
/// row, too bright in turn), and the paper's settings left Figure 3's
/// directly lit reflector a few elements. Push–pull spreads a link's light
/// evenly over the receiver's children; this measures it per child
/// instead, at one quadrature per child tested. The elements it reaches
/// may be finer than any other link's: build the element trees from the
/// links it returns.
pub fn resolve_emitter_links(
    ctx: &KernelContext,
    max_level: u32,
    links: &[Link],
    progress: &dyn Progress,
) -> (Vec<Link>, usize) {
    let scene = ctx.scene;
    let emits = |s: u32| scene.surfaces[s as usize].is_emitter();
    let receives = |s: u32| {
        let surface = &scene.surfaces[s as usize];
        surface.brdf.lambertian().is_some() && !surface.is_emitter()
    };
    refine_each("emitter links", links, progress, |l| {
        // (receiver, element, emitter, element), and the link's orientation.
        let (receiver, a, emitter, c, flipped) = match (emits(l.p), emits(l.r)) {
            (false, true) if receives(l.p) => (l.p, l.a, l.r, l.c, false),
            (true, false) if receives(l.r) => (l.r, l.c, l.p, l.a, true),
            _ => return vec![*l],
        };
        let source = c.patch(&scene.surfaces[emitter as usize].patch);
        // A link kept at its own receiver stays as it was.
        let link = |element: ElementId, throughput: f64, t: Option<&[f64]>| {
            if element == a {
                return *l;
            }
            let (a, c) = if flipped { (c, element) } else { (element, c) };
            Link {
                a,
                c,
                throughput,
                children: t.and_then(|t| ChildShares::new(!flipped, t)),
                ..*l
            }
        };
        let mut out = Vec::new();
        let patch = a.patch(&scene.surfaces[receiver as usize].patch);
        let deepest = ctx.deepest_level(receiver, max_level);
        let mut stack = vec![(a, patch, l.throughput)];
        while let Some((id, patch, throughput)) = stack.pop() {
            if id.level >= deepest {
                out.push(link(id, throughput, None));
                continue;
            }
            let children = patch.subdivide();
            let t: Vec<f64> = children
                .iter()
                .map(|child| {
                    ctx.throughput(
                        KernelElement {
                            patch: child,
                            surface: receiver,
                        },
                        KernelElement {
                            patch: &source,
                            surface: emitter,
                        },
                    )
                })
                .collect();
            let means = [0, 1, 2, 3].map(|k| t[k] / children[k].area());
            let mean = means.iter().sum::<f64>() / 4.0;
            if mean <= 0.0 || average_detail(means) <= EMITTER_LINK_VARIATION * mean {
                out.push(link(id, throughput, Some(&t)));
                continue;
            }
            // Children in reverse so the links come out in tree order.
            for (k, tk) in (0..4).zip(t).rev() {
                if tk > 0.0 {
                    stack.push((id.child(k), children[k], tk));
                }
            }
        }
        out
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::tracing::SceneTracer;
    use crate::kernel::default_context as context;
    use crate::progress::Silent;
    use crate::scene::{Rgb, Scene, Surface};

    /// A light close over a corner of the floor lights it unevenly: its
    /// link to the whole floor is carried down to level-2 elements where
    /// the light changes, and they share its throughput as the light sends
    /// it. Seen from far, the light is even: the link stays whole. Links
    /// between surfaces that do not emit are never touched.
    #[test]
    fn emitter_links_are_resolved_down_to_the_receivers_elements() {
        let link = |ctx: &KernelContext| {
            let patch = |s: usize| ctx.scene.surfaces[s].patch;
            let t = ctx.throughput(
                KernelElement {
                    patch: &patch(0),
                    surface: 0,
                },
                KernelElement {
                    patch: &patch(1),
                    surface: 1,
                },
            );
            Link {
                p: 0,
                a: ElementId::ROOT,
                r: 1,
                c: ElementId::ROOT,
                throughput: t,
                detail: 0.0,
                children: None,
            }
        };
        let resolve =
            |ctx: &KernelContext, link: Link| resolve_emitter_links(ctx, 2, &[link], &Silent);
        let scene = crate::testing::light_over_a_corner(0.3);
        let tracer = SceneTracer::new(&scene);
        let ctx = context(&scene, &tracer);
        let root = link(&ctx);
        let (resolved, changed) = resolve(&ctx, root);
        assert_eq!(changed, 1);
        assert!(resolved.iter().any(|l| l.a.level == 2), "{resolved:?}");
        assert!(resolved.iter().all(|l| l.a.level <= 2), "{resolved:?}");
        assert!(resolved.iter().all(|l| (l.r, l.c) == (1, ElementId::ROOT)));
        // The links partition the floor: unoccluded, quadrature over the
        // light against the closed form is exact for any floor element.
        let total: f64 = resolved.iter().map(|l| l.throughput).sum();
        assert!(
            (total - root.throughput).abs() < 1e-9 * total,
            "{total} vs {root:?}"
        );
        // The element under the light gets its share, not the average.
        let corner = ElementId::ROOT.child(0).child(0);
        let under = resolved
            .iter()
            .find(|l| l.a == corner)
            .expect("corner link");
        let per_area = under.throughput / (1.0 / 16.0);
        assert!(
            per_area > 4.0 * root.throughput,
            "{per_area} vs {}",
            root.throughput
        );
        // From far above, the light is even over the floor.
        let far = crate::testing::light_over_a_corner(50.0);
        let tracer = SceneTracer::new(&far);
        let ctx = context(&far, &tracer);
        let root = link(&ctx);
        let (same, changed) = resolve(&ctx, root);
        assert_eq!((same, changed), (vec![root], 0));
        // No emitter: untouched.
        let dark = crate::testing::light_over_a_corner(0.3);
        let dark = Scene::from_surfaces(
            dark.surfaces
                .into_iter()
                .map(|s| Surface {
                    emission: Rgb::ZERO,
                    ..s
                })
                .collect(),
        );
        let tracer = SceneTracer::new(&dark);
        let ctx = context(&dark, &tracer);
        let root = link(&ctx);
        let (same, changed) = resolve(&ctx, root);
        assert_eq!((same, changed), (vec![root], 0));
    }
}
