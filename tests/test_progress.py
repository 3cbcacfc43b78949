"""Progress of a solve and a render, reported to a callable or as lines on
stderr; a callable's exception and Ctrl-C stop the solve (which finishes
from what is done) and the render (which raises)."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import pytest

import wavrad

CORNELL_BOX = Path(__file__).resolve().parent.parent / "scenes" / "cornell-box" / "scene.xml"
COARSE = {"threshold": 1e-2, "max_level": 3}


@pytest.fixture(scope="module")
def scene() -> wavrad.Scene:
    return wavrad.load_scene(CORNELL_BOX, res=16)


def test_a_callable_sees_every_phase_from_start_to_end(scene: wavrad.Scene) -> None:
    calls: list[tuple[str, int, int]] = []
    solution = wavrad.solve(scene, progress=lambda *call: calls.append(call), **COARSE)
    phases = list(dict.fromkeys(phase for phase, _, _ in calls))
    assert phases[0] == "linking" and phases[-1] == "solving", phases
    assert "kernels" in phases
    for phase in phases:
        seen = [(done, total) for p, done, total in calls if p == phase]
        assert seen[0][0] == 0, phase
        dones = [done for done, _ in seen]
        assert dones == sorted(dones) and dones[-1] <= seen[-1][1], (phase, seen)
    # The kernels' phase ends with every surface pair done.
    done, total = [(d, t) for p, d, t in calls if p == "kernels"][-1]
    assert done == total > 0
    assert solution.stats["stopped"] is None

    # A render reports its rows.
    rendered: list[tuple[str, int, int]] = []
    solution.render(spp=1, progress=lambda *call: rendered.append(call))
    assert {phase for phase, _, _ in rendered} == {"rendering"}
    assert rendered[0] == ("rendering", 0, 16) and rendered[-1] == ("rendering", 16, 16)
    assert [done for _, done, _ in rendered] == sorted(done for _, done, _ in rendered)


def test_a_callable_raising_stops_the_solve_and_is_raised(scene: wavrad.Scene) -> None:
    class Enough(Exception):
        pass

    calls = 0

    def stop(phase: str, done: int, total: int) -> None:
        nonlocal calls
        calls += 1
        raise Enough(phase)

    with pytest.raises(Enough, match="linking"):
        wavrad.solve(scene, progress=stop, **COARSE)
    # The first exception is raised; later calls may come, but no solve
    # phase runs to completion after it.
    assert calls >= 1


def test_progress_true_prints_lines_to_stderr(
    scene: wavrad.Scene, capsys: pytest.CaptureFixture[str]
) -> None:
    wavrad.solve(scene, progress=True, **COARSE)
    err = capsys.readouterr().err.splitlines()
    # Not a terminal: one line at each phase's end, as tqdm's would read.
    kernels = [line for line in err if line.startswith("kernels:")]
    assert len(kernels) == 1, err
    assert "100%|" in kernels[0] and "/s]" in kernels[0], kernels[0]
    wavrad.solve(scene, progress=False, **COARSE)
    assert capsys.readouterr().err == ""


def test_progress_must_be_a_flag_or_a_callable(scene: wavrad.Scene) -> None:
    with pytest.raises(wavrad.ArgumentError, match="progress"):
        wavrad.solve(scene, progress="yes", **COARSE)


def test_ctrl_c_finishes_the_solve_from_what_is_done(scene: wavrad.Scene) -> None:
    # A fine solve (minutes); the interrupt comes 0.3 s in.
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    started = time.monotonic()
    timer.start()
    with pytest.warns(UserWarning, match="interrupted"):
        solution = wavrad.solve(scene, threshold=1e-4, max_level=6, progress=False)
    timer.join()
    assert solution.stats["stopped"] == "interrupted"
    assert solution.stats["unrefined_items"] > 0
    assert time.monotonic() - started < 30
    assert solution.render(mode="haar", spp=1).shape == (16, 16, 3)


@pytest.fixture(scope="module")
def coarse(scene: wavrad.Scene) -> wavrad.Solution:
    return wavrad.solve(scene, progress=False, **COARSE)


# A render of minutes: every camera ray final-gathers many times.
LONG_RENDER = {"spp": 4096, "gather_spp": 4096}


def test_ctrl_c_stops_a_render_and_raises(coarse: wavrad.Solution) -> None:
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    started = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        coarse.render(progress=False, **LONG_RENDER)
    timer.join()
    assert time.monotonic() - started < 10
    # Nothing was left half done: the solution renders again.
    assert coarse.render("smooth", 1, progress=False).shape == (16, 16, 3)


def test_a_callable_raising_stops_a_render_and_is_raised(coarse: wavrad.Solution) -> None:
    class Enough(Exception):
        pass

    def stop(phase: str, done: int, total: int) -> None:
        if done > 0:
            raise Enough(f"{phase} {done}/{total}")

    started = time.monotonic()
    with pytest.raises(Enough, match="rendering"):
        coarse.render(progress=stop, **LONG_RENDER)
    assert time.monotonic() - started < 10
