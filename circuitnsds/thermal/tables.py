"""A device's datasheet data as plain arrays: switching energy ``E(i, v, Tj)`` [J] and on-state
voltage ``v(i, Tj)`` [V], interpolated linearly in each axis and clamped to the table's range
(each clamped axis is counted, so that the caller can warn once).

The ``method`` of a table is PLECS's ``ComputationMethod``: ``table`` (the table alone),
``formula`` (an expression of ``i``, ``v``, ``T`` alone) or ``table and formula`` (an
expression that also uses ``E``, the table's value, or ``V`` for a conduction table's drop).
Temperatures are in °C, as the datasheets give them.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field

import numpy as np

from circuitnsds.errors import CircuitnsdsError

METHODS = {"table only": "table", "formula": "formula", "table and formula": "table and formula",
           "lookup table and formula": "table and formula"}
"""PLECS's ``ComputationMethod`` texts (lower-case) and the method each names."""


class ThermalDataError(CircuitnsdsError):
    """A thermal description that cannot be read or used (file:line of the XML)."""


SLACK = 1e-3
"""A lookup beyond a table's edge by less than this fraction of its span takes the edge
without being counted as outside (a 600.4 V blocking voltage against a 600 V axis)."""


def _outside(axis: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Which ``values`` lie beyond the axis by more than its slack (:data:`SLACK`); none for
    an axis of one value (the table does not depend on that variable)."""
    if axis.size == 1:
        return np.zeros(np.shape(values), dtype=bool)
    slack = SLACK * (axis[-1] - axis[0])
    return (values < axis[0] - slack) | (values > axis[-1] + slack)


def _interpolate_axis(axis: np.ndarray, x: float) -> tuple[int, int, float, bool]:
    """``(lower, upper, weight of upper, clamped)`` of ``x`` on an increasing ``axis`` (plain
    floats: one lookup per commutation, thousands per run)."""
    size = axis.size
    if size == 1:
        return 0, 0, 0.0, False
    first, last = float(axis[0]), float(axis[-1])
    slack = SLACK * (last - first)
    clamped = x < first - slack or x > last + slack
    if x <= first:
        return 0, 0, 0.0, clamped
    if x >= last:
        return size - 1, size - 1, 0.0, clamped
    upper = bisect.bisect_right(axis, x)
    lower = upper - 1
    low = float(axis[lower])
    return lower, upper, (x - low) / (float(axis[upper]) - low), False


@dataclass
class Clamps:
    """How many lookups fell outside each axis of a table (``current``, ``voltage``,
    ``temperature``) and the value farthest outside, for one warning per table."""

    counts: dict[str, int] = field(default_factory=dict)
    farthest: dict[str, tuple[float, float]] = field(default_factory=dict)

    def note(self, axis: str, value: float, table: np.ndarray, count: int = 1) -> None:
        self.counts[axis] = self.counts.get(axis, 0) + count
        distance = float(max(table[0] - value, value - table[-1]))
        if distance > self.farthest.get(axis, (-1.0, 0.0))[0]:
            self.farthest[axis] = (distance, float(value))

    def describe(self, units: dict[str, str], axes: dict[str, np.ndarray]) -> str:
        """``current 80 A (3 times) outside 0..40 A; ...``, or ``""`` when nothing was clamped."""
        return "; ".join(f"{axis} {self.farthest[axis][1]:g} {units[axis]} ({count} time"
                         f"{'s' if count > 1 else ''}) outside {axes[axis][0]:g}..{axes[axis][-1]:g} "
                         f"{units[axis]}" for axis, count in self.counts.items())


@dataclass(kw_only=True)
class TableMethod:
    """How a table gives its value (the XML's ``method``; keyword fields of every table).

    Attributes:
        method: ``table``, ``formula`` or ``table and formula`` (see the module docstring).
        formula: the expression, for the formula methods.
        where: ``file:line`` of the element, for messages.
        clamps: the lookups that fell outside the table's axes.
    """

    method: str = "table"
    formula: str = ""
    where: str = ""
    clamps: Clamps = field(default_factory=Clamps)


@dataclass
class EnergyTable(TableMethod):
    """``<TurnOnLoss>`` or ``<TurnOffLoss>``: energy [J] per event.

    Attributes:
        current, voltage, temperature: the axes [A], [V], [°C], increasing.
        energy: ``energy[t, v, i]`` [J] (the XML's ``scale`` applied).
        method, formula, where, clamps: see :class:`TableMethod`.
    """

    current: np.ndarray
    voltage: np.ndarray
    temperature: np.ndarray
    energy: np.ndarray

    def table_value(self, current: float, voltage: float, temperature: float) -> float:
        """Trilinear interpolation of the table at ``(i, v, T)``, clamped to its range."""
        weights = []
        for axis, name, value in ((self.temperature, "temperature", temperature),
                                  (self.voltage, "voltage", voltage),
                                  (self.current, "current", current)):
            lower, upper, weight, clamped = _interpolate_axis(axis, value)
            if clamped:
                self.clamps.note(name, value, axis)
            weights.append(((lower, 1.0 - weight), (upper, weight)))
        total = 0.0
        for t, wt in weights[0]:
            for v, wv in weights[1]:
                for i, wi in weights[2]:
                    total += wt * wv * wi * self.energy[t, v, i]
        return float(total)

    def __call__(self, current: float, voltage: float, temperature: float) -> float:
        """The energy [J] of one event at current ``i`` [A], voltage ``v`` [V], ``Tj`` [°C]."""
        if self.method == "table":
            return self.table_value(current, voltage, temperature)
        names = {"i": current, "v": voltage, "t": temperature}
        if self.method == "table and formula":
            names["e"] = self.table_value(current, voltage, temperature)
        return _formula(self.formula, names, self.where)


@dataclass
class ConductionTable(TableMethod):
    """``<ConductionLoss>``: on-state voltage ``v(i, Tj)`` [V].

    Attributes:
        current, temperature: the axes [A], [°C], increasing.
        drop: ``drop[t, i]`` [V] (``scale`` applied).
        method, formula, where: as :class:`EnergyTable` (a formula uses ``V`` for the table's
            value).
    """

    current: np.ndarray
    temperature: np.ndarray
    drop: np.ndarray

    def table_values(self, current: np.ndarray, temperature: np.ndarray | float) -> np.ndarray:
        """The drop [V] at each current [A] and temperature [°C] (one, or one per current),
        bilinear in (i, T), clamped to the table's range."""
        current = np.asarray(current, dtype=float)
        temperature = np.broadcast_to(np.asarray(temperature, dtype=float), current.shape)
        for axis, values, name in ((self.current, current, "current"),
                                   (self.temperature, temperature, "temperature")):
            outside = _outside(axis, values)
            if outside.any():
                beyond = values[outside]
                far = beyond[np.argmax(np.maximum(axis[0] - beyond, beyond - axis[-1]))]
                self.clamps.note(name, float(far), axis, int(outside.sum()))
        if self.current.size == 1:
            rows = np.repeat(self.drop[:, :1], current.size, axis=1)
        else:
            rows = np.array([np.interp(current.ravel(), self.current, row) for row in self.drop])
        if self.temperature.size == 1:
            return rows[0].reshape(current.shape)
        axis = self.temperature
        clipped = np.clip(temperature.ravel(), axis[0], axis[-1])
        upper = np.clip(np.searchsorted(axis, clipped, side="right"), 1, axis.size - 1)
        weight = (clipped - axis[upper - 1]) / (axis[upper] - axis[upper - 1])
        columns = np.arange(clipped.size)
        values = (1.0 - weight) * rows[upper - 1, columns] + weight * rows[upper, columns]
        return values.reshape(current.shape)

    def __call__(self, current: np.ndarray, temperature: np.ndarray | float) -> np.ndarray:
        """The on-state voltage [V] at each current [A], at ``Tj`` [°C] (one, or one per
        current)."""
        current = np.asarray(current, dtype=float)
        if self.method == "table":
            return self.table_values(current, temperature)
        table = (self.table_values(current, temperature) if self.method == "table and formula"
                 else np.zeros(current.shape))
        temperatures = np.broadcast_to(np.asarray(temperature, dtype=float), current.shape)
        return np.array([_formula(self.formula, {"i": float(i), "t": float(t), "v": float(v)},
                                  self.where)
                         for i, t, v in zip(current.ravel(), temperatures.ravel(), table.ravel())]
                        ).reshape(current.shape)


def _formula(text: str, names: dict[str, float], where: str) -> float:
    from circuitnsds.netlist.expressions import ExpressionError, evaluate

    try:
        return float(evaluate(text, names))
    except ExpressionError as exc:
        raise ThermalDataError(f"the loss formula {text!r} cannot be evaluated: {exc}", where=where,
                               hint="formulas may use i [A], v [V], T [°C] and E (or V, the "
                               "table's value); custom variables and lookup() are not supported") from None
