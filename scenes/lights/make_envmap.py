#!/usr/bin/env python3
"""Write scenes/lights/envmap.exr: a 128x64 latitude-longitude sky in Mitsuba 3's
envmap parametrisation (row j at theta = pi*j/(h-1) from +y, column i at
phi = 2*pi*i/w, direction (sin(theta)*sin(phi), cos(theta), -sin(theta)*cos(phi))):
a sky brighter and bluer towards the zenith, a dark ground, and a small sun
(radiance 3000 over 6 pixels) 30 degrees from the zenith towards
(-0.3, 0.85, 0.4). Deterministic; needs numpy and mitsuba (for the EXR)."""

import os

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
W, H = 128, 64
j, i = np.meshgrid(np.arange(H), np.arange(W), indexing="ij")
theta = np.pi * j / (H - 1)
phi = 2 * np.pi * i / W
d = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], -1)
up = np.clip(d[..., 1], 0, 1)[..., None]
sky = (0.6 + 0.6 * up) * np.array([0.55, 0.7, 1.0]) * (d[..., 1:2] > 0)
ground = np.array([0.08, 0.07, 0.06]) * (d[..., 1:2] <= 0)
sun_dir = np.array([-0.3, 0.85, 0.4]) / np.linalg.norm([-0.3, 0.85, 0.4])
sun = 3000.0 * (d @ sun_dir > np.cos(np.radians(2.5)))[..., None] * np.array([1.0, 0.9, 0.75])
rgb = (sky + ground + sun).astype(np.float32)
out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "envmap.exr")
mi.Bitmap(rgb, pixel_format=mi.Bitmap.PixelFormat.RGB).write(out)
print(f"wrote {out}: {W}x{H}, sun pixels {(rgb[..., 0] > 100).sum()}")
