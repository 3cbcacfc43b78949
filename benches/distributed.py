#!/usr/bin/env python3
"""The kernel projection on Ray: speed-up from 1 to N workers, and what
crosses the network.

Writes the Cornell box around a tessellated sphere (benches/mesh_scenes.py),
plans its solve in this process, then for each worker count starts that many
Ray actors of one thread each on a local cluster (`wavrad.distributed`), sent
each block's items (or, `replan`, planning the scene again themselves),
projects every block on them and finishes here. Checks that each solution is
`wavrad.solve`'s bit for bit, and writes the table to docs/distributed.md,
keeping what follows its `<!-- notes -->` line.

    make python
    .venv/bin/python benches/distributed.py                  # 2000 triangles, 1 and 2 workers
    .venv/bin/python benches/distributed.py --triangles 500 --workers 1 2 4
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import ray

import wavrad
import wavrad.distributed

ROOT = Path(__file__).resolve().parent.parent
NOTES = "<!-- notes -->"
sys.path.insert(0, str(ROOT / "benches"))
import mesh_scenes  # noqa: E402


def timed(f, *args, **kwargs):
    start = time.perf_counter()
    result = f(*args, **kwargs)
    return result, time.perf_counter() - start


def run(scene_path: Path, workers: list[int], blocks_per_worker: int) -> dict:
    """Every measurement of one scene."""
    scene, load_s = timed(wavrad.load_scene, scene_path)
    plan, plan_s = timed(wavrad.plan, scene)
    items = len(plan)
    items_bytes = sum(len(plan.items(b)) for b in plan.blocks(max(workers) * blocks_per_worker))
    whole, solve_s = timed(wavrad.solve, scene)
    # In this process, on all its threads: the projection alone.
    blocks, local_s = timed(lambda: [plan.project(b) for b in plan.blocks(1)])
    local = plan.finish(blocks)
    assert np.array_equal(local.radiance, whole.radiance)
    rows = []
    for n, replan in [(n, replan) for replan in (False, True) for n in workers]:
        plan = wavrad.plan(scene)
        projectors, start_s = timed(
            wavrad.distributed.Projectors,
            plan,
            scene_path,
            workers=n,
            cpus_per_worker=1,
            replan=replan,
        )
        with projectors:
            cpu = sum(projectors.cpu_seconds())
            blocks, project_s = timed(projectors.project, plan, blocks_per_worker)
            cpu = sum(projectors.cpu_seconds()) - cpu
        counts = [plan.links_in(b) for b in blocks]
        solution, finish_s = timed(plan.finish, blocks)
        rows.append(
            {
                "workers": n,
                "replan": replan,
                "blocks": len(blocks),
                "start_s": start_s,
                "project_s": project_s,
                "cores": cpu / project_s,
                "finish_s": finish_s,
                "bytes": sum(len(b) for b in blocks),
                "two_point": sum(c[0] for c in counts),
                "three_point": sum(c[1] for c in counts),
                "identical": bool(
                    np.array_equal(solution.radiance, whole.radiance)
                    and np.array_equal(solution.directional, whole.directional)
                ),
            }
        )
    return {
        "load_s": load_s,
        "plan_s": plan_s,
        "items": items,
        "items_bytes": items_bytes,
        "cluster_links": whole.stats["cluster_links"],
        "surfaces": whole.stats["surfaces"],
        "solve_s": solve_s,
        "times": whole.stats["times"],
        "local_project_s": local_s,
        "rows": rows,
    }


def header(command: str, load: tuple, commit: str) -> list[str]:
    return [
        "# Distributed projection (Ray)",
        "",
        "`wavrad.distributed` on the Cornell box around a tessellated sphere "
        "(`benches/mesh_scenes.py`), default settings. The driver plans (loads the "
        "scene, builds the ray queries and the cluster tree, links from the root); Ray "
        "actors of one thread each (`cpus_per_worker=1`) on a local cluster start, load "
        "the scene and build a projector of it, or with *replan* plan it again "
        "(*start*); they project the items in blocks handed to whichever actor is free, "
        "sent as items or, with *replan*, as ranges (*project*: until the last block's "
        "bytes are in the driver); the driver finishes (decodes the blocks, resolves the "
        "emitters' links, builds the hierarchies, sweeps). *cores* = the workers' CPU "
        "seconds during *project* over its wall-clock seconds: the cores they really got "
        "on a machine shared with other work; × = speed-up of *project* over the first "
        "row; identical = radiance and directional radiance equal "
        "`wavrad.solve`'s bit for bit. One run each.",
        "",
        f"Written by `{command}`. Measured {datetime.date.today()} at commit `{commit}` "
        f"on {platform.machine()}, {os.cpu_count()} logical CPUs shared with other "
        f"work (load average {load[0]:.2f} before, {load[1]:.2f} after).",
    ]


def section(triangles: int, r: dict) -> list[str]:
    rows = r["rows"]
    base = rows[0]
    links = base["two_point"] + base["three_point"]
    per_link = base["bytes"] / max(links, 1)
    # One worker's output on the wire, and how many workers fill a link.
    rate = base["bytes"] / base["project_s"] * base["workers"]
    serial = r["plan_s"] + base["finish_s"]
    lines = [
        "",
        f"## A sphere of {triangles} triangles",
        "",
        "| workers | replan | blocks | start s | project s | cores | × | finish s | links | "
        "bytes | bytes/link | identical |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        n = row["two_point"] + row["three_point"]
        lines.append(
            f"| {row['workers']} | {'yes' if row['replan'] else 'no'} | {row['blocks']} | "
            f"{row['start_s']:.1f} | "
            f"{row['project_s']:.1f} | {row['cores']:.2f} | "
            f"{base['project_s'] / row['project_s']:.2f} | "
            f"{row['finish_s']:.1f} | {n} | {row['bytes']} | "
            f"{row['bytes'] / max(n, 1):.1f} | {'yes' if row['identical'] else 'NO'} |"
        )
    lines += [
        "",
        "| the same scene | |",
        "|---|---|",
        f"| surfaces | {r['surfaces']} |",
        f"| projection items (element pairs, then surface triples) | {r['items']} |",
        f"| items sent to the workers, all blocks | {r['items_bytes']} bytes |",
        f"| cluster links (made by the plan, not projected) | {r['cluster_links']} |",
        f"| two-point / three-point links projected | {base['two_point']} / "
        f"{base['three_point']} |",
        f"| driver: load scene | {r['load_s']:.2f} s |",
        f"| driver: plan (of which the ray queries' BVH) | {r['plan_s']:.2f} s "
        f"({r['times']['visibility_build_s']:.4f} s) |",
        f"| `wavrad.solve` in one process, {os.cpu_count()} threads "
        f"(of which kernels) | {r['solve_s']:.1f} s ({r['times']['kernels_s']:.1f} s) |",
        f"| the projection alone in one process, {os.cpu_count()} threads | "
        f"{r['local_project_s']:.1f} s |",
        f"| wire bytes per link | {per_link:.1f} |",
        f"| one worker's output (bytes on the wire per second of projection) | "
        f"{rate / 1e6:.2f} MB/s |",
        f"| workers whose output fills 1 Gbit/s / 10 Gbit/s into the driver | "
        f"{125e6 / rate:.0f} / {1250e6 / rate:.0f} |",
        f"| serial in the driver: plan + finish | {serial:.1f} s |",
    ]
    return lines


def main() -> None:
    # The generated sphere's poles hold a few triangles of zero area.
    warnings.filterwarnings("ignore", message=".*zero area")
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, nargs="+", default=[300, 2000])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--blocks-per-worker", type=int, default=4)
    parser.add_argument("--out", type=Path, default=ROOT / "docs/distributed.md")
    args = parser.parse_args()
    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
    ).stdout.strip()
    command = "python3 benches/distributed.py " + " ".join(sys.argv[1:])
    before = os.getloadavg()[0]
    sections = []
    ray.init(num_cpus=max(args.workers), include_dashboard=False, log_to_driver=False)
    try:
        for triangles in args.triangles:
            with tempfile.TemporaryDirectory() as tmp:
                scene_path = mesh_scenes.make("sphere", triangles, Path(tmp))
                result = run(scene_path, args.workers, args.blocks_per_worker)
            sections += section(triangles, result)
    finally:
        ray.shutdown()
    after = os.getloadavg()[0]
    lines = header(command.strip(), (before, after), commit) + sections
    table = "\n".join(lines) + "\n"
    notes = ""
    if args.out.exists() and NOTES in args.out.read_text():
        notes = args.out.read_text().split(NOTES, 1)[1]
    args.out.write_text(table + "\n" + NOTES + notes)
    print(table)


if __name__ == "__main__":
    main()
