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

import importlib
import sys
import types

_HOMES = {
    "Comparison": "api", "RunComparison": "api", "compare": "api",
    "CompareError": "errors", "NgspiceUnavailable": "errors",
    "SignalMetrics": "metrics", "resample": "metrics", "signal_metrics": "metrics",
    "NgspiceRun": "ngspice", "ngspice_version": "ngspice", "run_ngspice": "ngspice",
    "DiodeOverrides": "translate", "translate_netlist": "translate",
}
"""Each public name and its module, imported on first use: ``import circuitnsds`` (and
every ``circuitnsds run``) does not pay for the comparison's modules (~0.03-0.09 s)."""


def __getattr__(name: str):
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_HOMES[name]}"), name)
    globals()[name] = value
    return value


class _CallableModule(types.ModuleType):
    """``circuitnsds.compare`` is both this package and, called, :func:`~.api.compare`."""

    def __call__(self, *args, **kwargs):
        return self.compare(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule

__all__ = [
    "CompareError", "Comparison", "DiodeOverrides", "NgspiceRun", "NgspiceUnavailable", "RunComparison",
    "SignalMetrics", "compare", "ngspice_version", "resample", "run_ngspice", "signal_metrics",
    "translate_netlist",
]
