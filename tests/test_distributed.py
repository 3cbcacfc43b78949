"""``wavrad.distributed`` on a local Ray cluster of two workers that the test
starts itself: a clustered mesh scene solved by Ray actors is the
single-process solve bit for bit."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

import wavrad

ray = pytest.importorskip(
    "ray", reason='wavrad.distributed needs Ray: pip install "wavrad[distributed]"'
)
import wavrad.distributed  # noqa: E402

# The generated sphere's poles hold a few triangles of zero area.
pytestmark = pytest.mark.filterwarnings("ignore:.*zero area:UserWarning")

ROOT = Path(__file__).resolve().parent.parent
DEFINES = {"res": 16}
SETTINGS = {"threshold": 1e-2, "max_level": 3}


@pytest.fixture(scope="module")
def sphere(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The Cornell box around a sphere of 300 triangles."""
    out = tmp_path_factory.mktemp("sphere")
    script = ROOT / "benches" / "mesh_scenes.py"
    subprocess.run([sys.executable, str(script), "sphere", "300", str(out)], check=True)
    return out / "scene.xml"


@pytest.fixture(scope="module")
def two_workers() -> Iterator[None]:
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


@pytest.mark.parametrize("replan", [False, True])
def test_distributed_solve_is_the_single_process_solve(
    sphere: Path, two_workers: None, replan: bool
) -> None:
    single = wavrad.solve(wavrad.load_scene(sphere, **DEFINES), **SETTINGS)
    distributed = wavrad.distributed.solve(
        sphere, workers=2, cpus_per_worker=1, defines=DEFINES, replan=replan, **SETTINGS
    )
    assert single.stats["cluster_links"] > 0
    np.testing.assert_array_equal(distributed.radiance, single.radiance)
    np.testing.assert_array_equal(distributed.directional, single.directional)
    assert distributed.stats["two_point_interactions"] == single.stats["two_point_interactions"]


def test_workers_that_plan_another_scene_are_refused(sphere: Path, two_workers: None) -> None:
    plan = wavrad.plan(wavrad.load_scene(sphere, **DEFINES), **SETTINGS)
    other = ROOT / "scenes" / "cornell-box" / "scene.xml"
    with pytest.raises(wavrad.SolveError, match="made .* differently"):
        wavrad.distributed.Projectors(plan, other, workers=1, defines=DEFINES)
