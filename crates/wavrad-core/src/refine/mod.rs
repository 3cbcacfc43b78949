//! Adaptive projection of the kernels (paper §3.2): two-point links between
//! elements and three-point links through glossy elements, refined until
//! the oracle accepts them, with the light estimates the weighted oracles
//! weigh by.

pub mod emitter_links;
pub mod estimate;
pub mod importance;
pub mod oracle;
pub mod three_point_projection;
pub mod two_point_projection;

use crate::geometry::hierarchy::ElementRef;
use crate::kernel::KernelElement;
use crate::progress::Progress;
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

/// Replace every link by what `refine` makes of it, in parallel and in
/// order; also count the links that changed.
pub(crate) fn refine_each<L: Copy + PartialEq + Send + Sync>(
    links: &[L],
    progress: &dyn Progress,
    refine: impl Fn(&L) -> Vec<L> + Sync,
) -> (Vec<L>, usize) {
    let per_link: Vec<Vec<L>> = links
        .par_iter()
        .map(|l| {
            let out = refine(l);
            progress.advance(1);
            out
        })
        .collect();
    let changed = per_link
        .iter()
        .zip(links)
        .filter(|(new, old)| new.as_slice() != [**old])
        .count();
    (per_link.into_iter().flatten().collect(), changed)
}
