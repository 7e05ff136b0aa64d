"""The converters of issue 21, written with B-source comparators and with XSPICE digital
parts: agreement with ngspice running the same file, and wall times.

Run from the repository root::

    python benchmarks/xspice_converters.py [--repeat 3]

For each netlist (ngspice at N = 0.03, the stop time and step of the table): circuitnsds /
ngspice - 1 for the mean output, the switching frequency and the duty cycle of v(sw) over
the window, circuitnsds's wall time (median of ``--repeat``, parsing excluded) with
``stepping=auto`` and ``stepping=compiled``, and ngspice's (its ``run`` command).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from pathlib import Path

import circuitnsds

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from tests.test_behavioural import _converter_figures  # noqa: E402

CASES = [
    # netlist, .param vramp (None: as written), step [s], stop [s], output, window start [s], options
    ("buck_hysteretic.cir", None, 4e-8, 400e-6, "v(a)", 100e-6, ""),
    ("buck_hysteretic_xspice.cir", None, 4e-8, 400e-6, "v(a)", 100e-6, ""),
    ("buck_voltage_mode.cir", None, 4e-8, 1.8e-3, "v(out)", 1.4e-3, "method=gear"),
    ("buck_voltage_mode_xspice.cir", None, 4e-8, 1.8e-3, "v(out)", 1.4e-3, "method=gear"),
    ("buck_peak_current.cir", 0.8, 2e-8, 0.6e-3, "v(out)", 0.4e-3, ""),
    ("buck_peak_current_xspice.cir", 0.8, 2e-8, 0.6e-3, "v(out)", 0.4e-3, ""),
    ("buck_peak_current_xspice.cir", 0.0, 2e-8, 0.6e-3, "v(out)", 0.4e-3, ""),
]


def _path(name: str, ramp: float | None, scratch: Path) -> Path:
    path = ROOT / "netlists" / name
    if ramp is None:
        return path
    copy = scratch / f"{path.stem}_vramp{ramp}.cir"
    copy.write_text(path.read_text().replace(".param vramp=0\n", f".param vramp={ramp}\n"))
    return copy


def main() -> None:
    import tempfile

    from circuitnsds.compare import compare

    parser = argparse.ArgumentParser()
    parser.add_argument("--repeat", type=int, default=3)
    repeat = parser.parse_args().repeat
    print(f"{'netlist':<30} {'vramp':>5} {'mean':>9} {'freq':>9} {'duty':>9} {'auto s':>7} "
          f"{'compiled s':>10} {'ngspice s':>9}")
    with tempfile.TemporaryDirectory() as scratch, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, ramp, step, stop, output, start, options in CASES:
            path = _path(name, ramp, Path(scratch))
            comparison = compare(path, n=0.03, step=step, stop=stop, signals=[output, "v(sw)"],
                                 ngspice_options=options)
            ours, theirs = comparison.circuitnsds, comparison.run.ngspice.waveforms
            mine = _converter_figures(ours.time, ours[output], ours["v(sw)"], start)
            reference = _converter_figures(theirs.time, theirs[output], theirs["v(sw)"], start)
            circuit = circuitnsds.read_netlist(path)
            seconds = {}
            for stepping in ("auto", "compiled"):
                circuit.transient(stop=stop / 20, step=step, stepping=stepping)   # warm up
                times = []
                for _ in range(repeat):
                    begin = time.perf_counter()
                    circuit.transient(stop=stop, step=step, stepping=stepping)
                    times.append(time.perf_counter() - begin)
                seconds[stepping] = statistics.median(times)
            ratios = [a / b - 1 for a, b in zip(mine, reference)]
            print(f"{name:<30} {'' if ramp is None else ramp:>5} {ratios[0]:>+9.1e} "
                  f"{ratios[1]:>+9.1e} {ratios[2]:>+9.1e} {seconds['auto']:>7.2f} "
                  f"{seconds['compiled']:>10.2f} {comparison.run.ngspice.seconds:>9.2f}")


if __name__ == "__main__":
    main()
