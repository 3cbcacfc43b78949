"""The refinement oracles (``oracle=``) and solvers (``solver=``) of
``wavrad.solve`` on the bundled Cornell box, solved coarsely (32x32 film,
level 3) so the file runs in a few seconds."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import wavrad

SCENES = Path(__file__).resolve().parent.parent / "scenes"
CORNELL_BOX = SCENES / "cornell-box" / "scene.xml"
GLOSSY_CORNELL_BOX = SCENES / "glossy-cornell-box" / "scene.xml"
MAX_LEVEL = 3
# The weighted oracles' default threshold (SolveSettings::for_oracle).
WEIGHTED_THRESHOLD = 2e-4


@pytest.fixture(scope="module")
def scene() -> wavrad.Scene:
    return wavrad.load_scene(CORNELL_BOX, res=32)


@pytest.fixture(scope="module")
def kernel(scene: wavrad.Scene) -> wavrad.Solution:
    return wavrad.solve(scene, max_level=MAX_LEVEL)


@pytest.fixture(scope="module")
def power(scene: wavrad.Scene) -> wavrad.Solution:
    return wavrad.solve(scene, max_level=MAX_LEVEL, oracle="power")


# Oracles


def test_power_oracle_converges_with_fewer_links_than_the_kernel_oracle(
    kernel: wavrad.Solution, power: wavrad.Solution
) -> None:
    assert kernel.stats["settings"]["oracle"] == "kernel"
    assert power.stats["settings"]["oracle"] == "power"
    assert power.stats["converged"]
    assert 0 < power.stats["two_point_interactions"] < kernel.stats["two_point_interactions"]


def test_power_oracle_gives_the_kernel_oracles_image(
    kernel: wavrad.Solution, power: wavrad.Solution
) -> None:
    a, b = kernel.render("gather", spp=4), power.render("gather", spp=4)
    assert abs(b.mean() / a.mean() - 1.0) < 0.02


def test_weighted_oracles_have_their_own_default_threshold(
    kernel: wavrad.Solution, power: wavrad.Solution
) -> None:
    assert kernel.stats["settings"]["threshold"] == 1e-3
    assert power.stats["settings"]["threshold"] == WEIGHTED_THRESHOLD
    assert power.stats["settings"]["three_point_threshold"] == WEIGHTED_THRESHOLD


def test_threshold_and_refine_passes_override_the_oracles_defaults(
    scene: wavrad.Scene,
) -> None:
    solution = wavrad.solve(
        scene, max_level=MAX_LEVEL, oracle="power", threshold=1e-3, refine_passes=1
    )
    assert solution.stats["settings"]["threshold"] == 1e-3
    assert solution.stats["projections"] == 1


def test_zero_refine_passes_is_a_solve_error(scene: wavrad.Scene) -> None:
    with pytest.raises(wavrad.SolveError, match="refine_passes"):
        wavrad.solve(scene, oracle="power", refine_passes=0)


def test_unknown_oracle_is_a_solve_error_naming_the_choices(scene: wavrad.Scene) -> None:
    message = 'oracle: "nope" is not one of: kernel, power, importance'
    with pytest.raises(wavrad.SolveError, match=re.escape(message)):
        wavrad.solve(scene, oracle="nope")  # type: ignore[arg-type]


def test_importance_oracle_without_a_sensor_is_a_solve_error(tmp_path: Path) -> None:
    path = tmp_path / "scene.xml"
    path.write_text(
        '<scene version="3.0.0">\n  <shape type="cube">'
        '<emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>\n</scene>\n'
    )
    scene = wavrad.load_scene(path)
    with pytest.raises(wavrad.SolveError, match="needs a sensor"):
        wavrad.solve(scene, oracle="importance")


# Solvers


def test_shooting_matches_gathering_on_a_diffuse_scene(
    scene: wavrad.Scene, kernel: wavrad.Solution
) -> None:
    shot = wavrad.solve(scene, max_level=MAX_LEVEL, solver="shoot")
    assert kernel.stats["solver"] == "gather"
    assert kernel.stats["shooting_steps"] == 0
    assert shot.stats["solver"] == "shoot"
    assert shot.stats["shooting_steps"] > 0
    assert shot.stats["converged"]
    a, b = kernel.render("gather", spp=4), shot.render("gather", spp=4)
    assert abs(b.mean() / a.mean() - 1.0) < 0.02


def test_shooting_with_the_power_oracle(scene: wavrad.Scene, power: wavrad.Solution) -> None:
    shot = wavrad.solve(scene, max_level=MAX_LEVEL, oracle="power", solver="shoot")
    assert (shot.stats["solver"], shot.stats["settings"]["oracle"]) == ("shoot", "power")
    assert shot.stats["kernel_pairs"] <= shot.stats["exchanging_pairs"]
    a, b = power.render("gather", spp=4), shot.render("gather", spp=4)
    assert abs(b.mean() / a.mean() - 1.0) < 0.02


def test_shooting_a_glossy_scene_is_a_solve_error() -> None:
    scene = wavrad.load_scene(GLOSSY_CORNELL_BOX, res=16)
    with pytest.raises(wavrad.SolveError, match="glossy"):
        wavrad.solve(scene, solver="shoot")


def test_shooting_with_the_importance_oracle_is_a_solve_error(scene: wavrad.Scene) -> None:
    with pytest.raises(wavrad.SolveError, match="kernel and power oracles"):
        wavrad.solve(scene, oracle="importance", solver="shoot")


def test_unknown_solver_is_a_solve_error_naming_the_choices(scene: wavrad.Scene) -> None:
    message = 'unknown solver "nope" (expected one of: gather, shoot)'
    with pytest.raises(wavrad.SolveError, match=re.escape(message)):
        wavrad.solve(scene, solver="nope")  # type: ignore[arg-type]


def test_every_setting_given_is_the_one_the_stats_report(scene: wavrad.Scene) -> None:
    given = {
        "oracle": "power",
        "threshold": 5e-4,
        "max_level": 2,
        "three_point_threshold": 3e-4,
        "three_point_max_level": 1,
        "three_point_receiver_levels": 1,
        "cluster_ratio": 0.2,
        "refine_passes": 2,
        "tolerance": 1e-4,
        "max_iterations": 50,
        "time_limit": 3600.0,
        "max_memory": 64.0,
    }
    with warnings.catch_warnings():
        # A limit that is not reached tells nothing.
        warnings.simplefilter("error", wavrad.SolveWarning)
        solution = wavrad.solve(scene, **given)  # type: ignore[arg-type]
    assert solution.stats["settings"] == given
    assert solution.stats["projections"] in range(1, given["refine_passes"] + 1)
    assert (solution.stats["stopped"], solution.stats["unrefined_items"]) == (None, 0)


def test_a_time_limit_finishes_the_solve_from_what_was_done(scene: wavrad.Scene) -> None:
    full = wavrad.solve(scene, max_level=MAX_LEVEL)
    with pytest.warns(wavrad.SolveWarning) as told:
        cut = wavrad.solve(scene, max_level=MAX_LEVEL, time_limit=1e-9)
    # Told where the solve was called, as a UserWarning: once that the
    # limit cut the solve short (with what it left unrefined), once that it
    # coarsened the linking, which it reached first.
    messages = [str(w.message) for w in told]
    assert all(w.filename == __file__ for w in told), [w.filename for w in told]
    assert issubclass(wavrad.SolveWarning, UserWarning)
    short = [m for m in messages if "the time limit cut the solve short" in m]
    assert len(short) == 1 and str(cut.stats["unrefined_items"]) in short[0], messages
    assert len([m for m in messages if "the time limit cut the linking short" in m]) == 1
    assert cut.stats["stopped"] == "time_limit"
    assert cut.stats["unrefined_items"] > 0
    assert cut.stats["two_point_interactions"] < full.stats["two_point_interactions"]
    image = cut.render("direct", 1)
    assert np.isfinite(image).all() and image.max() > 0


def test_a_solve_out_of_sweeps_warns_that_it_did_not_converge(scene: wavrad.Scene) -> None:
    with pytest.warns(wavrad.SolveWarning, match="not converged: the residual is") as told:
        solution = wavrad.solve(scene, max_level=MAX_LEVEL, max_iterations=1)
    assert all(w.filename == __file__ for w in told), [w.filename for w in told]
    assert solution.stats["converged"] is False and solution.stats["iterations"] == 1
    assert solution.stats["residual"] > solution.stats["settings"]["tolerance"]
    with warnings.catch_warnings():
        warnings.simplefilter("error", wavrad.SolveWarning)
        assert wavrad.solve(scene, max_level=MAX_LEVEL).stats["converged"] is True


def test_render_settings_are_taken_by_name(kernel: wavrad.Solution) -> None:
    a = kernel.render("gather", 4, gather_spp=1)
    b = kernel.render(mode="gather", spp=4, gather_spp=1)
    assert (a == b).all()
    with pytest.raises(wavrad.SolveError, match="gather_spp: must be in 1..="):
        kernel.render("gather", 4, gather_spp=0)


def test_a_seed_changes_the_noise_and_nothing_else(kernel: wavrad.Solution) -> None:
    a, b = (kernel.render("gather", 4, gather_spp=1, seed=s) for s in (0, 9))
    assert (a == kernel.render("gather", 4, gather_spp=1)).all()
    assert not (a == b).all()
    assert abs(a.mean() - b.mean()) < 0.05 * a.mean()


def test_unknown_setting_is_a_type_error(scene: wavrad.Scene) -> None:
    with pytest.raises(TypeError, match="colour"):
        wavrad.solve(scene, colour=1)  # type: ignore[call-arg]


def test_settings_of_the_wrong_kind_name_the_setting(scene: wavrad.Scene) -> None:
    with pytest.raises(ValueError, match="max_level: expected a whole number"):
        wavrad.solve(scene, max_level=2.5)  # type: ignore[arg-type]
    with pytest.raises(wavrad.SolveError, match="max_level: must be in 0..=16"):
        wavrad.solve(scene, max_level=17)


# Progressive shooting: a callback after every step


def test_on_step_sees_every_step_with_a_preview_image(scene: wavrad.Scene) -> None:
    steps: list[dict] = []
    means: list[float] = []

    def on_step(step: dict, image) -> None:
        steps.append(step)
        assert image.shape == (32, 32, 3)
        means.append(float(image.mean()))

    shot = wavrad.solve(scene, max_level=MAX_LEVEL, solver="shoot", on_step=on_step)
    assert [s["index"] for s in steps] == list(range(1, len(steps) + 1))
    assert len(steps) == shot.stats["shooting_steps"]
    assert set(steps[0]) == {"index", "shooter", "unshot_fraction", "kernel_pairs", "links"}
    # Light only accumulates: the unshot power falls, the image brightens.
    unshot = [s["unshot_fraction"] for s in steps]
    assert unshot[-1] < unshot[0]
    assert means[-1] > means[0] > 0.0


def test_on_step_returning_false_stops_shooting(scene: wavrad.Scene) -> None:
    seen: list[int] = []

    def on_step(step: dict, image) -> bool:
        seen.append(step["index"])
        return step["index"] < 3

    shot = wavrad.solve(scene, max_level=MAX_LEVEL, solver="shoot", on_step=on_step)
    assert seen == [1, 2, 3]
    assert shot.stats["shooting_steps"] == 3


def test_an_exception_in_on_step_is_raised_from_solve(scene: wavrad.Scene) -> None:
    def on_step(step: dict, image) -> None:
        raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        wavrad.solve(scene, max_level=MAX_LEVEL, solver="shoot", on_step=on_step)


def test_on_step_needs_the_shooting_solver(scene: wavrad.Scene) -> None:
    with pytest.raises(ValueError, match='solver="shoot"'):
        wavrad.solve(scene, max_level=MAX_LEVEL, on_step=lambda step, image: None)
