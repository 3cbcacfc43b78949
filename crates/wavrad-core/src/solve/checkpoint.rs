//! Resuming a gathering solve that was cut short (time limit, memory
//! limit, interrupt: [`crate::progress::Budget`]) without projecting again
//! what it had finished.
//!
//! The kernel projection is most of a solve, and each of its items (an
//! element pair or a surface triple of the [`Plan`]) is projected on its
//! own, the same way wherever and whenever it runs. So a solve cut short
//! keeps a [`Checkpoint`] with its solution: the linking its items came
//! from and the links of every item it projected in full. [`resume`]
//! projects only the items left (those linked whole, or part-refined, when
//! the budget ran out) and finishes as an uninterrupted solve does: the
//! emitters' links resolved, the hierarchies built, Gauss–Seidel from the
//! emission (and, for the weighted oracles, their refine–solve loop). The
//! solution is an uninterrupted solve's bit for bit, as [`Plan::finish`]'s
//! is for any split of the items.
//!
//! A process can also be killed outright (`kill -9`, a machine that
//! goes down). Given a [`Saver`], a solve projects its items in chunks and
//! hands the driver a [`CheckpointView`] of what it has finished at most
//! every [`Saver::every`], to be written where a later run resumes from.
//!
//! ```
//! use wavrad_core::progress::Silent;
//! use wavrad_core::solve::{checkpoint::resume, solve, SolveSettings};
//!
//! let scene = wavrad_core::testing::light_over_a_corner(0.3);
//! let settings = SolveSettings::default();
//! let cut = solve(&scene, &SolveSettings { time_limit: 1e-9, ..settings }, &Silent).unwrap();
//! assert!(cut.checkpoint.is_some());
//! let resumed = resume(&scene, &settings, cut.unfinished().unwrap(), None, &Silent).unwrap();
//! let whole = solve(&scene, &settings, &Silent).unwrap();
//! assert_eq!(resumed.radiance, whole.radiance);
//! assert!(resumed.checkpoint.is_none());
//! ```

use super::settings::MAX_LEVEL;
use super::{BlockLinks, Plan, Projector, Solution, SolveSettings};
use crate::geometry::cluster::ClusterTree;
use crate::geometry::hierarchy::ElementRef;
use crate::progress::Progress;
use crate::refine::cluster_links::{End, Linking};
use crate::refine::three_point_projection::ThreePointLink;
use crate::refine::two_point_projection::Link;
use crate::refine::{three_point_projection, two_point_projection};
use crate::refine::{ByItem, Projected};
use crate::scene::Scene;
use crate::setting::{Described, Value};
use crate::solve::stats::PhaseTimes;
use crate::{Error, Result};
use std::ops::Range;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// What a gathering solve cut short had finished, for [`resume`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Checkpoint {
    /// The linking from the root its items came from (linking again would
    /// repeat work that can cost as much as the projection).
    pub linking: Linking,
    /// How many items its plan has.
    pub items: usize,
    /// The items projected in full, in runs of consecutive items with
    /// their links, in item order (their `kernels_s` are 0: the time was
    /// the solve's that made them).
    pub finished: Vec<BlockLinks>,
}

/// [`Checkpoint`] borrowed from a solve under way, to be written
/// ([`Saver`]): serialised, it is the checkpoint it views (the same fields
/// in the same order; serde writes a borrowed value as the value).
#[derive(Debug, Clone, serde::Serialize)]
pub struct CheckpointView<'a> {
    /// [`Checkpoint::linking`].
    pub linking: &'a Linking,
    /// [`Checkpoint::items`].
    pub items: usize,
    /// [`Checkpoint::finished`]: runs of finished items in item order
    /// (consecutive runs need not be merged).
    pub finished: Vec<&'a BlockLinks>,
}

impl CheckpointView<'_> {
    /// Items projected in full.
    pub fn finished_items(&self) -> usize {
        self.finished.iter().map(|b| b.items.len()).sum()
    }

    /// The checkpoint viewed, owned.
    pub fn to_checkpoint(&self) -> Checkpoint {
        Checkpoint {
            linking: self.linking.clone(),
            items: self.items,
            finished: self.finished.iter().map(|&b| b.clone()).collect(),
        }
    }
}

/// A solve that stopped before its end, to [`resume`]: the scene and
/// settings it was made with, and what it had finished.
#[derive(Debug, Clone, Copy)]
pub struct Unfinished<'a> {
    /// The scene it solved.
    pub scene: &'a Scene,
    /// Its settings.
    pub settings: &'a SolveSettings,
    /// What it had finished.
    pub checkpoint: &'a Checkpoint,
}

impl Solution {
    /// The solve to [`resume`], when it was cut short.
    pub fn unfinished(&self) -> Option<Unfinished<'_>> {
        Some(Unfinished {
            scene: &self.scene,
            settings: &self.settings,
            checkpoint: self.checkpoint.as_ref()?,
        })
    }
}

/// Where a solve under way saves its checkpoints, for a run that resumes
/// after the process was killed.
pub struct Saver<'a> {
    /// The least time between two saves (the first comes after this long).
    pub every: Duration,
    /// Called with the scene, the settings and a view of what is finished
    /// (it writes them; a failure is the driver's to report, and the solve
    /// goes on).
    #[allow(clippy::type_complexity)]
    pub save: &'a (dyn Fn(&Scene, &SolveSettings, CheckpointView<'_>) + Sync),
}

/// Consecutive items of a plan projected together, all of them in full or
/// all of them cut short.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The items and their links.
    pub links: BlockLinks,
    /// Whether they were projected in full (as [`ByItem`] tells of each).
    pub finished: bool,
}

/// Settings a refinement does not depend on: a resumed solve may change
/// them.
const NOT_REFINEMENT: [&str; 4] = ["tolerance", "max_iterations", "time_limit", "max_memory"];

impl Checkpoint {
    /// The checkpoint of a solve cut short whose first projection made
    /// `two_point` and `three_point` (the links of `runs`, in item order).
    pub(super) fn new(
        linking: Linking,
        items: usize,
        runs: &[RunSpan],
        two_point: Vec<Link>,
        three_point: Vec<ThreePointLink>,
    ) -> Checkpoint {
        let (mut two_point, mut three_point) = (two_point.into_iter(), three_point.into_iter());
        let mut finished: Vec<BlockLinks> = Vec::new();
        for run in runs {
            let two: Vec<Link> = two_point.by_ref().take(run.two_point).collect();
            let three: Vec<ThreePointLink> = three_point.by_ref().take(run.three_point).collect();
            if !run.finished {
                continue;
            }
            match finished.last_mut() {
                Some(last) if last.items.end == run.items.start => {
                    last.items.end = run.items.end;
                    last.two_point.extend(two);
                    last.three_point.extend(three);
                }
                _ => finished.push(BlockLinks {
                    items: run.items.clone(),
                    two_point: two,
                    three_point: three,
                    kernels_s: 0.0,
                }),
            }
        }
        Checkpoint {
            linking,
            items,
            finished,
        }
    }

    /// An error unless the finished runs are ranges of the items (none
    /// reversed), in order and apart (as [`Checkpoint::new`] makes them), and every element,
    /// cluster and value they and the linking name is one of `scene`'s
    /// (whose cluster tree has `clusters` nodes): a checkpoint read from a
    /// file is followed without further checks.
    fn check(&self, scene: &Scene, clusters: usize) -> Result<()> {
        let mut next = 0;
        for block in &self.finished {
            let (start, end) = (block.items.start, block.items.end);
            if start > end || start < next || end > self.items {
                return Err(Error::Resume(format!(
                    "the checkpoint's finished items {:?} are not in order within its {} items",
                    block.items, self.items
                )));
            }
            next = block.items.end;
        }
        let surfaces = scene.surfaces.len();
        let element = |e: ElementRef| {
            (e.surface as usize) < surfaces
                && e.id.level <= MAX_LEVEL
                && e.id.path < 1u64 << (2 * e.id.level)
        };
        let end = |e: &End| match *e {
            End::Cluster(c) => (c as usize) < clusters,
            End::Element(e) => element(e),
        };
        let linking = &self.linking;
        let links_ok = self.finished.iter().all(|b| {
            (b.two_point.iter())
                .all(|l| l.elements().into_iter().all(element) && l.throughput.is_finite())
                && (b.three_point.iter()).all(|l| {
                    l.elements().into_iter().all(element)
                        && l.coefficient.0.iter().all(|v| v.is_finite())
                })
        });
        let linking_ok = linking.element_pairs.iter().flatten().all(|&e| element(e))
            && (linking.cluster_links.iter())
                .all(|l| l.ends.iter().all(end) && l.visibility.is_finite());
        if !(links_ok && linking_ok) {
            return Err(Error::Resume(
                "the checkpoint names an element, cluster or value the scene does not have".into(),
            ));
        }
        Ok(())
    }

    /// Items projected in full.
    pub fn finished_items(&self) -> usize {
        self.finished.iter().map(|b| b.items.len()).sum()
    }

    /// The items left to project, in order.
    pub fn unfinished(&self) -> Vec<usize> {
        let mut left = Vec::with_capacity(self.items - self.finished_items());
        let mut next = 0;
        for block in &self.finished {
            left.extend(next..block.items.start);
            next = block.items.end;
        }
        left.extend(next..self.items);
        left
    }
}

/// A value that only a checkpoint may need, held compressed until then
/// (postcard, then zstd at its fastest level): the links of a large
/// solve's projection and its plan's element pairs are the largest parts
/// of it that its sweeps do not read, and most solves are not cut short.
pub(super) struct Packed<T> {
    bytes: Vec<u8>,
    of: std::marker::PhantomData<T>,
}

impl<T: serde::de::DeserializeOwned> Packed<T> {
    /// `value` packed; `S` serialises as `T` does (`&[L]` as `Vec<L>`).
    pub(super) fn new<S: serde::Serialize + ?Sized>(value: &S) -> Packed<T> {
        let pack = || -> std::io::Result<Vec<u8>> {
            let mut encoder = zstd::stream::Encoder::new(Vec::new(), PACK_LEVEL)?;
            let cores = std::thread::available_parallelism().map_or(1, usize::from);
            encoder.multithread(cores as u32)?;
            let mut out = std::io::BufWriter::new(encoder);
            postcard::to_io(value, &mut out).map_err(std::io::Error::other)?;
            out.into_inner().map_err(|e| e.into_error())?.finish()
        };
        Packed {
            bytes: pack().expect("packing into memory does not fail"),
            of: std::marker::PhantomData,
        }
    }

    /// The value packed.
    pub(super) fn unpack(&self) -> T {
        let encoded = zstd::decode_all(&self.bytes[..]).expect("a packed value unpacks");
        postcard::from_bytes(&encoded).expect("a packed value decodes")
    }
}

/// zstd's level for [`Packed`] values: its fastest regular level.
const PACK_LEVEL: i32 = 1;

/// Where one run's links lie in the concatenation of a projection's links.
#[derive(Debug, Clone)]
pub(super) struct RunSpan {
    pub(super) items: Range<usize>,
    pub(super) two_point: usize,
    pub(super) three_point: usize,
    pub(super) finished: bool,
}

impl RunSpan {
    pub(super) fn of(run: &Run) -> RunSpan {
        RunSpan {
            items: run.links.items.clone(),
            two_point: run.links.two_point.len(),
            three_point: run.links.three_point.len(),
            finished: run.finished,
        }
    }
}

/// The items numbered `numbers` (increasing), whose links are `two_point`
/// then `three_point` item by item (the items `three_point` left out last,
/// unfinished and without links), in runs of consecutive numbers alike
/// finished or not; the first run takes the projection's `kernels_s`.
pub(super) fn runs_of(
    numbers: &[usize],
    two_point: ByItem<Link>,
    three_point: Projected<ThreePointLink>,
    kernels_s: f64,
) -> Vec<Run> {
    debug_assert_eq!(
        numbers.len(),
        two_point.len() + three_point.items.len() + three_point.left_out
    );
    // Each item: whether it was finished, and its numbers of links.
    let items = (two_point.iter().map(|(links, done)| (done, links.len(), 0)))
        .chain((three_point.items.iter()).map(|(links, done)| (done, 0, links.len())))
        .chain(std::iter::repeat((false, 0, 0)));
    let mut spans: Vec<RunSpan> = Vec::new();
    for (&n, (finished, two, three)) in numbers.iter().zip(items) {
        match spans.last_mut() {
            Some(span) if span.finished == finished && span.items.end == n => {
                span.items.end = n + 1;
                span.two_point += two;
                span.three_point += three;
            }
            _ => spans.push(RunSpan {
                items: n..n + 1,
                two_point: two,
                three_point: three,
                finished,
            }),
        }
    }
    // The runs' links, split off the ends of the items' (each moved once).
    let (mut two_point, mut three_point) = (two_point.into_links(), three_point.items.into_links());
    let mut runs: Vec<Run> = (spans.into_iter().rev())
        .map(|span| Run {
            links: BlockLinks {
                two_point: last(&mut two_point, span.two_point),
                three_point: last(&mut three_point, span.three_point),
                items: span.items,
                kernels_s: 0.0,
            },
            finished: span.finished,
        })
        .collect();
    runs.reverse();
    if let Some(first) = runs.first_mut() {
        first.links.kernels_s = kernels_s;
    }
    runs
}

/// The last `n` of `all`, taken off it.
fn last<T>(all: &mut Vec<T>, n: usize) -> Vec<T> {
    match n == all.len() {
        true => std::mem::take(all),
        false => all.split_off(all.len() - n),
    }
}

/// The links of `runs` (consecutive, in order) as one block of `items`.
pub(super) fn merged(items: Range<usize>, runs: Vec<Run>) -> BlockLinks {
    let mut block = BlockLinks {
        items,
        two_point: Vec::new(),
        three_point: Vec::new(),
        kernels_s: 0.0,
    };
    for run in runs {
        block.two_point.extend(run.links.two_point);
        block.three_point.extend(run.links.three_point);
        block.kernels_s += run.links.kernels_s;
    }
    block
}

impl SolveSettings {
    /// The settings to resume a solve made with `self`: its own, but for
    /// the limits (`time_limit`, `max_memory`: each run has its own, the
    /// defaults unless given), with the `given` values set on top.
    pub fn for_resuming(&self, given: &[(&str, Value)]) -> Result<SolveSettings> {
        let defaults = SolveSettings::default();
        let mut settings = SolveSettings {
            time_limit: defaults.time_limit,
            max_memory: defaults.max_memory,
            ..*self
        };
        for &(name, value) in given {
            settings.set(name, value)?;
        }
        settings.validate()?;
        Ok(settings)
    }

    /// An error naming the first setting of `self` that changes
    /// refinement and differs in `solved` (the settings of the solve to
    /// resume).
    fn check_resumes(&self, solved: &SolveSettings) -> Result<()> {
        let differs = |what: String| {
            Err(Error::Resume(format!(
                "{what}: a refinement is resumed with the settings it was made with"
            )))
        };
        for setting in SolveSettings::SETTINGS {
            let (now, then) = (self.get(setting.name), solved.get(setting.name));
            if !NOT_REFINEMENT.contains(&setting.name) && now != then {
                let show = |v: Option<Value>| v.map_or("none".into(), |v| v.to_string());
                return differs(format!(
                    "{} is {} but the solve was made with {}",
                    setting.name,
                    show(now),
                    show(then)
                ));
            }
        }
        if self.quadrature != solved.quadrature {
            return differs(format!(
                "the quadrature is {:?} but the solve was made with {:?}",
                self.quadrature, solved.quadrature
            ));
        }
        Ok(())
    }
}

/// Resume the gathering solve of `scene` that stopped `from` its
/// checkpoint (a [`Solution::unfinished`], or one a [`Saver`] wrote):
/// project the items it left, keep the links of those it finished, and
/// finish as [`super::solve`] does, with `settings` (which must refine as
/// `from.settings` did: [`SolveSettings::for_resuming`] makes them),
/// saving checkpoints through `saver` as [`super::solve_saving`] does; a
/// checkpoint that finished no item (its solve stopped while linking, which
/// the budget coarsens, or before its first item) is planned afresh. The
/// result is what the uninterrupted solve gives, bit for bit, and its
/// statistics count the items taken from the checkpoint (`resumed_items`)
/// and those projected (`projected_items`). Cut short again, it has a
/// checkpoint of its own.
///
/// # Errors
/// [`Error::Resume`] when `scene` is not the scene `from` solved (naming
/// the first difference), a setting that changes refinement differs
/// (naming it), or the checkpoint does not fit the scene's plan; the
/// errors of [`super::plan`].
pub fn resume(
    scene: &Scene,
    settings: &SolveSettings,
    from: Unfinished<'_>,
    saver: Option<&Saver>,
    progress: &dyn Progress,
) -> Result<Solution> {
    let checkpoint = from.checkpoint;
    if let Some(difference) = from.scene.difference(scene) {
        return Err(Error::Resume(format!(
            "the scene changed since the solve: it now has {difference}"
        )));
    }
    settings.check_resumes(from.settings)?;

    // A solve stopped before it finished any item (its linking, perhaps
    // coarsened by the budget, included) leaves nothing to keep: it is
    // planned afresh. Else the plan of the interrupted solve, its linking
    // as it was.
    let (plan, unfinished) = if checkpoint.finished.is_empty() {
        let plan = super::plan(scene, settings, progress)?;
        let items = plan.items().collect();
        (plan, items)
    } else {
        let mut times = PhaseTimes::default();
        let projector = Projector::timed(scene, settings, &mut times)?;
        let clusters = ClusterTree::build(scene);
        checkpoint.check(scene, clusters.nodes.len())?;
        let plan = Plan::new(projector, clusters, checkpoint.linking.clone(), times);
        if plan.items().end != checkpoint.items {
            return Err(Error::Resume(format!(
                "the checkpoint holds a plan of {} items, the scene's has {}",
                checkpoint.items,
                plan.items().end
            )));
        }
        (plan, checkpoint.unfinished())
    };
    let resumed = checkpoint.finished_items();
    let left = plan.project_saving(&unfinished, &checkpoint.finished, saver, progress);
    let runs = (checkpoint.finished.iter().cloned())
        .map(|links| Run {
            links,
            finished: true,
        })
        .chain(left)
        .collect();
    plan.finish_runs(runs, resumed, progress)
}

impl Plan {
    /// [`Plan::project_numbered`], saving checkpoints through `saver`
    /// (with the runs `before` finished by an earlier run): the items are
    /// projected in chunks, each taking about a quarter of `saver.every`,
    /// and after a chunk that ends `saver.every` or more after the last
    /// save, what is finished is saved. The links are the same however the
    /// items are chunked.
    pub(super) fn project_saving(
        &self,
        numbers: &[usize],
        before: &[BlockLinks],
        saver: Option<&Saver>,
        progress: &dyn Progress,
    ) -> Vec<Run> {
        let Some(saver) = saver else {
            return self.project_numbered(numbers, progress);
        };
        let pairs = self.element_pairs();
        let split = numbers.partition_point(|&n| n < pairs.len());
        let scene = self.projector.scene();
        let chunked = Chunked {
            progress,
            totals: [
                (
                    two_point_projection::PHASE,
                    (numbers[..split].iter())
                        .filter(|&&n| two_point_projection::has_two_point_links(scene, pairs[n]))
                        .count() as u64,
                ),
                (
                    three_point_projection::PHASE,
                    (numbers.len() - split) as u64,
                ),
            ],
            current: Mutex::new(None),
        };
        let chunk_time = (saver.every / 4).max(Duration::from_millis(10));
        let mut chunk = 4 * rayon::current_num_threads();
        let mut runs: Vec<Run> = Vec::new();
        let mut saved = Instant::now();
        let mut rest = numbers;
        while !rest.is_empty() {
            let clock = Instant::now();
            let (now, later) = rest.split_at(chunk.min(rest.len()));
            runs.extend(self.project_numbered(now, &chunked));
            rest = later;
            // The next chunk sized to take about `chunk_time`, by this one's pace.
            let pace = chunk_time.as_secs_f64() / clock.elapsed().as_secs_f64().max(1e-6);
            chunk =
                ((chunk as f64 * pace.clamp(0.5, 4.0)) as usize).max(rayon::current_num_threads());
            if !rest.is_empty() && saved.elapsed() >= saver.every && !progress.interrupted() {
                (saver.save)(scene, self.projector.settings(), self.view(before, &runs));
                saved = Instant::now();
            }
        }
        chunked.end();
        runs
    }

    /// The checkpoint of this plan with the runs `before` finished and
    /// the finished ones of `runs`, borrowed.
    fn view<'a>(&'a self, before: &'a [BlockLinks], runs: &'a [Run]) -> CheckpointView<'a> {
        let mut finished: Vec<&BlockLinks> = (before.iter())
            .chain(runs.iter().filter(|r| r.finished).map(|r| &r.links))
            .collect();
        finished.sort_by_key(|b| b.items.start);
        CheckpointView {
            linking: &self.linking,
            items: self.items().end,
            finished,
        }
    }
}

/// `progress` for a projection made in chunks: each phase starts once,
/// with its steps over every chunk (`totals`), and ends when the next one
/// starts or at [`Chunked::end`].
struct Chunked<'a> {
    progress: &'a dyn Progress,
    totals: [(&'static str, u64); 2],
    current: Mutex<Option<&'static str>>,
}

impl Progress for Chunked<'_> {
    fn start(&self, phase: &str, total: u64) {
        let Some(&(phase, all)) = self.totals.iter().find(|(p, _)| *p == phase) else {
            return;
        };
        // A chunk without items of the phase still starts and finishes it.
        if total == 0 {
            return;
        }
        let mut current = self.current.lock().unwrap_or_else(|e| e.into_inner());
        if *current != Some(phase) {
            if current.is_some() {
                self.progress.finish();
            }
            self.progress.start(phase, all);
            *current = Some(phase);
        }
    }
    fn advance(&self, steps: u64) {
        self.progress.advance(steps)
    }
    fn interrupted(&self) -> bool {
        self.progress.interrupted()
    }
    fn cut_short(&self, items: u64) {
        self.progress.cut_short(items)
    }
    fn left_out(&self, items: u64) {
        self.progress.left_out(items)
    }
    fn warn(&self, message: &str) {
        self.progress.warn(message)
    }
    fn holding(&self, bytes: u64) {
        self.progress.holding(bytes)
    }
}

impl Chunked<'_> {
    /// The last phase is over.
    fn end(self) {
        if self
            .current
            .into_inner()
            .unwrap_or_else(|e| e.into_inner())
            .is_some()
        {
            self.progress.finish();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::{Silent, Stop};
    use crate::solve::solve;
    use crate::testing::{grey, inward_box, rolled_aluminium};
    use glam::DVec3;

    /// A grey box with a small light under its ceiling and a glossy floor:
    /// element pairs and surface triples to project.
    fn glossy_box() -> Scene {
        let mut surfaces: Vec<_> = (inward_box(DVec3::ZERO, DVec3::ONE).into_iter())
            .map(grey)
            .collect();
        surfaces[0].brdf = rolled_aluminium();
        surfaces.push(crate::scene::Surface {
            emission: crate::scene::Rgb::splat(5.0),
            ..grey(crate::scene::Patch::Parallelogram {
                origin: DVec3::new(0.4, 0.4, 0.99),
                edge_s: DVec3::Y * 0.2,
                edge_t: DVec3::X * 0.2,
            })
        });
        Scene::from_surfaces(surfaces)
    }

    /// Coarse enough for tests in a debug build.
    fn coarse() -> SolveSettings {
        let mut settings = SolveSettings::default();
        settings.refine.max_level = 3;
        settings.refine.threshold = 1e-2;
        settings
    }

    /// Reports interrupted from the `after`-th question on.
    struct InterruptAfter {
        after: usize,
        asked: std::sync::atomic::AtomicUsize,
    }

    impl Progress for InterruptAfter {
        fn interrupted(&self) -> bool {
            let asked = self.asked.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            asked >= self.after
        }
    }

    fn interrupt_after(after: usize) -> InterruptAfter {
        InterruptAfter {
            after,
            asked: Default::default(),
        }
    }

    #[test]
    fn a_resumed_solve_is_the_uninterrupted_one_and_projects_only_what_was_left() {
        let scene = glossy_box();
        let settings = coarse();
        let whole = solve(&scene, &settings, &Silent).unwrap();
        assert_eq!(whole.checkpoint, None);
        let items = whole.stats.projected_items;
        // Interrupted at several depths into the projection.
        for after in [0, 40, 400, 4000] {
            let cut = solve(&scene, &settings, &interrupt_after(after)).unwrap();
            assert_eq!(cut.stats.stopped, Some(Stop::Interrupted));
            let checkpoint = cut.checkpoint.clone().expect("a checkpoint");
            assert_eq!(checkpoint.items, items);
            let left = checkpoint.unfinished().len();
            assert_eq!(left + checkpoint.finished_items(), items);
            let resumed =
                resume(&scene, &settings, cut.unfinished().unwrap(), None, &Silent).unwrap();
            assert_eq!(
                (resumed.stats.resumed_items, resumed.stats.projected_items),
                (items - left, left),
                "interrupted after {after}"
            );
            assert_eq!(
                resumed.radiance, whole.radiance,
                "interrupted after {after}"
            );
            assert_eq!(resumed.directional, whole.directional);
            assert_eq!(resumed.trees, whole.trees);
            assert_eq!(resumed.checkpoint, None);
            assert_eq!(resumed.stats.stopped, None);
        }
    }

    /// Asks to stop once the sweeps have started, the projection done.
    #[derive(Default)]
    struct StopInSweeps(std::sync::atomic::AtomicBool);

    impl Progress for StopInSweeps {
        fn start(&self, phase: &str, _total: u64) {
            if phase == "solving" {
                self.0.store(true, std::sync::atomic::Ordering::SeqCst);
            }
        }
        fn interrupted(&self) -> bool {
            self.0.load(std::sync::atomic::Ordering::SeqCst)
        }
    }

    #[test]
    fn a_solve_stopped_in_its_sweeps_keeps_every_item_it_packed_and_resumes_without_projecting() {
        let scene = glossy_box();
        // Sweeps stop once past their first few: enough of them to stop.
        let settings = SolveSettings {
            tolerance: 1e-12,
            ..coarse()
        };
        let whole = solve(&scene, &settings, &Silent).unwrap();
        let cut = solve(&scene, &settings, &StopInSweeps::default()).unwrap();
        assert_eq!(cut.stats.stopped, Some(Stop::Interrupted));
        assert!(cut.stats.iterations < whole.stats.iterations);
        let checkpoint = cut.checkpoint.clone().expect("a checkpoint");
        assert_eq!(checkpoint.unfinished().len(), 0);
        assert_eq!(checkpoint.finished_items(), whole.stats.projected_items);
        let plan = crate::solve::plan(&scene, &settings, &Silent).unwrap();
        assert_eq!(checkpoint.linking.element_pairs, plan.element_pairs());
        let resumed = resume(&scene, &settings, cut.unfinished().unwrap(), None, &Silent).unwrap();
        assert_eq!(resumed.stats.projected_items, 0);
        assert_eq!(resumed.radiance, whole.radiance);
        assert_eq!(resumed.directional, whole.directional);
    }

    #[test]
    fn packed_values_unpack_as_they_were() {
        let links: Vec<(u32, f64)> = (0..100_000).map(|k| (k % 7, f64::from(k).sqrt())).collect();
        let pairs = vec![[1u64, 2], [3, 4]];
        type Both = (Vec<(u32, f64)>, Vec<[u64; 2]>);
        let packed: Packed<Both> = Packed::new(&(&links, &pairs[..]));
        assert!(packed.bytes.len() < std::mem::size_of_val(&links[..]));
        assert_eq!(packed.unpack(), (links, pairs));
        let empty: Packed<Vec<u8>> = Packed::new(&Vec::<u8>::new());
        assert_eq!(empty.unpack(), Vec::<u8>::new());
    }

    #[test]
    fn a_resumed_solve_cut_short_again_keeps_both_runs_work() {
        let scene = glossy_box();
        let settings = coarse();
        let first = solve(&scene, &settings, &interrupt_after(30)).unwrap();
        let done = first.checkpoint.as_ref().unwrap().finished_items();
        let second = resume(
            &scene,
            &settings,
            first.unfinished().unwrap(),
            None,
            &interrupt_after(30),
        )
        .unwrap();
        let checkpoint = second.checkpoint.clone().expect("cut short again");
        assert!(checkpoint.finished_items() >= done);
        let resumed = resume(
            &scene,
            &settings,
            second.unfinished().unwrap(),
            None,
            &Silent,
        )
        .unwrap();
        let whole = solve(&scene, &settings, &Silent).unwrap();
        assert_eq!(resumed.radiance, whole.radiance);
    }

    /// Resuming the glossy box's solve, interrupted after `after`
    /// questions, with its checkpoint spoiled by each of `spoils`, is an
    /// error naming `problem`.
    fn refused_when_spoiled(after: usize, spoils: &[fn(&mut Checkpoint)], problem: &str) {
        let scene = glossy_box();
        let settings = coarse();
        let cut = solve(&scene, &settings, &interrupt_after(after)).unwrap();
        for (k, spoil) in spoils.iter().enumerate() {
            let mut bad = cut.checkpoint.clone().unwrap();
            spoil(&mut bad);
            let from = Unfinished {
                scene: &scene,
                settings: &settings,
                checkpoint: &bad,
            };
            match resume(&scene, &settings, from, None, &Silent) {
                Err(e) => assert!(e.to_string().contains(problem), "case {k}: {e}"),
                Ok(_) => panic!("case {k}: resumed"),
            }
        }
    }

    #[test]
    fn a_checkpoint_naming_what_the_scene_lacks_is_refused_not_followed() {
        refused_when_spoiled(
            4000,
            &[
                |c| c.linking.element_pairs[0][1].surface = 999,
                |c| c.linking.element_pairs[0][0].id.path = 1 << 40,
                |c| {
                    let block = c.finished.iter_mut().find(|b| !b.two_point.is_empty());
                    match block {
                        Some(b) => b.two_point[0].throughput = f64::NAN,
                        None => c.finished[0].three_point[0].coefficient.0[1] = f64::INFINITY,
                    }
                },
            ],
            "does not have",
        );
    }

    #[test]
    fn a_checkpoint_whose_runs_are_not_ranges_of_its_items_in_order_is_refused() {
        // A reversed range (found by the fuzzer: it reached past the items),
        // one past the end, and two that overlap.
        refused_when_spoiled(
            400,
            &[
                |c| c.finished[0].items = c.items + 12..c.items - 1,
                |c| c.finished[0].items.end = c.items + 1,
                |c| {
                    let first = c.finished[0].clone();
                    c.finished.push(first);
                },
            ],
            "not in order",
        );
    }

    #[test]
    fn resuming_with_other_settings_or_another_scene_is_refused() {
        let scene = glossy_box();
        let settings = coarse();
        let cut = || solve(&scene, &settings, &interrupt_after(10)).unwrap();
        let message = |result: Result<Solution>| match result {
            Err(e @ Error::Resume(_)) => e.to_string(),
            Err(e) => panic!("another error: {e}"),
            Ok(_) => panic!("resumed"),
        };

        let finer = settings
            .for_resuming(&[("threshold", Value::Real(1e-4))])
            .unwrap();
        let refused = message(resume(
            &scene,
            &finer,
            cut().unfinished().unwrap(),
            None,
            &Silent,
        ));
        assert!(refused.contains("threshold is 1e-4"), "{refused}");
        // The limits and the sweeps' settings may change.
        let longer = settings
            .for_resuming(&[("max_iterations", Value::Count(300))])
            .unwrap();
        assert!(resume(&scene, &longer, cut().unfinished().unwrap(), None, &Silent).is_ok());

        let mut other = scene.clone();
        let light = other.surfaces.last_mut().unwrap();
        light.emission = light.emission * 2.0;
        let refused = message(resume(
            &other,
            &settings,
            cut().unfinished().unwrap(),
            None,
            &Silent,
        ));
        assert!(refused.contains("scene changed"), "{refused}");

        let whole = solve(&scene, &settings, &Silent).unwrap();
        assert!(whole.unfinished().is_none());
    }

    /// Records the phases started, with their totals and the steps
    /// advanced in each.
    #[derive(Default)]
    struct Phases(Mutex<Vec<(String, u64, u64)>>);

    impl Progress for Phases {
        fn start(&self, phase: &str, total: u64) {
            self.0.lock().unwrap().push((phase.into(), total, 0));
        }
        fn advance(&self, steps: u64) {
            self.0.lock().unwrap().last_mut().unwrap().2 += steps;
        }
    }

    #[test]
    fn a_solve_that_saves_as_it_goes_is_the_same_and_resumes_from_every_save() {
        let scene = glossy_box();
        let settings = coarse();
        let whole = solve(&scene, &settings, &Phases::default()).unwrap();
        let saved = Mutex::new(Vec::new());
        let save = |s: &Scene, t: &SolveSettings, view: CheckpointView<'_>| {
            assert!(s.difference(&scene).is_none() && *t == settings);
            saved.lock().unwrap().push(view.to_checkpoint());
        };
        let saver = Saver {
            every: Duration::ZERO,
            save: &save,
        };
        let phases = Phases::default();
        let saving = super::super::solve_saving(&scene, &settings, Some(&saver), &phases).unwrap();
        assert_eq!(saving.radiance, whole.radiance);
        assert_eq!(saving.trees, whole.trees);
        assert_eq!(saving.directional, whole.directional);

        // Each projection phase started once, with every chunk's steps.
        let phases = phases.0.into_inner().unwrap();
        for phase in [two_point_projection::PHASE, three_point_projection::PHASE] {
            let started: Vec<_> = phases.iter().filter(|p| p.0 == phase).collect();
            assert_eq!(started.len(), 1, "{phase}: {phases:?}");
            assert_eq!(started[0].1, started[0].2, "{phase}: {phases:?}");
        }

        // Saved after every chunk but the last, each with more finished.
        let saved = saved.into_inner().unwrap();
        assert!(saved.len() >= 2, "{} saves", saved.len());
        let items = whole.stats.projected_items;
        let finished: Vec<usize> = saved.iter().map(Checkpoint::finished_items).collect();
        assert!(finished.windows(2).all(|w| w[0] < w[1]), "{finished:?}");
        assert!(*finished.last().unwrap() < items);
        for checkpoint in &saved {
            let from = Unfinished {
                scene: &scene,
                settings: &settings,
                checkpoint,
            };
            let resumed = resume(&scene, &settings, from, None, &Silent).unwrap();
            assert_eq!(resumed.radiance, whole.radiance);
            assert_eq!(resumed.stats.resumed_items, checkpoint.finished_items());
        }

        // A resume saves too, with the runs it was given.
        let saved_again = Mutex::new(Vec::new());
        let save = |_: &Scene, _: &SolveSettings, view: CheckpointView<'_>| {
            saved_again.lock().unwrap().push(view.finished_items());
        };
        let saver = Saver {
            every: Duration::ZERO,
            save: &save,
        };
        let from = Unfinished {
            scene: &scene,
            settings: &settings,
            checkpoint: &saved[0],
        };
        let resumed = resume(&scene, &settings, from, Some(&saver), &Silent).unwrap();
        assert_eq!(resumed.radiance, whole.radiance);
        let again = saved_again.into_inner().unwrap();
        assert!(again.first().is_some_and(|&n| n > finished[0]), "{again:?}");
    }

    #[test]
    fn the_limits_are_not_resumed() {
        let solved = SolveSettings {
            time_limit: 5.0,
            max_memory: 2.0,
            tolerance: 1e-3,
            ..coarse()
        };
        let resumed = solved.for_resuming(&[]).unwrap();
        assert_eq!((resumed.time_limit, resumed.max_memory), (0.0, 0.0));
        assert_eq!(resumed.tolerance, 1e-3);
        assert_eq!(resumed.refine, solved.refine);
    }
}
