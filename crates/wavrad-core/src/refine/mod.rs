//! Adaptive projection of the kernels (paper §3.2): two-point links between
//! elements and three-point links through glossy elements, refined until
//! the oracle accepts them, with the light estimates the weighted oracles
//! weigh by.

pub mod cluster_links;
pub mod emitter_links;
pub mod estimate;
pub mod importance;
pub mod light_links;
pub mod oracle;
pub mod three_point_projection;
pub mod two_point_projection;

use crate::geometry::hierarchy::ElementRef;
use crate::kernel::{KernelContext, KernelElement};
use crate::progress::Progress;
use crate::refine::estimate::LightEstimate;
use crate::scene::{Patch, Scene};
use rayon::prelude::*;

/// One element of a pair or triple being refined, with its geometry.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Part {
    /// Which element it is.
    pub(crate) element: ElementRef,
    /// Its geometry.
    pub(crate) patch: Patch,
}

impl Part {
    /// `element` of `scene`.
    pub(crate) fn of(scene: &Scene, element: ElementRef) -> Part {
        let root = &scene.surfaces[element.surface as usize].patch;
        Part {
            element,
            patch: element.id.patch(root),
        }
    }

    /// Its four children, in [`Patch::subdivide`] order.
    pub(crate) fn children(&self) -> [Part; 4] {
        let patches = self.patch.subdivide();
        [0, 1, 2, 3].map(|k| Part {
            element: self.element.child(k),
            patch: patches[k],
        })
    }

    /// The element as a kernel evaluation takes it.
    pub(crate) fn kernel(&self) -> KernelElement<'_> {
        KernelElement {
            patch: &self.patch,
            surface: self.element.surface,
        }
    }
}

/// What projecting a list of items (surface pairs or triples, links) made,
/// item by item: every item's links in one vector, in item order, and per
/// item how many they are and whether it was projected in full. A vector
/// per item would cost an allocation and its spare room per item: several
/// times the links themselves, where most items make one or two.
#[derive(Debug, Clone, PartialEq)]
pub struct ByItem<L> {
    links: Vec<L>,
    /// Per item: its number of links, and whether it was projected in full
    /// (the work was not asked to stop, [`Progress::interrupted`], before
    /// it ended, so projecting it again would make the same links; a stop
    /// that comes between an item's last test and this one marks it
    /// unfinished too, which only costs projecting it again).
    items: Vec<(u32, bool)>,
}

impl<L> Default for ByItem<L> {
    fn default() -> Self {
        ByItem {
            links: Vec::new(),
            items: Vec::new(),
        }
    }
}

impl<L> ByItem<L> {
    /// The number of items.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether it holds no item.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Add one item: its `links`, and whether it was projected in full.
    pub fn push(&mut self, links: impl IntoIterator<Item = L>, finished: bool) {
        let before = self.links.len();
        self.links.extend(links);
        let made = u32::try_from(self.links.len() - before).expect("an item's links fit a u32");
        self.items.push((made, finished));
    }

    /// Every item's links and whether it was projected in full, in order.
    pub fn iter(&self) -> impl Iterator<Item = (&[L], bool)> {
        let mut rest = self.links.as_slice();
        self.items.iter().map(move |&(made, finished)| {
            let (links, after) = rest.split_at(made as usize);
            rest = after;
            (links, finished)
        })
    }

    /// Every item's links, in order, at their length (a solve holds them
    /// to its end).
    pub fn into_links(mut self) -> Vec<L> {
        self.links.shrink_to_fit();
        self.links
    }

    /// These items as some of a longer list, the `k`-th of them where
    /// `these[k]` is the `k`-th true value; the others made no links and
    /// count as projected in full.
    pub(crate) fn among(self, these: &[bool]) -> ByItem<L> {
        let mut mine = self.items.into_iter();
        let items = (these.iter())
            .map(|&this| match this {
                true => mine.next().expect("one item per true value"),
                false => (0, true),
            })
            .collect();
        debug_assert!(mine.next().is_none(), "one true value per item");
        ByItem {
            links: self.links,
            items,
        }
    }

    /// Add the items `made` in one pass, in order.
    fn append(&mut self, made: Vec<(Vec<L>, bool)>) {
        self.links
            .reserve(made.iter().map(|(links, _)| links.len()).sum());
        for (links, finished) in made {
            self.push(links, finished);
        }
    }
}

/// Most items of one parallel pass of [`project_each`] and
/// [`project_while_unspent`]: each pass's own vectors of links are held
/// only until it ends, and the budget is looked at between passes.
const MAX_PASS: usize = 1 << 16;

/// What `project` makes of every item, in parallel and in order, one
/// progress step each under the phase `label`; the result does not depend
/// on the number of threads. `project(item, refine)` refines unless the
/// work was asked to stop ([`Progress::interrupted`]); the items it did not
/// refine are reported ([`Progress::cut_short`]).
pub(crate) fn project_each<T: Sync, L: Send>(
    label: &str,
    items: &[T],
    progress: &dyn Progress,
    project: impl Fn(&T, bool) -> Vec<L> + Sync,
) -> ByItem<L> {
    progress.start(label, items.len() as u64);
    let mut out = ByItem::default();
    for pass in items.chunks(MAX_PASS) {
        out.append(
            pass.par_iter()
                .map(|item| {
                    let refine = !progress.interrupted();
                    if !refine {
                        progress.cut_short(1);
                    }
                    let links = project(item, refine);
                    progress.holding(std::mem::size_of_val(links.as_slice()) as u64);
                    progress.advance(1);
                    (links, refine && !progress.interrupted())
                })
                .collect(),
        );
    }
    progress.finish();
    out
}

/// What `project_while_unspent` made of a list of items: the links of
/// its first `items.len()` items, in order, and how many items after them
/// were left out without being looked at.
#[derive(Debug, Clone, PartialEq)]
pub struct Projected<L> {
    /// The links of the first items.
    pub items: ByItem<L>,
    /// Items after those, left out: no links, no quadrature.
    pub left_out: usize,
}

/// Items of the first parallel pass of [`project_while_unspent`]; each
/// pass takes twice as many as the last, up to [`MAX_PASS`].
const FIRST_PASS: usize = 1024;

/// What `project` makes of each of `items`, in parallel passes and in
/// order, one progress step each under the phase `label`, until the work is
/// asked to stop ([`Progress::interrupted`]): from then on the items not
/// yet started are left out ([`Progress::left_out`]) with no links and no
/// quadrature, those of the pass under way one by one and every later one
/// at once, so a stop ends the phase within one item's work however many
/// items remain, and the memory held grows only with the items projected.
/// The result does not depend on the number of threads (each item is
/// projected on its own), only, once stopped, on when the stop came.
pub(crate) fn project_while_unspent<T: Sync, L: Send>(
    label: &str,
    items: &[T],
    progress: &dyn Progress,
    project: impl Fn(&T) -> Vec<L> + Sync,
) -> Projected<L> {
    progress.start(label, items.len() as u64);
    let mut done = ByItem::default();
    let (mut rest, mut pass) = (items, FIRST_PASS);
    while !rest.is_empty() && !progress.interrupted() {
        let (now, later) = rest.split_at(pass.min(rest.len()));
        done.append(
            now.par_iter()
                .map(|item| {
                    if progress.interrupted() {
                        progress.left_out(1);
                        progress.advance(1);
                        return (Vec::new(), false);
                    }
                    let links = project(item);
                    progress.holding(std::mem::size_of_val(links.as_slice()) as u64);
                    progress.advance(1);
                    (links, !progress.interrupted())
                })
                .collect(),
        );
        rest = later;
        pass = (2 * pass).min(MAX_PASS);
    }
    if !rest.is_empty() {
        progress.left_out(rest.len() as u64);
    }
    progress.finish();
    Projected {
        items: done,
        left_out: rest.len(),
    }
}

/// Replace every link by what `refine` makes of it, in parallel and in
/// order (once the work is asked to stop, the links left stay as they
/// are); also count the links that changed.
pub(crate) fn refine_each<L: Copy + PartialEq + Send + Sync>(
    label: &str,
    links: &[L],
    progress: &dyn Progress,
    refine: impl Fn(&L) -> Vec<L> + Sync,
) -> (Vec<L>, usize) {
    let per_link = project_each(label, links, progress, |l, go_on| match go_on {
        true => refine(l),
        false => vec![*l],
    });
    let changed = per_link
        .iter()
        .zip(links)
        .filter(|((new, _), old)| *new != [**old])
        .count();
    (per_link.into_links(), changed)
}

/// A kernel projection (two-point or three-point), named by its settings,
/// as the refine–solve loop re-judges the links it made.
pub trait Projection: Copy + Sync {
    /// The links it makes.
    type Link: Copy + PartialEq + Send + Sync;
    /// The progress phase of a pass over its links.
    const PHASE: &'static str;

    /// What `link` becomes under the new `estimate`: itself while the
    /// weighted oracle still accepts it (as far as its stored detail tells,
    /// without new quadrature), else the links it is refined into.
    fn refine_link(
        &self,
        ctx: &KernelContext,
        estimate: &LightEstimate,
        link: &Self::Link,
    ) -> Vec<Self::Link>;
}

/// One pass of the refine–solve loop over the `links` of the projection
/// `settings`: every link that the weighted oracle rejects under the new
/// `estimate` is refined further (links are never coarsened); the others
/// are kept as they are. Returns the links, in a deterministic order, and
/// how many were refined.
pub fn refine_further<P: Projection>(
    ctx: &KernelContext,
    settings: P,
    estimate: &LightEstimate,
    links: Vec<P::Link>,
    progress: &dyn Progress,
) -> (Vec<P::Link>, usize) {
    refine_each(P::PHASE, &links, progress, |l| {
        settings.refine_link(ctx, estimate, l)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Silent;

    #[test]
    fn items_keep_their_own_links_across_passes() {
        // Items 3k make none, 3k+1 one, 3k+2 two: over three passes.
        let items: Vec<usize> = (0..2 * MAX_PASS + 5).collect();
        let made = project_each("test", &items, &Silent, |&i, refine| {
            assert!(refine);
            vec![i; i % 3]
        });
        assert_eq!(made.len(), items.len());
        for (i, (links, finished)) in made.iter().enumerate() {
            assert_eq!(links, vec![i; i % 3].as_slice(), "item {i}");
            assert!(finished);
        }
        let all = made.clone().into_links();
        assert_eq!(all.len(), items.iter().map(|i| i % 3).sum::<usize>());
        assert!(all.windows(2).all(|w| w[0] <= w[1]));

        // The same items among others that made none.
        let these: Vec<bool> = (0..2 * items.len()).map(|k| k % 2 == 1).collect();
        let among = made.among(&these);
        assert_eq!(among.len(), these.len());
        for (k, (links, finished)) in among.iter().enumerate() {
            let i = k / 2;
            let expected = if these[k] { vec![i; i % 3] } else { Vec::new() };
            assert_eq!(links, expected.as_slice(), "item {k}");
            assert!(finished);
        }
    }
}
