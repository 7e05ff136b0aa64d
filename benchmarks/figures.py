"""Waveform figures: matplotlib against our PNG renderer (``output/raster_figure.py``: lines
painted in C where it was built at install, else by Pillow; text by Pillow).

Prints one table: the import of each (a fresh process, median), and drawing and writing the
figure in-process (best of ``--repeats``) for the bundled bridge rectifier (10 signals,
5,001 points, two panels) and for a million-point signal (a sine with ringing and one spike,
three traces). The PNG goes through :func:`circuitnsds.output.plot.plot_waveforms`;
matplotlib's figure through :func:`~circuitnsds.output.plot.draw` and ``save_figure`` (the
path every PDF/SVG takes), at the same size and dpi.

    python benchmarks/figures.py [--repeats 3] [--out folder]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from circuitnsds.output.plot import _panels, _size, default_signals, draw, plot_waveforms, save_figure  # noqa: E402
from circuitnsds.output.waveforms import Waveforms  # noqa: E402


def import_seconds(statement: str, repeats: int) -> float:
    """Median wall time of a fresh Python running ``statement`` minus one running ``pass``
    (so ~0.01 s of noise)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}

    def once(code: str) -> float:
        started = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True, env=env)
        return time.perf_counter() - started

    base = statistics.median(once("pass") for _ in range(repeats))
    return statistics.median(once(statement) for _ in range(repeats)) - base


def best(function, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        function()
        times.append(time.perf_counter() - started)
    return min(times)


def matplotlib_png(waves: Waveforms, path: Path) -> None:
    from matplotlib.figure import Figure

    names = default_signals(waves)
    figure = Figure(figsize=_size(len(_panels(names))), layout="constrained")
    draw(figure, waves, names)
    save_figure(figure, path, 120, "png")


def cases() -> dict[str, Waveforms]:
    import circuitnsds

    bridge = circuitnsds.read_netlist(HERE.parent / "netlists" / "bridge_rectifier.cir").transient()
    time_ = np.linspace(0.0, 1e-3, 1_000_001)
    ringing = np.sin(2 * np.pi * 5e3 * time_) + 0.3 * np.sin(2 * np.pi * 3e5 * time_)
    ringing[500_000] = 5.0
    million = Waveforms(time_, {"v(a)": ringing, "v(b)": 0.5 * ringing, "i(x)": 1e-3 * ringing},
                        title="1M points")
    return {"bridge (10 signals x 5,001)": bridge, "1M points (3 signals)": million}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=None, help="keep the PNGs in this folder")
    args = parser.parse_args(argv)
    out = args.out or Path(tempfile.mkdtemp())
    out.mkdir(parents=True, exist_ok=True)
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print("| | matplotlib [s] | ours, PNG [s] |")
    print("|---|---|---|")
    mpl_import = import_seconds("import matplotlib.figure, matplotlib.backends.backend_agg", args.repeats)
    pil_import = import_seconds("import PIL.Image, PIL.ImageDraw, PIL.ImageFont", args.repeats)
    print(f"| import (fresh process, median) | {mpl_import:.3f} | {pil_import:.3f} |")
    for label, waves in cases().items():
        stem = label.split()[0]
        mpl = best(lambda w=waves, s=stem: matplotlib_png(w, out / f"{s}_matplotlib.png"), args.repeats)
        pil = best(lambda w=waves, s=stem: plot_waveforms(w, out / f"{s}_pillow.png"), args.repeats)
        print(f"| {label}: draw + write PNG (best of {args.repeats}) | {mpl:.3f} | {pil:.3f} |")
    print(f"PNGs in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
