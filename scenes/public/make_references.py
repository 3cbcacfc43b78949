#!/usr/bin/env python3
"""Render the Mitsuba 3 references of the public scenes (scenes/public/scenes.json).

For every scene with a ``reference`` entry this writes, at the table's
resolution (128 x 128, set with the scene's own ``<default>``s, the
``defines`` of its entry, exactly as ``wavrad render -D`` sets them):

  NAME/reference.exr   path-traced image of the scene as written (its own
                       integrator, filter and sampler type), RGB float32;
                       the average of two halves, A (seeds 0..P-1) and
                       B (seeds P..2P-1), P passes of --pass-spp each
  NAME/emitters.exr    the same view rendered with a path tracer of
                       max_depth 1: only what is seen of the emitters
                       directly (the test leaves out every pixel where it
                       is not zero)

and prints the reference's own noise, estimated from the halves, over all
pixels and over those that see no emitter (the pixels the test compares):

  noise_half = sqrt(mean((A-B)^2)) / mean(B) / sqrt(2)   (one half)
  noise_ref  = noise_half / sqrt(2)                       (the average)

then records spp and the second noise_ref in scenes.json.

Mitsuba 0.x files: Mitsuba 3 upgrades their parameter names itself (scene
version < 2) but refuses their camelCase <lookAt> tag. An entry with
"upgrade": "lookat-tag" is loaded from a temporary copy beside the file in
which that tag, and only it, is spelt <lookat> (LOOKAT below; the copy is
removed after loading); everything else is Mitsuba 3's own reading of the
0.x file. Such files have fixed films (no <default>s), so their references
are at the film's own resolution.

Files without an <integrator>: Mitsuba 0.x gave such a scene a `direct`
integrator (Mitsuba 0.6, src/librender/scene.cpp, Scene::configure: "Create
a direct integrator by default"); Mitsuba 3 loads the file but refuses to
render it without one. An entry with "default_integrator": "direct" is
rendered with that integrator, as Mitsuba 0.6 would; the file is not
changed; wavrad gives such a file the same default.

Usage:
  python3 scenes/public/make_references.py                     # every scene, 4096 spp
  python3 scenes/public/make_references.py --scene veach-mis --spp 65536

The Mitsuba variant is chosen as in scenes/make_references.py (llvm_ad_rgb
with libLLVM >= 17, else scalar_rgb).
"""

import argparse
import importlib.util
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
TABLE = os.path.join(HERE, "scenes.json")
EMITTER_SPP = 1024


def bundled_references():
    """scenes/make_references.py, for its choice of Mitsuba variant."""
    path = os.path.join(os.path.dirname(HERE), "make_references.py")
    spec = importlib.util.spec_from_file_location("bundled_references", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# The one edit an "upgrade": "lookat-tag" entry's copy gets.
LOOKAT = (("<lookAt", "<lookat"), ("</lookAt>", "</lookat>"))


def load(mi, entry):
    path = os.path.join(HERE, entry["file"])
    upgrade = entry.get("upgrade")
    if upgrade is None:
        return mi.load_file(path, **entry["defines"])
    if upgrade != "lookat-tag":
        raise SystemExit(f"{entry['file']}: unknown upgrade {upgrade!r}")
    with open(path, encoding="utf-8") as f:
        text = f.read()
    for old, new in LOOKAT:
        text = text.replace(old, new)
    copy = os.path.join(os.path.dirname(path), ".lookat-upgraded.xml")
    with open(copy, "w", encoding="utf-8") as f:
        f.write(text)
    try:
        return mi.load_file(copy, **entry["defines"])
    finally:
        os.remove(copy)


def rgb(mi, np, image):
    """The first three channels (integrators such as `moment` add more)."""
    return np.array(image, dtype=np.float64)[..., :3]


def default_integrator(mi, scene, entry):
    """The integrator of an entry whose file has none (see above), else None."""
    name = entry.get("default_integrator")
    if name is None:
        return None
    if scene.integrator() is not None:
        raise SystemExit(f"{entry['file']}: has an <integrator>; drop its default_integrator")
    return mi.load_dict({"type": name})


def render_halves(mi, np, scene, spp, pass_spp, integrator=None):
    passes = max(1, spp // (2 * pass_spp))
    halves = []
    for h in range(2):
        acc = 0.0
        for p in range(passes):
            seed = h * passes + p
            image = mi.render(scene, integrator=integrator, spp=pass_spp, seed=seed)
            acc = acc + rgb(mi, np, image)
        halves.append(acc / passes)
    return halves, 2 * passes * pass_spp


def write_exr(mi, np, image, path):
    bitmap = mi.Bitmap(image.astype(np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB)
    bitmap.write(path)


def make_reference(mi, np, name, entry, spp, pass_spp):
    scene = load(mi, entry)
    direct = mi.load_dict({"type": "path", "max_depth": 1})
    emitters = rgb(mi, np, mi.render(scene, integrator=direct, spp=EMITTER_SPP, seed=0))
    kept = emitters.max(axis=-1) <= 0.0
    t0 = time.time()
    integrator = default_integrator(mi, scene, entry)
    (a, b), total = render_halves(mi, np, scene, spp, pass_spp, integrator)
    seconds = time.time() - t0
    noise = {}
    for region, mask in (("all", np.ones_like(kept)), ("no-emitter", kept)):
        half = np.sqrt(np.mean((a[mask] - b[mask]) ** 2)) / np.mean(b[mask]) / np.sqrt(2.0)
        noise[region] = (half, half / np.sqrt(2.0))
    reference = entry["reference"]
    write_exr(mi, np, 0.5 * (a + b), os.path.join(HERE, reference["image"]))
    write_exr(mi, np, emitters, os.path.join(HERE, reference["emitters"]))
    print(f"{name}: {total} spp in {seconds:.0f} s; {int(np.count_nonzero(~kept))} pixels see "
          f"an emitter; noise of one half / of the reference: "
          + ", ".join(f"{region} {100 * h:.3f} % / {100 * r:.3f} %"
                      for region, (h, r) in noise.items()), flush=True)
    reference["spp"] = total
    reference["noise"] = round(float(noise["no-emitter"][1]), 5)


def main():
    table = json.load(open(TABLE))
    with_reference = sorted(n for n, e in table["scenes"].items() if e["reference"])
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", action="append", choices=with_reference,
                    help="render only this scene (repeatable; default: all)")
    ap.add_argument("--spp", type=int, default=4096, help="samples per pixel, both halves")
    ap.add_argument("--pass-spp", type=int, default=256, help="samples per pixel of one pass")
    ap.add_argument("--variant", default="auto",
                    help="Mitsuba variant (default: llvm_ad_rgb, else scalar_rgb)")
    args = ap.parse_args()

    bundled = bundled_references()
    bundled.find_libllvm()
    import mitsuba as mi
    import numpy as np

    variant = bundled.pick_variant(mi, args.variant)
    print(f"mitsuba {mi.__version__}, variant {variant}", flush=True)
    for name in args.scene or with_reference:
        make_reference(mi, np, name, table["scenes"][name], args.spp, args.pass_spp)
        with open(TABLE, "w") as f:
            json.dump(table, f, indent=2, ensure_ascii=False)
            f.write("\n")


if __name__ == "__main__":
    sys.exit(main())
