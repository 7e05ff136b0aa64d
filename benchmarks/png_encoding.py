"""The bridge's PNG figure: what drawing and encoding it cost, and our PNG writer
(:func:`circuitnsds.output.raster_figure.encode_png`) against Pillow's ``save`` at the
compression levels one could choose.

Each way of encoding runs on the same rendered image, interleaved with the others, repeated;
the median and minimum time and the file's size are printed. The first Pillow ``save`` of a
process also imports Pillow's default format plugins: it runs in a fresh process of its own
(the row "Pillow, first save in a process").

Usage: ``python benchmarks/png_encoding.py [--repeat 15]``.
"""

from __future__ import annotations

import argparse
import io
import statistics
import subprocess
import sys
import time
from pathlib import Path

from PIL import Image

import circuitnsds
from circuitnsds.output.plot import _size, default_signals, figure_data
from circuitnsds.output.raster_figure import encode_png, render

BRIDGE = Path(__file__).resolve().parents[1] / "netlists" / "bridge_rectifier.cir"

FIRST_SAVE = """
import io, time
from PIL import Image
image = Image.new("RGB", (1200, 768), "white")
started = time.perf_counter()
image.save(io.BytesIO(), format="PNG", compress_level=3)
print(time.perf_counter() - started)
"""


def _pillow(level: int):
    def encode(image: Image.Image) -> bytes:
        buffer = io.BytesIO()
        image.save(buffer, format="PNG", dpi=(120, 120), compress_level=level)
        return buffer.getvalue()
    return encode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=15)
    args = parser.parse_args()
    waves = circuitnsds.read_netlist(BRIDGE).transient()
    data = figure_data(waves, default_signals(waves), False)
    size = _size(len(data.panels))
    render(data, size)  # fonts loaded, memory touched
    renders = []
    for _ in range(args.repeat):
        started = time.perf_counter()
        image = render(data, size)
        renders.append(time.perf_counter() - started)
    ways = {"ours (filter none, zlib 3)": lambda image: encode_png(image, 120),
            **{f"Pillow save, level {level}": _pillow(level) for level in (1, 3, 6)}}
    times: dict[str, list[float]] = {name: [] for name in ways}
    sizes = {}
    for _ in range(args.repeat):  # interleaved: the machine's drift hits every way alike
        for name, encode in ways.items():
            started = time.perf_counter()
            sizes[name] = len(encode(image))
            times[name].append(time.perf_counter() - started)
    firsts = [float(subprocess.run([sys.executable, "-c", FIRST_SAVE], capture_output=True, text=True,
                                   check=True).stdout) for _ in range(5)]
    print(f"bridge figure {image.size[0]} x {image.size[1]}; render (text by Pillow, lines in C if built): "
          f"median {statistics.median(renders) * 1e3:.1f} ms, min {min(renders) * 1e3:.1f} ms\n")
    print(f"{'encoding':32} {'median [ms]':>11} {'min [ms]':>9} {'size [kB]':>10}")
    for name in ways:
        print(f"{name:32} {statistics.median(times[name]) * 1e3:11.1f} {min(times[name]) * 1e3:9.1f} "
              f"{sizes[name] / 1e3:10.1f}")
    print(f"{'Pillow, first save in a process':32} {statistics.median(firsts) * 1e3:11.1f} "
          f"{min(firsts) * 1e3:9.1f} {'(blank)':>10}")


if __name__ == "__main__":
    main()
