//! Statistics of a solution: the quantities the paper reports in §5 ("two
//! point nodes", "two point interactions"), per-level counts, time per phase
//! and peak memory.

use crate::geometry::hierarchy::ElementTree;
use crate::progress::Stop;
use crate::refine::two_point_projection::Link;
use crate::scene::Scene;
use crate::setting::{Described, Value};
use crate::solve::gather::Directional;
use crate::solve::SolveSettings;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Wall-clock seconds spent in each phase.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct PhaseTimes {
    /// Building the ray-tracing acceleration structure.
    pub visibility_build_s: f64,
    /// Adaptive kernel projection (links).
    pub kernels_s: f64,
    /// Building element hierarchies and transfer lists.
    pub hierarchy_s: f64,
    /// Gauss–Seidel gathering with push–pull.
    pub solve_s: f64,
    /// Rendering (zero until an image is rendered).
    pub render_s: f64,
}

/// How the Gauss–Seidel sweeps of a solve ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sweeps {
    /// Sweeps done.
    pub iterations: u32,
    /// Change of the power the surfaces send in the last sweep, relative
    /// to that power (infinite before any sweep).
    pub residual: f64,
}

impl Sweeps {
    /// No sweep done yet.
    pub const NONE: Sweeps = Sweeps {
        iterations: 0,
        residual: f64::INFINITY,
    };
}

/// Statistics of one solve.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Number of surfaces (two-sided materials count twice).
    pub surfaces: usize,
    /// Elements in all hierarchies: the paper's "two point nodes".
    pub two_point_nodes: usize,
    /// Links: the paper's "two point interactions".
    pub two_point_interactions: usize,
    /// Element pairs in all directional structures of glossy surfaces: the
    /// paper's "three point directional nodes".
    pub three_point_nodes: usize,
    /// Three-point links: the paper's "three point interactions".
    pub three_point_interactions: usize,
    /// Element pairs per sum of their two levels (index = level of a +
    /// level of b).
    pub three_point_nodes_per_level: Vec<usize>,
    /// Elements per level (index = level).
    pub nodes_per_level: Vec<usize>,
    /// Links per level of their finer element (index = level).
    pub interactions_per_level: Vec<usize>,
    /// Every setting of the solve by its described name
    /// ([`SolveSettings::SETTINGS`](crate::setting::Described::SETTINGS)).
    /// Written in human-readable formats (JSON) only: a binary one (a
    /// solution file) holds the settings themselves, and reads back an
    /// empty map.
    #[serde(with = "text_only")]
    pub settings: BTreeMap<&'static str, Value>,
    /// Leaves whose form factors summed above one (quadrature error, or
    /// surfaces closer together than their elements resolve), whose
    /// reflected light was scaled down so that none reflects more than
    /// reaches it ([`crate::solve::push_pull::reflection_limits`]).
    pub limited_leaves: usize,
    /// Projections the refine–solve loop made (1 for the kernel oracle; at
    /// most the `refine_passes` setting).
    pub projections: u32,
    /// How the system was solved: `gather` (Gauss–Seidel, every kernel
    /// projected up front) or `shoot` (progressive shooting, kernels
    /// projected lazily where light flows).
    pub solver: String,
    /// Shooting steps done (one surface's unshot radiance each; 0 when
    /// gathering).
    pub shooting_steps: u32,
    /// Unshot power left when shooting stopped, relative to the emitted
    /// power (0 when gathering).
    pub unshot_fraction: f64,
    /// Surface pairs linked element to element that can exchange light
    /// (not facing away): the pairs gathering projects kernels for.
    pub exchanging_pairs: usize,
    /// Links between clusters of surfaces or elements, made above the
    /// elements ([`crate::refine::cluster_links`]).
    pub cluster_links: usize,
    /// Surface pairs whose kernels were projected: all exchanging pairs when
    /// gathering, only those light flowed through when shooting.
    pub kernel_pairs: usize,
    /// Gauss–Seidel sweeps done (when shooting: the sweeps that finish the
    /// solution over the links it made).
    pub iterations: u32,
    /// Change of the power the surfaces send in the last sweep, relative
    /// to that power ([`super::SolveSettings::tolerance`]).
    pub residual: f64,
    /// Whether the residual reached the tolerance, or the sweeps the
    /// scene's bounce limit allows were made ([`super::bounces`]).
    pub converged: bool,
    /// Time per phase.
    pub times: PhaseTimes,
    /// Peak resident memory of the process in bytes, where the OS tells.
    pub peak_memory_bytes: Option<u64>,
    /// What cut the solve short ([`crate::progress::Budget`]), if anything.
    pub stopped: Option<Stop>,
    /// Surface pairs and triples linked whole, links left as they were
    /// instead of refined further, and pairs of clusters linked at the
    /// coarsest cluster ratio
    /// ([`MAX_CLUSTER_RATIO`](crate::refine::cluster_links::MAX_CLUSTER_RATIO)),
    /// because the solve was cut short: what it cost in accuracy.
    pub unrefined_items: usize,
    /// Surface triples (r, p, q) of glossy surfaces the plan projects
    /// (the paper's three-point kernels, each refined from whole surfaces).
    pub three_point_items: usize,
    /// Surface triples of the scene past the plan's
    /// [`MAX_TRIPLES`](crate::refine::three_point_projection::MAX_TRIPLES),
    /// left out of it: with no three-point links, their glossy surfaces
    /// reflect through their distributions per bin
    /// ([`crate::solve::glossy_clusters`]).
    pub unplanned_triples: u64,
    /// Surface triples of the plan left out, with no three-point links,
    /// because the solve was cut short before they started (linking them
    /// whole would cost a quadrature each).
    pub left_out_items: usize,
    /// Projection items (surface pairs and triples) taken with their links
    /// from the checkpoint of a solve cut short ([`crate::solve::resume`]),
    /// not projected again.
    pub resumed_items: usize,
    /// Projection items projected by this solve (all of them, unless it
    /// resumed another).
    pub projected_items: usize,
}

impl Stats {
    /// What the user should be told when something cut the solve short
    /// ([`Stats::stopped`]): the limit, what it left unrefined or out, and
    /// whether Gauss–Seidel stopped early; `None` when it ran to the end.
    pub fn cut_short_warning(&self) -> Option<String> {
        let stop = self.stopped?;
        let left_out = match self.left_out_items {
            0 => String::new(),
            n => format!(
                ", {n} of {} surface triples of glossy surfaces left out (no three-point links)",
                self.three_point_items
            ),
        };
        let sweeps = match self.converged {
            true => String::new(),
            false => format!(
                ", and Gauss–Seidel stopped after {} sweeps",
                self.iterations
            ),
        };
        Some(format!(
            "{stop} cut the solve short: {} surface pairs, triples or links were left \
             unrefined{left_out}{sweeps}; the image is coarser than a full solve's",
            self.unrefined_items
        ))
    }

    /// What the user should be told when Gauss–Seidel ran out of sweeps
    /// before its residual fell below `tolerance` (and no limit stopped
    /// it: [`Stats::cut_short_warning`] says that); `None` when it
    /// converged.
    pub fn not_converged_warning(&self, tolerance: f64) -> Option<String> {
        (!self.converged && self.stopped.is_none()).then(|| {
            format!(
                "not converged: the residual is {:.2e} after {} sweeps (tolerance {tolerance:.0e})",
                self.residual, self.iterations
            )
        })
    }

    /// The counts of a gathering solve over `trees` and two-point links
    /// counted as `links`, `three_point_interactions` three-point links
    /// into the `directional` structures, after `sweeps`; one refine pass,
    /// no times (the solvers fill in those and their own fields).
    pub(crate) fn new(
        scene: &Scene,
        settings: &SolveSettings,
        trees: &[ElementTree],
        links: LinkCounts,
        directional: &[Directional],
        three_point_interactions: usize,
        sweeps: Sweeps,
    ) -> Stats {
        let nodes_per_level = add_counts(trees.iter().map(ElementTree::count_per_level));
        let LinkCounts(mut interactions_per_level) = links;
        let two_point_interactions = interactions_per_level.iter().sum();
        let levels = interactions_per_level
            .len()
            .max(nodes_per_level.len())
            .max(1);
        interactions_per_level.resize(levels, 0);
        Stats {
            surfaces: scene.surfaces.len(),
            two_point_nodes: trees.iter().map(|t| t.nodes.len()).sum(),
            two_point_interactions,
            three_point_nodes: directional.iter().map(|d| d.tree.nodes.len()).sum(),
            three_point_nodes_per_level: add_counts(
                directional.iter().map(|d| d.tree.count_per_level()),
            ),
            three_point_interactions,
            nodes_per_level,
            interactions_per_level,
            settings: settings.values().into_iter().collect(),
            projections: 1,
            limited_leaves: 0,
            solver: "gather".into(),
            shooting_steps: 0,
            unshot_fraction: 0.0,
            exchanging_pairs: 0,
            cluster_links: 0,
            kernel_pairs: 0,
            iterations: sweeps.iterations,
            residual: sweeps.residual,
            converged: sweeps.residual <= settings.tolerance
                || super::bounces(scene).is_some_and(|b| sweeps.iterations >= b),
            times: PhaseTimes::default(),
            stopped: None,
            unrefined_items: 0,
            three_point_items: 0,
            unplanned_triples: 0,
            left_out_items: 0,
            resumed_items: 0,
            projected_items: 0,
            peak_memory_bytes: peak_memory_bytes(),
        }
    }
}

/// Two-point links counted by level (the deeper of their two elements'):
/// all [`Stats`] keeps of them, so that a solve need not hold the links.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct LinkCounts(Vec<usize>);

impl LinkCounts {
    /// The counts of `links`.
    pub(crate) fn of<'l>(links: impl IntoIterator<Item = &'l Link>) -> LinkCounts {
        let mut per_level = Vec::new();
        for l in links {
            let level = l.a.level.max(l.c.level) as usize;
            if per_level.len() <= level {
                per_level.resize(level + 1, 0);
            }
            per_level[level] += 1;
        }
        LinkCounts(per_level)
    }
}

/// [`Stats::settings`] in human-readable formats (JSON) only
/// ([`serde::Serializer::is_human_readable`]): its values are untagged,
/// which only a self-describing format tells apart, so a binary one (a
/// solution file) holds the [`SolveSettings`] they describe instead. Read
/// back, from either, as an empty map.
mod text_only {
    use super::{BTreeMap, Value};
    use serde::de::IgnoredAny;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(
        settings: &BTreeMap<&'static str, Value>,
        serializer: S,
    ) -> Result<S::Ok, S::Error> {
        if serializer.is_human_readable() {
            settings.serialize(serializer)
        } else {
            serializer.serialize_unit()
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(
        deserializer: D,
    ) -> Result<BTreeMap<&'static str, Value>, D::Error> {
        if deserializer.is_human_readable() {
            IgnoredAny::deserialize(deserializer)?;
        } else {
            <()>::deserialize(deserializer)?;
        }
        Ok(BTreeMap::new())
    }
}

/// Per-level counts added up level by level.
fn add_counts(counts: impl Iterator<Item = Vec<usize>>) -> Vec<usize> {
    let mut total = Vec::new();
    for c in counts {
        if total.len() < c.len() {
            total.resize(c.len(), 0);
        }
        total.iter_mut().zip(c).for_each(|(t, n)| *t += n);
    }
    total
}

/// Peak resident set size of this process (Linux `VmHWM`), if known.
pub fn peak_memory_bytes() -> Option<u64> {
    crate::progress::proc_status_kib("VmHWM:").map(|kib| kib * 1024)
}
