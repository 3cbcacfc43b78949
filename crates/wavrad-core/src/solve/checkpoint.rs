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
//! ```
//! use wavrad_core::progress::Silent;
//! use wavrad_core::solve::{checkpoint::resume, solve, SolveSettings};
//!
//! let scene = wavrad_core::testing::light_over_a_corner(0.3);
//! let settings = SolveSettings::default();
//! let cut = solve(&scene, &SolveSettings { time_limit: 1e-9, ..settings }, &Silent).unwrap();
//! assert!(cut.checkpoint.is_some());
//! let resumed = resume(&scene, &settings, &cut, &Silent).unwrap();
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
use crate::refine::ItemLinks;
use crate::scene::Scene;
use crate::setting::{Described, Value};
use crate::solve::stats::PhaseTimes;
use crate::{Error, Result};
use std::ops::Range;

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

/// Consecutive items of a plan projected together, all of them in full or
/// all of them cut short.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The items and their links.
    pub links: BlockLinks,
    /// Whether they were projected in full ([`ItemLinks::finished`]).
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

    /// An error unless the finished runs are ranges of the items, in order
    /// and apart (as [`Checkpoint::new`] makes them), and every element,
    /// cluster and value they and the linking name is one of `scene`'s
    /// (whose cluster tree has `clusters` nodes): a checkpoint read from a
    /// file is followed without further checks.
    fn check(&self, scene: &Scene, clusters: usize) -> Result<()> {
        let mut next = 0;
        for block in &self.finished {
            if block.items.start < next || block.items.end > self.items {
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
/// then `three_point` item by item, in runs of consecutive numbers alike
/// finished or not; the first run takes the projection's `kernels_s`.
pub(super) fn runs_of(
    numbers: &[usize],
    two_point: Vec<ItemLinks<Link>>,
    three_point: Vec<ItemLinks<ThreePointLink>>,
    kernels_s: f64,
) -> Vec<Run> {
    debug_assert_eq!(numbers.len(), two_point.len() + three_point.len());
    let mut runs: Vec<Run> = Vec::new();
    let mut two_point = two_point.into_iter();
    let mut three_point = three_point.into_iter();
    for &n in numbers {
        let (finished, two, three) = match two_point.next() {
            Some(item) => (item.finished, item.links, Vec::new()),
            None => {
                let item = three_point.next().expect("one item per number");
                (item.finished, Vec::new(), item.links)
            }
        };
        match runs.last_mut() {
            Some(run) if run.finished == finished && run.links.items.end == n => {
                run.links.items.end = n + 1;
                run.links.two_point.extend(two);
                run.links.three_point.extend(three);
            }
            _ => runs.push(Run {
                links: BlockLinks {
                    items: n..n + 1,
                    two_point: two,
                    three_point: three,
                    kernels_s: if runs.is_empty() { kernels_s } else { 0.0 },
                },
                finished,
            }),
        }
    }
    runs
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

/// Resume the gathering solve of `scene` that `from` was cut short in
/// (its [`Solution::checkpoint`]): project the items it left, keep the
/// links of those it finished, and finish as [`super::solve`] does, with
/// `settings` (which must refine as `from.settings` did:
/// [`SolveSettings::for_resuming`] makes them). The result is what the
/// uninterrupted solve gives, bit for bit, and its statistics count the
/// items taken from the checkpoint (`resumed_items`) and those projected
/// (`projected_items`). Cut short again, it has a checkpoint of its own.
///
/// # Errors
/// [`Error::Resume`] when `from` has no checkpoint (it ran to the end),
/// `scene` is not the scene it solved (naming the first difference), a
/// setting that changes refinement differs (naming it), or the checkpoint
/// does not fit the scene's plan; the errors of [`super::plan`].
pub fn resume(
    scene: &Scene,
    settings: &SolveSettings,
    from: &Solution,
    progress: &dyn Progress,
) -> Result<Solution> {
    let Some(checkpoint) = &from.checkpoint else {
        return Err(Error::Resume(
            "the solve ran to the end: nothing is left to resume".into(),
        ));
    };
    if let Some(difference) = from.scene.difference(scene) {
        return Err(Error::Resume(format!(
            "the scene changed since the solve: it now has {difference}"
        )));
    }
    settings.check_resumes(&from.settings)?;

    // The plan of the interrupted solve, its linking as it was.
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
    let resumed = checkpoint.finished_items();
    let left = plan.project_numbered(&checkpoint.unfinished(), progress);
    let runs = (checkpoint.finished.iter().cloned())
        .map(|links| Run {
            links,
            finished: true,
        })
        .chain(left)
        .collect();
    plan.finish_runs(runs, resumed, progress)
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
            let resumed = resume(&scene, &settings, &cut, &Silent).unwrap();
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

    #[test]
    fn a_resumed_solve_cut_short_again_keeps_both_runs_work() {
        let scene = glossy_box();
        let settings = coarse();
        let first = solve(&scene, &settings, &interrupt_after(30)).unwrap();
        let done = first.checkpoint.as_ref().unwrap().finished_items();
        let second = resume(&scene, &settings, &first, &interrupt_after(30)).unwrap();
        let checkpoint = second.checkpoint.clone().expect("cut short again");
        assert!(checkpoint.finished_items() >= done);
        let resumed = resume(&scene, &settings, &second, &Silent).unwrap();
        let whole = solve(&scene, &settings, &Silent).unwrap();
        assert_eq!(resumed.radiance, whole.radiance);
    }

    #[test]
    fn a_checkpoint_naming_what_the_scene_lacks_is_refused_not_followed() {
        let scene = glossy_box();
        let settings = coarse();
        let spoil: [fn(&mut Checkpoint); 3] = [
            |c| c.linking.element_pairs[0][1].surface = 999,
            |c| c.linking.element_pairs[0][0].id.path = 1 << 40,
            |c| {
                let block = c.finished.iter_mut().find(|b| !b.two_point.is_empty());
                match block {
                    Some(b) => b.two_point[0].throughput = f64::NAN,
                    None => c.finished[0].three_point[0].coefficient.0[1] = f64::INFINITY,
                }
            },
        ];
        for (k, spoil) in spoil.into_iter().enumerate() {
            let mut bad = solve(&scene, &settings, &interrupt_after(4000)).unwrap();
            spoil(bad.checkpoint.as_mut().unwrap());
            match resume(&scene, &settings, &bad, &Silent) {
                Err(e) => assert!(e.to_string().contains("does not have"), "case {k}: {e}"),
                Ok(_) => panic!("case {k}: resumed"),
            }
        }
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
        let refused = message(resume(&scene, &finer, &cut(), &Silent));
        assert!(refused.contains("threshold is 1e-4"), "{refused}");
        // The limits and the sweeps' settings may change.
        let longer = settings
            .for_resuming(&[("max_iterations", Value::Count(300))])
            .unwrap();
        assert!(resume(&scene, &longer, &cut(), &Silent).is_ok());

        let mut other = scene.clone();
        let light = other.surfaces.last_mut().unwrap();
        light.emission = light.emission * 2.0;
        let refused = message(resume(&other, &settings, &cut(), &Silent));
        assert!(refused.contains("scene changed"), "{refused}");

        let whole = solve(&scene, &settings, &Silent).unwrap();
        let refused = message(resume(&scene, &settings, &whole, &Silent));
        assert!(refused.contains("ran to the end"), "{refused}");
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
