#!/usr/bin/env python3
"""End-to-end benchmark: wavrad against Mitsuba 3's path tracer on the
bundled scenes, in one run on one machine. Writes docs/benchmarks.md (tables)
and docs/benchmarks.json (every raw number), and the walkthrough's images
under docs/benchmarks/.

For each scene and each wavrad configuration (CONFIGS below, with the
per-scene additions of SCENE_CONFIGS):

* wavrad: solve (every phase in ``solution.stats["times"]``), render the
  scene's view (gather mode, default camera rays), counts, peak memory and
  relRMSE against the committed reference (``scenes/*/reference.exr``). Each
  configuration runs in its own process, so that peak memory is its own.
* Mitsuba 3 (``path`` as in the scene file, the reference's integrator):
  progressive renders with the sample count doubling (1, 2, 4, ... spp, each
  pass with new seeds, the running average is the image at that spp), timed,
  until the running relRMSE falls below wavrad's; the time Mitsuba needs to
  reach wavrad's relRMSE is interpolated log-log between the two measured
  points that bracket it.
* Walkthrough (WALKTHROUGH_SCENE): VIEWS views along a path from one wavrad
  solution (WALKTHROUGH_CONFIG: the gather cache made by the first view and
  read by all), against VIEWS Mitsuba images at the spp that reached
  wavrad's relRMSE on the scene's own view.

Usage: make bench   (installs benches/requirements.txt into .venv, then
       .venv/bin/python benches/benchmarks.py [--scenes NAME ...])
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

import wavrad

# wavrad configurations: name -> keyword arguments of wavrad.solve; add a
# line to compare another.
CONFIGS: dict[str, dict[str, object]] = {
    "default": {},
    # The default solve, rendered with the view-independent gather cache
    # (RENDER_ARGS): the walkthrough's configuration.
    "cached": {},
    # Power-weighted oracle (refine-solve loop), with its own default
    # thresholds (2e-4 relative radiance error) unless SCENE_CONFIGS says.
    "power": {"oracle": "power"},
    # The three-point maximum level before it became 2: the finer directional
    # structure's cost and what it buys once the final gather lights glossy
    # surfaces per point.
    "level-3": {"three_point_max_level": 3},
}
# Keyword arguments of Solution.render besides mode="gather", per configuration.
RENDER_ARGS: dict[str, dict[str, object]] = {"cached": {"gather_cache": True}}
# The configuration the walkthrough renders its views with: the cache is built
# by its first view (the scene's own), whose render time includes it.
WALKTHROUGH_CONFIG = "cached"
# Configurations that run only on some scenes (the others have nothing for
# them to change): configuration -> scenes.
SCENE_ONLY: dict[str, list[str]] = {"level-3": ["glossy-cornell-box"]}
# Per-scene keyword arguments of a configuration, on top of CONFIGS:
# configuration -> scene -> keyword arguments.
SCENE_CONFIGS: dict[str, dict[str, dict[str, object]]] = {
    "power": {"cornell-box": {"threshold": 1e-4}},
}

SCENES = ["cornell-box", "glossy-cornell-box"]  # names of scenes/make_references.py
WALKTHROUGH_SCENE = "glossy-cornell-box"
VIEWS = 16
# Walkthrough views given a Mitsuba reference of REFERENCE_RENDERS renders at
# the walkthrough's spp (view 0 is the scene's own view: it has the committed one).
REFERENCE_VIEWS = (5, 10, 15)
REFERENCE_RENDERS = 4
# Self-noise (relRMSE) of the committed references, from scenes/README.md.
REFERENCE_NOISE = {
    "cornell-box": 0.00348,
    "glossy-cornell-box": 0.00276,
    "figure3-diffuse": 0.00314,
    "figure3-specular": 0.00458,
}
MAX_LANES = 1 << 24  # pixels x spp per mi.render call (memory)
CURVE_TIME_CAP_S = 300.0  # per scene
CURVE_MAX_SPP = 1 << 17
# Independent progressive curves per scene: Mitsuba's error on the glossy box
# is heavy-tailed (in two runs, 16384 spp gave 1.03 % and 1.47 %), so one
# curve's crossing moved the glossy ratio by 2x between runs. The time to
# wavrad's error is the median of the curves' crossings.
CURVES = 3
FIRST_SEED = 1_000_000  # the references used seeds below 1 000 000

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES_DIR = os.path.join(ROOT, "scenes")
DOCS = os.path.join(ROOT, "docs")
IMAGES = os.path.join(DOCS, "benchmarks")


def scene_files(name: str) -> tuple[str, str, str]:
    """(scene XML, reference EXR, reference integrator) of a bundled scene."""
    sys.path.insert(0, SCENES_DIR)
    import make_references

    xml, exr, _res, _spp, _pass_spp, integrator = make_references.SCENES[name]
    return xml, exr, integrator


def walkthrough_views(n: int = VIEWS) -> list[tuple[tuple[float, ...], ...]]:
    """(origin, target, up) of n views: from the scene's own camera, outside
    the box's open side, dollying in to just inside the box while circling
    left and right and up, always looking into the box (towards its back
    wall at the end)."""
    views = []
    for k in range(n):
        t = k / (n - 1)
        s, h = math.sin(2 * math.pi * t), math.sin(math.pi * t)
        origin = (0.55 * s, 0.3 * h, 3.9 - 3.1 * t)
        target = (-0.35 * s, -0.3 * h, -t)
        views.append((origin, target, (0.0, 1.0, 0.0)))
    return views


def cpu_seconds() -> float:
    """CPU time of this process so far, every thread (user + system)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


# wavrad, one process per (scene, configuration)


def solve_arguments(scene_name: str, config: str) -> dict[str, object]:
    """Keyword arguments of wavrad.solve for a configuration on a scene."""
    return {**CONFIGS[config], **SCENE_CONFIGS.get(config, {}).get(scene_name, {})}


def wavrad_worker(scene_name: str, config: str, out: str) -> None:
    xml, exr, _ = scene_files(scene_name)
    scene = wavrad.load_scene(xml)
    clock, cpu = time.perf_counter(), cpu_seconds()
    solution = wavrad.solve(scene, **solve_arguments(scene_name, config))
    solve_wall, solve_cpu = time.perf_counter() - clock, cpu_seconds() - cpu
    stats = solution.stats
    render_args = RENDER_ARGS.get(config, {})
    walk = scene_name == WALKTHROUGH_SCENE and config == WALKTHROUGH_CONFIG
    times, cpus, views = [], [], []
    # The walkthrough's first view is the scene's own: it is the main image.
    for origin, target, up in walkthrough_views() if walk else [(None, None, None)]:
        clock, cpu = time.perf_counter(), cpu_seconds()
        views.append(solution.render(mode="gather", origin=origin, target=target, up=up,
                                     **render_args))
        times.append(time.perf_counter() - clock)
        cpus.append(cpu_seconds() - cpu)
    image, render_s, render_cpu = views[0], times[0], cpus[0]
    np.save(os.path.join(out, "main.npy"), image)
    result = {
        "stats": stats,
        "solve_wall_s": solve_wall,
        "solve_cpu_s": solve_cpu,
        "render_s": render_s,
        "render_cpu_s": render_cpu,
        "rel_rmse": wavrad.relative_rmse(image, wavrad.read_exr(exr)),
        "width": scene.width,
        "height": scene.height,
    }
    if walk:
        for k, view in enumerate(views):
            np.save(os.path.join(out, f"view{k}.npy"), view)
        result["view_render_s"] = times
        result["view_render_cpu_s"] = cpus
    with open(os.path.join(out, "result.json"), "w") as f:
        json.dump(result, f)


def run_wavrad(scene_name: str, config: str, out: str) -> dict:
    """Run the worker in a fresh process; adds its peak resident memory."""
    os.makedirs(out, exist_ok=True)
    args = [sys.executable, os.path.abspath(__file__), "--worker", scene_name, config, out]
    process = subprocess.Popen(args)
    _, status, usage = os.wait4(process.pid, 0)
    if status != 0:
        sys.exit(f"wavrad worker {scene_name} {config} failed (status {status})")
    with open(os.path.join(out, "result.json")) as f:
        result = json.load(f)
    result["process_max_rss_bytes"] = usage.ru_maxrss * 1024
    result["main"] = np.load(os.path.join(out, "main.npy"))
    if "view_render_s" in result:
        result["views"] = [np.load(os.path.join(out, f"view{k}.npy")) for k in range(VIEWS)]
    return result


# Mitsuba 3


class Mitsuba:
    """Mitsuba 3 set up as scenes/make_references.py does (llvm_ad_rgb with
    libLLVM >= 17, Mitsuba 0.6's ward registered from Python), with drjit's
    kernel history on to tell compile time from render time."""

    def __init__(self) -> None:
        sys.path.insert(0, SCENES_DIR)
        import make_references

        make_references.find_libllvm()
        import drjit as dr
        import mitsuba as mi

        self.mi, self.dr = mi, dr
        self.variant = make_references.pick_variant(mi, "auto")
        if self.variant != "llvm_ad_rgb":
            # scalar_rgb is many times slower than what a user would run:
            # timing it would flatter wavrad.
            sys.exit("benchmarks.py: Mitsuba's llvm_ad_rgb variant is unavailable (it needs "
                     "libLLVM >= 17: `make llvm` installs Debian's libllvm19)")
        import ward_bsdf

        ward_bsdf.register()
        dr.set_flag(dr.JitFlag.KernelHistory, True)
        self.next_seed = FIRST_SEED
        self.compile_ms = 0.0  # codegen + backend compile inside timed renders
        self.kernels_compiled = 0  # JIT kernels not found in drjit's caches

    def load(self, xml: str, integrator: str):
        scene = self.mi.load_file(xml)
        integ = None
        if integrator != "path":
            integ = self.mi.load_dict({"type": integrator, "max_depth": -1})
        return scene, integ

    def render(self, loaded, spp: int, timed: bool = True) -> tuple[np.ndarray, float, float]:
        """An spp-sample image (float64, passes of at most MAX_LANES samples,
        each with new seeds), the wall-clock seconds of its mi.render calls
        and their CPU seconds (every thread)."""
        scene, integ = loaded
        size = scene.sensors()[0].film().size()
        max_pass = max(1, MAX_LANES // (int(size[0]) * int(size[1])))
        total, seconds, cpu, done = None, 0.0, 0.0, 0
        self.dr.kernel_history()  # drop older entries
        while done < spp:
            n = min(max_pass, spp - done)
            seed, self.next_seed = self.next_seed, self.next_seed + 1
            clock, cpu_start = time.perf_counter(), cpu_seconds()
            if integ is None:
                image = self.mi.render(scene, spp=n, seed=seed)
            else:
                image = self.mi.render(scene, integrator=integ, spp=n, seed=seed)
            image = np.array(image, dtype=np.float64)
            seconds += time.perf_counter() - clock
            cpu += cpu_seconds() - cpu_start
            total = image * n if total is None else total + image * n
            done += n
        if timed:
            for k in self.dr.kernel_history():
                self.compile_ms += k.get("codegen_time", 0.0) + k.get("backend_time", 0.0)
                self.kernels_compiled += int(k.get("cache_hit", 1) == 0)
        return total / spp, seconds, cpu

    def set_view(self, loaded, origin, target, up) -> None:
        scene, _ = loaded
        params = self.mi.traverse(scene)
        key = next(k for k in params.keys() if k.endswith(".x_fov")).replace(".x_fov", ".to_world")
        params[key] = self.mi.ScalarTransform4f().look_at(origin=origin, target=target, up=up)
        params.update()

    def warm_up(self, loaded) -> float:
        """One render that compiles (or loads from drjit's disk cache) the
        kernels, untimed in the results; returns its seconds."""
        _, seconds, _ = self.render(loaded, 1, timed=False)
        self.dr.kernel_history()
        return seconds


def relative_rmse(a: np.ndarray, b: np.ndarray) -> float:
    return wavrad.relative_rmse(a.astype(np.float32), b.astype(np.float32))


def mitsuba_curve(mitsuba: Mitsuba, loaded, reference: np.ndarray, target: float) -> list[dict]:
    """Progressive renders, spp doubling, until relRMSE < target (or the caps)."""
    curve, total, spp, seconds, cpu = [], None, 0, 0.0, 0.0
    while True:
        n = max(1, spp)  # 1, 1, 2, 4, ... : running spp 1, 2, 4, 8, ...
        image, dt, dcpu = mitsuba.render(loaded, n)
        total = image * n if total is None else total + image * n
        spp, seconds, cpu = spp + n, seconds + dt, cpu + dcpu
        error = relative_rmse(total / spp, reference)
        curve.append({"spp": spp, "time_s": seconds, "cpu_s": cpu, "rel_rmse": error})
        print(f"  mitsuba {spp:7d} spp {seconds:8.2f} s ({cpu:8.2f} s CPU) "
              f"relRMSE {100 * error:.2f} %", flush=True)
        if error < target or seconds > CURVE_TIME_CAP_S or spp >= CURVE_MAX_SPP:
            return curve


def match(curve: list[dict], target: float) -> dict:
    """Mitsuba's spp and time at relRMSE = target: log-log interpolation
    between the first point below target and the one before it; past the
    curve's end, extrapolated with error ∝ spp^(-1/2) and time ∝ spp."""
    keys = ("spp", "time_s", "cpu_s")
    for before, after in zip(curve, curve[1:]):
        if before["rel_rmse"] >= target > after["rel_rmse"]:
            f = math.log(target / before["rel_rmse"]) / math.log(
                after["rel_rmse"] / before["rel_rmse"]
            )
            out = {key: math.exp((1 - f) * math.log(before[key]) + f * math.log(after[key]))
                   for key in keys}
            return {**out, "method": "interpolated"}
    if curve[0]["rel_rmse"] < target:
        return {**{key: curve[0][key] for key in keys}, "method": "first point"}
    last = curve[-1]
    scale = (last["rel_rmse"] / target) ** 2
    return {**{key: last[key] * scale for key in keys}, "method": "extrapolated"}


def median_match(curves: list[list[dict]], target: float) -> dict:
    """The median, by spp, of `match` on each curve, with every curve's spp."""
    matches = sorted((match(c, target) for c in curves), key=lambda m: m["spp"])
    return {**matches[len(matches) // 2], "spp_per_curve": [m["spp"] for m in matches]}


def walkthrough(mitsuba: Mitsuba, loaded, spp: int) -> dict:
    """VIEWS Mitsuba images at spp (two halves each, whose difference
    measures the image's own noise), and references for REFERENCE_VIEWS."""
    views, times, cpus, noise = [], [], [], []
    half = max(1, spp // 2)
    for k, (origin, target, up) in enumerate(walkthrough_views()):
        mitsuba.set_view(loaded, origin, target, up)
        a, ta, ca = mitsuba.render(loaded, half)
        b, tb, cb = mitsuba.render(loaded, half)
        image = 0.5 * (a + b)
        # relRMSE of one half is relRMSE(a, b)/sqrt(2); of their mean, half of relRMSE(a, b).
        noise.append(0.5 * relative_rmse(a, b) * float(b.mean()) / float(image.mean()))
        views.append(image)
        times.append(ta + tb)
        cpus.append(ca + cb)
        print(f"  mitsuba view {k:2d}: {ta + tb:6.2f} s, own noise {100 * noise[-1]:.2f} %",
              flush=True)
    references = {}
    for k in REFERENCE_VIEWS:
        mitsuba.set_view(loaded, *walkthrough_views()[k])
        renders = [views[k]]
        for _ in range(REFERENCE_RENDERS - 1):
            renders.append(mitsuba.render(loaded, 2 * half, timed=False)[0])
        reference = np.mean(renders, axis=0)
        # Noise of one render from the pairs' differences, of the mean /sqrt(n).
        pairs = [(i, j) for i in range(len(renders)) for j in range(i + 1, len(renders))]
        single = math.sqrt(np.mean([relative_rmse(renders[i], renders[j]) ** 2 / 2
                                    for i, j in pairs]))
        references[k] = {"image": reference, "noise": single / math.sqrt(len(renders)),
                         "spp": len(renders) * 2 * half}
        print(f"  reference view {k}: {references[k]['spp']} spp, "
              f"noise {100 * references[k]['noise']:.2f} %", flush=True)
    mitsuba.set_view(loaded, *walkthrough_views()[0])
    return {"spp": 2 * half, "views": views, "times": times, "cpu_s": cpus, "noise": noise,
            "references": references}


# Report


def machine() -> dict:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            names = [line.split(":", 1)[1].strip() for line in f if line.startswith("model name")]
        cpu = names[0] if names else cpu
    except OSError:
        pass

    def git(*args: str) -> str:
        run = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True)
        return run.stdout.strip() if run.returncode == 0 else ""

    return {
        "cpu": cpu,
        "cpu_count": os.cpu_count(),
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "wavrad_commit": git("rev-parse", "HEAD") or "unknown",
        "uncommitted_changes": bool(git("status", "--porcelain", "--untracked-files=no")),
        "python": platform.python_version(),
        "load_average_start": os.getloadavg(),
    }


def mosaic(images: list[np.ndarray], columns: int = 4) -> np.ndarray:
    rows = [np.concatenate(images[i:i + columns], axis=1)
            for i in range(0, len(images), columns)]
    return np.concatenate(rows, axis=0).astype(np.float32)


def pct(x: float) -> str:
    return f"{100 * x:.2f} %"


def write_report(info: dict, results: dict, walk: dict | None) -> None:
    m = info["machine"]
    commit = m["wavrad_commit"][:12]
    if m["uncommitted_changes"]:
        commit += " + uncommitted changes"
    lines = [
        "# wavrad against Mitsuba 3: end-to-end benchmark",
        "",
        f"Written by `benches/benchmarks.py` (`make bench`), {m['date']}: {m['cpu']}, "
        f"`os.cpu_count()` = {m['cpu_count']}, wavrad {commit}, Python {m['python']}, "
        f"Mitsuba {info['mitsuba']} (drjit {info['drjit']}, variant `{info['variant']}`). "
        f"Load average at start {m['load_average_start'][0]:.2f}, at end "
        f"{m['load_average_end'][0]:.2f} (1 min; both programs use every core, so "
        "other jobs on the machine slow both). Raw numbers: `docs/benchmarks.json`. "
        f"The whole run took {info['total_s'] / 60:.1f} min.",
        "",
        "relRMSE = sqrt(mean((a−b)²)) / mean(b) over all pixels and channels, against "
        "the committed reference (`scenes/*/reference.exr`, itself Mitsuba 3 at high spp, "
        "whose own noise is listed; it adds in quadrature to every error below, to "
        "wavrad's and Mitsuba's alike).",
        "",
        "## Time to the same error",
        "",
        "| scene | wavrad config | wavrad relRMSE | wavrad solve | wavrad render | "
        "wavrad total (CPU) | Mitsuba spp for that relRMSE | Mitsuba time (CPU) | "
        "**Mitsuba / wavrad** | same, CPU time | cores busy, wavrad / Mitsuba |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, r in results.items():
        for config, w in r["wavrad"].items():
            mt = r["match"][config]
            total = w["solve_s"] + w["render_s"]
            total_cpu = w["solve_cpu_s"] + w["render_cpu_s"]
            flag = "" if mt["method"] == "interpolated" else f" ({mt['method']})"
            lines.append(
                f"| {name} ({w['width']}×{w['height']}) | {config} | {pct(w['rel_rmse'])} | "
                f"{w['solve_s']:.2f} s | {w['render_s']:.2f} s | "
                f"{total:.2f} s ({total_cpu:.1f} s) | {mt['spp']:.0f}{flag} | "
                f"{mt['time_s']:.2f} s ({mt['cpu_s']:.1f} s) | **{mt['time_s'] / total:.2f}** | "
                f"{mt['cpu_s'] / total_cpu:.2f} | {total_cpu / total:.1f} / "
                f"{mt['cpu_s'] / mt['time_s']:.1f} |"
            )
    lines += ["", "Mitsuba spp at wavrad's relRMSE on each curve (the table takes the median):"]
    lines += [
        f"{name} {config}: " + ", ".join(f"{x:.0f}" for x in mt["spp_per_curve"]) + "; "
        for name, r in results.items()
        for config, mt in r["match"].items()
        if "spp_per_curve" in mt
    ]
    lines += [
        "",
        "wavrad solve = every phase of `solution.stats[\"times\"]` (visibility, kernels, "
        "hierarchy, Gauss–Seidel); render = wall clock of `solution.render()` (gather "
        "mode, default camera rays; config `cached` with `gather_cache=True`, its time "
        "including the cache's making). Mitsuba time = wall clock of its `mi.render` calls "
        "(scene loading excluded), interpolated log-log between the two measured points "
        "of a curve below that bracket wavrad's relRMSE; the median over "
        f"{CURVES} independent curves (every curve's spp below the table). CPU: user + "
        "system time of "
        "the process over the same calls, every thread. Both programs use every core "
        f"({m['cpu_count']} here), so \"cores busy\" (CPU time / wall clock) should be "
        "about the same for both; where it differs, other jobs shared the machine during "
        "one of them, and the CPU-time ratio is the fairer comparison.",
        "",
        "| scene | config | elements (two-point nodes) | links (two-point interactions) | "
        "three-point nodes | three-point interactions | iterations | kernels | peak memory |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name, r in results.items():
        for config, w in r["wavrad"].items():
            s = w["stats"]
            mem = (s.get("peak_memory_bytes") or 0) / 2**20
            lines.append(
                f"| {name} | {config} | {s['two_point_nodes']:,} | "
                f"{s['two_point_interactions']:,} | {s['three_point_nodes']:,} | "
                f"{s['three_point_interactions']:,} | {s['iterations']} | "
                f"{s['times']['kernels_s']:.2f} s | {mem:.0f} MB |"
            )
    lines += [
        "",
        "Peak memory: the solving process's peak resident set (`VmHWM`) at the end of the "
        "solve, as `stats[\"peak_memory_bytes\"]`, Python and numpy included (each "
        "configuration runs in a fresh process); `docs/benchmarks.json` also has the "
        "process's peak after rendering (`process_max_rss_bytes`).",
        "",
        "## Mitsuba 3's error against time",
        "",
        "Progressive: passes of 1, 1, 2, 4, … spp with new seeds, each point the running "
        "average. The integrator is the scene file's (`path`, `max_depth` −1), as for the "
        "references. One untimed 1-spp warm-up render per scene first compiles the "
        "kernels (or loads them from drjit's disk cache); inside the timed renders drjit's "
        f"kernel history shows {info['kernels_compiled']} kernel(s) compiled anew and "
        f"{info['compile_ms']:.0f} ms of codegen and backend compile in all, which the "
        "times include (as they include drjit's first allocation of each larger "
        "wavefront, which any user pays too).",
        "",
    ]
    for name, r in results.items():
        lines += [
            f"**{name}** (reference: {pct(r['reference_noise'] or float('nan'))} "
            f"self-noise; warm-up {r['warm_up_s']:.2f} s)",
            "",
            "| spp | time | CPU time | relRMSE | relRMSE, every curve |",
            "|---|---|---|---|---|",
        ]
        curves = r.get("curves", [r["curve"]])
        lines += [f"| {p['spp']} | {p['time_s']:.2f} s | {p['cpu_s']:.2f} s | "
                  f"{pct(p['rel_rmse'])} | "
                  + ", ".join(pct(c[i]["rel_rmse"]) for c in curves if i < len(c)) + " |"
                  for i, p in enumerate(r["curve"])]
        lines.append("")
    if walk is not None:
        lines += walkthrough_report(walk)
    with open(os.path.join(DOCS, "benchmarks.md"), "w") as f:
        f.write("\n".join(lines))


def walkthrough_report(walk: dict) -> list[str]:
    config, mt = walk["config"], walk["mitsuba"]
    solve_s, render_s = walk["wavrad_solve_s"], walk["wavrad_view_render_s"]
    n = len(mt["times"])
    wavrad_total = solve_s + sum(render_s)
    mitsuba_total = sum(mt["times"])
    wavrad_cpu = walk["wavrad_solve_cpu_s"] + sum(walk["wavrad_view_render_cpu_s"])
    mitsuba_cpu = sum(mt["cpu_s"])
    errors = walk["errors"]
    ref_views = [int(k) for k in errors if k != "0"]
    refs = ", ".join(str(k) for k in ref_views)
    lines = [
        f"## Walkthrough: {n} views of {walk['scene']} from one solution",
        "",
        f"The camera starts at the scene's own view and dollies in through the box's open "
        f"side to just inside it, swinging left, right and up, always looking into the box "
        f"(`walkthrough_views()` in the script; images: `docs/benchmarks/walkthrough-"
        f"wavrad.png`, `walkthrough-mitsuba.png`, views row by row). wavrad solves once "
        f"(config `{config}`) and renders every view (with the view-independent gather "
        "cache, which the first view makes: its render time includes that); Mitsuba "
        "renders every view at "
        f"{mt['spp']} spp, the spp at which it reached wavrad's relRMSE on the scene's "
        "own view (rounded up to even): this assumes that the same spp gives about the same "
        "error on the other views, which the per-view noise below checks for Mitsuba.",
        "",
        "| | wavrad | Mitsuba 3 |",
        "|---|---|---|",
        f"| once | solve {solve_s:.2f} s | — |",
        f"| per view (mean) | render {np.mean(render_s):.2f} s | "
        f"{np.mean(mt['times']):.2f} s ({mt['spp']} spp) |",
        f"| {n} views | **{wavrad_total:.1f} s** | **{mitsuba_total:.1f} s** |",
        f"| Mitsuba / wavrad | | **{mitsuba_total / wavrad_total:.2f}** |",
        f"| {n} views, CPU time | {wavrad_cpu:.1f} s | {mitsuba_cpu:.1f} s "
        f"(ratio {mitsuba_cpu / wavrad_cpu:.2f}) |",
        f"| cores busy (CPU time / wall clock) | {wavrad_cpu / wavrad_total:.1f} | "
        f"{mitsuba_cpu / mitsuba_total:.1f} |",
        f"| relRMSE, view 0 (committed reference) | {pct(errors['0']['wavrad'])} | "
        f"{pct(errors['0']['mitsuba'])} (own noise {pct(mt['noise'][0])}) |",
    ]
    ratios = []
    # Mitsuba's seconds to wavrad's error on each view that has a reference:
    # view 0's from its curves, the others' scaled from their own noise.
    equal_error_s = [walk["view0_match_s"]]
    for k in ref_views:
        e = errors[str(k)]
        # Mitsuba at wavrad's error on this view, if its error ∝ spp^(-1/2).
        scale = (mt["noise"][k] / e["wavrad_corrected"]) ** 2
        ratios.append(e["wavrad_corrected"] / mt["noise"][k])
        equal_error_s.append(mt["times"][k] * scale)
        lines.append(
            f"| relRMSE, view {k} (reference of {e['reference_spp']} spp, noise "
            f"{pct(e['reference_noise'])}) | {pct(e['wavrad'])} measured, "
            f"{pct(e['wavrad_corrected'])} without the reference's noise | "
            f"{pct(mt['noise'][k])} (own noise); wavrad's error at ≈ {mt['spp'] * scale:.0f} "
            f"spp, ≈ {mt['times'][k] * scale:.1f} s (if error ∝ spp^−½) |"
        )
    lines += [
        f"| {n} views at wavrad's error on each (the mean of views 0, {refs}, times {n}) | "
        f"**{wavrad_total:.1f} s** | **{n * np.mean(equal_error_s):.1f} s** (ratio "
        f"**{n * np.mean(equal_error_s) / wavrad_total:.1f}**) |",
        f"| Mitsuba's own noise, mean (min–max) over the {n} views | | "
        f"{pct(np.mean(mt['noise']))} ({pct(min(mt['noise']))}–{pct(max(mt['noise']))}) |",
        "",
        "Errors: there are no committed references for views other than view 0, so "
        f"wavrad's error is measured on views {refs} against references rendered in this "
        f"run ({walk['reference_renders']} independent Mitsuba images at {mt['spp']} spp, "
        "averaged; "
        "their noise, estimated from the renders' pairwise differences, is subtracted in "
        "quadrature for the corrected value) and on view 0 against the committed one. "
        "Mitsuba is unbiased, so its error on each view is its noise, estimated from the "
        "difference of the two half-spp renders that make each image (view 0 is also "
        "compared with the committed reference). The references' renders are not timed.",
        "",
        f"So the walkthrough's assumption does not hold here: on views {refs} wavrad's "
        f"error is {min(ratios):.1f}–{max(ratios):.1f}× Mitsuba's at {mt['spp']} spp "
        "(Mitsuba's noise falls once the camera is inside the box, wavrad's error does "
        "not), "
        "and the comparison at the scene view's spp overstates Mitsuba's time for equal "
        "error on those views; the last column of the rows above estimates the time it "
        "would need for wavrad's error there."
        if ratios and min(ratios) > 1.5 else
        f"On views {refs} wavrad's error is {min(ratios, default=0):.1f}–"
        f"{max(ratios, default=0):.1f}× Mitsuba's at {mt['spp']} spp.",
        "",
        "| view | wavrad render | Mitsuba | Mitsuba noise |",
        "|---|---|---|---|",
    ]
    for k in range(n):
        lines.append(f"| {k} | {render_s[k]:.2f} s | {mt['times'][k]:.2f} s | "
                     f"{pct(mt['noise'][k])} |")
    lines.append("")
    return lines


def report_from_json() -> None:
    """Rewrite docs/benchmarks.md from docs/benchmarks.json (no rendering)."""
    with open(os.path.join(DOCS, "benchmarks.json")) as f:
        raw = json.load(f)
    write_report(raw["info"], raw["scenes"], raw["walkthrough"])


def to_json(x):
    if isinstance(x, dict):
        return {str(k): to_json(v) for k, v in x.items() if not isinstance(v, np.ndarray)}
    if isinstance(x, (list, tuple)):
        return [to_json(v) for v in x if not isinstance(v, np.ndarray)]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", default=SCENES,
                    help="bundled scenes (names of scenes/make_references.py)")
    ap.add_argument("--report", action="store_true",
                    help="only rewrite docs/benchmarks.md from docs/benchmarks.json")
    ap.add_argument("--worker", nargs=3, metavar=("SCENE", "CONFIG", "OUT"),
                    help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        wavrad_worker(*args.worker)
        return
    if args.report:
        report_from_json()
        return

    start = time.perf_counter()
    info = {"machine": machine(), "configs": CONFIGS, "scene_configs": SCENE_CONFIGS,
            "scene_only": SCENE_ONLY, "render_args": RENDER_ARGS}
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        # wavrad first, each configuration in its own process.
        for name in args.scenes:
            results[name] = {"wavrad": {}}
            for config in CONFIGS:
                if name not in SCENE_ONLY.get(config, [name]):
                    continue
                print(f"wavrad {name} {config}", flush=True)
                w = run_wavrad(name, config, os.path.join(tmp, name, config))
                t = w["stats"]["times"]
                w["solve_s"] = sum(v for k, v in t.items() if k != "render_s")
                results[name]["wavrad"][config] = w
                print(f"  solve {w['solve_s']:.2f} s render {w['render_s']:.2f} s "
                      f"relRMSE {100 * w['rel_rmse']:.2f} %", flush=True)

    mitsuba = Mitsuba()
    info.update(mitsuba=mitsuba.mi.__version__, drjit=mitsuba.dr.__version__,
                variant=mitsuba.variant,
                libllvm=os.environ.get("DRJIT_LIBLLVM_PATH"))
    walk = None
    for name in args.scenes:
        r = results[name]
        xml, exr, integrator = scene_files(name)
        reference = wavrad.read_exr(exr).astype(np.float64)
        loaded = mitsuba.load(xml, integrator)
        print(f"mitsuba {name}", flush=True)
        r["warm_up_s"] = mitsuba.warm_up(loaded)
        target = min(w["rel_rmse"] for w in r["wavrad"].values())
        r["curves"] = [mitsuba_curve(mitsuba, loaded, reference, target)
                       for _ in range(CURVES)]
        r["curve"] = r["curves"][0]
        r["match"] = {c: median_match(r["curves"], w["rel_rmse"])
                      for c, w in r["wavrad"].items()}
        r["reference_noise"] = REFERENCE_NOISE.get(name)
        if name == WALKTHROUGH_SCENE:
            first = WALKTHROUGH_CONFIG
            spp = 2 * math.ceil(r["match"][first]["spp"] / 2)
            mt = walkthrough(mitsuba, loaded, spp)
            errors = {"0": {"wavrad": relative_rmse(r["wavrad"][first]["views"][0], reference),
                            "mitsuba": relative_rmse(mt["views"][0], reference)}}
            for k, ref in mt["references"].items():
                e = relative_rmse(r["wavrad"][first]["views"][k], ref["image"])
                errors[str(k)] = {
                    "wavrad": e, "reference_noise": ref["noise"], "reference_spp": ref["spp"],
                    "wavrad_corrected": math.sqrt(max(0.0, e**2 - ref["noise"] ** 2)),
                }
            w = r["wavrad"][first]
            walk = {"scene": name, "reference_renders": REFERENCE_RENDERS,
                    "config": first, "wavrad_solve_s": w["solve_s"],
                    "wavrad_solve_cpu_s": w["solve_cpu_s"],
                    "wavrad_view_render_s": w["view_render_s"],
                    "wavrad_view_render_cpu_s": w["view_render_cpu_s"],
                    "mitsuba": mt, "errors": errors, "views": walkthrough_views(),
                    "view0_match_s": r["match"][first]["time_s"]}
            os.makedirs(IMAGES, exist_ok=True)
            wavrad.write_image(os.path.join(IMAGES, "walkthrough-wavrad.png"),
                               mosaic(r["wavrad"][first]["views"]))
            wavrad.write_image(os.path.join(IMAGES, "walkthrough-mitsuba.png"),
                               mosaic(mt["views"]))
    info["compile_ms"] = mitsuba.compile_ms
    info["kernels_compiled"] = mitsuba.kernels_compiled
    info["machine"]["load_average_end"] = os.getloadavg()
    info["total_s"] = time.perf_counter() - start
    write_report(info, results, walk)
    raw = {"info": info, "scenes": results, "walkthrough": walk}
    with open(os.path.join(DOCS, "benchmarks.json"), "w") as f:
        json.dump(to_json(raw), f, indent=1)
        f.write("\n")
    print(f"wrote docs/benchmarks.md, docs/benchmarks.json ({info['total_s'] / 60:.1f} min)")


if __name__ == "__main__":
    main()
