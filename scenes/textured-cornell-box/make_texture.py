#!/usr/bin/env python3
"""Write wall.png, the bitmap texture of scenes/textured-cornell-box/scene.xml.

16x16 8-bit sRGB: red rises along x, green along y (from the top row down),
blue is a 4-texel checker, so that a texture read flipped, transposed or
without the sRGB-to-linear conversion shows against Mitsuba 3's reference.

Usage: python3 scenes/textured-cornell-box/make_texture.py
"""

import os

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
HERE = os.path.dirname(os.path.abspath(__file__))

size = 16
y, x = np.mgrid[0:size, 0:size]
texels = np.stack(
    [
        40 + 200 * x / (size - 1),
        30 + 180 * y / (size - 1),
        np.where(((x // 4) + (y // 4)) % 2 == 0, 60, 220),
    ],
    axis=-1,
).round().astype(np.uint8)
bitmap = mi.Bitmap(texels, pixel_format=mi.Bitmap.PixelFormat.RGB)
bitmap.set_srgb_gamma(True)
bitmap.write(os.path.join(HERE, "wall.png"))
print("wrote wall.png", texels.shape)
