//! Progressive shooting with lazy kernels, the route the paper's §6 proposes
//! (progressive refinement after Cohen et al. 1988, in its Southwell form,
//! over the hierarchical links of Hanrahan et al. 1991).
//!
//! Every surface keeps, per element of its hierarchy, its radiance and its
//! *unshot* radiance: light it has received but not yet sent on. Emitters
//! start with unshot radiance = emission. Each step shoots the surface with
//! the most unshot power (area × unshot radiance, largest channel): for
//! every diffuse surface it can light (the pairs of
//! [`crate::refine::two_point_projection::linked_pairs`]), the pair's links are projected the first
//! time power flows through them, with the power-weighted oracle weighing
//! the kernel by the shooter's unshot radiance, and re-tested from their
//! stored details ([`crate::refine::refine_further`]) when a later shot
//! carries more power than they were refined for. Each receiver element
//! gains ρ·F·ΔL, push–pull keeps its averages, and the shooter's unshot
//! radiance becomes zero. Kernels between surfaces no light flows between
//! are never projected.
//!
//! Shooting stops when the unshot power falls below `tolerance` × the
//! emitted power, or after `max_iterations` steps. Gauss–Seidel sweeps over
//! the links made then finish the solution, starting from the shot
//! radiance (so they are few): early shots went through links that later
//! shots refined, and the sweeps make the result the exact fixed point of
//! the final links, as [`super::solve`]'s is of its own, and spread the
//! last unshot power. The result is an ordinary [`Solution`].
//!
//! Only diffuse scenes for now: glossy surfaces are an
//! [`Error::InvalidSetting`].
//!
//! ```
//! use std::ops::ControlFlow;
//! use wavrad_core::scene::{Rgb, Scene, Surface};
//! use wavrad_core::solve::{shoot::solve_shooting, SolveSettings};
//! use wavrad_core::progress::Silent;
//! use glam::DVec3;
//!
//! // A unit cube seen from inside: every face reflects 50 % and emits 1.
//! let faces = wavrad_core::testing::inward_box(DVec3::ZERO, DVec3::ONE);
//! let surfaces = faces
//!     .into_iter()
//!     .map(|patch| Surface { name: "wall".into(), patch, brdf: wavrad_core::scene::brdf::Brdf::diffuse(Rgb::splat(0.5)), emission: Rgb::splat(1.0), texture: None, shading: None })
//!     .collect();
//! let mut settings = SolveSettings::default();
//! settings.refine.max_level = 3;
//! let mut steps = 0;
//! let mut on_step = |_: &_, _: &_| {
//!     steps += 1; // a progressive image could be rendered here
//!     ControlFlow::Continue(())
//! };
//! let solution =
//!     solve_shooting(&Scene::from_surfaces(surfaces), &settings, &Silent, Some(&mut on_step)).unwrap();
//! // The furnace: radiance is Le / (1 − ρ) = 2 everywhere.
//! assert!((solution.radiance[0][0][0] - 2.0).abs() < 0.03);
//! assert_eq!(solution.stats.shooting_steps, steps);
//! ```

use super::gather::{form_factor, receiver_gradient, reflected, Interactions};
use super::push_pull::Gathered;
use super::{push_pull, Links, Solution, SolveSettings, System};
use crate::geometry::cluster::ClusterTree;
use crate::geometry::hierarchy::{ElementId, ElementRef, ElementTree};
use crate::geometry::tracing::SceneTracer;
use crate::kernel::exposure::exposed_fractions;
use crate::kernel::KernelContext;
use crate::progress::{Budgeted, Progress, StopOnly};
use crate::refine::emitter_links::resolve_emitter_links;
use crate::refine::estimate::LightEstimate;
use crate::refine::oracle::Oracle;
use crate::refine::refine_further;
use crate::refine::two_point_projection::{linked_pairs, refine_pair, Link};
use crate::scene::brdf::{BrdfFlags, BrdfModel};
use crate::scene::{Rgb, Scene};
use crate::solve::stats::{LinkCounts, PhaseTimes, Stats, Sweeps};
use crate::{Error, Result};
use rayon::prelude::*;
use std::borrow::Cow;
use std::collections::BTreeSet;
use std::ops::ControlFlow;
use std::time::Instant;

/// Most surfaces the shooting solver takes: it links surfaces pairwise (no
/// clustering), and 4096 surfaces already make 8.4 million pairs.
pub const MAX_SHOOTING_SURFACES: usize = 4096;

/// The root elements of a surface pair.
fn roots((p, r): (u32, u32)) -> [ElementRef; 2] {
    [ElementRef::root(p), ElementRef::root(r)]
}

/// What one shooting step did, as reported to the `on_step` callback of
/// [`solve_shooting`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// Steps done so far (1 after the first).
    pub index: u32,
    /// The surface that was shot.
    pub shooter: u32,
    /// Unshot power left, relative to the emitted power.
    pub unshot_fraction: f64,
    /// Surface pairs whose kernels are projected so far.
    pub kernel_pairs: usize,
    /// Two-point links so far.
    pub links: usize,
}

/// The callback of [`solve_shooting`]: called after every step with the
/// solution so far; `ControlFlow::Break` stops shooting early (the solution
/// is then finished as usual).
pub type OnStep<'a> = &'a mut dyn FnMut(&Solution, &Step) -> ControlFlow<()>;

/// Solve a diffuse `scene` by progressive shooting with lazy kernels (see
/// the [module documentation](self)).
///
/// `settings` are those of [`super::solve`]: with [`Oracle::Power`] links
/// are refined by the power they carry, with [`Oracle::Kernel`] by the
/// paper's kernel oracle (still only for pairs light flows through);
/// `tolerance` applies to the unshot power relative to the emitted power,
/// `max_iterations` to the steps (and to the finishing sweeps).
///
/// After every step `on_step`, if given, sees the solution so far: its
/// element trees and radiance (what rendering reads on diffuse surfaces)
/// and its statistics; its `interactions` stay empty until the end. The
/// result is the same for any number of threads.
///
/// # Errors
/// [`Error::InvalidSetting`] for a scene with a glossy or textured surface
/// or a path length limit ([`crate::scene::RenderHints::max_depth`]), for
/// the importance oracle, or for bad settings; [`Error::EmptyScene`],
/// [`Error::TooManySurfaces`], [`Error::NoLight`] and [`Error::Diverged`]
/// as [`super::solve`].
pub fn solve_shooting(
    scene: &Scene,
    settings: &SolveSettings,
    progress: &dyn Progress,
    mut on_step: Option<OnStep<'_>>,
) -> Result<Solution> {
    let budget = settings.budget();
    let progress = &Budgeted {
        progress,
        budget: &budget,
    };
    settings.validate()?;
    super::check_size(scene)?;
    if scene.surfaces.len() > MAX_SHOOTING_SURFACES {
        return Err(Error::TooManySurfaces {
            surfaces: scene.surfaces.len(),
            limit: MAX_SHOOTING_SURFACES,
        });
    }
    super::check_light(scene)?;
    if let Some(s) = scene
        .surfaces
        .iter()
        .find(|s| s.brdf.flags().contains(BrdfFlags::GLOSSY_REFLECTION))
    {
        return Err(Error::InvalidSetting(format!(
            "the shooting solver supports diffuse scenes for now, but surface '{}' is glossy \
             (use the gather solver)",
            s.name
        )));
    }
    if !scene.lights.is_empty() {
        return Err(Error::InvalidSetting(
            "the shooting solver supports area emitters only for now, but the scene has point, \
             spot, directional or sky lights (use the gather solver)"
                .into(),
        ));
    }
    if let Some(s) = scene.surfaces.iter().find(|s| s.texture.is_some()) {
        return Err(Error::InvalidSetting(format!(
            "the shooting solver supports untextured scenes for now, but surface '{}' is \
             textured (use the gather solver)",
            s.name
        )));
    }
    if settings.oracle == Oracle::Importance {
        return Err(Error::InvalidSetting(
            "the shooting solver supports the kernel and power oracles for now".into(),
        ));
    }
    if let Some(depth) = scene.hints.max_depth {
        return Err(Error::InvalidSetting(format!(
            "the shooting solver solves for every bounce, but the scene's integrator limits \
             paths to max_depth {depth} (use the gather solver, which honours it)"
        )));
    }
    let mut times = PhaseTimes::default();
    let clock = Instant::now();
    let tracer = SceneTracer::new(scene);
    times.visibility_build_s = clock.elapsed().as_secs_f64();
    // The statistics are filled in after every step.
    let mut solution = Solution {
        scene: scene.clone(),
        tracer,
        pairs: Vec::new(),
        trees: Vec::new(),
        radiance: Vec::new(),
        interactions: Interactions::default(),
        directional: Vec::new(),
        settings: *settings,
        stats: Stats::default(),
        checkpoint: None,
    };
    let ctx = KernelContext::new(scene, &solution.tracer, settings.quadrature);
    let mut shooting = Shooting::new(ctx, settings, times);

    // Shoot the surface with the most unshot power until little is left.
    progress.start("shooting", u64::from(settings.max_iterations));
    while shooting.steps < settings.max_iterations && !progress.interrupted() {
        let (shooter, remaining) = shooting.largest_unshot();
        if remaining <= settings.tolerance {
            break;
        }
        shooting.shoot(shooter, progress);
        progress.advance(1);
        let Some(on_step) = on_step.as_deref_mut() else {
            continue;
        };
        solution.trees = shooting.states.iter().map(|s| s.tree.clone()).collect();
        solution.radiance = shooting.states.iter().map(|s| s.radiance.clone()).collect();
        solution.stats = shooting.stats(&solution.trees, Sweeps::NONE);
        let step = Step {
            index: shooting.steps,
            shooter: shooter as u32,
            unshot_fraction: solution.stats.unshot_fraction,
            kernel_pairs: solution.stats.kernel_pairs,
            links: solution.stats.two_point_interactions,
        };
        if on_step(&solution, &step).is_break() {
            break;
        }
    }
    progress.finish();

    // Finish with Gauss–Seidel sweeps over the links made, the emitters'
    // carried down to where their light changes (as the gather solver does:
    // that may make new elements, so the system is assembled anew and its
    // sweeps start from the emission).
    let clock = Instant::now();
    let links: Vec<Link> = shooting.links().copied().collect();
    let max_level = settings.refine.max_level;
    let (links, _) = resolve_emitter_links(&ctx, max_level, &links, progress);
    let trees = super::element_trees(scene, &links, &[], &[], &[]);
    shooting.times.kernels_s += clock.elapsed().as_secs_f64();
    let links = Links {
        two_point: Cow::Owned(links),
        three_point: &[],
        clusters: (&ClusterTree::default(), Cow::Borrowed(&[])),
        lights: &[],
    };
    let mut system = System::assemble(&ctx, &[], trees, links, &mut shooting.times);
    let sweeps = system.solve(scene, settings, progress, &mut shooting.times)?;
    solution.stats = Stats {
        limited_leaves: system.interactions.limited_leaves,
        stopped: budget.stopped(),
        unrefined_items: budget.coarse_items(),
        ..shooting.stats(&system.trees, sweeps)
    };
    solution.trees = system.trees;
    solution.radiance = system.radiance;
    solution.interactions = system.interactions;
    Ok(solution)
}

/// Radiance and unshot radiance over one surface's element hierarchy.
struct SurfaceState {
    /// Elements any link of the surface mentioned (the tree holds them).
    ids: BTreeSet<ElementId>,
    tree: ElementTree,
    /// Exposed fraction of each node ([`crate::kernel::exposure`]) under
    /// the kernels' quadrature.
    exposure: Vec<f64>,
    radiance: Vec<Rgb>,
    unshot: Vec<Rgb>,
}

impl SurfaceState {
    fn new(ctx: &KernelContext, s: u32) -> SurfaceState {
        let surface = &ctx.scene.surfaces[s as usize];
        let tree = ElementTree::build(&surface.patch, &BTreeSet::new());
        SurfaceState {
            ids: BTreeSet::new(),
            exposure: exposed_fractions(ctx, s, &tree, None),
            tree,
            radiance: vec![surface.emission],
            unshot: vec![surface.emission],
        }
    }

    /// Make the tree hold `ids`. New elements inherit the radiance of the
    /// leaf they lie in (radiance is constant over a leaf), so the radiance
    /// represented does not change.
    fn grow(&mut self, ctx: &KernelContext, s: u32, ids: impl IntoIterator<Item = ElementId>) {
        let before = self.ids.len();
        self.ids.extend(
            ids.into_iter()
                .filter(|&id| self.tree.index_of(id).is_none()),
        );
        if self.ids.len() == before {
            return;
        }
        let tree = ElementTree::build(&ctx.scene.surfaces[s as usize].patch, &self.ids);
        let carry = |values: &[Rgb]| {
            tree.nodes
                .iter()
                .map(|n| values[self.tree.node_containing(n.id) as usize])
                .collect::<Vec<Rgb>>()
        };
        self.radiance = carry(&self.radiance);
        self.unshot = carry(&self.unshot);
        let previous = Some((&self.tree, &self.exposure[..]));
        self.exposure = exposed_fractions(ctx, s, &tree, previous);
        self.tree = tree;
    }

    /// Receive the unshot radiance `unshot` (over `tree`) of surface `s`
    /// through `links` of the pair (r, s), r being this surface:
    /// ρ·F·ΔL at each receiving element, then push–pull.
    fn receive(
        &mut self,
        ctx: &KernelContext,
        r: u32,
        links: &[Link],
        tree: &ElementTree,
        unshot: &[Rgb],
    ) {
        let rho = ctx.scene.surfaces[r as usize]
            .brdf
            .lambertian()
            .unwrap_or(Rgb::ZERO);
        let ends = |l: &Link| if l.p == r { (l.a, l.c) } else { (l.c, l.a) };
        self.grow(ctx, r, links.iter().map(|l| ends(l).0));
        let mut gathered = Gathered::new(self.tree.nodes.len());
        for l in links {
            let (a, c) = ends(l);
            let node = self.tree.index_of(a).expect("link element is in its tree") as usize;
            let form_factor = form_factor(&self.tree, &self.exposure, node, l.throughput);
            let sent = unshot[tree.node_containing(c) as usize];
            let value = reflected(rho, form_factor, sent);
            let shares = l.shares_into(l.p == r);
            let source = c.patch(&tree.nodes[0].patch);
            let gradient = receiver_gradient(&self.tree, &self.exposure, node, &source, shares);
            gathered.add(node, value, gradient);
        }
        let averages = gathered.into_averages(&self.tree);
        let received = push_pull::push_pull(
            &self.tree,
            &averages,
            Rgb::ZERO,
            Some(&self.exposure),
            None,
            None,
        );
        for ((l, u), d) in self.radiance.iter_mut().zip(&mut self.unshot).zip(received) {
            *l += d;
            *u += d;
        }
    }
}

/// The state of a shooting solve.
struct Shooting<'a> {
    ctx: KernelContext<'a>,
    settings: &'a SolveSettings,
    /// Surface pairs that can exchange light, in order.
    pairs: Vec<(u32, u32)>,
    /// For each surface, the (receiver, pair index) it can light: diffuse
    /// receivers that reflect something.
    targets: Vec<Vec<(u32, usize)>>,
    /// Links of each pair, `None` until light first flows through it.
    links: Vec<Option<Vec<Link>>>,
    states: Vec<SurfaceState>,
    /// Σ area × emission (largest channel).
    emitted: f64,
    steps: u32,
    times: PhaseTimes,
}

impl<'a> Shooting<'a> {
    fn new(ctx: KernelContext<'a>, settings: &'a SolveSettings, times: PhaseTimes) -> Self {
        let scene = ctx.scene;
        let pairs = linked_pairs(&ctx);
        let reflects = |s: u32| {
            let surface = &scene.surfaces[s as usize];
            surface
                .brdf
                .lambertian()
                .is_some_and(|rho| rho.max_channel() > 0.0)
        };
        let mut targets = vec![Vec::new(); scene.surfaces.len()];
        for (i, &(p, r)) in pairs.iter().enumerate() {
            if reflects(r) {
                targets[p as usize].push((r, i));
            }
            if reflects(p) {
                targets[r as usize].push((p, i));
            }
        }
        Shooting {
            ctx,
            settings,
            links: vec![None; pairs.len()],
            pairs,
            targets,
            states: (0..scene.surfaces.len() as u32)
                .map(|s| SurfaceState::new(&ctx, s))
                .collect(),
            emitted: scene
                .surfaces
                .iter()
                .map(|s| s.patch.area() * s.emission.max_channel())
                .sum(),
            steps: 0,
            times,
        }
    }

    /// The surface with the most unshot power (the first of equals), and
    /// the unshot power of all surfaces relative to the emitted power.
    fn largest_unshot(&self) -> (usize, f64) {
        let mut best = (0, 0.0);
        let mut total = 0.0;
        for (s, (state, surface)) in self.states.iter().zip(&self.ctx.scene.surfaces).enumerate() {
            let power = surface.patch.area() * state.exposure[0] * state.unshot[0].max_channel();
            total += power;
            if power > best.1 {
                best = (s, power);
            }
        }
        let relative = if self.emitted > 0.0 {
            total / self.emitted
        } else {
            0.0
        };
        (best.0, relative)
    }

    /// Send the unshot radiance of surface `s` to every surface it can
    /// light; refinement stops splitting once `stop` asks it to.
    fn shoot(&mut self, s: usize, stop: &dyn Progress) {
        let (ctx, settings) = (&self.ctx, self.settings);
        let scene = ctx.scene;
        let tree = self.states[s].tree.clone();
        let unshot = std::mem::take(&mut self.states[s].unshot);

        // Kernels: project the pairs light flows through for the first time,
        // re-test the others. The oracle weighs a link by all the radiance
        // its source has gathered so far, not this shot's share: a link's
        // error shows in the receiver's final radiance.
        let clock = Instant::now();
        let estimate = (settings.oracle == Oracle::Power)
            .then(|| LightEstimate::shot(scene, s as u32, tree.clone(), &self.states[s].radiance));
        let mut work: Vec<(usize, Option<Vec<Link>>)> = self.targets[s]
            .iter()
            .map(|&(_, i)| (i, self.links[i].take()))
            .collect();
        let stop = &StopOnly(stop);
        work.par_iter_mut().for_each(|(i, links)| {
            let pair = self.pairs[*i];
            *links = Some(match (links.take(), &estimate) {
                (None, e) => refine_pair(ctx, settings.refine, e.as_ref(), roots(pair), stop),
                (Some(old), Some(e)) => refine_further(ctx, settings.refine, e, old, stop).0,
                (Some(old), None) => old,
            });
        });
        for (i, links) in work {
            self.links[i] = links;
        }
        self.times.kernels_s += clock.elapsed().as_secs_f64();

        // Receivers gain ρ·F·ΔL; the shooter keeps nothing unshot.
        let clock = Instant::now();
        let mut pair_of = vec![None; scene.surfaces.len()];
        for &(r, i) in &self.targets[s] {
            pair_of[r as usize] = Some(i);
        }
        let links = &self.links;
        self.states
            .par_iter_mut()
            .zip(&pair_of)
            .enumerate()
            .for_each(|(r, (state, pair))| {
                if let Some(i) = *pair {
                    let links = links[i].as_deref().unwrap_or_default();
                    state.receive(ctx, r as u32, links, &tree, &unshot);
                }
            });
        let own_ends = self.targets[s]
            .iter()
            .flat_map(|&(_, i)| self.links[i].iter().flatten())
            .map(|l| if l.p as usize == s { l.a } else { l.c });
        let state = &mut self.states[s];
        state.unshot = vec![Rgb::ZERO; state.tree.nodes.len()];
        state.grow(ctx, s as u32, own_ends.collect::<Vec<_>>());
        self.steps += 1;
        self.times.solve_s += clock.elapsed().as_secs_f64();
    }

    /// Every link made so far, pair by pair in order.
    fn links(&self) -> impl Iterator<Item = &Link> {
        self.links.iter().flatten().flatten()
    }

    /// Statistics over `trees` and the links so far, after the finishing
    /// Gauss–Seidel `sweeps`.
    fn stats(&self, trees: &[ElementTree], sweeps: Sweeps) -> Stats {
        let scene = self.ctx.scene;
        Stats {
            solver: super::Solver::Shoot.to_string(),
            shooting_steps: self.steps,
            unshot_fraction: self.largest_unshot().1,
            exchanging_pairs: self.pairs.len(),
            kernel_pairs: self.links.iter().filter(|l| l.is_some()).count(),
            times: self.times,
            ..Stats::new(
                scene,
                self.settings,
                trees,
                LinkCounts::of(self.links()),
                &[],
                0,
                sweeps,
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::{Silent, Stop};
    use crate::scene::brdf::Brdf;
    use crate::scene::{Patch, Surface};
    use crate::solve::solve;
    use glam::DVec3;

    fn wall(patch: Patch, rho: f64, emission: f64) -> Surface {
        Surface {
            name: "wall".into(),
            patch,
            brdf: Brdf::diffuse(Rgb::splat(rho)),
            emission: Rgb::splat(emission),
            texture: None,
            shading: None,
        }
    }

    fn settings(oracle: Oracle, max_level: u32) -> SolveSettings {
        let mut settings = SolveSettings::for_oracle(oracle);
        settings.refine.max_level = max_level;
        settings
    }

    fn shoot(scene: &Scene, settings: &SolveSettings) -> Solution {
        solve_shooting(scene, settings, &Silent, None).unwrap()
    }

    /// A box, open on one side, lit by its ceiling, with a tilted panel
    /// inside that shadows the floor.
    fn open_box() -> Scene {
        let mut faces = crate::testing::inward_box(DVec3::ZERO, DVec3::new(1.0, 1.0, 1.0));
        faces.pop(); // open: one wall missing
        let mut surfaces: Vec<Surface> = faces
            .into_iter()
            .enumerate()
            .map(|(i, patch)| wall(patch, [0.7, 0.5, 0.6, 0.4, 0.5][i], 0.0))
            .collect();
        surfaces[1].emission = Rgb::splat(2.0);
        surfaces.push(wall(
            Patch::Parallelogram {
                origin: DVec3::new(0.3, 0.2, 0.3),
                edge_s: DVec3::new(0.4, 0.0, 0.1),
                edge_t: DVec3::new(0.0, 0.5, 0.0),
            },
            0.6,
            0.0,
        ));
        Scene::from_surfaces(surfaces)
    }

    #[test]
    fn shooting_furnace_radiance_is_le_over_one_minus_rho() {
        let faces =
            crate::testing::inward_box(DVec3::new(-1.0, 0.0, 2.0), DVec3::new(1.0, 1.5, 3.0));
        let scene = Scene::from_surfaces(faces.into_iter().map(|p| wall(p, 0.5, 1.0)).collect());
        for oracle in [Oracle::Kernel, Oracle::Power] {
            let solution = shoot(&scene, &settings(oracle, 4));
            assert!(solution.stats.converged && solution.stats.shooting_steps > 6);
            for r in &solution.radiance {
                let error = (r[0][0] - 2.0).abs() / 2.0;
                assert!(error < 0.015, "{oracle}: surface average {}", r[0][0]);
            }
        }
    }

    #[test]
    fn shooting_matches_gathering_on_an_open_scene() {
        let scene = open_box();
        for (oracle, tolerance) in [(Oracle::Kernel, 1e-3), (Oracle::Power, 0.03)] {
            let settings = settings(oracle, 4);
            let shot = shoot(&scene, &settings);
            let gathered = solve(&scene, &settings, &Silent).unwrap();
            for (s, (a, b)) in shot.radiance.iter().zip(&gathered.radiance).enumerate() {
                for ch in 0..3 {
                    let error = (a[0][ch] - b[0][ch]).abs() / b[0][ch].max(1e-3);
                    assert!(error < tolerance, "{oracle}: surface {s}: {a:?} vs {b:?}");
                }
            }
        }
    }

    /// An emitter over a floor, and two squares below the floor facing each
    /// other: the upper one faces away from both, the lower one sees the
    /// emitter only through the floor. No light reaches them, so their
    /// pair's kernel is never projected.
    #[test]
    fn kernels_are_projected_only_where_light_flows() {
        let square = |z: f64, up: bool| Patch::Parallelogram {
            origin: DVec3::new(0.0, 0.0, z),
            edge_s: if up { DVec3::X } else { DVec3::Y },
            edge_t: if up { DVec3::Y } else { DVec3::X },
        };
        let scene = Scene::from_surfaces(vec![
            wall(square(0.0, true), 0.5, 0.0),
            wall(square(0.5, false), 0.5, 4.0),
            wall(square(-1.0, false), 0.5, 0.0),
            wall(square(-2.0, true), 0.5, 0.0),
        ]);
        let solution = shoot(&scene, &settings(Oracle::Power, 4));
        assert_eq!(solution.stats.exchanging_pairs, 3);
        assert_eq!(solution.stats.kernel_pairs, 2);
        assert!(solution.interactions.incoming[2].is_empty());
        assert_eq!(solution.radiance[3][0], Rgb::ZERO);
        let gathered = solve(&scene, &settings(Oracle::Power, 4), &Silent).unwrap();
        assert_eq!(gathered.stats.kernel_pairs, 3);
        let (a, b) = (solution.radiance[0][0][0], gathered.radiance[0][0][0]);
        assert!((a - b).abs() < 0.01 * b, "floor {a} vs {b}");
    }

    #[test]
    fn shooting_does_not_depend_on_thread_count() {
        let scene = open_box();
        let settings = settings(Oracle::Power, 4);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let s = shoot(&scene, &settings);
                (s.radiance, s.trees, s.interactions, s.stats.shooting_steps)
            })
        };
        assert!(run(1) == run(2));
    }

    #[test]
    fn progressive_steps_brighten_and_can_stop_early() {
        let scene = open_box();
        let mut seen = Vec::new();
        let mut on_step = |solution: &Solution, step: &Step| {
            let total: f64 = solution.radiance.iter().map(|r| r[0][0]).sum();
            seen.push((step.index, step.unshot_fraction, total));
            if step.index == 5 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        };
        let settings = settings(Oracle::Power, 3);
        let solution = solve_shooting(&scene, &settings, &Silent, Some(&mut on_step)).unwrap();
        assert_eq!(solution.stats.shooting_steps, 5);
        assert_eq!(
            seen.iter().map(|s| s.0).collect::<Vec<_>>(),
            [1, 2, 3, 4, 5]
        );
        assert!(seen
            .windows(2)
            .all(|w| w[1].2 >= w[0].2 && w[1].1 <= w[0].1));
    }

    /// A driver that asks the work to stop from its `after`-th question on.
    struct InterruptAfter {
        asked: std::sync::atomic::AtomicUsize,
        after: usize,
    }
    impl Progress for InterruptAfter {
        fn interrupted(&self) -> bool {
            let asked = self
                .asked
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            asked + 1 >= self.after
        }
    }

    #[test]
    fn a_stop_during_a_step_cuts_its_refinement_short() {
        let scene = open_box();
        let mut settings = settings(Oracle::Kernel, 8);
        settings.refine.threshold = 0.0;
        let stop = InterruptAfter {
            asked: Default::default(),
            after: 40,
        };
        let cut = solve_shooting(&scene, &settings, &stop, None).unwrap();
        assert_eq!(cut.stats.stopped, Some(Stop::Interrupted));
        assert!(cut.stats.unrefined_items > 0, "{:?}", cut.stats);
        assert_eq!(cut.stats.shooting_steps, 1);
        // The first step's links stop at the level reached when asked,
        // far above the finest an uninterrupted step would make.
        assert!(cut.stats.two_point_interactions < 2_000, "{:?}", cut.stats);
        assert!(cut
            .radiance
            .iter()
            .flatten()
            .all(|r| r.0.iter().all(|v| v.is_finite())));
    }

    #[test]
    fn glossy_textured_or_depth_limited_scenes_and_the_importance_oracle_are_clear_errors() {
        let mut scene = open_box();
        let err = shoot_err(&scene, Oracle::Importance);
        assert!(err.contains("kernel and power"), "{err}");
        scene.surfaces[0].brdf = Brdf::Ward(crate::scene::brdf::Ward::default());
        let err = shoot_err(&scene, Oracle::Power);
        assert!(err.contains("diffuse scenes"), "{err}");
        let mut scene = open_box();
        scene.surfaces[0].texture = Some(crate::scene::texture::TextureMapping {
            texture: 0,
            uv: [glam::Vec2::ZERO; 3],
        });
        let err = shoot_err(&scene, Oracle::Power);
        assert!(err.contains("untextured scenes"), "{err}");
        let mut scene = open_box();
        scene.hints.max_depth = Some(3);
        let err = shoot_err(&scene, Oracle::Power);
        assert!(err.contains("max_depth 3"), "{err}");
    }

    fn shoot_err(scene: &Scene, oracle: Oracle) -> String {
        match solve_shooting(scene, &SolveSettings::for_oracle(oracle), &Silent, None) {
            Err(e) => e.to_string(),
            Ok(_) => String::new(),
        }
    }
}
