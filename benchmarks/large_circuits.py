"""Issue 20 benchmark: reading and simulating large circuits, time and peak memory.

Cases (each in a fresh process, so that its peak resident set size is its own):

* ``read N``: ``read_netlist`` of an RC ladder of N elements (reading is linear: elements
  are indexed by name, the common netlist line is split without the character loop);
* ``ladder N``: the diode-RC ladder of ``benchmarks/performance.py`` with N sections
  (N nodes, N complementarity pairs): its DC operating point, then 1,000 time steps.

Prints one table: wall and CPU seconds of the measured part, and the process's peak RSS
(``resource.getrusage``, which includes Python, numpy, scipy and numba: ~150 MB for the
smallest case). The machine is shared, so CPU seconds are the steadier figure.

Usage: ``python benchmarks/large_circuits.py [--quick]`` (``--quick``: smaller sizes).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).parent

CHILD = r"""
import json, resource, sys, time
import circuitnsds
kind, size, path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
wall, cpu = time.perf_counter(), time.process_time()
circuit = circuitnsds.read_netlist(path)
result = {"read_s": time.perf_counter() - wall, "read_cpu_s": time.process_time() - cpu,
          "elements": len(circuit.elements)}
if kind == "ladder":
    wall, cpu = time.perf_counter(), time.process_time()
    circuit.operating_point()
    result.update(op_s=time.perf_counter() - wall, op_cpu_s=time.process_time() - cpu)
    wall, cpu = time.perf_counter(), time.process_time()
    waves = circuit.transient()
    result.update(tran_s=time.perf_counter() - wall, tran_cpu_s=time.process_time() - cpu,
                  steps=int(waves.stats["steps"]), mapped=int(waves.stats["mapped_steps"]))
result["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps(result))
"""


def rc_netlist(elements: int) -> str:
    """A source and an RC ladder with ``elements`` elements in all (one node per section)."""
    lines = [f"RC ladder of {elements} elements", "V1 n0 0 SIN(0 10 50)"]
    section = 0
    while len(lines) - 1 < elements:
        lines.append(f"R{section} n{section} n{section + 1} 10")
        if len(lines) - 1 < elements:
            lines.append(f"C{section} n{section + 1} 0 1u")
        section += 1
    return "\n".join(lines + [".tran 1u 10u", ".end"]) + "\n"


def ladder_netlist(sections: int, steps: int = 1000) -> str:
    """The diode-RC ladder of ``benchmarks/performance.py``, ``steps`` steps of 10 µs."""
    lines = [f"Ladder of {sections} diode-RC sections", "V1 n0 0 SIN(10 1 1k)"]
    for k in range(1, sections + 1):
        lines += [f"D{k} n{k - 1} n{k} dl", f"R{k} n{k} 0 {1e3 * sections!r}", f"C{k} n{k} 0 1u"]
    lines += [".model dl D(Ron=1)", f".tran 10u {steps * 1e-5!r}", ".end"]
    return "\n".join(lines) + "\n"


def measure(kind: str, size: int, text: str) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "case.cir"
        path.write_text(text)
        done = subprocess.run([sys.executable, "-c", CHILD, kind, str(size), str(path)],
                              capture_output=True, text=True, check=False,
                              env={**os.environ, "PYTHONPATH": str(HERE.parent)})
    if done.returncode != 0:
        return {"error": (done.stderr.strip().splitlines() or ["?"])[-1]}
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes (smoke test)")
    args = parser.parse_args(argv)
    reads = [10_000] if args.quick else [10_000, 100_000]
    ladders = [300] if args.quick else [1_000, 10_000]
    print(f"{'case':<16} {'elements':>9} {'read s':>7} {'(cpu)':>6} {'op s':>7} {'(cpu)':>6} "
          f"{'tran s':>7} {'(cpu)':>6} {'steps':>6} {'mapped':>7} {'peak RSS':>9}")
    for kind, sizes, make in (("read", reads, rc_netlist), ("ladder", ladders, ladder_netlist)):
        for size in sizes:
            row = measure(kind, size, make(size))
            if "error" in row:
                print(f"{kind} {size:<11} failed: {row['error']}")
                continue

            def cell(key: str, width: int = 7, row: dict = row) -> str:
                return f"{row[key]:>{width}.2f}" if key in row else f"{'-':>{width}}"

            print(f"{kind + ' ' + str(size):<16} {row['elements']:>9} {cell('read_s')} "
                  f"{cell('read_cpu_s', 6)} {cell('op_s')} {cell('op_cpu_s', 6)} {cell('tran_s')} "
                  f"{cell('tran_cpu_s', 6)} {row.get('steps', '-'):>6} {row.get('mapped', '-'):>7} "
                  f"{row['peak_rss_mb']:>7.0f} MB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
