"""The diode's run-time notes on its fits to SPICE models (:class:`FitRangeObserver`, declared
by :class:`~circuitnsds.circuit.elements.diode.Diode`): the peak forward and breakdown
current each fitted diode carries over a run (:attr:`FitRangeObserver.peaks`, which an
analysis reads to refit the models where the circuit works and run again), a warning for a
peak outside the range a fit's branches cover where they depart from the model's curve
(:func:`warn_fit_departures`), and one note of how closely the fits followed their models
(:func:`note_fits_served`)."""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

import numpy as np

from circuitnsds.circuit.elements.diode_fit import PiecewiseFit, coarse_breakdown
from circuitnsds.errors import CircuitWarning, RunNote
from circuitnsds.system.mlcs import MLCS
from circuitnsds.system.output_rows import output_values, signal_terms

if TYPE_CHECKING:
    from circuitnsds.circuit.circuit import Circuit
    from circuitnsds.circuit.elements.diode import Diode, DiodeModel

STACKLEVEL = 6
"""Frames from a note's ``warnings.warn`` to the user's call of the analysis."""

Peaks = dict[str, tuple[float, float]]
"""Diode name -> its largest forward and breakdown current [A per unit area] over a run."""


class FitRangeObserver:
    """Keeps the peak forward and breakdown current per unit area of every diode fitted to a
    SPICE model over a run (:attr:`peaks`, :func:`diode_peaks`); warns of the diodes whose
    peaks leave their fits' ranges and notes how closely the fits served (:meth:`report`)."""

    def __init__(self, circuit: Circuit, diodes: list[Diode]):
        self.circuit, self.diodes = circuit, diodes
        self.peaks: Peaks = {}

    @classmethod
    def of(cls, circuit: Circuit, diodes: list[Diode]) -> FitRangeObserver | None:
        """The observer of ``diodes`` (``None`` when none is fitted to a SPICE model)."""
        fitted = [d for d in diodes if d.model.shockley is not None]
        return cls(circuit, fitted) if fitted else None

    def observe(self, mlcs: MLCS, trajectory, first: int) -> None:
        diode_peaks(self.diodes, mlcs, trajectory, self.peaks)

    def report(self) -> None:
        warn_fit_departures(self.circuit, self.diodes, self.peaks)
        note_fits_served(self.circuit, self.diodes, self.peaks)


def breakdown_share(element: Diode, reverse: float) -> float:
    """The part [A per unit area] of a reverse current ``reverse`` (per unit area) that the
    breakdown branches of ``element`` can carry: at most ``reverse − V(reverse)/Roff``, the
    rest being the off-conductance's leakage (0 for a diode without breakdown)."""
    fit = element.model.breakdown_fit
    if fit is None or reverse <= 0:
        return 0.0
    return max(0.0, reverse - float(fit.voltage(reverse)) / element.model.off_resistance)


def _add_peak(peaks: Peaks, element: Diode, current: np.ndarray) -> None:
    """Fold the current ``current`` [A per unit area] of ``element`` into ``peaks``."""
    forward, reverse = peaks.get(element.name, (0.0, 0.0))
    peaks[element.name] = (max(forward, float(current.max(initial=0.0))),
                           max(reverse, breakdown_share(element, float(-current.min(initial=0.0)))))


def diode_peaks(diodes: list[Diode], mlcs: MLCS, trajectory, peaks: Peaks) -> Peaks:
    """Diode name -> the largest forward and breakdown current (:func:`breakdown_share` of the
    largest reverse one) [A per unit area] through each of ``diodes`` fitted to a SPICE model
    over every row of ``trajectory`` (each diode's current ``i(name)`` computed once, as its
    waveform is), taken together with ``peaks`` (of earlier parts of the same run), which is
    updated and returned."""
    rows = {name: j for j, name in enumerate(mlcs.output_names)}
    for element in diodes:
        row = rows.get(f"i({element.name})")
        if element.model.shockley is None or row is None:
            continue
        _add_peak(peaks, element, output_values(signal_terms(mlcs, row), trajectory.y,
                                                trajectory.current) / element.area)
    return peaks


def waveform_diode_peaks(diodes: list[Diode], waves, peaks: Peaks | None = None) -> Peaks:
    """:func:`diode_peaks` read from the waveforms ``waves`` (``waves["i(name)"]``; the diodes whose currents
    ``waves`` does not hold are left out)."""
    peaks = {} if peaks is None else peaks
    for element in diodes:
        if element.model.shockley is None:
            continue
        try:
            current = np.asarray(waves[f"i({element.name})"]) / element.area
        except KeyError:  # a run that kept only some signals
            continue
        _add_peak(peaks, element, current)
    return peaks


def fit_departures(model: DiodeModel, forward_peak: float,
                   reverse_peak: float) -> list[tuple[str, float, PiecewiseFit, float]]:
    """``(branch, peak, fit, error)`` for each fitted curve of ``model`` whose peak current
    ``peak`` [A per unit area] lies outside the range it was fitted over, where the fit
    departs from the model's curve by ``error`` [V], more than the fit's stated error
    (``branch``: ``forward`` or ``breakdown``); a breakdown still one branch where it
    conducts counts with its fit's error."""
    if model.shockley is None:
        return []
    found = []
    curves = [("forward", forward_peak, model.forward_fit, model.shockley.forward_voltage)]
    if model.breakdown_fit is not None:
        curves.append(("breakdown", reverse_peak, model.breakdown_fit, model.shockley.breakdown_drop))
    for branch, peak, fit, curve in curves:
        if fit is None or peak <= 1e-12:
            continue
        if branch == "breakdown" and peak > 1e-9 and coarse_breakdown(model.breakdown_fit):
            found.append((branch, peak, fit, fit.max_error))  # one branch where it conducts
            continue
        if fit.low <= peak <= fit.high:
            continue
        error = abs(float(fit.voltage(peak)) - float(curve(peak)))
        if error > max(2 * fit.max_error, 1e-3):
            found.append((branch, peak, fit, error))
    return found


def warn_fit_departures(circuit: Circuit, diodes: list[Diode], peaks: Peaks,
                        stacklevel: int = STACKLEVEL) -> None:
    """A :class:`CircuitWarning` for each of ``diodes`` fitted to a SPICE model whose peak
    forward or breakdown current (``peaks``) lies outside the range its branches were fitted
    over, where they depart from the model's curve by more than the fit's stated error
    (:func:`fit_departures`): the answer there is the fit's, not the model's."""
    fixed = isinstance(circuit.options.get("pwlfit"), float | int)
    for element in diodes:
        if element.name not in peaks:
            continue
        for branch, peak, fit, error in fit_departures(element.model, *peaks[element.name]):
            miss = f"{error:.3g} V" if error >= 1 else f"{error * 1e3:.3g} mV"
            fix = ("set .options pwlfit to that current, or leave pwlfit out to fit where the "
                   "circuit works" if fixed
                   else "a run whose rows are streamed (run --signals) is not repeated with "
                   "a refit: leave --signals out, or set .options pwlfit="
                   f"{peak * element.area:.3g} (every SPICE diode model's range then ends there)")
            if fit.low <= peak <= fit.high:  # a breakdown still one branch
                where = (f"where its {branch} is still one branch, within {miss} of the model's "
                         "curve over its range")
            else:
                where = (f"outside the {fit.low:.3g}..{fit.high:.3g} A per unit area its {branch} "
                         f"curve was fitted over (within {fit.max_error * 1e3:.3g} mV there); at "
                         f"that current the fit misses the model by {miss}")
            warnings.warn(CircuitWarning(
                f"{circuit.file}: diode {element.name} (.model {element.model.name}) carries up "
                f"to {peak * element.area:.3g} A {branch}, {where}: {fix}"), stacklevel=stacklevel)


def note_fits_served(circuit: Circuit, diodes: list[Diode], peaks: Peaks,
                     stacklevel: int = STACKLEVEL) -> None:
    """One :class:`RunNote` saying how closely ``diodes`` fitted to SPICE models followed
    them: the largest error of their branches over the ranges they were fitted to, the
    ranges and the largest peak currents per unit area (``peaks``) the diodes carried (a
    peak outside its range is warned about: :func:`warn_fit_departures`)."""
    diodes = [e for e in diodes if e.model.shockley is not None]
    if not diodes:
        return
    parts = []
    for branch, index, fit_of in (("forward", 0, lambda m: m.forward_fit),
                                  ("breakdown", 1, lambda m: m.breakdown_fit)):
        fits = [(fit_of(e.model), peaks.get(e.name, (0.0, 0.0))[index]) for e in diodes
                if fit_of(e.model) is not None]
        if fits:
            error = max(fit.max_error for fit, _ in fits)
            low, high = min(fit.low for fit, _ in fits), max(fit.high for fit, _ in fits)
            peak = max(peak for _, peak in fits)
            parts.append(f"{branch} within {1e3 * error:.2g} mV over {low:.3g}..{high:.3g} A "
                         f"(peak {peak:.3g} A)")
    models = len({e.model.name for e in diodes})
    warnings.warn(RunNote(f"{circuit.file}: {len(diodes)} diode(s) of {models} SPICE model(s) "
                          f"fitted by parallel branches: {'; '.join(parts)}, per unit area"),
                  stacklevel=stacklevel)
