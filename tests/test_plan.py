"""A solve in steps (``wavrad.plan``): blocks of its kernel projection made
one by one and finished give ``wavrad.solve``'s solution bit for bit; blocks
that do not fit the plan are refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import wavrad

ROOT = Path(__file__).resolve().parent.parent
GLOSSY_BOX = ROOT / "scenes" / "glossy-cornell-box" / "scene.xml"
SETTINGS = {"threshold": 1e-2, "max_level": 3, "three_point_threshold": 1e-3}


@pytest.fixture(scope="module")
def scene() -> wavrad.Scene:
    return wavrad.load_scene(GLOSSY_BOX, res=16)


@pytest.fixture(scope="module")
def whole(scene: wavrad.Scene) -> wavrad.Solution:
    return wavrad.solve(scene, **SETTINGS)


def test_blocks_in_any_order_make_the_solve(scene: wavrad.Scene, whole: wavrad.Solution) -> None:
    plan = wavrad.plan(scene, **SETTINGS)
    blocks = plan.blocks(5)
    assert len(blocks) == 5
    assert blocks[0].start == 0 and blocks[-1].stop == len(plan)
    assert all(a.stop == b.start for a, b in zip(blocks, blocks[1:]))
    links = [plan.project(block) for block in reversed(blocks)]
    counts = [plan.links_in(block) for block in links]
    assert sum(two for two, _ in counts) > 0
    assert whole.stats["three_point_interactions"] > 0
    assert sum(three for _, three in counts) == whole.stats["three_point_interactions"]
    split = plan.finish(links)
    np.testing.assert_array_equal(split.radiance, whole.radiance)
    np.testing.assert_array_equal(split.directional, whole.directional)
    assert split.radiance.shape == (whole.stats["two_point_nodes"], 3)
    with pytest.raises(ValueError, match="finished"):
        plan.project(blocks[0])


def test_a_projector_elsewhere_projects_the_items(
    scene: wavrad.Scene, whole: wavrad.Solution
) -> None:
    plan = wavrad.plan(scene, **SETTINGS)
    worker = wavrad.projector(scene, **plan.settings)
    assert worker.fingerprint == plan.projector_fingerprint
    links = [worker.project(plan.items(block)) for block in plan.blocks(3)]
    split = plan.finish(links)
    np.testing.assert_array_equal(split.radiance, whole.radiance)
    np.testing.assert_array_equal(split.directional, whole.directional)


def test_a_projector_of_other_settings_refuses_the_items(scene: wavrad.Scene) -> None:
    plan = wavrad.plan(scene, **SETTINGS)
    worker = wavrad.projector(scene, **{**SETTINGS, "max_level": 2})
    assert worker.fingerprint != plan.projector_fingerprint
    with pytest.raises(wavrad.SceneError, match="another scene or other settings"):
        worker.project(plan.items(range(0, 1)))


def test_planning_again_with_its_settings_makes_the_same_plan(scene: wavrad.Scene) -> None:
    plan = wavrad.plan(scene, **SETTINGS)
    assert plan.settings["threshold"] == SETTINGS["threshold"]
    again = wavrad.plan(scene, **plan.settings)
    assert again.fingerprint == plan.fingerprint
    assert wavrad.plan(scene, max_level=2).fingerprint != plan.fingerprint
    assert repr(plan).startswith("Plan(element_pairs=")


def test_blocks_that_do_not_fit_the_plan_are_refused(scene: wavrad.Scene) -> None:
    plan = wavrad.plan(scene, **SETTINGS)
    blocks = plan.blocks(3)
    links = [plan.project(block) for block in blocks]
    with pytest.raises(wavrad.SolveError, match=f"no block holds items {blocks[1].start}"):
        plan.finish([links[0], links[2]])
    with pytest.raises(wavrad.SolveError, match="overlaps"):
        plan.finish([*links, links[1]])
    with pytest.raises(wavrad.SolveError, match="not a range"):
        plan.project(range(0, len(plan) + 1))
    with pytest.raises(ValueError, match="step 1"):
        plan.project(range(0, len(plan), 2))
    other = wavrad.plan(scene, max_level=2)
    with pytest.raises(wavrad.SceneError, match="another plan"):
        plan.finish([other.project(block) for block in other.blocks(1)])
    with pytest.raises(wavrad.SceneError, match="not a block"):
        plan.finish([b"links"])
    # Refusals leave the plan usable.
    plan.finish(links)


def test_a_limit_reached_while_planning_is_told(scene: wavrad.Scene) -> None:
    # Reached before the linking: it links the pairs left coarser and says
    # so; the plan's blocks are then projected whole, and finishing says
    # that the limit cut the solve short. The solution still has light.
    with pytest.warns(wavrad.SolveWarning, match="cut the linking short"):
        plan = wavrad.plan(scene, time_limit=1e-9, **SETTINGS)
    blocks = [plan.project(block) for block in plan.blocks(2)]
    with pytest.warns(wavrad.SolveWarning, match="the time limit cut the solve short"):
        cut = plan.finish(blocks)
    assert cut.stats["stopped"] == "time_limit"
    assert np.isfinite(cut.radiance).all() and cut.radiance.max() > 0
