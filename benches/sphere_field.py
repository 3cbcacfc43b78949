#!/usr/bin/env python3
"""A Cornell box holding many small spheres, for the cost of camera rays
against exact curved shapes: scenes/sphere-cornell-box/scene.xml with its
sphere and its large box replaced by `count` spheres on a jittered grid
filling the box's lower half (none touching another, the walls or the
floor).

    python3 benches/sphere_field.py 1000 /tmp/field.xml
    wavrad solve --max-level 2 --time-limit 90 -o /tmp/field.wavrad /tmp/field.xml
    wavrad render --mode smooth -o field.exr /tmp/field.wavrad

Each sphere is tessellated into 528 surfaces for the solve, so a thousand
make a solve of half a million surfaces; rendering a solution file written
once times the camera rays alone. Standard library only; the jitter is
seeded, so a count always makes the same scene.
"""

from __future__ import annotations

import math
import random
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "scenes/sphere-cornell-box/scene.xml"

# The block the spheres fill: x and z across the box, y from just above
# the floor to the middle.
LO, HI = (-0.9, -0.95, -0.9), (0.9, 0.0, 0.9)


def spheres(count: int, seed: int = 1) -> list[tuple[float, float, float, float]]:
    """(x, y, z, radius) of `count` spheres, one per cell of the smallest
    grid of at least `count` cubic cells over the block, jittered within
    their cells; radius a third of a cell."""
    volume = math.prod(h - lo for lo, h in zip(LO, HI))
    cell = (volume / count) ** (1 / 3)
    while True:
        shape = [max(1, math.floor((h - lo) / cell)) for lo, h in zip(LO, HI)]
        if math.prod(shape) >= count:
            break
        cell *= 0.99
    radius = cell / 3
    rng = random.Random(seed)
    cells = [(i, j, k) for i in range(shape[0]) for j in range(shape[1]) for k in range(shape[2])]
    out = []
    for index in rng.sample(cells, count):
        centre = [
            lo + (n + 0.5) * cell + rng.uniform(-1, 1) * (cell / 2 - radius) * 0.9
            for lo, n in zip(LO, index)
        ]
        out.append((*centre, radius))
    return out


def scene(count: int) -> str:
    """The scene's XML."""
    text = SCENE.read_text()
    shapes = "\n".join(
        f'    <shape type="sphere">\n'
        f'        <point name="center" x="{x:.6f}" y="{y:.6f}" z="{z:.6f}"/>\n'
        f'        <float name="radius" value="{r:.6f}"/>\n'
        f'        <ref id="white"/>\n'
        f"    </shape>"
        for x, y, z, r in spheres(count)
    )
    for name, replacement in (("sphere", shapes + "\n"), ("large-box", "")):
        pattern = rf'    <shape type="[a-z]+" id="{name}">.*?</shape>\n'
        text, replaced = re.subn(pattern, lambda _, r=replacement: r, text, flags=re.S)
        assert replaced == 1, f"no shape {name} in {SCENE}"
    return text


def main() -> None:
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    Path(sys.argv[2]).write_text(scene(int(sys.argv[1])))


if __name__ == "__main__":
    main()
