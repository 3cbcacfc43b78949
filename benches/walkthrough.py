#!/usr/bin/env python3
"""wavrad's side of the walkthrough benchmark alone, for profiling and for
checking that a change to the renderer leaves its images as accurate: one
solve of the glossy Cornell box (as `benchmarks.py` writes it: box filter,
256²), then the 16 views of `benchmarks.walkthrough_views`, each timed and
saved as DIR/viewK.npy.

    .venv/bin/python benches/walkthrough.py render DIR [--seed N] [--views 0,8,15]
    .venv/bin/python benches/walkthrough.py compare OLD_SEED0 OLD_SEED1 NEW_SEED0 NEW_SEED1

`compare` takes two renders (different seeds) from each of two builds and
prints, per view, each build's noise (relRMSE of one render against its
expectation, from the pair's difference), how far apart the two builds'
means are, and what of that is more than their noise (a systematic change).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import benchmarks  # noqa: E402

import wavrad  # noqa: E402


def render(out: str, seed: int, views: list[int]) -> None:
    os.makedirs(out, exist_ok=True)
    with tempfile.TemporaryDirectory() as folder:
        xml = benchmarks.bench_xml(benchmarks.WALKTHROUGH_SCENE, "independent", folder)
        scene = wavrad.load_scene(xml, res=benchmarks.RESOLUTIONS[0])
    clock = time.perf_counter()
    solution = wavrad.solve(scene, **benchmarks.CONFIGS[benchmarks.WALKTHROUGH_CONFIG])
    total = time.perf_counter() - clock
    print(f"solve {total:.2f} s", flush=True)
    every = benchmarks.walkthrough_views()
    for k in views:
        origin, target, up = every[k]
        clock = time.perf_counter()
        image = solution.render(mode="gather", origin=origin, target=target, up=up, seed=seed)
        seconds = time.perf_counter() - clock
        total += seconds
        np.save(os.path.join(out, f"view{k}.npy"), image)
        print(f"view {k:2d} {seconds:.2f} s", flush=True)
    print(f"solve + renders {total:.2f} s")


def compare(old: tuple[str, str], new: tuple[str, str]) -> None:
    rel = benchmarks.rel_rmse
    for k in range(benchmarks.VIEWS):
        paths = [os.path.join(d, f"view{k}.npy") for d in (*old, *new)]
        if not all(os.path.exists(p) for p in paths):
            continue
        a0, a1, b0, b1 = (np.load(p).astype(np.float64) for p in paths)
        noise_old, noise_new = rel(a0, a1) / math.sqrt(2), rel(b0, b1) / math.sqrt(2)
        apart = rel(0.5 * (b0 + b1), 0.5 * (a0 + a1))
        # Each mean's noise is half a render's variance.
        systematic = math.sqrt(max(0.0, apart**2 - 0.5 * (noise_old**2 + noise_new**2)))
        print(f"view {k:2d}: noise {100 * noise_old:.3f} % -> {100 * noise_new:.3f} %, "
              f"means {100 * apart:.3f} % apart, systematic {100 * systematic:.3f} %, "
              f"mean ratio {b0.mean() / a0.mean():.4f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render")
    r.add_argument("out")
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--views", default=None, help="comma-separated view numbers (default: all)")
    c = sub.add_parser("compare")
    c.add_argument("dirs", nargs=4, metavar="DIR")
    args = ap.parse_args()
    if args.command == "render":
        views = ([int(v) for v in args.views.split(",")] if args.views
                 else list(range(benchmarks.VIEWS)))
        render(args.out, args.seed, views)
    else:
        compare(tuple(args.dirs[:2]), tuple(args.dirs[2:]))


if __name__ == "__main__":
    main()
