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

use crate::progress::Progress;
use rayon::prelude::*;

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
