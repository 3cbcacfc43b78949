#!/usr/bin/env python3
"""Mitsuba 3's wall-clock cost per sample on this machine, at 256² and
512², through the benchmark's own render path (benches/benchmarks.py:
the bundled Cornell box, box filter, multijitter, path): whether its time
per spp grows with the pixels alone, and how fast this machine is against
the one of another run. Run from the repository root with the Python of
`make bench`:

    .venv/bin/python benches/mitsuba_sample_cost.py
"""

import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import benchmarks  # noqa: E402

# (resolution, spp): the same number of samples at both sizes, twice each.
RENDERS = ((256, 4), (256, 288), (512, 72), (256, 288), (512, 72))


def main() -> None:
    mitsuba = benchmarks.Mitsuba()
    with tempfile.TemporaryDirectory() as folder:
        xml = benchmarks.bench_xml("cornell-box", "multijitter", folder)
        for res, spp in RENDERS:
            _, actual, seconds, cpu = mitsuba.render(xml, res, spp, "path", "timed")
            per_sample = seconds / (actual * res * res) * 1e9
            print(f"{res}² {actual} spp: {seconds:.2f} s ({cpu:.1f} s CPU), "
                  f"{per_sample:.0f} ns per sample", flush=True)


if __name__ == "__main__":
    main()
