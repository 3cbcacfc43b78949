//! The whole solution (paper §4.2, wavelet_radiance): compute kernels
//! ([`crate::refine::two_point_projection::refine_links`]), build the element hierarchies, then
//! Gauss–Seidel gathering with push–pull until the coarsest coefficients
//! settle. [`shoot`] solves diffuse scenes by progressive shooting instead,
//! projecting kernels only where light flows (the paper's §6).

pub mod checkpoint;
pub mod cluster_gather;
pub mod direction_cells;
mod extrapolation;
pub mod gather;
pub mod glossy_clusters;
pub mod push_pull;
pub mod settings;
pub mod shoot;
pub mod stats;

use crate::geometry::cluster::ClusterTree;
use crate::geometry::hierarchy::{ElementId, ElementRef, ElementTree};
use crate::geometry::pair_tree::PairTree;
use crate::geometry::tracing::SceneTracer;
use crate::kernel::exposure::{exposed_fractions, PairExposure};
use crate::kernel::{KernelContext, Quadrature};
use crate::progress::{Budget, Budgeted, Progress};
use crate::refine::cluster_links::{
    link_from_root, ClusterLink, ClusterSettings, End, Linking, MAX_CLUSTER_RATIO,
};
use crate::refine::emitter_links::resolve_emitter_links;
use crate::refine::estimate::LightEstimate;
use crate::refine::importance::Importance;
use crate::refine::light_links::{link_lights, LightLink};
use crate::refine::oracle::{Oracle, WEIGHTED_THRESHOLD};
use crate::refine::refine_further;
use crate::refine::three_point_projection::{
    project_triples, surface_triples, SurfaceTriples, ThreePointLink, ThreePointSettings,
};
use crate::refine::two_point_projection::{refine_links_by_item, Link, RefineSettings};
use crate::scene::{Rgb, Scene};
use crate::solve::stats::{LinkCounts, PhaseTimes, Stats, Sweeps};
use crate::{Error, Result};
use checkpoint::{merged, runs_of, Packed, Run, RunSpan};
pub use checkpoint::{resume, Checkpoint, CheckpointView, Saver, Unfinished};
use cluster_gather::{ClusterTransfers, FarField};
use extrapolation::Extrapolation;
use gather::{Directional, Interactions};
use rayon::prelude::*;
use std::borrow::Cow;
use std::collections::BTreeSet;
use std::ops::Range;
use std::time::Instant;

/// Settings of a solve.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SolveSettings {
    /// Kernel projection (oracle threshold, maximum level).
    pub refine: RefineSettings,
    /// Quadrature of every kernel coefficient.
    pub quadrature: Quadrature,
    /// Deepest element level of three-point links (each of the three
    /// elements). Their count grows with the cube of the elements per
    /// surface, so they stop coarser than two-point links by default (2:
    /// the final gather lights glossy surfaces per point, so on the glossy
    /// Cornell box level 3 buys little error for many times the links; the
    /// `level-3` rows of `docs/benchmarks.md`); the paper uses 8 for both.
    pub three_point_max_level: u32,
    /// Levels the receiving element of a three-point link may go below
    /// `three_point_max_level` (default 3), for light straight from an
    /// emitter where the glossy surface's lobe is sharp and narrower than
    /// the element seen from the glossy one (so never for broad lobes). Only the receiver splits there,
    /// which costs no ray queries, and a diffuse receiver's two-point links
    /// read the glossy surface's directional radiance at that resolution
    /// ([`Interactions`]): a highlight's edges sharpen
    /// on the receiver for a few times the kernel time instead of the
    /// tenfold of one more level for all three elements (`docs/figure3.md`).
    pub three_point_receiver_levels: u32,
    /// Oracle threshold of three-point links (the paper's orthonormal
    /// normalisation). Glossy lobes concentrate light that the kernel-only
    /// oracle sees as small kernel values, so it is finer than the
    /// two-point threshold by default; the paper uses 1e-4 for both. At the
    /// default maximum level three-point links are cheap enough to afford it
    /// (commit c9faf7d has the measurements).
    pub three_point_threshold: f64,
    /// Stop when the power all surfaces send (each coarsest coefficient
    /// times its surface's area) changes in a sweep by at most this
    /// fraction of itself.
    pub tolerance: f64,
    /// Give up after this many Gauss–Seidel sweeps.
    pub max_iterations: u32,
    /// Which test decides that a link is fine enough (the thresholds above
    /// are in its units).
    pub oracle: Oracle,
    /// Most projections of the refine–solve loop of the weighted oracles
    /// (the first counts; 1 keeps the links projected with the emission).
    pub max_refine_passes: u32,
    /// Largest (r_x + r_y)/d of a cluster link: clusters of surfaces and
    /// elements that are this small against their distance exchange light
    /// as wholes ([`crate::refine::cluster_links`]); 0 links every pair of
    /// surfaces as the paper does.
    pub cluster_ratio: f64,
    /// Wall-clock seconds the solve may take before refinement stops
    /// splitting and Gauss–Seidel stops sweeping ([`Budget`]); 0: no limit.
    pub time_limit: f64,
    /// Resident memory, in GiB, at which refinement stops splitting and
    /// Gauss–Seidel stops sweeping ([`Budget`]; during the projection,
    /// the memory with the copies of its links that the end of the solve
    /// will hold); 0: [`DEFAULT_MEMORY_SHARE`]
    /// of the machine's physical memory.
    pub max_memory: f64,
}

/// Share of the machine's physical memory a solve may hold by default
/// ([`SolveSettings::max_memory`] 0).
pub const DEFAULT_MEMORY_SHARE: f64 = 0.8;

/// How the radiance system is solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Solver {
    /// [`solve`]: every kernel projected up front, then Gauss–Seidel
    /// gathering (the paper's §4.2).
    #[default]
    Gather,
    /// [`shoot::solve_shooting`]: progressive shooting from the emitters,
    /// kernels projected lazily where light flows (the paper's §6).
    Shoot,
}

/// A view-independent radiance solution.
pub struct Solution {
    /// The scene solved.
    pub scene: Scene,
    /// Ray queries over its surfaces (shared with rendering).
    pub tracer: SceneTracer,
    /// The surface pairs (p < r) linked element to element, which can
    /// exchange light (the rest exchange it through cluster links).
    pub pairs: Vec<(u32, u32)>,
    /// One element hierarchy per surface.
    pub trees: Vec<ElementTree>,
    /// Average radiance of every node of every tree, `radiance[surface][node]`:
    /// emission and Lambertian reflection (all of a diffuse surface's; of a
    /// glossy one, what leaves it alike in every direction).
    pub radiance: Vec<Vec<Rgb>>,
    /// The links arranged for gathering, with the directional structures of
    /// glossy surfaces (`interactions.directional`).
    pub interactions: Interactions,
    /// Average radiance L_{a→b} of every node of every directional structure:
    /// the light the glossy surface's non-Lambertian lobes reflect towards
    /// the receiver, on top of its elements' `radiance`.
    pub directional: Vec<Vec<Rgb>>,
    /// The refinement settings of the solve (rendering reuses them for the
    /// eye receiver).
    pub settings: SolveSettings,
    /// What it took (paper §5 quantities, times, memory).
    pub stats: Stats,
    /// What a gathering solve cut short had finished, to [`resume`] it
    /// from; `None` when it ran to the end (or shot).
    pub checkpoint: Option<Checkpoint>,
}

/// Solve `scene`: diffuse surfaces through two-point links (eq. 12), glossy
/// ones through three-point links and directional radiance (eq. 13), and
/// their Lambertian lobes through two-point links ([`gather`]).
///
/// With the paper's oracle the kernels are projected once. The weighted
/// oracles need the light the links carry, so they run a refine–solve loop
/// (Hanrahan et al. 1991): links are projected with the emission alone,
/// the system is solved, every link is re-tested against the new solution
/// (from the detail stored with it, without new quadrature) and refined
/// further where it fails, until no link changes or after
/// `settings.max_refine_passes` passes.
///
/// The steps of a [`Plan`] in one process: [`plan`], the projection of all
/// its items, [`Plan::finish`].
///
/// # Errors
/// [`Error::InvalidSetting`] for bad settings (or the importance oracle
/// without a sensor), [`Error::EmptyScene`], [`Error::NoLight`] for a scene
/// where nothing emits, all before any kernel work; [`Error::Diverged`]
/// when Gauss–Seidel's residual keeps growing.
pub fn solve(scene: &Scene, settings: &SolveSettings, progress: &dyn Progress) -> Result<Solution> {
    solve_saving(scene, settings, None, progress)
}

/// [`solve`], saving a checkpoint through `saver` as the kernels are
/// projected, for [`resume`] after the process is killed (the solution is
/// [`solve`]'s bit for bit).
///
/// # Errors
/// Those of [`solve`].
pub fn solve_saving(
    scene: &Scene,
    settings: &SolveSettings,
    saver: Option<&Saver>,
    progress: &dyn Progress,
) -> Result<Solution> {
    let plan = plan(scene, settings, progress)?;
    let all: Vec<usize> = plan.items().collect();
    let runs = plan.project_saving(&all, &[], saver, progress);
    plan.finish_runs(runs, 0, progress)
}

/// A gathering solve ([`solve`]) up to its kernel projection: the scene's
/// ray queries, its cluster tree and the linking from the root
/// ([`link_from_root`]). The linking fixes the projection's *items*: its
/// element pairs, then the surface triples (r, p, q) of the glossy surfaces
/// ([`surface_triples`]). Each item is refined on its own (compute_kernel,
/// §4.2), so the items can be split into blocks projected anywhere — other
/// threads, processes, machines — by [`Plan::project`]; [`Plan::finish`]
/// takes the blocks' links in item order and solves. The solution is
/// [`solve`]'s bit for bit, however the items are split. A process that is
/// sent its items ([`Plan::block_items`]) projects them with a
/// [`Projector`] of the same scene and settings, without the linking.
///
/// ```
/// use wavrad_core::progress::Silent;
/// use wavrad_core::solve::{plan, solve, SolveSettings};
///
/// let scene = wavrad_core::testing::light_over_a_corner(0.3);
/// let settings = SolveSettings::default();
/// let plan = plan(&scene, &settings, &Silent).unwrap();
/// let blocks = plan
///     .blocks(2)
///     .into_iter()
///     .map(|block| plan.project(block, &Silent).unwrap())
///     .collect();
/// let split = plan.finish(blocks, &Silent).unwrap();
/// let whole = solve(&scene, &settings, &Silent).unwrap();
/// assert_eq!(split.radiance, whole.radiance);
/// ```
pub struct Plan {
    projector: Projector,
    clusters: ClusterTree,
    linking: Linking,
    /// The surface pairs of `linking`'s element pairs.
    pairs: Vec<(u32, u32)>,
    triples: Vec<(u32, u32, u32)>,
    /// The scene's triples past [`MAX_TRIPLES`](crate::refine::three_point_projection::MAX_TRIPLES),
    /// left out of `triples`.
    unplanned_triples: u64,
    /// The glossy surfaces whose triples those are.
    binned: u64,
    times: PhaseTimes,
}

/// What projecting needs besides the items: the scene, its ray queries,
/// the settings, and the light the weighted oracles weigh the first
/// projection with.
pub struct Projector {
    /// The limits of the solve, from the projector's creation.
    budget: Budget,
    scene: Scene,
    settings: SolveSettings,
    tracer: SceneTracer,
    estimate: Option<LightEstimate>,
}

/// The items of one block of a plan ([`Plan::block_items`]), for a
/// [`Projector`] elsewhere.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BlockItems {
    /// Which of the plan's items they are.
    pub items: Range<usize>,
    /// The element pairs among them, in order.
    pub element_pairs: Vec<[ElementRef; 2]>,
    /// The surface triples (r, p, q) among them, in order.
    pub triples: Vec<(u32, u32, u32)>,
}

/// The links [`Plan::project`] or [`Projector::project`] made of one block
/// of a plan's items.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BlockLinks {
    /// The items projected (indices into the plan's items).
    pub items: Range<usize>,
    /// The two-point links of its element pairs, in item order.
    pub two_point: Vec<Link>,
    /// The three-point links of its surface triples, in item order.
    pub three_point: Vec<ThreePointLink>,
    /// Seconds the projection took where it ran.
    pub kernels_s: f64,
}

/// Plan the gathering solve of `scene`: check the settings, build the ray
/// queries and the cluster tree, link from the root cluster, and list the
/// surface triples of glossy surfaces.
pub fn plan(scene: &Scene, settings: &SolveSettings, progress: &dyn Progress) -> Result<Plan> {
    let mut times = PhaseTimes::default();
    let projector = Projector::timed(scene, settings, &mut times)?;

    // What compute_kernel() will project: pairs and triples of elements.
    let clock = Instant::now();
    let ctx = projector.kernel_context();
    let clusters = ClusterTree::build(scene);
    // Direct lighting only (the longest path two segments): the solution
    // holds the emission alone, and nothing is linked.
    let linking = match bounces(scene) {
        Some(0) => Linking::default(),
        _ => link_from_root(
            &ctx,
            &clusters,
            settings.clusters(),
            &projector.budgeted(progress),
        ),
    };
    times.kernels_s += clock.elapsed().as_secs_f64();
    // Linking is the plan's first budgeted work: every pair linked coarse
    // so far is its own.
    let coarse = projector.budget.coarse_items();
    if let (Some(stop), true) = (projector.budget.stopped(), coarse > 0) {
        progress.warn(&format!(
            "{stop} cut the linking short: {coarse} pairs of clusters or elements were \
             linked whole, up to (size of both ends)/distance {MAX_CLUSTER_RATIO} instead of the \
             cluster ratio {}; their light is carried, less accurately",
            settings.cluster_ratio
        ));
    }
    let plan = Plan::new(projector, clusters, linking, times);
    if plan.unplanned_triples > 0 {
        progress.warn(&format!(
            "the scene has {} surface triples (r, p, q) of glossy surfaces p, more than a plan \
             holds: {} smaller glossy surfaces, with {} of them, get no three-point links; their \
             lobes' light is carried, less sharply, as each surface's average over 128 directions",
            plan.triples.len() as u64 + plan.unplanned_triples,
            plan.binned,
            plan.unplanned_triples
        ));
    }
    Ok(plan)
}

impl Projector {
    /// Check the settings against `scene` and build the ray queries (and,
    /// for the weighted oracles, the emission's light estimate).
    pub fn new(scene: &Scene, settings: &SolveSettings) -> Result<Projector> {
        Projector::timed(scene, settings, &mut PhaseTimes::default())
    }

    /// [`Projector::new`], adding its times to `times`.
    fn timed(scene: &Scene, settings: &SolveSettings, times: &mut PhaseTimes) -> Result<Projector> {
        let budget = settings.budget();
        settings.validate()?;
        check_size(scene)?;
        check_light(scene)?;
        if settings.oracle == Oracle::Importance && scene.camera.is_none() {
            return Err(Error::InvalidSetting(
                "the importance oracle needs a sensor in the scene".into(),
            ));
        }

        // Visibility structure.
        let clock = Instant::now();
        let scene = scene.clone();
        let tracer = SceneTracer::new(&scene);
        times.visibility_build_s += clock.elapsed().as_secs_f64();

        let clock = Instant::now();
        let ctx = KernelContext::new(&scene, &tracer, settings.quadrature);
        let estimate = settings
            .oracle
            .is_weighted()
            .then(|| LightEstimate::emission(&scene, importance(&ctx, settings.oracle, &[])));
        times.kernels_s += clock.elapsed().as_secs_f64();
        Ok(Projector {
            budget,
            settings: *settings,
            estimate,
            tracer,
            scene,
        })
    }

    /// The scene projected in.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The settings of the solve.
    pub fn settings(&self) -> &SolveSettings {
        &self.settings
    }

    /// compute_kernel() (§4.2) of `block`: the adaptive two-point links of
    /// its element pairs and three-point links of its surface triples,
    /// refined in parallel.
    pub fn project(&self, block: &BlockItems, progress: &dyn Progress) -> BlockLinks {
        let numbers: Vec<usize> = block.items.clone().collect();
        let runs = self.project_numbered(&numbers, &block.element_pairs, &block.triples, progress);
        merged(block.items.clone(), runs)
    }

    /// compute_kernel() (§4.2) of the items numbered `numbers`
    /// (increasing): the element pairs `element_pairs`, then the surface
    /// triples `triples`, refined in parallel; their links in runs of
    /// consecutive items alike projected in full or cut short.
    fn project_numbered(
        &self,
        numbers: &[usize],
        element_pairs: &[[ElementRef; 2]],
        triples: &[(u32, u32, u32)],
        progress: &dyn Progress,
    ) -> Vec<Run> {
        let clock = Instant::now();
        let progress = &self.budgeted(progress);
        let ctx = self.kernel_context();
        let two_point = refine_links_by_item(
            &ctx,
            self.settings.refine,
            self.estimate.as_ref(),
            element_pairs,
            progress,
        );
        let three_point = project_triples(
            &ctx,
            self.settings.three_point_refine(),
            self.estimate.as_ref(),
            triples,
            progress,
        );
        runs_of(
            numbers,
            two_point,
            three_point,
            clock.elapsed().as_secs_f64(),
        )
    }

    /// `progress` asking the work to stop once the budget is spent.
    fn budgeted<'a>(&'a self, progress: &'a dyn Progress) -> Budgeted<'a> {
        Budgeted {
            progress,
            budget: &self.budget,
        }
    }

    fn kernel_context(&self) -> KernelContext<'_> {
        KernelContext::new(&self.scene, &self.tracer, self.settings.quadrature)
    }
}

/// The receivers' importance for the scene's sensor, lit through `links`,
/// when the importance oracle decides.
fn importance(ctx: &KernelContext, oracle: Oracle, links: &[Link]) -> Option<Importance> {
    let camera = ctx.scene.camera.as_ref()?;
    (oracle == Oracle::Importance).then(|| Importance::new(ctx, camera, &ctx.scene.film, links))
}

impl Plan {
    /// The plan of `projector` from `linking`, made over `clusters`.
    fn new(
        projector: Projector,
        clusters: ClusterTree,
        linking: Linking,
        times: PhaseTimes,
    ) -> Plan {
        let pairs = linking.surface_pairs();
        let SurfaceTriples {
            planned: triples,
            left_out: unplanned_triples,
            binned,
        } = surface_triples(&projector.scene, &pairs);
        Plan {
            projector,
            clusters,
            linking,
            pairs,
            triples,
            unplanned_triples,
            binned,
            times,
        }
    }

    /// What projects its items here.
    pub fn projector(&self) -> &Projector {
        &self.projector
    }

    /// The element pairs to project, the first items.
    pub fn element_pairs(&self) -> &[[ElementRef; 2]] {
        &self.linking.element_pairs
    }

    /// The surface triples (r, p, q) to project, the items after the
    /// element pairs.
    pub fn triples(&self) -> &[(u32, u32, u32)] {
        &self.triples
    }

    /// The scene's surface triples left out of the plan, with no links
    /// ([`MAX_TRIPLES`](crate::refine::three_point_projection::MAX_TRIPLES)).
    pub fn unplanned_triples(&self) -> u64 {
        self.unplanned_triples
    }

    /// The links between clusters, made by the linking (not projected).
    pub fn cluster_links(&self) -> &[ClusterLink] {
        &self.linking.cluster_links
    }

    /// Every item: `0..element pairs + triples`.
    pub fn items(&self) -> Range<usize> {
        0..self.linking.element_pairs.len() + self.triples.len()
    }

    /// The items in at most `n` consecutive blocks of sizes that differ by
    /// one at most (none without items).
    pub fn blocks(&self, n: usize) -> Vec<Range<usize>> {
        let items = self.items().end;
        let n = n.clamp(1, items.max(1));
        (0..n)
            .map(|k| k * items / n..(k + 1) * items / n)
            .filter(|block| !block.is_empty())
            .collect()
    }

    /// The items in `block`, to be projected by a [`Projector`].
    pub fn block_items(&self, block: Range<usize>) -> Result<BlockItems> {
        let items = self.items().end;
        if block.start > block.end || block.end > items {
            return Err(Error::Blocks {
                items,
                problem: format!("block {block:?} is not a range of them"),
            });
        }
        let element_pairs = self.linking.element_pairs.len();
        let (pairs, triples) = (
            block.start.min(element_pairs)..block.end.min(element_pairs),
            block.start.max(element_pairs) - element_pairs
                ..block.end.max(element_pairs) - element_pairs,
        );
        Ok(BlockItems {
            items: block,
            element_pairs: self.linking.element_pairs[pairs].to_vec(),
            triples: self.triples[triples].to_vec(),
        })
    }

    /// compute_kernel() (§4.2) of the items in `block`
    /// ([`Projector::project`]).
    pub fn project(&self, block: Range<usize>, progress: &dyn Progress) -> Result<BlockLinks> {
        Ok(self.projector.project(&self.block_items(block)?, progress))
    }

    /// compute_kernel() (§4.2) of the items numbered `numbers` (increasing,
    /// each below [`Plan::items`]'s end), in runs of consecutive items
    /// alike projected in full or cut short.
    fn project_numbered(&self, numbers: &[usize], progress: &dyn Progress) -> Vec<Run> {
        let pairs = &self.linking.element_pairs;
        let split = numbers.partition_point(|&n| n < pairs.len());
        let element_pairs: Vec<[ElementRef; 2]> =
            numbers[..split].iter().map(|&n| pairs[n]).collect();
        let triples: Vec<(u32, u32, u32)> = (numbers[split..].iter())
            .map(|&n| self.triples[n - pairs.len()])
            .collect();
        (self.projector).project_numbered(numbers, &element_pairs, &triples, progress)
    }

    /// Check that `blocks` hold every item once, in any order, as
    /// [`Plan::finish`] needs.
    pub fn check_cover(&self, blocks: &[BlockLinks]) -> Result<()> {
        let items = self.items().end;
        let mut ranges: Vec<Range<usize>> = blocks.iter().map(|b| b.items.clone()).collect();
        ranges.sort_by_key(|r| (r.start, r.end));
        let mut next = 0;
        for range in ranges {
            if range.start != next {
                let problem = if range.start > next {
                    format!("no block holds items {next}..{}", range.start)
                } else {
                    format!("block {range:?} overlaps the blocks before it")
                };
                return Err(Error::Blocks { items, problem });
            }
            next = range.end;
        }
        if next != items {
            return Err(Error::Blocks {
                items,
                problem: format!("no block holds items {next}..{items}"),
            });
        }
        Ok(())
    }

    /// The solution from the links of `blocks`, which must hold every item
    /// once (in any order; they are taken in item order): carry the
    /// emitters' links down to where their light changes, build the element
    /// hierarchies, and solve; the weighted oracles' refine–solve loop runs
    /// here. `stats.times.kernels_s` adds up the blocks' projection times.
    /// Cut short ([`Budget`]), the solution keeps a [`Checkpoint`] that
    /// takes the blocks as projected in full.
    pub fn finish(self, blocks: Vec<BlockLinks>, progress: &dyn Progress) -> Result<Solution> {
        let runs = (blocks.into_iter())
            .map(|links| Run {
                links,
                finished: true,
            })
            .collect();
        self.finish_runs(runs, 0, progress)
    }

    /// [`Plan::finish`] from `runs` of items, the first `resumed` of which
    /// were taken from a checkpoint.
    fn finish_runs(
        mut self,
        mut runs: Vec<Run>,
        resumed: usize,
        progress: &dyn Progress,
    ) -> Result<Solution> {
        let progress = &self.projector.budgeted(progress);
        // The runs' links, in item order.
        runs.sort_by_key(|r| r.links.items.start);
        let spans: Vec<RunSpan> = runs.iter().map(RunSpan::of).collect();
        let blocks: Vec<BlockLinks> = runs.into_iter().map(|r| r.links).collect();
        self.check_cover(&blocks)?;
        let mut times = self.times;
        // The first block's vectors grown, not copied.
        let (mut links, mut three_point) = (Vec::new(), Vec::new());
        let two_total = blocks.iter().map(|b| b.two_point.len()).sum();
        let three_total = blocks.iter().map(|b| b.three_point.len()).sum();
        for block in blocks {
            append_part(&mut links, block.two_point, two_total);
            append_part(&mut three_point, block.three_point, three_total);
            times.kernels_s += block.kernels_s;
        }

        // What a checkpoint would need and the sweeps do not read is packed:
        // the projection's links (which the refine–solve loop refines
        // further) and the plan's element pairs. The final system holds the
        // cluster links; a checkpoint gets them back from it.
        let items = self.items().end;
        let projected: Packed<(Vec<Link>, Vec<ThreePointLink>)> =
            Packed::new(&(&links, &three_point));
        let element_pairs: Packed<Vec<[ElementRef; 2]>> =
            Packed::new(&std::mem::take(&mut self.linking.element_pairs));
        let mut cluster_links = std::mem::take(&mut self.linking.cluster_links);
        let Plan {
            projector: Projector {
                scene, settings, ..
            },
            clusters,
            pairs,
            triples,
            ..
        } = &self;
        let ctx = self.projector.kernel_context();
        // The lights that are not surfaces light the elements the same way
        // whatever the links between surfaces.
        let clock = Instant::now();
        let light_links = link_lights(&ctx, settings.refine.max_level, progress);
        times.kernels_s += clock.elapsed().as_secs_f64();
        // Carry the emitters' links down to where their light changes
        // (`resolve_emitter_links`), then arrange the links and solve the
        // system they make. The refine–solve loop's intermediate solutions
        // only estimate where light flows, so they skip the resolution; the
        // solution returned always has it, and its system, the last, takes
        // the cluster links.
        // The final system takes the links and lets them go once resolved.
        let mut assemble_and_solve = |links: Cow<[Link]>,
                                      three_point: &[ThreePointLink],
                                      resolve: bool,
                                      times: &mut PhaseTimes| {
            let clock = Instant::now();
            let resolved = match resolve {
                true => {
                    let max_level = settings.refine.max_level;
                    let resolved = resolve_emitter_links(&ctx, max_level, &links, progress).0;
                    drop(links);
                    Cow::Owned(resolved)
                }
                false => links,
            };
            let cluster_links = match resolve {
                true => Cow::Owned(std::mem::take(&mut cluster_links)),
                false => Cow::Borrowed(&cluster_links[..]),
            };
            let trees = element_trees(scene, &resolved, three_point, &cluster_links, &light_links);
            times.kernels_s += clock.elapsed().as_secs_f64();
            let counts = LinkCounts::of(resolved.iter());
            let links = Links {
                two_point: resolved,
                three_point,
                clusters: (clusters, cluster_links),
                lights: &light_links,
            };
            let mut system = System::assemble(&ctx, triples, trees, links, times);
            let sweeps = system.solve(scene, settings, progress, times)?;
            Ok::<_, Error>((system, sweeps, counts))
        };
        let looping = settings.oracle.is_weighted() && settings.max_refine_passes > 1;
        let (mut system, mut sweeps, mut counts) = assemble_and_solve(
            taken(&mut links, !looping),
            &three_point,
            !looping,
            &mut times,
        )?;
        let mut passes = 1;
        let mut final_system = !looping;
        while looping && passes < settings.max_refine_passes && !progress.interrupted() {
            let clock = Instant::now();
            let estimate = LightEstimate::from_solution(
                scene,
                system.trees.clone(),
                &system.radiance,
                system
                    .interactions
                    .directional_radiance(&system.directional),
                importance(&ctx, settings.oracle, &links),
            );
            let (more, refined) = refine_further(&ctx, settings.refine, &estimate, links, progress);
            links = more;
            let (more, refined_three_point) = refine_further(
                &ctx,
                settings.three_point_refine(),
                &estimate,
                three_point,
                progress,
            );
            three_point = more;
            times.kernels_s += clock.elapsed().as_secs_f64();
            if refined + refined_three_point == 0 {
                break;
            }
            passes += 1;
            final_system = passes == settings.max_refine_passes;
            (system, sweeps, counts) = assemble_and_solve(
                taken(&mut links, final_system),
                &three_point,
                final_system,
                &mut times,
            )?;
        }
        if !final_system {
            (system, sweeps, counts) =
                assemble_and_solve(taken(&mut links, true), &three_point, true, &mut times)?;
        }

        let stats = Stats {
            projections: passes,
            limited_leaves: system.interactions.limited_leaves,
            stopped: self.projector.budget.stopped(),
            unrefined_items: self.projector.budget.coarse_items(),
            three_point_items: triples.len(),
            unplanned_triples: self.unplanned_triples,
            left_out_items: self.projector.budget.left_out_items(),
            resumed_items: resumed,
            projected_items: items - resumed,
            exchanging_pairs: pairs.len(),
            kernel_pairs: pairs.len(),
            cluster_links: system.interactions.clusters.len(),
            times,
            ..Stats::new(
                scene,
                settings,
                &system.trees,
                counts,
                &system.interactions.directional,
                three_point.len(),
                sweeps,
            )
        };
        let (settings, pairs) = (*settings, pairs.clone());
        let checkpoint = stats.stopped.map(|_| {
            let (links, three_point) = projected.unpack();
            let mut linking = self.linking;
            linking.element_pairs = element_pairs.unpack();
            linking.cluster_links = (system.interactions.clusters.links(&system.trees))
                .expect("a solve's cluster transfers name its own elements");
            Checkpoint::new(linking, items, &spans, links, three_point)
        });
        let Projector { scene, tracer, .. } = self.projector;
        Ok(Solution {
            scene,
            tracer,
            pairs,
            trees: system.trees,
            radiance: system.radiance,
            interactions: system.interactions,
            directional: system.directional,
            settings,
            stats,
            checkpoint,
        })
    }
}

/// `links` as a system takes them: the `last` one's own, taken, else
/// borrowed (the refine–solve loop refines them further).
fn taken(links: &mut Vec<Link>, last: bool) -> Cow<'_, [Link]> {
    match last {
        true => Cow::Owned(std::mem::take(links)),
        false => Cow::Borrowed(&links[..]),
    }
}

/// Append `part` to `all`, which holds `total` items once every part is
/// in: the first part with any is taken as it is and grown, not copied.
fn append_part<T>(all: &mut Vec<T>, part: Vec<T>, total: usize) {
    if all.is_empty() {
        *all = part;
        all.reserve_exact(total - all.len());
    } else {
        all.extend(part);
    }
}

impl Solution {
    /// The kernel context of the solve: its scene, ray queries and
    /// quadrature (rendering evaluates kernels into hypothetical receivers
    /// with it).
    pub fn kernel_context(&self) -> KernelContext<'_> {
        KernelContext::new(&self.scene, &self.tracer, self.settings.quadrature)
    }

    /// The part of every diffuse element's radiance reflected straight from
    /// the emitters and the lights that are not surfaces (eq. 12 with the
    /// emission as the only source, no emission of its own): the first bounce, which a final gather
    /// evaluates per point instead of reading it from the elements. Of a
    /// glossy surface, its Lambertian lobe's (empty without one); `None` while the solution's links are not
    /// arranged (a shooting step in progress).
    pub fn first_bounce(&self) -> Option<Vec<Vec<Rgb>>> {
        let emission: Vec<Vec<Rgb>> = (self.scene.surfaces.iter())
            .zip(&self.trees)
            .map(|(s, t)| vec![s.emission; t.nodes.len()])
            .collect();
        let directional: Vec<Vec<Rgb>> = (self.interactions.directional.iter())
            .map(|d| vec![Rgb::ZERO; d.tree.nodes.len()])
            .collect();
        self.reflection_of(&emission, &directional)
    }

    /// The light every diffuse element reflects (eq. 12 with no emission
    /// of its own) when the elements' radiance is `radiance` and the
    /// directional structures' `directional`, and the lights that are not
    /// surfaces shine: one gathering sweep, Jacobi's, read from those
    /// (through cluster links, glossy members' Lambertian light only).
    /// Shaped as [`Solution::first_bounce`], which is this of the emission.
    pub fn reflection_of(
        &self,
        radiance: &[Vec<Rgb>],
        directional: &[Vec<Rgb>],
    ) -> Option<Vec<Vec<Rgb>>> {
        let scene = &self.scene;
        if self.interactions.incoming.len() != scene.surfaces.len() {
            return None;
        }
        // Cluster links carry the members' Lambertian light here, not the
        // glossy light their lobes reflect: that is one more reflection
        // than `radiance` holds (the emission's first bounce is not
        // reflected twice), and the solution holds no state of it to read.
        let far = self.interactions.clusters.far_field(radiance, None, None);
        let bounce = scene
            .surfaces
            .par_iter()
            .enumerate()
            .map(|(p, surface)| {
                let Some(rho) = surface.brdf.lambertian() else {
                    return Vec::new();
                };
                let tree = &self.trees[p];
                let mut gathered =
                    self.interactions
                        .gather(p, rho, tree, (radiance, directional), &far);
                self.interactions.gather_lights(p, rho, &mut gathered);
                let exposure = Some(&self.interactions.exposure[p][..]);
                let limit = Some(&self.interactions.limit[p][..]);
                let texture = self.interactions.texture_of(p);
                push_pull::push_pull(tree, &gathered, Rgb::ZERO, exposure, limit, texture)
            })
            .collect();
        Some(bounce)
    }
}

/// A scene the solvers accept: some surfaces, within [`Scene::check_bounds`].
fn check_size(scene: &Scene) -> Result<()> {
    if scene.surfaces.is_empty() {
        return Err(Error::EmptyScene);
    }
    scene.check_bounds()
}

/// A scene with light: some surface emits, or some light that is not a
/// surface shines. Without any the solution is black whatever the solve
/// does, so it is refused before any kernel work (whether the scene has no
/// emitters or only ones of zero radiance: either way nothing would be
/// lit).
fn check_light(scene: &Scene) -> Result<()> {
    if scene.has_light() {
        Ok(())
    } else {
        Err(Error::NoLight)
    }
}

/// Every link of one projection, as the system is assembled from them
/// (the two-point and cluster links it is handed are dropped once
/// arranged).
struct Links<'a> {
    two_point: Cow<'a, [Link]>,
    three_point: &'a [ThreePointLink],
    clusters: (&'a ClusterTree, Cow<'a, [ClusterLink]>),
    lights: &'a [LightLink],
}

/// The linear system of one set of links and its solution.
struct System {
    trees: Vec<ElementTree>,
    interactions: Interactions,
    radiance: Vec<Vec<Rgb>>,
    directional: Vec<Vec<Rgb>>,
}

/// The element hierarchy of every surface: the smallest trees holding every
/// element of `links`, every source element of `three_point` and its
/// receiving element on a surface with a Lambertian lobe, every
/// element end of `cluster_links` and every element of `lights`.
fn element_trees(
    scene: &Scene,
    links: &[Link],
    three_point: &[ThreePointLink],
    cluster_links: &[ClusterLink],
    lights: &[LightLink],
) -> Vec<ElementTree> {
    let mut ids = vec![BTreeSet::from([ElementId::ROOT]); scene.surfaces.len()];
    for l in lights {
        ids[l.surface as usize].insert(l.element);
    }
    for end in cluster_links.iter().flat_map(|l| l.ends) {
        if let End::Element(e) = end {
            ids[e.surface as usize].insert(e.id);
        }
    }
    for l in links {
        ids[l.p as usize].insert(l.a);
        ids[l.r as usize].insert(l.c);
    }
    for l in three_point {
        ids[l.r as usize].insert(l.c);
        // The receiving elements, where a diffuse surface gathers the
        // reflection at their resolution ([`Interactions`]' highlights).
        if let Some(q) = ids.get_mut(l.q as usize) {
            if scene.surfaces[l.q as usize].brdf.lambertian().is_some() {
                q.insert(l.b);
            }
        }
    }
    scene
        .surfaces
        .iter()
        .zip(&ids)
        .map(|(s, ids)| ElementTree::build(&s.patch, ids))
        .collect()
}

impl System {
    /// The system over the element hierarchies `trees` (holding every
    /// linked element, [`element_trees`]) and the directional structures
    /// holding every linked element pair; radiance starts at the emission.
    fn assemble(
        ctx: &KernelContext,
        triples: &[(u32, u32, u32)],
        trees: Vec<ElementTree>,
        links: Links,
        times: &mut PhaseTimes,
    ) -> System {
        let Links {
            two_point: links,
            three_point,
            clusters: (clusters, cluster_links),
            lights,
        } = links;
        let clock = Instant::now();
        let mut pairs: BTreeSet<(u32, u32)> = triples.iter().map(|&(_, p, q)| (p, q)).collect();
        // A glossy surface lit by nothing may still emit towards what it sees.
        pairs.extend(triples.iter().map(|&(r, p, _)| (p, r)));
        let mut directional: Vec<Directional> = pairs
            .into_iter()
            .map(|(p, q)| Directional {
                p,
                q,
                tree: PairTree::default(),
            })
            .collect();
        let index: std::collections::BTreeMap<(u32, u32), usize> = directional
            .iter()
            .enumerate()
            .map(|(i, d)| ((d.p, d.q), i))
            .collect();
        for l in three_point {
            directional[index[&(l.p, l.q)]].tree.insert(l.a, l.b);
        }
        let exposure = trees
            .par_iter()
            .enumerate()
            .map(|(s, t)| exposed_fractions(ctx, s as u32, t, None))
            .collect();
        let pairs = PairExposure::new(
            ctx,
            directional
                .iter()
                .flat_map(|d| {
                    d.tree
                        .nodes
                        .iter()
                        .map(move |n| [ElementRef::new(d.p, n.a), ElementRef::new(d.q, n.b)])
                })
                .chain(
                    three_point
                        .iter()
                        .map(|l| [ElementRef::new(l.p, l.a), ElementRef::new(l.q, l.b)]),
                ),
        );
        // The cluster links, the largest of the plan's parts, are arranged
        // and let go before the element links are, so that the two plans
        // and the two arrangements are never all held at once.
        let arranged = ClusterTransfers::new(ctx.scene, clusters.clone(), &trees, &cluster_links);
        drop(cluster_links);
        let mut interactions = Interactions::new(
            ctx.scene,
            &trees,
            exposure,
            &links,
            three_point,
            &pairs,
            directional,
        );
        drop(links);
        interactions.clusters = arranged;
        interactions.limit_reflection(ctx.scene, &trees);
        interactions.link_lights(ctx, &trees, lights);
        let radiance = ctx
            .scene
            .surfaces
            .iter()
            .zip(&trees)
            .map(|(s, t)| vec![s.emission; t.nodes.len()])
            .collect();
        // A glossy surface's emission is in its elements' radiance; its
        // element pairs hold only what the non-Lambertian lobes reflect.
        let directional = interactions
            .directional
            .iter()
            .map(|d| vec![Rgb::ZERO; d.tree.nodes.len()])
            .collect();
        times.hierarchy_s += clock.elapsed().as_secs_f64();
        System {
            trees,
            interactions,
            radiance,
            directional,
        }
    }

    /// compute_radiance_solution(): Gauss–Seidel gathering with push–pull
    /// until the power the surfaces send (coarsest coefficients times
    /// areas) changes in a sweep by at most the tolerance of itself; an
    /// error when the changes keep growing ([`Divergence`]). Measured in
    /// power, a room lit by a small, intense emitter (a bulb in a lamp)
    /// converges as its own light does, not as a fraction of the bulb's
    /// radiance. Once the change shrinks by a steady ratio, the sweeps
    /// still to come are added at once ([`extrapolation`]), and the sweeps
    /// that follow take the residual on from there.
    ///
    /// A scene whose integrator limits the path length
    /// ([`crate::scene::RenderHints::max_depth`]) is swept Jacobi's way
    /// instead, each sweep reading the radiance of the one before, at most
    /// [`bounces`] times: the radiance then holds exactly the
    /// light of at most that many reflections, which the final gather's
    /// reflection at the visible point completes to the longest path.
    fn solve(
        &mut self,
        scene: &Scene,
        settings: &SolveSettings,
        progress: &dyn Progress,
        times: &mut PhaseTimes,
    ) -> Result<Sweeps> {
        let clock = Instant::now();
        let System {
            trees,
            interactions,
            radiance,
            directional,
        } = self;
        let mut structures_of = vec![Vec::new(); scene.surfaces.len()];
        for (i, d) in interactions.directional.iter().enumerate() {
            structures_of[d.p as usize].push(i);
        }
        // Power, in the largest channel: a coarsest coefficient (the
        // surface's mean radiance) times its area.
        let areas: Vec<f64> = scene.surfaces.iter().map(|s| s.patch.area()).collect();
        let change = |new: Rgb, old: Rgb| (new - old).map(f64::abs).max_channel();
        let (mut iterations, mut residual) = (0u32, f64::INFINITY);
        let mut divergence = Divergence::default();
        let mut extrapolation = Extrapolation::default();
        // Each surface's change of power in the last sweep, and the power
        // it sends after it.
        let mut changes = vec![0.0f64; scene.surfaces.len()];
        let mut leaving = vec![0.0f64; scene.surfaces.len()];
        let bounces = bounces(scene);
        let sweeps = bounces.map_or(settings.max_iterations, |b| b.min(settings.max_iterations));
        progress.start("solving", u64::from(sweeps));
        let mut far = FarField::default();
        while iterations < sweeps
            && residual > settings.tolerance
            && !(iterations >= MIN_SWEEPS && progress.interrupted())
        {
            // The sweep before's glossy light alone, not its links' sends.
            let lobes = std::mem::take(&mut far).lobes();
            far = interactions.far_field(scene, trees, (radiance, directional), Some(&lobes));
            interactions.clusters.sum_at_elements(&mut far);
            // The radiance before this sweep: read by the sweep with a
            // bounce limit, else what an extrapolation after it extends.
            let before = (bounces.is_some() || extrapolation.may_extrapolate_next())
                .then(|| (radiance.clone(), directional.clone()));
            for (p, surface) in scene.surfaces.iter().enumerate() {
                (changes[p], leaving[p]) = (0.0, 0.0);
                if let Some(rho) = surface.brdf.lambertian() {
                    let read = match (bounces, &before) {
                        (Some(_), Some((r, d))) => (&r[..], &d[..]),
                        _ => (&radiance[..], &directional[..]),
                    };
                    let mut gathered = interactions.gather(p, rho, &trees[p], read, &far);
                    interactions.gather_lights(p, rho, &mut gathered);
                    let exposure = Some(&interactions.exposure[p][..]);
                    let limit = Some(&interactions.limit[p][..]);
                    let updated = push_pull::push_pull(
                        &trees[p],
                        &gathered,
                        surface.emission,
                        exposure,
                        limit,
                        interactions.texture_of(p),
                    );
                    changes[p] = change(updated[0], radiance[p][0]) * areas[p];
                    leaving[p] = updated[0].max_channel() * areas[p];
                    radiance[p] = updated;
                }
                for &s in &structures_of[p] {
                    let gathered = match (bounces, &before) {
                        (Some(_), Some((r, d))) => interactions.gather_three_point(s, (r, d), &far),
                        _ => interactions.gather_three_point(s, (radiance, directional), &far),
                    };
                    let tree = &interactions.directional[s].tree;
                    let exposure = Some(&interactions.pair_exposure[s][..]);
                    let updated =
                        push_pull::push_pull(tree, &gathered, Rgb::ZERO, exposure, None, None);
                    changes[p] += change(updated[0], directional[s][0]) * areas[p];
                    leaving[p] += updated[0].max_channel() * areas[p];
                    directional[s] = updated;
                }
            }
            let changed: f64 = changes.iter().sum();
            let total: f64 = leaving.iter().sum();
            residual = if total > 0.0 { changed / total } else { 0.0 };
            iterations += 1;
            progress.advance(1);
            if let Some(growing) = divergence.record(changed) {
                progress.finish();
                return Err(Error::Diverged {
                    sweeps: iterations,
                    growing,
                    residual,
                    surfaces: fastest_changing(scene, &changes),
                });
            }
            // A bounce limit counts the reflections each sweep adds: none
            // is skipped; nor is a converged solve extended.
            let factor = (extrapolation.record(changed))
                .filter(|_| bounces.is_none() && residual > settings.tolerance);
            if let (Some(factor), Some((r, d))) = (factor, &before) {
                extend(radiance, r, factor);
                extend(directional, d, factor);
            }
        }
        progress.finish();
        times.solve_s += clock.elapsed().as_secs_f64();
        Ok(Sweeps {
            iterations,
            residual,
        })
    }
}

/// Adds `factor` times the change from `before` to every coefficient of
/// `now` ([`extrapolation`]).
fn extend(now: &mut [Vec<Rgb>], before: &[Vec<Rgb>], factor: f64) {
    for (now, before) in now.iter_mut().zip(before) {
        for (x, &b) in now.iter_mut().zip(before) {
            *x = *x + (*x - b) * factor;
        }
    }
}

/// The reflections a solution of `scene` holds, when its integrator's
/// longest path is limited ([`crate::scene::RenderHints::max_depth`]): that
/// many segments less the eye's and the last reflection, which the final
/// gather makes at the visible point.
pub fn bounces(scene: &Scene) -> Option<u32> {
    scene.hints.max_depth.map(|d| d.saturating_sub(2))
}

/// Sweeps Gauss–Seidel makes even when the work is asked to stop
/// ([`Progress::interrupted`]): the first bounces, most of the light.
const MIN_SWEEPS: u32 = 8;

/// Sweeps in a row that Gauss–Seidel's residual may grow, past its first
/// sweep's, before the solve is called divergent. A converging solve's
/// residual shrinks by about the scene's mean reflectance each sweep; one
/// that keeps growing reflects more light than it receives somewhere.
const GROWING_SWEEPS: u32 = 5;

/// How many times the largest change of any sweep before it a sweep's
/// change may reach, from the third sweep on. A solve that conserves
/// energy changes each sweep by at most its largest reflectance times the
/// sweep before's (the second sweep may exceed the first: light a glossy
/// surface without a Lambertian lobe reflects, not counted in the first
/// sweep's change, reaches its receivers one sweep later). A change that
/// grows in bursts, falling between them, escapes [`GROWING_SWEEPS`]
/// (`docs/decisions-measurements.md`, "Divergence in bursts").
const OVERSHOOT: f64 = 2.0;

/// Watches Gauss–Seidel's changes of power per sweep for divergence: a
/// change that is not finite, one that has grown for [`GROWING_SWEEPS`]
/// sweeps in a row to above the first sweep's (emission to first bounce,
/// the largest change a converging solve makes), or, from the third sweep
/// on, one above [`OVERSHOOT`] times the largest change before it.
#[derive(Debug, Clone, Copy, Default)]
struct Divergence {
    first: Option<f64>,
    previous: f64,
    growing: u32,
    sweeps: u32,
    largest: f64,
}

impl Divergence {
    /// Record one sweep's change of power; `Some(sweeps grown in a row)`
    /// when the solve diverges.
    fn record(&mut self, residual: f64) -> Option<u32> {
        match self.first {
            None => self.first = Some(residual),
            Some(_) if residual > self.previous => self.growing += 1,
            Some(_) => self.growing = 0,
        }
        self.sweeps += 1;
        let overshoots = self.sweeps >= 3 && residual > OVERSHOOT * self.largest;
        self.largest = self.largest.max(residual);
        self.previous = residual;
        let first = self.first.unwrap_or(residual);
        let diverges = !residual.is_finite()
            || (self.growing >= GROWING_SWEEPS && residual > first)
            || overshoots;
        diverges.then_some(self.growing)
    }
}

/// The (at most three) surfaces of `scene` with the largest `changes`,
/// largest first, by name and index.
fn fastest_changing(scene: &Scene, changes: &[f64]) -> Vec<String> {
    let mut order: Vec<usize> = (0..changes.len()).collect();
    order.sort_by(|&a, &b| changes[b].total_cmp(&changes[a]));
    order
        .into_iter()
        .take(3)
        .map(|s| match scene.surfaces[s].name.as_str() {
            "" => format!("surface {s}"),
            name => format!("{name} (surface {s})"),
        })
        .collect()
}

impl SolveSettings {
    /// The limits of a solve with these settings, from now: `time_limit`
    /// and `max_memory` (0: [`DEFAULT_MEMORY_SHARE`] of the physical
    /// memory, where the OS tells).
    pub fn budget(&self) -> Budget {
        let time =
            (self.time_limit > 0.0).then(|| std::time::Duration::from_secs_f64(self.time_limit));
        let memory = if self.max_memory > 0.0 {
            Some((self.max_memory * (1u64 << 30) as f64) as u64)
        } else {
            crate::progress::physical_memory_bytes()
                .map(|bytes| (bytes as f64 * DEFAULT_MEMORY_SHARE) as u64)
        };
        Budget::new(time, memory)
    }

    /// The defaults for `oracle`: the weighted oracles' thresholds are
    /// relative radiance errors, not kernel details.
    pub fn for_oracle(oracle: Oracle) -> SolveSettings {
        let mut settings = SolveSettings {
            oracle,
            ..SolveSettings::default()
        };
        if oracle.is_weighted() {
            settings.refine.threshold = WEIGHTED_THRESHOLD;
            settings.three_point_threshold = WEIGHTED_THRESHOLD;
        }
        settings
    }

    /// The settings of linking from the root cluster.
    pub fn clusters(&self) -> ClusterSettings {
        ClusterSettings {
            ratio: self.cluster_ratio,
            max_level: self.refine.max_level,
            threshold: self.refine.threshold,
            gather_bytes: cluster_gather::GATHER_BYTES_PER_LINK,
        }
    }

    /// The refinement settings of three-point links.
    pub fn three_point_refine(&self) -> ThreePointSettings {
        ThreePointSettings {
            refine: RefineSettings {
                max_level: self.three_point_max_level,
                threshold: self.three_point_threshold,
            },
            receiver_max_level: self
                .three_point_max_level
                .saturating_add(self.three_point_receiver_levels),
        }
    }

    /// The refinement settings of three-point links into a hypothetical
    /// receiver (the eye, the enclosure): one level deeper than the solve's.
    /// Such a receiver is gathered once, after the solve, so its links
    /// refine the source elements further at a cost the solve's (three
    /// surfaces' worth of elements per link) could not afford.
    pub fn receiver_refine(&self) -> ThreePointSettings {
        let ThreePointSettings {
            refine,
            receiver_max_level,
        } = self.three_point_refine();
        ThreePointSettings {
            refine: RefineSettings {
                max_level: refine.max_level + 1,
                ..refine
            },
            receiver_max_level: receiver_max_level + 1,
        }
    }

    /// Check the settings make sense.
    pub fn validate(&self) -> Result<()> {
        let r = &self.refine;
        for (name, t) in [
            ("threshold", r.threshold),
            ("three-point threshold", self.three_point_threshold),
        ] {
            if !(t >= 0.0 && t.is_finite()) {
                return Err(Error::InvalidSetting(format!(
                    "{name} must be a finite number >= 0, got {t}"
                )));
            }
        }
        for (name, level) in [
            ("max level", r.max_level),
            ("three-point max level", self.three_point_max_level),
            (
                "three-point max level plus receiver levels",
                self.three_point_max_level
                    .saturating_add(self.three_point_receiver_levels),
            ),
        ] {
            if level > 16 {
                return Err(Error::InvalidSetting(format!(
                    "{name} must be at most 16, got {level}"
                )));
            }
        }
        if self.quadrature.points == 0 || self.quadrature.rays == 0 {
            return Err(Error::InvalidSetting(
                "quadrature orders must be at least 1".into(),
            ));
        }
        if !(0.0..=0.9).contains(&self.cluster_ratio) {
            return Err(Error::InvalidSetting(format!(
                "cluster ratio must be in [0, 0.9], got {}",
                self.cluster_ratio
            )));
        }
        if self.max_refine_passes == 0 {
            return Err(Error::InvalidSetting(
                "refine passes must be at least 1".into(),
            ));
        }
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(Error::InvalidSetting(format!(
                "tolerance must be > 0, got {}",
                self.tolerance
            )));
        }
        Ok(())
    }
}

impl Default for SolveSettings {
    /// Defaults that render the bundled Cornell box within a few per cent of
    /// a path-traced reference (see README).
    fn default() -> Self {
        SolveSettings {
            refine: RefineSettings {
                threshold: 1e-3,
                max_level: 5,
            },
            quadrature: Quadrature::default(),
            three_point_max_level: 2,
            three_point_receiver_levels: 3,
            three_point_threshold: 1e-5,
            tolerance: 1e-5,
            max_iterations: 200,
            oracle: Oracle::Kernel,
            max_refine_passes: 4,
            cluster_ratio: 0.25,
            time_limit: 0.0,
            max_memory: 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Silent;
    use crate::refine::two_point_projection::{refine_links, root_pairs};
    use crate::scene::brdf::Brdf;
    use crate::scene::{Patch, Surface};
    use glam::DVec3;

    /// Two facing unit squares 0.1 apart reflecting `rho`, named "lower"
    /// and "upper"; the lower one emits 1.
    fn facing_squares(rho: f64) -> Scene {
        let square = |z: f64, up: bool| Patch::Parallelogram {
            origin: DVec3::new(0.0, 0.0, z),
            edge_s: if up { DVec3::X } else { DVec3::Y },
            edge_t: if up { DVec3::Y } else { DVec3::X },
        };
        let surface = |name: &str, patch, emission| Surface {
            name: name.into(),
            patch,
            brdf: Brdf::diffuse(Rgb::splat(rho)),
            emission: Rgb::splat(emission),
            texture: None,
            shading: None,
        };
        Scene::from_surfaces(vec![
            surface("lower", square(0.0, true), 1.0),
            surface("upper", square(0.1, false), 0.0),
        ])
    }

    /// The system of the squares' links, each given twice: links that
    /// overlap, every form factor counted double (ΣF up to 1.9).
    fn doubled_links(ctx: &KernelContext, settings: &SolveSettings) -> System {
        let links = refine_links(ctx, settings.refine, None, &root_pairs(ctx), &Silent);
        let doubled: Vec<Link> = links.iter().chain(&links).copied().collect();
        let trees = element_trees(ctx.scene, &doubled, &[], &[], &[]);
        let links = Links {
            two_point: Cow::Owned(doubled),
            three_point: &[],
            clusters: (&ClusterTree::default(), Cow::Borrowed(&[])),
            lights: &[],
        };
        System::assemble(ctx, &[], trees, links, &mut PhaseTimes::default())
    }

    /// A unit floor of `brdf` (surface 0) under a light beside it (1) and
    /// a diffuse wall (2) at x = 1.5 facing it, where a sharp floor
    /// reflects the light as a highlight; nothing stands between floor and
    /// wall.
    fn floor_reflecting_onto_a_wall(brdf: Brdf) -> Scene {
        let light = Patch::Parallelogram {
            origin: DVec3::new(-1.0, 0.3, 1.0),
            edge_s: DVec3::Y * 0.4,
            edge_t: DVec3::X * 0.4,
        };
        let wall = Patch::Parallelogram {
            origin: DVec3::new(1.5, -0.5, 0.2),
            edge_s: DVec3::Z * 2.8,
            edge_t: DVec3::Y * 2.0,
        };
        let grey = crate::testing::grey;
        Scene::from_surfaces(vec![
            Surface {
                brdf,
                ..grey(crate::testing::unit_floor())
            },
            Surface {
                emission: Rgb::splat(1.0),
                ..grey(light)
            },
            grey(wall),
        ])
    }

    #[test]
    fn only_a_sharp_lobe_splits_its_receivers_and_its_light_keeps_the_form_factors() {
        let settings = SolveSettings::default();
        let deepest_receiver = |solution: &Solution| {
            let s = solution.interactions.structure_of[&(0, 2)] as usize;
            let tree = &solution.interactions.directional[s].tree;
            tree.nodes.iter().map(|n| n.b.level).max().unwrap()
        };
        let sharp = solve(
            &floor_reflecting_onto_a_wall(crate::testing::rolled_aluminium()),
            &settings,
            &Silent,
        )
        .unwrap();
        assert!(deepest_receiver(&sharp) > settings.three_point_max_level);
        let broad = Brdf::Ward(crate::scene::brdf::ward::Ward {
            alpha_u: 0.4,
            alpha_v: 0.4,
            ..match crate::testing::rolled_aluminium() {
                Brdf::Ward(w) => w,
                _ => unreachable!(),
            }
        });
        let broad = solve(&floor_reflecting_onto_a_wall(broad), &settings, &Silent).unwrap();
        assert!(deepest_receiver(&broad) <= settings.three_point_max_level);
        // Split over the tiles of the reflection or not, the wall's
        // transfers from the floor add up to its form factor to the floor:
        // A_wall·F(wall → floor), Lambert's closed form over a fine grid.
        let floor = sharp.scene.surfaces[0].patch;
        let wall = sharp.scene.surfaces[2].patch;
        let n = 200;
        let exact: f64 = (0..n * n)
            .map(|k| {
                let (u, v) = ((k % n) as f64 + 0.5, (k / n) as f64 + 0.5);
                let x = wall.point_at(glam::DVec2::new(u, v) / n as f64);
                crate::kernel::form_factor::point_to_polygon(
                    x,
                    wall.normal(),
                    &floor.vertices(),
                    floor.normal(),
                )
            })
            .sum::<f64>()
            * wall.area()
            / (n * n) as f64;
        for solution in [&sharp, &broad] {
            let (tree, exposure) = (&solution.trees[2], &solution.interactions.exposure[2]);
            let total: f64 = (solution.interactions.incoming[2].iter())
                .filter(|t| t.source.element().0 == 0)
                .map(|t| {
                    let node = t.receiver as usize;
                    t.form_factor * tree.nodes[node].patch.area() * exposure[node]
                })
                .sum();
            assert!(
                (total / exact - 1.0).abs() < 0.01,
                "{total} against {exact}"
            );
        }
        let split = |solution: &Solution| solution.interactions.incoming[2].len();
        assert!(split(&sharp) > split(&broad), "the highlight's tiles");
    }

    #[test]
    fn a_spent_budget_links_the_items_left_whole_and_still_solves() {
        let scene = crate::testing::light_over_a_corner(0.3);
        let full = solve(&scene, &SolveSettings::default(), &Silent).unwrap();
        assert_eq!((full.stats.stopped, full.stats.unrefined_items), (None, 0));
        let limited = SolveSettings {
            time_limit: 1e-9,
            ..SolveSettings::default()
        };
        let cut = solve(&scene, &limited, &Silent).unwrap();
        assert_eq!(cut.stats.stopped, Some(crate::progress::Stop::TimeLimit));
        assert!(full.checkpoint.is_none() && cut.checkpoint.is_some());
        // Every surface pair, and the emitter's links left unresolved.
        assert!(cut.stats.unrefined_items > full.stats.kernel_pairs);
        assert!(cut.stats.two_point_interactions < full.stats.two_point_interactions);
        // Whole-surface links still carry the light: every lit surface
        // receives about what the full solve gives it.
        assert!(cut.stats.iterations >= MIN_SWEEPS.min(full.stats.iterations));
        for (c, f) in cut.radiance.iter().zip(&full.radiance) {
            let (c, f) = (c[0].max_channel(), f[0].max_channel());
            assert!(
                c.is_finite() && (c - f).abs() <= 0.1 * f + 1e-9,
                "{c} against {f}"
            );
        }
    }

    /// Keeps the warnings it is given.
    #[derive(Default)]
    struct Warnings(std::sync::Mutex<Vec<String>>);

    impl Progress for Warnings {
        fn warn(&self, message: &str) {
            self.0.lock().unwrap().push(message.to_string());
        }
    }

    #[test]
    fn a_budget_spent_before_linking_links_coarser_and_still_solves_within_the_energy_bound() {
        // The unit box, grey (ρ = 0.5), its floor cut into 64 tiles, and a
        // small light of radiance 5.
        let scene = Scene::from_surfaces(
            (crate::testing::glossy_tiled_box(3).surfaces.into_iter())
                .map(|s| Surface {
                    brdf: Brdf::diffuse(Rgb::splat(0.5)),
                    ..s
                })
                .collect(),
        );
        let settings = SolveSettings::default();
        let full = solve(&scene, &settings, &Silent).unwrap();
        assert!(full.stats.cluster_links > 0);
        // A budget that is not spent changes nothing.
        let open = SolveSettings {
            time_limit: 3600.0,
            ..settings
        };
        let unspent = solve(&scene, &open, &Silent).unwrap();
        assert_eq!(unspent.radiance, full.radiance);
        assert_eq!(unspent.stats.cluster_links, full.stats.cluster_links);

        let limited = SolveSettings {
            time_limit: 1e-9,
            ..settings
        };
        let warnings = Warnings::default();
        let cut = solve(&scene, &limited, &warnings).unwrap();
        assert_eq!(cut.stats.stopped, Some(crate::progress::Stop::TimeLimit));
        assert!(cut.stats.cluster_links < full.stats.cluster_links);
        assert!(cut.stats.exchanging_pairs < full.stats.exchanging_pairs);
        let warnings = warnings.0.into_inner().unwrap();
        let linking: Vec<&String> = warnings.iter().filter(|w| w.contains("linking")).collect();
        assert_eq!(linking.len(), 1, "{warnings:?}");
        assert!(linking[0].contains("the time limit"), "{}", linking[0]);

        // Resumed, it is planned afresh (no item was finished) and gives
        // the solve the budget cut short.
        let resumed = resume(&scene, &settings, cut.unfinished().unwrap(), None, &Silent).unwrap();
        assert_eq!(resumed.radiance, full.radiance);
        assert_eq!(resumed.stats.cluster_links, full.stats.cluster_links);

        // Every surface is lit, and none reflects more than reaches it: in
        // a closed box of reflectance ρ lit by radiance Le, no surface
        // that does not emit exceeds ρ·Le/(1 − ρ).
        let bound = 0.5 * 5.0 / (1.0 - 0.5);
        for (s, (c, f)) in cut.radiance.iter().zip(&full.radiance).enumerate() {
            if scene.surfaces[s].is_emitter() {
                continue;
            }
            let brightest = c.iter().map(|l| l.max_channel()).fold(0.0, f64::max);
            assert!(
                brightest.is_finite() && brightest <= bound,
                "surface {s}: {brightest}"
            );
            let (c, f) = (c[0].max_channel(), f[0].max_channel());
            assert!(c > 0.1 * f, "surface {s}: {c} against {f}");
        }
    }

    /// Counts the questions whether to stop, and says yes from the
    /// `after`-th on; remembers how many had been asked when the
    /// three-point phase started.
    struct StopAfter {
        after: usize,
        asked: std::sync::atomic::AtomicUsize,
        before_three_point: std::sync::atomic::AtomicUsize,
    }

    impl StopAfter {
        fn new(after: usize) -> StopAfter {
            StopAfter {
                after,
                asked: Default::default(),
                before_three_point: Default::default(),
            }
        }
    }

    impl Progress for StopAfter {
        fn start(&self, phase: &str, _total: u64) {
            use std::sync::atomic::Ordering::SeqCst;
            if phase == crate::refine::three_point_projection::PHASE {
                let asked = self.asked.load(SeqCst);
                self.before_three_point.store(asked, SeqCst);
            }
        }
        fn interrupted(&self) -> bool {
            self.asked.fetch_add(1, std::sync::atomic::Ordering::SeqCst) >= self.after
        }
    }

    #[test]
    fn a_spent_budget_leaves_out_the_surface_triples_not_started() {
        let scene = crate::testing::glossy_tiled_box(1);
        let mut settings = SolveSettings {
            three_point_max_level: 1,
            ..SolveSettings::default()
        };
        settings.refine.max_level = 3;
        let full = solve(&scene, &settings, &StopAfter::new(usize::MAX)).unwrap();
        let triples = full.stats.three_point_items;
        assert!(triples > 100, "{triples}");
        assert_eq!(
            (full.stats.left_out_items, full.stats.unplanned_triples),
            (0, 0)
        );
        assert!(full.stats.three_point_interactions > triples);

        // Spent before the projection: no triple is projected, not even
        // whole, and the diffuse light is still solved.
        let limited = SolveSettings {
            time_limit: 1e-9,
            ..settings
        };
        let cut = solve(&scene, &limited, &Silent).unwrap();
        assert_eq!(cut.stats.stopped, Some(crate::progress::Stop::TimeLimit));
        // (The linking, cut short too, element-links fewer pairs: its plan
        // holds fewer triples.)
        assert!(cut.stats.three_point_items <= triples);
        assert_eq!(cut.stats.left_out_items, cut.stats.three_point_items);
        assert_eq!(cut.stats.three_point_interactions, 0);
        assert!(cut.radiance.iter().all(|r| r[0].max_channel().is_finite()));
        assert!(cut.radiance[1][0].max_channel() > 0.0);

        // Stopped within the three-point phase: the triples started are at
        // most the questions answered "go on" (the work done after a stop
        // does not grow with the triples left), the rest left out.
        let questions = full_questions_before_three_point(&scene, &settings);
        for extra in [0, 10, 100] {
            let progress = StopAfter::new(questions + extra);
            let cut = solve(&scene, &settings, &progress).unwrap();
            assert_eq!(cut.stats.stopped, Some(crate::progress::Stop::Interrupted));
            let started = triples - cut.stats.left_out_items;
            assert!(started <= extra, "{started} triples started after {extra}");
            assert!(cut.stats.left_out_items > 0);
            assert!(cut.stats.three_point_interactions < full.stats.three_point_interactions);
            // What was left out is projected when the solve is resumed.
            let resumed =
                resume(&scene, &settings, cut.unfinished().unwrap(), None, &Silent).unwrap();
            assert_eq!(resumed.radiance, full.radiance);
            assert_eq!(resumed.directional, full.directional);
        }
    }

    /// Questions whether to stop that `solve` asks before its three-point
    /// phase starts.
    fn full_questions_before_three_point(scene: &Scene, settings: &SolveSettings) -> usize {
        let progress = StopAfter::new(usize::MAX);
        solve(scene, settings, &progress).unwrap();
        progress
            .before_three_point
            .load(std::sync::atomic::Ordering::SeqCst)
    }

    #[test]
    fn overlapping_links_are_limited_so_that_gauss_seidel_converges() {
        let scene = facing_squares(0.7);
        let tracer = SceneTracer::new(&scene);
        let settings = SolveSettings::default();
        let ctx = crate::kernel::default_context(&scene, &tracer);
        let mut system = doubled_links(&ctx, &settings);
        assert!(system.interactions.limited_leaves > 0);
        let sweeps = system
            .solve(&scene, &settings, &Silent, &mut PhaseTimes::default())
            .unwrap();
        assert!(sweeps.residual <= settings.tolerance, "{sweeps:?}");
        // No leaf reflects more than reaches it: the upper square, lit by
        // the lower alone, stays below the lower's radiance.
        let brightest = system.radiance[0].iter().map(|l| l[0]).fold(0.0, f64::max);
        assert!(system.radiance[1].iter().all(|l| l[0] <= brightest));

        // Without the limits the same sweeps diverge, and the error says
        // so, naming the squares.
        let mut system = doubled_links(&ctx, &settings);
        for limit in &mut system.interactions.limit {
            limit.fill(1.0);
        }
        let error = system
            .solve(&scene, &settings, &Silent, &mut PhaseTimes::default())
            .unwrap_err();
        assert!(matches!(error, Error::Diverged { .. }), "{error}");
        let message = error.to_string();
        assert!(message.contains("lower (surface 0)"), "{message}");
        assert!(message.contains("upper (surface 1)"), "{message}");
    }

    #[test]
    fn divergence_is_a_residual_growing_past_the_first_sweeps() {
        let diverges = |residuals: &[f64]| {
            let mut watch = Divergence::default();
            residuals.iter().any(|&r| watch.record(r).is_some())
        };
        // Converging, with a bump; growing for five sweeps but still below
        // the first sweep's change (light spreading through a dark scene).
        assert!(!diverges(&[1.0, 0.5, 0.6, 0.3, 0.1, 0.05]));
        assert!(!diverges(&[1.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]));
        // Growing for five sweeps past it, or not a number.
        assert!(diverges(&[1.0, 0.9, 1.0, 1.1, 1.2, 1.3, 1.4]));
        assert!(!diverges(&[1.0, 0.9, 1.0, 1.1, 1.2, 1.3]));
        assert!(diverges(&[1.0, f64::INFINITY]));
        assert!(diverges(&[1.0, f64::NAN]));
        // In bursts: never five sweeps in a row, but past twice the largest
        // change before (the mirror-and-torus scene's first changes). The
        // second sweep may exceed the first (a glossy surface's light
        // arrives a sweep late).
        assert!(diverges(&[
            2.0e3, 6.6e4, 1.8e4, 6.1e2, 7.3e2, 8.0e1, 3.7e2, 1.4e5
        ]));
        assert!(!diverges(&[
            2.0e3, 6.6e4, 1.8e4, 6.1e2, 7.3e2, 8.0e1, 3.7e2, 1.2e5
        ]));
        assert!(!diverges(&[1.0, 3.0, 2.0, 1.0, 0.5]));
        assert!(diverges(&[1.0, 3.0, 6.1]));
    }

    #[test]
    fn a_scene_without_light_is_refused_before_any_kernel_work() {
        let mut scene = facing_squares(0.5);
        scene.surfaces[0].emission = Rgb::ZERO;
        let settings = SolveSettings::default();
        assert_eq!(
            solve(&scene, &settings, &Silent).err(),
            Some(Error::NoLight)
        );
        let shooting = shoot::solve_shooting(&scene, &settings, &Silent, None);
        assert_eq!(shooting.err(), Some(Error::NoLight));
        scene.surfaces[1].emission = Rgb([0.0, 0.0, 0.1]);
        assert!(solve(&scene, &settings, &Silent).is_ok());
    }
}
