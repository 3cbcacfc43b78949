"""Solution files from Python: ``Solution.save`` and ``wavrad.load_solution``
on the Cornell box (24x24 film, coarse solve so the file runs in seconds),
in this process and in a fresh one."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import wavrad

SCENES = Path(__file__).resolve().parent.parent / "scenes"
SPP = 16


@pytest.fixture()
def scene_file(tmp_path: Path) -> Path:
    """A copy of the Cornell box that a test may edit."""
    path = tmp_path / "scene.xml"
    shutil.copy(SCENES / "cornell-box" / "scene.xml", path)
    return path


def solved(scene_file: Path) -> wavrad.Solution:
    scene = wavrad.load_scene(scene_file, res=24)
    return wavrad.solve(scene, threshold=1e-2, max_level=3, progress=False)


def test_a_saved_solution_renders_the_same_images(scene_file: Path, tmp_path: Path) -> None:
    solution = solved(scene_file)
    saved = tmp_path / "cornell.wavrad"
    solution.save(saved)
    read = wavrad.load_solution(saved)
    for mode in ("gather", "smooth"):
        np.testing.assert_array_equal(read.render(mode, SPP), solution.render(mode, SPP))
    np.testing.assert_array_equal(read.radiance, solution.radiance)
    assert read.stats["two_point_interactions"] == solution.stats["two_point_interactions"]
    # And in another process, which never solved.
    script = (
        "import sys, numpy as np, wavrad\n"
        "np.save(sys.argv[2], wavrad.load_solution(sys.argv[1]).render('smooth', 16))\n"
    )
    other = tmp_path / "other.npy"
    subprocess.run([sys.executable, "-c", script, str(saved), str(other)], check=True)
    np.testing.assert_array_equal(np.load(other), solution.render("smooth", SPP))


def test_a_changed_or_damaged_file_is_a_scene_error(scene_file: Path, tmp_path: Path) -> None:
    saved = tmp_path / "cornell.wavrad"
    solved(scene_file).save(saved)
    data = saved.read_bytes()

    damaged = tmp_path / "damaged.wavrad"
    damaged.write_bytes(data[: len(data) // 2])
    with pytest.raises(wavrad.SceneError, match="damaged.wavrad.*truncated"):
        wavrad.load_solution(damaged)

    flipped = bytearray(data)
    flipped[len(data) // 2] ^= 0x10
    damaged.write_bytes(bytes(flipped))
    with pytest.raises(wavrad.SceneError, match="damaged.wavrad.*checksum"):
        wavrad.load_solution(damaged)

    # The scene solved changes: the light gets brighter.
    text = scene_file.read_text()
    assert text.count('name="radiance"') == 1
    scene_file.write_text(text.replace('name="radiance" value="18.387,',
                                       'name="radiance" value="36.774,'))
    assert scene_file.read_text() != text
    with pytest.raises(wavrad.SceneError, match="cornell.wavrad"):
        wavrad.load_solution(saved)

    # The scene file is gone: a warning, and the solution still renders.
    scene_file.unlink()
    with pytest.warns(UserWarning, match="scene.xml"):
        read = wavrad.load_solution(saved)
    assert read.render("smooth", SPP).shape == (24, 24, 3)


def test_saving_where_nothing_can_be_written_is_a_scene_error(
    scene_file: Path, tmp_path: Path
) -> None:
    solution = solved(scene_file)
    with pytest.raises(wavrad.SceneError, match="missing"):
        solution.save(tmp_path / "missing" / "cornell.wavrad")
    assert not (tmp_path / "missing").exists()


def test_a_solve_cut_short_resumes_to_the_uninterrupted_solution(
    scene_file: Path, tmp_path: Path
) -> None:
    scene = wavrad.load_scene(scene_file, res=24)
    settings = {"threshold": 1e-3, "max_level": 4, "progress": False}
    whole = wavrad.solve(scene, **settings)
    assert whole.checkpoint is None
    # Cut short by a time limit of a third of the kernels' time.
    limit = whole.stats["times"]["kernels_s"] / 3
    with pytest.warns(wavrad.SolveWarning, match="the time limit cut the solve short"):
        cut = wavrad.solve(scene, time_limit=limit, **settings)
    assert cut.stats["stopped"] == "time_limit"
    finished, items = cut.checkpoint
    assert 0 < finished < items == whole.stats["projected_items"]
    saved = tmp_path / "cut.wavrad"
    cut.save(saved)
    assert wavrad.load_solution(saved).checkpoint == (finished, items)
    # From the solution or its file, with its own settings: only the items
    # left are projected, and the solution is the uninterrupted one.
    for resume in (cut, saved):
        resumed = wavrad.solve(scene, resume=resume, progress=False)
        assert resumed.checkpoint is None and resumed.stats["stopped"] is None
        assert resumed.stats["resumed_items"] == finished
        assert resumed.stats["projected_items"] == items - finished
        np.testing.assert_array_equal(resumed.radiance, whole.radiance)
    np.testing.assert_array_equal(resumed.render("smooth", SPP), whole.render("smooth", SPP))


def test_resuming_what_does_not_fit_is_refused(scene_file: Path) -> None:
    scene = wavrad.load_scene(scene_file, res=24)
    with pytest.warns(wavrad.SolveWarning, match="cut the linking short"):
        cut = wavrad.solve(scene, threshold=1e-2, max_level=3, time_limit=1e-9, progress=False)
    assert cut.checkpoint is not None
    with pytest.raises(wavrad.SolveError, match="threshold is 1e-4"):
        wavrad.solve(scene, resume=cut, threshold=1e-4, progress=False)
    with pytest.raises(wavrad.SolveError, match="the scene changed since the solve"):
        wavrad.solve(wavrad.load_scene(scene_file, res=16), resume=cut, progress=False)
    with pytest.raises(wavrad.ArgumentError, match="shoot"):
        wavrad.solve(scene, resume=cut, solver="shoot")
    with pytest.raises(wavrad.ArgumentError, match="resume expects"):
        wavrad.solve(scene, resume=42)
    whole = wavrad.solve(scene, resume=cut, progress=False)
    with pytest.raises(wavrad.SolveError, match="nothing is left to resume"):
        wavrad.solve(scene, resume=whole, progress=False)


def test_a_solve_saves_checkpoints_to_resume_from(scene_file: Path, tmp_path: Path) -> None:
    scene = wavrad.load_scene(scene_file, res=24)
    settings = {"threshold": 1e-3, "max_level": 4, "progress": False}
    whole = wavrad.solve(scene, **settings)
    path = tmp_path / "cornell.checkpoint.wavrad"
    saving = wavrad.solve(scene, checkpoint=path, checkpoint_every=1e-3, **settings)
    # Saving changes nothing in the solution; the last save is left.
    np.testing.assert_array_equal(saving.radiance, whole.radiance)
    assert path.exists()
    resumed = wavrad.solve(scene, resume=path, progress=False)
    assert 0 < resumed.stats["resumed_items"] < whole.stats["projected_items"]
    np.testing.assert_array_equal(resumed.radiance, whole.radiance)
    # A checkpoint is not a solution; bad intervals and places are refused.
    with pytest.raises(wavrad.SceneError, match="not a solution"):
        wavrad.load_solution(path)
    with pytest.raises(wavrad.ArgumentError, match="checkpoint_every"):
        wavrad.solve(scene, checkpoint=path, checkpoint_every=0)
    with pytest.raises(wavrad.WavradError, match="missing"):
        wavrad.solve(scene, checkpoint=tmp_path / "missing" / "x.checkpoint.wavrad")
    with pytest.raises(wavrad.ArgumentError, match="shoot"):
        wavrad.solve(scene, checkpoint=path, solver="shoot")
