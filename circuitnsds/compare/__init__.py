"""Comparison with ngspice: the same netlist with ideal devices (circuitnsds) and Shockley diodes (ngspice).

ngspice runs in-process through PySpice's shared-library interface
(``apt-get install ngspice libngspice0-dev``, ``pip install 'circuitnsds[ngspice]'``).
See ``docs/compare.md``.

Typical use::

    from circuitnsds import compare
    result = compare("netlists/half_wave_rectifier.cir", n=[1, 0.3, 0.1, 0.03])
    print(result.table())
    result.runs[-1].metrics["v(out)"].nrms      # RMS error / range of v(out) at N = 0.03
"""

from circuitnsds.compare.api import Comparison, RunComparison, compare
from circuitnsds.compare.errors import CompareError, NgspiceUnavailable
from circuitnsds.compare.metrics import SignalMetrics, resample, signal_metrics
from circuitnsds.compare.ngspice import NgspiceRun, ngspice_version, run_ngspice
from circuitnsds.compare.translate import DiodeOverrides, translate_netlist

__all__ = [
    "CompareError", "Comparison", "DiodeOverrides", "NgspiceRun", "NgspiceUnavailable", "RunComparison",
    "SignalMetrics", "compare", "ngspice_version", "resample", "run_ngspice", "signal_metrics",
    "translate_netlist",
]
