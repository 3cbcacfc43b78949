#!/usr/bin/env python3
"""Scenes of many triangles for the scale benchmark: the bundled Cornell box
with its blocks replaced by a tessellated sphere (convex: its triangles never
see each other) or by a bowl (concave: they do), at any triangle count.

    python3 benches/mesh_scenes.py sphere 4000 /tmp/scenes   # writes scene.xml + mesh
    python3 benches/mesh_scenes.py sphere 4000 /tmp/scenes metal   # rough aluminium
    python3 benches/mesh_scenes.py sphere 4000 /tmp/scenes metal point   # ... lit by a point light
    python3 benches/mesh_scenes.py bunny.ply /tmp/scenes     # any PLY/OBJ, fitted in

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
            verts.append(
                (math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi))
            )
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
                f"element vertex {len(verts)}\n"
                "property float x\nproperty float y\nproperty float z\n"
                f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
            ).encode()
        )
        for v in verts:
            f.write(struct.pack("<3f", *v))
        for t in faces:
            f.write(struct.pack("<B3i", 3, *t))


def mesh_bounds(path: Path) -> tuple[list[float], list[float]]:
    """Bounding box of the vertices of a PLY (ASCII or binary little-endian,
    x y z as the first three float properties) or OBJ file."""
    lo, hi = [math.inf] * 3, [-math.inf] * 3

    def add(v):
        for k in range(3):
            lo[k], hi[k] = min(lo[k], v[k]), max(hi[k], v[k])

    if path.suffix.lower() == ".obj":
        for line in path.read_text(errors="replace").splitlines():
            if line.startswith("v "):
                add([float(x) for x in line.split()[1:4]])
        return lo, hi
    data = path.read_bytes()
    end = data.index(b"end_header") + len(b"end_header")
    end = data.index(b"\n", end) + 1
    header = data[:end].decode("ascii", errors="replace").splitlines()
    count, props, fmt = 0, [], header[1].split()[1]
    for line in header:
        words = line.split()
        if words[:2] == ["element", "vertex"]:
            count = int(words[2])
        elif words and words[0] == "element":
            if count and props:
                break
        elif words[:1] == ["property"] and count and words[1] != "list":
            props.append(words[1])
    sizes = {
        "float": "f",
        "float32": "f",
        "double": "d",
        "float64": "d",
        "uchar": "B",
        "uint8": "B",
        "int": "i",
        "int32": "i",
        "uint": "I",
        "uint32": "I",
        "short": "h",
        "ushort": "H",
    }
    if fmt == "ascii":
        lines = data[end:].decode().splitlines()[:count]
        for line in lines:
            add([float(x) for x in line.split()[:3]])
        return lo, hi
    record = struct.Struct("<" + "".join(sizes[p] for p in props))
    for k in range(count):
        add(record.unpack_from(data, end + k * record.size)[:3])
    return lo, hi


def room(mesh: str, scale: float, offset: list[float], out: Path, bsdf: str) -> Path:
    """The Cornell box without its blocks, with `mesh` (in `out`) scaled by
    `scale` and moved by `offset`."""
    xml = CORNELL.read_text()
    # Drop the two blocks (every shape after the walls' comment block).
    xml = re.sub(r"<!-- =+ Box(?:es)? =+ -->.*?(?=</scene>)", "", xml, flags=re.S)
    kind = "obj" if mesh.lower().endswith(".obj") else "ply"
    shape = f"""
    <shape type="{kind}">
        <string name="filename" value="{mesh}"/>
        <boolean name="face_normals" value="true"/>
        <transform name="to_world">
            <scale value="{scale}"/>
            <translate x="{offset[0]}" y="{offset[1]}" z="{offset[2]}"/>
        </transform>
        {bsdf}
    </shape>
"""
    xml = xml.replace("</scene>", shape + "</scene>")
    path = out / "scene.xml"
    path.write_text(xml)
    return path


# Rough aluminium (Beckmann, alpha 0.2): a glossy mesh with no Lambertian lobe.
METAL = (
    '<bsdf type="roughconductor"><string name="material" value="Al"/>'
    '<float name="alpha" value="0.2"/></bsdf>'
)


# A point light 0.09 under the ceiling's centre in place of the ceiling's
# area light: half that light's L·A as its intensity (the area light sends
# π·L·A into a hemisphere, this one 4π·I into the sphere).
POINT_LIGHT = (
    '<emitter type="point"><point name="position" x="0" y="0.9" z="0"/>'
    '<rgb name="intensity" value="1.607, 1.222, 0.590"/></emitter>'
)


def make(
    kind: str, triangles: int, out: Path, metal: bool = False, point: bool = False
) -> Path:
    """Write `out/scene.xml` with a sphere or bowl of about `triangles`
    triangles, 0.45 in radius, its centre 0.5 above the floor, white or
    (`metal`) rough aluminium, lit by the Cornell box's light or (`point`)
    a point light; return the scene's path."""
    out.mkdir(parents=True, exist_ok=True)
    verts, faces = grid_sphere(triangles, rows_for_bowl=(kind == "bowl"))
    write_ply(out / "mesh.ply", verts, faces)
    material = METAL if metal else '<ref id="white"/>'
    two_sided = f'<bsdf type="twosided">{material}</bsdf>'
    path = room("mesh.ply", 0.45, [0, -0.5, 0], out, two_sided if kind == "bowl" else material)
    if point:
        xml = path.read_text()
        light = re.search(r'    <shape type="rectangle" id="light">.*?</shape>', xml, re.S)
        assert light, "the Cornell box's light shape"
        path.write_text(xml.replace(light.group(0), "    " + POINT_LIGHT))
    return path


def make_from(mesh: Path, out: Path) -> Path:
    """Write `out/scene.xml` with the mesh file `mesh` fitted into the box
    (its largest side 0.9, standing on the floor), two-sided."""
    out.mkdir(parents=True, exist_ok=True)
    (out / mesh.name).write_bytes(mesh.read_bytes())
    lo, hi = mesh_bounds(mesh)
    scale = 0.9 / max(top - bottom for bottom, top in zip(lo, hi))
    offset = [
        -scale * 0.5 * (lo[0] + hi[0]),
        -0.999 - scale * lo[1],
        -scale * 0.5 * (lo[2] + hi[2]),
    ]
    return room(mesh.name, scale, offset, out, '<bsdf type="twosided"><ref id="white"/></bsdf>')


if __name__ == "__main__":
    if sys.argv[1] in ("sphere", "bowl"):
        options = sys.argv[4:]
        metal, point = "metal" in options, "point" in options
        print(make(sys.argv[1], int(sys.argv[2]), Path(sys.argv[3]), metal, point))
    else:
        print(make_from(Path(sys.argv[1]), Path(sys.argv[2])))
