"""Bode tables and figures of small-signal results (:class:`~circuitnsds.analyses.ac.ACResult`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from circuitnsds.output.files import atomic_path
from circuitnsds.output.plot import save_figure
from circuitnsds.units import format_si


def write_bode_csv(result, path) -> None:
    """CSV: ``frequency`` [Hz], then ``mag(OUT)`` [dB] and ``phase(OUT)`` [deg] per output;
    ``path`` a file name (written all or nothing) or an open text stream (``sys.stdout``)."""
    names = list(result.transfer)
    columns = [result.frequencies]
    header = ["frequency"]
    for name in names:
        columns += [result.magnitude_db(name), result.phase_deg(name)]
        header += [f"mag({name})", f"phase({name})"]
    if hasattr(path, "write"):
        np.savetxt(path, np.column_stack(columns), delimiter=",", header=",".join(header),
                   comments="", fmt="%.10g")
        return
    with atomic_path(path) as temporary:
        np.savetxt(temporary, np.column_stack(columns), delimiter=",", header=",".join(header),
                   comments="", fmt="%.10g")


def plot_bode(result, path: str | Path, marks: dict | None = None, dpi: int = 120) -> None:
    """Magnitude [dB] and phase [deg] panels against log frequency, one line per output;
    ``marks``: output name -> ``(crossover [Hz], phase margin [deg])`` drawn on it."""
    from matplotlib.figure import Figure  # no pyplot: no backend, no screen needed

    figure = Figure(figsize=(10.0, 6.4), layout="constrained")
    magnitude, phase = figure.subplots(2, 1, sharex=True)
    for name in result.transfer:
        magnitude.semilogx(result.frequencies, result.magnitude_db(name), label=name)
        phase.semilogx(result.frequencies, result.phase_deg(name), label=name)
    magnitude.set_ylabel("magnitude [dB]")
    phase.set_ylabel("phase [deg]")
    phase.set_xlabel("frequency [Hz]")
    around = "periodic steady state" if result.around == "pss" else "operating point"
    magnitude.set_title(f"response to {result.input} around the {around}")
    for axis in (magnitude, phase):
        axis.grid(True, which="both", alpha=0.3)
    for name, (crossover, margin) in (marks or {}).items():
        if np.isfinite(crossover):
            for axis in (magnitude, phase):
                axis.axvline(crossover, color="grey", linestyle="--", linewidth=0.8)
            magnitude.annotate(f"{name}: crossover {format_si(crossover, 'Hz', 3)}", (crossover, 0),
                               textcoords="offset points", xytext=(4, 4), fontsize=8)
            phase.annotate(f"phase margin {margin:.3g}°", (crossover, margin - 180),
                           textcoords="offset points", xytext=(4, 4), fontsize=8)
    magnitude.legend()
    save_figure(figure, path, dpi)
