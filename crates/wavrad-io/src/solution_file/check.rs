//! What a solution read from a file must hold before it is rendered: the
//! renderer follows its indices (nodes, surfaces, directional structures,
//! cover lists) and computes with its values without checks, as it may for
//! a solution it solved itself. A file whose checksum matches can still be
//! made by hand, or by a writer's bug; each check here turns what would be
//! a panic, or a non-finite pixel, into a [`SolutionProblem::Inconsistent`]
//! naming the part.

use std::collections::BTreeMap;
use std::fmt::Display;
use std::ops::Range;

use glam::DVec3;
use wavrad_core::kernel::Quadrature;
use wavrad_core::render::settings::MAX_SAMPLES_PER_PIXEL;
use wavrad_core::scene::bounds::MAX_COORDINATE;
use wavrad_core::scene::brdf::microfacet::MIN_ALPHA;
use wavrad_core::scene::glass::Glass;
use wavrad_core::scene::{Camera, Projection, Rgb};
use wavrad_core::setting::Described;
use wavrad_core::solve::gather::{Interactions, Shares, Source};
use wavrad_core::solve::glossy_clusters::BINS;
use wavrad_core::solve::{Solution, SolveSettings};

use super::SolutionProblem;

/// The problem `problem` with `part` of a solution.
pub(super) fn inconsistent(part: impl Display, problem: impl Display) -> SolutionProblem {
    SolutionProblem::Inconsistent {
        part: part.to_string(),
        problem: problem.to_string(),
    }
}

/// Check that every part of `solution` fits the others, as the renderer
/// assumes: per surface, an emission that is a radiance (finite, not
/// negative: the renderer draws emitters by it), one element tree (a
/// well-formed one, over its surface) and one list per node of radiance,
/// exposure and reflection limit;
/// every transfer's receiver and source within the trees, the directional
/// structures and the cover lists; the directional structures' trees
/// well-formed, indexed by their surface pairs, with one radiance and
/// exposure per node; the cluster links as their ends arrange them; every
/// value finite; the settings valid, and the scene's sensor and sampler as
/// the loader accepts them. (The scene's bounds are checked before its ray queries
/// are built.)
pub(super) fn check_solution(solution: &Solution) -> Result<(), SolutionProblem> {
    let scene = &solution.scene;
    check_settings(&solution.settings).map_err(|e| inconsistent("the settings", e))?;
    if let Some(n) = (scene.hints.samples_per_pixel).filter(|&n| n > MAX_SAMPLES_PER_PIXEL) {
        return Err(inconsistent(
            "the scene",
            format!("a sampler of {n} samples per pixel (at most {MAX_SAMPLES_PER_PIXEL})"),
        ));
    }
    if let Some(camera) = &scene.camera {
        check_camera(camera).map_err(|e| inconsistent("the sensor", e))?;
    }
    for (g, glass) in scene.glass.iter().enumerate() {
        check_glass(glass).map_err(|e| inconsistent(format!("glass shape {g}"), e))?;
    }
    let interactions = &solution.interactions;
    let surfaces = scene.surfaces.len();
    let per_surface = [
        ("element trees", solution.trees.len()),
        ("radiance lists", solution.radiance.len()),
        ("exposure lists", interactions.exposure.len()),
        ("reflection limits", interactions.limit.len()),
        ("incoming transfer lists", interactions.incoming.len()),
        ("children lists", interactions.children.len()),
    ];
    if let Some((what, n)) = per_surface.iter().find(|(_, n)| *n != surfaces) {
        return Err(inconsistent(
            "the solution",
            format!("{n} {what} for {surfaces} surfaces"),
        ));
    }
    for (s, (tree, surface)) in solution.trees.iter().zip(&scene.surfaces).enumerate() {
        let part = || format!("surface {s}");
        if !surface
            .emission
            .0
            .iter()
            .all(|c| *c >= 0.0 && c.is_finite())
        {
            return Err(inconsistent(
                part(),
                format!("its emission {:?}", surface.emission),
            ));
        }
        tree.check(&surface.patch)
            .map_err(|e| inconsistent(part(), format!("its element tree: {e}")))?;
        let nodes = tree.nodes.len();
        check_values(&solution.radiance[s], nodes, |v| rgb_finite(*v))
            .map_err(|e| inconsistent(part(), format!("its radiance: {e}")))?;
        check_values(&interactions.exposure[s], nodes, |v| v.is_finite())
            .map_err(|e| inconsistent(part(), format!("its exposure: {e}")))?;
        check_values(&interactions.limit[s], nodes, |v| v.is_finite())
            .map_err(|e| inconsistent(part(), format!("its reflection limit: {e}")))?;
        let first_children = tree.nodes.iter().map(|n| n.first_child.unwrap_or(u32::MAX));
        if !first_children.eq(interactions.children[s].iter().copied()) {
            return Err(inconsistent(
                part(),
                "its children list is not its element tree's",
            ));
        }
        for (j, t) in interactions.incoming[s].iter().enumerate() {
            let part = || format!("surface {s}'s incoming transfer {j}");
            check_index(t.receiver, nodes).map_err(|e| inconsistent(part(), e))?;
            if !(t.form_factor.is_finite() && t.gradient.is_finite()) {
                return Err(inconsistent(part(), "a form factor that is not finite"));
            }
            check_source(solution, &t.source).map_err(|e| inconsistent(part(), e))?;
        }
    }
    check_directional(solution).map_err(|(part, e)| inconsistent(part, e))?;
    check_light_bins(interactions, surfaces).map_err(|e| inconsistent("the lights' bins", e))?;
    let tree_nodes = |s: usize| solution.trees[s].nodes.len();
    check_light_nodes(&interactions.lights, surfaces, tree_nodes)
        .map_err(|e| inconsistent("the lights' light per surface", e))?;
    let pair_nodes = |d: usize| interactions.directional[d].tree.nodes.len();
    let structures = interactions.directional.len();
    check_light_nodes(&interactions.light_pairs, structures, pair_nodes)
        .map_err(|e| inconsistent("the lights' light per directional structure", e))?;
    if let Some((p, r)) = (solution.pairs.iter()).find(|&&(p, r)| p.max(r) as usize >= surfaces) {
        return Err(inconsistent(
            "the solution",
            format!("the surface pair ({p}, {r}) of {surfaces} surfaces"),
        ));
    }
    if let Some(&(_, w)) = interactions.covers.iter().find(|(_, w)| !w.is_finite()) {
        return Err(inconsistent("the cover lists", format!("a weight of {w}")));
    }
    if let Some(&(_, w)) = interactions.bins.iter().find(|(_, w)| !w.is_finite()) {
        return Err(inconsistent("the bin lists", format!("a weight of {w}")));
    }
    (interactions.clusters)
        .check(scene, &solution.trees)
        .map_err(|e| inconsistent("the cluster links", e))
}

/// The largest quadrature order per axis a solution file may hold: solves
/// use 2 ([`Quadrature::default`]); rendering allocates the square of the
/// square of it per element point.
/// A glass shape as the loader makes one: a positive, finite index, tints
/// in [0, 1], a rough interface's isotropic roughness within the loader's
/// bounds, and faces within [`MAX_COORDINATE`].
fn check_glass(glass: &Glass) -> Result<(), String> {
    let interface = &glass.interface;
    if !(interface.eta > 0.0 && interface.eta.is_finite()) {
        return Err(format!("its index of refraction {}", interface.eta));
    }
    let unit = |v: Rgb| v.0.iter().all(|c| (0.0..=1.0).contains(c));
    if !(unit(interface.reflectance) && unit(interface.transmittance)) {
        return Err(format!(
            "its tints {} and {} (each in [0, 1])",
            interface.reflectance, interface.transmittance
        ));
    }
    if let Some(m) = interface.roughness {
        if interface.thin
            || m.alpha_u != m.alpha_v
            || !(m.alpha_u.is_finite() && m.alpha_u >= MIN_ALPHA)
        {
            return Err(format!(
                "its roughness {} × {} (isotropic, finite, at least {MIN_ALPHA:e}, on a solid's boundary)",
                m.alpha_u, m.alpha_v
            ));
        }
    }
    let within = |v: &DVec3| v.is_finite() && v.abs().max_element() <= MAX_COORDINATE;
    if let Some((centre, radius)) = glass.sphere {
        if !(within(&centre) && radius > 0.0 && radius <= MAX_COORDINATE) {
            return Err(format!("its sphere at {centre} of radius {radius}"));
        }
    }
    match (glass.faces.iter()).position(|(patch, _)| !patch.vertices().iter().all(within)) {
        Some(f) => Err(format!("face {f} is not within {MAX_COORDINATE:e}")),
        None => Ok(()),
    }
}

const MAX_QUADRATURE_ORDER: usize = 16;

/// Check `settings` as a solve's: every described setting within its range,
/// [`SolveSettings::validate`], and quadrature orders of at most
/// [`MAX_QUADRATURE_ORDER`].
pub(super) fn check_settings(settings: &SolveSettings) -> Result<(), String> {
    for (name, value) in settings.values() {
        SolveSettings::setting(name)
            .and_then(|s| s.check(value))
            .map_err(|e| e.to_string())?;
    }
    settings.validate().map_err(|e| e.to_string())?;
    let Quadrature { points, rays } = settings.quadrature;
    if points.max(rays) > MAX_QUADRATURE_ORDER {
        return Err(format!(
            "quadrature orders {points} and {rays} (at most {MAX_QUADRATURE_ORDER})"
        ));
    }
    Ok(())
}

/// Check `camera` as the loader checks a sensor (`mitsuba/sensors.rs`): an
/// invertible `to_world` with entries within the scene's coordinate bound
/// ([`MAX_COORDINATE`]), 0 < `near_clip` < `far_clip`, a field of view
/// between 0° and 180°. The renderer's camera rays must be finite.
fn check_camera(camera: &Camera) -> Result<(), String> {
    let m = &camera.world_from_camera;
    if !(m.is_finite() && m.to_cols_array().iter().all(|v| v.abs() <= MAX_COORDINATE))
        || m.determinant().abs() < 1e-300
    {
        return Err(format!(
            "to_world {m} is not an invertible transform within {MAX_COORDINATE:e}"
        ));
    }
    let (near, far) = (camera.near_clip, camera.far_clip);
    if !(near > 0.0 && far > near && far.is_finite()) {
        return Err(format!("near_clip {near} and far_clip {far}"));
    }
    match camera.projection {
        Projection::Perspective { fov_x_degrees, .. }
            if !(fov_x_degrees > 0.0 && fov_x_degrees < 180.0) =>
        {
            Err(format!("a field of view of {fov_x_degrees}°"))
        }
        _ => Ok(()),
    }
}

/// Check the directional structures of `solution`: each (p, q) within the
/// surfaces and the index of its structure, each tree well-formed, with a
/// radiance and an exposure per node and its incoming three-point
/// transfers within it. Errors name the part.
fn check_directional(solution: &Solution) -> Result<(), (String, String)> {
    let interactions = &solution.interactions;
    let structures = interactions.directional.len();
    let structure_of: BTreeMap<(u32, u32), u32> = (interactions.directional.iter())
        .enumerate()
        .map(|(i, d)| ((d.p, d.q), i as u32))
        .collect();
    if structure_of != interactions.structure_of {
        return Err((
            "the directional structures".into(),
            "they are not indexed by their surface pairs".into(),
        ));
    }
    let per_structure = [
        ("radiance lists", solution.directional.len()),
        ("exposure lists", interactions.pair_exposure.len()),
        (
            "incoming transfer lists",
            interactions.incoming_three_point.len(),
        ),
    ];
    if let Some((what, n)) = per_structure.iter().find(|(_, n)| *n != structures) {
        return Err((
            "the solution".into(),
            format!("{n} {what} for {structures} directional structures"),
        ));
    }
    let surfaces = solution.scene.surfaces.len();
    for (i, d) in interactions.directional.iter().enumerate() {
        let part = || format!("directional structure {i} ({}, {})", d.p, d.q);
        let fail = |e: String| (part(), e);
        if d.p.max(d.q) as usize >= surfaces {
            return Err(fail(format!("a surface out of range ({surfaces})")));
        }
        d.tree.check().map_err(|e| fail(format!("its tree: {e}")))?;
        let nodes = d.tree.nodes.len();
        check_values(&solution.directional[i], nodes, |v| rgb_finite(*v))
            .map_err(|e| fail(format!("its radiance: {e}")))?;
        check_values(&interactions.pair_exposure[i], nodes, |v| v.is_finite())
            .map_err(|e| fail(format!("its exposure: {e}")))?;
        for (j, t) in interactions.incoming_three_point[i].iter().enumerate() {
            let fail = |e: String| (format!("{}'s incoming transfer {j}", part()), e);
            check_covers(interactions, &t.receivers, nodes).map_err(fail)?;
            if !rgb_finite(t.coefficient) {
                return Err(fail("a coefficient that is not finite".into()));
            }
            check_source(solution, &t.source).map_err(fail)?;
        }
    }
    Ok(())
}

/// Check that `source` names a node of a surface's tree and, when glossy,
/// a directional structure and nodes of its tree.
fn check_source(solution: &Solution, source: &Source) -> Result<(), String> {
    let (surface, node) = source.element();
    let tree = (solution.trees.get(surface as usize))
        .ok_or_else(|| format!("source surface {surface} out of range"))?;
    check_index(node, tree.nodes.len()).map_err(|e| format!("source {e}"))?;
    if let Source::Glossy {
        structure, nodes, ..
    } = source
    {
        let interactions = &solution.interactions;
        let d = (interactions.directional.get(*structure as usize))
            .ok_or_else(|| format!("source structure {structure} out of range"))?;
        check_covers(interactions, nodes, d.tree.nodes.len()).map_err(|e| format!("source {e}"))?;
    }
    if let Source::Element { towards, .. } = source {
        let bins = (solution.interactions.bins)
            .get(towards.start as usize..towards.end as usize)
            .ok_or_else(|| format!("source bins {towards:?} out of range"))?;
        if let Some(&(b, _)) = bins.iter().find(|(b, _)| usize::from(*b) >= BINS) {
            return Err(format!("source bin {b} out of range"));
        }
    }
    let (Source::Element { shares, .. } | Source::Glossy { shares, .. }) = source;
    if *shares != Shares::NONE && tree.nodes[node as usize].first_child.is_none() {
        return Err(format!("source node {node} has shares but no children"));
    }
    Ok(())
}

/// Check lists of the lights' light, none or one per `noun` (`items` of
/// them): `problem(i, entry)` says what is wrong with an entry of item
/// i's list, if anything.
fn check_light_lists<T>(
    lists: &[Vec<T>],
    (items, noun): (usize, &str),
    problem: impl Fn(usize, &T) -> Option<String>,
) -> Result<(), String> {
    if !lists.is_empty() && lists.len() != items {
        return Err(format!("{} lists for {items} {noun}s", lists.len()));
    }
    for (i, list) in lists.iter().enumerate() {
        if let Some(p) = list.iter().find_map(|entry| problem(i, entry)) {
            return Err(format!("{noun} {i}'s {p}"));
        }
    }
    Ok(())
}

/// Check lists of the lights' light per node, one per item (`items` of
/// them): each node within item i's `nodes(i)`, each value finite.
fn check_light_nodes(
    lists: &[Vec<(u32, Rgb)>],
    items: usize,
    nodes: impl Fn(usize) -> usize,
) -> Result<(), String> {
    check_light_lists(lists, (items, "item"), |i, &(node, l)| {
        let n = nodes(i);
        (node as usize >= n || !rgb_finite(l)).then(|| format!("node {node} (of {n}) of {l:?}"))
    })
}

/// Check the lights' light per bin of the glossy surfaces: one list per
/// surface, each bin within a hemisphere's and finite.
fn check_light_bins(interactions: &Interactions, surfaces: usize) -> Result<(), String> {
    check_light_lists(
        &interactions.light_bins,
        (surfaces, "surface"),
        |_, &(b, e)| {
            (usize::from(b) >= BINS || !rgb_finite(e)).then(|| format!("bin {b} of {e:?}"))
        },
    )
}

/// Check that `range` lies within the cover lists, and each node in it
/// within a tree of `nodes` nodes.
fn check_covers(
    interactions: &Interactions,
    range: &Range<u32>,
    nodes: usize,
) -> Result<(), String> {
    let covers = (interactions.covers)
        .get(range.start as usize..range.end as usize)
        .ok_or_else(|| {
            format!(
                "covers {range:?} out of range ({})",
                interactions.covers.len()
            )
        })?;
    covers
        .iter()
        .try_for_each(|&(node, _)| check_index(node, nodes))
}

/// Check that `node` is one of `nodes`.
fn check_index(node: u32, nodes: usize) -> Result<(), String> {
    match (node as usize) < nodes {
        true => Ok(()),
        false => Err(format!("node {node} out of range ({nodes} nodes)")),
    }
}

/// Check that `values` has one value per node of `nodes`, each `ok`.
fn check_values<T: std::fmt::Debug>(
    values: &[T],
    nodes: usize,
    ok: impl Fn(&T) -> bool,
) -> Result<(), String> {
    if values.len() != nodes {
        return Err(format!("{} values for {nodes} nodes", values.len()));
    }
    match values.iter().position(|v| !ok(v)) {
        Some(node) => Err(format!("{:?} at node {node}", values[node])),
        None => Ok(()),
    }
}

fn rgb_finite(v: Rgb) -> bool {
    v.0.iter().all(|c| c.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use wavrad_core::scene::brdf::microfacet::{Microfacet, MicrofacetType};
    use wavrad_core::scene::glass::Dielectric;

    #[test]
    fn glass_is_checked_as_the_loader_makes_it() {
        let glass = |eta, thin, roughness| Glass {
            name: "glass".into(),
            interface: Dielectric {
                eta,
                thin,
                reflectance: Rgb::splat(1.0),
                transmittance: Rgb::splat(0.9),
                roughness,
            },
            faces: Vec::new(),
            sphere: Some((DVec3::ZERO, 1.0)),
        };
        let rough = |au, av| {
            Some(Microfacet {
                kind: MicrofacetType::Ggx,
                alpha_u: au,
                alpha_v: av,
            })
        };
        assert_eq!(check_glass(&glass(1.5, false, None)), Ok(()));
        assert_eq!(check_glass(&glass(1.5, true, None)), Ok(()));
        assert_eq!(check_glass(&glass(1.5, false, rough(0.3, 0.3))), Ok(()));
        for (case, bad) in [
            ("index", glass(-1.5, false, None)),
            ("rough pane", glass(1.5, true, rough(0.3, 0.3))),
            ("anisotropic", glass(1.5, false, rough(0.3, 0.1))),
            (
                "below Mitsuba's least roughness",
                glass(1.5, false, rough(0.0, 0.0)),
            ),
            ("not a number", glass(1.5, false, rough(f64::NAN, f64::NAN))),
        ] {
            assert!(check_glass(&bad).is_err(), "{case}");
        }
    }
}
