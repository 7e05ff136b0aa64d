"""PNG plots of waveforms (matplotlib, no screen needed)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from circuitnsds.waveforms import Waveforms

MAX_DEFAULT_SIGNALS = 8


def plot_waveforms(waves: Waveforms, path: str | Path, names: Sequence[str] | None = None) -> None:
    """Write a PNG with voltages (top) and currents (bottom) against time.

    Args:
        waves: the results.
        path: PNG file to write.
        names: signals to draw; default: up to 8 node voltages and the device currents.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if names is None:
        voltages = [n for n in waves.names if n.startswith("v(")][:MAX_DEFAULT_SIGNALS]
        currents = [n for n in waves.names if n.startswith("i(") and not n.startswith("i(r")]
        names = voltages + currents[:MAX_DEFAULT_SIGNALS]
    names = [n.strip().lower() for n in names]
    groups = [[n for n in names if n.startswith("v(")], [n for n in names if not n.startswith("v(")]]
    groups = [g for g in groups if g]
    figure, axes = plt.subplots(len(groups), 1, sharex=True, figsize=(9, 3.2 * len(groups)),
                                squeeze=False)
    scale, unit = _time_scale(float(waves.time[-1]) if waves.time.size else 1.0)
    for axis, group in zip(axes[:, 0], groups):
        for name in group:
            axis.plot(waves.time * scale, waves[name], label=name, linewidth=1.0)
        axis.set_ylabel("voltage [V]" if group[0].startswith("v(") else "current [A]")
        axis.grid(True, alpha=0.3)
        axis.legend(loc="best", fontsize="small")
    axes[-1, 0].set_xlabel(f"time [{unit}]")
    axes[0, 0].set_title(waves.title or "circuitnsds transient")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def _time_scale(stop: float) -> tuple[float, str]:
    for factor, unit in ((1e9, "ns"), (1e6, "µs"), (1e3, "ms")):
        if stop * factor < 1000 and stop * factor >= 1:
            return factor, unit
    return 1.0, "s"
