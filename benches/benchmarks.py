#!/usr/bin/env python3
"""End-to-end benchmark: wavrad against Mitsuba 3's path tracer at its best,
in one run on one machine. Writes docs/benchmarks.md (tables) and
docs/benchmarks.json (every raw number).

Each bundled scene (SCENES) is rendered at each resolution (256² and 512²
by default) with a box pixel filter by both programs, from the same XML:
the bundled file with its film's filter made `box` and its sampler the one
under test, written to a temporary folder.

* Reference: REFERENCE_RENDERS independent Mitsuba renders (REFERENCE_SAMPLER,
  the scene's reference integrator), averaged; their pairwise differences
  measure the average's own noise on any set of pixels, which is taken out
  of every error below in quadrature. References are cached under
  out/bench/references/ (keyed by scene, resolution, spp and the XML's hash),
  since they cost more than everything else; the timed renders never reuse
  their seeds.
* Masks: pixels whose reference sees an emitter directly (Mitsuba's `path`
  with max_depth 1) are left out of the headline error, which both programs
  get exactly; the all-pixel error is reported beside it. Scenes with
  `region="indirect"` also report the pixels lit only indirectly (their
  direct-only render, max_depth 2, below 1 % of the reference).
* wavrad: each configuration (CONFIGS) in its own process: solve, render
  (gather mode, default camera rays), then `direct` and `smooth` renders of
  the same solution (the view-independent solution, timed apart).
* Mitsuba 3 (llvm_ad_rgb): for every sampler in SAMPLERS and every
  integrator of the scene, single renders at 1, 2, 4, ... spp (each its own
  render with new seeds, as a user would run it), timed without drjit's
  kernel compilation (which its disk cache saves on a second run), until
  the error is below wavrad's or the time cap; the time to wavrad's error is
  interpolated log-log between the two renders that bracket it. The
  headline compares wavrad with the fastest sampler/integrator; the others
  are in the JSON and the per-sampler table.
* Walkthrough (--walkthrough): VIEWS views of WALKTHROUGH_SCENE from one
  wavrad solution against Mitsuba's best sampler at the spp that reached
  wavrad's error on the scene's own view.

Usage: make bench   (installs benches/requirements.txt into .venv, then
       .venv/bin/python benches/benchmarks.py [--scenes NAME ...] [--res 256 ...])
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import hashlib
import json
import math
import os
import platform
import re
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

import wavrad


@dataclasses.dataclass(frozen=True)
class SceneSpec:
    """A bundled scene as the benchmark runs it."""

    xml: str  # relative to scenes/
    integrators: tuple[str, ...]  # Mitsuba integrators timed, the likely fastest first
    reference_integrator: str
    reference_spp: int  # per reference render
    region: str | None = None  # "indirect": also report the indirectly lit pixels
    # -D values for both programs (besides res and spp).
    defines: tuple[tuple[str, str], ...] = ()


SCENES: dict[str, SceneSpec] = {
    "cornell-box": SceneSpec("cornell-box/scene.xml", ("path",), "path", 4096),
    "glossy-cornell-box": SceneSpec("glossy-cornell-box/scene.xml", ("path",), "path", 2048),
    # A solid glass sphere: camera rays' specular chains, photons' caustic.
    "glass-cornell-box": SceneSpec("glass-cornell-box/scene.xml", ("path",), "path", 4096),
    # The same sphere frosted (roughdielectric): sampled microfacet normals.
    "rough-glass-cornell-box": SceneSpec("rough-glass-cornell-box/scene.xml", ("path",), "path",
                                         4096),
    # The paper's experiment: emitter -> Ward reflector -> diffuse receiver,
    # seen from the receiver. Its receiver is lit mostly through the
    # reflector, a path the light tracer samples far better.
    "figure3-specular": SceneSpec("figure3/specular.xml", ("ptracer", "path"), "ptracer",
                                  32768, region="indirect"),
}
# Scenes not in the repository (--external NAME=XML: public scenes keep their
# licence where they are): path tracing with every bounce, as the references.
EXTERNAL_ENV = "WAVRAD_BENCH_EXTERNAL"
RESOLUTIONS = (256, 512)
# Mitsuba 3's samplers that suit path tracing, the likely fastest first: a
# curve stops once one render takes longer than the fastest time to wavrad's
# error so far, reached or extrapolated (its own time is then extrapolated).
SAMPLERS = ("multijitter", "orthogonal", "stratified", "ldsampler", "independent")
REFERENCE_SAMPLER = "multijitter"
REFERENCE_RENDERS = 4
# wavrad configurations: name -> keyword arguments of wavrad.solve.
CONFIGS: dict[str, dict[str, object]] = {
    # Default settings: the final gather reads the view-independent gather
    # cache where the light it gathers varies slowly.
    "default": {},
    # The default solve rendered with every gathering camera ray gathering.
    "per-ray": {},
}
# Keyword arguments of Solution.render besides mode="gather", per configuration.
RENDER_ARGS: dict[str, dict[str, object]] = {"per-ray": {"gather_cache": False}}
# Modes rendered from the default configuration's solution besides gather:
# the view-independent solution, read without a per-pixel final gather.
SOLUTION_MODES = ("direct", "smooth")
WALKTHROUGH_SCENE = "glossy-cornell-box"
WALKTHROUGH_CONFIG = "default"
VIEWS = 16
MAX_LANES = 1 << 25  # pixels x spp per mi.render call (memory)
CURVE_TIME_CAP_S = 120.0  # per render
CURVE_MAX_SPP = 1 << 16
SEED_BASE = {"reference": 1_000_000, "timed": 2_000_000, "mask": 3_000_000}

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES_DIR = os.path.join(ROOT, "scenes")
DOCS = os.path.join(ROOT, "docs")
CACHE = os.path.join(ROOT, "out", "bench", "references")


def add_external(specs: list[str]) -> None:
    """Add scenes given as NAME=XML to SCENES (and to the environment, for
    the wavrad workers)."""
    for spec in specs:
        name, _, xml = spec.partition("=")
        if not xml or not os.path.isfile(xml):
            sys.exit(f"benchmarks.py: --external {spec}: expected NAME=XML of an existing file")
        with open(xml) as f:
            declared = re.findall(r'<default\s+name="(\w+)"', f.read())
        defines = (("max_depth", "-1"),) if "max_depth" in declared else ()
        SCENES[name] = SceneSpec(os.path.abspath(xml), ("path",), "path", 2048,
                                 defines=defines)
    os.environ[EXTERNAL_ENV] = json.dumps(specs)


def bench_xml(name: str, sampler: str, folder: str) -> str:
    """The scene's XML with a box filter and `sampler`, written to `folder`
    (with a `<path>` to its own folder, for the files it names)."""
    source = os.path.join(SCENES_DIR, SCENES[name].xml)
    with open(source) as f:
        text = f.read()
    text, filters = re.subn(r'<rfilter type="\w+"\s*/>', '<rfilter type="box"/>', text)
    text, samplers = re.subn(r'<sampler type="\w+">', f'<sampler type="{sampler}">', text)
    # A film sized by `resx` and `resy` (Bitterli's scenes) takes the
    # benchmark's square `res` like the bundled ones.
    declared = re.findall(r'<default\s+name="(\w+)"', text)
    if "res" not in declared and {"resx", "resy"} <= set(declared):
        text = text.replace("$resx", "$res").replace("$resy", "$res")
        text = re.sub(r'(<default\s+name="resx")', r'<default name="res" value="256"/>\1', text,
                      count=1)
    text, scenes = re.subn(r'(<scene\b[^>]*>)',
                           rf'\1<path value="{os.path.dirname(source)}"/>', text, count=1)
    if filters != 1 or samplers != 1 or scenes != 1:
        sys.exit(f"benchmarks.py: {source} needs one <rfilter .../> and one "
                 "<sampler type=...>")
    path = os.path.join(folder, f"{name}-{sampler}.xml")
    with open(path, "w") as f:
        f.write(text)
    return path


def scene_name(xml: str) -> str:
    """The scene a `bench_xml` file was written for."""
    return os.path.basename(xml).rsplit("-", 1)[0]


def cpu_seconds() -> float:
    """CPU time of this process so far, every thread (user + system)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


# Errors


def rel_rmse(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None) -> float:
    """sqrt(mean((a - b)²)) / mean(b) over the pixels of `mask` (all if None)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if mask is not None:
        a, b = a[mask], b[mask]
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.mean(b))


@dataclasses.dataclass
class Reference:
    """A reference image, the renders it averages, and its pixel sets."""

    renders: list[np.ndarray]
    masks: dict[str, np.ndarray]  # "all", "no-emitter", maybe "indirect"
    spp: int  # of the average
    seconds: float

    @property
    def image(self) -> np.ndarray:
        return np.mean(self.renders, axis=0)

    def noise(self, mask: str) -> float:
        """relRMSE of the average against its expectation on `mask`, from
        the renders' pairwise differences (each pair's difference has twice
        one render's variance; the average has 1/n of it)."""
        m, n = self.masks[mask], len(self.renders)
        scale = float(self.image[m].mean())
        single = math.sqrt(np.mean([
            np.mean((self.renders[i][m].astype(np.float64) - self.renders[j][m]) ** 2) / 2
            for i in range(n) for j in range(i + 1, n)])) / scale
        return single / math.sqrt(n)

    def error(self, image: np.ndarray, mask: str) -> dict[str, float]:
        """The image's relRMSE on `mask`, measured and with the reference's
        own noise taken out in quadrature."""
        measured, noise = rel_rmse(image, self.image, self.masks[mask]), self.noise(mask)
        return {"measured": measured, "corrected": math.sqrt(max(0.0, measured**2 - noise**2))}


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
        mi.set_log_level(mi.LogLevel.Error)  # not the samplers' rounding of spp
        dr.set_flag(dr.JitFlag.KernelHistory, True)
        self.loaded: dict[tuple, tuple] = {}
        self.seeds = dict(SEED_BASE)
        self.compile_s = 0.0  # codegen + backend compile inside timed renders, left out

    def load(self, xml: str, res: int, spp: int, integrator: str, max_depth: int = -1):
        """(scene, integrator or None, the sampler's own spp) loaded once."""
        key = (xml, res, spp, integrator, max_depth)
        if key not in self.loaded:
            scene = self.mi.load_file(xml, res=res, spp=spp,
                                      **dict(SCENES[scene_name(xml)].defines))
            integ = None
            if integrator != "path" or max_depth != -1:
                integ = self.mi.load_dict({"type": integrator, "max_depth": max_depth})
            actual = int(scene.sensors()[0].sampler().sample_count())
            self.loaded[key] = (scene, integ, actual)
        return self.loaded[key]

    def render(self, xml: str, res: int, spp: int, integrator: str, purpose: str,
               max_depth: int = -1, view=None) -> tuple[np.ndarray, int, float, float]:
        """An image of about `spp` samples per pixel (in passes of at most
        MAX_LANES samples, each with new seeds): (image, its spp as the
        sampler rounds it, wall-clock seconds of the mi.render calls less
        drjit's kernel compilation, CPU seconds)."""
        pass_spp = spp
        while pass_spp > 1 and pass_spp * res * res > MAX_LANES:
            pass_spp //= 2
        scene, integ, actual = self.load(xml, res, pass_spp, integrator, max_depth)
        if view is not None:
            self.set_view(scene, *view)
        passes = max(1, round(spp / actual))
        total, seconds, cpu = None, 0.0, 0.0
        self.dr.kernel_history()  # drop older entries
        for _ in range(passes):
            seed = self.seeds[purpose]
            self.seeds[purpose] += 1
            clock, cpu_start = time.perf_counter(), cpu_seconds()
            image = self.mi.render(scene, integrator=integ, seed=seed) if integ else \
                self.mi.render(scene, seed=seed)
            image = np.array(image, dtype=np.float64)
            seconds += time.perf_counter() - clock
            cpu += cpu_seconds() - cpu_start
            total = image if total is None else total + image
        compile_s = sum(k.get("codegen_time", 0.0) + k.get("backend_time", 0.0)
                        for k in self.dr.kernel_history()) / 1000.0
        self.compile_s += compile_s
        return total / passes, passes * actual, max(0.0, seconds - compile_s), cpu

    def set_view(self, scene, origin, target, up) -> None:
        params = self.mi.traverse(scene)
        key = next(k for k in params.keys() if k.endswith(".x_fov")).replace(".x_fov", ".to_world")
        params[key] = self.mi.ScalarTransform4f().look_at(origin=origin, target=target, up=up)
        params.update()


def source_hash(name: str) -> str:
    """Hash of the scene's own XML and its -D values (the cache key of its
    references)."""
    with open(os.path.join(SCENES_DIR, SCENES[name].xml), "rb") as f:
        data = f.read() + repr((SCENES[name].defines, SCENES[name].reference_integrator,
                                REFERENCE_SAMPLER, REFERENCE_RENDERS)).encode()
    return hashlib.sha256(data).hexdigest()[:16]


def reference(mitsuba: Mitsuba, name: str, res: int, folder: str, spp: int) -> Reference:
    """The scene's reference at `res` (cached under out/bench/references/)."""
    spec = SCENES[name]
    xml = bench_xml(name, REFERENCE_SAMPLER, folder)
    stem = f"{name}-{res}-{spp}-{source_hash(name)}"
    path = os.path.join(CACHE, stem + ".npz")
    if os.path.exists(path):
        data = np.load(path)
        renders = [data[f"render{k}"] for k in range(REFERENCE_RENDERS)]
        masks = {k[5:]: data[k] for k in data.files if k.startswith("mask_")}
        return Reference(renders, masks, int(data["spp"]), float(data["seconds"]))
    print(f"  reference {name} {res}²: {REFERENCE_RENDERS} x {spp} spp "
          f"({REFERENCE_SAMPLER}, {spec.reference_integrator})", flush=True)
    clock = time.perf_counter()
    renders, actual = [], 0
    for k in range(REFERENCE_RENDERS):
        image, actual, seconds, _ = mitsuba.render(xml, res, spp, spec.reference_integrator,
                                                   "reference")
        renders.append(image.astype(np.float32))
        print(f"    render {k + 1}/{REFERENCE_RENDERS}: {actual} spp, {seconds:.0f} s",
              flush=True)
    mean = np.mean(renders, axis=0)
    emitted, *_ = mitsuba.render(xml, res, 64, "path", "mask", max_depth=1)
    pixel = np.ones(mean.shape[:2], bool)
    masks = {"all": pixel, "no-emitter": emitted.max(axis=2) <= 0.0}
    if spec.region == "indirect":
        direct, *_ = mitsuba.render(xml, res, 1024, "path", "mask", max_depth=2)
        lum, dlum = mean.mean(axis=2), direct.mean(axis=2)
        masks["indirect"] = masks["no-emitter"] & (lum > 0.01 * lum.mean()) & (dlum < 0.01 * lum)
    seconds = time.perf_counter() - clock
    os.makedirs(CACHE, exist_ok=True)
    tmp = path + ".tmp.npz"
    np.savez_compressed(tmp, spp=REFERENCE_RENDERS * actual, seconds=seconds,
                        **{f"render{k}": r for k, r in enumerate(renders)},
                        **{f"mask_{k}": m for k, m in masks.items()})
    os.replace(tmp, path)
    wavrad.write_image(os.path.join(CACHE, stem + ".exr"), mean)
    return Reference(renders, masks, REFERENCE_RENDERS * actual, seconds)


def mitsuba_curve(mitsuba: Mitsuba, xml: str, res: int, integrator: str, ref: Reference,
                  target: float, cap_s: float) -> list[dict]:
    """Single renders at 1, 2, 4, ... spp (as the sampler rounds them)
    until the corrected error (no emitter pixels) is below `target`, or a
    render takes more than `cap_s`, or the spp cap."""
    mitsuba.render(xml, res, 1, integrator, "timed")  # warm-up: compiles the kernels
    curve, spp = [], 1
    while True:
        image, actual, seconds, cpu = mitsuba.render(xml, res, spp, integrator, "timed")
        errors = {m: ref.error(image, m) for m in ref.masks}
        error = errors["no-emitter"]["corrected"]
        curve.append({"spp": actual, "time_s": seconds, "cpu_s": cpu, "rel_rmse": error,
                      "errors": errors})
        print(f"    {actual:6d} spp {seconds:7.2f} s ({cpu:7.2f} s CPU) "
              f"relRMSE {100 * error:.2f} %", flush=True)
        if error < target or seconds > cap_s or actual >= CURVE_MAX_SPP:
            return curve
        spp = 2 * actual


def match(curve: list[dict], target: float, key: str = "rel_rmse") -> dict:
    """Mitsuba's spp and time at error = target: log-log interpolation
    between the first render below target and the one before it; past the
    curve's end, extrapolated with error ∝ spp^(-1/2) and time ∝ spp."""
    keys = ("spp", "time_s", "cpu_s")
    points = [p for p in curve if p[key] > 0]
    for before, after in zip(points, points[1:]):
        if before[key] >= target > after[key]:
            f = math.log(target / before[key]) / math.log(after[key] / before[key])
            out = {k: math.exp((1 - f) * math.log(before[k]) + f * math.log(after[k]))
                   for k in keys}
            return {**out, "method": "interpolated"}
    if curve[0][key] < target:
        return {**{k: curve[0][k] for k in keys}, "method": "first point"}
    last = points[-1]
    scale = (last[key] / target) ** 2
    return {**{k: last[k] * scale for k in keys}, "method": "extrapolated"}


# wavrad, one process per (scene, resolution, configuration)


def wavrad_worker(name: str, res: int, config: str, out: str) -> None:
    xml = bench_xml(name, "independent", out)
    scene = wavrad.load_scene(xml, res=res, **dict(SCENES[name].defines))
    clock, cpu = time.perf_counter(), cpu_seconds()
    solution = wavrad.solve(scene, **CONFIGS[config])
    solve_wall, solve_cpu = time.perf_counter() - clock, cpu_seconds() - cpu
    walk = name == WALKTHROUGH_SCENE and config == WALKTHROUGH_CONFIG and res == RESOLUTIONS[0]
    views = walkthrough_views() if walk and os.environ.get("WAVRAD_BENCH_WALK") else [None]
    result = {"stats": solution.stats, "solve_wall_s": solve_wall, "solve_cpu_s": solve_cpu,
              "views": []}
    for k, view in enumerate(views):
        origin, target, up = view or (None, None, None)
        clock, cpu = time.perf_counter(), cpu_seconds()
        image = solution.render(mode="gather", origin=origin, target=target, up=up,
                                **RENDER_ARGS.get(config, {}))
        result["views"].append({"render_s": time.perf_counter() - clock,
                                "render_cpu_s": cpu_seconds() - cpu})
        np.save(os.path.join(out, f"view{k}.npy"), image)
    if config == "default":
        result["modes"] = {}
        for mode in SOLUTION_MODES:
            clock = time.perf_counter()
            np.save(os.path.join(out, f"{mode}.npy"), solution.render(mode=mode))
            result["modes"][mode] = {"render_s": time.perf_counter() - clock}
    with open(os.path.join(out, "result.json"), "w") as f:
        json.dump(result, f)


def run_wavrad(name: str, res: int, config: str, out: str) -> dict:
    """Run the worker in a fresh process; adds its peak resident memory."""
    os.makedirs(out, exist_ok=True)
    args = [sys.executable, os.path.abspath(__file__), "--worker", name, str(res), config, out]
    process = subprocess.Popen(args)
    _, status, usage = os.wait4(process.pid, 0)
    if status != 0:
        sys.exit(f"wavrad worker {name} {res} {config} failed (status {status})")
    with open(os.path.join(out, "result.json")) as f:
        result = json.load(f)
    result["process_max_rss_bytes"] = usage.ru_maxrss * 1024
    result["images"] = [np.load(os.path.join(out, f"view{k}.npy"))
                        for k in range(len(result["views"]))]
    for mode in result.get("modes", {}):
        result["modes"][mode]["image"] = np.load(os.path.join(out, f"{mode}.npy"))
    view = result["views"][0]
    result["render_s"], result["render_cpu_s"] = view["render_s"], view["render_cpu_s"]
    result["total_s"] = result["solve_wall_s"] + result["render_s"]
    result["total_cpu_s"] = result["solve_cpu_s"] + result["render_cpu_s"]
    return result


# Walkthrough


def walkthrough_views(n: int = VIEWS) -> list[tuple[tuple[float, ...], ...]]:
    """(origin, target, up) of n views: from the scene's own camera, outside
    the box's open side, dollying in to just inside the box while circling
    left and right and up, always looking into the box."""
    views = []
    for k in range(n):
        t = k / (n - 1)
        s, h = math.sin(2 * math.pi * t), math.sin(math.pi * t)
        views.append(((0.55 * s, 0.3 * h, 3.9 - 3.1 * t), (-0.35 * s, -0.3 * h, -t),
                      (0.0, 1.0, 0.0)))
    return views


def walkthrough(mitsuba: Mitsuba, folder: str, res: int, best: dict, spp: int,
                wavrad_run: dict) -> dict:
    """Each view: Mitsuba's best sampler at `spp` (two independent halves,
    whose difference is its own noise) and wavrad's error against their
    average, less that average's noise (so both errors are against the
    expectation)."""
    xml = bench_xml(WALKTHROUGH_SCENE, best["sampler"], folder)
    half = max(1, spp // 2)
    views = []
    for k, view in enumerate(walkthrough_views()):
        a, n, ta, ca = mitsuba.render(xml, res, half, best["integrator"], "timed", view=view)
        b, _, tb, cb = mitsuba.render(xml, res, half, best["integrator"], "timed", view=view)
        mean = 0.5 * (a + b)
        # relRMSE of one half is relRMSE(a, b)/sqrt(2); of their mean, half of it.
        noise = 0.5 * rel_rmse(a, b) * float(b.mean()) / float(mean.mean())
        measured = rel_rmse(wavrad_run["images"][k], mean)
        wavrad_error = math.sqrt(max(0.0, measured**2 - noise**2))
        # Mitsuba's time to wavrad's error on this view, if error ∝ spp^(-1/2).
        equal = (ta + tb) * (noise / max(wavrad_error, 1e-9)) ** 2
        views.append({"spp": 2 * n, "time_s": ta + tb, "cpu_s": ca + cb, "noise": noise,
                      "wavrad_error": wavrad_error, "mitsuba_time_to_wavrad_error_s": equal,
                      "wavrad_render_s": wavrad_run["views"][k]["render_s"]})
        print(f"  view {k:2d}: Mitsuba {ta + tb:6.2f} s noise {100 * noise:.2f} %, wavrad "
              f"{100 * wavrad_error:.2f} %", flush=True)
    mitsuba.set_view(mitsuba.load(xml, res, half, best["integrator"])[0],
                     *walkthrough_views()[0])
    return {"views": views, "sampler": best["sampler"], "integrator": best["integrator"],
            "wavrad_solve_s": wavrad_run["solve_wall_s"]}


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


def pct(x: float) -> str:
    return f"{100 * x:.2f} %"


def write_report(info: dict, runs: list[dict], walk: dict | None) -> None:
    m = info["machine"]
    commit = m["wavrad_commit"][:12] + (" + uncommitted changes" if m["uncommitted_changes"]
                                        else "")
    lines = [
        "# wavrad against Mitsuba 3 at its best: end-to-end benchmark",
        "",
        f"Written by `benches/benchmarks.py` (`make bench`), {m['date']}: {m['cpu']}, "
        f"`os.cpu_count()` = {m['cpu_count']}, wavrad {commit}, Python {m['python']}, "
        f"Mitsuba {info['mitsuba']} (drjit {info['drjit']}, variant `{info['variant']}`). "
        f"Load average at start {m['load_average_start'][0]:.2f}, at end "
        f"{m['load_average_end'][0]:.2f} (both programs use every core, so other jobs on "
        "the machine slow both). One run; raw numbers: `docs/benchmarks.json`. The whole "
        f"run took {info['total_s'] / 60:.1f} min.",
        "",
        "Both programs render the same XML: the bundled scene with a box pixel filter, at "
        "the resolution shown. Error = relRMSE, sqrt(mean((a−b)²)) / mean(b) over pixels "
        "and channels, against a reference of "
        f"{REFERENCE_RENDERS} independent Mitsuba renders ({REFERENCE_SAMPLER} sampler) "
        "whose own noise, measured from their differences, is taken out of every error "
        "in quadrature. The headline leaves out the pixels that see an emitter directly "
        "(both programs get them exactly); the all-pixel error is beside it. Mitsuba is "
        "timed with every sampler in "
        f"{', '.join(f'`{s}`' for s in SAMPLERS)} and the integrators listed, one render "
        "per spp (1, 2, 4, …), its time without drjit's kernel compilation; the headline "
        "takes the fastest to wavrad's error.",
        "",
        "## Time to the same error",
        "",
        "| scene | wavrad config | wavrad error (all pixels) | wavrad solve + render "
        "(CPU) | Mitsuba's fastest | its spp | its time (CPU) | **Mitsuba / wavrad** | "
        "same, CPU time |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        for config, w in r["wavrad"].items():
            best = r["best"][config]
            lines.append(
                f"| {r['scene']} {r['res']}² | {config} | "
                f"{pct(w['errors']['no-emitter']['corrected'])} "
                f"({pct(w['errors']['all']['corrected'])}) | "
                f"{w['solve_wall_s']:.2f} + {w['render_s']:.2f} s "
                f"({w['total_cpu_s']:.1f} s) | `{best['sampler']}`, `{best['integrator']}` | "
                f"{best['spp']:.0f} | {best['time_s']:.2f} s ({best['cpu_s']:.1f} s) | "
                f"**{best['time_s'] / w['total_s']:.2f}** | "
                f"{best['cpu_s'] / w['total_cpu_s']:.2f} |")
    lines += [
        "",
        "wavrad's time: `wavrad.solve` and `Solution.render(mode=\"gather\")` (default: "
        "the gather cache, its texels' gathers included; config `per-ray`: "
        "`gather_cache=False`, every gathering camera ray gathers), wall "
        "clock and CPU time of the process, each configuration in a fresh process. "
        "Mitsuba's: the wall clock of its `mi.render` calls, interpolated log-log between "
        "the two renders that bracket wavrad's error (`extrapolated` below: a curve "
        f"stops past {info['cap_s']:.0f} s, or past the fastest sampler's time, "
        "and is extrapolated with error ∝ spp^−½).",
        "",
        "### Every sampler: Mitsuba's time to the default configuration's error",
        "",
        "| scene | integrator | " + " | ".join(SAMPLERS) + " |",
        "|---|---|" + "---|" * len(SAMPLERS),
    ]
    for r in runs:
        for integrator in r["integrators"]:
            cells = []
            for sampler in SAMPLERS:
                mt = r["matches"]["default"][f"{sampler}/{integrator}"]
                note = "" if mt["method"] == "interpolated" else f" ({mt['method']})"
                cells.append(f"{mt['time_s']:.1f} s, {mt['spp']:.0f} spp{note}")
            lines.append(f"| {r['scene']} {r['res']}² | `{integrator}` | " + " | ".join(cells)
                         + " |")
    if any("indirect" in r["reference_noise"] for r in runs):
        lines += [
            "",
            "### Pixels lit only indirectly",
            "",
            "The pixels whose direct-only render (Mitsuba, `max_depth` 2) is below 1 % of "
            "the reference: on the paper's experiment, the receiver lit through the "
            "reflector.",
            "",
            "| scene | wavrad config | wavrad error | Mitsuba's fastest there | its time | "
            "Mitsuba / wavrad |",
            "|---|---|---|---|---|---|",
        ]
        for r in runs:
            if "indirect" not in r["reference_noise"]:
                continue
            for config, w in r["wavrad"].items():
                best = r["best_indirect"][config]
                lines.append(
                    f"| {r['scene']} {r['res']}² | {config} | "
                    f"{pct(w['errors']['indirect']['corrected'])} | `{best['sampler']}`, "
                    f"`{best['integrator']}` | {best['time_s']:.2f} s | "
                    f"**{best['time_s'] / w['total_s']:.2f}** |")
    lines += [
        "",
        "## The solution without a final gather",
        "",
        "The default configuration's solution rendered with no final gather, in `smooth` "
        "mode (the solution alone, reconstructed: what a lightmap holds) and `direct` mode "
        "(the light straight from the emitters per camera ray over the rest of the "
        "solution: what a viewer with shadow rays over a baked solution shows).",
        "",
        "| scene | mode | error (all pixels) | render |",
        "|---|---|---|---|",
    ]
    for r in runs:
        for mode, x in r["wavrad"]["default"].get("modes", {}).items():
            lines.append(f"| {r['scene']} {r['res']}² | `{mode}` | "
                         f"{pct(x['errors']['no-emitter']['corrected'])} "
                         f"({pct(x['errors']['all']['corrected'])}) | {x['render_s']:.2f} s |")
    lines += [
        "",
        "## References and counts",
        "",
        "| scene | reference spp | its noise, no emitter (all) | elements | links | "
        "three-point interactions | kernels | wavrad peak memory |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        s = r["wavrad"]["default"]["stats"]
        n = r["reference_noise"]
        lines.append(
            f"| {r['scene']} {r['res']}² | {r['reference_spp']} | {pct(n['no-emitter'])} "
            f"({pct(n['all'])}) | {s['two_point_nodes']:,} | {s['two_point_interactions']:,} | "
            f"{s['three_point_interactions']:,} | {s['times']['kernels_s']:.2f} s | "
            f"{(s.get('peak_memory_bytes') or 0) / 2**20:.0f} MiB |")
    lines += ["", "## Mitsuba's error against time", ""]
    for r in runs:
        lines += [f"**{r['scene']} {r['res']}²**", "",
                  "| sampler, integrator | spp: time, error |", "|---|---|"]
        for key, curve in r["curves"].items():
            lines.append(f"| `{key}` | " + "; ".join(
                f"{p['spp']}: {p['time_s']:.2f} s, {pct(p['rel_rmse'])}" for p in curve) + " |")
        lines.append("")
    if walk is not None:
        views = walk["views"]
        wavrad_total = walk["wavrad_solve_s"] + sum(v["wavrad_render_s"] for v in views)
        equal = sum(v["mitsuba_time_to_wavrad_error_s"] for v in views)
        lines += [
            f"## Walkthrough: {len(views)} views of {WALKTHROUGH_SCENE} from one solution",
            "",
            f"wavrad solves once (config `{WALKTHROUGH_CONFIG}`) and renders every view; "
            f"Mitsuba (`{walk['sampler']}`, `{walk['integrator']}`) renders each view twice "
            "at half the spp that reached wavrad's error on the scene's own view. Each "
            "view's error is against the average of Mitsuba's two halves, less that "
            "average's noise; Mitsuba's time to wavrad's error on each view scales its "
            "time by (its noise / wavrad's error)².",
            "",
            f"wavrad, {len(views)} views: **{wavrad_total:.1f} s**; Mitsuba at wavrad's "
            f"error on each view: **{equal:.1f} s**; ratio **{equal / wavrad_total:.1f}**.",
            "",
            "| view | wavrad render | wavrad error | Mitsuba time | Mitsuba noise | "
            "Mitsuba at wavrad's error |",
            "|---|---|---|---|---|---|",
        ]
        lines += [f"| {k} | {v['wavrad_render_s']:.2f} s | {pct(v['wavrad_error'])} | "
                  f"{v['time_s']:.2f} s | {pct(v['noise'])} | "
                  f"{v['mitsuba_time_to_wavrad_error_s']:.1f} s |" for k, v in enumerate(views)]
        lines.append("")
    with open(os.path.join(DOCS, "benchmarks.md"), "w") as f:
        f.write("\n".join(lines))


def to_json(x):
    if isinstance(x, dict):
        return {str(k): to_json(v) for k, v in x.items() if not isinstance(v, np.ndarray)}
    if isinstance(x, (list, tuple)):
        return [to_json(v) for v in x if not isinstance(v, np.ndarray)]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x


def log_report(path: str) -> None:
    """Print the headline (wavrad against each sampler at wavrad's error)
    from the lines a run printed, for a run cut short before its report."""
    runs, curve, name = {}, [], ""
    for line in open(path).read().splitlines():
        if m := re.match(r"(\S+ \d+)²: reference \d+ spp", line):
            name = m.group(1)
            runs[name] = {"wavrad": {}, "curves": {}}
        elif m := re.match(r"\s+wavrad (\w+): solve ([\d.]+) s render ([\d.]+) s error ([\d.]+) %",
                           line):
            runs[name]["wavrad"][m.group(1)] = [float(x) for x in m.groups()[1:]]
        elif m := re.match(r"\s+mitsuba (\w+) (\w+)$", line):
            curve = runs[name]["curves"].setdefault(f"{m.group(1)}/{m.group(2)}", [])
        elif m := re.match(r"\s+(\d+) spp\s+([\d.]+) s \(\s*([\d.]+) s CPU\) relRMSE ([\d.]+) %",
                           line):
            spp, seconds, cpu, error = (float(x) for x in m.groups())
            curve.append({"spp": spp, "time_s": seconds, "cpu_s": cpu, "rel_rmse": error / 100})
    for name, run in runs.items():
        for config, (solve, render, error) in run["wavrad"].items():
            matches = {k: match(c, error / 100) for k, c in run["curves"].items() if c}
            best = min(matches, key=lambda k: matches[k]["time_s"])
            mt = matches[best]
            print(f"{name}² {config}: wavrad {error:.2f} % in {solve:.2f} + {render:.2f} s; "
                  f"fastest {best} {mt['time_s']:.1f} s ({mt['spp']:.0f} spp): "
                  f"{mt['time_s'] / (solve + render):.1f}×")
            for key, mt in matches.items():
                print(f"    {key}: {mt['time_s']:.1f} s, {mt['spp']:.0f} spp ({mt['method']})")


def bench_scene(mitsuba: Mitsuba, name: str, res: int, folder: str, reference_spp: int,
                cap_s: float = CURVE_TIME_CAP_S) -> dict:
    """One scene at one resolution: reference, wavrad, Mitsuba's curves
    (no render longer than `cap_s`)."""
    spec = SCENES[name]
    ref = reference(mitsuba, name, res, folder, reference_spp)
    run = {"scene": name, "res": res, "integrators": list(spec.integrators),
           "reference_spp": ref.spp, "reference_noise": {m: ref.noise(m) for m in ref.masks},
           "wavrad": {}}
    print(f"{name} {res}²: reference {ref.spp} spp, noise "
          f"{pct(run['reference_noise']['no-emitter'])}", flush=True)
    for config in CONFIGS:
        w = run_wavrad(name, res, config, os.path.join(folder, f"{name}-{res}-{config}"))
        w["errors"] = {m: ref.error(w["images"][0], m) for m in ref.masks}
        for x in w.get("modes", {}).values():
            x["errors"] = {m: ref.error(x["image"], m) for m in ref.masks}
        run["wavrad"][config] = w
        print(f"  wavrad {config}: solve {w['solve_wall_s']:.2f} s render {w['render_s']:.2f} s"
              f" error {pct(w['errors']['no-emitter']['corrected'])}", flush=True)
    target = min(w["errors"]["no-emitter"]["corrected"] for w in run["wavrad"].values())
    run["curves"], fastest = {}, cap_s
    for integrator in spec.integrators:
        for sampler in SAMPLERS:
            print(f"  mitsuba {sampler} {integrator}", flush=True)
            xml = bench_xml(name, sampler, folder)
            curve = mitsuba_curve(mitsuba, xml, res, integrator, ref, target,
                                  min(cap_s, fastest))
            run["curves"][f"{sampler}/{integrator}"] = curve
            # Reached or extrapolated: a render slower than that, still
            # above the target, cannot reach it sooner.
            fastest = min(fastest, match(curve, target)["time_s"])
    run["matches"], run["best"], run["best_indirect"] = {}, {}, {}
    for config, w in run["wavrad"].items():
        run["matches"][config] = {
            key: match(curve, w["errors"]["no-emitter"]["corrected"])
            for key, curve in run["curves"].items()}
        key = min(run["matches"][config], key=lambda k: run["matches"][config][k]["time_s"])
        sampler, integrator = key.split("/")
        run["best"][config] = {**run["matches"][config][key], "sampler": sampler,
                               "integrator": integrator}
        if "indirect" in ref.masks:
            for curve in run["curves"].values():
                for p in curve:
                    p["indirect"] = p["errors"]["indirect"]["corrected"]
            wanted = w["errors"]["indirect"]["corrected"]
            region = {k: match(c, wanted, "indirect") for k, c in run["curves"].items()}
            key = min(region, key=lambda k: region[k]["time_s"])
            sampler, integrator = key.split("/")
            run["best_indirect"][config] = {**region[key], "sampler": sampler,
                                            "integrator": integrator}
    return run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--external", nargs="+", default=[], metavar="NAME=XML",
                    help="scenes not in the repository, e.g. Mitsuba's "
                    "scenes/cbox/cbox.xml from its data repository")
    ap.add_argument("--scenes", nargs="+", default=None,
                    help=f"bundled or external scenes (default: all; bundled: {', '.join(SCENES)})")
    ap.add_argument("--res", nargs="+", type=int, default=list(RESOLUTIONS))
    ap.add_argument("--reference-spp", type=int, default=None,
                    help="spp of each reference render (default: per scene)")
    ap.add_argument("--references-only", action="store_true",
                    help="only render (and cache) the references")
    ap.add_argument("--walkthrough", action="store_true",
                    help=f"also the {VIEWS}-view walkthrough of {WALKTHROUGH_SCENE}")
    ap.add_argument("--cap", type=float, default=CURVE_TIME_CAP_S, metavar="SECONDS",
                    help="longest Mitsuba render; beyond, its time is extrapolated")
    ap.add_argument("--log-report", metavar="LOG",
                    help="only print the headline from a run's printed lines")
    ap.add_argument("--worker", nargs=4, metavar=("SCENE", "RES", "CONFIG", "OUT"),
                    help=argparse.SUPPRESS)
    args = ap.parse_args()
    add_external(args.external or json.loads(os.environ.get(EXTERNAL_ENV, "[]")))
    args.scenes = args.scenes or list(SCENES)
    unknown = [n for n in args.scenes if n not in SCENES]
    if unknown:
        sys.exit(f"benchmarks.py: unknown scene(s) {', '.join(unknown)}")
    if args.worker:
        name, res, config, out = args.worker
        wavrad_worker(name, int(res), config, out)
        return
    if args.log_report:
        log_report(args.log_report)
        return
    if args.walkthrough:
        os.environ["WAVRAD_BENCH_WALK"] = "1"

    start = time.perf_counter()
    info = {"machine": machine(), "configs": CONFIGS, "render_args": RENDER_ARGS,
            "samplers": SAMPLERS, "reference_sampler": REFERENCE_SAMPLER, "cap_s": args.cap}
    mitsuba = Mitsuba()
    info.update(mitsuba=mitsuba.mi.__version__, drjit=mitsuba.dr.__version__,
                variant=mitsuba.variant)
    runs, walk = [], None

    def report() -> None:
        """docs/benchmarks.md and .json from what is measured so far (a run
        cut short keeps its finished scenes)."""
        info["machine"]["load_average_end"] = os.getloadavg()
        info["compile_s_left_out"] = mitsuba.compile_s
        info["total_s"] = time.perf_counter() - start
        write_report(info, runs, walk)
        with open(os.path.join(DOCS, "benchmarks.json"), "w") as f:
            json.dump(to_json({"info": info, "runs": runs, "walkthrough": walk}), f, indent=1)
            f.write("\n")

    with tempfile.TemporaryDirectory() as folder:
        for res in args.res:
            for name in args.scenes:
                spp = args.reference_spp or SCENES[name].reference_spp
                if args.references_only:
                    reference(mitsuba, name, res, folder, spp)
                    continue
                run = bench_scene(mitsuba, name, res, folder, spp, args.cap)
                runs.append(run)
                report()
                if args.walkthrough and name == WALKTHROUGH_SCENE and res == args.res[0]:
                    best = run["best"][WALKTHROUGH_CONFIG]
                    walk = walkthrough(mitsuba, folder, res, best,
                                       2 * math.ceil(best["spp"] / 2),
                                       run["wavrad"][WALKTHROUGH_CONFIG])
                    report()
    if args.references_only:
        return
    report()
    print(f"wrote docs/benchmarks.md, docs/benchmarks.json ({info['total_s'] / 60:.1f} min)")


if __name__ == "__main__":
    main()
