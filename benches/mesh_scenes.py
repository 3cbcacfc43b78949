#!/usr/bin/env python3
"""Scenes of many triangles for the scale benchmark: the bundled Cornell box
with its blocks replaced by a tessellated sphere (convex: its triangles never
see each other) or by a bowl (concave: they do), at any triangle count.

    python3 benches/mesh_scenes.py sphere 4000 /tmp/scenes   # writes scene.xml + mesh

Standard library only. The meshes are written as binary PLY.
"""

from __future__ import annotations

import math
import re
import struct
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORNELL = ROOT / "scenes/cornell-box/scene.xml"


def grid_sphere(triangles: int, rows_for_bowl: bool = False):
    """A UV sphere of about `triangles` triangles (a bowl: its lower half,
    seen from inside as well as out). Returns (vertices, faces)."""
    # A UV grid of n×2n quads makes 4n² triangles.
    n = max(2, round(math.sqrt(triangles / (2 if rows_for_bowl else 4))))
    rows = n // 2 if rows_for_bowl else n
    cols = 2 * n
    verts = []
    for i in range(rows + 1):
        theta = math.pi * (0.5 + 0.5 * i / rows) if rows_for_bowl else math.pi * i / rows
        for j in range(cols):
            phi = 2 * math.pi * j / cols
            verts.append((math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi)))
    faces = []
    for i in range(rows):
        for j in range(cols):
            a, b = i * cols + j, i * cols + (j + 1) % cols
            c, d = a + cols, b + cols
            tris = [(a, b, d), (a, d, c)]
            for t in tris:
                # Poles collapse one triangle of each quad: keep the other.
                if len({verts[k] for k in t}) == 3:
                    faces.append(t)
    return verts, faces


def write_ply(path: Path, verts, faces):
    with open(path, "wb") as f:
        f.write(
            (
                "ply\nformat binary_little_endian 1.0\n"
                f"element vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n"
                f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
            ).encode()
        )
        for v in verts:
            f.write(struct.pack("<3f", *v))
        for t in faces:
            f.write(struct.pack("<B3i", 3, *t))


def make(kind: str, triangles: int, out: Path) -> Path:
    """Write `out/scene.xml` and its mesh; return the scene's path."""
    out.mkdir(parents=True, exist_ok=True)
    verts, faces = grid_sphere(triangles, rows_for_bowl=(kind == "bowl"))
    write_ply(out / "mesh.ply", verts, faces)
    xml = CORNELL.read_text()
    # Drop the two blocks (every shape after the walls' comment block).
    xml = re.sub(r"<!-- =+ Box(?:es)? =+ -->.*?(?=</scene>)", "", xml, flags=re.S)
    bsdf = '<bsdf type="twosided"><ref id="white"/></bsdf>' if kind == "bowl" else '<ref id="white"/>'
    shape = f"""
    <shape type="ply">
        <string name="filename" value="mesh.ply"/>
        <boolean name="face_normals" value="true"/>
        <transform name="to_world">
            <scale value="0.45"/>
            <translate x="0" y="-0.5" z="0"/>
        </transform>
        {bsdf}
    </shape>
"""
    xml = xml.replace("</scene>", shape + "</scene>")
    path = out / "scene.xml"
    path.write_text(xml)
    return path


if __name__ == "__main__":
    kind, count, out = sys.argv[1], int(sys.argv[2]), Path(sys.argv[3])
    print(make(kind, count, out))
