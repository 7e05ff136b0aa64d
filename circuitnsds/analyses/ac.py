"""Small-signal AC: transfer functions from a source's value to output signals, at the
operating point (a circuit whose sources are constant: SPICE's ``.ac`` with ideal
devices) or around the periodic steady state (a switching circuit: line-to-output,
output impedance). The mathematics is in :mod:`circuitnsds.engine.small_signal`."""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from circuitnsds.analyses.mosfet_refits import at_supply
from circuitnsds.analyses.operating_point import operating_point
from circuitnsds.analyses.pss import run_pss
from circuitnsds.analyses.refits import fitted_diodes, refit_diodes, refits_allowed, report_fits
from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements.diode_notes import diode_peaks
from circuitnsds.errors import CircuitError, CircuitWarning, SimulationError
from circuitnsds.specs import AcSpec
from circuitnsds.system.stimuli import Dc, Pwl


@dataclass
class ACResult:
    """Transfer functions per output.

    Attributes:
        frequencies: [Hz].
        input: the perturbed source (its name).
        transfer: output name -> complex transfer function (units of the output per unit
            of the source's value: V/V, or Ω for a voltage per current source).
        around: ``"op"`` (operating point, linear) or ``"pss"`` (periodic steady state).
        pss: the periodic steady state used (``around == "pss"``).
    """

    frequencies: np.ndarray
    input: str
    transfer: dict[str, np.ndarray]
    around: str
    pss: object | None = None

    def magnitude_db(self, output: str) -> np.ndarray:
        """``20 log10 |H|`` [dB]."""
        return 20 * np.log10(np.abs(self.transfer[output]))

    def phase_deg(self, output: str) -> np.ndarray:
        """Phase of ``H`` [deg], unwrapped along frequency."""
        return np.degrees(np.unwrap(np.angle(self.transfer[output])))

    def loop_gain(self, returned: str, injected: str) -> np.ndarray:
        """Loop gain by voltage injection (Middlebrook): with the input a source ``Vinj b a``
        in series with the loop (``v(b) = v(a) + vinj``, the loop running from ``b`` round to
        ``a``), ``T = −v(a)/v(b)`` (``returned = "v(a)"``, ``injected = "v(b)"``, both among the
        outputs). Exact when the source drives a high impedance from a low one."""
        return -self.transfer[returned.lower()] / self.transfer[injected.lower()]

    def to_dataframe(self):
        """A pandas frame: ``frequency`` [Hz], then ``mag(OUT)`` [dB] and ``phase(OUT)`` [deg]."""
        import pandas as pd

        columns = {"frequency": self.frequencies}
        for name in self.transfer:
            columns[f"mag({name})"] = self.magnitude_db(name)
            columns[f"phase({name})"] = self.phase_deg(name)
        return pd.DataFrame(columns)


def _constant(function) -> bool:
    return isinstance(function, Dc) or (isinstance(function, Pwl) and len(set(function.values)) == 1)


def run_ac(circuit: Circuit, spec: AcSpec | None, input: str | None, outputs, frequencies, *,
           around: str = "auto", pss=None) -> ACResult:
    """The small-signal response of ``circuit`` at ``frequencies`` [Hz], else at those of
    ``spec`` (an ``.ac`` line); see :meth:`Circuit.ac`. No time step is involved: around the
    operating point every source is constant, around the periodic steady state the
    :meth:`Circuit.pss` result brings its own grid and source defaults."""
    if frequencies is None:
        if spec is None:
            raise CircuitError("no frequencies given and no .ac line", where=circuit.file,
                               hint="add '.ac DEC 20 10 1meg' to the netlist, or give frequencies")
        frequencies = spec.frequencies()
    frequencies = np.atleast_1d(np.asarray(frequencies, dtype=float))
    if not (frequencies > 0).all():
        raise CircuitError("AC frequencies must be positive", where=circuit.file)
    varying = [e.name.upper() for e in circuit.elements
               if getattr(e, "function", None) is not None and not _constant(e.function)]
    if around == "auto":
        around = "pss" if (varying or pss is not None) else "op"
    if around not in ("op", "pss"):
        raise ValueError(f"around must be 'auto', 'op' or 'pss', got {around!r}")
    if around == "op" and varying:
        raise CircuitError(f"source(s) {', '.join(varying)} vary in time: the circuit has no fixed "
                           "operating point", where=circuit.file,
                           hint="use around='pss' (small-signal around the periodic steady state)")
    circuit = at_supply(circuit)  # MOSFETs' output capacitances over the supply, as pss has them
    if around == "pss":
        if pss is None:  # (the pss analysis itself, not Circuit.pss: no analysis goes up a layer)
            pss = run_pss(circuit, circuit.analyses.get("pss"))
        mlcs = pss.mlcs
    else:
        circuit = _refitted_at_the_operating_point(circuit)
        mlcs = circuit.mlcs()
    inputs = _inputs(circuit, mlcs, input)
    outputs = list(mlcs.output_names) if outputs is None else (
        [outputs] if isinstance(outputs, str) else list(outputs))
    rows = {name: j for j, name in enumerate(mlcs.output_names)}
    unknown = [name for name in outputs if name.lower() not in rows]
    if unknown:
        raise CircuitError(f"unknown output signal(s) {', '.join(unknown)}", where=circuit.file,
                           hint=f"available: {', '.join(mlcs.output_names)}")
    picked = [rows[name.lower()] for name in outputs]
    Y_out, L_out = mlcs.Y_out.tocsr()[picked], mlcs.L_out.tocsr()[picked]
    if around == "op":
        from circuitnsds.engine.small_signal import operating_point_response

        state = operating_point(circuit, mlcs)
        if mlcs.smooth:  # the smooth elements' small-signal model: their Jacobians there
            from circuitnsds.engine.newton_step import linearised

            mlcs = linearised(mlcs, state.y)
        try:
            values = operating_point_response(mlcs, state.switches, state.active, inputs,
                                              frequencies, Y_out, L_out)
        except (np.linalg.LinAlgError, RuntimeError) as exc:
            raise SimulationError(f"the small-signal system is singular ({exc})", where=circuit.file,
                                  hint="a node is left floating at the operating point (every diode "
                                  "at it blocks, no resistor to ground)") from None
    else:
        from circuitnsds.engine.small_signal import periodic_response

        if pss.exact is not None:  # on the exact orbit: closed forms and saltations
            from circuitnsds.engine.exact.small_signal import periodic_response as exact_response

            _warn_one_sided(circuit, mlcs, pss.exact.rows)
            values = exact_response(pss.exact, inputs, frequencies, Y_out.toarray(), L_out.toarray())
        elif pss.maps is None:
            raise CircuitError("ac around a periodic steady state found through smooth nonlinear "
                               "elements (finite-difference shooting) is not built yet: it has no "
                               "step maps", where=circuit.file,
                               hint="ac around the operating point (--around op) linearises the "
                               "smooth elements")
        else:
            from circuitnsds.engine.small_signal import one_sided_pairs

            _warn_one_sided(circuit, mlcs, pss.maps.trajectory, lambda C, D, neither: one_sided_pairs(
                pss.maps, inputs, frequencies, C, D, neither))
            values = periodic_response(pss.maps, inputs, frequencies, Y_out, L_out)
    transfer = {name.lower(): values[:, j] for j, name in enumerate(outputs)}
    return ACResult(frequencies, (input or "ac").lower(), transfer, around, pss)


OPERATING_POINT_REFITS = 3
"""Refits at most of the diodes' fits to their operating point currents (each one moves the
currents a little: they were those of the fit before)."""


def _refitted_at_the_operating_point(circuit: Circuit) -> Circuit:
    """``circuit`` with the diodes fitted to SPICE models refitted where their operating point
    currents are (:func:`~circuitnsds.analyses.refits.refit_diodes`, up to
    :data:`OPERATING_POINT_REFITS` times), warned about when those still lie outside a fit's
    range (a fixed ``.options pwlfit``)."""
    diodes = fitted_diodes(circuit)
    if not diodes:
        return circuit
    peaks = _operating_point_peaks(circuit, diodes)
    for _ in range(OPERATING_POINT_REFITS if refits_allowed(circuit) else 0):
        refitted = refit_diodes(circuit, peaks)
        if refitted is circuit:
            break
        circuit = refitted
        peaks = _operating_point_peaks(circuit, fitted_diodes(circuit))
    report_fits(circuit, peaks)
    return circuit


def _operating_point_peaks(circuit: Circuit, diodes: list) -> dict[str, tuple[float, float]]:
    """The currents of the fitted ``diodes`` at the operating point of ``circuit``, as their
    observer measures a run's (:func:`~circuitnsds.circuit.elements.diode_notes.diode_peaks`
    of the one state)."""
    mlcs = circuit.mlcs()
    state = operating_point(circuit, mlcs)
    one = SimpleNamespace(y=np.asarray(state.y)[None, :], current=np.asarray(state.current)[None, :])
    return diode_peaks(diodes, mlcs, one, {})


DEGENERATE = 1e-8
"""A pair whose gap ``|w|`` and current ``λ`` are both below this fraction of their largest
values over the period has neither (:func:`_warn_one_sided`)."""

ONE_SIDED_SHARE = 0.01
"""Share of the period's steps above which a one-sided pair is warned about (a diode at the
threshold for a step or two, where a sine crosses zero on the grid, changes little)."""


def _warn_one_sided(circuit: Circuit, mlcs, trajectory, moved=None) -> None:
    """Warn about each complementarity pair that, over more than :data:`ONE_SIDED_SHARE` of
    the period's rows (``trajectory``: the settled period), carries neither current nor
    voltage in the periodic steady state (a diode blocking at exactly 0 V, its node held there
    by the rest of the circuit) while the small-signal response would move it: there a
    perturbation of one sign turns it on and of the other does not, so the response is not
    linear and the transfer function (the modes kept) is not what a small sine gives.

    ``moved(C, D, neither)``: per pair, the rows where the response moves it
    (:func:`~circuitnsds.engine.small_signal.one_sided_pairs` on the θ step maps); without it
    (around the exact orbit, which has no step maps) every such row counts, and the warning
    says the response may move them."""
    if not mlcs.pairs:
        return
    current = np.asarray(trajectory.current[1:], dtype=float)
    C, D = mlcs.C.tocsr(), mlcs.D.tocsr()
    gap = (C @ np.asarray(trajectory.y[1:], dtype=float).T + D @ current.T).T + mlcs.e
    gap_scale = max(float(np.abs(gap).max(initial=0.0)), 1e-300)
    current_scale = max(float(np.abs(current).max(initial=0.0)), 1e-300)
    neither = ((np.abs(gap) <= DEGENERATE * gap_scale)
               & (np.abs(current) <= DEGENERATE * current_scale))
    if neither.sum(axis=0).max(initial=0) <= ONE_SIDED_SHARE * neither.shape[0]:
        return
    counts = neither.sum(axis=0) if moved is None else moved(C, D, neither)
    found = [f"{mlcs.pairs[j]} ({counts[j]} of {neither.shape[0]} steps)"
             for j in np.flatnonzero(counts > ONE_SIDED_SHARE * neither.shape[0])]
    if found:
        import warnings

        effect = ("and the perturbation moves them" if moved is not None else
                  "and wherever the perturbation moves them")
        warnings.warn(CircuitWarning(
            f"{circuit.file}: small-signal AC around the periodic steady state: "
            f"{', '.join(found)} carry neither current nor voltage there, at the threshold of "
            f"conducting, {effect}: one sign turns them on, the other does "
            "not, so the response is not linear and the transfer function shown (each kept in "
            "its state) is not what a small sine gives; give the node a defined bias (a "
            "resistor to a source) or check with a sine-injection transient"), stacklevel=4)


def _inputs(circuit: Circuit, mlcs, input: str | None) -> np.ndarray:
    """The phasor of every source column: a unit at ``input``, or every source's ``AC``."""
    phasors = np.zeros(len(mlcs.stimuli), dtype=complex)
    sources = [name.upper() for name in mlcs.stimulus_owners if name]
    if input is not None:
        try:
            phasors[mlcs.stimulus_column(input)] = 1.0
        except KeyError:
            raise CircuitError(f"no independent source called {input}", where=circuit.file,
                               hint=f"the input is a V or I source of the netlist: {', '.join(sources)}; "
                               "for an output impedance add a zero current source at the output "
                               "(Iinj 0 out 0)") from None
        return phasors
    for element in circuit.elements:
        ac = getattr(element, "ac", None)
        if ac is not None:
            magnitude, phase = ac
            phasors[mlcs.stimulus_column(element.name)] = magnitude * np.exp(1j * np.radians(phase))
    if not phasors.any():
        raise CircuitError("no source has an AC magnitude and no input is given", where=circuit.file,
                           hint="write 'AC 1' on the source that drives the circuit (V1 in 0 DC 0 AC 1), "
                           f"or name the input ({', '.join(sources)})")
    return phasors


def margins(frequencies: np.ndarray, loop: np.ndarray) -> tuple[float, float]:
    """``(crossover [Hz], phase margin [deg])`` of a loop gain ``loop`` sampled at increasing
    ``frequencies``: the first frequency where ``|T|`` falls through 1 (interpolated in log-log)
    and ``180° + arg T`` there (``arg T`` unwrapped from the lowest frequency, in (−360°, 0°]
    at low frequency). ``(nan, nan)`` when ``|T|`` never crosses 1 from above."""
    magnitude = np.log(np.abs(loop))
    phase = np.unwrap(np.angle(loop))
    phase -= 2 * np.pi * np.ceil(phase[0] / (2 * np.pi))  # start in (−360°, 0°]
    falls = np.flatnonzero((magnitude[:-1] >= 0) & (magnitude[1:] < 0))
    if not falls.size:
        return float("nan"), float("nan")
    k = int(falls[0])
    fraction = magnitude[k] / (magnitude[k] - magnitude[k + 1])
    log_f = np.log(frequencies[k]) + fraction * (np.log(frequencies[k + 1]) - np.log(frequencies[k]))
    at = phase[k] + fraction * (phase[k + 1] - phase[k])
    return float(np.exp(log_f)), float(180.0 + np.degrees(at))
