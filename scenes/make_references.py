#!/usr/bin/env python3
"""Regenerate wavrad's Mitsuba 3 reference data.

Outputs (paths relative to the repository root):

  tests/fixtures/cornell_box_dict_to_xml.xml
      mi.cornell_box() written verbatim by Mitsuba's own dict -> XML writer
      (Mitsuba >= 3.6: mi.parser.parse_dict + mi.parser.write_file; older
      versions had mitsuba.xml.dict_to_xml).  Loader test fixture.

  scenes/cornell-box/reference.exr
      Path-traced reference of scenes/cornell-box/scene.xml (path integrator,
      max_depth = -1), RGB float32, channels R,G,B.

The reference is the average of two independent halves (A: seeds 0..P-1,
B: seeds P..2P-1, each pass rendering --pass-spp samples per pixel).  The
self-noise is estimated from the two halves:

  noise_half = sqrt(mean((A-B)^2)) / mean(B) / sqrt(2)   (relative RMSE of one half)
  noise_ref  = noise_half / sqrt(2)                       (of the committed average)

Glossy scenes (--scene NAME; reference only, per-scene defaults below,
overridable with --spp/--res/--pass-spp/--integrator):

  glossy-cornell-box  scenes/glossy-cornell-box/scene.xml -> reference.exr
                      path, 64x64, 196608 spp
  figure3-diffuse     scenes/figure3/diffuse.xml  -> reference-diffuse.exr
                      path, 64x64, 262144 spp
  textured-cornell-box scenes/textured-cornell-box/scene.xml -> reference.exr
                      path, 64x64, 65536 spp (checkerboard floor, bitmap wall
                      from wall.png, smooth plastic block)
  sphere-cornell-box  scenes/sphere-cornell-box/scene.xml -> reference.exr
                      path, 64x64, 65536 spp (the small box replaced by a
                      white diffuse sphere: shading normals)
  principled-floor    scenes/principled-floor/scene.xml -> reference.exr
                      path, 64x64, 65536 spp (a principled floor with a
                      checkerboard base_color, a principled cube, a point
                      light; max_depth 3)
  principled-coated   scenes/principled-floor/coated.xml -> reference-coated.exr
                      path, 64x64, 65536 spp (the same with clearcoat and
                      sheen on floor and cube)
  metal-ball-cornell-box scenes/metal-ball-cornell-box/scene.xml -> reference.exr
                      path, 64x64, 65536 spp (the small box replaced by a
                      ball of about 1 000 rough aluminium triangles)
  glass-cornell-box   scenes/glass-cornell-box/scene.xml -> reference.exr
                      path, 64x64, 65536 spp (the small box replaced by a
                      solid glass sphere, dielectric)
  rough-glass-cornell-box scenes/rough-glass-cornell-box/scene.xml -> reference.exr
                      path, 64x64, 65536 spp (the glass sphere frosted:
                      roughdielectric, Beckmann 0.25)
  principled-glass-cornell-box scenes/rough-glass-cornell-box/principled.xml
                      -> reference-principled.exr: path, 64x64, 65536 spp
                      (the sphere a transmissive principled, tinted)
  figure3-specular    scenes/figure3/specular.xml -> reference-specular.exr
                      ptracer (light tracer), 64x64, 1048576 spp
                      (the receiver is lit only via the glossy reflector, a
                      caustic-like path that a path tracer samples ~9x less
                      efficiently; with the whole lit geometry >= 4 px inside
                      the frame both integrators have the same expectation in
                      every pixel; --integrator path renders it as written)

  lights-point        scenes/lights/point.xml -> reference-point.exr
  lights-spot         scenes/lights/spot.xml -> reference-spot.exr
  lights-directional  scenes/lights/directional.xml -> reference-directional.exr
  lights-sky          scenes/lights/sky.xml -> reference-sky.exr
  lights-envmap       scenes/lights/envmap.xml -> reference-envmap.exr
                      path, 64x64, 16384 spp (the Cornell box with its area
                      light replaced: point, spot, directional, constant sky, envmap)
  lights-envmap-glass scenes/lights/envmap-glass.xml -> reference-envmap-glass.exr
                      path, 64x64, 262144 spp (envmap.xml with a glass sphere)

  The ward BSDF (Mitsuba 0.6; Mitsuba 3 has none) comes from
  scenes/ward_bsdf.py, registered before any scene is loaded.

Usage:
  python3 scenes/make_references.py                       # everything, defaults
  python3 scenes/make_references.py --spp 98304 --res 128
  python3 scenes/make_references.py --fixture-only
  python3 scenes/make_references.py --verify-only         # XML-vs-dict check
  python3 scenes/make_references.py --scene glossy-cornell-box
  python3 scenes/make_references.py --scene figure3-diffuse
  python3 scenes/make_references.py --scene figure3-specular

Variant: llvm_ad_rgb if available (needs a libLLVM shared library, LLVM >= 17:
LLVM 14/15/16 abort with "Cannot select: fminimum" on AVX-512 CPUs), else
scalar_rgb.  If DRJIT_LIBLLVM_PATH is unset, this script looks for the newest
libLLVM-NN.so with NN >= 17 in the usual system library folders.
"""

import argparse
import glob
import os
import re
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SCENE_XML = os.path.join(HERE, "cornell-box", "scene.xml")
REFERENCE_EXR = os.path.join(HERE, "cornell-box", "reference.exr")
FIXTURE_XML = os.path.join(ROOT, "tests", "fixtures", "cornell_box_dict_to_xml.xml")

# --scene NAME: (scene xml, reference exr, res, spp, pass_spp, integrator)
SCENES = {
    "cornell-box": (SCENE_XML, REFERENCE_EXR, 128, 98304, 1024, "path"),
    "glossy-cornell-box": (os.path.join(HERE, "glossy-cornell-box", "scene.xml"),
                           os.path.join(HERE, "glossy-cornell-box", "reference.exr"),
                           64, 196608, 1024, "path"),
    "figure3-diffuse": (os.path.join(HERE, "figure3", "diffuse.xml"),
                        os.path.join(HERE, "figure3", "reference-diffuse.exr"),
                        64, 262144, 1024, "path"),
    "textured-cornell-box": (os.path.join(HERE, "textured-cornell-box", "scene.xml"),
                             os.path.join(HERE, "textured-cornell-box", "reference.exr"),
                             64, 65536, 1024, "path"),
    "sphere-cornell-box": (os.path.join(HERE, "sphere-cornell-box", "scene.xml"),
                           os.path.join(HERE, "sphere-cornell-box", "reference.exr"),
                           64, 65536, 1024, "path"),
    "principled-floor": (os.path.join(HERE, "principled-floor", "scene.xml"),
                         os.path.join(HERE, "principled-floor", "reference.exr"),
                         64, 65536, 1024, "path"),
    "principled-coated": (os.path.join(HERE, "principled-floor", "coated.xml"),
                          os.path.join(HERE, "principled-floor", "reference-coated.exr"),
                          64, 65536, 1024, "path"),
    "metal-ball-cornell-box": (os.path.join(HERE, "metal-ball-cornell-box", "scene.xml"),
                               os.path.join(HERE, "metal-ball-cornell-box", "reference.exr"),
                               64, 65536, 1024, "path"),
    "glass-cornell-box": (os.path.join(HERE, "glass-cornell-box", "scene.xml"),
                          os.path.join(HERE, "glass-cornell-box", "reference.exr"),
                          64, 65536, 1024, "path"),
    "rough-glass-cornell-box": (os.path.join(HERE, "rough-glass-cornell-box", "scene.xml"),
                                os.path.join(HERE, "rough-glass-cornell-box", "reference.exr"),
                                64, 65536, 1024, "path"),
    "principled-glass-cornell-box": (
        os.path.join(HERE, "rough-glass-cornell-box", "principled.xml"),
        os.path.join(HERE, "rough-glass-cornell-box", "reference-principled.exr"),
        64, 65536, 1024, "path"),
    "figure3-specular": (os.path.join(HERE, "figure3", "specular.xml"),
                         os.path.join(HERE, "figure3", "reference-specular.exr"),
                         64, 1048576, 1024, "ptracer"),
}
# The Cornell box lit by lights other than area lights (scenes/lights/).
for _light in ("point", "spot", "directional", "sky", "envmap"):
    SCENES[f"lights-{_light}"] = (os.path.join(HERE, "lights", f"{_light}.xml"),
                                  os.path.join(HERE, "lights", f"reference-{_light}.exr"),
                                  64, 16384, 1024, "path")
# The envmap box with a glass sphere: the sun's caustic through it needs
# many more paths.
SCENES["lights-envmap-glass"] = (os.path.join(HERE, "lights", "envmap-glass.xml"),
                                 os.path.join(HERE, "lights", "reference-envmap-glass.exr"),
                                 64, 262144, 1024, "path")


def find_libllvm():
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return os.environ["DRJIT_LIBLLVM_PATH"]
    cands = []
    for d in ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu",
              "/usr/lib", "/usr/local/lib", "/usr/lib64"):
        for p in glob.glob(os.path.join(d, "libLLVM-*.so*")) + \
                glob.glob(os.path.join(d, "libLLVM.so.*")):
            m = re.search(r"libLLVM[-.](?:so\.)?(\d+)", os.path.basename(p))
            if m and int(m.group(1)) >= 17:
                cands.append((int(m.group(1)), p))
    if not cands:
        return None
    cands.sort()
    os.environ["DRJIT_LIBLLVM_PATH"] = cands[-1][1]
    return cands[-1][1]


def pick_variant(mi, requested):
    if requested != "auto":
        mi.set_variant(requested)
        return requested
    if find_libllvm() is not None and "llvm_ad_rgb" in mi.variants():
        try:
            mi.set_variant("llvm_ad_rgb")
            return "llvm_ad_rgb"
        except Exception as e:  # noqa: BLE001
            print(f"llvm_ad_rgb unavailable ({e}); falling back to scalar_rgb")
    mi.set_variant("scalar_rgb")
    return "scalar_rgb"


def write_fixture(mi, variant):
    """mi.cornell_box() -> XML with Mitsuba's own writer, verbatim."""
    os.makedirs(os.path.dirname(FIXTURE_XML), exist_ok=True)
    if hasattr(mi, "parser") and hasattr(mi.parser, "write_file"):
        cfg = mi.parser.ParserConfig(variant)
        state = mi.parser.parse_dict(cfg, mi.cornell_box())
        mi.parser.write_file(state, FIXTURE_XML)
    else:  # Mitsuba < 3.6
        from mitsuba.xml import dict_to_xml
        dict_to_xml(mi.cornell_box(), FIXTURE_XML)
    # It must load back.
    mi.load_file(FIXTURE_XML)
    print(f"wrote {os.path.relpath(FIXTURE_XML, ROOT)} (loads OK)")


def load_dict_equivalent(mi, res):
    d = mi.cornell_box()
    d["integrator"]["max_depth"] = -1
    d["sensor"]["film"]["width"] = res
    d["sensor"]["film"]["height"] = res
    return mi.load_dict(d)


def rel_rmse(a, b, np):
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.mean(b))


def verify_xml_matches_dict(mi, np, res, spp):
    sx = mi.load_file(SCENE_XML, res=res)
    sd = load_dict_equivalent(mi, res)
    a = np.array(mi.render(sd, spp=spp, seed=0))
    b = np.array(mi.render(sx, spp=spp, seed=0))
    c = np.array(mi.render(sx, spp=spp, seed=1))
    same = rel_rmse(a, b, np)
    noise = rel_rmse(a, c, np)
    print(f"verify @ {spp} spp, {res}x{res}: dict vs scene.xml, same seed: rel. RMSE {same:.2e}; "
          f"different seeds: {noise:.4f} (= noise level)")
    return same, noise


def render_reference(mi, np, res, spp, pass_spp, scene_xml=SCENE_XML,
                     reference_exr=REFERENCE_EXR, integrator=None):
    passes = max(1, spp // (2 * pass_spp))  # passes per half
    total = 2 * passes * pass_spp
    scene = mi.load_file(scene_xml, res=res)
    integ = None
    if integrator is not None and integrator != "path":
        integ = mi.load_dict({"type": integrator, "max_depth": -1})
    print(f"scene {os.path.relpath(scene_xml, ROOT)}, {res}x{res}, integrator "
          f"{integrator or 'path (as in the XML)'}", flush=True)
    halves = []
    t0 = time.time()
    for h in range(2):
        acc = np.zeros((res, res, 3), dtype=np.float64)
        for p in range(passes):
            seed = h * passes + p
            img = (mi.render(scene, spp=pass_spp, seed=seed) if integ is None else
                   mi.render(scene, integrator=integ, spp=pass_spp, seed=seed))
            acc += np.array(img, dtype=np.float64)
            print(f"  half {'AB'[h]} pass {p + 1}/{passes} (seed {seed}) "
                  f"t={time.time() - t0:.0f}s", flush=True)
        halves.append(acc / passes)
    elapsed = time.time() - t0
    a, b = halves
    noise_half = rel_rmse(a, b, np) / np.sqrt(2.0)
    noise_ref = noise_half / np.sqrt(2.0)
    ref = (0.5 * (a + b)).astype(np.float32)
    bmp = mi.Bitmap(ref, pixel_format=mi.Bitmap.PixelFormat.RGB)
    bmp.write(reference_exr)
    # read back and check
    back = mi.Bitmap(reference_exr)
    chans = [back.struct_()[i].name for i in range(back.channel_count())]
    print(f"wrote {os.path.relpath(reference_exr, ROOT)}: {res}x{res}, channels {chans}, "
          f"{back.component_format()}, {os.path.getsize(reference_exr)} bytes")
    print(f"total spp {total} ({2 * passes} passes x {pass_spp}), render time {elapsed:.0f}s")
    print(f"self-noise: per half ({total // 2} spp) rel. RMSE {100 * noise_half:.3f} %; "
          f"reference ({total} spp) {100 * noise_ref:.3f} %")
    print(f"mean RGB {ref.reshape(-1, 3).mean(axis=0).tolist()}, mean {float(ref.mean()):.6f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", choices=sorted(SCENES), default=None,
                    help="render only this scene's reference (default: the original "
                         "cornell-box fixture + check + reference)")
    ap.add_argument("--spp", type=int, default=None,
                    help="total samples per pixel (both halves; default per scene, 98304)")
    ap.add_argument("--pass-spp", type=int, default=None,
                    help="samples per pixel per render pass (default per scene, 1024)")
    ap.add_argument("--res", type=int, default=None,
                    help="image width = height (default per scene, 128)")
    ap.add_argument("--integrator", default=None,
                    help="override the scene's reference integrator (path, ptracer)")
    ap.add_argument(
        "--variant", default="auto", help="mitsuba variant (default: llvm_ad_rgb, else scalar_rgb)"
    )
    ap.add_argument("--verify-spp", type=int, default=256, help="spp of the XML-vs-dict check")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--fixture-only", action="store_true")
    g.add_argument("--verify-only", action="store_true")
    g.add_argument("--reference-only", action="store_true")
    args = ap.parse_args()

    find_libllvm()
    import mitsuba as mi
    import numpy as np

    variant = pick_variant(mi, args.variant)
    print(f"mitsuba {mi.__version__}, variant {variant}, "
          f"DRJIT_LIBLLVM_PATH={os.environ.get('DRJIT_LIBLLVM_PATH')}")
    sys.path.insert(0, HERE)
    import ward_bsdf  # noqa: E402  (Mitsuba 0.6's ward, see scenes/ward_bsdf.py)
    ward_bsdf.register()

    if args.scene is not None:
        xml, exr, res, spp, pass_spp, integrator = SCENES[args.scene]
        render_reference(mi, np, args.res or res, args.spp or spp,
                         args.pass_spp or pass_spp, xml, exr,
                         args.integrator or integrator)
        return
    args.res = args.res or 128
    args.spp = args.spp or 98304
    args.pass_spp = args.pass_spp or 1024

    if not (args.verify_only or args.reference_only):
        write_fixture(mi, variant)
    if args.fixture_only:
        return
    if not args.reference_only:
        verify_xml_matches_dict(mi, np, args.res, args.verify_spp)
    if args.verify_only:
        return
    render_reference(mi, np, args.res, args.spp, args.pass_spp)


if __name__ == "__main__":
    sys.exit(main())
