#!/usr/bin/env python3
"""Parallel scaling of `wavrad render`: phase times at 1, 2, ... threads.

Renders each case with RAYON_NUM_THREADS=1, 2, ..., reads the phase times
from the --stats JSON, checks that every image is byte-for-byte identical to
the one-thread image (images must not depend on the thread count), and
writes the tables to docs/thread-scaling.md, keeping what follows its
`<!-- notes -->` line. Standard library only.

    cargo build --release -p wavrad-cli
    python3 benches/thread_scaling.py                      # 1 and 2 threads, one run each
    python3 benches/thread_scaling.py --threads 1 2 4 --repeat 3 --full

The glossy Cornell box runs with --three-point-max-level 2; --full adds it
at the default settings (level 3: minutes on one thread).
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PHASES = ["visibility_build_s", "kernels_s", "hierarchy_s", "solve_s", "render_s"]
NOTES = "<!-- notes -->"
PARALLELISM = [
    ("load scene", "sequential"),
    ("BVH build", "obvhs' builder (0.1 ms on these scenes)"),
    ("kernels", "rayon over surface pairs (two-point), then over surface triples (three-point)"),
    ("hierarchy", "sequential (element trees, pair trees, transfer lists)"),
    ("solve", "sequential: Gauss–Seidel sweeps over surfaces"),
    ("render", "rayon over the pixels of a row (samples), then of a band (filtering)"),
]


def cases(full: bool) -> list[tuple[str, str, list[str]]]:
    glossy = "scenes/glossy-cornell-box/scene.xml"
    out = [
        ("cornell-box", "scenes/cornell-box/scene.xml", []),
        ("glossy-cornell-box", glossy, ["--three-point-max-level", "2"]),
    ]
    if full:
        out.append(("glossy-cornell-box (default settings)", glossy, []))
    return out


def children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def render(wavrad: Path, scene: str, extra: list[str], threads: int, out: Path) -> dict:
    """One render: phase times, wall and CPU seconds, image digest."""
    image, stats = out / f"{threads}.exr", out / f"{threads}.json"
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    cmd = [str(wavrad), "render", scene, "-o", str(image), "--stats", str(stats), *extra]
    cpu, clock = children_cpu_s(), time.perf_counter()
    subprocess.run(
        cmd, cwd=ROOT, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    wall, cpu = time.perf_counter() - clock, children_cpu_s() - cpu
    times = json.loads(stats.read_text())["times"]
    return {
        "times": {p: times[p] for p in PHASES},
        "wall_s": wall,
        "cpu_s": cpu,
        "image": image,
        "digest": hashlib.sha256(image.read_bytes()).hexdigest(),
    }


def best_of(runs: list[dict]) -> dict:
    """Per phase, the fastest of the repeats (the least disturbed by other load)."""
    return {
        "times": {p: min(r["times"][p] for r in runs) for p in PHASES},
        "wall_s": min(r["wall_s"] for r in runs),
        "cores": max(r["cpu_s"] / r["wall_s"] for r in runs),
        "digests": {r["digest"] for r in runs},
        "image": runs[0]["image"],
    }


def relative_rmse(wavrad: Path, image: Path, reference: Path) -> str:
    out = subprocess.run(
        [str(wavrad), "compare", str(image), str(reference)],
        cwd=ROOT, check=True, capture_output=True, text=True,
    )
    return out.stdout.strip()


def measure(wavrad: Path, threads: list[int], repeat: int, only: str | None, full: bool):
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, scene, extra in cases(full):
            if only and name != only:
                continue
            out = Path(tmp) / f"case{len(results)}"
            out.mkdir()
            rows: dict[int, dict] = {}
            for t in threads:
                rows[t] = best_of([render(wavrad, scene, extra, t, out) for _ in range(repeat)])
                base = rows[threads[0]]
                same = rows[t]["digests"] == base["digests"] and len(base["digests"]) == 1
                rows[t]["identical"] = same
                if not same:
                    rows[t]["difference"] = relative_rmse(wavrad, rows[t]["image"], base["image"])
                tt = rows[t]["times"]
                print(
                    f"{name}, {t} thread(s): kernels {tt['kernels_s']:.2f} s, "
                    f"solve {tt['solve_s']:.3f} s, render {tt['render_s']:.2f} s, "
                    f"wall {rows[t]['wall_s']:.2f} s, CPU/wall {rows[t]['cores']:.2f}, "
                    f"identical {same}",
                    flush=True,
                )
            results.append((name, extra, rows))
    return results


def ratio(a: float, b: float) -> str:
    return f"{a / b:.2f}" if b > 0 else "–"


def table(extra: list[str], rows: dict[int, dict], threads: list[int]) -> list[str]:
    lines = [
        "| threads | BVH s | kernels s | hierarchy s | solve s | render s | wall s | CPU/wall "
        "| kernels × | render × | wall × | identical |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    base = rows[threads[0]]
    for t in threads:
        r, tt, bt = rows[t], rows[t]["times"], base["times"]
        same = "yes" if r["identical"] else f"no ({r.get('difference', '')})"
        cells = [
            str(t),
            f"{tt['visibility_build_s']:.4f}",
            f"{tt['kernels_s']:.2f}",
            f"{tt['hierarchy_s']:.3f}",
            f"{tt['solve_s']:.3f}",
            f"{tt['render_s']:.2f}",
            f"{r['wall_s']:.2f}",
            f"{r['cores']:.2f}",
            ratio(bt["kernels_s"], tt["kernels_s"]),
            ratio(bt["render_s"], tt["render_s"]),
            ratio(base["wall_s"], r["wall_s"]),
            same,
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def report(results, threads, repeat, load, notes: str, commit: str | None) -> str:
    git = ["git", "rev-parse", "--short", "HEAD"]
    if not commit:
        commit = subprocess.run(git, cwd=ROOT, capture_output=True, text=True).stdout.strip()
    lines = [
        "# Parallel scaling",
        "",
        "Phase times of `wavrad render SCENE -o OUT.exr --stats OUT.json` with",
        f"`RAYON_NUM_THREADS` = {', '.join(map(str, threads))}, from the `--stats` JSON",
        f"(per phase the fastest of {repeat} run(s)); wall = the whole process; CPU/wall =",
        "the cores the process actually got; × = speed-up over "
        f"{threads[0]} thread(s); identical =",
        f"the EXR file is byte-for-byte the {threads[0]}-thread one.",
        f"Written by `python3 benches/thread_scaling.py {' '.join(sys.argv[1:])}`.",
        "",
        f"Measured {datetime.date.today()} at commit `{commit or 'unknown'}` on "
        f"{platform.machine()}, {os.cpu_count()} logical CPUs, load average "
        f"{load[0]:.2f} before and {load[1]:.2f} after.",
        "",
    ]
    for name, extra, rows in results:
        flags = " ".join(extra)
        lines += [f"## {name}" + (f" (`{flags}`)" if flags else ""), ""]
        lines += table(extra, rows, threads) + [""]
    lines += ["## What runs in parallel", "", "| phase | parallelism |", "|---|---|"]
    lines += [f"| {phase} | {how} |" for phase, how in PARALLELISM]
    lines += ["", notes.rstrip(), ""]
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--wavrad", type=Path, default=ROOT / "target/release/wavrad")
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--repeat", type=int, default=1, help="runs per count; fastest counts")
    parser.add_argument("--full", action="store_true", help="add the glossy box at defaults")
    parser.add_argument("--only", help="run only the case of this name")
    parser.add_argument("--out", type=Path, default=ROOT / "docs/thread-scaling.md")
    parser.add_argument("--commit", help="commit the binary was built from (default: HEAD)")
    args = parser.parse_args()
    wavrad = args.wavrad.resolve()
    if not wavrad.exists():
        sys.exit(f"{wavrad} not found: cargo build --release -p wavrad-cli")
    threads = sorted(set(args.threads))
    old = args.out.read_text() if args.out.exists() else ""
    notes = old[old.index(NOTES):] if NOTES in old else NOTES + "\n"

    before = os.getloadavg()[0]
    results = measure(wavrad, threads, args.repeat, args.only, args.full)
    after = os.getloadavg()[0]
    args.out.write_text(report(results, threads, args.repeat, (before, after), notes, args.commit))
    print(f"wrote {args.out}")
    identical = all(r["identical"] for *_, rows in results for r in rows.values())
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
