#!/usr/bin/env python3
"""Run the hostile inputs of issue 19 against the CLI and tabulate what each does.

Every case is a scene file, a mesh or a flag that once crashed wavrad, exhausted
the machine or wrote a wrong image with exit status 0. The script runs each with
a time limit and writes `docs/hostile-inputs.md`: the exit status, the wall time,
the first line wavrad printed about it, and whether an output file (or a
temporary file) was left behind. The regression tests that pin each case down
are in `crates/wavrad-io/tests/scene_errors.rs`, `crates/wavrad-cli/tests/`
(`limits.rs`, `cli_errors.rs`) and `tests/` (Python).

    python3 benches/hostile_inputs.py [--wavrad target/release/wavrad] [--timeout 120]
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORNELL = ROOT / "scenes" / "cornell-box" / "scene.xml"


@dataclass
class Case:
    """One hostile input: the files it needs, the command's arguments."""

    what: str
    args: list[str]
    files: dict[str, str]
    command: str = "render"
    output: str | None = "out.exr"


def cornell(res: int = 32) -> str:
    """The bundled Cornell box at a small film, for cases that change one thing."""
    return CORNELL.read_text().replace(
        '<default name="res" value="128"/>', f'<default name="res" value="{res}"/>'
    )


def with_light(text: str, radiance: str) -> str:
    return re.sub(
        r'(<rgb name="radiance" value=")[^"]*(")', rf"\g<1>{radiance}\g<2>", text, count=1
    )


def with_film(text: str, width: str, height: str) -> str:
    return text.replace(
        'value="$res"/>\n            <integer name="height"',
        f'value="{width}"/>\n            <integer name="height"',
    ).replace('<integer name="height" value="$res"/>', f'<integer name="height" value="{height}"/>')


def with_filter(text: str, rfilter: str) -> str:
    return text.replace('<rfilter type="gaussian"/>', rfilter)


def before_walls(text: str, xml: str) -> str:
    return text.replace("<!-- ==================== Walls ==================== -->", xml)


def scaled_rectangle(scale: str) -> str:
    return (
        '<shape type="rectangle"><transform name="to_world">'
        f'<scale value="{scale}"/></transform><ref id="white"/></shape>'
    )


def obj_shape(name: str) -> str:
    return f'<shape type="obj"><string name="filename" value="{name}"/><ref id="white"/></shape>'


TRIANGLE_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


def include_bomb(n: int = 31) -> dict[str, str]:
    files = {}
    for i in range(n):
        inner = (
            ""
            if i == n - 1
            else f'<include filename="f{i + 1}.xml"/><include filename="f{i + 1}.xml"/>'
        )
        files[f"f{i}.xml"] = f'<scene version="3.0.0">{inner}</scene>'
    files["scene.xml"] = before_walls(cornell(), '<include filename="f0.xml"/>')
    return files


def cases() -> list[Case]:
    c = cornell()
    ward_block = (
        '<bsdf type="ward" id="w"><float name="alpha_u" value="1e-308"/>'
        '<float name="alpha_v" value="0.1"/></bsdf>'
    )
    return [
        Case(
            "rectangle scaled by 1e19", [], {"scene.xml": before_walls(c, scaled_rectangle("1e19"))}
        ),
        Case(
            "rectangle scaled by 1e19, `solve`",
            [],
            {"scene.xml": before_walls(c, scaled_rectangle("1e19"))},
            "solve",
            None,
        ),
        Case(
            "rectangle scaled by 1e38", [], {"scene.xml": before_walls(c, scaled_rectangle("1e38"))}
        ),
        Case(
            "OBJ vertex at 1e20",
            [],
            {
                "scene.xml": before_walls(c, obj_shape("m.obj")),
                "m.obj": "v 1e20 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            },
        ),
        Case(
            "OBJ `filename` /dev/zero", [], {"scene.xml": before_walls(c, obj_shape("/dev/zero"))}
        ),
        Case("film 4294967295²", [], {"scene.xml": with_film(c, "4294967295", "4294967295")}),
        Case("film 65536²", [], {"scene.xml": with_film(c, "65536", "65536")}),
        Case("film 100000²", [], {"scene.xml": with_film(c, "100000", "100000")}),
        Case(
            "Gaussian filter `stddev` 1e6",
            [],
            {
                "scene.xml": with_filter(
                    c, '<rfilter type="gaussian"><float name="stddev" value="1e6"/></rfilter>'
                )
            },
        ),
        Case("`sample_count` 2e9", ["-D", "spp=2000000000"], {"scene.xml": c}),
        Case("`--spp 4294967295`", ["--spp", "4294967295"], {"scene.xml": c}),
        Case("`--gather-spp 4294967295`", ["--gather-spp", "4294967295"], {"scene.xml": c}),
        Case("31 files each including the next twice", [], include_bomb()),
        Case("radiance 1e300", [], {"scene.xml": with_light(c, "1e300, 1e300, 1e300")}),
        Case(
            "Ward `alpha_u` 1e-308",
            [],
            {
                "scene.xml": c.replace(
                    "<!-- ==================== Light",
                    ward_block + "<!-- ==================== Light",
                ).replace(
                    '<ref id="white"/>\n    </shape>\n\n    <shape type="rectangle" id="ceiling">',
                    '<ref id="w"/>\n    </shape>\n\n    <shape type="rectangle" id="ceiling">',
                    1,
                )
            },
        ),
        Case(
            "`--threshold 1e-12 --max-level 12` (memory grows)",
            ["--threshold", "1e-12", "--max-level", "12", "--max-memory", "0.3"],
            {"scene.xml": c},
            "solve",
            None,
        ),
        Case(
            "`--solver shoot --threshold 0`",
            ["--solver", "shoot", "--threshold", "0", "--time-limit", "20"],
            {"scene.xml": c},
            "solve",
            None,
        ),
        Case(
            "the paper's settings (`--threshold 1e-4 --max-level 8`), 30 s limit",
            ["--threshold", "1e-4", "--max-level", "8", "--time-limit", "30"],
            {"scene.xml": c},
        ),
        Case("`--stats` in a missing folder", ["--stats", "no/such/dir/s.json"], {"scene.xml": c}),
        Case("output in a missing folder", [], {"scene.xml": c}, "render", "no/such/dir/out.exr"),
        Case("`--stats` the same path as the image", ["--stats", "out.exr"], {"scene.xml": c}),
        Case("`-D` of an undeclared name", ["-D", "nosuch=3"], {"scene.xml": c}),
        Case("`-D` with an empty name", ["-D", "=3"], {"scene.xml": c}),
        Case(
            "a second `<default>` of the same name",
            [],
            {
                "scene.xml": c.replace(
                    '<default name="spp" value="64"/>',
                    '<default name="spp" value="64"/><default name="spp" value="8"/>',
                )
            },
        ),
        Case("a second sensor", [], {"scene.xml": before_walls(c, '<sensor type="perspective"/>')}),
        Case(
            "`--no-gather-cache --mode haar`",
            ["--no-gather-cache", "--mode", "haar"],
            {"scene.xml": c},
        ),
        Case(
            "an unknown integrator parameter",
            [],
            {
                "scene.xml": c.replace(
                    '<integer name="max_depth" value="-1"/>',
                    '<integer name="max_depth" value="-1"/><float name="nosuch" value="1"/>',
                )
            },
        ),
    ]


def first_line(stderr: str) -> str:
    for line in stderr.splitlines():
        line = line.strip()
        if re.search(r"\b(error|warning)\b", line, re.IGNORECASE):
            return line
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    return lines[-1] if lines else ""


def run(case: Case, wavrad: Path, timeout: float) -> dict:
    with tempfile.TemporaryDirectory(prefix="wavrad-hostile-") as tmp:
        d = Path(tmp)
        for name, text in case.files.items():
            (d / name).write_text(text)
        cmd = [str(wavrad), case.command, "scene.xml", "--quiet", *case.args]
        if case.output:
            cmd += ["-o", case.output]
        start = time.monotonic()
        try:
            p = subprocess.run(
                cmd,
                cwd=d,
                capture_output=True,
                text=True,
                timeout=timeout,
                stdin=subprocess.DEVNULL,
            )
            status, message = str(p.returncode), first_line(p.stderr)
        except subprocess.TimeoutExpired as e:
            status, message = (
                f"killed at {timeout:.0f} s",
                first_line((e.stderr or b"").decode(errors="replace")),
            )
        seconds = time.monotonic() - start
        left = sorted(
            str(p.relative_to(d)) for p in d.rglob("*") if p.is_file() and p.name not in case.files
        )
    message = message.replace(str(d) + "/", "").replace(str(d), ".").replace("|", "\\|")
    return {
        "status": status,
        "seconds": seconds,
        "message": message[:220],
        "left": ", ".join(left) or "–",
    }


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--wavrad", type=Path, default=ROOT / "target" / "release" / "wavrad")
    ap.add_argument("--timeout", type=float, default=120.0)
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "hostile-inputs.md")
    args = ap.parse_args()
    if not args.wavrad.exists():
        sys.exit(f"{args.wavrad} does not exist: build it with `make build`")
    rows = []
    for case in cases():
        r = run(case, args.wavrad.resolve(), args.timeout)
        print(
            f"{case.what}: exit {r['status']} in {r['seconds']:.1f} s; {r['message']}", flush=True
        )
        rows.append((case, r))
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Hostile inputs: what each does now",
        "",
        f"Written by `python3 benches/hostile_inputs.py` on {now}, {os.cpu_count()} logical "
        f"CPUs ({platform.machine()}), each case limited to {args.timeout:.0f} s. The cases "
        'are those of issue 19 ("Trustworthy in use"); the Cornell box is the bundled one '
        'at 32². "Left behind" lists the files the command left in its folder besides its '
        "inputs (an image means it succeeded).",
        "",
        "| case | command | exit | seconds | what wavrad says | left behind |",
        "|---|---|---:|---:|---|---|",
    ]
    for case, r in rows:
        flags = " ".join(case.args)
        command = f"{case.command} {flags}".strip()
        cells = [case.what, f"`{command}`", r["status"], f"{r['seconds']:.1f}"]
        lines.append("| " + " | ".join([*cells, r["message"], r["left"]]) + " |")
    tmp = args.out.with_suffix(".md.tmp")
    tmp.write_text("\n".join(lines) + "\n")
    shutil.move(tmp, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
