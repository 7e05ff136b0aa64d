"""Reports of a comparison: a text table, JSON, an overlay plot and a convergence plot."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from circuitnsds.compare.errors import CompareError
from circuitnsds.compare.metrics import DC_LIKE, NEGLIGIBLE

if TYPE_CHECKING:
    from circuitnsds.compare.api import Comparison, RunComparison

#: At most this many signals are drawn in the overlay plot (the table has them all).
MAX_PLOTTED_SIGNALS = 8

_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"),
             (1e-12, "p"), (1e-15, "f"))


def unit_of(signal: str) -> str:
    """``"V"`` for ``v(...)``, ``"A"`` for ``i(...)``."""
    return "V" if signal.startswith("v(") else "A"


def engineering(value: float | None, unit: str = "", digits: int = 3) -> str:
    """``0.0123, "V"`` -> ``"12.3 mV"``; ``None``/NaN -> ``"-"``."""
    if value is None or not math.isfinite(value):
        return "-"
    if value == 0:
        return f"0 {unit}".strip()
    for factor, prefix in _PREFIXES:
        if abs(value) >= factor * 0.9995:
            return f"{value / factor:.{digits}g} {prefix}{unit}".strip()
    return f"{value:.{digits}g} {unit}".strip()


def run_label(run: RunComparison) -> str:
    return run.overrides.label()


def _run_status(run: RunComparison) -> str:
    ngspice = run.ngspice
    if ngspice.ok:
        points = ngspice.waveforms.time.size if ngspice.waveforms is not None else 0
        return f"ok, {points} time points in {ngspice.seconds:.3g} s"
    if ngspice.status == "rejected":
        return f"REJECTED the netlist: {ngspice.message}"
    where = engineering(ngspice.stopped_at, "s") if ngspice.stopped_at is not None else "the start"
    return f"FAILED at t = {where} after {ngspice.seconds:.3g} s: {ngspice.message}"


def format_table(comparison: Comparison) -> str:
    """The report printed by ``circuitnsds compare``: one table per ngspice run, then a summary."""
    waves = comparison.circuitnsds
    steps = int(waves.stats.get("steps", max(waves.time.size - 1, 0)))
    t0, t1 = comparison.window
    lines = [
        f"{comparison.netlist}: {comparison.title}",
        f"  circuitnsds (ideal devices): {steps} steps in {comparison.circuitnsds_seconds:.3g} s"
        + (f", θ = {comparison.theta:g}" if comparison.theta != 1 else ""),
        f"  {comparison.ngspice_version or 'ngspice'} (Shockley diodes, PySpice "
        f"{comparison.pyspice_version or '?'})"
        + (f", .options {comparison.ngspice_options}" if comparison.ngspice_options else ""),
        f"  window {engineering(t0, 's')} .. {engineering(t1, 's')}",
        *(f"  for ngspice: {note}" for note in comparison.notes),
        "  errors of ngspice against circuitnsds: nRMS and nMAX normalised by the circuitnsds "
        "signal's range, rRMS by its RMS value;",
        "  the summary ranks by rRMS for DC-like signals (range below "
        f"{DC_LIKE:g} of the RMS value, marked *) and by nRMS otherwise;",
        "  Δmean and Δripple are ngspice minus circuitnsds (time average, peak-to-peak);",
        f"  (negligible): varies and differs by less than {NEGLIGIBLE:g} of the largest range of "
        "its kind; left out of summaries",
    ]
    for run in comparison.runs:
        lines.append("")
        lines.append(f"ngspice {run_label(run)}: {_run_status(run)}")
        if run.metrics:
            lines.append(f"  {'signal':<16}{'range':>11}{'nRMS':>10}{'rRMS':>10}{'nMAX':>10}{'at':>11}"
                         f"{'Δmean':>12}{'Δripple':>12}")
            for name in comparison.signals:
                metric = run.metrics.get(name)
                if metric is None:
                    lines.append(f"  {name:<16}  (not provided by ngspice)")
                    continue
                unit = unit_of(name)
                rrms = _percent(metric.rrms) + ("*" if metric.dc_like else "")
                lines.append(f"  {name:<16}{engineering(metric.scale, unit):>11}{_percent(metric.nrms):>10}"
                             f"{rrms:>10}"
                             f"{_percent(metric.nmax):>10}{engineering(metric.max_at, 's'):>11}"
                             f"{engineering(metric.mean_diff, unit):>12}"
                             f"{engineering(metric.ripple_diff, unit):>12}"
                             + ("  (negligible)" if metric.negligible else ""))
        elif run.ngspice.missing and run.ok:
            lines.append(f"  ngspice provided none of: {', '.join(run.ngspice.missing)}")
        if run.measurements:
            lines.append(f"  {'.meas':<16}{'circuitnsds':>16}{'ngspice':>16}{'relative':>12}")
            for name, (ours, theirs) in run.measurements.items():
                relative = abs(ours - theirs) / max(abs(theirs), 1e-300)
                lines.append(f"  {name:<16}{ours:>16.7g}{theirs:>16.7g}{relative:>12.2e}")
    if len(comparison.runs) > 1:
        lines.append("")
        lines.append("convergence (largest error over the signals):")
        lines.append(f"  {'ngspice':<22}{'status':<8}{'time [s]':>10}{'points':>8}  {'error':>8} "
                     f"{'signal':<14}{'nMAX':>8} signal")
        for run in comparison.runs:
            points = run.ngspice.waveforms.time.size if run.ngspice.waveforms is not None else 0
            status = "ok" if run.ok else run.ngspice.status
            rms, peak = run.worst("error"), run.worst("nmax")
            row = f"  {run_label(run):<22}{status:<8}{run.ngspice.seconds:>10.3g}{points:>8}  "
            if rms is not None and peak is not None:
                row += f"{_percent(rms.error):>8} {rms.signal:<14}{_percent(peak.nmax):>8} {peak.signal:<14}"
            elif not run.ok:
                where = engineering(run.ngspice.stopped_at, "s") if run.ngspice.stopped_at is not None \
                    else "start"
                row += f"stopped at {where}"
            lines.append(row.rstrip())
    return "\n".join(lines)


def _percent(value: float) -> str:
    if not math.isfinite(value):
        return "-"
    return f"{100 * value:.3g}%"


def _clean(value):
    """NaN/inf -> None, numpy scalars -> Python numbers (for JSON)."""
    if isinstance(value, dict):
        return {key: _clean(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def comparison_dict(comparison: Comparison) -> dict:
    """The comparison as plain data (what ``--json`` writes)."""
    waves = comparison.circuitnsds
    runs = []
    for run in comparison.runs:
        ngspice = run.ngspice
        runs.append({
            "overrides": run.overrides.items(),
            "status": ngspice.status,
            "message": ngspice.message,
            "stopped_at": ngspice.stopped_at,
            "seconds": ngspice.seconds,
            "points": int(ngspice.waveforms.time.size) if ngspice.waveforms is not None else 0,
            "missing": ngspice.missing,
            "metrics": {name: metric.to_dict() for name, metric in run.metrics.items()},
            "messages": ngspice.messages,
        })
    return _clean({
        "netlist": comparison.netlist,
        "title": comparison.title,
        "ngspice_version": comparison.ngspice_version,
        "pyspice_version": comparison.pyspice_version,
        "signals": comparison.signals,
        "window": list(comparison.window),
        "circuitnsds": {
            "seconds": comparison.circuitnsds_seconds,
            "steps": int(waves.stats.get("steps", max(waves.time.size - 1, 0))),
            "points": int(waves.time.size),
        },
        "theta": comparison.theta,
        "ngspice_options": comparison.ngspice_options,
        "notes": comparison.notes,
        "runs": runs,
    })


def write_json(comparison: Comparison, path: str | Path) -> None:
    Path(path).write_text(json.dumps(comparison_dict(comparison), indent=2) + "\n", encoding="utf-8")


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _time_scale(stop: float) -> tuple[float, str]:
    for factor, unit in ((1e9, "ns"), (1e6, "µs"), (1e3, "ms")):
        if 1 <= stop * factor < 1000:
            return factor, unit
    return 1.0, "s"


def plot_overlay(comparison: Comparison, path: str | Path) -> None:
    """PNG: per signal, circuitnsds and every ngspice run overlaid (left), ngspice − circuitnsds (right).

    A failed ngspice run is drawn up to where it stopped, which is marked with ×.
    At most :data:`MAX_PLOTTED_SIGNALS` signals are drawn.
    """
    plt = _pyplot()
    waves = comparison.circuitnsds
    signals = comparison.signals[:MAX_PLOTTED_SIGNALS]
    figure, axes = plt.subplots(len(signals), 2, sharex=True, squeeze=False, layout="constrained",
                                figsize=(12, 2.4 * len(signals) + 0.8))
    scale, unit = _time_scale(float(waves.time[-1]) if waves.time.size else 1.0)
    colors = plt.get_cmap("viridis")(np.linspace(0.0, 0.85, max(len(comparison.runs), 1)))
    for row, name in enumerate(signals):
        left, right = axes[row]
        left.plot(waves.time * scale, waves[name], color="black", linewidth=2.0, alpha=0.5,
                  label="circuitnsds (ideal)")
        for color, run in zip(colors, comparison.runs):
            ngspice = run.ngspice
            if ngspice.waveforms is None or name not in ngspice.waveforms.signals:
                continue
            label = f"ngspice {run_label(run)}" + ("" if run.ok else " (failed)")
            left.plot(ngspice.waveforms.time * scale, ngspice.waveforms[name], color=color, linewidth=1.0,
                      linestyle="-" if run.ok else "--", label=label)
            if name in run.resampled:
                right.plot(waves.time * scale, run.resampled[name] - waves[name], color=color,
                           linewidth=1.0, linestyle="-" if run.ok else "--", label=label)
            if not run.ok and ngspice.waveforms.time.size:
                left.plot(ngspice.waveforms.time[-1] * scale, ngspice.waveforms[name][-1], "x",
                          color="red", markersize=9)
        left.set_ylabel(f"{name} [{unit_of(name)}]")
        right.set_ylabel(f"difference [{unit_of(name)}]")
        for axis in (left, right):
            axis.grid(True, alpha=0.3)
            if comparison.window != (float(waves.time[0]), float(waves.time[-1])):
                axis.axvspan(comparison.window[0] * scale, comparison.window[1] * scale, color="0.9",
                             zorder=0)
    axes[0, 0].legend(loc="best", fontsize="x-small")
    axes[0, 0].set_title("waveforms")
    axes[0, 1].set_title("ngspice − circuitnsds")
    for axis in axes[-1]:
        axis.set_xlabel(f"time [{unit}]")
    figure.suptitle(f"{comparison.title}  ({comparison.ngspice_version})", fontsize="medium")
    figure.savefig(path, dpi=110)
    plt.close(figure)


def plot_convergence(comparison: Comparison, path: str | Path) -> None:
    """PNG: normalised RMS and max error per signal (left) and ngspice's runtime (right) against N.

    Runs where ngspice failed are marked with a red × on the N axis.

    Raises:
        CompareError: the comparison did not sweep the emission coefficient N.
    """
    runs = comparison.runs
    if len(runs) < 2 or any(run.overrides.n is None for run in runs):
        raise CompareError("a convergence plot needs ngspice runs at two or more values of N",
                           hint="give several emission coefficients, e.g. --n 1,0.3,0.1,0.03")
    plt = _pyplot()
    figure, (errors, times) = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    n_values = np.array([run.overrides.n for run in runs], dtype=float)
    finished = np.array([run.ok for run in runs])
    colors = plt.get_cmap("tab10")
    shown = [name for name in comparison.signals
             if any(name in run.metrics and not run.metrics[name].negligible for run in runs)]
    for index, name in enumerate(shown[:10]):
        rms = np.array([run.metrics[name].error if name in run.metrics else np.nan for run in runs])
        peak = np.array([run.metrics[name].nmax if name in run.metrics else np.nan for run in runs])
        errors.loglog(n_values, rms, "o-", color=colors(index), label=f"{name} RMS")
        errors.loglog(n_values, peak, "s:", color=colors(index), alpha=0.6, markersize=4,
                      label=f"{name} max")
    for n_value in n_values[~finished]:
        errors.axvline(n_value, color="red", alpha=0.3)
    errors.set_xlabel("emission coefficient N of the ngspice diodes")
    errors.set_ylabel("error / signal range")
    errors.set_title("ngspice (Shockley) vs circuitnsds (ideal)")
    errors.grid(True, which="both", alpha=0.3)
    if shown:
        errors.legend(fontsize="x-small", ncol=2)
    else:
        errors.text(0.5, 0.5, "ngspice finished no run", transform=errors.transAxes, ha="center")
    seconds = np.array([run.ngspice.seconds for run in runs])
    if finished.any():
        times.loglog(n_values[finished], seconds[finished], "o-", color="tab:blue", label="ngspice finished")
    if (~finished).any():
        times.loglog(n_values[~finished], np.maximum(seconds[~finished], 1e-4), "x", color="red",
                     markersize=10, label="ngspice failed")
    times.axhline(comparison.circuitnsds_seconds, color="black", linestyle="--",
                  label=f"circuitnsds ({comparison.circuitnsds_seconds:.3g} s)")
    times.set_xlabel("emission coefficient N of the ngspice diodes")
    times.set_ylabel("wall time [s]")
    times.set_title(f"runtime ({comparison.ngspice_version})")
    times.grid(True, which="both", alpha=0.3)
    times.legend(fontsize="small")
    figure.suptitle(comparison.title, fontsize="medium")
    figure.savefig(path, dpi=110)
    plt.close(figure)
