"""Is the complementarity problem of a time step well posed?

For a step of length ``h`` (and given switch states) the integrator solves the MLCP

    K y - B λ + a = 0,      w = C y + D λ + b,      0 <= w ⊥ λ >= 0

with ``K = E/h - ΘA`` (rows divided by ``h``, so ``λ`` are currents [A] and ``w``
voltages [V]). Eliminating ``y`` gives ``LCP(M, q)`` with the *port resistance matrix*

    M = C K⁻¹ B + D          [Ω]

(what the devices' terminals see over one step: resistors, capacitors as ``h/C``,
inductors as ``L/h``, the ``Ron`` of each device on its diagonal). The classical results:

* ``M`` is a **P-matrix** (every principal minor > 0) ⇔ the LCP has exactly one
  solution for *every* right-hand side: every step has a unique solution.
* ``M`` is **positive semidefinite** (``xᵀMx >= 0``: the network is passive) ⇒ a
  solution exists whenever the step is feasible, and Lemke's method finds it; it may
  not be unique (e.g. two ideal diodes in a loop without resistance: a current can
  circulate) and may not exist (an ideal diode forward-biased across a voltage source).
* neither: some steps may have no solution or several (a negative resistance, a
  controlled source with the wrong sign, driving a device).

**Computing M accurately.** Where a node reaches the rest only through blocked
devices, ``K`` is nearly singular (its only path is ``Roff``, 1e12 Ω by default) and
``K⁻¹`` loses most digits (docs/solvers.md). As the solver does, the analysis then
exchanges the roles of ``λ_i`` and ``w_i`` for a set ``α0`` of pairs that ties those
nodes (a *principal pivot transform*, computed from the well-conditioned bordered
matrix ``[[K, -B_α0], [C_α0, D_α0α0]]``). A principal pivot transform keeps P-matrices
P and positive semidefinite matrices positive semidefinite, and its principal minor at
``β`` is the minor of ``M`` at ``α0 Δ β`` divided by ``det M_α0α0``, so the tests below
are exact statements about ``M``. **Limitation:** if no set of pairs makes the
bordered matrix well-conditioned (``K`` singular for reasons no device can fix, e.g. a
loop of voltage sources and closed ``RON = 0`` switches), ``M`` does not exist and the
report names the unknowns of the singular direction instead.

**Smooth relations** (BJTs, JFETs, smooth MOSFETs and diodes, nonlinear B/E/G sources)
enter ``K`` linearised at zero bias (every unknown 0 V or 0 A, ``t = 0``): ``A − J_F``
and ``E + J_Q``, as the Newton stepper's first iteration from rest sees them. The check
asks a structural question (is there a step matrix at all, and what do the pairs see), and
the structure is there at any bias: a device's series resistances (``RB``, ``RC``, ``RD``
...) join its internal nodes to its terminals inside the relation, and ngspice's GMIN
spans each junction. Left out, those internal nodes held by nothing but the relation made
``K`` singular for a false reason. Zero bias rather than the operating point: the checks
sit below the analyses, and an operating point of a nonlinear circuit is itself a Newton
solve that may fail; the pairs' verdict is then the one with each smooth device at its
zero-bias conductance (a transistor off), which the report says.

**Tests.** After symmetric diagonal scaling (``M_ii`` → 1, which changes neither
property): the P test enumerates every principal minor for up to
:data:`EXACT_LIMIT` pairs (exact); beyond, it is a sufficient test (positive definite
symmetric part) plus a necessary one (all 1×1 and 2×2 minors), and may answer
"unknown". A scaled minor ``<=`` :data:`MINOR_TOL` counts as zero. The PSD test is the
smallest eigenvalue of the symmetric part ``>= -`` :data:`EIG_TOL`.

**Ideal limit.** ``Roff`` makes many ill-posed ideal circuits solvable with absurd
answers. :func:`analyse_circuit` also lists node groups whose only connections, over a
step, are devices that can block (diodes, open switches) and current sources: there a
current source forces its current through the devices, and in the ideal model the step
has no solution when that current flows against them (with ``Roff`` it flows anyway,
at a voltage of about ``I·Roff``): the ideal diode in series with a current source.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from circuitnsds.engine.step_system import step_system
from circuitnsds.errors import CircuitError
from circuitnsds.solvers.linalg import RCOND_MIN, factorise
from circuitnsds.solvers.pivot_transform import PivotTransform, completion_mask
from circuitnsds.specs import SourceDefaults
from circuitnsds.system.mlcs import MLCS
from circuitnsds.theta import THETA_HINT, theta_in_range, theta_text

EXACT_LIMIT = 12
"""Up to this many pairs the P-matrix test checks all ``2**m - 1`` principal minors."""
MINOR_TOL = 1e-10
"""A principal minor of the scaled LCP matrix at or below this counts as zero (not P)."""
EIG_TOL = 1e-9
"""The scaled symmetric part is positive semidefinite when its eigenvalues are ``>= -EIG_TOL``."""
K_RCOND_GOOD = 1e-8
"""``K`` with a smaller reciprocal condition number is pivoted before ``M`` is formed."""
COMPONENT = 0.3
"""A pair (or unknown) is named in a direction when its component is at least this
fraction of the largest."""
MAX_STATES = 4
"""With up to this many switches, :func:`analyse_circuit` examines every combination of states."""


@dataclass
class WellPosedness:
    """The verdict on one step's LCP (see the module docstring).

    Attributes:
        step: ``h`` [s]; theta: θ of the step.
        switch_states: switch name -> closed.
        pairs, pair_devices: the complementarity pairs and their devices.
        M: the (scaled, pivoted) LCP matrix the tests ran on, or ``None``.
        pivot: the pairs ``α0`` exchanged to form it (empty: ``M`` itself, scaled).
        p_matrix: every principal minor positive (``None``: the test could not decide).
        psd: the symmetric part is positive semidefinite.
        exact: whether ``p_matrix`` comes from the exhaustive test.
        failing_pairs: pairs of a principal minor of ``M`` that is not positive (the
            smallest such set found), or of a singular ``K`` direction.
        failing_minor: 0 when that minor is zero (the bordered matrix is singular), -1 when
            it is negative, ``None`` when no minor failed.
        negative_pairs: pairs that carry the direction of negative ``xᵀMx``.
        singular_unknowns: unknowns of a direction in which ``K`` is singular whatever
            the devices do (``M`` does not exist).
        forced: notes on current sources forcing current through devices that can
            block (the ideal-limit check of :func:`analyse_circuit`).
        linearised: the smooth relations that entered ``K`` linearised at zero bias.
    """

    step: float
    theta: float
    switch_states: dict[str, bool]
    pairs: list[str]
    pair_devices: list[str]
    M: np.ndarray | None = None
    pivot: tuple[str, ...] = ()
    p_matrix: bool | None = None
    psd: bool | None = None
    exact: bool = True
    failing_pairs: tuple[str, ...] = ()
    failing_minor: float | None = None
    negative_pairs: tuple[str, ...] = ()
    singular_unknowns: tuple[str, ...] = ()
    forced: list[str] = field(default_factory=list)
    linearised: tuple[str, ...] = ()

    @property
    def verdict(self) -> str:
        """``"P"``, ``"PSD"`` (positive semidefinite, not P), ``"neither"``, ``"unknown"``
        (large problem, not decided), ``"singular"`` (``K`` singular whatever the devices
        do) or ``"none"`` (no complementarity pairs)."""
        if self.singular_unknowns:
            return "singular"
        if not self.pairs:
            return "none"
        if self.p_matrix:
            return "P"
        if self.psd:
            return "PSD"
        if self.p_matrix is None and self.psd is None:
            return "unknown"
        return "neither" if self.p_matrix is False or self.psd is False else "unknown"

    @property
    def devices(self) -> tuple[str, ...]:
        """The devices named by the failing minor and the negative direction."""
        wanted = set(self.failing_pairs) | set(self.negative_pairs)
        return tuple(dict.fromkeys(d for p, d in zip(self.pairs, self.pair_devices) if p in wanted))

    @property
    def ok(self) -> bool:
        """Every step has exactly one solution (and no current is forced against a device)."""
        return self.verdict in {"P", "none"} and not self.forced

    def summary(self) -> str:
        """One paragraph: the verdict, the devices responsible and what to do."""
        size = f"{len(self.pairs)} pair{'s' if len(self.pairs) != 1 else ''}"
        verdict = self.verdict
        if verdict == "singular":
            text = (f"the step matrix is singular whatever the devices do (unknowns "
                    f"{', '.join(self.singular_unknowns)}): a loop of voltage sources and closed "
                    "switches with RON=0, or a node that nothing holds")
        elif verdict == "none":
            text = "no complementarity pairs: each step is a linear system"
        elif verdict == "P":
            text = (f"P-matrix ({size}, {'exact test' if self.exact else 'sufficient test'}): "
                    "every step has exactly one solution")
        elif verdict == "PSD":
            text = (f"positive semidefinite but not P ({size}): a solution exists when the step "
                    "is feasible, but not always a unique one; "
                    + _blame(self.failing_pairs, self.failing_minor))
        elif verdict == "neither":
            text = f"neither P nor positive semidefinite ({size}): a step may have no solution or several; "
            if self.negative_pairs:
                text += (f"{', '.join(self.negative_pairs)} "
                         f"{'sees' if len(self.negative_pairs) == 1 else 'see'} a negative resistance "
                         "(a controlled source or negative element feeding energy in)")
            if self.failing_pairs and self.failing_pairs != self.negative_pairs:
                text += ("; " if self.negative_pairs else "") + _blame(self.failing_pairs,
                                                                       self.failing_minor)
        else:
            text = (f"P-matrix test inconclusive ({size}, more than {EXACT_LIMIT}: only necessary and "
                    "sufficient tests were run); positive semidefinite"
                    + ("" if self.psd else ": no"))
        if self.forced:
            text += "; ideal limit: " + "; ".join(self.forced)
        if self.linearised:
            text += f" (smooth {', '.join(self.linearised)} linearised at zero bias)"
        return text


def _blame(pairs: tuple[str, ...], minor: float | None) -> str:
    if not pairs:
        return "no failing minor was isolated"
    names = ", ".join(pairs)
    verb = "sees" if len(pairs) == 1 else "see"
    if minor is not None and minor == 0.0:
        return (f"{names} {verb} no resistance (the principal minor of M is 0, the bordered matrix "
                "with them conducting is singular): ideal diodes in a loop without resistance, or a "
                "diode across a voltage source or closed switch; give the diode model Ron > 0 or add "
                "a series resistance")
    return (f"the principal minor of M for {names} is negative: a negative resistance (a "
            "controlled source or negative element) acts on them")


def step_matrices(mlcs: MLCS, step: float, states: tuple[bool, ...] = (), theta: float = 1.0
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Dense ``K = E/h - ΘA(states)``, ``B``, ``C``, ``D`` of one step: the integrator's step
    system (:func:`circuitnsds.engine.step_system.step_system`)."""
    K = step_system(mlcs, step, states, theta).K.toarray()
    return K, mlcs.B.toarray(), mlcs.C.toarray(), mlcs.D.toarray()


def analyse(mlcs: MLCS, step: float, states: tuple[bool, ...] | None = None,
            theta: float = 1.0) -> WellPosedness:
    """P-matrix and positive-semidefiniteness tests of one step's LCP (module docstring).

    Args:
        mlcs: the system.
        step: ``h`` [s].
        states: closed (true) or open for each of ``mlcs.switches``; default their ``ON`` flags.
        theta: θ (1 for the first step and for implicit Euler).

    Raises:
        CircuitError: the step's matrices are not finite (an absurd step or element value).
    """
    if states is None:
        states = tuple(s.initially_on for s in mlcs.switches)
    states = tuple(bool(s) for s in states)
    report = WellPosedness(step=step, theta=theta,
                           switch_states={s.name: on for s, on in zip(mlcs.switches, states)},
                           pairs=list(mlcs.pairs), pair_devices=list(mlcs.pair_devices))
    if mlcs.smooth:
        report.linearised = tuple(relation.name for relation in mlcs.smooth)
        mlcs = _at_zero_bias(mlcs)
    with np.errstate(all="ignore"):
        K, B, C, D = step_matrices(mlcs, step, states, theta)
    if not (np.isfinite(K).all() and np.isfinite(D).all()):
        raise CircuitError(f"the equations of a step of {step:g} s are not finite (capacitance/h "
                           "or inductance/h overflows)", hint="check the step and the element values")
    n, m = mlcs.n, mlcs.m
    KK = np.block([[K, -B], [C, D]]) if m else K
    empty = np.zeros(m, dtype=bool)
    candidates: list[np.ndarray] = []
    if factorise(K).rcond < K_RCOND_GOOD and m:
        completion = completion_mask(KK, n, K_RCOND_GOOD)  # the solver's start basis
        if completion is not None:
            candidates.append(completion)
    candidates.append(empty)
    chosen = None
    for mask in candidates:
        sel = np.concatenate([np.arange(n), n + np.flatnonzero(mask)])
        lu = factorise(KK[np.ix_(sel, sel)])
        if lu.ok:
            chosen = (mask, lu)
            break
    if chosen is None:
        _, s, Vt = np.linalg.svd(K)
        direction = np.abs(Vt[-1])
        report.singular_unknowns = tuple(name for name, value in zip(mlcs.unknowns, direction)
                                         if value >= COMPONENT * direction.max())
        report.p_matrix = report.psd = False
        return report
    if not m:
        report.p_matrix = report.psd = True
        return report
    mask, lu = chosen
    report.pivot = tuple(p for p, on in zip(mlcs.pairs, mask) if on)
    report.M = PivotTransform(KK, n, mask, lu).M
    reference = float(np.prod(np.sign(np.diag(lu.lu)))) * _permutation_sign(lu.piv) if lu.size else 1.0
    _test(report, mlcs, KK, report.M, mask, reference)
    return report


def _at_zero_bias(mlcs: MLCS) -> MLCS:
    """``mlcs`` with its smooth relations linearised at zero bias (module docstring).

    Raises:
        CircuitError: a relation cannot be evaluated there.
    """
    from circuitnsds.engine.newton_step import linearised

    try:
        return linearised(mlcs, np.zeros(mlcs.n), 0.0)
    except ValueError as error:
        names = ", ".join(relation.name for relation in mlcs.smooth)
        raise CircuitError(f"the smooth relations of {names} cannot be evaluated at zero bias: {error}",
                           hint="check their expressions at 0 V (a log or a division by v())") from None


def _exclusive(mlcs: MLCS) -> set[frozenset[int]]:
    """Pairs that can never be active together: a Zener's forward and reverse pairs (their
    ``w`` rows are opposite in ``y`` and sum to ``Vfwd + BV + Ron·λ_f + Rrev·λ_r > 0``)."""
    C, D = mlcs.C.tocsr(), mlcs.D.tocsr()
    result = set()
    for i, j in itertools.combinations(range(mlcs.m), 2):
        if (mlcs.pair_devices[i] == mlcs.pair_devices[j] and mlcs.e[i] + mlcs.e[j] > 0
                and (C[i] + C[j]).count_nonzero() == 0 and D[i, j] == 0 and D[j, i] == 0):
            result.add(frozenset((i, j)))
    return result


def _test(report: WellPosedness, mlcs: MLCS, KK: np.ndarray, M: np.ndarray, pivot: np.ndarray,
          reference: float) -> None:
    """Fill in the P and PSD verdicts.

    P: the minor of ``M`` at ``γ`` is ``det K_γ / det K`` (``K_γ`` the bordered matrix of
    active set ``γ``), so ``M`` is P exactly when every ``K_γ`` is nonsingular (reciprocal
    condition ``>= RCOND_MIN``, as the solver requires) and all have one determinant sign,
    that of the well-conditioned ``K_α0`` (``reference``). Sets that cannot occur
    (:func:`_exclusive`) are skipped. PSD: the symmetric part of the pivoted ``M``.
    """
    n, m = mlcs.n, mlcs.m
    pairs = np.array(report.pairs)
    symmetric = 0.5 * (M + M.T)
    values, vectors = np.linalg.eigh(symmetric)
    scale = max(float(np.abs(M).max()), np.finfo(float).tiny)
    report.psd = bool(values[0] >= -EIG_TOL * scale)
    if not report.psd:
        direction = np.abs(vectors[:, 0])
        report.negative_pairs = tuple(pairs[direction >= COMPONENT * direction.max()])
    exclusive = _exclusive(mlcs)
    sizes = range(0, m + 1) if m <= EXACT_LIMIT else range(0, 3)
    for size in sizes:
        for subset in itertools.combinations(range(m), size):
            if any(pair <= set(subset) for pair in exclusive):
                continue
            sel = np.concatenate([np.arange(n), n + np.array(subset, dtype=int)])
            block = KK[np.ix_(sel, sel)]
            lu = factorise(block)
            sign = float(np.prod(np.sign(np.diag(lu.lu)))) * _permutation_sign(lu.piv) if lu.size else 1.0
            if not lu.ok or sign != reference:
                named = tuple(pairs[list(subset)]) if subset else tuple(pairs[pivot])
                report.p_matrix = False
                report.failing_pairs = named
                report.failing_minor = 0.0 if not lu.ok else -1.0
                report.exact = m <= EXACT_LIMIT
                return
    if m <= EXACT_LIMIT:
        report.p_matrix, report.exact = True, True
    elif values[0] > EIG_TOL * scale:
        report.p_matrix, report.exact = True, False  # positive definite ⇒ P
    else:
        report.p_matrix, report.exact = None, False


def _permutation_sign(piv: np.ndarray) -> float:
    """Sign of the row permutation of LAPACK's pivot vector (0-based)."""
    return -1.0 if int(np.sum(piv != np.arange(piv.size))) % 2 else 1.0


def forced_currents(circuit, states: dict[str, bool]) -> list[str]:
    """Node groups joined to the rest, over one step, only by current sources and devices
    that can block (diodes, open switches): the current sources force their current
    through those devices (see the module docstring, "Ideal limit")."""
    from circuitnsds.graphs import connected_components

    edges = []
    for element in circuit.elements:
        if len(element.nodes) < 2:
            continue
        if element.junction == "diode" or element.topology == "current":
            continue
        if element.junction == "switch" and not states.get(element.name, element.initially_on):
            continue
        if element.topology == "capacitor" and element.capacitance == 0:
            continue
        edges.append(element.nodes[:2])
    notes = []
    for group in connected_components(["0", *circuit.nodes], edges):
        if "0" in group:
            continue
        crossing = [e for e in circuit.elements
                    if len(e.nodes) >= 2 and (e.nodes[0] in group) != (e.nodes[1] in group)]
        sources = [e.name for e in crossing if e.topology == "current"]
        blocking = [e.name for e in crossing if e.junction is not None]
        if sources and blocking:
            notes.append(f"the current of {', '.join(sources)} into node(s) {', '.join(sorted(group))} "
                         f"can pass only through {', '.join(blocking)}: when it flows against them the "
                         "ideal step has no solution (here it flows through Roff, at about I·Roff volts)")
    return notes


def blocked_currents(circuit, times: np.ndarray) -> list[tuple[str, str, bool]]:
    """Independent current sources forced against diodes, found before simulating.

    A node group joined to the rest only by independent current sources and diodes
    must pass the sources' net current through the diodes, each of which conducts one
    way only (a Zener both). When at some instant of ``times`` [s] the net current
    enters the group and no diode can let it out (or leaves and none can let it in), the
    ideal step has no solution: the current flows through the diodes' ``Roff`` instead,
    at ``I·Roff`` volts (``I1 a 0 DC 1m`` with ``D1 a 0``: -1 GV). Groups crossed by a
    switch (warned about by :mod:`circuitnsds.checks.rules`) or by a controlled source
    (its current is not known beforehand) are left out.

    Returns ``(message, where, fatal)`` per such group: ``fatal`` unless every diode
    concerned has an ``Roff`` of its own (then ``I·Roff`` is the model's answer).
    """
    from circuitnsds.checks.topology import isolated_groups
    from circuitnsds.circuit.elements.diode import DEFAULT_OFF_RESISTANCE

    found = []
    groups = isolated_groups(circuit.elements, circuit.nodes,
                             lambda e: e.junction is not None or e.topology == "current")
    for group, crossing in groups:
        diodes = [e for e in crossing if e.junction == "diode"]
        sources = [e for e in crossing if e.topology == "current"]
        if (not diodes or not sources or any(e.junction == "switch" for e in crossing)
                or not all(e.independent_source for e in sources)):
            continue
        # SPICE's current source pushes its current from its first node to its second
        with np.errstate(all="ignore"):
            into = sum((1.0 if e.nodes[1] in group else -1.0) * np.asarray(e.function.sample(times), float)
                       for e in sources)
        zener = any(d.model.kind == "zener" for d in diodes)
        can_leave = zener or any(d.nodes[0] in group for d in diodes)
        can_enter = zener or any(d.nodes[1] in group for d in diodes)
        bad = ((into > 0) & (not can_leave)) | ((into < 0) & (not can_enter))
        if not bad.any():
            continue
        k = int(np.argmax(bad))
        value = float(into[k])
        ohms = min(d.model.off_resistance / d.area for d in diodes)
        names = ", ".join(d.name for d in diodes)
        message = (f"{', '.join(e.name for e in sources)} drive{'s' if len(sources) == 1 else ''} "
                   f"{abs(value):.3g} A {'into' if value > 0 else 'out of'} node(s) "
                   f"{', '.join(sorted(group))} at t = {times[k]:.6g} s, but the only other path, "
                   f"{names}, blocks that direction: the ideal circuit has no solution (the current "
                   f"would flow through Roff = {ohms:.3g} Ω, about {abs(value) * ohms:.3g} V)")
        fatal = any(d.model.off_resistance == DEFAULT_OFF_RESISTANCE for d in diodes)
        where = next((str(e.location) for e in sources if e.location), None)
        found.append((message, where, fatal))
    return found


def switch_configurations(switches: list, states=None) -> list[tuple[bool, ...]]:
    """The switch states :func:`analyse_circuit` examines (see :meth:`Circuit.well_posedness`)."""
    if states is not None:
        return [tuple(bool(s) for s in combination) for combination in states]
    count = len(switches)
    if count <= MAX_STATES:
        return [tuple(c) for c in itertools.product((False, True), repeat=count)]
    initial = tuple(s.initially_on for s in switches)
    return list(dict.fromkeys([initial, (False,) * count, (True,) * count]))


def analyse_circuit(circuit, step: float | None = None, *, states=None,
                    theta: float = 1.0) -> list[WellPosedness]:
    """:func:`analyse` for each switch configuration, with the ideal-limit notes."""
    tran = circuit.analyses.get("tran")  # the step examined is the transient's, unless given
    if step is None:
        step = tran.step if tran else 1.0
    elif not (step > 0 and math.isfinite(step)):
        raise CircuitError(f"step = {step:g} must be positive and finite", where=circuit.file,
                           hint="the time step [s] of the LCP examined; leave it out for .tran's TSTEP")
    if not theta_in_range(theta):
        raise CircuitError(f"theta = {theta_text(theta)} is outside [0.5, 1]", where=circuit.file,
                           hint=f"theta: {THETA_HINT}")
    mlcs = circuit.mlcs(SourceDefaults(step, tran.stop if tran else max(step, 1.0)))
    reports = []
    for configuration in switch_configurations(mlcs.switches, states):
        report = analyse(mlcs, step, configuration, theta)
        report.forced = forced_currents(circuit, report.switch_states)
        reports.append(report)
    return reports


def report_lines(circuit) -> list[str]:
    """Lines for ``circuitnsds info``: the verdict for each switch configuration examined."""
    from circuitnsds.units import format_si

    tran = circuit.analyses.get("tran")
    step = tran.step if tran else 1.0
    reports = analyse_circuit(circuit, step)
    lines = [f"well-posedness of each step's LCP (h = {format_si(step, 's')}):"]
    for report in reports:
        label = ", ".join(f"{name} {'closed' if on else 'open'}"
                          for name, on in report.switch_states.items())
        lines.append(f"  {label + ': ' if label else ''}{report.summary()}")
    return lines


__all__ = ["WellPosedness", "analyse", "analyse_circuit", "blocked_currents", "forced_currents",
           "report_lines", "step_matrices", "RCOND_MIN"]
