#!/usr/bin/env python3
"""How the solve grows with triangle count: time, peak memory, elements,
links and the error clustering costs, for meshes from 10^3 to 10^6
triangles in the Cornell box (benches/mesh_scenes.py), with the log-log
slopes of time and memory against triangles (least squares).

Each solve is `wavrad solve scene.xml --stats S.json` in its own process;
time is its wall clock, memory its peak resident set (wait4). The error
columns compare renders (64², default render and `--mode direct`, the
solution read directly) of the clustered solve with the same scene solved
with `--cluster-ratio 0` (every pair of surfaces linked, as the paper
does), for the sizes where that is affordable: they are what clustering
costs, not the error against a path tracer. With `--mitsuba-spp N` every
sphere and bowl is also rendered by Mitsuba 3's path tracer (two halves of
N/2 spp, independent seeds) and the same two renders are compared with it,
the reference's own noise taken out in quadrature: the whole error at each
size, clustering included. Writes docs/scaling.md, keeping what follows
its `<!-- notes -->` line. Standard library only, and Mitsuba 3 with numpy
for `--mitsuba-spp` (run it with the Python of `make python`).

    cargo build --release -p wavrad-cli
    python3 benches/mesh_scaling.py                          # 10^3 … 10^6 (an hour or more)
    python3 benches/mesh_scaling.py --sizes 1000 10000 --compare-up-to 10000
    python3 benches/mesh_scaling.py --mesh path/to/bunny.ply  # add a real mesh
    .venv/bin/python benches/mesh_scaling.py --mitsuba-spp 16384  # error against Mitsuba
    python3 benches/mesh_scaling.py --sizes --bowl-sizes --scene veach-bidir \
        --scene-args "--approximate --time-limit 300 --max-memory 8"   # a real scene

A real mesh (e.g. the Stanford bunny, common/meshes/bunny.ply of Mitsuba's
mitsuba-data repository; not redistributed here) is fitted into the box
in place of the sphere. A real scene (`--scene`, a name of
scenes/public/scenes.json) is solved as it is, with its `-D` values from
there and `--scene-args`; it has no unclustered comparison.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import mesh_scenes  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
PUBLIC = ROOT / "scenes" / "public"
NOTES = "<!-- notes -->"


def solve(wavrad: Path, scene: Path, extra: list[str], stats: Path | None = None) -> dict:
    stats = stats or scene.parent / "stats.json"
    start = time.perf_counter()
    proc = subprocess.Popen(
        [str(wavrad), "solve", scene.name, "--stats", str(stats.resolve()), *extra],
        cwd=scene.parent,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    err = proc.stderr.read()
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(f"wavrad solve {scene} failed:\n{err}")
    s = json.loads(stats.read_text())
    s["wall_s"] = wall
    s["peak_rss_bytes"] = usage.ru_maxrss * 1024
    return s


def render(wavrad: Path, scene: Path, out: Path, extra: list[str]) -> None:
    subprocess.run(
        [str(wavrad), "render", scene.name, "-D", "res=64", "-o", str(out), *extra],
        cwd=scene.parent,
        check=True,
        capture_output=True,
    )


def relative_rmse(wavrad: Path, image: Path, reference: Path) -> float:
    out = subprocess.run(
        [str(wavrad), "compare", str(image), str(reference)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    return float(out.split()[-1])


def mitsuba_error(wavrad: Path, scene: Path, folder: Path, spp: int) -> dict:
    """The default render's and `--mode direct`'s relRMSE against Mitsuba 3
    at `spp` (two halves of spp/2, seeds 0 and 1), the halves' noise taken
    out in quadrature; also that noise."""
    sys.path.insert(0, str(ROOT / "scenes"))
    import make_references

    # drjit reads DRJIT_LIBLLVM_PATH when it starts: its LLVM backend needs
    # libLLVM >= 17 (older ones abort in code generation).
    make_references.find_libllvm()
    import mitsuba as mi
    import numpy as np

    make_references.pick_variant(mi, "auto")
    loaded = mi.load_file(str(scene), res=64)
    halves = [
        np.array(mi.render(loaded, spp=spp // 2, seed=seed), dtype=np.float64) for seed in (0, 1)
    ]
    reference = 0.5 * (halves[0] + halves[1])
    # The mean of two halves has half the variance of either: its noise is
    # relRMSE(A, B) / 2 (A − B has twice a half's variance).
    noise = float(np.sqrt(np.mean((halves[0] - halves[1]) ** 2)) / np.mean(reference)) / 2
    mi.Bitmap(reference.astype(np.float32)).write(str(folder / "mitsuba.exr"))
    errors = {"noise": noise}
    for label, mode in [("gather", []), ("direct", ["--mode", "direct"])]:
        image = folder / f"c-{label}.exr"
        if not image.exists():
            render(wavrad, scene, image, mode)
        e = relative_rmse(wavrad, image, folder / "mitsuba.exr")
        errors[label] = math.sqrt(max(e * e - noise * noise, 0.0))
    return errors


def slope(xs: list[float], ys: list[float]) -> float:
    lx, ly = [math.log(x) for x in xs], [math.log(y) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    num = sum((a - mx) * (b - my) for a, b in zip(lx, ly))
    den = sum((a - mx) ** 2 for a in lx)
    return num / den if den > 0 else float("nan")


def measure(args, notes: str) -> list[dict]:
    """Every case, the report rewritten after each (a long run that is
    stopped keeps what it measured)."""
    rows = []
    cases = [("sphere", n) for n in args.sizes] + [("bowl", n) for n in args.bowl_sizes]
    if args.mesh:
        cases.append((str(args.mesh), 0))
    with tempfile.TemporaryDirectory() as tmp:
        for kind, n in cases:
            folder = Path(tmp) / f"{Path(kind).stem}-{n}"
            if n == 0:
                scene = mesh_scenes.make_from(Path(kind), folder)
            else:
                scene = mesh_scenes.make(kind, n, folder)
            print(f"{Path(kind).stem} {n or ''}: solving", file=sys.stderr, flush=True)
            s = solve(args.wavrad, scene, [])
            row = {"case": Path(kind).stem, "stats": s}
            if s["surfaces"] <= args.compare_up_to:
                print("  rendering clustered and unclustered", file=sys.stderr, flush=True)
                errors = {}
                for label, mode in [("gather", []), ("direct", ["--mode", "direct"])]:
                    a, b = folder / f"c-{label}.exr", folder / f"u-{label}.exr"
                    render(args.wavrad, scene, a, mode)
                    render(args.wavrad, scene, b, mode + ["--cluster-ratio", "0"])
                    errors[label] = relative_rmse(args.wavrad, a, b)
                row["clustering_error"] = errors
                row["unclustered"] = solve(args.wavrad, scene, ["--cluster-ratio", "0"])
            if args.mitsuba_spp:
                print("  rendering with Mitsuba 3", file=sys.stderr, flush=True)
                row["mitsuba_error"] = mitsuba_error(args.wavrad, scene, folder, args.mitsuba_spp)
            rows.append(row)
            args.out.write_text(report(rows, args, notes))
            print(f"  {s['wall_s']:.1f} s, {s['peak_rss_bytes'] / 2**20:.0f} MiB", file=sys.stderr)
        public = json.loads((PUBLIC / "scenes.json").read_text())["scenes"]
        for name in args.scene:
            entry = public[name]
            defines = [a for k, v in entry.get("defines", {}).items() for a in ("-D", f"{k}={v}")]
            extra = defines + shlex.split(args.scene_args)
            print(f"{name}: solving", file=sys.stderr, flush=True)
            stats = Path(tmp) / f"{name}.json"
            s = solve(args.wavrad, PUBLIC / entry["file"], extra, stats)
            case = f"{name} ({' '.join(extra)}; stopped: {s['stopped'] or 'no'})"
            rows.append({"case": case, "stats": s, "triangles": entry["triangles"]})
            args.out.write_text(report(rows, args, notes))
            print(f"  {s['wall_s']:.1f} s, {s['peak_rss_bytes'] / 2**20:.0f} MiB", file=sys.stderr)
    return rows


def beyond_noise(error: float) -> str:
    """An error with the reference's noise taken out; 0 means it was within that noise."""
    return f"{100 * error:.2f} %" if error > 0 else "within the noise"


def table(rows: list[dict]) -> list[str]:
    lines = [
        "| case | triangles | solve s | peak MiB | elements | element links | cluster links "
        "| surface pairs | unclustered s / MiB | clustering error: render, direct "
        "| error against Mitsuba: render, direct (its noise) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        s = r["stats"]
        u, e, m = r.get("unclustered"), r.get("clustering_error"), r.get("mitsuba_error")
        mib = s["peak_rss_bytes"] / 2**20
        unclustered = f"{u['wall_s']:.1f} / {u['peak_rss_bytes'] / 2**20:.0f}" if u else "–"
        error = f"{100 * e['gather']:.2f} %, {100 * e['direct']:.2f} %" if e else "–"
        against = (
            f"{beyond_noise(m['gather'])}, {beyond_noise(m['direct'])} ({100 * m['noise']:.2f} %)"
            if m
            else "–"
        )
        triangles = r.get("triangles", s["surfaces"] - 6)
        lines.append(
            f"| {r['case']} | {triangles} | {s['wall_s']:.1f} | {mib:.0f} "
            f"| {s['two_point_nodes']} | {s['two_point_interactions']} | {s['cluster_links']} "
            f"| {s['exchanging_pairs']} | {unclustered} | {error} | {against} |"
        )
    return lines


def report(rows: list[dict], args, notes: str) -> str:
    load = os.getloadavg()[0]
    out = [
        "# Scaling with triangle count",
        "",
        f"Written by `python3 benches/mesh_scaling.py {shlex.join(sys.argv[1:])}` on "
        f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
        f"{os.cpu_count()} logical CPUs ({platform.machine()}), "
        f"load average {load:.2f} at the end. "
        "The bundled Cornell box with its blocks replaced by a mesh (`benches/mesh_scenes.py`): "
        "`sphere` is a UV sphere (convex: its triangles never see each other), `bowl` a "
        "hemisphere open at the top, two-sided (concave: they do). Triangles exclude the box's "
        "six rectangles. Solve = the whole `wavrad solve` process (loading included); memory = "
        "its peak resident set. Elements and element links are the two-point nodes and "
        "interactions; clustering error = relRMSE at 64² between the clustered solve and the "
        "same scene with `--cluster-ratio 0` (default render, and `--mode direct`); error "
        "against Mitsuba = the same two renders' relRMSE against Mitsuba 3's path tracer on "
        "the same XML (`--mitsuba-spp`), the reference's noise (in brackets) taken out in "
        "quadrature. A public "
        "scene's row (`--scene`) is solved as it is, with the arguments it names; its "
        "triangles are scenes/public/scenes.json's count.",
        "",
        *table(rows),
        "",
    ]
    for case in sorted({r["case"] for r in rows}):
        rs = [r for r in rows if r["case"] == case]
        if len(rs) >= 2:
            xs = [r["stats"]["surfaces"] for r in rs]
            t = slope(xs, [r["stats"]["wall_s"] for r in rs])
            m = slope(xs, [r["stats"]["peak_rss_bytes"] for r in rs])
            out.append(
                f"- {case}: log–log slope of time {t:.2f}, of memory {m:.2f} "
                f"({min(xs)}–{max(xs)} surfaces)."
            )
    out += ["", NOTES, "", notes.strip(), ""]
    return "\n".join(out)


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--wavrad", type=Path, default=ROOT / "target/release/wavrad")
    parser.add_argument("--sizes", type=int, nargs="*", default=[1000, 10000, 100000, 1000000])
    parser.add_argument("--bowl-sizes", type=int, nargs="*", default=[1000, 10000])
    parser.add_argument(
        "--compare-up-to",
        type=int,
        default=10000,
        help="largest surface count solved unclustered too",
    )
    parser.add_argument(
        "--mitsuba-spp",
        type=int,
        default=0,
        help="also compare each sphere and bowl with Mitsuba 3 at this many spp (0: no)",
    )
    parser.add_argument("--mesh", type=Path, help="a real mesh (PLY/OBJ) to fit into the box")
    parser.add_argument(
        "--scene",
        action="append",
        default=[],
        metavar="NAME",
        help="a public scene of scenes/public/scenes.json, solved as it is (repeatable)",
    )
    parser.add_argument(
        "--scene-args",
        default="",
        help="more `wavrad solve` arguments for --scene, e.g. "
        "'--approximate --time-limit 300 --max-memory 8'",
    )
    parser.add_argument("--out", type=Path, default=ROOT / "docs/scaling.md")
    args = parser.parse_args()
    notes = ""
    if args.out.exists() and NOTES in args.out.read_text():
        notes = args.out.read_text().split(NOTES, 1)[1]
    measure(args, notes)
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
