#!/usr/bin/env python3
"""Quick checks of scenes/ward_bsdf.py (Mitsuba 0.6's ward in Mitsuba 3).

1. Directional albedo rho(wi) by two independent estimators: the mean
   sampling weight (sample()) and eval() integrated with uniform hemisphere
   samples (2 pi * mean(eval)).  They must agree, and rho <= 1 for the
   'balanced' variant with rho_s + rho_d <= 1.
2. mitsuba.chi2 test: sample() agrees with pdf() (SphericalDomain, res 101,
   ires 32; ires 8 is too coarse to integrate the alpha = .04 lobe).

Usage: python3 scenes/check_ward_bsdf.py   (llvm_ad_rgb; set DRJIT_LIBLLVM_PATH)
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402
import numpy as np  # noqa: E402

mi.set_variant("llvm_ad_rgb")
import ward_bsdf  # noqa: E402

ward_bsdf.register()
from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain  # noqa: E402


def albedo(bsdf, theta, n=1 << 20, seed=0):
    ctx = mi.BSDFContext()
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(float(np.sin(theta)), 0.0, float(np.cos(theta)))
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed, n)
    _, w = bsdf.sample(ctx, si, sampler.next_1d(), sampler.next_2d())
    wo = mi.warp.square_to_uniform_hemisphere(sampler.next_2d())
    e = bsdf.eval(ctx, si, wo) * (2 * np.pi)
    return np.array(w).mean(axis=1), np.array(e).mean(axis=1)


ok = True
for kw in [dict(variant="balanced", alpha=0.1, specular_reflectance=1.0, diffuse_reflectance=0.0),
           dict(variant="balanced", alpha_u=0.1, alpha_v=0.35, specular_reflectance=1.0,
                diffuse_reflectance=0.0),
           dict(variant="balanced", alpha=0.3, specular_reflectance=1.0, diffuse_reflectance=0.0),
           dict(variant="balanced", alpha=0.25, specular_reflectance=0.18,
                diffuse_reflectance=0.62),
           dict(variant="ward", alpha_u=0.04, alpha_v=0.09, specular_reflectance=0.21,
                diffuse_reflectance=0.1),
           dict(variant="ward-duer", alpha=0.3, specular_reflectance=1.0, diffuse_reflectance=0.0)]:
    b = mi.load_dict(dict(type="ward", **kw))
    print(kw)
    for th in [0, 30, 60, 80, 89]:
        s, e = albedo(b, np.radians(th))
        print(f"   theta {th:2d}: albedo via sample() {s[0]:.4f}, via eval() {e[0]:.4f}")
        if abs(s[0] - e[0]) > 0.03 * max(e[0], 0.1):
            ok = False
        if kw["variant"] == "balanced" and s[0] > 1.0:
            ok = False

cases = [
    ('<string name="variant" value="balanced"/><float name="alpha" value="0.25"/>'
     '<rgb name="specular_reflectance" value="0.18"/>'
     '<rgb name="diffuse_reflectance" value="0.6,0.5,0.45"/>', [0.1, 0.5, 0.9]),
    ('<string name="variant" value="balanced"/><float name="alpha_u" value="0.1"/>'
     '<float name="alpha_v" value="0.35"/><rgb name="specular_reflectance" value="0.18"/>'
     '<rgb name="diffuse_reflectance" value="0.6"/>', [0.2, 0.7]),
    ('<string name="variant" value="ward"/><float name="alpha_u" value="0.04"/>'
     '<float name="alpha_v" value="0.09"/><float name="specular_reflectance" value="0.21"/>'
     '<float name="diffuse_reflectance" value="0.1"/>', [0.3, 0.8]),
    ('<string name="variant" value="ward"/><float name="alpha_u" value="0.3"/>'
     '<float name="alpha_v" value="0.15"/><float name="specular_reflectance" value="0.5"/>'
     '<float name="diffuse_reflectance" value="0.0"/>', [0.5]),
]
for xml, wzs in cases:
    for wz in wzs:
        r = float(np.sqrt(1 - wz * wz))
        wi = [r * float(np.cos(0.7)), r * float(np.sin(0.7)), wz]
        sample_func, pdf_func = BSDFAdapter("ward", xml, wi=wi)
        t = ChiSquareTest(domain=SphericalDomain(), sample_func=sample_func, pdf_func=pdf_func,
                          sample_dim=3, sample_count=2000000, res=101, ires=32)
        res = t.run()
        ok &= bool(res)
        print(f"chi2 {'PASS' if res else 'FAIL'} wi.z={wz:.2f} {xml}")
print("ALL OK" if ok else "SOME CHECKS FAILED")
sys.exit(0 if ok else 1)
