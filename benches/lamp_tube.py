"""A bright lamp inside an open tube, against Mitsuba 3: how much light the
tube's inner wall reflects, by how it is tessellated.

veach-bidir's spotlight is a small emitter (radiance up to 12 048) inside
an open cylinder of 64 triangles as long as the tube. This script puts the
same emitter and room (`scenes/public/veach-bidir/models/Mesh010.obj`, the
emitter `Diffuse_0003`) around tubes of the same size, tessellated as
`SEGMENTS x RINGS` quads of two triangles each, with a one-sided diffuse
inner wall (albedo 0.5), and a camera looking into the tube. For each
tube it prints the mean of wavrad's solution (`--mode smooth`,
`max_depth` 4: the emitter's light and one reflection) over Mitsuba 3's
light tracer at `max_depth` 3 (the same light), emitter pixels left out.

    .venv/bin/python benches/lamp_tube.py [--tubes 8x1 64x1 64x8] [--spp 2048]
        [--options '--max-level 8']
"""

import argparse
import re
import subprocess
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
BIDIR = ROOT / "scenes" / "public" / "veach-bidir"
CENTRE = np.array([-2.6593, 4.911, -3.368])
AXIS = np.array([-0.0704, 0.4316, -0.8993]) / np.linalg.norm([-0.0704, 0.4316, -0.8993])
RADIUS, HALF_LENGTH = 0.2982, 0.493


def tube_obj(segments, rings, path):
    """An open tube around AXIS, its faces turned towards the axis."""
    u = np.cross(AXIS, [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(AXIS, u)
    vertices = [
        CENTRE
        + (-HALF_LENGTH + 2 * HALF_LENGTH * k / rings) * AXIS
        + RADIUS * (np.cos(2 * np.pi * i / segments) * u + np.sin(2 * np.pi * i / segments) * v)
        for k in range(rings + 1)
        for i in range(segments)
    ]
    faces = []
    for k in range(rings):
        for i in range(segments):
            a, b = k * segments + i, k * segments + (i + 1) % segments
            c, d = a + segments, b + segments
            for face in ((a, b, d), (a, d, c)):
                p = [vertices[j] for j in face]
                normal = np.cross(p[1] - p[0], p[2] - p[0])
                out = sum(p) / 3 - CENTRE
                out -= out.dot(AXIS) * AXIS
                faces.append(face if normal.dot(out) < 0 else (face[0], face[2], face[1]))
    with open(path, "w") as f:
        f.writelines(f"v {p[0]:.6f} {p[1]:.6f} {p[2]:.6f}\n" for p in vertices)
        f.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces)


def scene_xml(tube):
    """veach-bidir's room and spotlight emitter around `tube`, seen from
    beyond the tube's end."""
    source = (BIDIR / "scene.xml").read_text()
    shapes = re.findall(r"\t<shape .*?</shape>\n", source, flags=re.S)
    keep = [s for s in shapes if 'id="Diffuse_0003"' in s or 'id="Diffuse_0009"' in s]
    keep = [s.replace('value="models/', f'value="{BIDIR}/models/') for s in keep]
    eye = CENTRE - 1.6 * AXIS
    sensor = f"""<sensor type="perspective">
        <float name="fov" value="35"/>
        <transform name="to_world"><lookat origin="{eye[0]:.4f}, {eye[1]:.4f}, {eye[2]:.4f}"
            target="{CENTRE[0]:.4f}, {CENTRE[1]:.4f}, {CENTRE[2]:.4f}" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="64"/></sampler>
        <film type="hdrfilm"><integer name="width" value="128"/><integer name="height" value="128"/>
            <rfilter type="box"/></film>
    </sensor>"""
    head = source[: source.index("\t<sensor")]
    bsdfs = source[source.index("</sensor>") + len("</sensor>") : source.index("\t<shape")]
    tube_shape = f"""\t<shape type="obj">
\t\t<string name="filename" value="{tube}"/>
\t\t<boolean name="face_normals" value="true"/>
\t\t<bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>
\t</shape>
"""
    return head + sensor + bsdfs + "".join(keep) + tube_shape + "</scene>\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tubes", nargs="+", default=["8x1", "64x1", "64x8"])
    parser.add_argument("--spp", type=int, default=2048, help="Mitsuba's samples per pixel")
    parser.add_argument("--wavrad", default=str(ROOT / "target" / "release" / "wavrad"))
    parser.add_argument("--options", default="", help="more wavrad options, e.g. '--max-level 8'")
    args = parser.parse_args()
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    with tempfile.TemporaryDirectory() as tmp:
        for tube in args.tubes:
            segments, rings = map(int, tube.split("x"))
            obj, xml = Path(tmp, f"tube{tube}.obj"), Path(tmp, f"tube{tube}.xml")
            tube_obj(segments, rings, obj)
            xml.write_text(scene_xml(obj))
            scene = mi.load_file(str(xml), integrator="ptracer", max_depth=3)
            reference = np.array(mi.render(scene, spp=args.spp))[..., :3]
            image = Path(tmp, f"tube{tube}.exr")
            subprocess.run(
                [
                    args.wavrad,
                    "render",
                    "-q",
                    "-D",
                    "integrator=path",
                    "-D",
                    "max_depth=4",
                    "--mode",
                    "smooth",
                    *args.options.split(),
                    str(xml),
                    "-o",
                    str(image),
                ],
                check=True,
            )
            wavrad = np.array(mi.Bitmap(str(image)))[..., :3]
            keep = reference.max(-1) < 100.0
            ratio = wavrad[keep].mean() / reference[keep].mean()
            print(f"tube {tube}: wavrad / Mitsuba {ratio:.4f}")


if __name__ == "__main__":
    main()
