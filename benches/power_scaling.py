#!/usr/bin/env python3
"""How the power-weighted oracle's cost grows with the solution's size: the
bundled Cornell box solved with `--oracle power` at a ladder of thresholds,
kernel time, whole solve time and peak memory against the element and link
counts, with the log-log slopes (least squares). Writes docs/power_scaling.md.
Standard library only.

    cargo build --release -p wavrad-cli
    python3 benches/power_scaling.py [--scene scenes/cornell-box/scene.xml]
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
WAVRAD = ROOT / "target" / "release" / "wavrad"
THRESHOLDS = [8e-4, 4e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5]


def solve(scene: Path, threshold: float) -> dict:
    """One `wavrad solve` in its own process (so peak memory is its own)."""
    with tempfile.TemporaryDirectory() as tmp:
        stats = Path(tmp) / "stats.json"
        subprocess.run(
            [str(WAVRAD), "solve", str(scene), "--oracle", "power",
             "--threshold", str(threshold), "--stats", str(stats)],
            check=True, capture_output=True,
        )
        return json.loads(stats.read_text())


def slope(xs: list[float], ys: list[float]) -> float:
    """Least-squares slope of log y against log x."""
    lx, ly = [math.log(x) for x in xs], [math.log(y) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    sxy = sum((a - mx) * (b - my) for a, b in zip(lx, ly))
    sxx = sum((a - mx) ** 2 for a in lx)
    return sxy / sxx


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "cornell-box" / "scene.xml"))
    args = ap.parse_args()
    scene = Path(args.scene)
    rows = []
    for t in THRESHOLDS:
        s = solve(scene, t)
        times = s["times"]
        rows.append({
            "threshold": t,
            "elements": s["two_point_nodes"],
            "links": s["two_point_interactions"],
            "kernels_s": times["kernels_s"],
            "solve_s": sum(times.values()),
            "memory_mb": s["peak_memory_bytes"] / 1e6,
            "passes": s["projections"],
        })
        print(rows[-1], flush=True)
    elements = [r["elements"] for r in rows]
    links = [r["links"] for r in rows]
    fits = {
        (y, x): slope(xs, [r[y] for r in rows])
        for y in ("kernels_s", "solve_s", "memory_mb")
        for x, xs in (("elements", elements), ("links", links))
    }
    out = [
        "# Cost of the power-weighted oracle against solution size",
        "",
        f"Written by `python3 benches/power_scaling.py` on "
        f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
        f"{os.cpu_count()} logical CPUs, load average "
        f"{os.getloadavg()[0]:.2f} at the end: `wavrad solve {scene.relative_to(ROOT)} "
        "--oracle power --threshold T` for each threshold, each in its own process. "
        "Elements = two-point nodes, links = two-point interactions; solve = every "
        "phase of the stats' `times` (kernels, hierarchy, Gauss–Seidel, over the "
        "refine–solve loop's passes); memory = the process's peak resident set.",
        "",
        "| threshold | elements | links | refine passes | kernels | solve | peak memory |",
        "|---|---|---|---|---|---|---|",
    ]
    out += [
        f"| {r['threshold']:g} | {r['elements']:,} | {r['links']:,} | {r['passes']} | "
        f"{r['kernels_s']:.2f} s | {r['solve_s']:.2f} s | {r['memory_mb']:.0f} MB |"
        for r in rows
    ]
    out += [
        "",
        "Log–log slopes (least squares over the rows above; 1 is linear):",
        "",
        "| | against elements | against links |",
        "|---|---|---|",
    ]
    names = {"kernels_s": "kernel time", "solve_s": "solve time", "memory_mb": "peak memory"}
    out += [
        f"| {names[y]} | {fits[(y, 'elements')]:.2f} | {fits[(y, 'links')]:.2f} |"
        for y in names
    ]
    out += [
        "",
        "Links per element grow from the first row to the last "
        f"({links[0] / elements[0]:.1f} to {links[-1] / elements[-1]:.1f}): time "
        "follows the links, so against elements it grows faster than linearly.",
        "",
    ]
    path = ROOT / "docs" / "power_scaling.md"
    path.write_text("\n".join(out))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
