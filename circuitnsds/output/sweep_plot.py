"""Figures of a sweep table: one panel per measurement.

* A parameter sweep: the measurement against the first parameter that takes more than
  one value, one line per value (or combination of values) of the other varying
  parameters; a logarithmic axis when the values span two decades or more.
* A Monte Carlo run (the only varying parameter is ``run``): a histogram of each
  measurement, its mean and standard deviation in the title.

Failed points are left out (and counted in the title).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from circuitnsds.output.plot import PlotError, save_figure

MAX_LINES = 12
"""Most lines in one panel (more combinations of the other parameters is an error)."""


def varying(table, parameters: Sequence[str]) -> list[str]:
    """The parameters that take more than one value in ``table``."""
    return [p for p in parameters if table[p].nunique() > 1]


def plot_sweep(table, parameters: Sequence[str], measures: Sequence[str], path: str | Path,
               run: str = "run", dpi: int = 120) -> None:
    """Write the figure of a sweep to ``path`` (format from the extension).

    Args:
        table: the table of :func:`circuitnsds.sweep`.
        parameters: its parameter columns, in sweep order.
        measures: its measurement columns.
        run: the Monte Carlo run parameter.

    Raises:
        PlotError: nothing to plot (no measurement, no varying parameter, every point
            failed) or too many lines.
    """
    from matplotlib.figure import Figure

    if not measures:
        raise PlotError("a sweep figure shows measurements, and none was asked for",
                        where="--plot", hint='add --measure "mean(v(out))" (or another measurement)')
    ok = table[table["status"] == "ok"]
    if ok.empty:
        raise PlotError("every point failed: nothing to plot", where="--plot",
                        hint="see the error column of the table")
    changing = varying(table, parameters)
    if not changing:
        raise PlotError("no parameter takes more than one value: nothing to plot against",
                        where="--plot")
    failed = len(table) - len(ok)
    note = f" ({failed} failed point{'s' * (failed != 1)} left out)" if failed else ""
    figure = Figure(figsize=(7.5, 1.2 + 3.0 * len(measures)), layout="constrained")
    axes = np.atleast_1d(figure.subplots(len(measures), 1, squeeze=False)[:, 0])
    if changing == [run]:
        for axis, measure in zip(axes, measures):
            values = ok[measure].to_numpy(dtype=float)
            axis.hist(values, bins=min(50, max(5, int(np.sqrt(values.size)))))
            axis.set_xlabel(measure)
            axis.set_ylabel("points")
            std = values.std(ddof=1) if values.size > 1 else 0.0
            axis.set_title(f"{measure}: mean {values.mean():.6g}, std {std:.3g}, "
                           f"{values.size} runs{note}", fontsize="medium")
        save_figure(figure, path, dpi)
        return
    x, others = changing[0], [p for p in changing[1:] if p != run]
    groups = list(ok.groupby(others, sort=True)) if others else [((), ok)]
    if len(groups) > MAX_LINES:
        raise PlotError(f"{len(groups)} lines (one per value of {', '.join(others)}): more than "
                        f"{MAX_LINES}", where="--plot", hint="sweep fewer values, or plot the table's "
                        "CSV yourself")
    values = table[x].to_numpy(dtype=float)
    logarithmic = bool(np.all(values > 0) and values.max() / values.min() >= 100)
    for axis, measure in zip(axes, measures):
        for key, group in groups:
            key = key if isinstance(key, tuple) else (key,)
            label = ", ".join(f"{name}={value:g}" for name, value in zip(others, key)) or None
            group = group.sort_values(x)
            style = "o" if run in changing else "o-"
            axis.plot(group[x], group[measure], style, label=label, markersize=4)
        axis.set_xlabel(x)
        axis.set_ylabel(measure)
        if logarithmic:
            axis.set_xscale("log")
        axis.grid(True, alpha=0.3)
        if others:
            axis.legend(fontsize="small")
    axes[0].set_title(f"{len(ok)} points{note}", fontsize="medium")
    save_figure(figure, path, dpi)

