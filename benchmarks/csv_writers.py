"""CSV writers on 1M rows × 2 columns (issue 19: ≥ 50 MB/s), and what choosing the compiled
formatter costs a whole process; prints two tables.

Table 1, in one process (numba already loaded, medians of ``--repeats``): circuitnsds's
compiled formatter (:mod:`circuitnsds.output.floattext`) with its C kernel (built at
install) and with its numba kernel, the CSV writer as it chooses, its Python writer (all
write the same bytes: ``repr`` of every double), ``numpy.savetxt`` with 10 and 17
significant digits, pandas with 17.

Table 2, whole processes (``python -c`` writing the same file through
``Waveforms.to_csv``): with the C kernel; without it (``CIRCUITNSDS_NATIVE=0``) with the
numba formatter cached (warm), with an empty cache folder (cold: ``CIRCUITNSDS_CACHE_DIR``
a new temporary folder; the writer then stays in Python), forced Python; plus the costs
behind :data:`circuitnsds.output.csvfile.LOADED_VALUES` and
:data:`~circuitnsds.output.csvfile.COLD_VALUES`: importing numba and loading the
formatter in a fresh process, loading it after the stepping loop, and compiling it.

Usage: ``python benchmarks/csv_writers.py [--rows 1000000] [--repeats 3]``.
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

from circuitnsds.output import csvfile, floattext  # noqa: E402
from circuitnsds.output.waveforms import Waveforms  # noqa: E402


def buck_like(rows: int) -> tuple[np.ndarray, np.ndarray]:
    """A time column and a converter-like output voltage (what ``run -o`` writes)."""
    time_column = np.linspace(0.0, 0.1, rows)
    signal = 12.0 + 0.3 * np.sin(1e5 * time_column) + 1e-3 * np.random.default_rng(0).random(rows)
    return time_column, signal


def median_seconds(function, repeats: int) -> float:
    seconds = []
    for _ in range(repeats):
        started = time.perf_counter()
        function()
        seconds.append(time.perf_counter() - started)
    return statistics.median(seconds)


def in_process(rows: int, repeats: int, folder: Path) -> list[tuple[str, float, float]]:
    time_column, signal = buck_like(rows)
    data = np.column_stack([time_column, signal])
    path = folder / "speed.csv"

    def ours(compiled: bool):
        def write():
            with open(path, "wb") as stream:
                csvfile.write_csv(stream, time_column, ["v(out)"], [signal], compiled=compiled)
        return write

    def kernel(kind: str):
        def write():  # what csvfile.write_rows does, with the kernel named
            with open(path, "wb") as stream:
                csvfile.write_header(stream, ["v(out)"])
                for start in range(0, rows, csvfile.BLOCK_ROWS):
                    stream.write(floattext.csv_bytes(data[start:start + csvfile.BLOCK_ROWS], kind=kind))
        return write

    waves = Waveforms(time=time_column, signals={"v(out)": signal})
    writers = {"ours, C kernel (repr)": kernel("native"), "ours, numba kernel (repr)": kernel("numba"),
               "ours, write_csv compiled (C if built, else numba)": ours(True),
               "ours, Python (repr)": ours(False),
               "ours, Waveforms.to_csv (writer chosen by size)": lambda: waves.to_csv(path),
               "numpy.savetxt %.10g": lambda: np.savetxt(path, data, delimiter=",", fmt="%.10g"),
               "numpy.savetxt %.17g": lambda: np.savetxt(path, data, delimiter=",", fmt="%.17g")}
    try:
        import pandas as pd

        frame = pd.DataFrame(data)
        writers["pandas %.17g"] = lambda: frame.to_csv(path, index=False, float_format="%.17g")
    except ImportError:
        pass
    kernel("numba")()  # load the formatters first
    ours(True)()
    table = []
    for label, write in writers.items():
        seconds = median_seconds(write, repeats)
        table.append((label, seconds, path.stat().st_size / 1e6 / seconds))
    return table


WRITE = """
import sys, time
started = time.perf_counter()
import numpy as np
sys.path.insert(0, {root!r})
from circuitnsds.output import csvfile
from circuitnsds.output.waveforms import Waveforms
rows = {rows}
t = np.linspace(0.0, 0.1, rows)
v = 12.0 + 0.3 * np.sin(1e5 * t) + 1e-3 * np.random.default_rng(0).random(rows)
{force}
ready = time.perf_counter()
Waveforms(time=t, signals={{"v(out)": v}}).to_csv({path!r})
print(time.perf_counter() - ready, csvfile.floattext.loaded(), csvfile.floattext.has_native(),
      "numba" in sys.modules)
"""

LOAD = """
import sys, time
sys.path.insert(0, {root!r})
import numpy as np
{before}
from circuitnsds.output import floattext
started = time.perf_counter()
floattext.warm()
print(time.perf_counter() - started)
"""


def process(code: str, cache: str, repeats: int, native: bool) -> tuple[float, float, str]:
    """Median wall time of a whole process, and the median of what it prints first;
    ``native``: with the C kernel (else ``CIRCUITNSDS_NATIVE=0``)."""
    walls, inner, last = [], [], ""
    for _ in range(repeats):
        started = time.perf_counter()
        env = dict(os.environ, CIRCUITNSDS_CACHE_DIR=cache, CIRCUITNSDS_NATIVE="1" if native else "0")
        result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                env=env, check=True)
        walls.append(time.perf_counter() - started)
        inner.append(float(result.stdout.split()[0]))
        last = result.stdout.strip()
    return statistics.median(walls), statistics.median(inner), last


def whole_processes(rows: int, repeats: int, folder: Path) -> list[tuple[str, float, float, str]]:
    root = str(HERE.parent)
    path = str(folder / "process.csv")
    warm = str(folder / "cache")
    from circuitnsds.engine.warmup import main as warm_loops

    os.environ["CIRCUITNSDS_CACHE_DIR"] = warm
    warm_loops()  # compiled loops in the warm cache, marker set
    floattext.warm()  # and the numba formatter (its own main() skips it when the C one is built)
    floattext.ready_marker().touch()
    table = []

    def write(label: str, force: str, cold: bool, native: bool = False) -> None:
        code = WRITE.format(root=root, rows=rows, path=path, force=force)
        cache = tempfile.mkdtemp(dir=folder) if cold else warm
        wall, writing, printed = process(code, cache, 1 if cold else repeats, native)
        _, numba_kernel, c_kernel, numba_imported = printed.split()
        writer = "C" if c_kernel == "True" else "numba" if numba_kernel == "True" else "Python"
        table.append((label, wall, writing, writer + (", numba imported" if numba_imported == "True"
                                                      else "")))

    def load(label: str, before: str, cold: bool) -> None:
        code = LOAD.format(root=root, before=before)
        cache = tempfile.mkdtemp(dir=folder) if cold else warm
        wall, seconds, _ = process(code, cache, 1 if cold else repeats, False)
        table.append((label, wall, seconds, ""))

    write("to_csv, C kernel built", "", False, native=True)
    write("to_csv, C kernel built, empty cache", "", True, native=True)
    write("to_csv, NATIVE=0, numba formatter cached (warm)", "", False)
    write("to_csv, NATIVE=0, forced Python writer", "csvfile.COLD_VALUES = 10**12", False)
    load("load numba formatter, fresh process (numba import + load)", "", False)
    load("load numba formatter after the stepping loop",
         "from circuitnsds.engine.warmup import warm_dense; warm_dense()", False)
    load("compile numba formatter (empty cache)", "", True)
    # last: it starts the warm-up process, which goes on compiling after this one ends
    write("to_csv, NATIVE=0, empty cache (cold: Python writer, warm-up started)", "", True)
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        print(f"CSV of {args.rows:,} rows × 2 columns (time, v(out)); load average "
              f"{os.getloadavg()[0]:.1f}")
        print("\n| writer (in one process) | seconds | MB/s |\n|---|---|---|")
        for label, seconds, rate in in_process(args.rows, args.repeats, folder):
            print(f"| {label} | {seconds:.3f} | {rate:.0f} |")
        print("\n| whole process | wall [s] | inside [s] | writer |\n|---|---|---|---|")
        for label, wall, inside, writer in whole_processes(args.rows, args.repeats, folder):
            print(f"| {label} | {wall:.2f} | {inside:.3f} | {writer} |")
        print(f"\n(python -c pass and numpy's import are part of every wall time; floattext "
              f"tables: {len(floattext.tables()[0])} powers of ten)")
    _ = Waveforms


if __name__ == "__main__":
    main()
