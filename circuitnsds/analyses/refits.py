"""Diodes fitted to SPICE models refitted where a run's currents are: the analysis' side of
the fits' run-time observer (:class:`~circuitnsds.circuit.elements.diode_notes.FitRangeObserver`).

The observer measures each fitted diode's peak forward and breakdown current over a run
(its ``peaks``); an analysis whose peaks leave a fit's range (or use little of it) refits
the models there (:func:`refit_diodes`) and runs the circuit again, once. ``.options
pwlfit=I`` fixes every fit's range instead (:func:`refits_allowed` is then false)."""

from __future__ import annotations

import warnings
from dataclasses import replace

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements import Diode
from circuitnsds.circuit.elements.diode import refit_to
from circuitnsds.circuit.elements.diode_notes import (
    FitRangeObserver,
    Peaks,
    note_fits_served,
    warn_fit_departures,
)
from circuitnsds.errors import RunNote


def fitted_diodes(circuit: Circuit) -> list[Diode]:
    """The diodes of ``circuit`` whose models are fitted to a SPICE diode's curves."""
    return [e for e in circuit.elements if isinstance(e, Diode) and e.model.shockley is not None]


def refits_allowed(circuit: Circuit) -> bool:
    """Whether ``circuit`` has fitted diodes whose fits may follow a run's currents (no fixed
    ``.options pwlfit=I``)."""
    return (not isinstance(circuit.options.get("pwlfit"), float | int)) and bool(fitted_diodes(circuit))


def fit_observer(observers: list) -> FitRangeObserver | None:
    """The fitted diodes' observer among a run's ``observers`` (``None``: none)."""
    return next((o for o in observers if isinstance(o, FitRangeObserver)), None)


def report_fits(circuit: Circuit, peaks: Peaks, stacklevel: int = 4) -> None:
    """Warn of the fitted diodes of ``circuit`` whose ``peaks`` leave their fits and note how
    closely the fits served (:mod:`~circuitnsds.circuit.elements.diode_notes`), for an
    analysis that measured the peaks itself (pss, ac)."""
    diodes = fitted_diodes(circuit)
    warn_fit_departures(circuit, diodes, peaks, stacklevel=stacklevel)
    note_fits_served(circuit, diodes, peaks, stacklevel=stacklevel)


def refit_diodes(circuit: Circuit, peaks: Peaks) -> Circuit:
    """A copy of ``circuit`` whose fitted diode models are refitted where their diodes work
    (:func:`~circuitnsds.circuit.elements.diode.refit_to` of each model's largest ``peaks``
    over its instances), with a note for each; ``circuit`` itself when none needs it."""
    largest: dict[str, tuple[float, float]] = {}
    models = {}
    for element in fitted_diodes(circuit):
        forward, reverse = peaks.get(element.name, (0.0, 0.0))
        before = largest.get(element.model.name, (0.0, 0.0))
        largest[element.model.name] = (max(before[0], forward), max(before[1], reverse))
        models[element.model.name] = element.model
    refits = {}
    for name, (forward, reverse) in largest.items():
        refit = refit_to(models[name], forward, reverse)
        if refit is None:
            continue
        refits[name] = refit
        warnings.warn(RunNote(f"{circuit.file}: .model {name}: refitted where its diodes work "
                              f"(peaks {forward:.3g} A forward, {reverse:.3g} A breakdown per "
                              f"unit area in a first run): {refit.origin}"), stacklevel=3)
    if not refits:
        return circuit
    elements = [replace(e, model=refits[e.model.name]) if isinstance(e, Diode) and e.model.name in refits
                else e for e in circuit.elements]
    return replace(circuit, elements=elements, models={**circuit.models, **refits})
