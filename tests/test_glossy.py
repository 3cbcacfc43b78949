"""The Python API on glossy scenes: the glossy Cornell box solved coarsely
(16x16 film, three-point threshold 1e-3, level 2) so the file runs in
seconds, and the paper's Figure 3 scene."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import wavrad

SCENES = Path(__file__).resolve().parent.parent / "scenes"


@pytest.fixture(scope="module")
def glossy() -> wavrad.Solution:
    scene = wavrad.load_scene(SCENES / "glossy-cornell-box" / "scene.xml", res=16)
    return wavrad.solve(
        scene,
        threshold=1e-2,
        max_level=3,
        three_point_threshold=1e-3,
        three_point_max_level=2,
    )


def test_glossy_stats_count_three_point_nodes_and_interactions(glossy: wavrad.Solution) -> None:
    stats = glossy.stats
    assert stats["three_point_nodes"] > 0
    assert stats["three_point_interactions"] > stats["three_point_nodes"] / 10
    assert sum(stats["three_point_nodes_per_level"]) == stats["three_point_nodes"]
    # A pair's two levels are each at most the three-point maximum level.
    assert len(stats["three_point_nodes_per_level"]) <= 2 * 2 + 1
    assert stats["settings"]["three_point_max_level"] == 2
    assert stats["settings"]["three_point_threshold"] == 1e-3
    assert stats["converged"]


def test_three_point_receivers_refine_below_the_three_point_level_for_sharp_lobes(
    glossy: wavrad.Solution,
) -> None:
    """Receivers split past three_point_max_level only where a sharp lobe's
    highlight needs it: Figure 3's rolled aluminium, not the glossy Cornell
    box's broad Ward lobes."""
    figure3 = wavrad.load_scene(SCENES / "figure3" / "specular.xml", res=16)

    def per_level(scene: wavrad.Scene, levels: int, **settings: float) -> list[int]:
        stats = wavrad.solve(scene, three_point_max_level=2,
                             three_point_receiver_levels=levels, **settings).stats
        assert stats["settings"]["three_point_receiver_levels"] == levels
        return stats["three_point_nodes_per_level"]

    # Pairs whose receiver lies below level 2, and none below level 4.
    sharp, flat = per_level(figure3, 2), per_level(figure3, 0)
    assert len(flat) <= 2 + 2 + 1 < len(sharp) <= 2 + 4 + 1
    box = wavrad.load_scene(SCENES / "glossy-cornell-box" / "scene.xml", res=16)
    broad = per_level(box, 2, threshold=1e-2, max_level=3, three_point_threshold=1e-3)
    assert broad == glossy.stats["three_point_nodes_per_level"]


@pytest.mark.parametrize("mode", ["gather", "direct", "smooth", "haar"])
def test_glossy_render_modes_give_finite_positive_images(
    glossy: wavrad.Solution, mode: str
) -> None:
    image = glossy.render(mode, spp=4)
    assert image.shape == (16, 16, 3)
    assert np.isfinite(image).all()
    assert image.min() >= 0.0
    assert image.mean() > 0.0


def test_direct_and_gather_agree_on_the_glossy_box(glossy: wavrad.Solution) -> None:
    # Two independent readings of the same solution: the eye receiver's
    # directional radiance and the final gather through the BRDF.
    direct = glossy.render("direct", spp=16)
    gather = glossy.render("gather", spp=16)
    assert abs(direct.mean() / gather.mean() - 1.0) < 0.05


def test_the_view_independent_lookup_agrees_with_the_eye(glossy: wavrad.Solution) -> None:
    # eye=False reads glossy surfaces from the solution's receivers (the
    # surfaces beyond the eye, or the enclosure) instead of a per-view eye.
    eye = glossy.render("direct", spp=16)
    lookup = glossy.render("direct", spp=16, eye=False)
    assert np.isfinite(lookup).all() and lookup.min() >= 0.0
    assert abs(lookup.mean() / eye.mean() - 1.0) < 0.05
    # A view from outside the box's open side, where glossy directions
    # leave the scene past the camera, reads the enclosure.
    moved = glossy.render("direct", spp=4, origin=[0.3, 0.2, 4.5], eye=False)
    assert moved.mean() > 0.0


def test_negative_three_point_threshold_is_a_solve_error() -> None:
    scene = wavrad.load_scene(SCENES / "figure3" / "specular.xml", res=8)
    with pytest.raises(wavrad.SolveError, match="three_point_threshold"):
        wavrad.solve(scene, three_point_threshold=-1.0)
