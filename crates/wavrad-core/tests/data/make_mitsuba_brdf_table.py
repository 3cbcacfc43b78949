"""Write mitsuba_brdf_eval.json: BRDF values from Mitsuba for random
direction pairs, the reference of wavrad-core's `brdf_mitsuba_reference`
test (which only reads the JSON; CI needs no Mitsuba).

    python -m venv venv && venv/bin/pip install mitsuba==3.9.1 drjit==1.5.0
    venv/bin/python crates/wavrad-core/tests/data/make_mitsuba_brdf_table.py

`roughconductor`, `roughplastic` and `principled` are Mitsuba 3's own plugins
(`scalar_rgb`). Mitsuba 3 has no `ward`; it is re-implemented below line by
line from Mitsuba 0.6's `src/bsdfs/ward.cpp` as a Mitsuba 3 Python BSDF
plugin and evaluated through the same `BSDF.eval` call. Mitsuba's `eval`
includes the cosine of the sampled (light) direction; it is divided out, so
the table holds f(wi, wo) per unit solid angle. Directions are rounded to
float32 before use, so that both sides evaluate the same vectors.
"""

import json
import math
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

PAIRS = 200
SEED = 20240607


class Ward06(mi.BSDF):
    """Mitsuba 0.6's `ward` (variant, alphaU/alphaV, specular/diffuse
    reflectance), evaluation only, faithful to ward.cpp's `eval`."""

    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        self.variant = props.get("variant", "balanced")
        alpha = props.get("alpha", 0.1)
        self.au = props.get("alpha_u", alpha)
        self.av = props.get("alpha_v", alpha)
        self.ks = mi.Color3f(props.get("specular_reflectance", mi.Color3f(0.2)))
        self.kd = mi.Color3f(props.get("diffuse_reflectance", mi.Color3f(0.5)))
        self.m_components = [mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide,
                             mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide]
        self.m_flags = self.m_components[0] | self.m_components[1]

    def eval(self, ctx, si, wo, active=True):
        wi = si.wi
        ci, co = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
        if not (ci > 0 and co > 0):
            return mi.Color3f(0.0)
        h = wi + wo
        au, av = self.au, self.av
        if self.variant == "ward":
            factor1 = 1.0 / (4.0 * dr.pi * au * av * dr.sqrt(ci * co))
        elif self.variant == "ward-duer":
            factor1 = 1.0 / (4.0 * dr.pi * au * av * ci * co)
        else:
            factor1 = dr.dot(h, h) / (dr.pi * au * av * dr.power(h.z, 4))
        factor2, factor3 = h.x / au, h.y / av
        exponent = -(factor2 * factor2 + factor3 * factor3) / (h.z * h.z)
        spec = factor1 * dr.exp(exponent)
        result = mi.Color3f(0.0)
        if spec > 1e-10:
            result += self.ks * spec
        result += self.kd * dr.inv_pi
        return result * co

    def pdf(self, ctx, si, wo, active=True):
        return 0.0

    def sample(self, ctx, si, sample1, sample2, active=True):
        return mi.BSDFSample3f(), mi.Color3f(0.0)

    def to_string(self):
        return "Ward06"


mi.register_bsdf("ward06", lambda props: Ward06(props))

PARAMETER_SETS = [
    {"type": "roughconductor"},
    {"type": "roughconductor", "distribution": "beckmann", "alpha": 0.3, "material": "Au"},
    {"type": "roughconductor", "distribution": "ggx", "alpha": 0.2, "material": "Cu"},
    {"type": "roughconductor", "distribution": "ggx", "alpha_u": 0.1, "alpha_v": 0.4,
     "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.1], "specular_reflectance": [0.8, 0.9, 1.0]},
    {"type": "roughconductor", "distribution": "beckmann", "alpha_u": 0.35, "alpha_v": 0.08,
     "material": "Al"},
    {"type": "roughplastic"},
    {"type": "roughplastic", "distribution": "ggx", "alpha": 0.3, "int_ior": 1.5,
     "diffuse_reflectance": [0.2, 0.6, 0.3]},
    {"type": "roughplastic", "distribution": "beckmann", "alpha": 0.5, "int_ior": "bk7",
     "ext_ior": "water", "diffuse_reflectance": [0.9, 0.9, 0.9]},
    {"type": "roughplastic", "distribution": "ggx", "alpha": 0.05, "int_ior": 1.9,
     "nonlinear": True, "diffuse_reflectance": [0.8, 0.3, 0.1],
     "specular_reflectance": [0.5, 0.5, 0.5]},
    {"type": "ward", "variant": "ward", "alpha_u": 0.1, "alpha_v": 0.3},
    {"type": "ward", "variant": "ward-duer", "alpha_u": 0.3, "alpha_v": 0.1},
    {"type": "ward", "variant": "balanced", "alpha_u": 0.1, "alpha_v": 0.3},
    {"type": "ward", "variant": "balanced", "alpha": 0.25,
     "specular_reflectance": [0.3, 0.2, 0.1], "diffuse_reflectance": [0.4, 0.5, 0.6]},
    {"type": "principled", "base_color": [0.8, 0.5, 0.3], "roughness": 0.6, "metallic": 0.2},
    {"type": "principled", "base_color": [0.2, 0.4, 0.7], "roughness": 0.3, "clearcoat": 0.8,
     "clearcoat_gloss": 0.7},
    {"type": "principled", "base_color": [0.9, 0.3, 0.2], "roughness": 0.8, "sheen": 0.9,
     "sheen_tint": 0.6, "spec_tint": 0.3},
    {"type": "principled", "base_color": [0.5, 0.5, 0.5], "roughness": 0.4, "anisotropic": 0.5,
     "metallic": 0.5, "clearcoat": 1.0, "clearcoat_gloss": 0.2, "sheen": 0.5},
    {"type": "principled", "base_color": [0.6, 0.7, 0.4], "roughness": 0.7, "flatness": 0.6},
    {"type": "principled", "base_color": [0.3, 0.5, 0.9], "roughness": 0.2, "flatness": 1.0,
     "spec_tint": 0.5, "sheen": 0.3},
]

COLOR_KEYS = {"eta", "k", "specular_reflectance", "diffuse_reflectance", "base_color"}


def mitsuba_dict(params):
    d = dict(params)
    if d["type"] == "ward":
        # plain colour properties: the Python plugin reads them directly
        d["type"] = "ward06"
        for key in COLOR_KEYS & d.keys():
            d[key] = mi.ScalarColor3f(d[key])
        return d
    for key in COLOR_KEYS & d.keys():
        d[key] = {"type": "rgb", "value": d[key]}
    return d


def f32_unit(v):
    v = np.asarray(v, dtype=np.float64)
    return (v / np.linalg.norm(v)).astype(np.float32).astype(np.float64)


def random_hemisphere(rng):
    # uniform on the hemisphere, away from exact grazing
    z = rng.uniform(0.02, 1.0)
    phi = rng.uniform(0.0, 2.0 * math.pi)
    s = math.sqrt(1.0 - z * z)
    return np.array([s * math.cos(phi), s * math.sin(phi), z])


def direction_pairs(rng, n):
    """Half independent pairs, half near the mirror direction (the lobe)."""
    pairs = []
    while len(pairs) < n:
        wo = random_hemisphere(rng)
        if len(pairs) % 2 == 0:
            wi = random_hemisphere(rng)
        else:
            wi = np.array([-wo[0], -wo[1], wo[2]]) + rng.normal(0.0, 0.15, 3)
            if wi[2] <= 0.02:
                continue
        pairs.append((f32_unit(wi), f32_unit(wo)))
    return pairs


def main():
    rng = np.random.default_rng(SEED)
    ctx = mi.BSDFContext()
    sets = []
    for params in PARAMETER_SETS:
        bsdf = mi.load_dict(mitsuba_dict(params))
        rows = []
        for wi, wo in direction_pairs(rng, PAIRS):
            # Mitsuba: si.wi is the viewing direction (wavrad's wo), the
            # argument the light direction (wavrad's wi), whose cosine is in.
            si = mi.SurfaceInteraction3f()
            si.wi = mi.Vector3f(wo)
            value = bsdf.eval(ctx, si, mi.Vector3f(wi))
            f = [float(value[c]) / float(mi.Vector3f(wi).z) for c in range(3)]
            rows.append([float(x) for x in wi] + [float(x) for x in wo] + f)
        sets.append({"params": params, "pairs": rows})
    out = {
        "generator": "make_mitsuba_brdf_table.py",
        "mitsuba": mi.__version__,
        "variant": mi.variant(),
        "note": "f(wi, wo) per unit solid angle (Mitsuba's eval / cos(wi)); "
                "ward is Mitsuba 0.6's, re-implemented as a Mitsuba 3 plugin",
        "sets": sets,
    }
    path = Path(__file__).with_name("mitsuba_brdf_eval.json")
    # one pair per line: [wi.x, wi.y, wi.z, wo.x, wo.y, wo.z, f.r, f.g, f.b]
    head = json.dumps({k: v for k, v in out.items() if k != "sets"}, indent=1)
    lines = [head[:-2] + ",", ' "sets": [']
    for i, s in enumerate(sets):
        lines.append('  {"params": ' + json.dumps(s["params"]) + ', "pairs": [')
        rows = ["   [" + ",".join(f"{v:.9g}" for v in row) + "]" for row in s["pairs"]]
        lines.append(",\n".join(rows))
        lines.append("  ]}" + ("," if i + 1 < len(sets) else ""))
    lines += [" ]", "}"]
    path.write_text("\n".join(lines) + "\n")
    print(f"wrote {path} ({sum(len(s['pairs']) for s in sets)} pairs)")


if __name__ == "__main__":
    main()
