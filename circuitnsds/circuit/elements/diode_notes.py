"""The diode's run-time note: a Shockley-fitted model whose diodes carry currents outside the
range its lines were fitted over (:class:`FitRangeObserver`, declared by
:class:`~circuitnsds.circuit.elements.diode.Diode`)."""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

from circuitnsds.errors import RunNote
from circuitnsds.system.mlcs import MLCS
from circuitnsds.system.output_rows import output_values, signal_terms

if TYPE_CHECKING:
    from circuitnsds.circuit.circuit import Circuit
    from circuitnsds.circuit.elements.diode import Diode

STACKLEVEL = 6
"""Frames from a note's ``warnings.warn`` to the user's call of the analysis."""


class FitRangeObserver:
    """Keeps the peak forward and reverse current per unit area of every Shockley-fitted
    diode model over a run; notes the models whose fit range misses them
    (:func:`note_fits_outside_their_range`)."""

    def __init__(self, circuit: Circuit, diodes: list[Diode]):
        self.circuit, self.diodes = circuit, diodes
        self.peaks: dict[str, tuple[float, float]] = {}

    @classmethod
    def of(cls, circuit: Circuit, diodes: list[Diode]) -> FitRangeObserver | None:
        """The observer of ``diodes`` (``None`` when none has a fitted Shockley model)."""
        fitted = [d for d in diodes if d.model.shockley is not None]
        return cls(circuit, fitted) if fitted else None

    def observe(self, mlcs: MLCS, trajectory, first: int) -> None:
        diode_peaks(self.diodes, mlcs, trajectory, self.peaks)

    def report(self) -> None:
        note_fits_outside_their_range(self.circuit, self.diodes, self.peaks)


def diode_peaks(diodes: list[Diode], mlcs: MLCS, trajectory,
                peaks: dict[str, tuple[float, float]]) -> dict[str, tuple[float, float]]:
    """Model name -> the largest forward and reverse current [A] per unit area through the
    instances among ``diodes`` of each Shockley-fitted diode model over every row of
    ``trajectory`` (each diode's current ``i(name)`` computed once, as its waveform is), taken
    together with ``peaks`` (of earlier parts of the same run), which is updated and returned."""
    rows = {name: j for j, name in enumerate(mlcs.output_names)}
    for element in diodes:
        row = rows.get(f"i({element.name})")
        if element.model.shockley is None or row is None:
            continue
        current = output_values(signal_terms(mlcs, row), trajectory.y, trajectory.current) / element.area
        forward, reverse = peaks.get(element.model.name, (0.0, 0.0))
        peaks[element.model.name] = (max(forward, float(current.max(initial=0.0))),
                                     max(reverse, float(-current.min(initial=0.0))))
    return peaks


FIT_DROP_TOLERANCE = 0.02
"""Forward-drop error [V] of a fitted line (against its Shockley curve) at a diode's peak
current beyond which the run notes that the fit range misses the circuit's currents."""


def note_fits_outside_their_range(circuit: Circuit, diodes: list[Diode],
                                  peaks: dict[str, tuple[float, float]]) -> None:
    """A :class:`RunNote` for each Shockley-fitted diode model whose instances' peak forward or
    reverse (breakdown) current (``peaks``: :func:`diode_peaks`) lies outside the range its
    forward or breakdown line was fitted over, where the line misses the curve by more than
    :data:`FIT_DROP_TOLERANCE` (the answer is then the line's, not the model's)."""
    models = {e.model.name: e.model for e in diodes if e.model.fit_range is not None}
    for name, (forward, reverse) in peaks.items():
        model = models.get(name)
        if model is None:
            continue
        branches = [("", forward, model.fit_range, model.forward_drop, model.on_resistance,
                     model.shockley.forward_voltage)]
        if model.breakdown_fit_range is not None and model.breakdown_voltage is not None:
            branches.append((" breakdown", reverse, model.breakdown_fit_range,
                             model.breakdown_voltage, model.breakdown_resistance,
                             model.shockley.breakdown_drop))
        for branch, peak, (low, high), drop, slope, curve in branches:
            if peak <= 1e-12:
                continue
            error = abs(drop + slope * peak - float(curve(peak)))
            if (peak < low or peak > high) and error > FIT_DROP_TOLERANCE:
                what = f".model {name}'s breakdown line was" if branch else f".model {name} was"
                way = " in breakdown" if branch else ""
                miss = f"{error:.3g} V" if error >= 1 else f"{error * 1e3:.3g} mV"
                fix = (f"set .options pwlfit={peak:.3g} (pwlfit=auto refits once, to the peaks of "
                       "a first run, and they moved)" if circuit.options.get("pwlfit") == "auto"
                       else f"set .options pwlfit={peak:.3g} (or pwlfit=auto)")
                warnings.warn(RunNote(
                    f"{circuit.file}: {what} fitted over {low:.3g}..{high:.3g} A but its diodes "
                    f"carry up to {peak:.3g} A{way}, where the fitted line misses the model's "
                    f"curve by {miss}: {fix} to fit it where the circuit works"), stacklevel=STACKLEVEL)
