"""Behavioural sources whose value is affine in the unknowns, or a min/max of affine values,
and the integrator block.

A value is an :class:`Affine` combination of node voltages, branch currents of voltage
sources and *auxiliary* unknowns; each auxiliary is ``max(a, b)`` or ``min(a, b)`` of two
affine values, written exactly as one complementarity pair (no smoothing):

* ``x = max(a, b)``:  ``x = b + λ``,  ``0 <= λ ⊥ x - a >= 0``
  (``λ = max(0, a - b)``: where ``a > b`` the pair is active and ``x = a``);
* ``x = min(a, b)``:  ``x = b - λ``,  ``0 <= λ ⊥ a - x >= 0``.

So a limiter ``limit(u, lo, hi) = min(max(u, lo), hi)`` is two pairs (like a Zener: its
output is held at a rail while the pair of that rail is active), ``abs(u) = max(u, -u)``
and ``uramp(u) = max(u, 0)`` one pair each, and a piecewise-linear table a sum of clamped
ramps. Each auxiliary is an MNA unknown with its algebraic row
``0 = b - x ± λ``; ``λ`` has the unit of ``x`` (volts or amperes), and the step solves for
``μ = h·λ`` like every pair (Acary & Brogliato, §1.1.6.1). The relations hold at every
step, not after the fact.

Sign conventions (SPICE): a voltage output imposes ``v(n+) - v(n-) = value`` and its
current ``i(name)`` flows into ``n+`` through the source (as ``V``); a current output
drives ``value`` [A] from ``n+`` through the source to ``n-`` (as ``I``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from circuitnsds.circuit.elements.base import Element
from circuitnsds.system.mlcs import MLCSBuilder
from circuitnsds.system.stimuli import Dc


@dataclass(frozen=True)
class Affine:
    """``Σ c·v(node) + Σ c·i(source) + Σ c·x_k + constant``.

    Attributes:
        voltages: ``(node, coefficient)``: node voltages [V] (ground is ``0``).
        currents: ``(voltage source, coefficient)``: branch currents [A].
        auxiliaries: ``(k, coefficient)``: the element's auxiliary unknown ``k``.
        constant: the constant term.
        rates: ``ddt()`` terms, ``(("v", node) or ("i", source), coefficient)``: the time
            derivative of a node voltage [V/s] or branch current [A/s] times the coefficient
            (ngspice's ``ddt(v(x))``; a capacitor-like term, exact: it goes in ``E``). Only the
            element's own output may hold them, never a ``min``/``max`` or comparator's value.
    """

    voltages: tuple[tuple[str, float], ...] = ()
    currents: tuple[tuple[str, float], ...] = ()
    auxiliaries: tuple[tuple[int, float], ...] = ()
    constant: float = 0.0
    rates: tuple[tuple[tuple[str, str], float], ...] = ()

    @property
    def is_constant(self) -> bool:
        return not (self.voltages or self.currents or self.auxiliaries or self.rates)

    def rate_columns(self, builder: MLCSBuilder) -> list[tuple[int, float]]:
        """``(column of y, coefficient)`` of the ``ddt()`` terms."""
        terms = [(builder.node(name) if kind == "v" else builder.branch(f"i({name})"), c)
                 for (kind, name), c in self.rates]
        return [(column, c) for column, c in terms if column != builder.GROUND]

    def columns(self, builder: MLCSBuilder, auxiliary: list[int]) -> list[tuple[int, float]]:
        """``(column of y, coefficient)`` of the non-constant terms."""
        terms = [(builder.node(node), c) for node, c in self.voltages]
        terms += [(builder.branch(f"i({source})"), c) for source, c in self.currents]
        terms += [(auxiliary[k], c) for k, c in self.auxiliaries]
        return [(column, c) for column, c in terms if column != builder.GROUND]


@dataclass(frozen=True)
class MinMax:
    """Auxiliary unknown ``x = max(a, b)`` (``kind="max"``) or ``min(a, b)``; see module docstring."""

    kind: str
    a: Affine
    b: Affine


@dataclass(frozen=True)
class Select:
    """Auxiliary unknown ``x = on if control > 0 else off``: a comparator.

    ``control`` is affine; the choice is an ideal switch of the engine (an exogenous mode, see
    :mod:`circuitnsds.circuit.elements.switch`) whose control is the non-constant part of
    ``control`` and whose threshold is ``-control.constant ± hysteresis``, so its instant is
    located like any circuit-controlled switch's and every change is in ``waves.events``
    under ``name``. The row of ``x`` is switched: ``0 = on - x`` closed, ``0 = off - x`` open
    (constants through the element's unit unknown ``x(name.one) = 1``).

    Attributes:
        control: the compared difference (``a - b`` for ``a > b``) [its unit].
        on: value while ``control > 0``.
        off: value while ``control < 0``.
        name: the switch's name (``b1.cmp0``), as it appears in events.
        hysteresis: half-width of the band in which the state is kept (0: none).
        initially_on: the state before the operating point (``control > 0`` assumed: a latch's
            initial state; the operating point then follows the control, with hysteresis).
    """

    control: Affine
    on: Affine
    off: Affine
    name: str = ""
    hysteresis: float = 0.0
    initially_on: bool = False


def stamp_affine_row(builder: MLCSBuilder, row: int, value: Affine, auxiliary: list[int],
               sign: float) -> None:
    """Add ``sign·value`` to row ``row`` of ``0 = A y + B λ + s``."""
    for column, c in value.columns(builder, auxiliary):
        builder.add("A", row, column, sign * c)
    if value.constant:
        builder.add("S", row, builder.stimulus(Dc(value.constant)), sign)


def _stamp_pair_row(builder: MLCSBuilder, pair: int, value: Affine, auxiliary: list[int],
                    sign: float) -> None:
    """Add ``sign·value`` to ``w[pair] = C y + e``."""
    for column, c in value.columns(builder, auxiliary):
        builder.add("C", pair, column, sign * c)
    builder.e[pair] += sign * value.constant


def _selected_row(builder: MLCSBuilder, x: int, value: Affine, auxiliary: list[int],
                  one: int) -> tuple[tuple[int, float], ...]:
    """Row ``0 = value - x`` over ``y``, the constant as a coefficient of the unit unknown."""
    row: dict[int, float] = {x: -1.0}
    for column, c in value.columns(builder, auxiliary) + [(one, value.constant)]:
        row[column] = row.get(column, 0.0) + c
    return tuple((column, c) for column, c in row.items() if c != 0.0 or column == x)


def _stamp_select(builder: MLCSBuilder, name: str, select: Select, x: int,
                  columns: list[int]) -> None:
    new = f"x({name}.one)" not in builder.unknowns
    one = builder.branch(f"x({name}.one)")
    if new:  # 0 = one - 1
        builder.add("A", one, one, 1.0)
        builder.add("S", one, builder.stimulus(Dc(1.0)), -1.0)
    open_row = _selected_row(builder, x, select.off, columns, one)
    closed_row = _selected_row(builder, x, select.on, columns, one)
    for column, value in open_row:
        builder.add("A", x, column, value)
    half_band = abs(select.hysteresis)
    builder.switch(dict(
        name=select.name, row=x, open_row=open_row, closed_row=closed_row,
        control=tuple(select.control.columns(builder, columns)),
        on_threshold=-select.control.constant + half_band,
        off_threshold=-select.control.constant - half_band,
        initially_on=select.initially_on,
    ))
    builder.output(f"x({select.name})", [(x, 1.0)])


def stamp_auxiliaries(builder: MLCSBuilder, name: str,
                      auxiliaries: tuple[MinMax | Select, ...]) -> list[int]:
    """Allocate and stamp the auxiliary unknowns ``x_k`` of element ``name``; their columns."""
    columns = [builder.branch(f"x({name}.{k})") for k in range(len(auxiliaries))]
    for k, (auxiliary, x) in enumerate(zip(auxiliaries, columns)):
        if isinstance(auxiliary, Select):
            _stamp_select(builder, name, auxiliary, x, columns)
            continue
        sign = 1.0 if auxiliary.kind == "max" else -1.0
        # 0 = b - x + sign·λ ;  w = sign·(x - a)
        stamp_affine_row(builder, x, auxiliary.b, columns, 1.0)
        builder.add("A", x, x, -1.0)
        pair = builder.pair(f"{name}.{auxiliary.kind}{k}", name, 0.0)
        builder.add("B", x, pair, sign)
        builder.add("C", pair, x, sign)
        _stamp_pair_row(builder, pair, auxiliary.a, columns, -sign)
    return columns


@dataclass(frozen=True)
class BehaviouralSource(Element):
    """A voltage (``output="v"``) or current (``output="i"``) source of value ``value``.

    ``nodes`` are ``(n+, n-, control nodes...)``; the control nodes are listed so that the
    circuit knows them (they carry no current through this element).
    ``expression`` is the text as read, for messages; ``model`` the ``.model`` of an XSPICE
    block, if it is one.
    """

    output: str = "v"
    value: Affine = Affine()
    auxiliaries: tuple[MinMax | Select, ...] = ()
    expression: str = ""
    model: str | None = None
    owns_branch_current: ClassVar[bool] = False  # F, H and W sense V, L, E, H and switches only

    @property
    def topology(self) -> str:  # type: ignore[override]
        return "voltage" if self.output == "v" else "current"

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus = (builder.node(n) for n in self.nodes[:2])
        auxiliary = stamp_auxiliaries(builder, self.name, self.auxiliaries)
        if self.output == "v":
            k = builder.branch(f"i({self.name})")
            builder.add("A", plus, k, -1.0)
            builder.add("A", minus, k, 1.0)
            builder.add("A", k, plus, 1.0)
            builder.add("A", k, minus, -1.0)
            stamp_affine_row(builder, k, self.value, auxiliary, -1.0)
            for column, c in self.value.rate_columns(builder):  # c·x' = v(n+) - v(n-) - value
                builder.add("E", k, column, c)
            builder.output(f"i({self.name})", [(k, 1.0)])
            return
        # the current as an unknown of its own, so that i(name) includes the constant term
        k = builder.branch(f"i({self.name})")
        stamp_affine_row(builder, k, self.value, auxiliary, 1.0)
        for column, c in self.value.rate_columns(builder):  # -c·x' = value - i
            builder.add("E", k, column, -c)
        builder.add("A", k, k, -1.0)
        builder.add("A", plus, k, -1.0)
        builder.add("A", minus, k, 1.0)
        builder.output(f"i({self.name})", [(k, 1.0)])


ROW_SCALE = 1e-6
"""The integrator's state row is multiplied by this [F]: ``c·out' = c·input``, a 1 µF
capacitor's row, so that its entries have the size of a circuit's node rows (amperes);
the row ``out' = input`` as it stands weighs like a 1 F capacitor and, on a 1 ns step
(``1/h = 1e9``), the solver's normwise test accepted a limit violated by 1 µV."""


@dataclass(frozen=True)
class Integrator(Element):
    """XSPICE ``int``: ``d/dt (v(n+) - v(n-)) = input`` [V/s], an ideal voltage output.

    ``nodes`` are ``(n+, n-, input nodes...)``; ``input`` is affine (the model's
    ``gain·(in + in_offset)``). The output's branch row carries the derivative (an MNA
    state row), so the θ-method integrates it like a capacitor's charge.
    ``initial_output`` [V] is the model's ``out_ic``, used with UIC. ``lower``/``upper`` [V]
    (``out_lower_limit``/``out_upper_limit``) bound the state itself, as ngspice's ``int``
    does (it overwrites its stored integral with the limit): the output is projected onto
    ``[lower, upper]`` in every step, by two complementarity pairs.
    """

    input: Affine = Affine()
    initial_output: float = 0.0
    lower: float | None = None
    upper: float | None = None
    model: str | None = None
    topology: ClassVar[str] = "voltage"
    owns_branch_current: ClassVar[bool] = False  # F, H and W sense V, L, E, H and switches only

    @property
    def initial_charge(self) -> float:
        """What the state row carries at ``t = 0`` under UIC: ``ROW_SCALE·out_ic``."""
        return ROW_SCALE * self.initial_output

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus = (builder.node(n) for n in self.nodes[:2])
        k = builder.branch(f"i({self.name})")
        builder.add("A", plus, k, -1.0)
        builder.add("A", minus, k, 1.0)
        builder.add("E", k, plus, ROW_SCALE)
        builder.add("E", k, minus, -ROW_SCALE)
        stamp_affine_row(builder, k, self.input, [], ROW_SCALE)
        # limits: out' = input + λ_lower - λ_upper, 0 <= λ_upper ⊥ upper - out >= 0 and
        # 0 <= λ_lower ⊥ out - lower >= 0 (the state stops at a limit and leaves it as soon as
        # the input turns back: no wind-up)
        for limit, sign, label in ((self.upper, -1.0, "upper"), (self.lower, 1.0, "lower")):
            if limit is None:
                continue
            pair = builder.pair(f"{self.name}.{label}", self.name, -sign * limit)
            builder.add("B", k, pair, sign * ROW_SCALE)
            builder.add("C", pair, plus, sign)
            builder.add("C", pair, minus, -sign)
        builder.output(f"i({self.name})", [(k, 1.0)])
