"""The Python API on the bundled Cornell box, solved coarsely (32x32 film,
threshold 1e-2, level 3) so the whole file runs in a few seconds."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Literal, Optional

import numpy as np
import pytest

import wavrad

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scenes"
CORNELL_BOX = SCENES / "cornell-box" / "scene.xml"
CORNELL_BOX_REFERENCE = SCENES / "cornell-box" / "reference.exr"
THRESHOLD, MAX_LEVEL = 1e-2, 3

Mode = Optional[Literal["gather", "direct", "smooth", "haar"]]


@pytest.fixture(scope="module")
def scene() -> wavrad.Scene:
    return wavrad.load_scene(CORNELL_BOX, res=32)


@pytest.fixture(scope="module")
def solution(scene: wavrad.Scene) -> wavrad.Solution:
    return wavrad.solve(scene, threshold=THRESHOLD, max_level=MAX_LEVEL)


@pytest.fixture(scope="module")
def reference() -> np.ndarray:
    return wavrad.read_exr(CORNELL_BOX_REFERENCE)


def write_scene(tmp_path: Path, xml: str) -> Path:
    path = tmp_path / "scene.xml"
    path.write_text(xml)
    return path


# Scenes


def test_load_scene_applies_defines(scene: wavrad.Scene) -> None:
    assert (scene.width, scene.height) == (32, 32)
    # Five walls, the light, two boxes of six faces.
    assert scene.surface_count == 18
    assert repr(scene) == "Scene(surfaces=18, film=32x32)"


def test_load_scene_defines_are_converted_with_str() -> None:
    scene = wavrad.load_scene(str(CORNELL_BOX), res="24")
    assert (scene.width, scene.height) == (24, 24)


def test_missing_scene_names_its_path(tmp_path: Path) -> None:
    path = tmp_path / "missing.xml"
    with pytest.raises(wavrad.SceneError, match=re.escape(str(path))):
        wavrad.load_scene(path)


def test_malformed_xml_names_file_and_line(tmp_path: Path) -> None:
    path = write_scene(tmp_path, '<scene version="3.0.0">\n  <shape type="rectangle">\n</scene>\n')
    with pytest.raises(wavrad.SceneError, match=re.escape(f"{path}:3:")):
        wavrad.load_scene(path)


def test_unsupported_plugin_names_file_and_line(tmp_path: Path) -> None:
    path = write_scene(
        tmp_path, '<scene version="3.0.0">\n\n  <shape type="bsplinecurve"/>\n</scene>\n'
    )
    message = f'{path}:3: unsupported shape plugin "bsplinecurve"'
    with pytest.raises(wavrad.SceneError, match=re.escape(message)):
        wavrad.load_scene(path)


def test_loader_warnings_are_user_warnings(tmp_path: Path) -> None:
    # A quad and one triangle of zero area, which is skipped and counted.
    obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nf 1 2 3 4\nf 1 2 5\n"
    (tmp_path / "mesh.obj").write_text(obj)
    path = write_scene(
        tmp_path,
        '<scene version="3.0.0">\n  <shape type="obj">\n'
        '    <string name="filename" value="mesh.obj"/>\n  </shape>\n</scene>\n',
    )
    message = f'{path}:3: shape "obj": skipped 1 of the 3 triangles'
    with pytest.warns(UserWarning, match=re.escape(message)):
        scene = wavrad.load_scene(path)
    assert scene.surface_count == 2


def test_exceptions_form_one_tree() -> None:
    assert issubclass(wavrad.SceneError, wavrad.WavradError)
    assert issubclass(wavrad.SolveError, wavrad.WavradError)
    assert issubclass(wavrad.WavradError, Exception)
    assert not issubclass(wavrad.SceneError, wavrad.SolveError)


# Solving


def test_stats_report_the_solve(solution: wavrad.Solution) -> None:
    stats = solution.stats
    for key in [
        "two_point_nodes",
        "two_point_interactions",
        "iterations",
        "residual",
        "times",
        "peak_memory_bytes",
        "nodes_per_level",
    ]:
        assert key in stats
    assert stats["two_point_nodes"] > 0
    assert stats["two_point_interactions"] > 0
    assert stats["iterations"] > 0
    assert sum(stats["nodes_per_level"]) == stats["two_point_nodes"]
    assert len(stats["nodes_per_level"]) <= MAX_LEVEL + 1
    assert stats["settings"]["threshold"] == THRESHOLD
    assert stats["times"]["kernels_s"] >= 0.0


def test_negative_threshold_is_a_solve_error(scene: wavrad.Scene) -> None:
    with pytest.raises(wavrad.SolveError, match="threshold"):
        wavrad.solve(scene, threshold=-1.0)


def test_empty_scene_is_a_solve_error(tmp_path: Path) -> None:
    scene = wavrad.load_scene(write_scene(tmp_path, '<scene version="3.0.0">\n</scene>\n'))
    with pytest.raises(wavrad.SolveError, match="no surfaces"):
        wavrad.solve(scene)


# Rendering


@pytest.mark.parametrize("mode", ["gather", "direct", "smooth", "haar", None])
def test_render_is_a_finite_positive_image(solution: wavrad.Solution, mode: Mode) -> None:
    image = solution.render(mode, spp=4)
    assert image.shape == (32, 32, 3)
    assert image.dtype == np.float32
    assert np.isfinite(image).all()
    assert image.min() >= 0.0
    assert image.mean() > 0.0


def test_render_is_deterministic(solution: wavrad.Solution) -> None:
    np.testing.assert_array_equal(solution.render("gather", 4), solution.render("gather", 4))


def test_haar_and_smooth_differ_but_carry_the_same_light(solution: wavrad.Solution) -> None:
    haar = solution.render("haar", spp=4)
    smooth = solution.render("smooth", spp=4)
    assert not np.array_equal(haar, smooth)
    assert abs(haar.mean() - smooth.mean()) < 0.02 * smooth.mean()


def test_coarse_solution_matches_the_reference_brightness(
    solution: wavrad.Solution, reference: np.ndarray
) -> None:
    image = solution.render("gather", spp=4)
    assert abs(image.mean() - reference.mean()) < 0.1 * reference.mean()


def test_unknown_mode_is_a_solve_error_naming_the_modes(solution: wavrad.Solution) -> None:
    with pytest.raises(wavrad.SolveError, match='mode: "phong" is not one of: gather, direct'):
        solution.render("phong")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("mode", "options", "unused"),
    [
        ("haar", {"gather_cache": False}, "gather_cache off"),
        ("direct", {"gather_cache": False}, "gather_cache off"),
        ("gather", {"eye": False}, "without the eye"),
        (None, {"eye": False}, "without the eye"),
    ],
)
def test_an_option_the_mode_has_no_use_for_is_a_solve_error(
    solution: wavrad.Solution, mode: str | None, options: dict[str, bool], unused: str
) -> None:
    with pytest.raises(wavrad.SolveError, match=unused):
        solution.render(mode, 1, **options)  # type: ignore[arg-type]


def test_render_without_sensor_is_a_solve_error(tmp_path: Path) -> None:
    # A glowing cube: a scene with light, solved, but nothing to render from.
    xml = (
        '<scene version="3.0.0">\n  <shape type="cube">'
        '<emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>\n</scene>\n'
    )
    scene = wavrad.load_scene(write_scene(tmp_path, xml))
    solution = wavrad.solve(scene, threshold=THRESHOLD, max_level=MAX_LEVEL)
    with pytest.raises(wavrad.SolveError, match="no sensor"):
        solution.render()


# Images


def test_read_exr_reads_the_reference(reference: np.ndarray) -> None:
    assert reference.shape == (128, 128, 3)
    assert reference.dtype == np.float32
    assert np.isfinite(reference).all()
    assert reference.mean() > 0.0


def test_relative_rmse_of_an_image_with_itself_is_zero(reference: np.ndarray) -> None:
    assert wavrad.relative_rmse(reference, reference) == 0.0
    assert wavrad.relative_rmse(reference, 2.0 * reference) > 0.0


def test_relative_rmse_accepts_float64_and_rejects_other_shapes() -> None:
    a = np.ones((4, 4, 3))
    assert wavrad.relative_rmse(a, a) == 0.0
    assert wavrad.relative_rmse(2.0 * a, a) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="shape"):
        wavrad.relative_rmse(a, np.ones((4, 3, 3)))


def test_exr_round_trips_losslessly(tmp_path: Path, solution: wavrad.Solution) -> None:
    image = solution.render("haar", spp=1)
    path = tmp_path / "image.exr"
    wavrad.write_image(path, image)
    np.testing.assert_array_equal(wavrad.read_exr(path), image)


def test_write_png(tmp_path: Path, solution: wavrad.Solution) -> None:
    path = tmp_path / "image.png"
    wavrad.write_image(path, solution.render("haar", spp=1))
    assert path.read_bytes().startswith(b"\x89PNG")


def test_write_image_rejects_non_rgb_arrays(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="shape"):
        wavrad.write_image(tmp_path / "image.exr", np.zeros((4, 4, 4), dtype=np.float32))


def test_unknown_image_extension_is_a_scene_error(tmp_path: Path) -> None:
    path = tmp_path / "image.bmp"
    with pytest.raises(wavrad.SceneError, match="image.bmp"):
        wavrad.write_image(path, np.zeros((2, 2, 3), dtype=np.float32))


def test_read_exr_of_a_missing_file_names_it(tmp_path: Path) -> None:
    path = tmp_path / "missing.exr"
    with pytest.raises(wavrad.SceneError, match="missing.exr"):
        wavrad.read_exr(path)


# End to end


@pytest.mark.slow
def test_default_settings_match_the_path_traced_reference(reference: np.ndarray) -> None:
    solution = wavrad.solve(wavrad.load_scene(CORNELL_BOX))
    image = solution.render()
    assert image.shape == reference.shape
    assert wavrad.relative_rmse(image, reference) < 0.03


def test_version_is_the_cargo_workspace_version() -> None:
    cargo = (ROOT / "Cargo.toml").read_text()
    workspace = cargo[cargo.index("[workspace.package]") :]
    version = re.search(r'^version = "([^"]+)"', workspace, re.M)
    assert version is not None
    assert wavrad.__version__ == version.group(1)
