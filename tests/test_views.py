"""Rendering other views from one solution: ``Solution.render(origin=...,
target=..., up=..., fov=...)`` on the Cornell box, solved coarsely (24x24
film, threshold 1e-2, level 3) and rendered with few rays so the file runs in
seconds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import wavrad

SCENES = Path(__file__).resolve().parent.parent / "scenes"
# The scene's own sensor: <lookat origin="0, 0, 3.9" target="0, 0, 0" up="0, 1, 0"/>,
# fov 39.3077 along the "smaller" axis (x on a square film).
ORIGIN, TARGET, UP, FOV = (0.0, 0.0, 3.9), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 39.3077
SPP = 16


@pytest.fixture(scope="module")
def solution() -> wavrad.Solution:
    scene = wavrad.load_scene(SCENES / "cornell-box" / "scene.xml", res=24)
    return wavrad.solve(scene, threshold=1e-2, max_level=3)


@pytest.mark.parametrize("mode", ["gather", "smooth"])
def test_the_scenes_own_view_reproduces_the_default_render(
    solution: wavrad.Solution, mode: str
) -> None:
    default = solution.render(mode, SPP)
    same = solution.render(mode, SPP, origin=ORIGIN, target=TARGET, up=UP, fov=FOV)
    np.testing.assert_array_equal(same, default)
    # Lists, tuples and numpy arrays are all points.
    as_arrays = solution.render(mode, SPP, origin=np.array(ORIGIN), target=list(TARGET))
    np.testing.assert_array_equal(as_arrays, default)


def test_unset_keywords_keep_the_scenes_camera(solution: wavrad.Solution) -> None:
    default = solution.render("smooth", SPP)
    # Moving along the view axis towards the target keeps the view direction.
    closer = solution.render("smooth", SPP, origin=(0.0, 0.0, 3.0))
    np.testing.assert_array_equal(
        closer, solution.render("smooth", SPP, origin=(0.0, 0.0, 3.0), target=TARGET, up=UP)
    )
    assert not np.array_equal(closer, default)


def test_other_views_differ_and_stay_plausible(solution: wavrad.Solution) -> None:
    default = solution.render("smooth", SPP)
    views = {
        "orbit": solution.render("smooth", SPP, origin=(1.2, 0.3, 3.6), target=(0.0, 0.0, 0.0)),
        "tilt": solution.render("smooth", SPP, up=(0.3, 1.0, 0.0)),
        "zoom": solution.render("smooth", SPP, fov=20.0),
    }
    for name, image in views.items():
        assert image.shape == default.shape == (24, 24, 3), name
        assert image.dtype == np.float32, name
        assert np.isfinite(image).all() and (image >= 0).all(), name
        assert wavrad.relative_rmse(image, default) > 0.05, name
    # A narrower field of view sees only the lit inside of the box.
    assert views["zoom"].mean(axis=2).min() > 0.0


def test_a_view_from_behind_the_wall_sees_its_back(solution: wavrad.Solution) -> None:
    # The back wall is one-sided (Mitsuba's diffuse): from behind it is black.
    image = solution.render("smooth", SPP, origin=(0.0, 0.0, -3.0), target=(0.0, 0.0, -1.0))
    assert image.max() == 0.0


@pytest.mark.parametrize(
    ("keywords", "message"),
    [
        ({"origin": (0.0, 0.0, 0.0), "target": (0.0, 0.0, 0.0)}, "degenerate look_at"),
        ({"up": (0.0, 0.0, 1.0)}, "degenerate look_at"),
        ({"up": (0.0, 0.0, 0.0)}, "degenerate look_at"),
        ({"origin": (1.0, 2.0)}, "origin needs three finite numbers"),
        ({"target": (0.0, float("nan"), 0.0)}, "target needs three finite numbers"),
        ({"fov": 0.0}, r"fov = 0 is outside \(0, 180\)"),
        ({"fov": 180.0}, r"fov = 180 is outside \(0, 180\)"),
        ({"fov": -10.0}, "outside"),
        ({"fov": float("nan")}, "outside"),
    ],
)
def test_bad_views_raise_value_error(
    solution: wavrad.Solution, keywords: dict[str, object], message: str
) -> None:
    with pytest.raises(ValueError, match=message):
        solution.render("haar", 1, **keywords)  # type: ignore[arg-type]


def test_view_keywords_are_keyword_only(solution: wavrad.Solution) -> None:
    with pytest.raises(TypeError):
        solution.render("haar", 1, ORIGIN)  # type: ignore[misc]


def test_a_gather_cache_serves_every_view_alike(solution: wavrad.Solution) -> None:
    # The cached gather is view-independent: a view renders the same
    # before and after another view used the cache, and it shows about
    # what gathering per camera ray shows.
    here = {"origin": (0.3, 0.2, 3.0), "target": (0.0, 0.0, -1.0)}
    first = solution.render("gather", SPP, gather_cache=True, **here)
    solution.render("gather", SPP, gather_cache=True, origin=(-0.4, 0.0, 2.5))
    again = solution.render("gather", SPP, gather_cache=True, **here)
    np.testing.assert_array_equal(again, first)
    per_ray = solution.render("gather", SPP, gather_cache=False, **here)
    assert wavrad.relative_rmse(first, per_ray) < 0.05


def sensor_xml(origin: str, fov: float, width: int, height: int) -> str:
    """A perspective sensor at ``origin`` looking at the origin."""
    return f"""<sensor type="perspective">
        <float name="fov" value="{fov}"/>
        <transform name="to_world">
            <lookat origin="{origin}" target="0,0,0" up="0,1,0"/>
        </transform>
        <film type="hdrfilm">
            <integer name="width" value="{width}"/><integer name="height" value="{height}"/>
        </film>
    </sensor>"""


TWO_SENSORS = f"""<scene version="3.0.0">
    {sensor_xml("0,0,3", 60, 8, 6)}
    {sensor_xml("0,2,3", 40, 5, 4)}
    <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/><translate y="-1" z="1"/></transform>
    </shape>
</scene>
"""


def test_each_sensor_renders_with_its_own_film(tmp_path: Path) -> None:
    path = tmp_path / "two-sensors.xml"
    path.write_text(TWO_SENSORS)
    scene = wavrad.load_scene(path)
    assert scene.sensor_count == 2
    solution = wavrad.solve(scene, max_level=2, progress=False)
    first = solution.render("smooth", 4)
    assert first.shape == (6, 8, 3)
    np.testing.assert_array_equal(solution.render("smooth", 4, sensor=0), first)
    second = solution.render("smooth", 4, sensor=1)
    assert second.shape == (4, 5, 3) and second.max() > 0
    with pytest.raises(wavrad.SolveError, match="sensor 2: the scene has 2 sensors"):
        solution.render("smooth", 4, sensor=2)
