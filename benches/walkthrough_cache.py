#!/usr/bin/env python3
"""The walkthrough of benches/benchmarks.py rendered twice from one solve of
the glossy Cornell box (its bundled 64² film): gathering per camera ray,
and with the view-independent gather cache (the default; its texels
gathered as the views first show them). Prints the solve
time, each way's total and per-view render times, each way's relRMSE on
view 0 against the committed reference, and how far the two ways' images
differ on the other views.

Usage: .venv/bin/python benches/walkthrough_cache.py   (after `make python`)
"""

from __future__ import annotations

import os
import sys
import time

import wavrad

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from benchmarks import SCENES, SCENES_DIR, WALKTHROUGH_SCENE, walkthrough_views  # noqa: E402


def main() -> None:
    xml = os.path.join(SCENES_DIR, SCENES[WALKTHROUGH_SCENE].xml)
    exr = os.path.join(os.path.dirname(xml), "reference.exr")
    reference = wavrad.read_exr(exr)
    clock = time.perf_counter()
    solution = wavrad.solve(wavrad.load_scene(xml))
    solve_s = time.perf_counter() - clock
    print(f"solve {solve_s:.2f} s")
    images = {}
    for cache in (False, True):
        times, views = [], []
        for origin, target, up in walkthrough_views():
            clock = time.perf_counter()
            views.append(solution.render(origin=origin, target=target, up=up,
                                         gather_cache=cache))
            times.append(time.perf_counter() - clock)
        images[cache] = views
        name = "gather cache" if cache else "per camera ray"
        print(f"{name}: {len(views)} views {solve_s + sum(times):.1f} s in all "
              f"(renders {' '.join(f'{t:.2f}' for t in times)}), "
              f"view 0 relRMSE {100 * wavrad.relative_rmse(views[0], reference):.2f} %")
    for k in (5, 10, 15):
        diff = wavrad.relative_rmse(images[True][k], images[False][k])
        print(f"view {k}: cached against per-ray image {100 * diff:.2f} %")


if __name__ == "__main__":
    main()
