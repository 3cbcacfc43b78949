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
